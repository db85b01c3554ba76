"""The running simulation: a scene's state (`WorldState`) stepped with followers and
callbacks, reachable from other threads (`CrossThreadControl`), in a paced run loop."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path

import mujoco

from simbridge.errors import SimError
from simbridge.sim.control.follower import TrajectoryFollower
from simbridge.sim.scene.builder import BuiltScene, build_scene
from simbridge.sim.scene.loader import load_scene
from simbridge.sim.scene.spec import Scene
from simbridge.sim.urdf.document import MjcfDocument
from simbridge.sim.world.callbacks import CallbackHandle, StepCallbacks
from simbridge.sim.world.crossthread import CrossThreadControl
from simbridge.sim.world.pacer import Pacer
from simbridge.sim.world.state import WorldState
from simbridge.sim.world.viewer import open_viewer

__all__ = ["ModelExtension", "RunStats", "StepCallback", "World"]

StepCallback = Callable[["World"], None]
"""Called on the simulation thread after a step (or a reset), with the world."""
ModelExtension = Callable[[MjcfDocument], None]
"""Edits the MJCF document before it is compiled (add sites, cameras, sensors, bodies)."""


@dataclass(frozen=True)
class RunStats:
    """What a `World.run` call did."""

    steps: int
    sim_time: float
    wall_time: float

    @property
    def realtime_factor(self) -> float:
        """Sim seconds per wall second achieved."""
        return self.sim_time / self.wall_time if self.wall_time > 0 else float("inf")


class World(WorldState, CrossThreadControl):
    """A MuJoCo model built from a `Scene`: read and drive it (`WorldState`), step it with
    followers and callbacks, run it paced in real time.

    Not thread-safe except what `CrossThreadControl` gives (`post`, `pause`, `resume`,
    `request_steps`, `request_reset`, `stop`), which other threads (e.g. ROS callbacks)
    use to reach the simulation thread.
    """

    def __init__(self, built: BuiltScene, model: mujoco.MjModel | None = None) -> None:
        WorldState.__init__(self, built, model)
        CrossThreadControl.__init__(self)
        self._callbacks: StepCallbacks[World] = StepCallbacks(window=0.001)
        self.follower = TrajectoryFollower(self.drives)
        """The world's own follower (scene-wide trajectories, the apps' motions); others
        join it with `add_follower`."""
        self._callbacks.add_follower(self.follower)
        self.reset()

    @classmethod
    def from_scene(
        cls, scene: Scene | str | Path, extensions: Sequence[ModelExtension] = ()
    ) -> World:
        """Build a world from a `Scene` or a scene YAML path; `extensions` edit the MJCF
        document first (this is how sensors add sites and cameras on links by name)."""
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        built = build_scene(scene)
        for extend in extensions:
            extend(built.document)
        return cls(built)

    def clone(self) -> World:
        """Another world on the same compiled model (no recompile): its own MjData, drives,
        RNG and callbacks, at time 0. Drive gains live in the model, so `drives.set_spec`
        changes them for every clone (e.g. the worlds of a vectorised learning env)."""
        return World(self.built, self.model)

    # ---- followers and callbacks -----------------------------------------------------------

    def add_follower(self, follower: TrajectoryFollower) -> CallbackHandle:
        """Update `follower` before every physics step, as the world's own `follower`
        (a controller's, or a namespaced robot's); cancelled at every reset."""
        return self._callbacks.add_follower(follower)

    def add_step_callback(self, fn: StepCallback, period: float | None = None) -> CallbackHandle:
        """Call `fn(world)` after every step, or at t = k * `period` of sim time (at the
        first step reaching each such t, counted in whole steps so the rate is exact);
        `remove()` the handle to stop."""
        return self._callbacks.add_step(fn, period, self.step_count, self.timestep)

    def add_reset_callback(self, fn: StepCallback) -> CallbackHandle:
        """Call `fn(world)` after every `reset()` (e.g. to restart sensor schedules);
        `remove()` the handle to stop."""
        return self._callbacks.add_reset(fn)

    def add_callback_scope(self, scope: AbstractContextManager[object]) -> CallbackHandle:
        """Enter `scope` (a reusable context manager, e.g. `Connector.batch()`) before the
        first due callback and leave it at the end of `step`, or, in `run`, once the run
        is about to sleep, pause or end, or after `batch_window` seconds: the messages of
        the steps in between leave together. `remove()` the handle to stop using it."""
        return self._callbacks.add_scope(scope)

    @property
    def batch_window(self) -> float:
        """Wall-clock seconds `run` may keep the callback scopes entered across steps (1 ms
        by default; 0: left after each step's callbacks). Running flat out, a step takes
        tens of microseconds, about what one socket write costs."""
        return self._callbacks.scopes.window

    @batch_window.setter
    def batch_window(self, seconds: float) -> None:
        if not (seconds >= 0 and math.isfinite(seconds)):
            raise SimError(f"batch_window must be >= 0 seconds, got {seconds!r}")
        self._callbacks.scopes.window = seconds

    # ---- stepping --------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to time 0: initial joint positions, drives holding them, RNG reseeded,
        followers cancelled, schedules restarted; then the reset callbacks run."""
        self.restore_initial()
        self._callbacks.after_reset(self, self.timestep)

    def step(self, count: int = 1) -> None:
        """Advance `count` physics steps, running posted work, the followers before each
        and the due callbacks after it (callbacks that read poses get them for the new
        time, see `refresh`)."""
        data, callbacks = self.data, self._callbacks
        followers, scopes = callbacks.followers, callbacks.scopes
        try:
            for _ in range(count):
                self.process_posted()
                for follower in followers:
                    follower.update(data.time)
                step, timestep = self.physics_step()
                callbacks.run_due(self, step, timestep)
                if scopes.open:
                    scopes.close_if_due()
        finally:
            if not self.running:
                scopes.close()

    def run(
        self,
        duration: float | None = None,
        realtime_factor: float | None = None,
        viewer: bool = False,
    ) -> RunStats:
        """Step until `duration` sim seconds pass (forever if None) or `stop()` is called,
        paced at `realtime_factor` (scene's value if None, 0 = as fast as possible);
        `viewer` opens MuJoCo's passive viewer (needs a display)."""
        factor = self.scene.physics.realtime_factor if realtime_factor is None else realtime_factor
        handle = open_viewer(self.model, self.data) if viewer else None
        pacer = Pacer(factor)
        pacer.restart(self.time)
        start_wall, steps, sim_elapsed = time.perf_counter(), 0, 0.0
        last_sync = 0.0
        scopes = self._callbacks.scopes
        self.begin_run()
        try:
            while not self.stop_requested:
                if duration is not None and sim_elapsed >= duration - 1e-9:
                    break
                self.process_posted()
                if not self.take_step():  # paused, no step granted
                    scopes.close()
                    self.holding()
                    time.sleep(0.002)
                    pacer.restart(self.time)
                    continue
                before = self.time
                self.step()
                steps += 1
                sim_elapsed += max(self.time - before, 0.0)
                pacer.wait(self.time, before_sleep=scopes.close)
                if handle is not None and time.perf_counter() - last_sync > 1 / 60:
                    if not handle.is_running():
                        break
                    handle.sync()
                    last_sync = time.perf_counter()
        finally:
            self.end_run()
            scopes.close()
            if handle is not None:
                handle.close()
        return RunStats(steps, sim_elapsed, time.perf_counter() - start_wall)
