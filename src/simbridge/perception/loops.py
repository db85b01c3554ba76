"""Silhouette loops of convex polytopes: the edges between faces that face a viewpoint and
faces that do not, in order around the outline. Projected (the whole shape in front of the
camera) they are the convex hull of the projected vertices, without computing a hull.

Boxes use a table of their 26 outside regions; cylinders are the prism of their rims
(shapes.RIM points a rim), whose facing sides form one arc.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray

__all__ = ["BOX_CORNERS", "RIM", "RIM_CIRCLE", "box_loop", "prism_loop"]

IndexArray = NDArray[np.intp]
FloatArray = NDArray[np.float64]

BOX_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
"""A box's corners in units of its half sizes; corner i has x, y, z signs of bits 4, 2, 1."""
RIM = 64
"""Points a rim of a cylinder (and of a round silhouette)."""

_ANGLES = np.linspace(0.0, 2.0 * np.pi, RIM, endpoint=False)
RIM_CIRCLE = np.stack([np.cos(_ANGLES), np.sin(_ANGLES), np.zeros(RIM)], axis=1)
"""The unit circle's RIM points (z = 0) that rims and round silhouettes are made of."""
_HALF_STEP = np.pi / RIM
_SIDE_NORMALS = np.stack([np.cos(_ANGLES + _HALF_STEP), np.sin(_ANGLES + _HALF_STEP)], axis=1)
"""Outward normals (x, y) of a prism's sides; side k joins rim points k and k + 1."""
_SIDE_OFFSET = np.cos(_HALF_STEP)
"""A side's distance from the axis, per unit radius."""


def _box_loops() -> dict[tuple[int, ...], IndexArray]:
    """Per region (each axis: -1 below the box's faces, 0 between, 1 above), the corners of
    the silhouette in order: the box edges with one facing and one turned-away face."""
    loops: dict[tuple[int, ...], IndexArray] = {}
    for region in itertools.product((-1, 0, 1), repeat=3):
        if region == (0, 0, 0):
            continue  # inside: no silhouette
        links: dict[int, list[int]] = {}
        for a, b in itertools.combinations(range(8), 2):
            differ = np.flatnonzero(BOX_CORNERS[a] != BOX_CORNERS[b])
            if len(differ) != 1:
                continue  # not an edge
            j, k = (axis for axis in range(3) if axis != differ[0])
            if (region[j] == BOX_CORNERS[a][j]) != (region[k] == BOX_CORNERS[a][k]):
                links.setdefault(a, []).append(b)
                links.setdefault(b, []).append(a)
        start = min(links)
        loop, previous, corner = [start], start, links[start][0]
        while corner != start:
            loop.append(corner)
            previous, corner = corner, next(c for c in links[corner] if c != previous)
        loops[region] = np.array(loop, dtype=np.intp)
    return loops


_BOX_LOOPS = _box_loops()


def box_loop(viewpoint: FloatArray, half: FloatArray) -> IndexArray | None:
    """Indices into BOX_CORNERS of the silhouette seen from `viewpoint` (the box's frame) of
    a box of half sizes `half`; None from inside the box."""
    x, y, z = (int(p > h) - int(p < -h) for p, h in zip(viewpoint, half, strict=True))
    return _BOX_LOOPS.get((x, y, z))


def prism_loop(viewpoint: FloatArray, radius: float, half_height: float) -> IndexArray | None:
    """Indices of the silhouette of a cylinder's prism seen from `viewpoint` (its frame),
    into its points: RIM on the bottom rim (z = -half_height), then RIM on the top one, each
    at angles 2 pi k / RIM. None from inside it."""
    top = bool(viewpoint[2] > half_height)
    bottom = bool(viewpoint[2] < -half_height)
    facing = _SIDE_NORMALS @ viewpoint[:2] > radius * _SIDE_OFFSET
    count = int(facing.sum())
    if count == 0:  # above or below the prism's sides: one cap's outline
        if not (top or bottom):
            return None
        return np.arange(RIM, dtype=np.intp) + (RIM if top else 0)
    starts = np.flatnonzero(facing & ~np.roll(facing, 1))
    if len(starts) != 1:
        return None  # not one arc (a tie in rounding): let the caller take a hull
    first = int(starts[0])
    # The facing sides run from rim point `first` to `first + count`; each rim is outlined
    # along its facing sides unless its cap faces the viewpoint too (then along the others).
    front = (first + np.arange(count + 1)) % RIM
    back = (first + count + np.arange(RIM - count + 1)) % RIM
    upper = back[::-1] if top else front
    lower = back if bottom else front[::-1]
    return np.concatenate([upper + RIM, lower]).astype(np.intp)
