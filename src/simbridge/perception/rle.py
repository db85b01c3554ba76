"""COCO run-length encoding of binary masks (what pycocotools' `mask.encode` writes), without
needing pycocotools at run time: runs in column-major order starting with a run of zeros,
written as COCO's compressed string (LEB128-like, 5 bits a character, offsets 48)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["encode_counts", "mask_runs", "rle"]


def mask_runs(
    mask: NDArray[np.bool_], origin: tuple[int, int], shape: tuple[int, int]
) -> list[int]:
    """Run lengths of an image of `shape` (height, width) that is 0 except for `mask`,
    placed with its top-left at pixel (column, row) `origin`."""
    height, width = shape
    col0, row0 = origin
    # Pad each column with a 0 above and below, so every run of ones starts and ends inside.
    padded = np.zeros((mask.shape[1], mask.shape[0] + 2), dtype=np.int8)
    padded[:, 1:-1] = mask.T
    steps = np.diff(padded, axis=1)
    cols_s, rows_s = np.nonzero(steps == 1)
    cols_e, rows_e = np.nonzero(steps == -1)
    starts = (cols_s + col0) * height + rows_s + row0
    ends = (cols_e + col0) * height + rows_e + row0
    counts: list[int] = []
    position = 0
    for start, end in zip(starts.tolist(), ends.tolist(), strict=True):
        if counts and start == position:  # a run continuing into the next column
            counts[-1] += end - start
        else:
            counts += [start - position, end - start]
        position = end
    if position < height * width or not counts:  # pycocotools ends with the last run of ones
        counts.append(height * width - position)
    return counts


def encode_counts(counts: list[int]) -> str:
    """COCO's compressed string of run lengths (pycocotools' rleToString)."""
    out = []
    for i, count in enumerate(counts):
        x = count - counts[i - 2] if i > 2 else count
        more = True
        while more:
            c = x & 0x1F
            x >>= 5
            more = x != -1 if c & 0x10 else x != 0
            if more:
                c |= 0x20
            out.append(chr(c + 48))
    return "".join(out)


def rle(
    mask: NDArray[np.bool_], origin: tuple[int, int], shape: tuple[int, int]
) -> dict[str, object]:
    """A COCO RLE segmentation: {"size": [height, width], "counts": compressed string}."""
    return {"size": [shape[0], shape[1]], "counts": encode_counts(mask_runs(mask, origin, shape))}
