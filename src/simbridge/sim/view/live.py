"""A live 3D view of a running `World` in the browser, served by `viser`.

Geometry is sent once when the view starts (and to each browser that connects); a
streaming thread then samples body poses at a bounded wall-clock rate (30 Hz by
default) and sends only those, so the physics thread never waits on the view, and a
browser that goes away costs nothing. The page has pause/resume, step N, reset, the
sim clock and real-time factor, and a slider per joint (drive target, like
joint_state_publisher_gui).
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from simbridge.errors import SimError
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


class LiveView:
    """Serves `world` at http://host:port until `close()`."""

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
        self.server = viser.ViserServer(host=opts.host, port=opts.port, verbose=False)
        self.port = int(self.server.get_port())
        self.frames_sent = 0
        """Pose updates sent since start (for tests and benchmarks)."""
        self._bodies: dict[int, Any] = {}
        self._last: tuple[np.ndarray, np.ndarray] | None = None
        self._stop = threading.Event()
        self._build_scene(world.model)
        self._build_gui()
        self._thread = threading.Thread(target=self._stream, name="simbridge-view", daemon=True)
        self._thread.start()
        _log.info("live view at http://%s:%d", opts.host, self.port)

    @property
    def url(self) -> str:
        """Where a browser opens the view."""
        host = "127.0.0.1" if self.options.host in ("", "0.0.0.0") else self.options.host
        return f"http://{host}:{self.port}"

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
        self._aim_camera(np.array([data.xpos[b] for b in with_shapes if b != 0]))

    def _aim_camera(self, points: np.ndarray) -> None:
        """Start browsers looking at the moving bodies from a diagonal, at a distance that
        frames them."""
        if len(points) == 0:
            return
        center = points.mean(axis=0)
        extent = max(0.8, float(np.linalg.norm(points - center, axis=1).max()) * 2.5)
        camera = self.server.initial_camera
        camera.look_at = (float(center[0]), float(center[1]), float(center[2]))
        camera.position = center + np.array([1.2, 1.0, 0.8]) * extent

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

    # -- controls ---------------------------------------------------------------------------

    def _build_gui(self) -> None:
        gui = self.server.gui
        self._clock = gui.add_text("sim time (s)", initial_value="0.000", disabled=True)
        self._rtf = gui.add_text("real-time factor", initial_value="-", disabled=True)
        self._pause = gui.add_button("Pause")
        self._pause.on_click(lambda _event: self.toggle_pause())
        self._steps = gui.add_number("steps", initial_value=10, min=1, step=1)
        gui.add_button("Step N").on_click(lambda _event: self.step(int(self._steps.value)))
        gui.add_button("Reset").on_click(lambda _event: self.world.request_reset())
        model = self.world.model
        with gui.add_folder("Joints"):
            for name in self.world.joint_names():
                jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
                if jid < 0 or int(model.jnt_type[jid]) not in (
                    mujoco.mjtJoint.mjJNT_HINGE,
                    mujoco.mjtJoint.mjJNT_SLIDE,
                ):
                    continue
                low, high = (float(v) for v in model.jnt_range[jid])
                if not model.jnt_limited[jid] or not high > low:
                    low, high = -np.pi, np.pi
                value = float(np.clip(self.world.data.qpos[model.jnt_qposadr[jid]], low, high))
                slider = gui.add_slider(
                    name, min=low, max=high, step=(high - low) / 200, initial_value=value
                )
                slider.on_update(self._slider_handler(name, slider))

    def _slider_handler(self, joint: str, slider: Any) -> Any:
        def moved(_event: Any) -> None:
            self.set_joint(joint, float(slider.value))

        return moved

    def set_joint(self, joint: str, value: float) -> None:
        """Send `joint` to `value`: its drive's target, or a teleport for undriven joints
        (applied on the simulation thread)."""
        world = self.world

        def apply() -> None:
            if joint in world.drives.joints:
                world.drives.set_position(joint, value)
            else:
                world.set_joint_positions({joint: value})

        world.post(apply)

    def toggle_pause(self) -> None:
        """What the Pause/Resume button does."""
        if self.world.paused:
            self.world.resume()
            self._pause.label = "Pause"
        else:
            self.world.pause()
            self._pause.label = "Resume"

    def step(self, count: int) -> None:
        """Pause (if running) and advance exactly `count` steps."""
        if not self.world.paused:
            self.toggle_pause()
        self.world.request_steps(max(count, 0))

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
                self._rtf.value = f"{(sim - last_sim) / (now - last_wall):.2f}"  # type: ignore[misc]
                last_wall, last_sim, next_rtf = now, sim, now + 1.0

    def push(self) -> None:
        """Send the current body poses and clock once (the streaming thread calls this)."""
        data = self.world.data
        xpos, xquat = np.array(data.xpos), np.array(data.xquat)  # one snapshot
        last = self._last
        moved = [
            body
            for body in self._bodies
            if last is None
            or not (
                np.allclose(xpos[body], last[0][body], atol=1e-5)
                and np.allclose(xquat[body], last[1][body], atol=1e-6)
            )
        ]
        self._last = (xpos, xquat)
        with self.server.atomic():
            for body in moved:  # bodies at rest cost nothing
                handle = self._bodies[body]
                handle.position = xpos[body]
                handle.wxyz = xquat[body]
            self._clock.value = f"{self.world.time:.3f}"  # type: ignore[misc]
        self.frames_sent += 1

    def close(self) -> None:
        """Stop streaming and the server."""
        self._stop.set()
        self._thread.join(timeout=5)
        self.server.stop()

    def __enter__(self) -> LiveView:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
