"""Publish a large CDR payload in place: rcl's `rcl_publish_serialized_message` via ctypes.

rclpy's `publish_raw(bytes)` takes its argument as a C++ `std::string`, so pybind11
copies the whole payload once more before rcl sees it (about 900 KB for a 640x480
rgb8 image), and it holds the GIL while Fast DDS copies the sample. Calling rcl
directly with a pointer into the received bytearray skips that copy and releases the
GIL meanwhile (ctypes does): about 40-50 us less per image here. For small messages
ctypes' own call overhead is larger than the copy it saves (a Twist took ~5.6 us this
way against ~3.7 us through publish_raw), so the backend uses this for the payloads the
session lends it (bytearrays of 64 KiB and more) and publish_raw for the rest.

Taking works the other way round (`DirectTake`): rclpy's `take_message(raw=True)` has
rmw copy the sample into a serialized message of its own and then copies that into a new
Python bytes object (about 100 us of the endpoint's ~700 us per image relayed to a
client, most of it that copy). `rcl_take_serialized_message` into one serialized message
kept per subscription (its buffer grows by rcutils' allocator, then stays) hands the
sample over as a memoryview of that buffer, lent until the next take.

Needs the rclpy publisher's or subscription's `pointer` (its `rcl_publisher_t *` or
`rcl_subscription_t *`) and librcl as loaded by rclpy; `direct_publish` and
`direct_take` return None when either is missing, and callers fall back.
"""

from __future__ import annotations

import ctypes
import functools
import logging
from collections.abc import Callable
from typing import Any, NamedTuple

from simbridge.errors import EndpointError

__all__ = ["DirectTake", "direct_publish", "direct_take"]

_log = logging.getLogger(__name__)

_TAKE_FAILED = 401
"""RCL_RET_SUBSCRIPTION_TAKE_FAILED: nothing was waiting (not an error)."""


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


class _Rcl(NamedTuple):
    """The C functions used here, from the libraries rclpy loaded."""

    publish: Any
    take: Any
    get_error: Any
    reset_error: Any
    default_allocator: Any
    array_init: Any
    array_fini: Any


@functools.cache
def _rcl() -> _Rcl | None:
    """The functions from the libraries rclpy loaded (dlopen finds a loaded library by its
    soname), else None."""
    try:
        rcl = ctypes.CDLL("librcl.so")
        rcutils = ctypes.CDLL("librcutils.so")
        functions = _Rcl(
            rcl.rcl_publish_serialized_message,
            rcl.rcl_take_serialized_message,
            rcutils.rcutils_get_error_string,
            rcutils.rcutils_reset_error,
            rcutils.rcutils_get_default_allocator,
            rcutils.rcutils_uint8_array_init,
            rcutils.rcutils_uint8_array_fini,
        )
    except (OSError, AttributeError) as exc:
        _log.debug("rcl not reachable through ctypes (%s): images go through rclpy", exc)
        return None
    message = ctypes.POINTER(_SerializedMessage)
    functions.publish.argtypes = (ctypes.c_void_p, message, ctypes.c_void_p)
    functions.publish.restype = ctypes.c_int
    functions.take.argtypes = (ctypes.c_void_p, message, ctypes.c_void_p, ctypes.c_void_p)
    functions.take.restype = ctypes.c_int
    functions.get_error.argtypes = ()
    functions.get_error.restype = _ErrorString
    functions.reset_error.argtypes = ()
    functions.reset_error.restype = None
    functions.default_allocator.argtypes = ()
    functions.default_allocator.restype = _Allocator
    functions.array_init.argtypes = (message, ctypes.c_size_t, ctypes.POINTER(_Allocator))
    functions.array_init.restype = ctypes.c_int
    functions.array_fini.argtypes = (message,)
    functions.array_fini.restype = ctypes.c_int
    return functions


def _error(functions: _Rcl, what: str, ret: int) -> EndpointError:
    """rcl's error text for a failed call (and rcl's error state reset)."""
    text = functions.get_error().str.decode(errors="replace")
    functions.reset_error()
    return EndpointError(f"{what} returned {ret}: {text}")


def direct_publish(publisher: Any) -> Callable[[bytes | bytearray], None] | None:
    """A function that publishes CDR through `publisher` (an rclpy Publisher) without
    copying it first: a bytearray in place, bytes from the object's own (read-only) buffer,
    which rcl only reads; None when rcl or the publisher's pointer cannot be reached. The
    caller keeps the publisher alive (not destroyed) while calling it."""
    inner = getattr(publisher, "_Publisher__publisher", None)
    pointer = getattr(inner, "pointer", None)
    functions = _rcl()
    if functions is None or not isinstance(pointer, int) or not pointer:
        return None
    publish = functions.publish

    def publish_in_place(payload: bytes | bytearray) -> None:
        size = len(payload)
        if isinstance(payload, bytearray):
            data: Any = (ctypes.c_char * size).from_buffer(payload)
            address = ctypes.addressof(data)
        else:
            data = ctypes.c_char_p(payload)  # points into the bytes object, kept alive here
            address = ctypes.cast(data, ctypes.c_void_p).value or 0
        message = _SerializedMessage(address, size, size)
        ret = publish(pointer, ctypes.byref(message), None)
        if ret != 0:
            raise _error(functions, "rcl_publish_serialized_message", ret)

    return publish_in_place


class DirectTake:
    """Takes a subscription's messages into one buffer of its own (see the module).

    `take()` returns the next message as a memoryview of that buffer, or None when none
    is waiting. The view is lent: the next `take()` or `close()` overwrites or frees the
    memory under it, so the caller copies what it keeps and releases the view (then a
    view kept by mistake raises instead of reading freed memory). Call on one thread,
    while the subscription is alive (its handle held); `close()` frees the buffer.
    """

    __slots__ = ("_functions", "_message", "_pointer", "_ref")

    def __init__(self, functions: _Rcl, pointer: int) -> None:
        self._functions = functions
        self._pointer = pointer
        self._message = _SerializedMessage()
        allocator = functions.default_allocator()
        ret = functions.array_init(ctypes.byref(self._message), 0, ctypes.byref(allocator))
        if ret != 0:
            raise _error(functions, "rcutils_uint8_array_init", ret)
        self._ref = ctypes.byref(self._message)

    def take(self) -> memoryview | None:
        """The next message (lent, see the class), or None."""
        message = self._message
        ret = self._functions.take(self._pointer, self._ref, None, None)
        if ret == _TAKE_FAILED:
            return None
        if ret != 0:
            raise _error(self._functions, "rcl_take_serialized_message", ret)
        if not message.buffer_length:
            return memoryview(b"")
        data = (ctypes.c_ubyte * message.buffer_length).from_address(message.buffer)
        return memoryview(data).cast("B")

    def close(self) -> None:
        """Free the buffer (no view of it may be in use)."""
        if self._message.buffer_capacity:
            self._functions.array_fini(self._ref)
        self._message = _SerializedMessage()
        self._ref = ctypes.byref(self._message)


def direct_take(subscription: Any) -> DirectTake | None:
    """A `DirectTake` of `subscription` (an rclpy Subscription), or None when rcl or the
    subscription's pointer cannot be reached."""
    pointer = getattr(getattr(subscription, "handle", None), "pointer", None)
    functions = _rcl()
    if functions is None or not isinstance(pointer, int) or not pointer:
        return None
    return DirectTake(functions, pointer)
