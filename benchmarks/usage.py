"""`--help` for a benchmark run on its own (`python benchmarks/bench_NAME.py --help` or
`python -m benchmarks.bench_NAME --help`): its docstring and options, then exit."""

from __future__ import annotations

import sys

__all__ = ["exit_on_help"]


def exit_on_help(doc: str | None, options: str = "") -> None:
    """With `-h` or `--help` among the arguments, print `doc` and `options` and exit 0."""
    if not {"-h", "--help"} & set(sys.argv[1:]):
        return
    print((doc or "").strip())
    if options:
        print(f"\noptions:\n{options}")
    raise SystemExit(0)
