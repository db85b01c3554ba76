"""The contact sheet shows what the labels say: each instance's mask tinted in its own colour
over the frame, its box in that colour, frames in a grid (checked on 640x480 frames whose
objects are large enough that a tint is measurable away from the strokes)."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from PIL import Image

from simbridge.perception.contact_sheet import GAP, THUMB_WIDTH, contact_sheet, instance_colour

WIDTH, HEIGHT = 640, 480
THUMB_HEIGHT = THUMB_WIDTH * HEIGHT // WIDTH
TINT = 0.55
"""The colour's weight over the frame inside a mask (the sheet's documented look)."""


def _frame(root: Path, index: int) -> tuple[dict[str, Any], NDArray[np.uint8], NDArray[Any]]:
    """A textured 640x480 frame with a rectangle (id 3) and a disc (id 7), as a view record."""
    rng = np.random.default_rng(index)
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    rgb = np.stack([xx * 255 // WIDTH, yy * 255 // HEIGHT, (xx + yy + 40 * index) % 256], axis=2)
    rgb = (rgb + rng.integers(-20, 21, rgb.shape)).clip(0, 255).astype(np.uint8)
    instance = np.zeros((HEIGHT, WIDTH), dtype=np.int32)
    instance[100 + 10 * index : 220 + 10 * index, 200:360] = 3
    instance[(yy - 330) ** 2 + (xx - 470) ** 2 <= 60**2] = 7
    Image.fromarray(rgb).save(root / f"rgb_{index}.png")
    np.savez(root / f"labels_{index}.npz", instance=instance)
    instances = []
    for inst_id, name in ((3, "cube"), (7, "can")):
        rows, cols = np.nonzero(instance == inst_id)
        box = [int(cols.min()), int(rows.min()), int(cols.max()), int(rows.max())]
        instances.append({"id": inst_id, "class": name, "box_tight": box})
    view = {
        "width": WIDTH,
        "height": HEIGHT,
        "rgb": f"rgb_{index}.png",
        "labels": f"labels_{index}.npz",
        "instances": instances,
    }
    return view, rgb, instance


def _thumb(image: NDArray[np.uint8]) -> NDArray[np.int16]:
    small = Image.fromarray(image).resize((THUMB_WIDTH, THUMB_HEIGHT), Image.Resampling.BILINEAR)
    return np.asarray(small).astype(np.int16)


def _interior(mask: NDArray[np.bool_], margin: int) -> NDArray[np.bool_]:
    """`mask` at thumbnail size, less `margin` thumbnail pixels at its edge."""
    small = np.asarray(
        Image.fromarray(mask).resize((THUMB_WIDTH, THUMB_HEIGHT), Image.Resampling.NEAREST)
    )
    inner = small.copy()
    for dy in range(-margin, margin + 1):
        for dx in range(-margin, margin + 1):
            inner &= np.roll(small, (dy, dx), axis=(0, 1))
    return inner


def _strokes(view: dict[str, Any]) -> NDArray[np.bool_]:
    """Where the sheet may draw on a thumbnail: each box's outline and the class name above it,
    with 3 pixels to spare."""
    drawn = np.zeros((THUMB_HEIGHT, THUMB_WIDTH), dtype=bool)
    for inst in view["instances"]:
        x0, y0, x1, y1 = (v // 2 for v in inst["box_tight"])
        drawn[max(y0 - 10, 0) : y0, max(x0 - 3, 0) : x0 + 4 * len(inst["class"]) + 6] = True
        for row in (y0, y1):
            drawn[max(row - 3, 0) : row + 4, max(x0 - 3, 0) : x1 + 4] = True
        for col in (x0, x1):
            drawn[max(y0 - 3, 0) : y1 + 4, max(col - 3, 0) : col + 4] = True
    return drawn


def test_each_mask_is_tinted_in_its_instance_colour_and_boxed(tmp_path: Path) -> None:
    frames = [_frame(tmp_path, k) for k in range(3)]
    sheet = np.asarray(
        Image.open(io.BytesIO(contact_sheet(tmp_path, [{"views": [f[0]]} for f in frames], 3)))
    ).astype(np.int16)
    # Three tiles make a 2x2 grid: tile k at column k % 2, row k // 2, GAP apart.
    assert sheet.shape == (2 * (THUMB_HEIGHT + GAP) + GAP, 2 * (THUMB_WIDTH + GAP) + GAP, 3)
    assert (sheet[THUMB_HEIGHT + 2 * GAP :, THUMB_WIDTH + 2 * GAP :] == 24).all()  # empty cell
    assert instance_colour(3) != instance_colour(7)
    for k, (view, rgb, instance) in enumerate(frames):
        top, left = GAP + (k // 2) * (THUMB_HEIGHT + GAP), GAP + (k % 2) * (THUMB_WIDTH + GAP)
        tile = sheet[top : top + THUMB_HEIGHT, left : left + THUMB_WIDTH]
        plain = _thumb(rgb)
        background = _interior(instance == 0, 4) & ~_strokes(view)
        assert np.abs(tile[background] - plain[background]).max() <= 1
        for inst in view["instances"]:
            colour = np.array(instance_colour(inst["id"]))
            inner = _interior(instance == inst["id"], 4)
            assert inner.sum() > 500
            tinted = plain[inner] * (1 - TINT) + colour * TINT
            assert np.abs(tile[inner] - tinted).max() <= 2, inst
            # The box's top edge, a thumbnail row, is drawn in the instance's colour (blurred
            # by the downscale into the rows beside it): far nearer it than the frame was.
            x0, y0, x1, _ = (v // 2 for v in inst["box_tight"])
            drawn = np.abs(tile[y0, x0 + 4 : x1 - 4] - colour).mean()
            assert drawn < 0.35 * np.abs(plain[y0, x0 + 4 : x1 - 4] - colour).mean(), (inst, drawn)
