"""The line's supervisor: runs the two arm cells side by side and hands parts over on the
pallet. It plans while the simulation is paused (std_srvs/SetBool on
`<services_prefix>/pause`), so planning time never shows as idle sim time, and moves robots
only through their cells' action goals.

Pipelined as a real line is: arm_in picks the next part while arm_out unloads the last one,
and waits, holding it, until the pallet is back at the load station.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from simbridge.apps.line.cells import ArmCell, ConveyorCell
from simbridge.apps.line.planner import ArmPlanner, Transfer, pallet_box, part_box
from simbridge.apps.line.task import ARM_BASES, CONVEYOR_X, PART_SIZE, TRAVEL_M, LineTask
from simbridge.errors import AppError, SimbridgeError
from simbridge.planning import BoxObstacle

__all__ = ["LineSupervisor"]


class _Pallet:
    """The pallet's hand-over state, shared by the two cells: which station it waits at and
    which part (if any) it carries; a failure on either side releases every waiter."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self.station = "load"
        self.carrying: int | None = None
        self.failed = False

    def wait_for(self, station: str, carrying: int | None, timeout: float) -> None:
        """Block until the pallet waits at ``station`` carrying ``carrying``."""
        with self._cond:
            ready = self._cond.wait_for(
                lambda: self.failed or (self.station == station and self.carrying == carrying),
                timeout,
            )
            if self.failed:
                raise AppError("the other cell failed")
            if not ready:
                raise AppError(
                    f"the pallet never reached the {station} station with part {carrying} "
                    f"in {timeout:g} s"
                )

    def set(self, station: str, carrying: int | None) -> None:
        """The pallet now waits at ``station`` carrying ``carrying`` (or is moving: "")."""
        with self._cond:
            self.station, self.carrying = station, carrying
            self._cond.notify_all()

    def fail(self) -> None:
        """Release every waiter with an error."""
        with self._cond:
            self.failed = True
            self._cond.notify_all()


class LineSupervisor:
    """Moves every part of ``task`` from the input area to its output slot:
    arm_in -> pallet -> conveyor -> arm_out -> output slot."""

    def __init__(
        self,
        task: LineTask,
        arm_in: ArmCell,
        arm_out: ArmCell,
        conveyor: ConveyorCell,
        set_paused: Callable[[bool], None],
        *,
        sim_time: Callable[[], float] = lambda: 0.0,
        progress: Callable[[str], None] = lambda _text: None,
        seed: int = 0,
        handover_timeout_s: float = 120.0,
    ) -> None:
        self.task = task
        self._set_paused = set_paused
        """Pauses (True) or resumes the simulation (the sim's `<services_prefix>/pause`)."""
        self.arm_in, self.arm_out, self.conveyor = arm_in, arm_out, conveyor
        self.sim_time = sim_time
        self.say = progress
        self.handover_timeout_s = handover_timeout_s
        self.planners = {
            "arm_in": ArmPlanner(ARM_BASES["arm_in"], seed),
            "arm_out": ArmPlanner(ARM_BASES["arm_out"], seed),
        }
        self.planning_wall_s = 0.0
        self.first_goal_at: float | None = None
        self.last_delivery_at: float | None = None
        self._pallet = _Pallet()
        self._pause_lock = threading.Lock()
        self._pausers = 0
        self._errors: list[str] = []

    # --- planning, with the simulation paused ----------------------------------------------

    def _pause(self, paused: bool) -> None:
        """Counted: the simulation runs again when the last planner is done."""
        with self._pause_lock:
            self._pausers += 1 if paused else -1
            if self._pausers == (1 if paused else 0):
                self._set_paused(paused)

    def _plan(
        self,
        what: str,
        arm: str,
        pick: tuple[float, float, float, float],
        place: tuple[float, float, float],
        obstacles: list[BoxObstacle],
    ) -> Transfer:
        began = time.perf_counter()
        cell = self.arm_in if arm == "arm_in" else self.arm_out
        self._pause(True)
        try:
            transfer = self.planners[arm].transfer(cell.positions(), pick, place, obstacles)
        finally:
            self._pause(False)
            self.planning_wall_s += time.perf_counter() - began
        self.say(f"[line] planned {what} in {transfer.planning_time * 1000:.0f} ms")
        return transfer

    # --- the two cells ---------------------------------------------------------------------

    def _pick(self, cell: ArmCell, transfer: Transfer, what: str) -> None:
        cell.follow(transfer.pre_grasp, f"{what}: pre-grasp")
        cell.follow(transfer.grasp, f"{what}: grasp")
        cell.grip(True)
        cell.follow(transfer.pick_up, f"{what}: pick up")

    def _place(self, cell: ArmCell, transfer: Transfer, what: str) -> None:
        cell.follow(transfer.place, f"{what}: place")
        cell.grip(False)
        cell.follow(transfer.retreat, f"{what}: retreat")

    def _loading(self) -> None:
        """arm_in: pick each part, set it on the pallet at the load station, send it off."""
        parts = self.task.parts
        load = self.task.pallet_slot(0.0)
        for index, part in enumerate(parts):
            waiting = [
                part_box(f"part_{j}", (p.x, p.y, PART_SIZE / 2))
                for j, p in enumerate(parts)
                if j > index
            ]
            what = f"part {index} (arm_in)"
            transfer = self._plan(
                f"part {index} onto the pallet",
                "arm_in",
                (part.x, part.y, PART_SIZE / 2, part.yaw),
                load,
                [pallet_box(load[1], CONVEYOR_X), *waiting],
            )
            self._pick(self.arm_in, transfer, what)
            self._pallet.wait_for("load", None, self.handover_timeout_s)
            self._place(self.arm_in, transfer, what)
            self._pallet.set("", index)
            self.conveyor.move_to(-TRAVEL_M, f"part {index} to the unload station")
            self._pallet.set("unload", index)

    def _unloading(self) -> None:
        """arm_out: take each part off the pallet, send the pallet back, set the part down."""
        for index in range(len(self.task.parts)):
            self._pallet.wait_for("unload", index, self.handover_timeout_s)
            unload = self.task.pallet_slot(float(self.conveyor.positions()[0]))
            delivered = [part_box(f"delivered_{j}", self.task.target(j)) for j in range(index)]
            what = f"part {index} (arm_out)"
            transfer = self._plan(
                f"part {index} to output slot {index}",
                "arm_out",
                (unload[0], unload[1], unload[2], 0.0),
                self.task.target(index),
                [pallet_box(unload[1], CONVEYOR_X), *delivered],
            )
            self._pick(self.arm_out, transfer, what)
            returning: threading.Thread | None = None
            if index + 1 < len(self.task.parts):  # the pallet goes back while arm_out places
                self._pallet.set("", None)
                returning = threading.Thread(target=self._guarded, args=(self._return,))
                returning.start()
            self._place(self.arm_out, transfer, what)
            self.last_delivery_at = self.sim_time()
            self.say(f"[line] part {index} set down at t = {self.last_delivery_at:.2f} s")
            if returning is not None:
                returning.join()

    def _return(self) -> None:
        self.conveyor.move_to(0.0, "pallet back to the load station")
        self._pallet.set("load", None)

    def _guarded(self, work: Callable[[], None]) -> None:
        """Run one cell's work on its thread; a failure is kept and stops the other cell."""
        try:
            work()
        except SimbridgeError as exc:
            self._errors.append(str(exc))
            self._pallet.fail()

    def run(self) -> None:
        """Move every part; AppError (naming the part and the step) when one step fails."""
        self.first_goal_at = self.sim_time()
        cells = [
            threading.Thread(target=self._guarded, args=(work,), name=f"line-{name}")
            for name, work in (("arm_in", self._loading), ("arm_out", self._unloading))
        ]
        for cell in cells:
            cell.start()
        for cell in cells:
            cell.join()
        if self._errors:  # the first failure, not the other cell's reaction to it
            raise AppError(self._errors[0])
