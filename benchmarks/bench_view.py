"""Real-time factor of the arm and mobile-robot scenes with and without the live view.

Each scene runs flat out (real-time factor 0) for a fixed span of sim time: headless,
with the live view serving (no browser), and with the view and one client attached (a
websocket client that receives every pose update, as a browser tab does). The view
samples poses at 30 Hz of wall time, so its cost is the share of CPU the streaming
thread takes from physics. Each row is the best of three runs (load swings the rest).
"""

from __future__ import annotations

import asyncio
import sys
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from simbridge.sim.scene import load_scene
from simbridge.sim.view import LiveView, ViewOptions
from simbridge.sim.world import World

APPS = Path(__file__).resolve().parents[1] / "src" / "simbridge" / "apps"
SCENES = {
    "arm (pick and place)": APPS / "pick_and_place" / "scene.yaml",
    "mobile robot": APPS / "mobile_robot" / "scene.yaml",
}
SIM_SECONDS = 10.0


def _client(url: str, stop: threading.Event, received: list[int]) -> None:
    import viser
    import websockets

    async def main() -> None:
        async with websockets.connect(
            url.replace("http", "ws"),
            max_size=None,
            subprotocols=[websockets.Subprotocol(f"viser-v{viser.__version__}")],
        ) as ws:
            while not stop.is_set():
                try:
                    await asyncio.wait_for(ws.recv(), 0.2)
                    received[0] += 1
                except TimeoutError:
                    continue

    asyncio.run(main())


def _run(scene: Path, view: bool, client: bool) -> dict[str, Any]:
    world = World.from_scene(load_scene(scene))
    live = LiveView(world, ViewOptions(port=0)) if view else None
    stop, received = threading.Event(), [0]
    thread = None
    if live is not None and client:
        thread = threading.Thread(target=_client, args=(live.url, stop, received), daemon=True)
        thread.start()
        time.sleep(1.0)  # connected and sent the scene
    sent_before = live.frames_sent if live is not None else 0
    try:
        stats = world.run(SIM_SECONDS, realtime_factor=0.0)
        sent = (live.frames_sent if live is not None else 0) - sent_before
    finally:
        stop.set()
        if thread is not None:
            thread.join(5)
        if live is not None:
            live.close()
    return {
        "rtf": f"{stats.realtime_factor:.1f}",
        "updates_per_s": f"{sent / stats.wall_time:.0f}" if live else "-",
        "client_msgs": received[0] if client else "-",
    }


def run() -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for name, path in SCENES.items():
        for label, view, client in (
            ("none", False, False),
            ("view, no browser", True, False),
            ("view + 1 client", True, True),
        ):
            runs = [_run(path, view, client) for _ in range(3)]
            best = max(runs, key=lambda r: float(r["rtf"]))
            rows.append({"scene": name, "viewer": label, **best})
    return rows


if __name__ == "__main__":
    from benchmarks.table import format_table

    print(format_table(run()))
