"""Publish a large CDR payload in place: rcl's `rcl_publish_serialized_message` via ctypes.

rclpy's `publish_raw(bytes)` takes its argument as a C++ `std::string`, so pybind11
copies the whole payload once more before rcl sees it (about 900 KB for a 640x480
rgb8 image), and it holds the GIL while Fast DDS copies the sample. Calling rcl
directly with a pointer into the received bytearray skips that copy and releases the
GIL meanwhile (ctypes does): about 40-50 us less per image here. For small messages
ctypes' own call overhead is larger than the copy it saves (a Twist took ~5.6 us this
way against ~3.7 us through publish_raw), so the backend uses this for the payloads the
session lends it (bytearrays of 64 KiB and more) and publish_raw for the rest.

Needs the rclpy publisher's `pointer` (its `rcl_publisher_t *`) and librcl as loaded by
rclpy; `direct_publish` returns None when either is missing, and callers fall back.
"""

from __future__ import annotations

import ctypes
import functools
import logging
from collections.abc import Callable
from typing import Any

from simbridge.errors import EndpointError

__all__ = ["direct_publish"]

_log = logging.getLogger(__name__)


class _Allocator(ctypes.Structure):
    """rcutils_allocator_t: four function pointers and a state (unused by publishing)."""

    _fields_ = (
        ("allocate", ctypes.c_void_p),
        ("deallocate", ctypes.c_void_p),
        ("reallocate", ctypes.c_void_p),
        ("zero_allocate", ctypes.c_void_p),
        ("state", ctypes.c_void_p),
    )


class _SerializedMessage(ctypes.Structure):
    """rcl_serialized_message_t (rcutils_uint8_array_t)."""

    _fields_ = (
        ("buffer", ctypes.c_void_p),
        ("buffer_length", ctypes.c_size_t),
        ("buffer_capacity", ctypes.c_size_t),
        ("allocator", _Allocator),
    )


class _ErrorString(ctypes.Structure):
    """rcutils_error_string_t, returned by value."""

    _fields_ = (("str", ctypes.c_char * 1024),)


@functools.cache
def _rcl() -> tuple[Any, Any, Any] | None:
    """(rcl_publish_serialized_message, rcutils_get_error_string, rcutils_reset_error) from
    the libraries rclpy loaded (dlopen finds a loaded library by its soname), else None."""
    try:
        rcl = ctypes.CDLL("librcl.so")
        rcutils = ctypes.CDLL("librcutils.so")
        publish = rcl.rcl_publish_serialized_message
        get_error = rcutils.rcutils_get_error_string
        reset_error = rcutils.rcutils_reset_error
    except (OSError, AttributeError) as exc:
        _log.debug("rcl not reachable through ctypes (%s): images go through publish_raw", exc)
        return None
    publish.argtypes = (ctypes.c_void_p, ctypes.POINTER(_SerializedMessage), ctypes.c_void_p)
    publish.restype = ctypes.c_int
    get_error.argtypes = ()
    get_error.restype = _ErrorString
    reset_error.argtypes = ()
    reset_error.restype = None
    return publish, get_error, reset_error


def direct_publish(publisher: Any) -> Callable[[bytearray], None] | None:
    """A function that publishes a bytearray of CDR through `publisher` (an rclpy
    Publisher) without copying it first; None when rcl or the publisher's pointer cannot
    be reached. The caller keeps the publisher alive (not destroyed) while calling it."""
    inner = getattr(publisher, "_Publisher__publisher", None)
    pointer = getattr(inner, "pointer", None)
    functions = _rcl()
    if functions is None or not isinstance(pointer, int) or not pointer:
        return None
    publish, get_error, reset_error = functions

    def publish_in_place(payload: bytearray) -> None:
        size = len(payload)
        data = (ctypes.c_char * size).from_buffer(payload)
        message = _SerializedMessage(ctypes.addressof(data), size, size)
        ret = publish(pointer, ctypes.byref(message), None)
        if ret != 0:
            text = get_error().str.decode(errors="replace")
            reset_error()
            raise EndpointError(f"rcl_publish_serialized_message returned {ret}: {text}")

    return publish_in_place
