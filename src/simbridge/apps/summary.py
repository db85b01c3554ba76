"""The keys every demo's `--json` summary starts with, in this order, so scripts read any
demo the same way; each demo's own figures follow them."""

from __future__ import annotations

__all__ = ["SUMMARY_KEYS"]

SUMMARY_KEYS = ("success", "seed", "backend", "sim_s", "wall_s", "realtime_factor", "error")
"""success: the demo's own test passed; seed: what random draws came from (null: nothing
was drawn, or the fixed default task); backend: local, ros1 or ros2; sim_s / wall_s:
simulated and wall-clock seconds (sim_s null without a simulation); realtime_factor:
their ratio; error: why it failed, else null."""
