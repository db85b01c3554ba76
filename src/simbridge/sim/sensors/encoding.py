"""Image compression for sensor_msgs/CompressedImage (JPEG or PNG through Pillow)."""

from __future__ import annotations

import io

import numpy as np
from numpy.typing import NDArray
from PIL import Image

from simbridge.errors import SimError

__all__ = ["COMPRESSED_FORMATS", "compressed_format_string", "encode_rgb"]

COMPRESSED_FORMATS = ("jpeg", "png")


def encode_rgb(rgb: NDArray[np.uint8], fmt: str, quality: int = 90) -> bytes:
    """Compress an (H, W, 3) rgb8 image; `quality` (1-95) applies to JPEG only."""
    if fmt not in COMPRESSED_FORMATS:
        raise SimError(f"image format {fmt!r} is not supported; choose one of {COMPRESSED_FORMATS}")
    buffer = io.BytesIO()
    image = Image.fromarray(rgb, mode="RGB")
    if fmt == "jpeg":
        image.save(buffer, format="JPEG", quality=quality)
    else:
        image.save(buffer, format="PNG", compress_level=1)
    return buffer.getvalue()


def compressed_format_string(fmt: str) -> str:
    """CompressedImage.format as image_transport writes it: 'rgb8; jpeg compressed bgr8'."""
    return f"rgb8; {fmt} compressed bgr8"
