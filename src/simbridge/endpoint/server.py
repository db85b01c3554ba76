"""The ROS-TCP endpoint: an asyncio TCP server bridging many clients into a backend."""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import time
from typing import Any

from simbridge.endpoint.backends.base import Backend, BackendPublisher
from simbridge.endpoint.backends.local import LocalBus
from simbridge.endpoint.budget import MemoryBudget
from simbridge.endpoint.options import EndpointOptions
from simbridge.endpoint.session.drain import PublisherDrains
from simbridge.endpoint.session.session import ClientSession
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
            types
            if types is not None
            else self.backend.type_check() or RegistryTypeCheck(registry_for(self.backend.protocol))
        )
        self.budget = MemoryBudget(self.options.max_memory, self.options.client_share)
        self._sessions: set[ClientSession] = set()
        self._server: asyncio.Server | None = None
        self._timer: asyncio.Task[None] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._drains: PublisherDrains | None = None
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

    async def start(self, *, listen: bool = True) -> None:
        """Start the backend and listen; `port` holds the bound port (useful with port 0).
        Without `listen`, clients come only through `adopt` (clients in this process)."""
        self._loop = asyncio.get_running_loop()
        self._drains = PublisherDrains(self._loop, self.options.drain_timeout)
        await self.backend.start()
        self.backend.watch_lost(self._backend_lost)
        opts = self.options
        if not listen:
            self.started_at = time.monotonic()
            self._timer = asyncio.create_task(self._keepalive_loop())
            log.info("simbridge endpoint in this process (backend %s)", self.backend.name)
            return
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

    async def adopt(self, sock: socket.socket) -> None:
        """Serve a client on `sock`, a connected stream socket (one end of a socketpair
        whose other end a Connector in this process dials), as if it had connected."""
        await self.loop.connect_accepted_socket(lambda: ClientSession(self), sock)

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
        if self._server is not None:
            await self._server.wait_closed()
            self._server = None
        await asyncio.sleep(0)
        if self._drains is not None:
            await self._drains.close()  # what leaving clients published, before ROS goes
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
                if self._too_slow(session, now):
                    continue
                session.send_keepalive_if_idle(now)

    def _too_slow(self, session: ClientSession, now: float) -> bool:
        """Close a client dribbling a frame (slowloris): one still incomplete after
        `frame_timeout` whose bytes arrive slower than `min_frame_rate`."""
        opts = self.options
        started = session.frame_started
        if not started or now - started <= opts.frame_timeout:
            return False
        rate = (session.stats.bytes_in - session.frame_bytes) / (now - started)
        if rate >= opts.min_frame_rate:
            return False
        session.send_error(
            f"frame not completed within {opts.frame_timeout:g} s and arriving at "
            f"{rate:,.0f} B/s (at least {opts.min_frame_rate:,.0f} B/s expected); closing"
        )
        session.close()
        return True

    def admit(self, session: ClientSession) -> bool:
        """Count a newly connected client; when full, first make room by evicting an idle
        one (`_evict_one`). False when there is no room (the client is then refused)."""
        if len(self._sessions) >= self.options.max_clients and not self._evict_one():
            return False
        self._sessions.add(session)
        return True

    def forget(self, session: ClientSession) -> None:
        """A client's connection is gone."""
        self._sessions.discard(session)

    def drain(self, peer: str, publishers: list[tuple[str, BackendPublisher]]) -> None:
        """Deliver what each publisher of client `peer` accepted, then close it, in the
        background (`PublisherDrains`); closed at once before start()."""
        if self._drains is None:
            for _, publisher in publishers:
                publisher.close()
            return
        self._drains.add(peer, publishers)

    def _evict_one(self) -> bool:
        """Make room for a new client when full: close the one that has been connected
        longest without sending a complete request (a drip or idle connection). False
        when every client has proven itself (then the new one is refused)."""
        now = time.monotonic()
        grace = self.options.evict_after
        idle = [s for s in self._sessions if not s.proven and now - s.connected_at >= grace]
        if not idle:
            return False
        victim = min(idle, key=lambda s: s.connected_at)
        log.warning("endpoint full: evicting client %s (no complete request yet)", victim.peer)
        victim.send_error(
            "endpoint full: closing this connection, which sent no complete request in "
            f"{now - victim.connected_at:.1f} s, to make room for a new client"
        )
        victim.close()
        self._sessions.discard(victim)
        return True

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
            "memory_bytes": self.budget.used,
            "memory_peak_bytes": self.budget.peak,
            "memory_limit_bytes": self.budget.limit,
            "published_total": sum(sum(s.stats.published.values()) for s in sessions),
            "drains": self._drains.stats() if self._drains is not None else {},
            "backend_counters": self.backend.stats(),
        }
