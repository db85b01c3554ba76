"""Every example in the README and docs/ that is meant to run is run, as written, so none
fails for a reader; and the documentation site builds with `mkdocs build --strict` (a
broken link or page fails).

A code block (```python, ```sh, ```bash) is preceded by one of these HTML comments
(among the comment lines right above it), which the rendered pages do not show:

- `<!-- test: run -->`: run the block in a fresh process (Python), or with bash
  (`set -e`; `simbridge` is this checkout's), from an empty folder that links the
  checkout's src/, docs/, benchmarks/ and .venv/ (paths in the examples are the
  checkout's);
  `<!-- test: run expect TEXT -->` also wants TEXT in what it prints (the expected
  output the page shows);
- `<!-- test: continue -->`: run it after the page's block run before it, in the same
  process, as a reader typing both would;
- `<!-- test: skip REASON -->`: not run, for the reason given (it needs ROS, a display,
  runs forever, installs software...).

A Python block must exit 0 without a traceback on stderr (at exit included); a shell
block must exit 0.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
RUNNABLE = ("python", "sh", "bash")
FENCE = re.compile(r"^ *```(\w*)[^\n]*\n(.*?)^ *```", re.MULTILINE | re.DOTALL)
MARK = re.compile(r"^<!-- test: (run|continue|skip)\b ?(.*?)-->$")
COMMENT = re.compile(r"^<!--.*-->$")


@dataclass(frozen=True)
class Block:
    page: Path
    line: int
    language: str
    code: str
    mark: str | None
    """run, continue, skip, or None when the block carries no mark."""
    reason: str

    @property
    def name(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def _blocks(page: Path) -> list[Block]:
    text = page.read_text()
    found = []
    for match in FENCE.finditer(text):
        above = text[: match.start()].rstrip("\n").split("\n")
        comments = []
        while above and COMMENT.match(above[-1].strip()):
            comments.append(above.pop().strip())
        marks = [m for m in map(MARK.match, comments) if m]
        mark = marks[0] if marks else None
        found.append(
            Block(
                page,
                text[: match.start()].count("\n") + 1,
                match[1],
                match[2],
                mark[1] if mark else None,
                mark[2].strip() if mark else "",
            )
        )
    return found


BLOCKS = [block for page in PAGES for block in _blocks(page)]


def test_every_runnable_block_is_marked() -> None:
    unmarked = [b.name for b in BLOCKS if b.language in RUNNABLE and b.mark is None]
    assert not unmarked, f"mark these run, continue or skip (with a reason): {unmarked}"
    unexplained = [b.name for b in BLOCKS if b.mark == "skip" and not b.reason]
    assert not unexplained, f"say why these are skipped: {unexplained}"


def test_the_readme_is_a_front_door() -> None:
    """At most 200 lines: what it is, the two commands, five minutes, features, links."""
    lines = (ROOT / "README.md").read_text().splitlines()
    assert len(lines) <= 200, f"README.md has {len(lines)} lines"


def _programs() -> list[tuple[str, str, str, str]]:
    """(name, language, code, expected output) of what to run: each run block with the
    continue blocks after it on its page."""
    programs: list[tuple[str, str, str, str]] = []
    for block in BLOCKS:
        if block.mark == "run":
            expect = block.reason.removeprefix("expect ").strip() if block.reason else ""
            programs.append((block.name, block.language, block.code, expect))
        elif block.mark == "continue":
            page = str(block.page.relative_to(ROOT))
            if not programs or not programs[-1][0].startswith(page):
                raise ValueError(f"{block.name}: no block run before it on its page")
            name, language, code, expect = programs[-1]
            programs[-1] = (f"{name}+{block.line}", language, code + block.code, expect)
    return programs


@pytest.mark.parametrize(
    ("name", "language", "code", "expect"), _programs(), ids=lambda v: str(v).split("\n")[0][:50]
)
def test_the_example_runs_as_written(
    tmp_path: Path, name: str, language: str, code: str, expect: str
) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ROS_MASTER_URI")}
    env.setdefault("MUJOCO_GL", "osmesa")
    env.setdefault("PYOPENGL_PLATFORM", env["MUJOCO_GL"])
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    for part in ("src", "docs", "benchmarks", ".venv"):  # what the examples' paths name
        (tmp_path / part).symlink_to(ROOT / part)
    command = [sys.executable, "-c", code] if language == "python" else ["bash", "-e", "-c", code]
    done = subprocess.run(
        command, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=600, check=False
    )
    assert done.returncode == 0, f"{name}:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    if language == "python":
        for sign in ("Traceback", "Exception ignored"):
            assert sign not in done.stderr, f"{name}:\n{done.stderr[-3000:]}"
    assert expect in done.stdout + done.stderr, f"{name}: no {expect!r} in\n{done.stdout[-3000:]}"


@pytest.mark.skipif(shutil.which("mkdocs", path=str(Path(sys.executable).parent)) is None,
                    reason="mkdocs is not installed (the dev extra has it)")  # fmt: skip
def test_the_site_builds_strictly(tmp_path: Path) -> None:
    mkdocs = Path(sys.executable).parent / "mkdocs"
    done = subprocess.run(
        [str(mkdocs), "build", "--strict", "--site-dir", str(tmp_path / "site")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-5000:]
    assert (tmp_path / "site" / "index.html").is_file()
