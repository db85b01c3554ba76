"""`make bench` writes the benchmarks page's tables itself: the writer, on a temporary page;
the page it writes is the docs' benchmarks page, not the README."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from benchmarks.readme import END, PAGE, START, machine_line, write_tables

ROOT = Path(__file__).resolve().parents[2]


def test_make_bench_writes_the_benchmarks_page_and_the_readme_links_it() -> None:
    page = PAGE.read_text()
    assert page.count(START) == page.count(END) == 1
    assert PAGE == ROOT / "docs" / "benchmarks.md"
    assert "run.py --page docs/benchmarks.md" in (ROOT / "Makefile").read_text()
    readme = (ROOT / "README.md").read_text()
    assert START not in readme  # the tables left the README
    assert "docs/benchmarks.md" in readme


def test_tables_replace_only_the_marked_section(tmp_path: Path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text(f"# title\n\nintro\n\n{START}\nold table\n{END}\n\n## after\ntext\n")
    write_tables(readme, "### Endpoint\n\n| a | b |\n|---|---|\n| 1 | 2 |\n")
    text = readme.read_text()
    assert "old table" not in text
    assert text.startswith("# title\n\nintro\n\n")
    assert text.endswith(f"{END}\n\n## after\ntext\n")
    assert f"{START}\n### Endpoint\n\n| a | b |" in text
    write_tables(readme, "second run")  # idempotent on its own output
    assert text.count(START) == 1
    assert f"{START}\nsecond run\n{END}" in readme.read_text()


def test_missing_markers_are_an_error(tmp_path: Path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text("# no markers\n")
    with pytest.raises(ValueError, match="BENCH:START"):
        write_tables(readme, "x")
    assert readme.read_text() == "# no markers\n"


def test_machine_line_names_cpu_cores_and_load() -> None:
    line = machine_line((1.25, 0.5, 0.25))
    assert f"{os.cpu_count()} cores" in line
    assert "load average 1.25 / 0.50 / 0.25" in line
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        model = next(
            ln.split(":", 1)[1].strip()
            for ln in cpuinfo.read_text().splitlines()
            if ln.startswith("model name")
        )
        assert model in line
