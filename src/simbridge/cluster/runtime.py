"""Connecting to a Ray cluster: Ray imported only here and only when asked for.

simbridge's local paths never import Ray; `ray_module` names the extra to install when
it is missing, and `connect` checks that the address answers before handing it to
`ray.init` (which retries a wrong address for minutes).
"""

from __future__ import annotations

import importlib
import logging
import os
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from simbridge.errors import ClusterError

__all__ = ["CONNECT_TIMEOUT_S", "FORWARDED_ENV", "connect", "node_id", "ray_module"]

CONNECT_TIMEOUT_S = 5.0
"""How long the cluster's address may take to accept a TCP connection."""

START_HINT = "Start one with `ray start --head` (docs/ray.md), or give the head's HOST:PORT."

FORWARDED_ENV = ("MUJOCO_GL", "PYOPENGL_PLATFORM")
"""Environment the workers get from the driver: the renderer MuJoCo uses there."""


def ray_module() -> Any:
    """The `ray` module (typed Any: Ray is an optional extra); ClusterError without it."""
    try:
        return importlib.import_module("ray")
    except ImportError as exc:
        raise ClusterError(f"Ray is not installed ({exc}): pip install 'simbridge[ray]'") from exc


def node_id() -> str:
    """The id of the Ray node this code runs on (in a task or actor)."""
    return str(ray_module().get_runtime_context().get_node_id())


def _bootstrap_address(address: str) -> str | None:
    """The GCS address `ray.init(address)` would dial ("auto": the cluster `ray start`
    recorded on this machine), or None where Ray starts or finds one itself."""
    services = importlib.import_module("ray._private.services")
    try:
        found = services.canonicalize_bootstrap_address(address)
    except (ValueError, ConnectionError) as exc:
        raise ClusterError(f"--ray {address!r}: {exc} {START_HINT}") from exc
    return None if found is None else str(found)


def _check_answers(address: str) -> None:
    """ClusterError unless something listens at the cluster's address."""
    if address == "local":  # ray.init starts a private one
        return
    target = _bootstrap_address(address)
    if target is None:
        raise ClusterError(f"no Ray cluster found for --ray {address!r}. {START_HINT}")
    host, _, port = target.rpartition(":")
    try:
        with socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT_S):
            pass
    except (OSError, ValueError) as exc:
        raise ClusterError(
            f"no Ray cluster answers at {target} (--ray {address!r}): {exc}; is `ray start "
            "--head` running there, and is its port reachable from here?"
        ) from exc


@contextmanager
def connect(address: str) -> Iterator[Any]:
    """The `ray` module, connected to the cluster at `address` (HOST:PORT of the head,
    "auto" for the one `ray start` runs on this machine, "local" for a private one) for
    the block. A connection this process already has is used as it is and left open."""
    ray = ray_module()
    if ray.is_initialized():
        yield ray
        return
    _check_answers(address)
    env = {key: os.environ[key] for key in FORWARDED_ENV if key in os.environ}
    try:
        ray.init(
            address=address,
            runtime_env={"env_vars": env} if env else None,
            logging_level=logging.WARNING,
        )
    except (ConnectionError, RuntimeError, ValueError) as exc:
        raise ClusterError(f"cannot connect to the Ray cluster at {address!r}: {exc}") from exc
    try:
        yield ray
    finally:
        ray.shutdown()
