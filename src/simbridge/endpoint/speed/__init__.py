"""The endpoint's speed tricks, each one a module that needs nothing else of the endpoint.

What each buys, with the figure measured for it (README, Endpoint and ROS 1 backend;
docs/ros1-speed.md):

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
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.endpoint.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.endpoint.speed.busypoll import BusyPollSelector
    from simbridge.endpoint.speed.splice import SpliceRelay, SpliceSink, can_splice
    from simbridge.endpoint.speed.writev import SocketWriter, write_chunks

__all__ = [
    "BusyPollSelector",
    "SocketWriter",
    "SpliceRelay",
    "SpliceSink",
    "can_splice",
    "write_chunks",
]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "BusyPollSelector": "busypoll",
        "SocketWriter": "writev",
        "SpliceRelay": "splice",
        "SpliceSink": "splice",
        "can_splice": "splice",
        "write_chunks": "writev",
    },
)
