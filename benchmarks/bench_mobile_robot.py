"""Mobile robot (lidar 10 Hz + 320x240 JPEG camera 10 Hz + IMU + odometry): real-time factor
with and without subscribers on the lidar, camera and IMU topics.

Lazy sensors compute nothing while no one subscribes, so the difference between the two
rows is what ray casting, rendering and encoding cost. Run:
`python -m benchmarks.bench_mobile_robot [--markdown]`; `run()` returns the rows.
"""

from __future__ import annotations

from typing import Any

from simbridge.apps.mobile_robot import run_mobile_robot

__all__ = ["run"]


def run(side_m: float = 1.0) -> list[dict[str, Any]]:
    """One unpaced square drive with the sensors subscribed and one without."""
    rows = []
    for subscribed in (True, False):
        result = run_mobile_robot(side_m, 0.0, subscribe_sensors=subscribed, progress=None)
        rows.append(
            {
                "sensor_subscribers": "lidar+camera+imu" if subscribed else "none (odom only)",
                "completed": "yes" if result.success else "no",
                "sim_s": round(result.sim_time, 2),
                "wall_s": round(result.wall_time, 2),
                "realtime_factor": round(result.realtime_factor, 2),
                "scans_per_sim_s": round(result.scans_per_s, 2),
                "images_per_sim_s": round(result.images_per_s, 2),
                "imu_per_sim_s": round(result.imu_per_s, 1),
                "wheel_odom_error_cm": round(result.wheel_odom_error_m * 100, 2),
            }
        )
    return rows


if __name__ == "__main__":
    import sys

    from benchmarks.table import format_table

    print(format_table(run(), markdown="--markdown" in sys.argv))
