"""Write benchmark tables into the documentation's benchmarks page between its BENCH
markers (`make bench`).

The page's figures are never edited by hand: `benchmarks/run.py --page docs/benchmarks.md`
replaces everything between `<!-- BENCH:START -->` and `<!-- BENCH:END -->` with the
tables of this run, headed by the machine they were measured on.
"""

from __future__ import annotations

import os
import platform
import time
from pathlib import Path

__all__ = ["END", "PAGE", "START", "machine_line", "write_tables"]

PAGE = Path(__file__).resolve().parents[1] / "docs" / "benchmarks.md"
"""The page `make bench` writes its tables into."""

START = "<!-- BENCH:START -->"
END = "<!-- BENCH:END -->"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def machine_line(load: tuple[float, float, float] | None = None) -> str:
    """Which machine and how busy: CPU model, cores, memory, load average, OS, Python, date."""
    one, five, fifteen = load if load is not None else os.getloadavg()
    try:
        pages = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        memory = f", {pages / 2**30:.0f} GiB"
    except (ValueError, OSError):
        memory = ""
    uname = platform.uname()
    return (
        f"Measured on {_cpu_model()}, {os.cpu_count()} cores{memory}; load average "
        f"{one:.2f} / {five:.2f} / {fifteen:.2f} (1/5/15 min) at the start; {uname.system} "
        f"{uname.machine}, Python {platform.python_version()}, "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}"
    )


def write_tables(page: Path, body: str) -> None:
    """Replace what lies between the markers in `page` with `body`."""
    text = page.read_text(encoding="utf-8")
    start, end = text.find(START), text.find(END)
    if start < 0 or end < start:
        msg = f"{page}: no {START} ... {END} section to write the benchmark tables into"
        raise ValueError(msg)
    head = text[: start + len(START)]
    page.write_text(f"{head}\n{body.strip()}\n{text[end:]}", encoding="utf-8")
