"""Silhouette loops against the convex hull of the projected points: the loop's corners
are the hull's (no hull corner missed), in order (a convex polygon of the hull's area)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from scipy.spatial import ConvexHull
from scipy.spatial.transform import Rotation

from simbridge.perception.loops import BOX_CORNERS, RIM, RIM_CIRCLE, box_loop, prism_loop

FloatArray = NDArray[np.float64]


sizes = st.floats(0.01, 2.0)
unit = st.floats(-1.0, 1.0)


def _pose(angles: tuple[float, float, float], offset: tuple[float, float, float]) -> FloatArray:
    """A camera at `offset` (geom frame) looking at the geom's origin, turned by `angles`."""
    forward = -np.asarray(offset) / np.linalg.norm(offset)
    # the camera frame's rows: any right-handed frame with z along `forward`
    helper = np.array([0.0, 0.0, 1.0]) if abs(forward[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    right = np.cross(helper, forward)
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    frame = np.stack([right, down, forward])
    roll = Rotation.from_euler("xyz", np.asarray(angles) * 0.3).as_matrix()  # small turns
    turned: FloatArray = roll @ frame
    return turned


def _check(
    points: FloatArray, camera: FloatArray, frame: FloatArray, loop: NDArray[np.intp]
) -> None:
    """Project `points` (geom frame) from `camera` with rows `frame`; the loop must be the
    projected convex hull."""
    local = (points - camera) @ frame.T
    assert local[:, 2].min() > 0, "the test's camera sees the whole shape"
    uv = local[:, :2] / local[:, 2:]
    hull = ConvexHull(uv)
    assert set(hull.vertices) <= set(loop.tolist()), "a hull corner is missing from the loop"
    polygon = uv[loop]
    x, y = polygon[:, 0], polygon[:, 1]
    area = 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    assert abs(abs(area) - hull.volume) <= 1e-9 * hull.volume
    edges = np.roll(polygon, -1, axis=0) - polygon
    turns = edges[:, 0] * np.roll(edges[:, 1], -1) - edges[:, 1] * np.roll(edges[:, 0], -1)
    scale = float(np.abs(turns).max())
    assert (turns >= -1e-9 * scale).all() or (turns <= 1e-9 * scale).all(), "not convex"


directions = st.tuples(unit, unit, unit).filter(lambda d: float(np.linalg.norm(d)) >= 0.1)
views = st.tuples(directions, st.floats(1.5, 20.0), st.tuples(unit, unit, unit))
"""Where the camera is (a direction, and a distance in shape sizes) and how it is turned."""


def _camera(
    view: tuple[tuple[float, float, float], float, tuple[float, float, float]], extent: float
) -> tuple[FloatArray, FloatArray]:
    """The camera's position (geom frame) at `view`'s distance times 2 `extent`, and its
    frame's rows."""
    direction, distance, angles = view
    position = np.asarray(direction) / np.linalg.norm(direction) * distance * extent * 2
    return position, _pose(angles, (float(position[0]), float(position[1]), float(position[2])))


@settings(max_examples=300, deadline=None)
@given(st.tuples(sizes, sizes, sizes), views)
def test_a_box_loop_is_the_hull_of_its_projected_corners(
    half: tuple[float, float, float],
    view: tuple[tuple[float, float, float], float, tuple[float, float, float]],
) -> None:
    half_sizes = np.asarray(half)
    camera, frame = _camera(view, float(half_sizes.max()))
    loop = box_loop(camera, half_sizes)
    assert loop is not None
    _check(BOX_CORNERS * half_sizes, camera, frame, loop)


@settings(max_examples=300, deadline=None)
@given(sizes, sizes, views)
def test_a_prism_loop_is_the_hull_of_its_projected_rims(
    radius: float,
    half_height: float,
    view: tuple[tuple[float, float, float], float, tuple[float, float, float]],
) -> None:
    camera, frame = _camera(view, max(radius, half_height))
    lift = np.array([0.0, 0.0, half_height])
    points = np.vstack([RIM_CIRCLE * radius - lift, RIM_CIRCLE * radius + lift])
    loop = prism_loop(camera, radius, half_height)
    assert loop is not None
    _check(points, camera, frame, loop)


@pytest.mark.parametrize(
    ("camera", "corners"),
    [((0.0, 0.0, 5.0), 4), ((0.0, 3.0, 5.0), 6), ((3.0, 3.0, 5.0), 6), ((4.0, 0.0, 0.0), 4)],
)
def test_a_box_shows_one_face_from_straight_on_and_six_corners_from_aside(
    camera: tuple[float, float, float], corners: int
) -> None:
    loop = box_loop(np.asarray(camera), np.array([1.0, 1.0, 1.0]))
    assert loop is not None
    assert len(loop) == corners


def test_straight_above_a_cylinder_its_outline_is_the_top_rim() -> None:
    loop = prism_loop(np.array([0.0, 0.0, 3.0]), 1.0, 0.5)
    assert loop is not None
    assert sorted(loop.tolist()) == list(range(RIM, 2 * RIM))


def test_from_inside_there_is_no_loop() -> None:
    assert box_loop(np.array([0.1, -0.2, 0.3]), np.array([1.0, 1.0, 1.0])) is None
    assert prism_loop(np.array([0.1, -0.2, 0.3]), 1.0, 0.5) is None
