"""The line's supervisor: sequences the cells part by part. It plans while the simulation
is paused (std_srvs/SetBool on `<services_prefix>/pause`), so planning time never shows as
idle sim time, and moves robots only through their cells' action goals."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from simbridge.apps.line.cells import ArmCell, ConveyorCell
from simbridge.apps.line.planner import ArmPlanner, Transfer, pallet_box, part_box
from simbridge.apps.line.task import ARM_BASES, CONVEYOR_X, PART_SIZE, TRAVEL_M, LineTask
from simbridge.endpoint import Node
from simbridge.errors import AppError
from simbridge.planning import BoxObstacle

__all__ = ["LineSupervisor"]


class LineSupervisor:
    """Moves every part of ``task`` from the input area to its output slot:
    arm_in -> pallet -> conveyor -> arm_out -> output slot."""

    def __init__(
        self,
        task: LineTask,
        arm_in: ArmCell,
        arm_out: ArmCell,
        conveyor: ConveyorCell,
        node: Node,
        *,
        pause_service: str = "/simbridge/pause",
        sim_time: Callable[[], float] = lambda: 0.0,
        progress: Callable[[str], None] = lambda _text: None,
        seed: int = 0,
    ) -> None:
        self.task, self.node = task, node
        self.arm_in, self.arm_out, self.conveyor = arm_in, arm_out, conveyor
        self.pause_service = pause_service
        self.sim_time = sim_time
        self.say = progress
        self.planners = {
            "arm_in": ArmPlanner(ARM_BASES["arm_in"], seed),
            "arm_out": ArmPlanner(ARM_BASES["arm_out"], seed),
        }
        self.planning_wall_s = 0.0
        self.first_goal_at: float | None = None
        self.last_delivery_at: float | None = None

    def _pause(self, paused: bool) -> None:
        request = self.node.registry.new(
            self.node.registry.service("std_srvs/SetBool").request, data=paused
        )
        response: Any = self.node.call(self.pause_service, "std_srvs/SetBool", request, timeout=10)
        if not response.success:
            raise AppError(f"{self.pause_service} refused data={paused}: {response.message}")

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

    def _execute(self, cell: ArmCell, transfer: Transfer, what: str) -> None:
        cell.follow(transfer.pre_grasp, f"{what}: pre-grasp")
        cell.follow(transfer.grasp, f"{what}: grasp")
        cell.grip(True)
        cell.follow(transfer.pick_up, f"{what}: pick up")
        cell.follow(transfer.place, f"{what}: place")
        cell.grip(False)
        cell.follow(transfer.retreat, f"{what}: retreat")

    def run(self) -> None:
        """Move every part; AppError (naming the part and the step) when one step fails."""
        self.first_goal_at = self.sim_time()
        parts = self.task.parts
        for index, part in enumerate(parts):
            waiting = [
                part_box(f"part_{j}", (p.x, p.y, PART_SIZE / 2))
                for j, p in enumerate(parts)
                if j > index
            ]
            load = self.task.pallet_slot(float(self.conveyor.positions()[0]))
            transfer = self._plan(
                f"part {index} into the pallet",
                "arm_in",
                (part.x, part.y, PART_SIZE / 2, part.yaw),
                load,
                [pallet_box(load[1], CONVEYOR_X), *waiting],
            )
            self._execute(self.arm_in, transfer, f"part {index} (arm_in)")
            self.conveyor.move_to(-TRAVEL_M, f"part {index} to the unload station")
            unload = self.task.pallet_slot(float(self.conveyor.positions()[0]))
            delivered = [part_box(f"delivered_{j}", self.task.target(j)) for j in range(index)]
            transfer = self._plan(
                f"part {index} to output slot {index}",
                "arm_out",
                (unload[0], unload[1], unload[2], 0.0),
                self.task.target(index),
                [pallet_box(unload[1], CONVEYOR_X), *delivered],
            )
            self._execute(self.arm_out, transfer, f"part {index} (arm_out)")
            self.last_delivery_at = self.sim_time()
            self.say(f"[line] part {index} set down at t = {self.last_delivery_at:.2f} s")
            if index + 1 < len(parts):
                self.conveyor.move_to(0.0, "pallet back to the load station")
