"""One bag file being written: a rosbag2 MCAP file (`.mcap`) or a ROS 1 bag (`.bag`).

Both come from the `rosbags` writers, with each topic's message definition taken from
the message registry the payloads were serialized with, so every reader (rosbag,
rosbags, the mcap tools, Foxglove) decodes them without simbridge's help.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from rosbags.interfaces import Connection
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer

from simbridge.errors import SimError
from simbridge.messages import MessageRegistry
from simbridge.messages.names import store_name

__all__ = ["BagFile", "bag_kind"]

BagKind = Literal["mcap", "bag"]


def bag_kind(path: str | Path) -> BagKind:
    """ "mcap" for a `.mcap` file, "bag" for a ROS 1 `.bag`; SimError for anything else."""
    suffix = Path(path).suffix.lower()
    if suffix == ".mcap":
        return "mcap"
    if suffix == ".bag":
        return "bag"
    raise SimError(
        f"recording '{path}': unknown file type {suffix or '(none)'!r}; expected a .mcap "
        "(rosbag2 MCAP) or .bag (ROS 1 bag) file name"
    )


@dataclass(frozen=True)
class _Key:
    topic: str
    msg_type: str


class BagFile:
    """Writes messages into `path` (created; an existing file is refused)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.kind = bag_kind(self.path)
        self.wire_format: Literal["ros1", "cdr"] = "ros1" if self.kind == "bag" else "cdr"
        """The serialization the file stores."""
        if self.path.exists():
            raise SimError(f"recording '{self.path}': the file exists; not overwriting it")
        self._dir = self.path.with_name(self.path.name + ".rosbag2")
        self._ros1: Ros1Writer | None = None
        self._ros2: Ros2Writer | None = None
        self._connections: dict[_Key, Connection] = {}
        try:
            if self.kind == "bag":
                self._ros1 = Ros1Writer(self.path)
                self._ros1.open()
            else:
                if self._dir.exists():
                    raise SimError(f"recording '{self.path}': '{self._dir}' is in the way")
                self._ros2 = Ros2Writer(self._dir, version=9, storage_plugin=StoragePlugin.MCAP)
                self._ros2.open()
        except OSError as exc:
            raise SimError(f"recording '{self.path}': cannot create it: {exc}") from exc

    def connection(
        self, topic: str, msg_type: str, registry: MessageRegistry, latched: bool
    ) -> Connection:
        """The file's connection for `topic` carrying `msg_type` (added on first use)."""
        key = _Key(topic, msg_type)
        conn = self._connections.get(key)
        if conn is not None:
            return conn
        canonical = registry.resolve(msg_type)
        if self._ros1 is not None:
            if registry.protocol == "ROS1":
                msgdef, md5 = registry.definition(canonical), registry.md5(canonical)
            else:
                msgdef, md5 = registry.typestore.generate_msgdef(store_name(canonical), 1)
            conn = self._ros1.add_connection(
                topic,
                store_name(canonical),
                msgdef=msgdef,
                md5sum=md5,
                callerid="/simbridge",
                latching=1 if latched else 0,
            )
        else:
            assert self._ros2 is not None
            conn = self._ros2.add_connection(
                topic, store_name(canonical), typestore=registry.typestore
            )
        self._connections[key] = conn
        return conn

    def write(self, conn: Connection, stamp_ns: int, data: bytes) -> None:
        """Append one serialized message (in `wire_format`) at `stamp_ns`."""
        writer = self._ros1 if self._ros1 is not None else self._ros2
        assert writer is not None
        writer.write(conn, stamp_ns, data)

    def close(self) -> None:
        """Finish the file. For MCAP the rosbag2 directory rosbags writes is folded into
        the one self-contained `.mcap` file that was asked for."""
        if self._ros1 is not None:
            self._ros1.close()
            self._ros1 = None
        if self._ros2 is not None:
            self._ros2.close()
            self._ros2 = None
            inner = self._dir / f"{self._dir.name}.mcap"
            inner.replace(self.path)
            shutil.rmtree(self._dir)
