"""A live 3D view of a running `World` in the browser, served by `viser`.

Geometry is sent once when a world is shown (and to each browser that connects); a
streaming thread then samples body poses at a bounded wall-clock rate (30 Hz by
default) and sends only those, so the physics thread never waits on the view, and a
browser that goes away costs nothing. The page has the simulation controls
(`controls.py`), TF frames and contact points on demand (`overlays.py`), a drag gizmo
for free objects (`mover.py`), lidar points and camera images when a sensor suite is
attached (`sensors.py`), and the buttons a demo registers (`add_button`).
"""

from __future__ import annotations

import io
import logging
import threading
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, redirect_stdout
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from simbridge.errors import SimError
from simbridge.sim.sensors import SensorSuite
from simbridge.sim.view.controls import SimControls
from simbridge.sim.view.follow import CameraFollow
from simbridge.sim.view.framing import framing
from simbridge.sim.view.mover import ObjectMover
from simbridge.sim.view.overlays import ContactPoints, TfFrames
from simbridge.sim.view.sensors import SensorFeed
from simbridge.sim.view.shapes import Shape, body_names, visual_shapes
from simbridge.sim.world.world import World

if TYPE_CHECKING:
    import viser

__all__ = ["LiveView", "ViewOptions"]

_log = logging.getLogger("simbridge.sim.view")


@dataclass(frozen=True)
class ViewOptions:
    """Where the view is served and how often poses are sent."""

    host: str = "127.0.0.1"
    """Loopback by default, like the endpoint; 0.0.0.0 shows it to the network."""
    port: int = 8080
    """0 picks a free port (see `LiveView.port`)."""
    rate: float = 30.0
    """Pose updates per wall-clock second (bounded so the view never slows physics)."""
    follow: str | None = None
    """What the camera follows (`follow.py`): a robot or body by name, "nothing", or None
    for the first robot."""
    linger: bool = False
    """After the run, keep serving (the last state) until Ctrl-C, so a browser opened late
    still sees it; `run_scene` waits, the command line asks for it."""


def _quiet() -> AbstractContextManager[object]:
    """viser prints a banner and "(viser) Server stopped" on stdout whatever `verbose` says:
    they would land in a demo's output (after its JSON line); the log says where the view is."""
    return redirect_stdout(io.StringIO())


class LiveView:
    """Serves `world` at http://host:port until `close()`; `show()` swaps in another world."""

    def __init__(self, world: World, options: ViewOptions | None = None) -> None:
        self.options = opts = options or ViewOptions()
        if not opts.rate > 0:
            raise SimError(f"view rate must be > 0 Hz, got {opts.rate}")
        try:
            import viser  # noqa: PLC0415 - optional dependency, imported on use
        except ImportError as exc:
            raise SimError(
                "--view needs the 'viser' package: pip install 'simbridge[view]' (make installs it)"
            ) from exc
        self.world = world
        with _quiet():
            self.server = viser.ViserServer(host=opts.host, port=opts.port, verbose=False)
        self.port = int(self.server.get_port())
        if opts.port and self.port != opts.port:  # viser moved on to the next free port
            with _quiet():
                self.server.stop()
            raise SimError(
                f"view port {opts.port} on {opts.host} is taken (another view or server); "
                "pick another with --view-port PORT, or --view-port 0 for any free port"
            )
        self.frames_sent = 0
        """Pose updates sent since start (for tests and benchmarks)."""
        self.buttons: dict[str, Any] = {}
        """Demo buttons by label (`add_button`)."""
        self.sensors: SensorFeed | None = None
        self._bodies: dict[int, Any] = {}
        self._last: tuple[np.ndarray, np.ndarray] | None = None
        self._lock = threading.Lock()  # the streaming thread vs `show`
        self._stop = threading.Event()
        self.controls = SimControls(self.server, lambda: self.world)
        with self.server.gui.add_folder("Show") as self._show_folder:
            self.tf = TfFrames(self.server)
            self.contacts = ContactPoints(self.server)
            self.follow = CameraFollow(self.server)
        self.mover = ObjectMover(self.server, lambda: self.world)
        self._demo_folder: Any = None
        try:
            self.show(world)
        except BaseException:  # e.g. nothing of the name to follow: the server goes too
            with _quiet():
                self.server.stop()
            raise
        self._thread = threading.Thread(target=self._stream, name="simbridge-view", daemon=True)
        self._thread.start()
        _log.info("live view at http://%s:%d", opts.host, self.port)

    @property
    def url(self) -> str:
        """Where a browser opens the view."""
        host = "127.0.0.1" if self.options.host in ("", "0.0.0.0") else self.options.host
        return f"http://{host}:{self.port}"

    def show(self, world: World) -> None:
        """Show `world` from now on (a demo's next run builds a new one): its geometry,
        joint sliders and free objects replace the previous world's."""
        with self._lock:
            self.world = world
            self._last = None
            self._bodies.clear()
            self.server.scene.reset()
            self.tf.reset(world.model)
            self.contacts.reset()
            if self.sensors is not None:
                self.sensors.forget_scene()
            self._build_scene(world.model)
            self.follow.reset(world, self.options.follow)
            self.controls.show_joints(world)
            self.mover.reset(world.model)

    def add_button(self, label: str, on_click: Callable[[], None], hint: str | None = None) -> Any:
        """A button in the page's "Demo" folder running `on_click()` (on a viser thread:
        hand long work to your own thread). This is how an app adds its own controls."""
        if label in self.buttons:
            raise SimError(f"the view already has a demo button {label!r}")
        gui = self.server.gui
        if self._demo_folder is None:
            self._demo_folder = gui.add_folder("Demo", order=-1.0)
        with self._demo_folder:
            button = gui.add_button(label, hint=hint)
        button.on_click(lambda _event: on_click())
        self.buttons[label] = button
        return button

    def watch_sensors(self, suite: SensorSuite) -> SensorFeed:
        """Draw `suite`'s lidar returns and camera images. Give the returned feed to the
        publisher that polls the suite (`SensorPublisher.add_observer`)."""
        if self.sensors is not None:
            raise SimError("the view already watches a sensor suite")
        with self.server.gui.add_folder("Sensors", order=self._show_folder.order + 0.5):
            self.sensors = SensorFeed(self.server, suite)
        return self.sensors

    # -- scene ------------------------------------------------------------------------------

    def _build_scene(self, model: mujoco.MjModel) -> None:
        scene = self.server.scene
        names = body_names(model)
        shapes = visual_shapes(model)
        with_shapes = {s.body for s in shapes}
        data = self.world.data
        for body in sorted(with_shapes):
            path = f"/world/{names[body]}"
            handle = scene.add_frame(
                path,
                show_axes=False,
                position=np.array(data.xpos[body]),
                wxyz=np.array(data.xquat[body]),
            )
            if body != 0:
                self._bodies[body] = handle
        for index, shape in enumerate(shapes):
            self._add_shape(scene, f"/world/{names[shape.body]}/{index}_{shape.name}", shape)
        self._aim_camera(shapes)

    def _aim_camera(self, shapes: list[Shape]) -> None:
        """Start browsers looking at the robots and free objects (`framing.py`)."""
        camera = self.server.initial_camera
        framed = framing(self.world, shapes, camera.fov)
        if framed is None:
            return
        camera.look_at = framed.target
        camera.position = framed.position

    @staticmethod
    def _add_shape(scene: viser.SceneApi, path: str, shape: Shape) -> None:
        opacity = shape.rgba[3] if shape.rgba[3] < 1.0 else None
        pose: dict[str, Any] = {"position": shape.position, "wxyz": shape.wxyz}
        color = shape.rgb255
        if shape.kind == "box":
            x, y, z = shape.size
            scene.add_box(path, color=color, dimensions=(x, y, z), opacity=opacity, **pose)
        elif shape.kind == "sphere":
            scene.add_icosphere(path, radius=shape.size[0], color=color, opacity=opacity, **pose)
        elif shape.kind == "cylinder":
            radius, height = shape.size
            scene.add_cylinder(
                path, radius=radius, height=height, color=color, opacity=opacity, **pose
            )
        else:
            assert shape.vertices is not None
            assert shape.faces is not None
            scene.add_mesh_simple(
                path, shape.vertices, shape.faces, color=color, opacity=opacity, **pose
            )

    # -- controls (kept here for callers and tests; see `SimControls`) -----------------------

    def set_joint(self, joint: str, value: float) -> None:
        """Send `joint` to `value` (what its slider does)."""
        self.controls.set_joint(joint, value)

    def toggle_pause(self) -> None:
        """What the Pause/Resume button does."""
        self.controls.toggle_pause()

    def step(self, count: int) -> None:
        """Pause (if running) and advance exactly `count` steps."""
        self.controls.step(count)

    # -- streaming --------------------------------------------------------------------------

    def _stream(self) -> None:
        period = 1.0 / self.options.rate
        last_wall, last_sim = time.perf_counter(), self.world.time
        next_rtf = last_wall + 1.0
        while not self._stop.wait(period):
            try:
                self.push()
            except Exception:  # a view error must never stop the simulation
                _log.exception("live view update failed; the view stops updating")
                return
            now = time.perf_counter()
            if now >= next_rtf:
                sim = self.world.time
                rate = max(sim - last_sim, 0.0) / (now - last_wall)  # a reset goes back
                self.controls.rtf.value = f"{rate:.2f}"  # type: ignore[misc]
                last_wall, last_sim, next_rtf = now, sim, now + 1.0

    def push(self) -> None:
        """Send the current body poses, overlays and clock once (the streaming thread
        calls this)."""
        with self._lock:
            data = self.world.data
            xpos, xquat = np.array(data.xpos), np.array(data.xquat)  # one snapshot
            last = self._last
            if last is None or len(last[0]) != len(xpos):
                moved = list(range(1, len(xpos)))
            else:
                moved = [
                    body
                    for body in range(1, len(xpos))
                    if not (
                        np.allclose(xpos[body], last[0][body], atol=1e-5)
                        and np.allclose(xquat[body], last[1][body], atol=1e-6)
                    )
                ]
            self._last = (xpos, xquat)
            self.follow.update(xpos)
            with self.server.atomic():
                for body in moved:  # bodies at rest cost nothing
                    handle = self._bodies.get(body)
                    if handle is not None:
                        handle.position = xpos[body]
                        handle.wxyz = xquat[body]
                self.tf.update(xpos, xquat, moved)
                self.contacts.update(data)
                if self.sensors is not None:
                    self.sensors.draw()
                self.controls.clock.value = f"{self.world.time:.3f}"  # type: ignore[misc]
            self.frames_sent += 1

    def close(self) -> None:
        """Stop streaming and the server."""
        self._stop.set()
        self._thread.join(timeout=5)
        with _quiet():
            self.server.stop()

    def __enter__(self) -> LiveView:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
