"""docs/ray.md runs as written: the one-machine recipe drives `ray start --head` and
`ray start --address` as separate processes, the way a user starts a cluster, then
`simbridge train --ray auto` on it; the Python example runs on a cluster."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np

from simbridge.gym.ars import LinearPolicy
from tests.raysupport import RayProcesses, ray_environment, require_ray

ROOT = Path(__file__).resolve().parents[2]


def example(name: str, language: str) -> str:
    """The code block after `<!-- example: NAME -->` in docs/ray.md."""
    text = (ROOT / "docs" / "ray.md").read_text()
    match = re.search(rf"<!-- example: {name} -->\s*```{language}\n(.*?)```", text, re.S)
    assert match, f"docs/ray.md has no {language} example {name!r}"
    return match.group(1)


def test_one_machine_recipe_trains_on_both_nodes_and_matches_the_local_run(
    tmp_path: Path,
) -> None:
    require_ray()
    lines = [shlex.split(line) for line in example("one-machine", "bash").splitlines() if line]
    with ray_environment() as env, RayProcesses(env, Path(env["RAY_TMPDIR"])) as ray:
        head = ""
        for words in lines:
            if words[0] == "export":
                key, _, value = words[1].partition("=")
                env[key] = value
            elif words[:2] == ["ray", "start"] and "--head" in words:
                assert "--port=6379" in words
                args = [w if w != "--port=6379" else "--port=0" for w in words[2:]]
                head = ray.start_head(*(w for w in args if w != "--head"))
            elif words[:2] == ["ray", "start"]:
                args = [w.replace("127.0.0.2:6379", head) for w in words[2:]]
                ray.start_node(*args)
            elif words[:2] == ["ray", "stop"]:
                ray.stop()
            else:
                assert words[0] == "simbridge", words
                done = subprocess.run(
                    [sys.executable, "-m", "simbridge.cli", *words[1:]],
                    cwd=tmp_path,
                    env=env,
                    capture_output=True,
                    text=True,
                    timeout=300,
                    check=False,
                )
                assert done.returncode == 0, done.stdout + done.stderr
        assert not ray.running, "the recipe ends with ray stop"
    on_ray = json.loads((tmp_path / "runs" / "reach-ray" / "run.json").read_text())
    local = json.loads((tmp_path / "runs" / "reach-local" / "run.json").read_text())
    assert on_ray["ray"] == "auto"
    assert local["ray"] is None
    # one worker on each node (1 CPU each), and both ran episodes
    assert len(set(on_ray["worker_nodes"])) == 2
    assert set(on_ray["episodes_per_node"]) == set(on_ray["worker_nodes"])
    assert all(count > 0 for count in on_ray["episodes_per_node"].values())
    # the same run: curve and policy
    strip = [{k: v for k, v in p.items() if k != "wall_s"} for p in on_ray["curve"]]
    assert strip == [{k: v for k, v in p.items() if k != "wall_s"} for p in local["curve"]]
    assert on_ray["curve"][-1]["iteration"] == 10
    policies = [
        LinearPolicy.load(tmp_path / "runs" / name / "policy.npz")
        for name in ("reach-ray", "reach-local")
    ]
    np.testing.assert_array_equal(policies[0].weights, policies[1].weights)
