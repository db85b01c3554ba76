"""Run every benchmark and print its table; `--markdown` for the README, `--only NAME`."""

from __future__ import annotations

import argparse
import importlib
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.table import format_table

SUITES = {
    "endpoint": "benchmarks.bench_endpoint",
    "ros1": "benchmarks.bench_ros1",
    "sim": "benchmarks.bench_sim",
    "sensors": "benchmarks.bench_sensors",
    "pick_and_place": "benchmarks.bench_pick_and_place",
    "mobile_robot": "benchmarks.bench_mobile_robot",
    "gym": "benchmarks.bench_gym",
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--only", action="append", choices=sorted(SUITES), default=[])
    args = parser.parse_args()
    names = args.only or list(SUITES)
    uname = platform.uname()
    print(
        f"# machine: {uname.system} {uname.machine}, python {platform.python_version()}, "
        f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}"
    )
    for name in names:
        try:
            module = importlib.import_module(SUITES[name])
        except ModuleNotFoundError as exc:
            print(f"\n## {name}: skipped ({exc})")
            continue
        print(f"\n## {name}\n", flush=True)
        start = time.perf_counter()
        rows = module.run()
        # A suite returns one table (a list of rows) or several ({title: rows}).
        tables = rows if isinstance(rows, dict) else {"": rows}
        for title, table in tables.items():
            if title:
                print(f"### {title}\n")
            print(format_table(table, markdown=args.markdown) + ("\n" if title else ""))
        print(f"\n({time.perf_counter() - start:.0f} s)", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
