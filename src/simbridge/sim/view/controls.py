"""The page's simulation controls: clock, real-time factor, pause/resume, step N, reset,
and a slider per robot joint (drive target, the role joint_state_publisher_gui plays).

Every control reaches the physics through `World`'s thread-safe requests; the world is
looked up at each use, so the controls stay valid when a demo shows a new world.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from simbridge.sim.world.world import World

if TYPE_CHECKING:
    import viser

__all__ = ["PAUSE_WAIT_S", "SimControls", "joint_slider_ranges"]

PAUSE_WAIT_S = 5.0
"""How long the Pause button waits for the simulation thread to finish its step."""


def joint_slider_ranges(world: World) -> dict[str, tuple[float, float, float]]:
    """Hinge and slide joints of the robots -> (low, high, current) for their sliders
    (an unlimited joint gets [-pi, pi])."""
    model = world.model
    ranges: dict[str, tuple[float, float, float]] = {}
    for name in world.joint_names():
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid < 0 or int(model.jnt_type[jid]) not in (
            mujoco.mjtJoint.mjJNT_HINGE,
            mujoco.mjtJoint.mjJNT_SLIDE,
        ):
            continue
        low, high = (float(v) for v in model.jnt_range[jid])
        if not model.jnt_limited[jid] or not high > low:
            low, high = -np.pi, np.pi
        value = float(np.clip(world.data.qpos[model.jnt_qposadr[jid]], low, high))
        ranges[name] = (low, high, value)
    return ranges


class SimControls:
    """Builds the controls in the page; `world()` is the world they act on now."""

    def __init__(self, server: viser.ViserServer, world: Callable[[], World]) -> None:
        self.server = server
        self._world = world
        gui = server.gui
        self.clock = gui.add_text("sim time (s)", initial_value="0.000", disabled=True)
        self.rtf = gui.add_text("real-time factor", initial_value="-", disabled=True)
        self.pause_button = gui.add_button("Pause")
        self.pause_button.on_click(lambda _event: self.toggle_pause())
        self.steps = gui.add_number("steps", initial_value=10, min=1, step=1)
        gui.add_button("Step N").on_click(lambda _event: self.step(int(self.steps.value)))
        gui.add_button("Reset").on_click(lambda _event: self._world().request_reset())
        self.sliders: dict[str, Any] = {}
        self._folder: Any = None

    def show_joints(self, world: World) -> None:
        """(Re)build the joint sliders for `world`'s robots."""
        if self._folder is not None:
            self._folder.remove()
        self.sliders.clear()
        gui = self.server.gui
        with gui.add_folder("Joints") as folder:
            for name, (low, high, value) in joint_slider_ranges(world).items():
                slider = gui.add_slider(
                    name, min=low, max=high, step=(high - low) / 200, initial_value=value
                )
                slider.on_update(self._slider_handler(name, slider))
                self.sliders[name] = slider
        self._folder = folder

    def _slider_handler(self, joint: str, slider: Any) -> Callable[[Any], None]:
        def moved(_event: Any) -> None:
            self.set_joint(joint, float(slider.value))

        return moved

    def set_joint(self, joint: str, value: float) -> None:
        """Send `joint` to `value`: its drive's target, or a teleport for undriven joints
        (applied on the simulation thread)."""
        world = self._world()

        def apply() -> None:
            if joint in world.drives.joints:
                world.drives.set_position(joint, value)
            else:
                world.set_joint_positions({joint: value})

        world.post(apply)

    def toggle_pause(self) -> None:
        """What the Pause/Resume button does. Pausing returns once the step in progress is
        done (at most PAUSE_WAIT_S), so the clock read after it (and the label) stays put."""
        world = self._world()
        if world.paused:
            world.resume()
            self.pause_button.label = "Pause"
        else:
            world.pause(wait=PAUSE_WAIT_S)
            self.pause_button.label = "Resume"

    def step(self, count: int) -> None:
        """Pause (if running) and advance exactly `count` steps."""
        if not self._world().paused:
            self.toggle_pause()
        self._world().request_steps(max(count, 0))
