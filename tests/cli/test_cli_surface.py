"""The command line as a newcomer meets it: help on every option, each demo's own options,
one shape of JSON summary, a version, no library chatter, a taken view port refused."""

from __future__ import annotations

import argparse
import json
import os
import re
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from simbridge import __version__
from simbridge.apps.mobile_robot import SCENE_PATH
from simbridge.apps.summary import SUMMARY_KEYS
from simbridge.cli import build_parser, main
from simbridge.cli.demo import with_default_demo


def _parsers(
    parser: argparse.ArgumentParser, path: str = "simbridge"
) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield from _parsers(child, f"{path} {name}")


def test_every_option_and_argument_has_help() -> None:
    missing = [
        f"{path} {'/'.join(action.option_strings) or action.dest}"
        for path, parser in _parsers(build_parser())
        for action in parser._actions
        if not isinstance(action, argparse._SubParsersAction) and not action.help
    ]
    assert not missing, missing


@pytest.mark.parametrize(
    ("demo", "own", "others"),
    [
        ("pick-and-place", ["--seed", "--video", "--view"], ["--side", "--parts"]),
        ("mobile-robot", ["--side", "--view", "--record"], ["--parts", "--seed", "--video"]),
        ("line", ["--parts", "--seed", "--video"], ["--side"]),
        ("bridge", ["--backend", "--json"], ["--view", "--record", "--seed", "--side"]),
    ],
)
def test_each_demo_lists_only_its_own_options(
    capsys: pytest.CaptureFixture[str], demo: str, own: list[str], others: list[str]
) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["demo", demo, "--help"])
    assert exited.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith(f"usage: simbridge demo {demo}")
    for option in own:
        assert option in text, option
    for option in others:
        assert not re.search(rf"{option}\b", text), option


def test_a_bare_demo_is_pick_and_place_and_its_help_lists_the_demos() -> None:
    assert with_default_demo(["demo"]) == ["demo", "pick-and-place"]
    assert with_default_demo(["demo", "--json"]) == ["demo", "pick-and-place", "--json"]
    assert with_default_demo(["--log-level", "INFO", "demo", "--seed", "1"]) == [
        "--log-level", "INFO", "demo", "pick-and-place", "--seed", "1",
    ]  # fmt: skip
    assert with_default_demo(["demo", "line", "--json"]) == ["demo", "line", "--json"]
    assert with_default_demo(["demo", "--help"]) == ["demo", "--help"]
    assert with_default_demo(["sim", "demo"]) == ["sim", "demo"]  # a scene file named demo


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["--version"])
    assert exited.value.code == 0
    assert capsys.readouterr().out.strip() == f"simbridge {__version__}"


def test_the_bridge_demo_prints_the_shared_json_keys(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "bridge", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert list(summary)[: len(SUMMARY_KEYS)] == list(SUMMARY_KEYS)
    assert summary["success"] is True
    assert (summary["sent"], summary["received"], summary["service_ok"]) == (5, 5, True)


def test_libraries_print_no_info_lines(tmp_path: Path) -> None:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "osmesa")}
    done = subprocess.run(
        [sys.executable, "-m", "simbridge.cli", "sim", str(SCENE_PATH), "--duration", "0.05"],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    logged = [line for line in done.stderr.splitlines() if " INFO " in line]
    assert logged, done.stderr  # simbridge's own INFO lines still show ...
    assert all(" INFO simbridge" in line for line in logged), done.stderr  # ... no one else's


def test_a_taken_view_port_is_an_error(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        args = ["sim", str(SCENE_PATH), "--duration", "0.01", "--view", "--view-port", str(port)]
        assert main(args) == 2
    error = capsys.readouterr().err
    assert f"view port {port} on 127.0.0.1 is taken" in error
    assert "--view-port 0 for any free port" in error
