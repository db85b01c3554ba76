"""Uncompressed .npz archives written directly: the bytes Python's zipfile writes for them
(stored members dated 1980-01-01, mode 0600), with the arrays' memory handed to the file
as it is (no copy) and CRC-32 by zlib-ng: about twice as fast for a frame's label arrays."""

from __future__ import annotations

import io
import struct
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray
from zlib_ng import zlib_ng

from simbridge.errors import PerceptionError

__all__ = ["write_npz_to"]

_DATE = (1 << 5) | 1
"""MS-DOS date of 1980-01-01 (time 00:00:00 is 0)."""
_VERSION = 20
"""ZIP 2.0: what a stored member needs."""
_UNIX = 3
_MODE = 0o600 << 16
"""External attributes zipfile gives members written through ZipFile.open."""
_LIMIT = 0xFFFFFFFF
"""Sizes and offsets above this need ZIP64, which these archives do not use."""


def _npy_header(array: NDArray[Any]) -> bytes:
    """The .npy header (format 1.0, as np.save writes for small headers) of `array`."""
    buffer = io.BytesIO()
    header = np.lib.format.header_data_from_array_1_0(array)
    np.lib.format.write_array_header_1_0(buffer, header)
    return buffer.getvalue()


def write_npz_to(file: BinaryIO, arrays: dict[str, NDArray[Any]]) -> None:
    """Write `arrays` to `file` (at its start) as an uncompressed .npz that np.load reads."""
    central = []
    offset = 0
    for key, value in arrays.items():
        array = np.require(value, requirements="C")  # a 0-d array stays 0-d
        if array.dtype.hasobject:
            raise PerceptionError(f"npz: member {key!r} holds Python objects")
        if not key.isascii():  # zipfile flags UTF-8 names; these archives keep to ASCII
            raise PerceptionError(f"npz: member name {key!r} is not ASCII")
        name = f"{key}.npy".encode()
        header = _npy_header(array)
        size = len(header) + array.nbytes
        if offset + size + 30 + len(name) > _LIMIT:
            raise PerceptionError(f"npz: member {key!r} would need ZIP64 ({size} bytes)")
        data = array.reshape(-1).view(np.uint8).data
        crc = zlib_ng.crc32(data, zlib_ng.crc32(header))
        sizes = struct.pack("<III", crc, size, size)
        file.write(
            b"PK\x03\x04"
            + struct.pack("<HHHHH", _VERSION, 0, 0, 0, _DATE)
            + sizes
            + struct.pack("<HH", len(name), 0)
            + name
        )
        file.write(header)
        file.write(data)
        central.append(
            b"PK\x01\x02"
            + struct.pack("<BBHHHHH", _VERSION, _UNIX, _VERSION, 0, 0, 0, _DATE)
            + sizes
            + struct.pack("<HHHHHII", len(name), 0, 0, 0, 0, _MODE, offset)
            + name
        )
        offset += 30 + len(name) + size
    directory = b"".join(central)
    end = struct.pack(
        "<4sHHHHIIH", b"PK\x05\x06", 0, 0, len(central), len(central), len(directory), offset, 0
    )
    file.write(directory + end)
