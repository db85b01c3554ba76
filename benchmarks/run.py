"""Run every benchmark and print its table; `--markdown` for Markdown, `--only NAME`;
`--page docs/benchmarks.md` also writes the tables between that page's BENCH markers."""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks.readme import machine_line, write_tables
from benchmarks.repeats import REPEATS
from benchmarks.table import format_table
from simbridge.progress import Ticker, elapsed

SUITES = {
    "endpoint": "benchmarks.bench_endpoint",
    "ros1": "benchmarks.bench_ros1",
    "ros2": "benchmarks.bench_ros2",
    "drain": "benchmarks.bench_drain",
    "sim": "benchmarks.bench_sim",
    "sensors": "benchmarks.bench_sensors",
    "pick_and_place": "benchmarks.bench_pick_and_place",
    "mobile_robot": "benchmarks.bench_mobile_robot",
    "gym": "benchmarks.bench_gym",
    "attacks": "benchmarks.bench_attacks",
    "urdf": "benchmarks.bench_urdf",
    "view": "benchmarks.bench_view",
    "line": "benchmarks.bench_line",
    "line_ros2": "benchmarks.bench_line_ros2",
    "ray": "benchmarks.bench_ray",
    "perception": "benchmarks.bench_perception",
}

TITLES = {
    "endpoint": "Endpoint, local backend (targets: >= 50,000 small msg/s, >= 1 GB/s images)",
    "drain": "ROS 2: a client that publishes and leaves at once, and a flat-out queue_size 0 "
    "stream (nothing accepted is lost)",
    "sim": "Simulator (Niryo One arm)",
    "sensors": "Sensors (targets: camera >= 15 fps on CPU, mobile robot >= 2x real time)",
    "pick_and_place": "Pick and place, 20 random seeds (target: >= 95% success)",
    "mobile_robot": "Mobile robot square with and without sensor subscribers (laziness)",
    "gym": "Gym environments",
    "attacks": "Endpoint under attack: peak resident memory beside the memory budget",
    "urdf": "URDF import: example-robot-data load time per robot, cold and warm mesh cache",
    "view": "Live view (`--view`): real-time factor flat out, without and with the view",
    "perception": "Perception data: labelled 640x480 frames/s on one core vs bare renders "
    "(targets: >= 10 frames/s, labelling + writing <= 30% over the renders)",
}
"""Benchmarks page heading of each suite that returns a single table."""

NOTES = f"""Notes:
- **Machine and load:** the line above says where and under what load this run was taken;
  figures swing with load (other jobs on the same cores), so compare rows of one run.
- **Best and median:** rows give the best and the median of several runs: three for the
  endpoint, {REPEATS} (`SIMBRIDGE_BENCH_REPEATS`) for ROS 1, ROS 2 and the simulator, in
  rounds that take each row in turn; `load_1min` is the 1-minute load average when a row's
  first run started.
- **ROS 1 ceiling:** a rospy publisher feeding a rospy subscriber, measured with the same
  payloads in the same run.
- **95% interval:** `of_ceiling_95ci` holds the true median share of the ceiling with at
  least 95% confidence whatever the rounds' spread (order statistics; from 6 rounds up), so
  a median above or below a target by less than the interval's width is not yet a finding.
  Perception's rows take 6 rounds and give such an interval of each median
  (`fps_median_95ci`, `median_95ci`): there, the lowest and highest round.
- **Attacks:** peak resident memory of an endpoint process under each attack, beside its
  memory budget (`--max-memory-mb`)."""


def _exit_on_sigterm() -> None:
    """SIGTERM (a CI timeout, `kill`) ends the run as Ctrl-C does, so the running suite's
    cleanup (its roscore, endpoints, temporary folders) runs before the process exits."""

    def stop(signum: int, _frame: object) -> None:
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, stop)


def main() -> int:
    _exit_on_sigterm()
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--markdown", action="store_true")
    parser.add_argument("--only", action="append", choices=sorted(SUITES), default=[])
    parser.add_argument(
        "--page",
        type=Path,
        help="write the tables between this page's BENCH markers (make bench: docs/benchmarks.md)",
    )
    args = parser.parse_args()
    names = args.only or list(SUITES)
    machine = machine_line()
    print(f"# {machine}")
    sections = [machine]
    began, ran, skipped = time.perf_counter(), [], []
    for number, name in enumerate(names, 1):
        try:
            module = importlib.import_module(SUITES[name])
        except ModuleNotFoundError as exc:
            print(f"\n## {name}: skipped ({exc})")
            skipped.append(name)
            continue
        print(f"\n## {name}\n", flush=True)
        start = time.perf_counter()

        def status(name: str = name, number: int = number, start: float = start) -> str:
            return (
                f"bench {name} ({number} of {len(names)}): {elapsed(time.perf_counter() - start)}"
                f", {elapsed(time.perf_counter() - began)} in all"
            )

        with Ticker(status):  # a suite runs for minutes before its table
            rows = module.run()
        ran.append(name)
        # A suite returns one table (a list of rows) or several ({title: rows}).
        tables = rows if isinstance(rows, dict) else {"": rows}
        for title, table in tables.items():
            if title:
                print(f"### {title}\n")
            print(format_table(table, markdown=args.markdown) + ("\n" if title else ""))
            heading = title or TITLES.get(name, name)
            sections.append(f"## {heading}\n\n{format_table(table, markdown=True)}")
        print(f"\n({time.perf_counter() - start:.0f} s)", flush=True)
    if args.page is not None:
        write_tables(args.page, "\n\n".join([*sections, NOTES]))
        print(f"\nwrote the tables into {args.page}")
    print(
        f"\nbench: {len(ran)} suites in {elapsed(time.perf_counter() - began)}"
        + (f"; skipped {', '.join(skipped)}" if skipped else ""),
        flush=True,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
