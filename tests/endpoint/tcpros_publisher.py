"""A raw ROS 1 publisher node for tests: it registers with a real master over XML-RPC,
answers requestTopic from its own slave API and treats each TCPROS connection it
accepts as its plan says, so a test can drop a subscriber's connection while the
publisher stays registered."""

from __future__ import annotations

import socket
import struct
import threading
import time
import xmlrpc.client
from collections.abc import Sequence
from typing import Any, Literal
from xmlrpc.server import SimpleXMLRPCServer

from simbridge.protocol.tcpros import TcprosDecoder, encode_header

__all__ = ["Plan", "RawPublisher"]

Plan = Literal["once", "close", "serve"]
"""What to do with an accepted connection: "once" answers the header, sends the
message "first" and closes; "close" closes at once, before any header; "serve"
answers the header and keeps the connection for `publish`."""


class RawPublisher:
    """One topic published by a node of its own, outside rospy."""

    def __init__(
        self,
        master_uri: str,
        topic: str,
        msg_type: str,
        md5sum: str,
        definition: str,
        *,
        plan: Sequence[Plan],
        then: Plan = "serve",
        callerid: str = "/sb_raw_publisher",
    ) -> None:
        self.master_uri = master_uri
        self.topic = topic
        self.callerid = callerid
        self.plan = list(plan)
        self.then = then
        """What to do with the connections after those of the plan."""
        self.accepted: list[float] = []
        """When each connection was accepted (time.monotonic())."""
        self.closed: list[float] = []
        """When this side closed a connection (time.monotonic())."""
        self._type = (msg_type, md5sum, definition)
        self._lock = threading.Lock()
        self._serving: list[socket.socket] = []
        self._stop = threading.Event()
        self._listener = socket.create_server(("127.0.0.1", 0))
        self._listener.settimeout(0.1)
        self.port: int = self._listener.getsockname()[1]
        self._api = SimpleXMLRPCServer(("127.0.0.1", 0), logRequests=False, allow_none=True)
        self._api.register_function(self._request_topic, "requestTopic")
        self.uri = f"http://127.0.0.1:{self._api.server_address[1]}/"
        self._threads = [
            threading.Thread(target=self._accept, daemon=True),
            threading.Thread(target=self._api.serve_forever, args=(0.1,), daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    def _request_topic(self, caller_id: Any, topic: Any, protocols: Any) -> list[Any]:
        if topic != self.topic:
            return [0, f"{topic} is not published here", []]
        return [1, "ready", ["TCPROS", "127.0.0.1", self.port]]

    def _master(self) -> Any:
        return xmlrpc.client.ServerProxy(self.master_uri)

    def register(self) -> None:
        code, message, _ = self._master().registerPublisher(
            self.callerid, self.topic, self._type[0], self.uri
        )
        assert code == 1, message

    def unregister(self) -> None:
        code, message, _ = self._master().unregisterPublisher(self.callerid, self.topic, self.uri)
        assert code == 1, message

    def _accept(self) -> None:
        while not self._stop.is_set():
            try:
                conn, _ = self._listener.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            with self._lock:
                index = len(self.accepted)
                self.accepted.append(time.monotonic())
            action = self.plan[index] if index < len(self.plan) else self.then
            if action == "close":
                self._close(conn)
                continue
            conn.settimeout(10)
            try:
                self._handshake(conn)
            except OSError:
                self._close(conn)
                continue
            if action == "once":
                conn.sendall(_frame(_ros_string("first")))
                self._close(conn)
            else:
                with self._lock:
                    self._serving.append(conn)

    def _handshake(self, conn: socket.socket) -> None:
        decoder = TcprosDecoder(1 << 20)
        while decoder.header is None:
            data = conn.recv(65536)
            if not data:
                raise OSError("the subscriber left before its header")
            decoder.feed(data)
        msg_type, md5sum, definition = self._type
        conn.sendall(
            encode_header(
                {
                    "callerid": self.callerid,
                    "latching": "0",
                    "md5sum": md5sum,
                    "message_definition": definition,
                    "topic": self.topic,
                    "type": msg_type,
                }
            )
        )

    def _close(self, conn: socket.socket) -> None:
        with self._lock:  # noted first: the subscriber cannot see the close before
            self.closed.append(time.monotonic())
        conn.close()

    def serving(self) -> int:
        """How many connections take messages now."""
        with self._lock:
            return len(self._serving)

    def publish(self, text: str) -> None:
        """Send a std_msgs/String to every served connection."""
        with self._lock:
            conns = list(self._serving)
        for conn in conns:
            conn.sendall(_frame(_ros_string(text)))

    def drop(self) -> None:
        """Close every served connection (the node stays registered, if it was)."""
        with self._lock:
            conns, self._serving = self._serving, []
        for conn in conns:
            self._close(conn)

    def close(self) -> None:
        self._stop.set()
        self.drop()
        self._api.shutdown()
        self._api.server_close()
        self._listener.close()
        for thread in self._threads:
            thread.join(5)


def _ros_string(text: str) -> bytes:
    raw = text.encode()
    return struct.pack("<I", len(raw)) + raw


def _frame(payload: bytes) -> bytes:
    return struct.pack("<I", len(payload)) + payload
