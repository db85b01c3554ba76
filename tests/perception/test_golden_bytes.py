"""Golden bytes of every encoder a dataset's files come from, for fixed pixels and labels
(integers from a seeded PCG64, nothing rendered: no llvmpipe or CPU in the bytes). A change
that writes the same content as other bytes must raise `ENCODING`
(simbridge/perception/dataset.py), which `--resume` checks, and pin its digests here."""

from __future__ import annotations

import hashlib
import io
import json

import numpy as np
from numpy.typing import NDArray

from simbridge.perception.dataset import ENCODING
from simbridge.perception.npz import write_npz_to
from simbridge.perception.png import png_bytes
from simbridge.perception.randomizers.image_effects import NoiseRandomizer
from simbridge.perception.rle import rle
from simbridge.perception.section import Section
from simbridge.sim.scene.located import Where

GOLDEN = {
    2: {
        "colour png, clean (run-length)": "c8c399f59cf8fdeb",
        "colour png, noisy (Huffman only)": "fc25fa4d5f6453bd",
        "depth png (16-bit)": "1309a60c4eb90ba0",
        "mask png (1-bit)": "bf29a7ab7592f7c4",
        "npz (depth, instance, semantic)": "55ba8d87dad10e1d",
        "noise step (blur and noise)": "1aefbbc15db0ebe5",
        "coco rle": "b363b93f2ea1b802",
    },
}
"""Per ENCODING, the first 16 hex digits of each output's SHA-256."""


def _outputs() -> dict[str, bytes]:
    rng = np.random.default_rng(2026)
    blocks = rng.integers(0, 256, (6, 8, 3), dtype=np.uint8)
    clean: NDArray[np.uint8] = np.repeat(np.repeat(blocks, 10, axis=0), 10, axis=1)
    noise = rng.integers(-6, 7, clean.shape)
    noisy = np.clip(clean.astype(int) + noise, 0, 255).astype(np.uint8)
    depth = rng.integers(0, 65536, (60, 80), dtype=np.uint16)
    mask = np.zeros((60, 80), dtype=bool)
    mask[12:40, 20:55] = True
    mask[25:30, 30:70] = True
    arrays: dict[str, NDArray[np.generic]] = {
        "depth": (depth / 1000).astype(np.float32),
        "instance": rng.integers(0, 9, (60, 80), dtype=np.uint16),
        "semantic": rng.integers(0, 5, (60, 80), dtype=np.uint16),
    }
    npz = io.BytesIO()
    write_npz_to(npz, arrays)
    section = Section(
        {"type": "noise", "gaussian": [2, 4], "blur": [0.5, 1.0]},
        Where("perception.randomizers[0]", None, None),
    )
    post = NoiseRandomizer(section).post(clean, None, np.random.default_rng(7))
    return {
        "colour png, clean (run-length)": png_bytes(clean, 1),
        "colour png, noisy (Huffman only)": png_bytes(noisy, 1),
        "depth png (16-bit)": png_bytes(depth, 1),
        "mask png (1-bit)": png_bytes(mask, 1),
        "npz (depth, instance, semantic)": npz.getvalue(),
        "noise step (blur and noise)": post.tobytes(),
        "coco rle": json.dumps(rle(mask, (0, 0), mask.shape)).encode(),
    }


def test_the_encoders_write_the_bytes_pinned_for_this_encoding() -> None:
    digests = {k: hashlib.sha256(v).hexdigest()[:16] for k, v in _outputs().items()}
    assert ENCODING in GOLDEN, f"ENCODING {ENCODING} has no pinned digests: {digests}"
    assert digests == GOLDEN[ENCODING], (
        "the same pixels and labels come out as other bytes: if intended, raise ENCODING in "
        "simbridge/perception/dataset.py and pin these digests under it"
    )
