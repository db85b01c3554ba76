"""docs/gym.md: the custom-task example runs as written (from the repository root)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _example(name: str) -> str:
    text = (ROOT / "docs" / "gym.md").read_text()
    match = re.search(rf"<!-- example: {name} -->\s*```python\n(.*?)```", text, re.S)
    assert match, f"docs/gym.md has no example {name!r}"
    return match.group(1)


def test_custom_task_example_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    namespace: dict[str, object] = {}
    exec(compile(_example("custom-task"), "docs/gym.md", "exec"), namespace)
    obs = namespace["obs"]
    assert isinstance(obs, dict)
    assert set(obs) == {"joint_pos", "joint_vel", "goal"}
    assert obs["goal"][2] == 0.125
