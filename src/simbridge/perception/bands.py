"""Per-pixel work a band of rows at a time: a band's arrays (and numpy's temporaries, such
as a look-up's indices widened to 64 bits) stay in the CPU's cache, where numpy over a
whole 640x480 frame at once waits on memory (1.5-2x slower)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["BAND_ROWS", "lookup", "row_bands"]

BAND_ROWS = 32
"""Rows a band holds (640x480 frames: noise and blur fastest at 16-48); a multiple of 4,
as the noise draws its 16-bit words a band at a time (randomizers/image_effects.py)."""


def row_bands(height: int) -> Iterator[slice]:
    """Slices of `BAND_ROWS` rows (the last may be shorter) covering `height` rows."""
    for start in range(0, height, BAND_ROWS):
        yield slice(start, min(start + BAND_ROWS, height))


def lookup(table: NDArray[Any], index: NDArray[Any]) -> NDArray[Any]:
    """`np.take(table, index)` for an image of indices, band by band."""
    out = np.empty(index.shape, dtype=table.dtype)
    for rows in row_bands(index.shape[0]):
        np.take(table, index[rows], out=out[rows])
    return out
