"""The suite's pytest-xdist scheduler: each test file whole on one worker, and every file
that runs ROS 2 processes together on one worker (tests/conftest.py says why)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from xdist.scheduler import LoadFileScheduling

__all__ = ["DDS_SIGNS", "FilesAndDds", "scope_of"]

DDS_SIGNS = ("tests.ros2support", "pytest.mark.ros2", "benchmarks.bench_ros2")
"""Text that marks a test file as one that starts ROS 2 (Fast DDS) processes."""


def scope_of(nodeid: str, root: Path, seen: dict[Path, bool]) -> str:
    """The unit a test is scheduled with: "dds" for a file that runs ROS 2, else its file."""
    file = nodeid.split("::", 1)[0]
    path = root / file
    if path not in seen:
        text = path.read_text(encoding="utf-8", errors="replace") if path.is_file() else ""
        seen[path] = any(sign in text for sign in DDS_SIGNS)
    return "dds" if seen[path] else file


class FilesAndDds(LoadFileScheduling):  # type: ignore[misc]  # xdist ships no types
    """`--dist loadfile`, with every file that runs ROS 2 processes in one unit, "dds"."""

    def __init__(self, config: Any, log: Any = None) -> None:
        super().__init__(config, log)
        self.root = Path(str(config.rootpath))
        self.seen: dict[Path, bool] = {}

    def _split_scope(self, nodeid: str) -> str:
        return scope_of(nodeid, self.root, self.seen)
