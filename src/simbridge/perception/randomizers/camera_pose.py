"""Camera randomisers: `type: camera` moves a camera on a sphere around its target,
`type: intrinsics` jitters focal lengths and the principal point.

    - type: camera
      camera: main               # default: every camera
      target: [0.15, 0, 0]       # default: the camera's declared target
      target_jitter: [0.05, 0.05, 0.02]   # m per axis, uniform
      distance: [0.8, 1.4]       # m from the target
      azimuth: [-60, 60]         # degrees about +z; 0 puts the camera on the +x side
      elevation: [20, 60]        # degrees above the target's horizontal plane
      roll: [-5, 5]              # degrees about the optical axis

    - type: intrinsics
      camera: main               # default: every camera
      focal: [0.9, 1.1]          # fx and fy scaled together by this
      aspect: [1, 1]             # fy scaled again by this
      principal: [-5, 5]         # pixels added to cx and to cy (each its own draw)
"""

from __future__ import annotations

import math

import numpy as np

from simbridge.errors import PerceptionError
from simbridge.perception.camera import CameraView, look_at
from simbridge.perception.randomizers.base import FrameState, Randomizer
from simbridge.perception.section import Range, Section

__all__ = ["CameraRandomizer", "IntrinsicsRandomizer"]


def _views(state: FrameState, camera: str | None) -> list[CameraView]:
    if camera is None:
        return list(state.views.values())
    if camera not in state.views:
        raise PerceptionError(
            f"perception randomizer: no camera '{camera}' (cameras: {', '.join(state.views)})"
        )
    return [state.views[camera]]


class CameraRandomizer(Randomizer):
    kind = "camera"
    KEYS = ("type", "camera", "target", "target_jitter", "distance", "azimuth", "elevation", "roll")

    def __init__(self, section: Section, targets: dict[str, tuple[float, float, float]]) -> None:
        self.camera = section.string("camera", "") or None
        if self.camera is not None and self.camera not in targets:
            raise section.error(
                f"no camera '{self.camera}' (cameras: {', '.join(targets)})", "camera"
            )
        self.targets = targets
        self.target = np.array(section.vector("target", 3, ())) if section.has("target") else None
        self.jitter = np.array(section.vector("target_jitter", 3, (0.0, 0.0, 0.0)))
        self.distance: Range = section.range("distance", (0.8, 1.4), 1e-3)
        self.azimuth: Range = section.range("azimuth", (-180.0, 180.0))
        self.elevation: Range = section.range("elevation", (20.0, 60.0), -89.9, 89.9)
        self.roll: Range = section.range("roll", (0.0, 0.0), -180.0, 180.0)
        section.done(self.KEYS)

    def apply(self, state: FrameState, rng: np.random.Generator) -> None:
        for view in _views(state, self.camera):
            base = self.target if self.target is not None else np.array(self.targets[view.name])
            target = base + (rng.random(3) - 0.5) * 2 * self.jitter
            distance = rng.uniform(*self.distance)
            azimuth = math.radians(rng.uniform(*self.azimuth))
            elevation = math.radians(rng.uniform(*self.elevation))
            roll = math.radians(rng.uniform(*self.roll))
            offset = distance * np.array([
                math.cos(elevation) * math.cos(azimuth),
                math.cos(elevation) * math.sin(azimuth),
                math.sin(elevation),
            ])  # fmt: skip
            eye = target + offset
            rotation = look_at(eye, target, np.array([0.0, 0.0, 1.0]))
            c, s = math.cos(roll), math.sin(roll)
            view.rotation = rotation @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            view.position = eye


class IntrinsicsRandomizer(Randomizer):
    kind = "intrinsics"
    KEYS = ("type", "camera", "focal", "aspect", "principal")

    def __init__(self, section: Section, cameras: list[str]) -> None:
        self.camera = section.string("camera", "") or None
        if self.camera is not None and self.camera not in cameras:
            raise section.error(
                f"no camera '{self.camera}' (cameras: {', '.join(cameras)})", "camera"
            )
        self.focal: Range = section.range("focal", (0.9, 1.1), 1e-3)
        self.aspect: Range = section.range("aspect", (1.0, 1.0), 1e-3)
        self.principal: Range = section.range("principal", (-5.0, 5.0))
        section.done(self.KEYS)

    def apply(self, state: FrameState, rng: np.random.Generator) -> None:
        for view in _views(state, self.camera):
            focal = rng.uniform(*self.focal)
            view.fx *= focal
            view.fy *= focal * rng.uniform(*self.aspect)
            view.cx += rng.uniform(*self.principal)
            view.cy += rng.uniform(*self.principal)
