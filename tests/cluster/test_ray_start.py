"""A cluster started the way a user starts one (`ray start --head`, `ray start --address`,
separate processes) and `simbridge train --ray` run against it as a command."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from simbridge.gym.ars import LinearPolicy
from tests.raysupport import ray_start_cluster, require_ray

TRAIN = [
    "train",
    "simbridge/Reach-v0",
    "--directions=2",
    "--iterations=2",
    "--eval-every=2",
    "--eval-episodes=4",
    "--max-steps=20",
    "--target-success=none",
    "--seed=7",
]


def _simbridge(*args: str, env: dict[str, str] | None = None) -> str:
    done = subprocess.run(
        [sys.executable, "-m", "simbridge.cli", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_train_on_a_cluster_started_with_ray_start(tmp_path: Path) -> None:
    require_ray()
    with ray_start_cluster() as (address, env):
        on_ray = _simbridge(
            *TRAIN, "--ray=auto", "--workers=2", f"--out={tmp_path / 'ray'}", env=env
        )
        assert "on 2 Ray workers, 2 node(s)" in on_ray
        record = json.loads((tmp_path / "ray" / "run.json").read_text())
    assert record["ray"] == "auto"
    assert len(set(record["worker_nodes"])) == 2
    assert set(record["episodes_per_node"]) == set(record["worker_nodes"])
    assert all(count > 0 for count in record["episodes_per_node"].values())
    assert address.startswith("127.0.0.2:")
    _simbridge(*TRAIN, f"--out={tmp_path / 'local'}")
    local = json.loads((tmp_path / "local" / "run.json").read_text())
    assert record["curve"][-1]["mean_return"] == local["curve"][-1]["mean_return"]
    on_cluster = LinearPolicy.load(tmp_path / "ray" / "policy.npz")
    here = LinearPolicy.load(tmp_path / "local" / "policy.npz")
    np.testing.assert_array_equal(on_cluster.weights, here.weights)
