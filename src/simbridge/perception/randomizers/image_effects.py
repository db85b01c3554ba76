"""Randomisers of the rendered RGB image (labels stay as rendered):

- type: background           # where no geometry was drawn (the sky), a procedural image
  probability: 1.0           # share of images that get one
  kinds: [gradient, checker, noise, flat]
  hue: [0, 1]                # its colours, as for `materials`
  saturation: [0, 0.6]
  value: [0.3, 1]

- type: noise
  gaussian: [0, 6]           # standard deviation of added noise, in 8-bit levels
  blur: [0, 1.0]             # Gaussian blur sigma in pixels (0: none; at most 3)

Both work in integers on the 8-bit image (a separable blur with weights in 1/256 steps;
noise drawn as 16-bit uniforms through a table of Gaussian quantiles), blur and noise
together a band of rows at a time (perception/bands.py): on the demo scene's 640x480 frames
3.6-3.9 ms a frame, where Pillow's blur and float32 noise took 34 and whole-frame integer
passes 6.1.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtri

from simbridge.perception.bands import row_bands
from simbridge.perception.randomizers.appearance import ColourRanges
from simbridge.perception.randomizers.base import Randomizer
from simbridge.perception.section import Range, Section

__all__ = [
    "BACKGROUNDS",
    "MAX_BLUR",
    "BackgroundRandomizer",
    "NoiseRandomizer",
    "blur_taps",
    "gaussian_blur",
    "uniform16",
]

BACKGROUNDS = ("gradient", "checker", "noise", "flat")
MAX_BLUR = 3.0
"""The largest blur sigma (px): beyond it weights in 1/256 steps describe the kernel badly."""
_QUANTILES = ndtri((np.arange(65536) + 0.5) / 65536)
"""Standard-normal quantiles of 65536 equally likely bins: a 16-bit uniform draw looked up
here is a Gaussian draw (tails to 4.2 sigma)."""


class BackgroundRandomizer(Randomizer):
    kind = "background"
    image_step = True
    KEYS = ("type", "probability", "kinds", *ColourRanges.KEYS)

    def __init__(self, section: Section) -> None:
        self.probability = section.number("probability", 1.0, 0.0, 1.0)
        self.kinds = section.strings("kinds", BACKGROUNDS)
        for kind in self.kinds:
            if kind not in BACKGROUNDS:
                raise section.error(
                    f"unknown background {kind!r} (valid: {', '.join(BACKGROUNDS)})", "kinds"
                )
        self.colours = ColourRanges.parse(section)
        section.done(self.KEYS)

    @property
    def needs_segmentation(self) -> bool:
        return True

    def _image(self, height: int, width: int, rng: np.random.Generator) -> NDArray[np.uint8]:
        """The background, (height, width, 3) or a view that broadcasts to it."""
        first = np.array(self.colours.draw(rng), dtype=np.float32)
        second = np.array(self.colours.draw(rng), dtype=np.float32)
        kind = self.kinds[int(rng.integers(len(self.kinds)))]
        cell = int(rng.integers(8, 64))
        if kind == "gradient":
            t = np.linspace(0.0, 1.0, height, dtype=np.float32)[:, None, None]
            return _bytes(first * (1 - t) + second * t)  # (height, 1, 3)
        if kind == "checker":
            cols = (np.arange(width) // cell % 2)[:, None] == 1
            even_row = np.where(cols, _bytes(second), _bytes(first))  # (width, 3)
            odd_row = np.where(cols, _bytes(first), _bytes(second))
            return np.stack([even_row, odd_row])[np.arange(height) // cell % 2]
        if kind == "noise":
            small = rng.random((height // cell + 1, width // cell + 1, 1), dtype=np.float32)
            cells = _bytes(first * (1 - small) + second * small)
            return np.repeat(np.repeat(cells, cell, axis=0), cell, axis=1)[:height, :width]
        return _bytes(first)[None, None, :]

    def post(
        self,
        rgb: NDArray[np.uint8],
        empty: NDArray[np.bool_] | None,
        rng: np.random.Generator,
    ) -> NDArray[np.uint8]:
        apply = rng.random() < self.probability
        image = self._image(rgb.shape[0], rgb.shape[1], rng)
        if not apply or empty is None:
            return rgb
        rows = np.flatnonzero(empty.any(axis=1))
        if not len(rows):
            return rgb  # no sky in this view
        band = slice(int(rows[0]), int(rows[-1]) + 1)  # only the rows with sky
        out = rgb.copy()
        fill = np.broadcast_to(image, out.shape)[band]
        np.copyto(out[band], fill, where=empty[band, :, None])
        return out


def _bytes(colour: NDArray[np.float32]) -> NDArray[np.uint8]:
    """Colours in [0, 1] as 8-bit levels, rounded."""
    out: NDArray[np.uint8] = (colour * 255.0 + 0.5).astype(np.uint8)
    return out


def blur_taps(sigma: float) -> list[int]:
    """A Gaussian kernel's centre and one side in 1/256 steps (summing to 256 both sides
    counted), without the zero tail."""
    reach = max(1, int(np.ceil(3 * sigma)))
    weights = np.exp(-(np.arange(reach + 1) ** 2) / (2 * sigma**2))
    side = np.rint(256 * weights[1:] / (weights[0] + 2 * weights[1:].sum())).astype(int).tolist()
    while side and side[-1] == 0:
        side.pop()
    return [256 - 2 * sum(side), *side]


def _weigh(padded: NDArray[Any], taps: list[int], axis: int) -> NDArray[np.uint16]:
    """A symmetric kernel along `axis` of `padded` (8- or 16-bit levels with `reach` extra
    entries at both ends), rounded to levels."""
    reach = len(taps) - 1
    size = padded.shape[axis] - 2 * reach

    def part(start: int) -> NDArray[Any]:
        index: list[slice] = [slice(None)] * padded.ndim
        index[axis] = slice(start, start + size)
        return padded[tuple(index)]

    total: NDArray[np.uint16] = np.multiply(part(reach), np.uint16(taps[0]), dtype=np.uint16)
    pair = np.empty_like(total)  # one buffer for every tap: no new array per tap
    for k in range(1, reach + 1):
        np.add(part(reach - k), part(reach + k), out=pair, dtype=np.uint16)
        pair *= np.uint16(taps[k])
        total += pair  # at most 255 * 256: no overflow
    total += np.uint16(128)
    total >>= np.uint16(8)
    return total


def _blur_band(image: NDArray[np.uint8], taps: list[int], rows: slice) -> NDArray[np.uint16]:
    """`rows` of the blurred image: across each row the band needs (edge pixels and rows
    repeated), then down the band."""
    reach, (height, width) = len(taps) - 1, image.shape[:2]
    low, high = max(rows.start - reach, 0), min(rows.stop + reach, height)
    before = low - (rows.start - reach)  # rows above the image, repeated from its first
    padded = np.empty(
        (rows.stop - rows.start + 2 * reach, width + 2 * reach, *image.shape[2:]), np.uint8
    )
    padded[before : before + high - low, reach : reach + width] = image[low:high]
    padded[:before, reach : reach + width] = image[low]
    padded[before + high - low :, reach : reach + width] = image[high - 1]
    padded[:, :reach] = padded[:, reach : reach + 1]
    padded[:, reach + width :] = padded[:, reach + width - 1 : reach + width]
    return _weigh(_weigh(padded, taps, 1), taps, 0)


def _bands(image: NDArray[np.uint8], taps: list[int]) -> Iterator[tuple[slice, NDArray[Any]]]:
    """The image a band at a time as levels: blurred by `taps` unless they are the
    identity."""
    for rows in row_bands(image.shape[0]):
        yield rows, image[rows] if len(taps) == 1 else _blur_band(image, taps, rows)


def gaussian_blur(image: NDArray[np.uint8], sigma: float) -> NDArray[np.uint8]:
    """A Gaussian blur of an (H, W) or (H, W, C) 8-bit image, in integers (weights in
    1/256 steps, sigma at most MAX_BLUR px; rows then columns, rounded after each)."""
    taps = blur_taps(sigma)
    if len(taps) == 1:
        return image  # too narrow to move any level
    out = np.empty_like(image)
    for rows, levels in _bands(image, taps):
        out[rows] = levels
    return out


def uniform16(rng: np.random.Generator, shape: tuple[int, ...]) -> NDArray[np.uint16]:
    """Uniform 16-bit draws: the bytes `rng.bytes` gives (after float draws, which leave no
    half-used 32-bit word), read straight from the bit generator (2.5x faster)."""
    size = int(np.prod(shape))
    words = rng.bit_generator.random_raw(-(-size // 4)).astype("<u8", copy=False)
    draws: NDArray[np.uint16] = words.view("<u2")[:size].reshape(shape)
    return draws


class NoiseRandomizer(Randomizer):
    kind = "noise"
    image_step = True
    KEYS = ("type", "gaussian", "blur")

    def __init__(self, section: Section) -> None:
        self.gaussian: Range = section.range("gaussian", (0.0, 6.0), 0.0)
        self.blur: Range = section.range("blur", (0.0, 1.0), 0.0, MAX_BLUR)
        section.done(self.KEYS)

    def post(
        self,
        rgb: NDArray[np.uint8],
        empty: NDArray[np.bool_] | None,
        rng: np.random.Generator,
    ) -> NDArray[np.uint8]:
        sigma = rng.uniform(*self.gaussian)
        blur = rng.uniform(*self.blur)
        if sigma <= 0:
            return gaussian_blur(rgb, blur) if blur > 0 else rgb
        taps = blur_taps(blur) if blur > 0 else [256]
        # Beyond +-255 levels every pixel clips the same: the table stays in int16.
        table = np.clip(np.rint(_QUANTILES * sigma), -255, 255).astype(np.int16)
        out = np.empty_like(rgb)
        for rows, levels in _bands(rgb, taps):
            # Drawn a band at a time: the words of one draw for the whole image, as every
            # band but the last holds a multiple of 4 draws (BAND_ROWS is).
            noisy = np.take(table, uniform16(rng, levels.shape))
            np.add(noisy, levels, out=noisy, casting="unsafe")  # levels are 0-255
            np.clip(noisy, 0, 255, out=noisy)
            out[rows] = noisy
        return out
