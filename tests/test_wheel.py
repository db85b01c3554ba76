"""simbridge as a pip user gets it: a wheel built from this checkout, installed into a
fresh venv, runs `--version`, shipped scenes by name, every local demo, and a ROS 1 demo
with Debian's ROS 1 found on demand (no .pth file pointing at it).

To stay offline and quick, the venv gets the wheel with --no-deps and reaches the
dependencies through one .pth line naming this test's own site-packages: a plain path
line, so that folder's own .pth files (the checkout's editable install, Debian's
dist-packages) are not read, and simbridge and ROS 1 come only from where a pip user's
would.
"""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
from pathlib import Path

import pytest

from simbridge import __version__
from simbridge.apps.summary import SUMMARY_KEYS
from simbridge.cli.common import DEBIAN_DIST_PACKAGES, ensure_ros1
from simbridge.errors import EndpointError

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh venv holding the wheel of this checkout; its `bin` folder."""
    work = tmp_path_factory.mktemp("wheel")
    source = work / "source"  # a copy: building writes build/ and egg-info next to the code
    source.mkdir()
    shutil.copytree(ROOT / "src", source / "src", ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    pip = [sys.executable, "-m", "pip"]
    build = [*pip, "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", str(work / "dist")]
    subprocess.run([*build, str(source)], check=True, timeout=300)
    (wheel,) = (work / "dist").glob("simbridge-*.whl")
    env = work / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env)], check=True)
    (purelib,) = env.glob("lib/python3*/site-packages")
    (purelib / "zz_simbridge_test_deps.pth").write_text(site.getsitepackages()[0] + "\n")
    install = [*pip, "--python", str(env / "bin" / "python"), "install", "-q", "--no-deps"]
    subprocess.run([*install, str(wheel)], check=True, timeout=300)
    return env / "bin"


def _run(venv: Path, *args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONPATH", "PYTHONHOME", "ROS_MASTER_URI", "VIRTUAL_ENV")
    }
    env["MUJOCO_GL"] = os.environ.get("MUJOCO_GL", "osmesa")
    return subprocess.run(
        [str(venv / args[0]), *args[1:]],
        capture_output=True,
        text=True,
        env=env,
        cwd=venv.parent,  # not the checkout: nothing of src/ is importable by accident
        timeout=timeout,
        check=False,
    )


def test_the_wheel_is_what_runs_and_knows_its_version(venv: Path) -> None:
    where = _run(venv, "python", "-c", "import simbridge; print(simbridge.__file__)")
    assert where.stdout.startswith(str(venv.parent)), where.stdout + where.stderr
    assert _run(venv, "simbridge", "--version").stdout.strip() == f"simbridge {__version__}"
    no_ros = _run(venv, "python", "-c", "import rospy")
    assert no_ros.returncode != 0  # ROS 1 is not on the path until a command asks for it


def test_a_shipped_scene_runs_by_name(venv: Path) -> None:
    done = _run(venv, "simbridge", "sim", "mobile-robot", "--duration", "0.2", "--realtime", "0")
    assert done.returncode == 0, done.stderr
    assert "simulated 0.200 s" in done.stdout


def test_sim_help_points_at_the_scene_reference_the_wheel_ships(venv: Path) -> None:
    helped = _run(venv, "simbridge", "sim", "--help")
    assert "docs/scenes.md" not in helped.stdout  # a wheel has no docs/ folder
    assert "simbridge sim --scene-format" in " ".join(helped.stdout.split())
    shown = _run(venv, "simbridge", "sim", "--scene-format")
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout == (ROOT / "docs" / "scenes.md").read_text()


@pytest.mark.parametrize(
    "demo",
    [
        ["bridge"],
        ["pick-and-place"],
        ["mobile-robot", "--side", "0.3"],
        ["line", "--parts", "1"],
    ],
    ids=lambda demo: demo[0],
)
def test_every_local_demo_runs(venv: Path, demo: list[str]) -> None:
    done = _run(venv, "simbridge", "demo", *demo, "--json")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    summary = json.loads(done.stdout.strip().splitlines()[-1])
    assert list(summary)[: len(SUMMARY_KEYS)] == list(SUMMARY_KEYS)
    assert summary["success"] is True
    assert summary["backend"] == "local"


@pytest.mark.skipif(
    not (DEBIAN_DIST_PACKAGES / "rospy").is_dir() or shutil.which("roscore") is None,
    reason="Debian's ROS 1 is not installed",
)
def test_debian_ros1_is_found_without_a_pth_file(venv: Path) -> None:
    done = _run(venv, "simbridge", "demo", "bridge", "--backend", "ros1", "--json")
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    summary = json.loads(done.stdout.strip().splitlines()[-1])
    assert (summary["success"], summary["backend"]) == (True, "ros1")


def test_without_ros1_the_error_says_what_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("simbridge.cli.common._has_rospy", lambda: False)
    with pytest.raises(EndpointError) as raised:
        ensure_ros1("--backend ros1", folder=tmp_path)
    text = str(raised.value)
    assert f"--backend ros1 needs rospy, which neither this Python nor {tmp_path} has" in text
    assert "sudo apt install ros-core python3-rospy" in text
    assert "--backend local (no ROS needed)" in text
