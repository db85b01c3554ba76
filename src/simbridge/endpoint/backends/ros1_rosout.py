"""Forward simbridge's log records to /rosout, so ROS tools see the endpoint's events."""

from __future__ import annotations

import logging

from rospy.impl.rosout import RosOutHandler

__all__ = ["RosoutForwarder"]


class RosoutForwarder(logging.Handler):
    """Publishes each record on /rosout through rospy's own /rosout handlers."""

    def emit(self, record: logging.LogRecord) -> None:
        """Hand the record to every rospy /rosout handler (none before init_node)."""
        for handler in logging.getLogger("rosout").handlers:
            if isinstance(handler, RosOutHandler):
                handler.handle(record)
