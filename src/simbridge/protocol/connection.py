"""A sans-I/O ROS-TCP connection: bytes in, typed events out; commands in, bytes out.

It tracks the one piece of per-connection state the protocol has: after a
`__request`/`__response` header the next frame is the service frame it announces.
Used by both sides: the endpoint (role "endpoint") and the connector (role "client").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from simbridge.errors import ProtocolError
from simbridge.protocol.commands import (
    MAX_COMMAND_SIZE,
    Command,
    ServiceRequestHeader,
    ServiceResponseHeader,
    decode_command,
    shorten,
)
from simbridge.protocol.framing import (
    DEFAULT_MAX_FRAME_SIZE,
    KEEPALIVE,
    Frame,
    FrameDecoder,
    encode_frame,
)

__all__ = [
    "CommandReceived",
    "Event",
    "KeepaliveReceived",
    "MessageReceived",
    "ProtocolConnection",
    "ProtocolViolation",
    "Role",
    "ServiceRequestReceived",
    "ServiceResponseReceived",
]

Role = Literal["endpoint", "client"]


@dataclass(frozen=True, slots=True)
class KeepaliveReceived:
    """The peer sent an empty keepalive frame."""


@dataclass(slots=True)
class MessageReceived:
    """A serialized message for (or from) `topic` (not frozen: built per message).

    A large `payload` is the bytearray it was received into (see `Frame`), now the
    receiver's own: passing it on saves copying an image once more."""

    topic: str
    payload: bytes | bytearray


@dataclass(frozen=True, slots=True)
class CommandReceived:
    """A system command other than the service headers."""

    command: Command


@dataclass(frozen=True, slots=True)
class ServiceRequestReceived:
    """A `__request` header and the request frame that followed it."""

    srv_id: int
    service: str
    payload: bytes


@dataclass(frozen=True, slots=True)
class ServiceResponseReceived:
    """A `__response` header and the response frame that followed it."""

    srv_id: int
    service: str
    payload: bytes


@dataclass(frozen=True, slots=True)
class ProtocolViolation:
    """Bad input. When `fatal`, the byte stream is unusable and the connection must close."""

    text: str
    fatal: bool = False


Event = (
    KeepaliveReceived
    | MessageReceived
    | CommandReceived
    | ServiceRequestReceived
    | ServiceResponseReceived
    | ProtocolViolation
)

_KEEPALIVE_EVENT = KeepaliveReceived()


class ProtocolConnection:
    """Protocol state of one TCP connection, as seen by `role`."""

    __slots__ = ("_decoder", "_peer", "_pending", "closed", "role")

    def __init__(
        self,
        role: Role,
        max_payload: int = DEFAULT_MAX_FRAME_SIZE,
        decoder: FrameDecoder | None = None,
    ) -> None:
        """`decoder` overrides the default one (e.g. to give it a memory budget); an
        endpoint's default decoder refuses client commands over MAX_COMMAND_SIZE."""
        self.role: Role = role
        self._peer: Literal["client", "endpoint"] = "client" if role == "endpoint" else "endpoint"
        if decoder is None:
            limit = MAX_COMMAND_SIZE if role == "endpoint" else None
            decoder = FrameDecoder(max_payload, max_command=limit)
        self._decoder = decoder
        self._pending: ServiceRequestHeader | ServiceResponseHeader | None = None
        self.closed = False

    def receive_data(self, data: bytes | bytearray | memoryview) -> list[Event]:
        """Feed received bytes; returns the events they complete, in order.

        A fatal ProtocolViolation is the last event; afterwards the connection is closed.
        """
        if self.closed:
            return []
        try:
            frames = self._decoder.feed(data)
        except ProtocolError:
            frames = []
        return self._events(frames)

    @property
    def decoder(self) -> FrameDecoder:
        """The frame decoder (its `partial` and `discard()` serve timeouts and cleanup)."""
        return self._decoder

    def get_buffer(self) -> memoryview:
        """Memory to receive into (zero-copy path, see FrameDecoder.get_buffer)."""
        return self._decoder.get_buffer()

    def buffer_updated(self, nbytes: int) -> list[Event]:
        """`nbytes` arrived in the last `get_buffer()`; returns the events they complete."""
        if self.closed:
            return []
        try:
            frames = self._decoder.buffer_updated(nbytes)
        except ProtocolError:
            frames = []
        return self._events(frames)

    def message_runs(self, nbytes: int) -> tuple[str, list[bytes]] | None:
        """`buffer_updated(nbytes)` for the commonest reads: one or more plain topic
        messages repeating the header of the frame before them (a command each step, a
        ping, a burst on one topic; FrameDecoder.repeated_messages). Returns (topic,
        payloads), what the MessageReceived events `buffer_updated` would return hold;
        None, with nothing consumed, for any other read (call `buffer_updated`)."""
        if self.closed or self._pending is not None:
            return None
        return self._decoder.repeated_messages(nbytes)

    def waiting_message(self) -> tuple[str, bytearray] | None:
        """(topic, buffer) when the next bytes on the stream are the whole payload of a
        large plain topic message (not a service frame), `buffer` reserved for it: see
        FrameDecoder.waiting_large. After taking those bytes, call `message_moved`."""
        if self.closed or self._pending is not None:
            return None
        return self._decoder.waiting_large()

    def message_moved(self, *, taken: bool = False) -> None:
        """The payload `waiting_message` named was moved elsewhere (with `taken`, in its
        buffer, which goes with it): go on to the next frame."""
        self._decoder.skip_large(taken=taken)

    def _events(self, frames: list[Frame]) -> list[Event]:
        events: list[Event] = []
        append = events.append
        for frame in frames:
            dest = frame.destination
            if not dest.startswith("__"):
                if not dest:
                    if frame.payload:
                        append(ProtocolViolation("frame with an empty destination and a payload"))
                    else:
                        append(_KEEPALIVE_EVENT)
                    continue
                pending = self._pending
                if pending is None:
                    append(MessageReceived(dest, frame.payload))
                else:
                    self._pending = None
                    if isinstance(pending, ServiceRequestHeader):
                        append(ServiceRequestReceived(pending.srv_id, dest, bytes(frame.payload)))
                    else:
                        append(ServiceResponseReceived(pending.srv_id, dest, bytes(frame.payload)))
                continue
            try:
                command = decode_command(dest, bytes(frame.payload), sender=self._peer)
            except ProtocolError as exc:
                append(ProtocolViolation(str(exc)))
                continue
            except Exception as exc:  # any input that trips the decoder is reported, not raised
                append(ProtocolViolation(f"{shorten(dest)}: cannot decode: {exc!r}"[:500]))
                continue
            if self._pending is not None:
                append(
                    ProtocolViolation(
                        f"{self._pending.NAME} srv_id={self._pending.srv_id} must be "
                        f"followed by its service frame, got {shorten(dest)}; request dropped"
                    )
                )
                self._pending = None
            if isinstance(command, ServiceRequestHeader | ServiceResponseHeader):
                self._pending = command
            else:
                append(CommandReceived(command))
        error = self._decoder.error
        if error is not None:
            self.closed = True
            append(ProtocolViolation(str(error), fatal=True))
        return events

    @staticmethod
    def message(topic: str, payload: bytes) -> bytes:
        """Frame for a message on `topic`."""
        return encode_frame(topic, payload)

    @staticmethod
    def command(command: Command) -> bytes:
        """Frame for a system command."""
        return command.encode()

    @staticmethod
    def service_request(srv_id: int, service: str, payload: bytes) -> bytes:
        """`__request` header and request frame, back to back as the protocol requires."""
        return ServiceRequestHeader(srv_id).encode() + encode_frame(service, payload)

    @staticmethod
    def service_response(srv_id: int, service: str, payload: bytes) -> bytes:
        """`__response` header and response frame, back to back."""
        return ServiceResponseHeader(srv_id).encode() + encode_frame(service, payload)

    @staticmethod
    def keepalive() -> bytes:
        """The 8-byte keepalive frame."""
        return KEEPALIVE
