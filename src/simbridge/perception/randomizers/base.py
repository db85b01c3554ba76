"""What every randomiser is: it may add to the model before it compiles (`extend`), finds
its ids after (`bind`), then changes the scene (`apply`) or a rendered image (`post`) of
each frame from a generator seeded by (dataset seed, frame, randomiser index) alone."""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.perception.camera import CameraView
from simbridge.sim import World
from simbridge.sim.scene.located import Where
from simbridge.sim.urdf.document import MjcfDocument

__all__ = ["Baseline", "FrameState", "Randomizer", "frame_rng"]

_MODEL_FIELDS = (
    "geom_rgba",
    "geom_matid",
    "geom_group",
    "geom_type",
    "geom_size",
    "geom_dataid",
    "mat_rgba",
    "mat_texid",
    "mat_texrepeat",
    "mat_specular",
    "mat_shininess",
    "mat_reflectance",
    "light_pos",
    "light_dir",
    "light_diffuse",
    "light_ambient",
    "light_active",
    "light_castshadow",
    "light_type",
    "body_pos",
    "body_quat",
)
"""Model arrays randomisers change; restored before every frame."""


def frame_rng(seed: int, frame: int, *stream: int) -> np.random.Generator:
    """The generator of `stream` (randomiser index, then camera index for image steps) in
    frame `frame`: a function of these numbers only, so any frame renders the same alone."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(frame, *stream)))


class Baseline:
    """The model as compiled (the arrays randomisers touch), put back before each frame."""

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.saved = {name: getattr(model, name).copy() for name in _MODEL_FIELDS}

    def restore(self) -> None:
        for name, values in self.saved.items():
            getattr(self.model, name)[...] = values


@dataclass
class FrameState:
    """One frame being made: the world (pose it, recolour it) and the cameras."""

    world: World
    views: dict[str, CameraView]
    frame: int
    occupied: dict[str, list[tuple[float, float, float]]] = field(default_factory=dict)
    """Per surface, the footprints (x, y, radius in the surface frame) placed so far."""

    @property
    def model(self) -> mujoco.MjModel:
        return self.world.model

    @property
    def data(self) -> mujoco.MjData:
        return self.world.data


class Randomizer:
    """A randomiser (a scene step unless it overrides `post`); subclasses parse their
    options from a YAML section and document their ranges."""

    kind = ""
    where: Where | None = None
    """Where the randomiser's entry is in the scene file (set when it is parsed)."""
    image_step = False
    """True for steps on the rendered RGB image (`post`) rather than on the scene."""

    def extend(self, document: MjcfDocument) -> None:
        """Add what this randomiser needs to the model before it compiles."""

    def bind(self, world: World) -> None:
        """Look up ids in the compiled model."""

    def apply(self, state: FrameState, rng: np.random.Generator) -> None:
        """Change the scene for this frame."""

    def post(
        self,
        rgb: NDArray[np.uint8],
        empty: NDArray[np.bool_] | None,
        rng: np.random.Generator,
    ) -> NDArray[np.uint8]:
        """Change a rendered image (`empty`: where nothing was drawn, when
        `needs_segmentation`); labels are never touched."""
        return rgb

    @property
    def needs_segmentation(self) -> bool:
        """Whether `post` reads where nothing was drawn (from the segmentation render)."""
        return False
