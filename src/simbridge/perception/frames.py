"""Making one labelled frame: put the scene back as compiled, apply the randomisers (seeded
by the dataset seed and the frame index only), render every camera, label what it sees."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import PerceptionError, SimbridgeError
from simbridge.perception.annotate import ViewLabels, annotate
from simbridge.perception.camera import CameraView
from simbridge.perception.config import PerceptionConfig, parse_perception
from simbridge.perception.randomizers import (
    Baseline,
    DistractorsRandomizer,
    FrameState,
    frame_rng,
)
from simbridge.perception.render import Rendered, StageTimes, ViewRenderer
from simbridge.perception.shapes import ShapeCache
from simbridge.sim import Scene, World, load_scene
from simbridge.sim.labels import LabelTable
from simbridge.sim.urdf.document import MjcfDocument

__all__ = ["IMAGE_STEPS", "Frame", "FrameMaker", "View"]

IMAGE_STEPS = "image randomisers (background, noise)"
"""The stage of `FrameMaker.render_times` the image randomisers' CPU time goes to."""

_SEGMENTATION_LABELERS = {"semantic", "instance", "boxes_2d", "keypoints"}


@dataclass
class View:
    """One camera's images and labels in a frame."""

    camera: CameraView
    rgb: NDArray[np.uint8] | None
    depth: NDArray[np.float32] | None
    labels: ViewLabels


@dataclass
class Frame:
    """A labelled frame: one view per camera, in the order the cameras are declared."""

    index: int
    views: list[View]


class FrameMaker:
    """A scene built once for making frames; `make(i)` is a function of (seed, i) alone;
    `quality` (a QUALITIES preset) overrides the scene's shadows and multisampling."""

    def __init__(
        self, scene: Scene | str | Path, seed: int = 0, quality: str | None = None
    ) -> None:
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        self.scene = scene
        self.seed = seed
        self.config: PerceptionConfig = parse_perception(scene)
        if quality is not None:  # a preset over the scene's render settings
            self.config = replace(self.config, render=self.config.render.with_quality(quality))

        def extend(document: MjcfDocument) -> None:
            for randomizer in self.config.randomizers:
                randomizer.extend(document)

        # The physics never runs: no ROS, no sensors; the world is posed, not stepped.
        self.world = World.from_scene(replace(scene, sensors=()), [extend])
        for randomizer in self.config.randomizers:
            try:
                randomizer.bind(self.world)
            except SimbridgeError as exc:  # what the scene lacks: say where it was asked
                if randomizer.where is None:
                    raise
                raise PerceptionError(str(randomizer.where.error(str(exc)))) from exc
        self.baseline = Baseline(self.world.model)
        distractors = [
            (name, label, self.world.model.body(name).id)
            for r in self.config.randomizers
            if isinstance(r, DistractorsRandomizer)
            for name, label in r.labelled_slots()
        ]
        self.table = LabelTable.build(
            self.world.model,
            scene,
            robot_bodies={n: list(r.bodies.values()) for n, r in self.world.robots.items()},
            rules=self.config.rules,
            distractors=distractors,
            classes=self.config.classes,
        )
        self.shapes = ShapeCache(self.world.model)
        # MuJoCo bakes part of the model into a GL context when it makes one (each plane's
        # grid from its geom and its material's texture repeat): every renderer is made now,
        # from the model as compiled, so no frame depends on which one a process drew first.
        self._renderers = {
            size: ViewRenderer(self.world.model, size[0], size[1], self.config.render)
            for size in sorted({(c.width, c.height) for c in self.config.cameras})
        }
        labelers = self.config.labelers
        image_steps = [r for r in self.config.randomizers if r.image_step]
        self._image_steps_need_segmentation = any(r.needs_segmentation for r in image_steps)
        self._image_times = StageTimes()
        self._want_seg = (
            bool(labelers & _SEGMENTATION_LABELERS) or self._image_steps_need_segmentation
        )

    def _renderer(self, width: int, height: int) -> ViewRenderer:
        renderer = self._renderers.get((width, height))
        if renderer is None:
            raise PerceptionError(
                f"no renderer of {width}x{height}: views keep their camera's declared size"
            )
        return renderer

    def pose(self, index: int) -> FrameState:
        """Frame `index`'s scene: the baseline, then each scene randomiser in order."""
        self.baseline.restore()
        self.world.restore_initial()
        views = {spec.name: spec.view() for spec in self.config.cameras}
        state = FrameState(self.world, views, index)
        for k, randomizer in enumerate(self.config.randomizers):
            if not randomizer.image_step:
                randomizer.apply(state, frame_rng(self.seed, index, k))
        mujoco.mj_forward(self.world.model, self.world.data)
        return state

    def render(self, view: CameraView, *, labelled: bool = True) -> Rendered:
        """The images of one view of the posed scene (`labelled=False`: RGB alone)."""
        labelers = self.config.labelers
        renderer = self._renderer(view.width, view.height)
        return renderer.render(
            self.world.data,
            view,
            rgb="rgb" in labelers or not labelled,
            depth=labelled and "depth" in labelers,
            segmentation=labelled and self._want_seg,
        )

    def make(self, index: int) -> Frame:
        """Frame `index`, rendered and labelled."""
        state = self.pose(index)
        views = []
        for c, spec in enumerate(self.config.cameras):
            view = state.views[spec.name]
            rendered = self.render(view)
            labels = annotate(
                self.world.model,
                self.world.data,
                view,
                rendered,
                table=self.table,
                shapes=self.shapes,
                labelers=self.config.labelers,
                near=self._renderer(view.width, view.height).near,
            )
            rgb = rendered.rgb
            if rgb is not None:
                clock = time.process_time()
                empty = rendered.empty if self._image_steps_need_segmentation else None
                for k, step in enumerate(self.config.randomizers):
                    if step.image_step:
                        rgb = step.post(rgb, empty, frame_rng(self.seed, index, k, c))
                self._image_times.add(IMAGE_STEPS, clock)
            views.append(View(view, rgb, rendered.depth, labels))
        return Frame(index, views)

    def render_times(self) -> StageTimes:
        """CPU seconds per render stage and views rendered, summed over this maker's
        renderers, and of the image randomisers (IMAGE_STEPS) on their images
        (benchmarks/bench_perception.py's stage table)."""
        total = StageTimes(dict(self._image_times.seconds))
        for renderer in self._renderers.values():
            for stage, seconds in renderer.times.seconds.items():
                total.seconds[stage] = total.seconds.get(stage, 0.0) + seconds
            total.views += renderer.times.views
        return total

    def close(self) -> None:
        """Free the renderers."""
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers.clear()
