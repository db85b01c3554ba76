"""What a mobile-robot run measured: odometry errors, lidar, sensor rates, real-time factor."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from simbridge.apps.mobile_robot.driver import ScanSample

__all__ = ["MobileRobotResult"]


@dataclass(frozen=True)
class MobileRobotResult:
    """Outcome of one run; every figure is measured from what arrived over the bus.

    Poses are (x m, y m, yaw rad) in the odom frame (the start pose, levelled). Errors
    compare with the ground truth (the simulated base) once the robot stands still.
    ``*_per_s`` are messages received per simulated second.
    """

    success: bool
    """The square was driven and the last readings arrived."""
    sim_time: float
    wall_time: float
    final_pose: tuple[float, float, float]
    odom_error_m: float
    odom_yaw_error_deg: float
    wheel_odom_error_m: float
    wheel_odom_yaw_error_deg: float
    min_range_m: float
    scans_per_s: float
    images_per_s: float
    imu_per_s: float
    odom_per_s: float
    image_kib: float
    """Mean JPEG size."""
    sensors_subscribed: bool = True
    backend: str = "local"
    error: str | None = None
    first_scan: ScanSample | None = field(default=None, repr=False)

    @property
    def realtime_factor(self) -> float:
        """Simulated seconds per wall-clock second."""
        return self.sim_time / self.wall_time if self.wall_time > 0 else float("inf")

    def to_dict(self) -> dict[str, Any]:
        """The JSON summary: the keys every demo has (success, seed, backend, sim_s, wall_s,
        realtime_factor, error), then odometry errors, rates and details."""
        return {
            "success": self.success,
            "seed": None,  # nothing in the run is drawn at random
            "backend": self.backend,
            "sim_s": round(self.sim_time, 4),
            "wall_s": round(self.wall_time, 4),
            "realtime_factor": round(self.realtime_factor, 3),
            "error": self.error,
            "odom_error_m": round(self.odom_error_m, 5),
            "wheel_odom_error_m": round(self.wheel_odom_error_m, 5),
            "min_range_m": round(self.min_range_m, 4),
            "scans_per_s": round(self.scans_per_s, 3),
            "images_per_s": round(self.images_per_s, 3),
            "imu_per_s": round(self.imu_per_s, 3),
            "odom_per_s": round(self.odom_per_s, 3),
            "odom_yaw_error_deg": round(self.odom_yaw_error_deg, 4),
            "wheel_odom_yaw_error_deg": round(self.wheel_odom_yaw_error_deg, 4),
            "final_pose": [round(v, 4) for v in self.final_pose],
            "image_kib": round(self.image_kib, 2),
            "sensors_subscribed": self.sensors_subscribed,
        }
