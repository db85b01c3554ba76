"""Forward simbridge's log records to /rosout, so ROS tools see the endpoint's events."""

from __future__ import annotations

import logging

import rospy
from rospy.impl.rosout import RosOutHandler

__all__ = ["RosoutForwarder"]


class RosoutForwarder(logging.Handler):
    """Publishes each record on /rosout through rospy's own /rosout handlers."""

    def emit(self, record: logging.LogRecord) -> None:
        """Hand the record to every rospy /rosout handler (none before init_node).

        Nothing once the node shuts down: rospy asks the master for a parameter on every
        /rosout message, and a node the master replaced by a same-name newcomer would
        thereby register its old address again and get the newcomer shut down.
        """
        if rospy.core.is_shutdown_requested():
            return
        for handler in logging.getLogger("rosout").handlers:
            if isinstance(handler, RosOutHandler):
                handler.handle(record)
