"""COCO run-length encoding against pycocotools' own encoder, for masks placed anywhere in
an image (empty, full, touching the borders, noisy)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from pycocotools import mask as mask_utils  # type: ignore[import-untyped]

from simbridge.perception.rle import rle


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 40),
    st.integers(1, 40),
    st.floats(0.0, 1.0),
    st.sampled_from(["random", "empty", "full", "block"]),
    st.integers(0, 2**32 - 1),
)
def test_rle_is_what_pycocotools_encodes(
    height: int, width: int, density: float, kind: str, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    image = rng.random((height, width)) < density
    if kind == "empty":
        image[:] = False
    elif kind == "full":
        image[:] = True
    elif kind == "block":
        image[:] = False
        image[height // 4 : height - height // 3, width // 5 :] = True
    rows, cols = np.nonzero(image)
    if len(rows):  # the mask over its tight box, as annotate keeps it
        top, left = int(rows.min()), int(cols.min())
        mask = image[top : rows.max() + 1, left : cols.max() + 1]
    else:
        top = left = 0
        mask = image[:1, :1]
    expected = mask_utils.encode(np.asfortranarray(image.astype(np.uint8)))
    assert rle(mask, (left, top), (height, width)) == {
        "size": [height, width],
        "counts": expected["counts"].decode(),
    }
