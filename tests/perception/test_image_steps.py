"""The fast image code of datagen: its own PNG encoder (read back by Pillow, pixel for
pixel; colour deflated to zlib's own bytes) and the integer blur and noise of the `noise`
randomiser."""

from __future__ import annotations

import io
import struct
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from PIL import Image
from scipy import ndimage

from simbridge.errors import PerceptionError
from simbridge.perception.png import png_bytes
from simbridge.perception.randomizers.image_effects import (
    NoiseRandomizer,
    blur_taps,
    gaussian_blur,
    uniform16,
)
from simbridge.perception.section import Section
from simbridge.sim.scene.located import Where


def _read(data: bytes) -> NDArray[np.generic]:
    return np.asarray(Image.open(io.BytesIO(data)))


@pytest.mark.parametrize("level", [0, 1, 9])
def test_png_round_trips_every_image_kind_datagen_writes(level: int) -> None:
    rng = np.random.default_rng(3)
    images: dict[str, NDArray[np.generic]] = {
        "rgb": rng.integers(0, 256, (37, 53, 3), dtype=np.uint8),
        "grey": rng.integers(0, 256, (37, 53), dtype=np.uint8),
        "depth": rng.integers(0, 65536, (37, 53), dtype=np.uint16),
        "mask": rng.random((37, 53)) < 0.3,  # 53 columns: the last byte of a row is partial
    }
    for name, image in images.items():
        data = png_bytes(image, level)
        back = _read(data)
        assert back.shape == image.shape, name
        assert np.array_equal(back.astype(image.dtype), image), name
        assert png_bytes(image, level) == data, name  # a pure function of pixels and level


def _idat(png: bytes) -> bytes:
    """The IDAT chunk's data of a PNG with one IDAT right after its IHDR."""
    (length,) = struct.unpack(">I", png[33:37])
    assert png[37:41] == b"IDAT"
    return png[41 : 41 + length]


@settings(max_examples=60, deadline=None)
@given(
    level=st.integers(0, 9),
    height=st.integers(1, 40),
    width=st.integers(1, 70),
    runs=st.integers(1, 30),
    noisy=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_colour_pngs_are_zlibs_own_bytes(
    level: int, height: int, width: int, *, runs: int, noisy: float, seed: int
) -> None:
    # Colour goes through zlib-ng for speed; the files must stay what zlib itself writes, so
    # a dataset's bytes do not hang on which deflate library a worker has (noise from none
    # to every pixel: both deflate modes).
    rng = np.random.default_rng(seed)
    pixels = height * width
    flat = np.repeat(rng.integers(0, 256, (runs, 3)), -(-pixels // runs), axis=0)[:pixels]
    noise = rng.integers(-3, 4, (pixels, 3)) * (rng.random((pixels, 1)) < noisy)
    image = np.clip(flat + noise, 0, 255).astype(np.uint8).reshape(height, width, 3)
    idat = _idat(png_bytes(image, level))
    assert idat in (_zlib(idat, level, zlib.Z_RLE), _zlib(idat, level, zlib.Z_HUFFMAN_ONLY))


@pytest.mark.parametrize("level", [0, 1, 6, 9])
@pytest.mark.parametrize(("sigma", "strategy"), [(0, zlib.Z_RLE), (4, zlib.Z_HUFFMAN_ONLY)])
def test_a_frame_png_is_run_length_coded_and_a_noisy_one_huffman_coded(
    level: int, sigma: int, strategy: int
) -> None:
    # A frame's size: past 64 kB, where stored blocks (level 0) start to differ. Runs pay
    # on flat colour; noise leaves too few to pay for looking for them.
    rng = np.random.default_rng(11)
    scene = np.repeat(np.repeat(rng.integers(0, 256, (12, 16, 3)), 40, axis=0), 40, axis=1)
    image = np.clip(scene + rng.normal(0, sigma, scene.shape), 0, 255).astype(np.uint8)
    idat = _idat(png_bytes(image, level))
    assert idat == _zlib(idat, level, strategy)


def _zlib(idat: bytes, level: int, strategy: int) -> bytes:
    """What zlib itself writes for `idat`'s data at `level` in `strategy`."""
    packer = zlib.compressobj(level, zlib.DEFLATED, 15, 9, strategy)
    return packer.compress(zlib.decompress(idat)) + packer.flush()


def test_png_refuses_an_image_it_cannot_encode() -> None:
    with pytest.raises(PerceptionError, match=r"float32 image of shape \(4, 4\)"):
        png_bytes(np.zeros((4, 4), dtype=np.float32), 1)


def test_blur_keeps_flat_images_and_matches_a_gaussian_filter() -> None:
    flat = np.full((20, 30, 3), 201, dtype=np.uint8)
    assert np.array_equal(gaussian_blur(flat, 2.5), flat)
    rng = np.random.default_rng(5)
    image = rng.integers(0, 256, (60, 80, 3), dtype=np.uint8)
    for sigma in (0.5, 0.8, 1.5, 3.0):
        ours = gaussian_blur(image, sigma).astype(float)
        exact = ndimage.gaussian_filter(image.astype(float), (sigma, sigma, 0), mode="nearest")
        assert np.abs(ours - exact).max() <= 2.0, sigma  # weights in 1/256 steps, rounded
        assert ours.std() < image.std()
    # A sigma too small to move a level leaves the image as it is.
    assert gaussian_blur(image, 0.1) is image


def _blurred_whole(image: NDArray[np.uint8], taps: list[int]) -> NDArray[np.uint8]:
    """The integer blur over the whole image at once: edge-padded, rows then columns, each
    pass rounded to levels."""
    reach, levels = len(taps) - 1, image.astype(np.int64)
    for axis in (1, 0):
        pad = [(0, 0)] * image.ndim
        pad[axis] = (reach, reach)
        padded = np.pad(levels, pad, mode="edge")
        size = levels.shape[axis]
        total = np.zeros_like(levels)
        for k in range(-reach, reach + 1):
            total += taps[abs(k)] * np.take(padded, np.arange(reach + k, reach + k + size), axis)
        levels = (total + 128) >> 8
    return levels.astype(np.uint8)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 100),
    st.integers(1, 40),
    st.sampled_from([(), (3,)]),
    st.floats(0.3, 3.0),
    st.integers(0, 2**32 - 1),
)
def test_the_blur_a_band_at_a_time_is_the_whole_images(
    height: int, width: int, channels: tuple[int, ...], sigma: float, seed: int
) -> None:
    # Bands of rows (kept in cache) must join seamlessly: rows near a band's edge read the
    # neighbouring bands, and the image's edge rows and columns repeat.
    image = np.random.default_rng(seed).integers(0, 256, (height, width, *channels), np.uint8)
    taps = blur_taps(sigma)
    assert sum(taps) + sum(taps[1:]) == 256
    expected = image if len(taps) == 1 else _blurred_whole(image, taps)
    assert np.array_equal(gaussian_blur(image, sigma), expected)


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 100), st.integers(1, 30), st.integers(0, 2**32 - 1))
def test_each_pixels_noise_follows_its_draw_in_the_whole_images_stream(
    height: int, width: int, seed: int
) -> None:
    # The noise is drawn a band at a time; each pixel must get the draw it would get from
    # one draw for the whole image (the same datasets), through a rising quantile table.
    grey = np.full((height, width, 3), 128, dtype=np.uint8)  # sigma 5: never clipped
    out = _noise(5.0, 0.0).post(grey, None, np.random.default_rng(seed))
    reference = np.random.default_rng(seed)
    reference.uniform(5.0, 5.0), reference.uniform(0.0, 0.0)  # what post draws first
    draws = uniform16(reference, grey.shape).ravel()
    order = np.argsort(draws, kind="stable")
    noise = out.astype(int).ravel()[order] - 128
    assert (np.diff(noise) >= 0).all()


def _noise(gaussian: float, blur: float) -> NoiseRandomizer:
    data = {"type": "noise", "gaussian": gaussian, "blur": blur}
    return NoiseRandomizer(Section(data, Where("perception.randomizers[0]", None, None)))


def test_noise_has_the_asked_standard_deviation_and_is_seeded() -> None:
    grey = np.full((200, 300, 3), 128, dtype=np.uint8)
    for sigma in (1.0, 4.0):
        step = _noise(sigma, 0.0)
        out = step.post(grey, None, np.random.default_rng(9))
        noise = out.astype(float) - 128
        assert abs(noise.mean()) < 0.05
        assert noise.std() == pytest.approx(sigma, rel=0.05)
        again = step.post(grey, None, np.random.default_rng(9))
        assert np.array_equal(out, again)
    # Clipped at the ends of the 8-bit range, never wrapped.
    white = np.full((50, 50, 3), 255, dtype=np.uint8)
    assert _noise(6.0, 0.0).post(white, None, np.random.default_rng(1)).min() > 200


@settings(max_examples=60, deadline=None)
@given(
    st.integers(0, 2**32),
    st.integers(0, 3),
    st.tuples(st.integers(1, 40), st.integers(1, 40), st.sampled_from([1, 3])),
)
def test_noise_draws_are_the_bytes_rng_bytes_gives(
    seed: int, floats: int, shape: tuple[int, int, int]
) -> None:
    """The noise's 16-bit draws read the bit generator directly: the same bytes (so the
    same datasets) as `rng.bytes` after the float draws that come before them."""
    direct, reference = np.random.default_rng(seed), np.random.default_rng(seed)
    for rng in (direct, reference):
        rng.random(floats)
    size = shape[0] * shape[1] * shape[2]
    expected = np.frombuffer(reference.bytes(2 * size), dtype="<u2").reshape(shape)
    assert np.array_equal(uniform16(direct, shape), expected)


def test_blur_beyond_its_bound_is_refused() -> None:
    with pytest.raises(PerceptionError, match="blur"):
        _noise(1.0, 4.0)
