"""`make demo` sets up only what the local demo needs: the package without its extras
(dev tools, live view, Ray), which `make test` still installs; and the demo runs with the
extras' modules out of reach."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import tomllib
from importlib.metadata import packages_distributions
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(shutil.which("make") is None, reason="needs make")


def _installs(target: str) -> list[str]:
    """The `pip install` lines `make TARGET` would run on a fresh checkout (dry run)."""
    done = subprocess.run(
        ["make", "--dry-run", "--always-make", target],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    return [line for line in done.stdout.splitlines() if "pip install" in line and "-e " in line]


def test_make_demo_installs_the_package_without_extras() -> None:
    installs = _installs("demo")
    assert len(installs) == 1, installs
    assert installs[0].endswith("-e ."), installs


def test_make_test_still_installs_every_extra() -> None:
    installs = _installs("pytest")
    assert any(line.endswith("-e '.[dev,view,ray]'") for line in installs), installs


def _extras_modules() -> list[str]:
    """The top-level modules of the distributions the dev, view and ray extras name."""
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    names = {
        re.split(r"[<>=!~\[ ;]", requirement)[0].lower().replace("_", "-")
        for extra in ("dev", "view", "ray")
        for requirement in extras[extra]
    }
    names.discard("setuptools")  # the build backend, not something the demo could import
    return sorted(
        module
        for module, dists in packages_distributions().items()
        if any(dist.lower().replace("_", "-") in names for dist in dists)
    )


BLOCKER = """
import importlib.abc, json, sys
BLOCKED = set(json.loads(sys.argv[1]))
class Blocker(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {name!r} (an extra)", name=name)
        return None
sys.meta_path.insert(0, Blocker())
from simbridge.cli import main
sys.exit(main(["demo", "--json"]))
"""


def test_the_local_demo_runs_without_the_extras() -> None:
    blocked = _extras_modules()
    assert {"viser", "ray", "pytest", "mypy"} <= set(blocked)
    done = subprocess.run(
        [sys.executable, "-c", BLOCKER, json.dumps(blocked)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    summary = json.loads(done.stdout.strip().splitlines()[-1])
    assert summary["success"] is True
    assert summary["backend"] == "local"
