"""The endpoint's speed tricks, each one a module that needs nothing else of the endpoint.

What each buys, with the figure measured for it (README, Endpoint and ROS 1 backend;
docs/ros1-speed.md; where those have none, the module's own docstring says what was
measured when it was added):

- `splice`: a large payload (64 KiB or more, a camera image) for a single native TCPROS
  subscriber that keeps up goes from the client's socket to the subscriber's through a
  pipe, with no copy into the endpoint. A third of the endpoint's CPU per image in a
  back-to-back stream: 514-618 us spliced against 719-897 us copied per 640x480 image to a
  rospy subscriber (4 alternating pairs); a standalone relay of 921 KB messages used
  134-141 us a message against 408-458 us. At a paced 240 images/s the two cost the same
  (586-763 against 611-684 us), and the image row's rate did not move beyond the noise.
- `writev`: scatter-gather writes; a frame's header and payload leave in one `writev`
  without being joined, and `SocketWriter` keeps what the kernel did not take as views of
  the caller's buffers, so an image crosses user space at most once. Copies saved, not
  rate: a rospy-like reader took 1,160 images/s from a non-blocking `writev` of header and
  payload, 1,163 from a blocking `sendall` and 1,188 from one `send` (16 rounds, medians).
- `busypoll`: after handling I/O the loop polls a while before it sleeps, when answers
  have lately come back within that spin (`--busy-poll-us`, on for ros1). ROS 1 round
  trip p50 1.27-1.35x rospy's against 1.56-1.58x with the spin off (p99 1.31x against
  1.42x), for about 250 us of endpoint CPU per ping against 150 us; a one-way stream of
  1,000-10,000 Twists a second did not spin; the ros2 round trip did not change, so it is
  off there.
- `deferred`: what one read brings in (a client's frames, a ROS publisher's messages) is
  written at the end of that read's callback, one write per connection, instead of in a
  `call_soon`: a pass through the event loop (and its `epoll_wait`) saved on every hop of
  a round trip, and a burst still leaves in batches. No figure of its own in README or
  docs/ros1-speed.md.
- `malloc_tuning`: glibc's mmap and trim thresholds raised, so a large message buffer is
  reused from the heap instead of mapped fresh (and page-faulted through) for each one:
  about 300 page faults fewer per 640x480 rgb8 image relayed by the ROS 2 backend (module
  docstring; not in README or docs/ros1-speed.md).
- `gc_tuning`: `gc.freeze()` after a backend's startup, so full collections no longer walk
  rclpy's (or rospy's) objects: about an eighth of the endpoint's CPU relaying Twists
  sim -> ROS 2 had gone to them (module docstring; not in README or docs/ros1-speed.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.endpoint.speed.busypoll import BusyPollSelector
    from simbridge.endpoint.speed.deferred import DeferredWrites, deferred_writes
    from simbridge.endpoint.speed.gc_tuning import freeze_startup_objects
    from simbridge.endpoint.speed.malloc_tuning import keep_large_buffers
    from simbridge.endpoint.speed.splice import SpliceRelay, SpliceSink, can_splice
    from simbridge.endpoint.speed.writev import SocketWriter, write_chunks

__all__ = [
    "BusyPollSelector",
    "DeferredWrites",
    "SocketWriter",
    "SpliceRelay",
    "SpliceSink",
    "can_splice",
    "deferred_writes",
    "freeze_startup_objects",
    "keep_large_buffers",
    "write_chunks",
]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "BusyPollSelector": "busypoll",
        "DeferredWrites": "deferred",
        "SocketWriter": "writev",
        "SpliceRelay": "splice",
        "SpliceSink": "splice",
        "can_splice": "splice",
        "deferred_writes": "deferred",
        "freeze_startup_objects": "gc_tuning",
        "keep_large_buffers": "malloc_tuning",
        "write_chunks": "writev",
    },
)
