"""Perception data: labelled, randomised synthetic images of any scene (what Unity's
Perception package, Isaac Replicator and BlenderProc do), with MuJoCo's renderer.

A scene declares `label:` on objects and robots and a `perception:` section (cameras,
labelers, randomisers; `simbridge.perception.config`). Each frame is a pure function of
(seed, frame index): the scene is put back as compiled, randomised, rendered per camera
and labelled (RGB, metric depth, semantic and instance segmentation, tight and amodal 2D
boxes with visible fraction and truncation, 3D boxes, 6D poses, robot keypoints, all in
the REP 103 optical frame), then written as a native layout, COCO and BOP.

The dataset API for workers (a Ray cluster, issue 35) is `simbridge.perception.dataset`:

    job = DatagenJob("scene.yaml", seed=7, formats=("coco", "bop"))
    render_frames(job, range(0, 100), Path("shards/a"))     # any frames, any process
    render_frames(job, range(100, 200), Path("shards/b"))
    merge_shards(job, [Path("shards/a"), Path("shards/b")], Path("out"), frames=200)

gives the same bytes as `generate(job, 200, Path("out"))`; see its docstring.
docs/perception.md has the YAML keys, the file schema and the conventions.
"""

from __future__ import annotations

from simbridge.perception.annotate import Box3D, InstanceLabel, ViewLabels, annotate
from simbridge.perception.camera import CameraSpec, CameraView, look_at
from simbridge.perception.config import LABELERS, OutputSettings, PerceptionConfig, parse_perception
from simbridge.perception.dataset import (
    FORMATS,
    SCHEMA,
    DatagenJob,
    DatasetSummary,
    first_missing_frame,
    generate,
    merge_shards,
    render_frames,
)
from simbridge.perception.frames import Frame, FrameMaker, View
from simbridge.perception.render import Rendered, RenderSettings, StageTimes, ViewRenderer
from simbridge.perception.rle import rle
from simbridge.sim.labels import Instance, LabelTable

__all__ = [
    "FORMATS",
    "LABELERS",
    "SCHEMA",
    "Box3D",
    "CameraSpec",
    "CameraView",
    "DatagenJob",
    "DatasetSummary",
    "Frame",
    "FrameMaker",
    "Instance",
    "InstanceLabel",
    "LabelTable",
    "OutputSettings",
    "PerceptionConfig",
    "RenderSettings",
    "Rendered",
    "StageTimes",
    "View",
    "ViewLabels",
    "ViewRenderer",
    "annotate",
    "first_missing_frame",
    "generate",
    "look_at",
    "merge_shards",
    "parse_perception",
    "render_frames",
    "rle",
]
