"""A minimal viser websocket client for tests: what a browser tab sends and receives,
without the page. It connects with the server's protocol version, drains every message
the server sends (as a live tab does), and sends GUI and gizmo messages as a user's
clicks and drags would."""

from __future__ import annotations

import threading
from typing import Any

import msgspec
import viser
import viser._messages as messages
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import ClientConnection, connect

__all__ = ["ViserClient"]


class ViserClient:
    """Connect to a viser server on 127.0.0.1:`port`; `close()` hangs up."""

    def __init__(self, port: int, *, drain: bool = True) -> None:
        self.socket: ClientConnection = connect(
            f"ws://127.0.0.1:{port}",
            subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
            max_size=None,
            open_timeout=10,
        )
        # A page reports its camera first; viser counts a client as connected from then.
        self.send(
            messages.ViewerCameraMessage(
                wxyz=(1.0, 0.0, 0.0, 0.0),
                position=(2.0, 2.0, 2.0),
                fov=1.0,
                near=0.01,
                far=100.0,
                image_height=700,
                image_width=900,
                look_at=(0.0, 0.0, 0.0),
                up_direction=(0.0, 0.0, 1.0),
            )
        )
        self.received = 0
        """Messages (frames) received so far."""
        self._thread: threading.Thread | None = None
        if drain:
            self._thread = threading.Thread(target=self._drain, daemon=True)
            self._thread.start()

    def _drain(self) -> None:
        try:
            for _frame in self.socket:
                self.received += 1
        except ConnectionClosed:
            pass

    def send(self, message: Any) -> None:
        """Send a viser message (a dataclass from viser._messages)."""
        self.socket.send(msgspec.msgpack.encode(message.as_serializable_dict()))

    def click(self, handle: Any) -> None:
        """Press a GUI button, as the page does."""
        self.send(messages.GuiUpdateMessage(handle._impl.uuid, {"value": True}))

    def drag(self, name: str, position: tuple[float, float, float], wxyz: Any) -> None:
        """Move the transform gizmo `name` to a pose, as a mouse drag does."""
        self.send(messages.TransformControlsUpdateMessage(name, tuple(wxyz), position))

    def close(self) -> None:
        """Hang up and stop draining."""
        self.socket.close()
        if self._thread is not None:
            self._thread.join(5)

    def __enter__(self) -> ViserClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
