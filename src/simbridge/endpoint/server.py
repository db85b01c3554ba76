"""The ROS-TCP endpoint: an asyncio TCP server bridging many clients into a backend."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from typing import Any

from simbridge.endpoint.backends.base import Backend
from simbridge.endpoint.backends.local import LocalBus
from simbridge.endpoint.options import EndpointOptions
from simbridge.endpoint.session import ClientSession
from simbridge.endpoint.typecheck import RegistryTypeCheck, TypeCheck
from simbridge.errors import EndpointError
from simbridge.messages import registry_for

__all__ = ["EndpointServer"]

log = logging.getLogger("simbridge.endpoint")


class EndpointServer:
    """Accepts ROS-TCP clients and routes their traffic through `backend`.

    Usage: `server = EndpointServer(options); await server.start(); ...; await server.close()`.
    """

    def __init__(
        self,
        options: EndpointOptions | None = None,
        backend: Backend | None = None,
        types: TypeCheck | None = None,
    ) -> None:
        self.options = options or EndpointOptions()
        self.backend = backend if backend is not None else LocalBus()
        self.types: TypeCheck = (
            types if types is not None else RegistryTypeCheck(registry_for(self.backend.protocol))
        )
        self._sessions: set[ClientSession] = set()
        self._server: asyncio.Server | None = None
        self._timer: asyncio.Task[None] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self.port = 0
        self.started_at = 0.0
        self.lost: str | None = None
        """Why the backend left the graph for good (then the server stops), else None."""
        self._lost = asyncio.Event()

    @property
    def loop(self) -> asyncio.AbstractEventLoop:
        """The loop the server runs on."""
        if self._loop is None:
            raise EndpointError("endpoint not started")
        return self._loop

    @property
    def sessions(self) -> frozenset[ClientSession]:
        """Connected clients."""
        return frozenset(self._sessions)

    async def start(self) -> None:
        """Start the backend and listen; `port` holds the bound port (useful with port 0)."""
        self._loop = asyncio.get_running_loop()
        await self.backend.start()
        self.backend.watch_lost(self._backend_lost)
        opts = self.options
        try:
            self._server = await self._loop.create_server(
                lambda: ClientSession(self), opts.host, opts.port, reuse_address=True
            )
        except OSError as exc:
            await self.backend.close()
            raise EndpointError(
                f"cannot listen on {opts.host}:{opts.port}: {exc.strerror}"
            ) from exc
        self.port = self._server.sockets[0].getsockname()[1]
        self.started_at = time.monotonic()
        self._timer = asyncio.create_task(self._keepalive_loop())
        if opts.host in ("0.0.0.0", "::", ""):
            log.warning(
                "listening on all interfaces (%s): any host that can reach this machine may "
                "publish and call services; use --host 127.0.0.1 unless you need remote clients",
                opts.host or "*",
            )
        log.info(
            "simbridge endpoint on %s:%d (backend %s)", opts.host, self.port, self.backend.name
        )

    async def serve_forever(self) -> None:
        """Run until cancelled; raise EndpointError if the backend leaves the graph for good."""
        if self._server is None:
            await self.start()
        assert self._server is not None
        serving = asyncio.ensure_future(self._server.serve_forever())
        lost = asyncio.ensure_future(self._lost.wait())
        try:
            await asyncio.wait({serving, lost}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            serving.cancel()
            lost.cancel()
        if self.lost is not None:
            raise EndpointError(self.lost)

    def _backend_lost(self, reason: str) -> None:
        """Tell every client, then stop: an endpoint cut off from the graph must not
        keep accepting clients as if their traffic still reached ROS."""
        if self.lost is not None:
            return
        self.lost = reason
        log.error("%s; telling %d client(s) and stopping", reason, len(self._sessions))
        for session in list(self._sessions):
            session.send_error(f"{reason}; the endpoint stops")
            session.close()
        if self._server is not None:
            self._server.close()
        self._lost.set()

    async def close(self) -> None:
        """Disconnect every client, stop listening and release the backend."""
        if self._timer is not None:
            self._timer.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._timer
            self._timer = None
        if self._server is not None:
            self._server.close()
            for session in list(self._sessions):
                session.close()
            await self._server.wait_closed()
            self._server = None
        await asyncio.sleep(0)
        await self.backend.close()

    async def _keepalive_loop(self) -> None:
        opts = self.options
        period = max(
            0.05, min(opts.keepalive_interval, opts.idle_timeout or opts.keepalive_interval) / 2
        )
        while True:
            await asyncio.sleep(period)
            now = time.monotonic()
            for session in list(self._sessions):
                if opts.idle_timeout and now - session.last_recv > opts.idle_timeout:
                    log.warning(
                        "client %s sent nothing for %.1f s; closing it",
                        session.peer,
                        opts.idle_timeout,
                    )
                    session.close()
                    continue
                session.send_keepalive_if_idle(now)

    def stats(self) -> dict[str, Any]:
        """Server-wide counters."""
        sessions = list(self._sessions)
        return {
            "clients": len(sessions),
            "backend": self.backend.name,
            "uptime_s": round(time.monotonic() - self.started_at, 3),
            "frames_in": sum(s.stats.frames_in for s in sessions),
            "frames_out": sum(s.stats.frames_out for s in sessions),
            "dropped_total": sum(sum(s.stats.dropped.values()) for s in sessions),
        }
