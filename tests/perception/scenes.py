"""Scenes of the perception tests: a truth scene of known shapes seen by known cameras (no
randomisers) and a small randomised scene, written to a test's folder."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "BOX_RPY",
    "BOX_SIZE",
    "BOX_XYZ",
    "FOCAL",
    "HEIGHT",
    "SPHERE_RADIUS",
    "SPHERE_XYZ",
    "TILE",
    "TRUTH_CAMERAS",
    "WIDTH",
    "look_at_frame",
    "pinhole",
    "random_scene",
    "truth_scene",
]

TILE = 0.2
"""Half the edge of the flat box half hidden under the plate (m)."""
SPHERE_XYZ, SPHERE_RADIUS = (0.0, 0.0, 0.5), 0.1
BOX_XYZ, BOX_RPY, BOX_SIZE = (10.0, 0.0, 0.3), (0.3, 0.2, 0.5), (0.3, 0.2, 0.1)

TRUTH_CAMERAS = {
    # name: (eye, target, up); 128x96, fx = fy = 150, centred principal point
    "sphere": ((0.0, 0.0, 1.5), (0.0, 0.0, 0.5), (0.0, 1.0, 0.0)),
    "box": ((10.8, 0.6, 1.0), (10.0, 0.0, 0.3), (0.0, 0.0, 1.0)),
    "plane": ((20.0, -1.0, 1.2), (20.0, 0.5, 0.0), (0.0, 0.0, 1.0)),
    "hidden": ((30.0, 0.0, 2.0), (30.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
}
WIDTH, HEIGHT, FOCAL = 128, 96, 150.0


def look_at_frame(
    eye: Sequence[float], target: Sequence[float], up: Sequence[float]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """World-from-optical rotation (REP 103: x right, y down, z forward) and position of a
    camera at `eye` looking at `target`, worked out here rather than taken from simbridge."""
    e, t, u = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = (t - e) / np.linalg.norm(t - e)
    x = np.cross(z, u)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1), e


def pinhole(
    world: NDArray[np.float64],
    rotation: NDArray[np.float64],
    eye: NDArray[np.float64],
    focal: float,
    centre: tuple[float, float],
) -> NDArray[np.float64]:
    """Pixel (u, v) of world points (N, 3) seen by a pinhole camera (square pixels)."""
    camera = (world - eye) @ rotation
    return np.stack(
        [
            focal * camera[:, 0] / camera[:, 2] + centre[0],
            focal * camera[:, 1] / camera[:, 2] + centre[1],
        ],
        axis=1,
    )


def _v(values: tuple[float, ...]) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def truth_scene(folder: Path, multisamples: int = 4) -> Path:
    """Known shapes far apart on an infinite floor, one camera on each: a sphere seen along
    its axis, a turned box, bare floor, and a flat box half hidden under a plate;
    `multisamples`: the renderer's anti-aliasing."""
    cameras = "\n".join(
        f"    - {{name: {name}, width: {WIDTH}, height: {HEIGHT}, fx: {FOCAL}, fy: {FOCAL}, "
        f"eye: {_v(eye)}, target: {_v(target)}, up: {_v(up)}}}"
        for name, (eye, target, up) in TRUTH_CAMERAS.items()
    )
    text = f"""\
ros:
  enabled: false
objects:
  - {{name: floor, type: plane, rgba: [0.4, 0.4, 0.4, 1]}}
  - {{name: ball, type: sphere, size: {SPHERE_RADIUS}, label: ball,
     pose: {{xyz: {_v(SPHERE_XYZ)}}}}}
  - {{name: crate, type: box, size: {_v(BOX_SIZE)}, label: crate,
     pose: {{xyz: {_v(BOX_XYZ)}, rpy: {_v(BOX_RPY)}}}}}
  - {{name: tile, type: box, size: [{2 * TILE}, {2 * TILE}, 0.02], label: tile,
     pose: {{xyz: [30.0, 0.0, 0.01]}}}}
  - {{name: plate, type: box, size: [0.4, 0.8, 0.02], label: plate,
     pose: {{xyz: [29.8, 0.0, 0.5]}}}}
lights:
  - {{type: directional, pos: [0, 0, 3], dir: [0.1, 0.2, -1], cast_shadows: false}}
perception:
  classes: [ball, crate, tile, plate]
  render: {{near: 0.05, far: 20, multisamples: {multisamples}}}
  output: {{contact_sheet: 4}}
  cameras:
{cameras}
"""
    path = folder / "truth.yaml"
    path.write_text(text)
    return path


def random_scene(folder: Path, *, size: tuple[int, int] = (64, 48)) -> Path:
    """A small randomised table scene: every scene randomiser that changes what MuJoCo
    bakes into a GL context (materials on a plane, distractors) and the image steps."""
    width, height = size
    text = f"""\
ros:
  enabled: false
objects:
  - {{name: table, type: box, size: [0.8, 1.0, 0.04], pose: {{xyz: [0, 0, -0.02]}}}}
  - {{name: floor, type: plane, pose: {{xyz: [0, 0, -0.75]}}}}
  - {{name: cube_0, type: box, size: [0.06, 0.06, 0.06], dynamic: true, label: cube,
     pose: {{xyz: [0.1, 0.1, 0.03]}}}}
  - {{name: cube_1, type: box, size: [0.05, 0.05, 0.05], dynamic: true, label: cube,
     pose: {{xyz: [-0.1, 0.1, 0.025]}}}}
  - {{name: can, type: cylinder, size: [0.03, 0.1], dynamic: true, label: can,
     pose: {{xyz: [0.0, -0.15, 0.05]}}}}
lights:
  - {{type: directional, pos: [0, 0, 2], dir: [0.2, 0.3, -1]}}
perception:
  classes: [cube, can, distractor]
  render: {{near: 0.05, far: 10}}
  output: {{contact_sheet: 4}}
  cameras:
    - {{name: main, width: {width}, height: {height}, fovy: 55, eye: [1.0, 0.5, 0.7],
       target: [0, 0, 0]}}
  randomizers:
    - {{type: placement, objects: [cube_*, can], surface: table, area: [0.6, 0.8]}}
    - {{type: distractors, count: [1, 4], surface: table, size: [0.02, 0.06],
       label: distractor}}
    - {{type: materials, bodies: [table, floor], texture: 0.7}}
    - {{type: materials, bodies: [cube_*, can], texture: 0.3}}
    - {{type: lights, count: [1, 3], region: {{center: [0, 0, 1.8], size: [2, 2, 0.6]}},
       intensity: [0.4, 0.8], shadows: 0.5}}
    - {{type: camera, camera: main, target: [0, 0, 0.05], target_jitter: [0.05, 0.05, 0.02],
       distance: [0.9, 1.3], azimuth: [-60, 60], elevation: [30, 60]}}
    - {{type: intrinsics, focal: [0.95, 1.05], principal: [-2, 2]}}
    - {{type: background}}
    - {{type: noise, gaussian: [0, 4], blur: [0, 0.6]}}
"""
    path = folder / "random.yaml"
    path.write_text(text)
    return path
