"""Real-time factor of the arm and mobile-robot scenes with and without the live view.

Each scene runs flat out (real-time factor 0) for a fixed span of sim time: headless,
with the live view serving (no browser), with the view and one client attached (a
websocket client that receives every pose update, as a browser tab does), and with three
clients and the TF frames and contact points on. The view
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
    import msgspec
    import viser
    import viser._messages as messages
    import websockets

    # A page reports its camera first; viser counts a client as connected from then.
    camera = messages.ViewerCameraMessage(
        (1.0, 0.0, 0.0, 0.0), (2.0, 2.0, 2.0), 1.0, 0.01, 100.0, 700, 900,
        (0.0, 0.0, 0.0), (0.0, 0.0, 1.0),
    )  # fmt: skip

    async def main() -> None:
        async with websockets.connect(
            url.replace("http", "ws"),
            max_size=None,
            subprotocols=[websockets.Subprotocol(f"viser-v{viser.__version__}")],
        ) as ws:
            await ws.send(msgspec.msgpack.encode(camera.as_serializable_dict()))
            while not stop.is_set():
                try:
                    await asyncio.wait_for(ws.recv(), 0.2)
                    received[0] += 1
                except TimeoutError:
                    continue

    asyncio.run(main())


def _run(scene: Path, view: bool, clients: int, overlays: bool = False) -> dict[str, Any]:
    world = World.from_scene(load_scene(scene))
    live = LiveView(world, ViewOptions(port=0)) if view else None
    stop, received = threading.Event(), [0]
    threads = []
    if live is not None:
        if overlays:
            live.tf.checkbox.value = True  # type: ignore[misc]
            live.contacts.checkbox.value = True  # type: ignore[misc]
        for _ in range(clients):
            thread = threading.Thread(target=_client, args=(live.url, stop, received), daemon=True)
            thread.start()
            threads.append(thread)
        if clients:
            time.sleep(1.0)  # connected and sent the scene
    sent_before = live.frames_sent if live is not None else 0
    try:
        stats = world.run(SIM_SECONDS, realtime_factor=0.0)
        sent = (live.frames_sent if live is not None else 0) - sent_before
    finally:
        stop.set()
        for thread in threads:
            thread.join(5)
        if live is not None:
            live.close()
    return {
        "rtf": f"{stats.realtime_factor:.1f}",
        "updates_per_s": f"{sent / stats.wall_time:.0f}" if live else "-",
        "client_msgs": received[0] if clients else "-",
    }


def run() -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for name, path in SCENES.items():
        for label, view, clients, overlays in (
            ("none", False, 0, False),
            ("view, no browser", True, 0, False),
            ("view + 1 client", True, 1, False),
            ("view + 3 clients, TF + contacts", True, 3, True),
        ):
            runs = [_run(path, view, clients, overlays) for _ in range(3)]
            best = max(runs, key=lambda r: float(r["rtf"]))
            rows.append({"scene": name, "viewer": label, **best})
    return rows


if __name__ == "__main__":
    from benchmarks.table import format_table

    print(format_table(run()))
