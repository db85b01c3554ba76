"""Run an endpoint on a background thread with its own event loop (demos, tests, apps)."""

from __future__ import annotations

import asyncio
import concurrent.futures
import socket
import threading
from collections.abc import Callable
from typing import Any, TypeVar

from simbridge.endpoint.backends.base import Backend
from simbridge.endpoint.options import EndpointOptions
from simbridge.endpoint.server import EndpointServer
from simbridge.endpoint.typecheck import TypeCheck
from simbridge.errors import EndpointError

__all__ = ["EndpointThread"]

T = TypeVar("T")


class EndpointThread:
    """An EndpointServer on a daemon thread; `start()` returns once it listens.

    Use as a context manager: `with EndpointThread(EndpointOptions(port=0)) as ep: ep.port`.
    """

    def __init__(
        self,
        options: EndpointOptions | None = None,
        backend: Backend | None = None,
        types: TypeCheck | None = None,
        *,
        listen: bool = True,
    ) -> None:
        """`listen`: False serves only clients in this process (`dial`), no port."""
        self._listen = listen
        self.server = EndpointServer(options or EndpointOptions(port=0), backend, types)
        self.loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._run, name="simbridge-endpoint", daemon=True)
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._stopped = asyncio.Event()

    @property
    def port(self) -> int:
        """The port the endpoint listens on."""
        return self.server.port

    @property
    def backend(self) -> Backend:
        """The backend (e.g. the LocalBus for in-process nodes)."""
        return self.server.backend

    def start(self, timeout: float = 10.0) -> EndpointThread:
        """Start serving; raise EndpointError if it cannot listen."""
        self._thread.start()
        if not self._ready.wait(timeout):
            raise EndpointError(f"endpoint did not start within {timeout:g} s")
        if self._error is not None:
            raise self._error
        return self

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)
        self.loop.run_until_complete(self._main())
        self.loop.close()

    async def _main(self) -> None:
        try:
            await self.server.start(listen=self._listen)
        except BaseException as exc:
            self._error = exc
            self._ready.set()
            return
        self._ready.set()
        await self._stopped.wait()
        await self.server.close()

    def call(self, fn: Callable[[], T], timeout: float = 10.0) -> T:
        """Run `fn()` on the endpoint's loop and return its result."""
        future: concurrent.futures.Future[T] = concurrent.futures.Future()

        def run() -> None:
            try:
                future.set_result(fn())
            except BaseException as exc:
                future.set_exception(exc)

        self.loop.call_soon_threadsafe(run)
        return future.result(timeout)

    def dial(self, timeout: float = 10.0) -> socket.socket:
        """A new client connection to this endpoint within the process: one end of a
        socketpair whose other end the endpoint serves (a Connector's `dial`).
        ConnectionRefusedError (an OSError, as from TCP) when the endpoint is not running."""
        if not self._thread.is_alive() or self.loop.is_closed() or self._stopped.is_set():
            raise ConnectionRefusedError("the endpoint in this process is not running")
        ours, theirs = socket.socketpair()
        try:
            asyncio.run_coroutine_threadsafe(self.server.adopt(theirs), self.loop).result(timeout)
        except Exception as exc:
            ours.close()
            theirs.close()
            if isinstance(exc, OSError):
                raise
            raise ConnectionRefusedError(
                f"the endpoint in this process did not take the connection ({exc!r})"
            ) from exc
        except BaseException:
            ours.close()
            theirs.close()
            raise
        return ours

    def stop(self, timeout: float = 10.0) -> None:
        """Close every connection and stop the thread."""
        if self._thread.is_alive() and not self.loop.is_closed():
            self.loop.call_soon_threadsafe(self._stopped.set)
            self._thread.join(timeout)

    def __enter__(self) -> EndpointThread:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()
