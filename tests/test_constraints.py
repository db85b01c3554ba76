"""The two pin files install together (the ROS 2 venv uses both): shared packages agree."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _pins(name: str) -> dict[str, str]:
    pins: dict[str, str] = {}
    for raw in (ROOT / name).read_text().splitlines():
        line = raw.split("#", 1)[0].strip()
        if "==" in line:
            package, version = line.split("==", 1)
            pins[package.strip().lower().replace("_", "-")] = version.strip()
    return pins


def test_shared_pins_agree() -> None:
    main, ros2 = _pins("constraints.txt"), _pins("constraints-ros2.txt")
    assert main
    assert ros2
    clashes = {p: (main[p], ros2[p]) for p in main.keys() & ros2.keys() if main[p] != ros2[p]}
    assert not clashes, f"constraints.txt vs constraints-ros2.txt: {clashes}"
