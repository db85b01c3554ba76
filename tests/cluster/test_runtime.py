"""Connecting to Ray: the errors a user meets, and the local paths that need no Ray."""

from __future__ import annotations

import socket
import subprocess
import sys

import pytest

from simbridge.cluster import connect, shares
from simbridge.errors import ClusterError
from tests.raysupport import LOOPBACK, ray_environment, require_ray

BLOCK_RAY = "import sys; sys.modules['ray'] = None\n"


def _python(script: str) -> subprocess.CompletedProcess[str]:
    """`script` run by a fresh interpreter (imports start from nothing)."""
    return subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120, check=False
    )


def test_a_dead_address_is_a_clear_error_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """ "At once": the address is probed before ray.init, which alone retries for minutes."""
    require_ray()
    import ray

    calls: list[object] = []
    monkeypatch.setattr(ray, "init", lambda *args, **kwargs: calls.append(args))
    with socket.socket() as unused:  # a port nobody listens on: bound, never listening
        unused.bind((LOOPBACK, 0))
        port = unused.getsockname()[1]
        expected = f"no Ray cluster answers at {LOOPBACK}:{port}"
        with pytest.raises(ClusterError, match=expected), connect(f"{LOOPBACK}:{port}"):
            pass
    assert calls == [], "ray.init was called for an address nobody answers at"


def test_auto_without_a_cluster_says_how_to_start_one() -> None:
    """Ray's `auto` looks for a running gcs_server among all processes, so the check runs in
    a PID namespace of its own: a cluster another program runs on this machine is not seen."""
    require_ray()
    script = (
        "from simbridge.cluster import connect\n"
        "from simbridge.errors import ClusterError\n"
        "try:\n"
        "    with connect('auto'):\n"
        "        raise SystemExit('connected to a cluster')\n"
        "except ClusterError as exc:\n"
        "    print(exc)\n"
    )
    command = ["unshare", "--pid", "--fork", "--mount-proc", sys.executable, "-c", script]
    if subprocess.run([*command[:4], "true"], capture_output=True, check=False).returncode:
        pytest.skip("cannot create a PID namespace here (needs root or user namespaces)")
    with ray_environment() as env:  # a private RAY_TMPDIR: no cluster recorded there
        done = subprocess.run(
            command, env=env, capture_output=True, text=True, timeout=120, check=False
        )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "ray start --head" in done.stdout


def test_without_ray_the_local_paths_work_and_ray_asks_for_the_extra() -> None:
    script = BLOCK_RAY + (
        "from simbridge.cli import main\n"
        "import simbridge.cluster, simbridge.gym\n"
        "args = ['train', 'simbridge/Reach-v0', '--directions=1', '--iterations=1',\n"
        "        '--eval-every=1', '--eval-episodes=2', '--max-steps=5']\n"
        "assert main(args) == 0\n"
        "assert main([*args, '--ray=auto']) == 2\n"
    )
    done = _python(script)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "trained simbridge/Reach-v0: success" in done.stdout
    assert "Ray is not installed" in done.stderr
    assert "pip install 'simbridge[ray]'" in done.stderr


def test_shares_split_directions_over_workers() -> None:
    assert shares(8, 2) == [4, 4]
    assert shares(3, 2) == [2, 1]
    assert shares(2, 3) == [1, 1, 0]
    assert sum(shares(17, 5)) == 17


def test_the_progress_boards_module_loads_without_the_learning_stack() -> None:
    """A Ray worker that unpickles the datagen progress board imports its module alone: the
    package face loads names on first use, so neither Gymnasium nor MuJoCo comes along (they
    once made the board's worker take 3.8 s to start)."""
    script = (
        "import json, sys\n"
        "import simbridge.cluster.shards\n"
        "import simbridge.cluster as face\n"
        "before = sorted(m for m in ('gymnasium', 'mujoco', 'simbridge.gym') if m in sys.modules)\n"
        "face.RayRollouts  # a name of the face still resolves, loading its module then\n"
        "print(json.dumps([before, 'simbridge.cluster.ars' in sys.modules]))\n"
    )
    done = _python(script)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[[], true]"
