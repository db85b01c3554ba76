"""The running simulation: a compiled scene, its drives, step callbacks and a paced run loop."""

from __future__ import annotations

import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError
from simbridge.sim.control.drive_bank import DriveBank
from simbridge.sim.control.follower import TrajectoryFollower
from simbridge.sim.scene.builder import BuiltScene, build_scene
from simbridge.sim.scene.loader import load_scene
from simbridge.sim.scene.model import Scene
from simbridge.sim.sensors.schedule import RateSchedule
from simbridge.sim.urdf.document import MjcfDocument
from simbridge.sim.urdf.transforms import Transform
from simbridge.sim.world.pacer import Pacer
from simbridge.sim.world.robot import RobotHandle
from simbridge.sim.world.scopes import CallbackScopes

__all__ = ["ModelExtension", "RunStats", "StepCallback", "World"]

_NEVER = 2**62
"""A step no run reaches (no scheduled callback is waiting)."""

StepCallback = Callable[["World"], None]
"""Called on the simulation thread after a step, with the world."""
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


@dataclass
class _Callback:
    fn: StepCallback
    schedule: RateSchedule | None


class World:
    """A MuJoCo model built from a `Scene`; step it, read joint and link state, drive joints.

    Not thread-safe except `post`, `pause`, `resume`, `request_steps`, `request_reset` and
    `stop`, which other threads (e.g. ROS callbacks) use to reach the simulation thread.
    """

    def __init__(self, built: BuiltScene, model: mujoco.MjModel | None = None) -> None:
        self._built = built
        self.scene: Scene = built.scene
        self.document = built.document
        self.model: mujoco.MjModel = built.document.compile() if model is None else model
        self.data = mujoco.MjData(self.model)
        self.robots = {r.name: RobotHandle(r, self.model) for r in built.robots}
        self._slot_table = {
            n: (n, s.qpos, s.dof) for r in self.robots.values() for n, s in r.joints.items()
        }
        self._all_slots = list(self._slot_table.values())
        self._body_ids: dict[str, int] = {}
        specs = {name: spec for r in built.robots for name, spec in r.drives.items()}
        self.drives = DriveBank(self.model, self.data, specs)
        self.follower = TrajectoryFollower(self.drives)
        self._rng: np.random.Generator | None = None
        self._callbacks: dict[int, _Callback] = {}
        self._reset_callbacks: list[StepCallback] = []
        self._scopes = CallbackScopes(window=0.001)
        self._running = False
        """Inside `run`, which leaves the scopes itself (not at the end of each `step`)."""
        self._run_thread: int | None = None
        self._holding = threading.Event()
        """Set by `run` while it holds time still between steps (see `pause(wait=...)`)."""
        self._next_id = 0
        self._posted: deque[Callable[[], None]] = deque()
        self._lock = threading.Lock()
        self._paused = False
        self._pending_steps = 0
        self._reset_requested = False
        self._stop = threading.Event()
        self._steps = 0
        self._derived_stale = False
        self._state_stale = False
        """Poses, velocity terms and actuator forces lag the state (`refresh_state`)."""
        self._opt = self.model.opt
        """The model's options, held once (`model.opt` builds a new accessor per read)."""
        self._next_due = 0
        """No callback is due before this step (at `_due_timestep`): `step` skips the
        callback loop until then. 0 forces a check (after callbacks or the timestep change)."""
        self._due_timestep = 0.0
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
        return World(self._built, self.model)

    # ---- state -----------------------------------------------------------------------------

    @property
    def rng(self) -> np.random.Generator:
        """The scene's random generator, seeded from `physics.seed` at every reset."""
        if self._rng is None:
            self._rng = np.random.default_rng(self.scene.physics.seed)
        return self._rng

    @property
    def time(self) -> float:
        """Simulated time in seconds since the last reset."""
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        """Seconds of sim time per step."""
        return float(self._opt.timestep)

    @property
    def step_count(self) -> int:
        """Physics steps since the last reset (`time` is exactly this times `timestep`)."""
        return self._steps

    def refresh(self) -> None:
        """Bring MuJoCo's derived quantities (body poses, velocities, accelerations,
        actuator forces) up to the current state.

        `mj_step` integrates positions and velocities to the new time but leaves what it
        derived from them describing the state one step earlier. Reading poses after a
        step without this would pair the new stamp with the old pose. Runs `mj_forward`
        at most once per step, and only when something reads derived state; it changes
        no state, so the trajectory is the same with or without it.
        """
        if self._derived_stale:
            mujoco.mj_forward(self.model, self.data)
            self._derived_stale = self._state_stale = False

    def refresh_state(self) -> None:
        """Like `refresh`, but only what joint states and TF read: body poses, velocity
        terms and actuator forces, the same numbers `mj_forward` gives, at well under
        half its cost (no collision detection, constraint forces, accelerations or sensor
        values, which `refresh` still brings up to date when something reads them)."""
        if self._state_stale and self._derived_stale:
            model, data = self.model, self.data
            if model.nflex:  # flexes need mj_fwdPosition's mj_flex: the whole forward
                mujoco.mj_forward(model, data)
                self._derived_stale = False
            else:
                mujoco.mj_kinematics(model, data)
                mujoco.mj_comPos(model, data)
                mujoco.mj_tendon(model, data)
                mujoco.mj_transmission(model, data)
                mujoco.mj_fwdVelocity(model, data)
                mujoco.mj_fwdActuation(model, data)
        self._state_stale = False

    def robot(self, name: str | None = None) -> RobotHandle:
        """The robot called `name` (or the only one)."""
        if name is None and len(self.robots) == 1:
            return next(iter(self.robots.values()))
        if name not in self.robots:
            raise SimError(f"unknown robot '{name}' (robots: {', '.join(self.robots) or 'none'})")
        return self.robots[name]

    def _slots(self, names: Sequence[str] | None) -> list[tuple[str, int, int]]:
        if names is None:
            return self._all_slots
        table = self._slot_table
        out = []
        for name in names:
            if name not in table:
                raise SimError(f"unknown joint '{name}' (joints: {', '.join(table) or 'none'})")
            out.append(table[name])
        return out

    def joint_names(self) -> list[str]:
        """Every robot's 1-DoF joint names (the /joint_states set)."""
        return [n for r in self.robots.values() for n in r.joint_names]

    def joint_indices(
        self, names: Sequence[str] | None = None
    ) -> tuple[list[str], NDArray[np.intp], NDArray[np.intp]]:
        """(names, their qpos indices, their dof indices) of `names` (every 1-DoF joint if
        None), to read many joints from `data.qpos`/`qvel`/`qfrc_actuator` at once."""
        slots = self._slots(names)
        return (
            [n for n, _, _ in slots],
            np.array([q for _, q, _ in slots], dtype=np.intp),
            np.array([d for _, _, d in slots], dtype=np.intp),
        )

    def joint_positions(self, names: Sequence[str] | None = None) -> dict[str, float]:
        """Joint positions (rad or m)."""
        return {n: float(self.data.qpos[q]) for n, q, _ in self._slots(names)}

    def joint_velocities(self, names: Sequence[str] | None = None) -> dict[str, float]:
        """Joint velocities (rad/s or m/s)."""
        return {n: float(self.data.qvel[d]) for n, _, d in self._slots(names)}

    def joint_efforts(self, names: Sequence[str] | None = None) -> dict[str, float]:
        """Force or torque the drives apply to each joint (N or N m)."""
        self.refresh()
        return {n: float(self.data.qfrc_actuator[d]) for n, _, d in self._slots(names)}

    def link_pose(self, name: str) -> Transform:
        """World pose of body `name` (a URDF link name with its robot's prefix, or an object)."""
        self.refresh()
        body = self._body_ids.get(name)
        if body is None:
            try:
                body = self._body_ids[name] = self.model.body(name).id
            except KeyError:
                raise SimError(f"unknown link or body '{name}'") from None
        return Transform(self.data.xmat[body].reshape(3, 3).copy(), self.data.xpos[body].copy())

    def link_poses(self, robot: str | None = None) -> dict[str, Transform]:
        """World poses of every link of `robot` (or of the only robot)."""
        return {name: self.link_pose(name) for name in self.robot(robot).bodies}

    # ---- commands --------------------------------------------------------------------------

    def set_joint_positions(self, values: Mapping[str, float]) -> None:
        """Teleport joints (kinematic follower): set positions, zero velocities, move drive
        targets there and update mimic joints, then recompute poses."""
        for name, qpos, dof in self._slots(list(values)):
            self.data.qpos[qpos] = values[name]
            self.data.qvel[dof] = 0.0
            if name in self.drives.joints:
                self.drives.set_position(name, values[name])
        self._sync_mimics()
        mujoco.mj_forward(self.model, self.data)
        self._derived_stale = self._state_stale = False

    def _sync_mimics(self) -> None:
        for robot in self.robots.values():
            for name, slot in robot.joints.items():
                mimic = robot.mimic_of(name)
                if mimic is not None:
                    leader, multiplier, offset = mimic
                    lead = robot.joints[leader]
                    self.data.qpos[slot.qpos] = multiplier * self.data.qpos[lead.qpos] + offset
                    self.data.qvel[slot.dof] = multiplier * self.data.qvel[lead.dof]

    # ---- callbacks and threads -------------------------------------------------------------

    def add_step_callback(self, fn: StepCallback, period: float | None = None) -> int:
        """Call `fn(world)` after every step, or at t = k * `period` of sim time (at the
        first step reaching each such t, counted in whole steps so the rate is exact);
        returns an id for `remove_step_callback`."""
        schedule = None
        if period is not None:
            if not (period > 0 and math.isfinite(period)):
                raise SimError(f"callback period must be > 0 seconds, got {period}")
            schedule = RateSchedule(1.0 / period)
            schedule.skip_through(self._steps, self.timestep)
        self._next_id += 1
        self._callbacks[self._next_id] = _Callback(fn, schedule)
        self._next_due = 0
        return self._next_id

    def add_callback_scope(self, scope: AbstractContextManager[object]) -> int:
        """Enter `scope` (a reusable context manager, e.g. `Connector.batch()`) before the
        first due callback and leave it at the end of `step`, or, in `run`, once the run
        is about to sleep, pause or end, or after `batch_window` seconds: the messages of
        the steps in between leave together. Returns an id for `remove_callback_scope`."""
        self._next_id += 1
        self._scopes.add(self._next_id, scope)
        return self._next_id

    def remove_callback_scope(self, scope_id: int) -> None:
        """Stop using a scope added with `add_callback_scope`."""
        self._scopes.remove(scope_id)

    @property
    def batch_window(self) -> float:
        """Wall-clock seconds `run` may keep the callback scopes entered across steps (1 ms
        by default; 0: left after each step's callbacks). Running flat out, a step takes
        tens of microseconds, about what one socket write costs."""
        return self._scopes.window

    @batch_window.setter
    def batch_window(self, seconds: float) -> None:
        if not (seconds >= 0 and math.isfinite(seconds)):
            raise SimError(f"batch_window must be >= 0 seconds, got {seconds!r}")
        self._scopes.window = seconds

    def add_reset_callback(self, fn: StepCallback) -> None:
        """Call `fn(world)` after every `reset()` (e.g. to restart sensor schedules)."""
        self._reset_callbacks.append(fn)

    def remove_step_callback(self, callback_id: int) -> None:
        """Stop calling a callback added with `add_step_callback`."""
        self._callbacks.pop(callback_id, None)

    def post(self, fn: Callable[[], None]) -> None:
        """Run `fn()` on the simulation thread before the next step (thread-safe)."""
        self._posted.append(fn)

    def pause(self, wait: float = 0.0) -> bool:
        """Stop advancing time in `run` (thread-safe). With `wait` > 0 and `run` going on
        another thread, wait up to that many seconds for the step in progress to finish,
        so time no longer changes on return; returns whether it is held (True when there
        was nothing to wait for)."""
        self._holding.clear()
        self._paused = True
        if wait <= 0 or not self._running or self._run_thread == threading.get_ident():
            return True
        return self._holding.wait(wait)

    def resume(self) -> None:
        """Continue advancing time in `run` (thread-safe)."""
        self._paused = False
        self._holding.clear()

    @property
    def paused(self) -> bool:
        """Whether `run` is holding time still."""
        return self._paused

    def request_steps(self, count: int) -> None:
        """While paused, let `run` advance exactly `count` more steps (thread-safe)."""
        if count < 0:
            raise SimError(f"step count must be >= 0, got {count}")
        if not self._paused:
            raise SimError("request_steps needs a paused world (call pause() first)")
        with self._lock:
            self._pending_steps += count

    def hold_while_paused(self, poll: float = 0.002) -> None:
        """For loops that call `step` themselves (not `run`): while paused, wait, running
        posted work, until resumed, or until a step granted by `request_steps` is due
        (which this takes). Returns at once when not paused."""
        while self._paused:
            self.process_posted()
            with self._lock:
                if self._pending_steps > 0:
                    self._pending_steps -= 1
                    return
            time.sleep(poll)

    def request_reset(self) -> None:
        """Reset at the start of `run`'s next iteration (thread-safe)."""
        self._reset_requested = True

    def stop(self) -> None:
        """Make `run` return after the current step (thread-safe)."""
        self._stop.set()

    def process_posted(self) -> None:
        """Run what other threads posted, and a requested reset (done by `run` and `step`)."""
        if self._reset_requested:
            self._reset_requested = False
            self.reset()
        while self._posted:  # deque appends and pops are atomic; this is the only consumer
            self._posted.popleft()()

    # ---- stepping --------------------------------------------------------------------------

    def reset(self) -> None:
        """Back to time 0: initial joint positions, drives holding them, RNG reseeded."""
        mujoco.mj_resetData(self.model, self.data)
        self._steps = 0
        for robot in self.robots.values():
            for name, value in robot.built.spec.initial_positions.items():
                self.data.qpos[robot.joints[robot.prefix + name].qpos] = value
        self._sync_mimics()
        mujoco.mj_forward(self.model, self.data)
        self._derived_stale = self._state_stale = False
        self.drives.hold_current()
        self.follower.cancel()
        self._rng = None  # reseeded when next used: a Generator costs tens of microseconds
        for cb in self._callbacks.values():
            if cb.schedule is not None:
                cb.schedule.reset()
                cb.schedule.skip_through(0, self.timestep)
        self._next_due = 0
        for fn in self._reset_callbacks:
            fn(self)

    def step(self, count: int = 1) -> None:
        """Advance `count` physics steps, running posted work and due callbacks.

        The clock is the step count times the timestep (not a running sum, which drifts),
        and callbacks that read poses get them for the new time (see `refresh`).
        """
        model, data, opt, scopes = self.model, self.data, self._opt, self._scopes
        try:
            for _ in range(count):
                self.process_posted()
                self.follower.update(data.time)
                mujoco.mj_step(model, data)
                self._steps = step = self._steps + 1
                timestep = opt.timestep
                data.time = step * timestep
                self._derived_stale = self._state_stale = True
                if step >= self._next_due or timestep != self._due_timestep:
                    self._run_callbacks(step, timestep)
                if scopes.open:
                    scopes.close_if_due()
        finally:
            if not self._running:
                scopes.close()

    def _run_callbacks(self, step: int, timestep: float) -> None:
        """Call the callbacks due at `step` (the scopes entered before the first due one),
        then note the next step any can be due."""
        self._next_due = -1
        nearest = _NEVER
        scopes = self._scopes
        try:
            for cb in list(self._callbacks.values()):
                schedule = cb.schedule
                if schedule is None or schedule.due(step, timestep):
                    if not scopes.open:
                        scopes.enter()
                    cb.fn(self)
                if schedule is None:
                    nearest = step + 1
                else:
                    nearest = min(nearest, schedule.next_step(timestep))
        except BaseException:
            scopes.close()
            raise
        if self._next_due == -1:  # else a callback added one or reset: check next step
            self._next_due = nearest
            self._due_timestep = timestep

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
        handle = self._open_viewer() if viewer else None
        pacer = Pacer(factor)
        pacer.restart(self.time)
        self._stop.clear()
        start_wall, steps, sim_elapsed = time.perf_counter(), 0, 0.0
        last_sync = 0.0
        scopes = self._scopes
        self._run_thread = threading.get_ident()
        self._running = True
        try:
            while not self._stop.is_set():
                if duration is not None and sim_elapsed >= duration - 1e-9:
                    break
                self.process_posted()
                if self._paused and self._pending_steps == 0:
                    scopes.close()
                    self._holding.set()
                    time.sleep(0.002)
                    pacer.restart(self.time)
                    continue
                if self._paused:
                    with self._lock:
                        self._pending_steps -= 1
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
            self._running = False
            self._run_thread = None
            self._holding.set()  # no step can follow: release `pause(wait=...)` callers
            scopes.close()
            if handle is not None:
                handle.close()
        return RunStats(steps, sim_elapsed, time.perf_counter() - start_wall)

    def _open_viewer(self) -> mujoco.viewer.Handle:
        if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise SimError("the viewer needs a display, but DISPLAY is not set (run headless)")
        import mujoco.viewer  # noqa: PLC0415 - pulls in GLFW, only wanted with a display

        try:
            return mujoco.viewer.launch_passive(self.model, self.data)
        except Exception as exc:  # GLFW init failures surface as RuntimeError and others
            raise SimError(f"could not open the MuJoCo viewer: {exc}") from None
