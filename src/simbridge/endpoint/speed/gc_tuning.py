"""Leave the objects a backend made at startup out of later garbage collections.

A relayed burst keeps thousands of small frame and event objects alive at once (one
read of a socket holds every frame it completed), which makes CPython's collector run
its full collection every few tens of thousands of messages. A full collection walks
every tracked object in the process, and after `import rclpy` and the message
packages that is most of the work: about an eighth of the endpoint's CPU relaying
Twists sim -> ROS 2 went to it. `gc.freeze()` moves what exists now (modules,
functions, type support, the node) to the permanent generation, so collections
walk only what was made since. Those objects are never collected; they live for the
process anyway.
"""

from __future__ import annotations

import gc
import logging

__all__ = ["freeze_startup_objects"]

_log = logging.getLogger(__name__)


def freeze_startup_objects() -> int:
    """Collect once, then freeze every object that survived; returns how many are frozen."""
    gc.collect()
    gc.freeze()
    frozen = gc.get_freeze_count()
    _log.debug("%d startup objects left out of garbage collection", frozen)
    return frozen
