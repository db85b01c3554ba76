"""Sensor costs: 2D/3D lidar per scan, 640x480 camera fps (raw, JPEG, with live labels:
instance and semantic images and 2D detections of the room's 24 labelled pieces), and the
real-time factor of a mobile robot in a furnished room with a 10 Hz lidar and a 10 Hz camera.

Run: `python benchmarks/bench_sensors.py` (prints a table); `run()` returns the rows.
Rendering uses the backend `configure_gl` picks (MUJOCO_GL, else EGL, else OSMesa).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from functools import partial
from typing import Any

import mujoco
import numpy as np

from simbridge.sim.labels import Instance, LabelTable
from simbridge.sim.sensors import (
    Camera,
    CameraConfig,
    Lidar2D,
    Lidar2DConfig,
    Lidar3D,
    Lidar3DConfig,
    SensorSuite,
    configure_gl,
)

__all__ = ["SCENE", "run"]


def _room() -> str:
    """A 10 m x 10 m walled room with 24 boxes and cylinders scattered in it."""
    rng = np.random.default_rng(0)
    clutter = []
    for i in range(24):
        x, y = rng.uniform(-4.5, 4.5, 2)
        if abs(x) < 1 and abs(y) < 1:
            x += 2
        kind = "box" if i % 2 else "cylinder"
        size = "0.3 0.3 0.5" if kind == "box" else "0.25 0.5"
        rgb = " ".join(f"{c:.2f}" for c in rng.uniform(0.2, 0.9, 3))
        clutter.append(
            f'<geom type="{kind}" pos="{x:.2f} {y:.2f} 0.5" size="{size}" rgba="{rgb} 1"/>'
        )
    walls = "".join(
        f'<geom type="box" pos="{x} {y} 1" size="{sx} {sy} 1" rgba=".8 .8 .7 1"/>'
        for x, y, sx, sy in [(5, 0, 0.1, 5), (-5, 0, 0.1, 5), (0, 5, 5, 0.1), (0, -5, 5, 0.1)]
    )
    return "\n".join(clutter) + walls


SCENE = f"""
<mujoco model="bench_room">
  <option timestep="0.002" integrator="implicitfast"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <asset>
    <texture name="grid" type="2d" builtin="checker" width="256" height="256"
             rgb1=".3 .3 .3" rgb2=".5 .5 .5"/>
    <material name="floor" texture="grid" texrepeat="10 10"/>
  </asset>
  <worldbody>
    <light pos="0 0 4" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="6 6 0.1" material="floor"/>
    {_room()}
    <body name="base_link" pos="0 0 0.12">
      <freejoint/>
      <geom type="box" size="0.25 0.18 0.06" mass="8" rgba=".2 .3 .8 1"/>
      <geom type="sphere" pos="-0.2 0 -0.07" size="0.05" mass="0.2" friction="0 0 0"/>
      <body name="left_wheel" pos="0.1 0.21 -0.04" quat="0.7071 -0.7071 0 0">
        <joint name="left" type="hinge" axis="0 0 1" damping="0.01"/>
        <geom type="cylinder" size="0.08 0.02" mass="0.5" rgba=".1 .1 .1 1"/>
      </body>
      <body name="right_wheel" pos="0.1 -0.21 -0.04" quat="0.7071 -0.7071 0 0">
        <joint name="right" type="hinge" axis="0 0 1" damping="0.01"/>
        <geom type="cylinder" size="0.08 0.02" mass="0.5" rgba=".1 .1 .1 1"/>
      </body>
      <body name="laser" pos="0.15 0 0.1"><geom type="cylinder" size="0.04 0.03"/></body>
      <body name="camera_link" pos="0.24 0 0.12"><geom type="box" size="0.02 0.04 0.02"/></body>
    </body>
  </worldbody>
  <actuator>
    <velocity name="left" joint="left" kv="5"/>
    <velocity name="right" joint="right" kv="5"/>
  </actuator>
</mujoco>
"""


def _world() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _per_call(fn: Callable[[], object], min_seconds: float = 1.0) -> tuple[float, float, int]:
    """Mean wall and CPU (all threads of this process) seconds per call of `fn`, repeating
    for at least `min_seconds`. CPU time is the figure to trust on a loaded machine."""
    fn()  # warm-up (allocations, GL context)
    count = 0
    start, cpu_start = time.perf_counter(), time.process_time()
    while (elapsed := time.perf_counter() - start) < min_seconds or count < 3:
        fn()
        count += 1
    return elapsed / count, (time.process_time() - cpu_start) / count, count


def _row(name: str, seconds: float, cpu_seconds: float, count: int) -> dict[str, Any]:
    return {
        "benchmark": name,
        "ms": seconds * 1e3,
        "cpu_ms": cpu_seconds * 1e3,
        "per_s": 1.0 / seconds,
        "n": count,
    }


def _lidar_rows(model: mujoco.MjModel, data: mujoco.MjData) -> list[dict[str, Any]]:
    lidar2d = Lidar2D(model, Lidar2DConfig(name="scan", body="laser", samples=360))
    lidar3d = Lidar3D(model, Lidar3DConfig(name="velo", body="laser", channels=16, samples=1800))
    rows = []
    for label, sensor in (("2D lidar 360 beams", lidar2d), ("3D lidar 16x1800", lidar3d)):
        rows.append(
            _row(f"{label}: scan + message", *_per_call(partial(sensor.measure, model, data)))
        )
    return rows


def _clutter_labels(model: mujoco.MjModel) -> LabelTable:
    """Each box and cylinder standing in the room one instance, of class box or cylinder."""
    classes = {
        int(mujoco.mjtGeom.mjGEOM_BOX): "box",
        int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder",
    }
    pieces = [
        g for g in range(model.ngeom) if model.geom_bodyid[g] == 0 and model.geom_type[g] in classes
    ]
    instances = []
    for i, geom in enumerate(pieces[:24], start=1):
        category = classes[int(model.geom_type[geom])]
        instances.append(
            Instance(
                i, f"piece{i}", category, 1 + (category == "cylinder"), "bodies", (0,), (geom,)
            )
        )
    return LabelTable(model, instances, ["box", "cylinder"])


def _camera_rows(model: mujoco.MjModel, data: mujoco.MjData) -> list[dict[str, Any]]:
    labelers = ("instance", "semantic", "boxes_2d")
    config = CameraConfig(name="cam", body="camera_link", width=640, height=480, labelers=labelers)
    camera = Camera(model, config)
    camera.bind_labels(_clutter_labels(model))
    measure = partial(camera.measure, model, data)
    labels = list(camera.labeller.outputs)
    rows = []
    try:
        camera.set_all_wanted(False)
        camera.set_wanted("camera/image_raw", True)
        rows.append(_row("camera 640x480 rgb8 Image", *_per_call(measure)))
        for topic in labels:
            camera.set_wanted(topic, True)
        rows.append(_row("camera 640x480 rgb8 + live labels", *_per_call(measure)))
        camera.set_wanted("camera/image_raw", False)
        rows.append(_row("camera 640x480 live labels alone", *_per_call(measure)))
        camera.set_all_wanted(False)
        camera.set_wanted("camera/image_raw/compressed", True)
        rows.append(_row("camera 640x480 JPEG q80", *_per_call(measure)))
    finally:
        camera.close()
    return rows


def _realtime_row(jpeg: bool, sim_seconds: float = 10.0) -> dict[str, Any]:
    """Real-time factor driving the robot with a 10 Hz lidar and a 10 Hz 640x480 camera
    publishing image_raw + camera_info (+ JPEG when `jpeg`)."""
    model, data = _world()
    suite = SensorSuite.from_config(
        model,
        [
            {"type": "lidar_2d", "name": "scan", "body": "laser", "rate": 10},
            {"type": "camera", "name": "cam", "body": "camera_link", "rate": 10},
        ],
    )
    suite.set_wanted("camera/image_raw/compressed", jpeg)
    data.ctrl[:] = [6.0, 4.0]  # drive along a curve
    steps = round(sim_seconds / model.opt.timestep)
    messages = 0
    try:
        start, cpu_start = time.perf_counter(), time.process_time()
        for _ in range(steps):
            mujoco.mj_step(model, data)
            messages += len(suite.poll(model, data))
        wall = time.perf_counter() - start
        cpu = time.process_time() - cpu_start
    finally:
        suite.close()
    outputs = "raw+jpeg+info" if jpeg else "raw+info"
    return {
        "benchmark": f"RTF: mobile robot, lidar 10 Hz + camera 10 Hz ({outputs})",
        "ms": wall / sim_seconds * 1e3,
        "cpu_ms": cpu / sim_seconds * 1e3,
        "per_s": sim_seconds / wall,
        "per_cpu_s": sim_seconds / cpu,
        "n": messages,
        "unit": "x real time",
    }


def run() -> list[dict[str, Any]]:
    """All sensor benchmarks: `ms`/`cpu_ms` wall/CPU per scan or frame (per simulated
    second for the RTF rows, whose `per_s`/`per_cpu_s` are the real-time factors)."""
    backend = configure_gl()
    model, data = _world()
    rows = _lidar_rows(model, data) + _camera_rows(model, data)
    rows += [_realtime_row(jpeg=False), _realtime_row(jpeg=True)]
    for row in rows:
        row.setdefault("unit", "per s")
        row["gl"] = backend
    return rows


def _table(rows: list[dict[str, Any]]) -> str:
    width = max(len(row["benchmark"]) for row in rows)
    head = f"{'benchmark':<{width}}  {'wall ms':>8}  {'cpu ms':>8}  {'rate':>7}  unit"
    lines = [head, "-" * len(head)]
    for row in rows:
        rate = row["per_s"]
        lines.append(
            f"{row['benchmark']:<{width}}  {row['ms']:8.2f}  {row['cpu_ms']:8.2f}  "
            f"{rate:7.1f}  {row['unit']}"
            + (f" (by CPU time {row['per_cpu_s']:.1f})" if "per_cpu_s" in row else "")
        )
    return "\n".join(lines)


if __name__ == "__main__":
    results = run()
    print(f"GL backend: {results[0]['gl']}, CPUs: {os.cpu_count()}")
    print(_table(results))
