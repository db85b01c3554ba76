"""The large-payload path (scatter-gather writes, reused receive buffer) keeps every byte
in order, for a fast reader and for one that lags so writes are only partly accepted."""

from __future__ import annotations

import os
import socket
import struct
import time

from simbridge.endpoint import EndpointOptions, EndpointThread
from simbridge.protocol import (
    CommandReceived,
    MessageReceived,
    Publish,
    Subscribe,
    TopicListReply,
    TopicListRequest,
    encode_frame,
)
from tests.endpoint.rawclient import RawClient


def _sync(client: RawClient) -> None:
    client.send(TopicListRequest().encode())
    client.expect(
        lambda e: isinstance(e, CommandReceived) and isinstance(e.command, TopicListReply)
    )


def test_images_arrive_byte_exact_to_fast_and_lagging_readers() -> None:
    options = EndpointOptions(port=0, max_memory=512 * 1024 * 1024)
    with EndpointThread(options) as ep:
        fast, slow = RawClient(ep.port), RawClient(ep.port)
        slow.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 64 * 1024)
        for client in (fast, slow):
            client.send(Subscribe("/img", "sensor_msgs/Image", queue_size=100).encode())
            _sync(client)
        pub = RawClient(ep.port)
        pub.send(Publish("/img", "sensor_msgs/Image").encode())
        _sync(pub)
        images = [struct.pack("<I", i) + os.urandom(921_600 + 37 * i) for i in range(40)]
        for image in images:
            pub.send(encode_frame("/img", image))
        _sync(pub)
        for client in (fast, slow):
            got: list[bytes] = []
            deadline = time.monotonic() + 30
            while len(got) < len(images) and time.monotonic() < deadline:
                event = client.expect(lambda e: isinstance(e, MessageReceived), timeout=30)
                got.append(event.payload)
            assert got == images
