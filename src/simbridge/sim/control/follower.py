"""Drive joints along a trajectory in simulation time."""

from __future__ import annotations

from simbridge.sim.control.drive_bank import Actuators, DriveBank
from simbridge.sim.control.trajectory import Trajectory

__all__ = ["TrajectoryFollower"]


class TrajectoryFollower:
    """Feeds a `Trajectory` into a `DriveBank` as position + velocity targets each step."""

    def __init__(self, drives: DriveBank) -> None:
        self.drives = drives
        self._active: Trajectory | None = None
        self._start = 0.0
        self._actuators: Actuators = slice(0, 0)

    @property
    def active(self) -> Trajectory | None:
        """The trajectory being followed (None when idle)."""
        return self._active

    def start(self, trajectory: Trajectory, now: float) -> None:
        """Follow `trajectory` from sim time `now`, replacing any current one; the current
        drive targets become the t=0 point when the trajectory starts later."""
        for joint in trajectory.joints:
            self.drives.target(joint)  # raises SimError for undriven joints
        current = {j: self.drives.target(j).position for j in trajectory.joints}
        self._active = trajectory.starting_from(current)
        self._actuators = self.drives.actuators(trajectory.joints)
        self._start = now

    def cancel(self) -> None:
        """Stop following; drives keep their last targets."""
        self._active = None

    def update(self, now: float) -> bool:
        """Set drive targets for sim time `now`; returns True while the trajectory runs."""
        traj = self._active
        if traj is None:
            return False
        t = now - self._start
        done = t >= traj.duration
        positions, velocities = traj.aim(t)
        self.drives.set_targets(self._actuators, positions, velocities)
        if done:
            self._active = None
            return False
        return True
