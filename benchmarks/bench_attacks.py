"""Peak resident memory of an endpoint process under each attack, beside its budget.

Each attack (benchmarks/attacks.py) runs against a fresh `simbridge endpoint` child
process with `--max-memory-mb BUDGET`; the row gives its resident memory before, the
peak during the attack (Linux VmHWM, reset per attack), and whether it still served a
new client afterwards. Bounded: a few seconds per attack, loopback only.
"""

from __future__ import annotations

import socket
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # also as a bare script

from benchmarks.attacks import ATTACKS, EndpointProcess, close_all
from simbridge.protocol import TopicListRequest

BUDGET_MB = 256


def _serves(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=5) as sock:
            sock.sendall(TopicListRequest().encode())
            sock.settimeout(10)
            data = b""
            while b"__topic_list" not in data:
                chunk = sock.recv(1 << 16)
                if not chunk:
                    return False
                data += chunk
    except OSError:
        return False
    return True


def run(budget_mb: int = BUDGET_MB) -> list[dict[str, Any]]:
    """One row per attack."""
    rows = []
    for name, attack in ATTACKS.items():
        with EndpointProcess("--max-memory-mb", str(budget_mb)) as ep:
            time.sleep(0.3)
            base = ep.rss()
            ep.reset_peak()
            start = time.perf_counter()
            socks = attack(ep.port)
            seconds = time.perf_counter() - start
            time.sleep(0.3)
            peak = ep.peak_rss()
            serves = ep.alive and _serves(ep.port)
            close_all(socks)
        rows.append(
            {
                "attack": name,
                "budget_mb": budget_mb,
                "rss_before_mb": base / 2**20,
                "peak_rss_mb": peak / 2**20,
                "peak_minus_before_mb": (peak - base) / 2**20,
                "seconds": seconds,
                "still_serving": "yes" if serves else "NO",
            }
        )
    return rows


if __name__ == "__main__":
    from benchmarks.table import format_table
    from benchmarks.usage import exit_on_help

    exit_on_help(__doc__, "  --markdown  a Markdown table")

    print(format_table(run(), markdown="--markdown" in sys.argv))
