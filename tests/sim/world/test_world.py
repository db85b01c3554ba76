"""Scene files and the World: objects, lights, physics settings, callbacks, pausing, pacing."""

from __future__ import annotations

import threading
import time
import warnings
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
import yaml

import simbridge.sim.world.pacer as pacer_module
import simbridge.sim.world.world as world_module
from simbridge.assets import robot_urdf
from simbridge.errors import SimError
from simbridge.sim.control import Trajectory, TrajectoryFollower
from simbridge.sim.scene import build_scene, load_scene, parse_scene
from simbridge.sim.sensors import RateSchedule
from simbridge.sim.urdf import MjcfDocument, forward_kinematics, parse_urdf
from simbridge.sim.world import World
from tests.sim.urdf_samples import GRAVITY_ARM
from tests.sim.worlds import arm_world


def test_objects_lights_and_physics_reach_the_model(tmp_path: Path) -> None:
    trimesh.creation.icosphere(radius=0.05).export(str(tmp_path / "ball.obj"))
    world = arm_world(
        tmp_path,
        physics={
            "timestep": 0.001,
            "gravity": [0, 0, -5],
            "solver_iterations": 30,
            "integrator": "implicit",
        },
        objects=[
            {"name": "floor", "type": "plane", "friction": 0.8},
            {
                "name": "crate",
                "type": "box",
                "size": [0.1, 0.2, 0.3],
                "dynamic": True,
                "mass": 2.0,
                "pose": {"xyz": [1.0, 0, 0.5]},
            },
            {
                "name": "post",
                "type": "cylinder",
                "size": [0.05, 0.4],
                "pose": {"xyz": [-1, 0, 0.2]},
            },
            {
                "name": "ball",
                "type": "mesh",
                "mesh": "ball.obj",
                "dynamic": True,
                "pose": {"xyz": [-1.0, 1.0, 0.3]},
            },
        ],
        lights=[{"name": "sun", "type": "directional", "dir": [0, 1, -1]}],
    )
    m = world.model
    assert m.opt.timestep == 0.001
    np.testing.assert_allclose(m.opt.gravity, [0, 0, -5])
    assert m.opt.iterations == 30
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICIT
    assert m.body("crate").mass[0] == pytest.approx(2.0)
    crate_i = 2.0 / 12 * np.array([0.04 + 0.09, 0.01 + 0.09, 0.01 + 0.04])
    np.testing.assert_allclose(sorted(m.body("crate").inertia), sorted(crate_i))
    assert m.geom("floor").friction[0] == pytest.approx(0.8)
    assert m.light("sun").type[0] == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    assert m.body("post").jntnum[0] == 0  # static
    world.step(2000)  # 2 s: the crate has fallen and rests on the floor
    assert world.link_pose("crate").xyz[2] == pytest.approx(0.15, abs=2e-3)
    assert world.link_pose("ball").xyz[2] == pytest.approx(0.05, abs=5e-3)  # icosphere: faceted
    assert world.link_pose("post").xyz == pytest.approx((-1, 0, 0.2))


def test_link_poses_match_urdf_fk_at_base_pose(tmp_path: Path) -> None:
    world = arm_world(
        tmp_path,
        physics={"gravity": [0, 0, 0]},
        robot={
            "base": {"xyz": [1, 2, 0.5], "rpy": [0, 0, 1.0]},
            "initial_positions": {"shoulder": 0.3, "elbow": -0.2, "wrist": 0.7},
        },
    )
    from simbridge.sim.urdf import Transform

    base = Transform.from_xyz_rpy((1, 2, 0.5), (0, 0, 1.0))
    expected = forward_kinematics(
        parse_urdf(GRAVITY_ARM), {"shoulder": 0.3, "elbow": -0.2, "wrist": 0.7}, base
    )
    for link, pose in world.link_poses().items():
        np.testing.assert_allclose(pose.translation, expected[link].translation, atol=1e-6)
        np.testing.assert_allclose(pose.rotation, expected[link].rotation, atol=1e-6)


def test_two_prefixed_robots(tmp_path: Path) -> None:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    scene = parse_scene(
        {
            "robots": [
                {"urdf": "arm.urdf", "name": "left", "prefix": "l_"},
                {"urdf": "arm.urdf", "name": "right", "prefix": "r_", "base": {"xyz": [1, 0, 0]}},
            ]
        },
        tmp_path,
    )
    world = World.from_scene(scene)
    assert world.joint_names()[:2] == ["l_shoulder", "l_elbow"]
    assert "r_grip_b" in world.joint_names()
    assert world.link_pose("r_base").xyz == pytest.approx((1, 0, 0))
    assert set(world.robots) == {"left", "right"}
    with pytest.raises(SimError, match="unknown robot"):
        world.robot("middle")


@pytest.mark.parametrize(
    ("scene", "message"),
    [
        ({"robot": []}, r"top level: unknown key 'robot'; did you mean 'robots'\?"),
        ({"physics": {"timestep": -1}}, r"physics.timestep: must be > 0"),
        ({"physics": {"integrator": "magic"}}, "unknown integrator 'magic'"),
        ({"objects": [{"name": "x", "type": "cone"}]}, r"objects\[0\].type: unknown shape 'cone'"),
        (
            {"objects": [{"name": "x", "type": "box", "size": [1, 2]}]},
            "expected a list of 3 numbers",
        ),
        (
            {"objects": [{"name": "x", "type": "plane", "dynamic": True}]},
            "a plane cannot be dynamic",
        ),
        (
            {
                "objects": [
                    {"name": "x", "type": "sphere", "size": 1},
                    {"name": "x", "type": "sphere", "size": 1},
                ]
            },
            r"objects\[1\].name: the name 'x' is already taken by objects\[0\]",
        ),
        ({"robots": [{"name": "a"}]}, "missing key 'urdf'"),
        (
            {"robots": [{"urdf": "arm.urdf", "drives": {"default": {"mode": "torque"}}}]},
            "unknown drive mode 'torque'",
        ),
        ({"lights": [{"type": "laser"}]}, "unknown light 'laser'"),
        ({"ros": {"joint_states_rate": 0}}, "joint_states_rate: must be > 0"),
    ],
)
def test_scene_errors_name_the_key(tmp_path: Path, scene: dict[str, object], message: str) -> None:
    with pytest.raises(SimError, match=message):
        parse_scene(scene, tmp_path)


def test_scene_errors_found_when_building(tmp_path: Path) -> None:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    bad_drive = parse_scene(
        {"robots": [{"urdf": "arm.urdf", "drives": {"joints": {"grip_b": {}}}}]}, tmp_path
    )
    with pytest.raises(SimError, match="'grip_b' is not a drivable joint"):
        build_scene(bad_drive)
    bad_initial = parse_scene(
        {"robots": [{"urdf": "arm.urdf", "initial_positions": {"knee": 1}}]}, tmp_path
    )
    with pytest.raises(SimError, match="'knee' is not a drivable joint"):
        build_scene(bad_initial)
    (tmp_path / "s.yaml").write_text("robots: [")
    with pytest.raises(SimError, match="not valid YAML"):
        load_scene(tmp_path / "s.yaml")


def _trace(tmp_path: Path) -> np.ndarray:
    world = arm_world(
        tmp_path,
        objects=[
            {"name": "floor", "type": "plane"},
            {
                "name": "crate",
                "type": "box",
                "size": [0.1, 0.1, 0.1],
                "dynamic": True,
                "pose": {"xyz": [0.75, 0, 0.2], "rpy": [0.3, 0.2, 0.1]},
            },
        ],
    )
    world.drives.set_position("shoulder", 0.8)  # swing down into the crate
    world.drives.set_position("elbow", 0.6)
    world.step(1000)
    return np.concatenate([world.data.qpos, world.data.qvel])


def test_runs_are_deterministic(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first, second = _trace(tmp_path / "a"), _trace(tmp_path / "b")
    assert np.array_equal(first, second)
    assert first[:2].tolist() != [0.0, 0.0]  # the arm did move


def test_reset_restores_initial_state_and_rng(tmp_path: Path) -> None:
    world = arm_world(tmp_path, robot={"initial_positions": {"elbow": 0.5}}, physics={"seed": 7})
    first = world.rng.random()
    world.drives.set_position("elbow", -1.0)
    world.step(200)
    world.reset()
    assert world.time == 0.0
    assert world.joint_positions()["elbow"] == 0.5
    assert world.drives.target("elbow").position == 0.5
    assert world.rng.random() == first


def test_step_callbacks_run_at_their_period(tmp_path: Path) -> None:
    world = arm_world(tmp_path)
    times: list[float] = []
    every: list[float] = []
    cb = world.add_step_callback(lambda w: times.append(w.time), period=0.01)
    world.add_step_callback(lambda w: every.append(w.time))
    world.step(50)  # 0.1 s
    assert times == pytest.approx([0.01 * k for k in range(1, 11)])
    assert len(every) == 50
    cb.remove()
    world.step(10)
    assert len(times) == 10
    with pytest.raises(SimError, match="period must be > 0"):
        world.add_step_callback(lambda w: None, period=0)


def test_handles_take_callbacks_scopes_and_followers_out(tmp_path: Path) -> None:
    """Whatever `add_*` registers, its handle's `remove()` takes out: no more calls after
    steps or resets, no scope entered, no follower driven (a second remove is harmless)."""
    world = arm_world(tmp_path)  # 2 ms steps
    world.batch_window = 0  # scopes left after each step's callbacks
    log: list[str] = []
    follower = TrajectoryFollower(world.drives)
    handles = [
        world.add_step_callback(lambda w: log.append("step")),
        world.add_step_callback(lambda w: log.append("tick"), period=0.004),
        world.add_reset_callback(lambda w: log.append("reset")),
        world.add_callback_scope(_Scope(world, log)),
        world.add_follower(follower),
    ]
    trajectory = Trajectory.from_lists(["elbow"], [1.0], [[0.8]])
    follower.start(trajectory, world.time)
    world.step(2)
    world.reset()
    assert log == ["enter 1", "step", "exit 1", "enter 2", "step", "tick", "exit 2", "reset"]
    assert follower.active is None  # the reset cancelled it
    follower.start(trajectory, world.time)
    world.step(1)
    assert world.drives.target("elbow").velocity > 0  # driven before the step
    for handle in handles:
        handle.remove()
        handle.remove()
        assert not handle.registered
    log.clear()
    world.step(4)
    world.reset()
    follower.start(trajectory, world.time)
    world.step(1)
    assert log == []
    assert follower.active is not None  # not cancelled by the reset
    assert world.drives.target("elbow").velocity == 0.0  # nor driven


class _Clock:
    """A wall clock that only a sleep moves (steps take no time on it): pacing measured
    as sim time against wall time without the machine's speed in it."""

    def __init__(self) -> None:
        self.now = 0.0
        self.sleeps = 0

    def perf_counter(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.sleeps += 1
        self.now += seconds


def test_run_paces_to_real_time_and_runs_fast_unpaced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    world = arm_world(tmp_path)
    paced = world.run(duration=0.3, realtime_factor=1.0)  # the real clock: never ahead of it
    assert paced.steps == 150
    assert paced.wall_time >= 0.28
    double = world.run(duration=0.3, realtime_factor=2.0)
    assert double.wall_time >= 0.14

    for factor, wall in ((1.0, 0.3), (2.0, 0.15), (0.5, 0.6)):
        clock = _Clock()
        monkeypatch.setattr(pacer_module, "time", clock)
        monkeypatch.setattr(world_module, "time", clock)
        stats = world.run(duration=0.3, realtime_factor=factor)
        assert stats.steps == 150
        assert wall - 0.002 <= stats.wall_time <= wall + 1e-9, factor  # no oversleeping
    clock = _Clock()
    monkeypatch.setattr(pacer_module, "time", clock)
    monkeypatch.setattr(world_module, "time", clock)
    fast = world.run(duration=1.0, realtime_factor=0)
    assert fast.steps == 500
    assert clock.sleeps == 0  # unpaced: it never waits


def test_pause_step_and_reset_from_another_thread(tmp_path: Path) -> None:
    world = arm_world(tmp_path)
    world.pause()
    runner = threading.Thread(target=world.run, kwargs={"realtime_factor": 0})
    runner.start()
    try:
        time.sleep(0.05)
        assert world.time == 0.0
        world.request_steps(7)
        deadline = time.monotonic() + 5
        while world.time < 7 * 0.002 - 1e-9 and time.monotonic() < deadline:
            time.sleep(0.005)
        time.sleep(0.05)
        assert world.time == pytest.approx(7 * 0.002)
        seen: list[float] = []
        world.post(lambda: seen.append(world.time))
        world.resume()
        while world.time < 0.1 and time.monotonic() < deadline:
            time.sleep(0.005)
        assert seen
        assert seen[0] >= 7 * 0.002 - 1e-12
        world.pause()
        world.request_reset()
        while world.time != 0.0 and time.monotonic() < deadline:
            time.sleep(0.005)
        assert world.time == 0.0
    finally:
        world.stop()
        runner.join(5)
    assert not runner.is_alive()


def test_pause_with_wait_returns_after_the_step_in_progress(tmp_path: Path) -> None:
    world = arm_world(tmp_path)
    in_step, release = threading.Event(), threading.Event()

    def slow(w: World) -> None:
        if w.time > 0.02 and not release.is_set():
            in_step.set()
            release.wait(5)

    world.add_step_callback(slow)
    runner = threading.Thread(target=world.run, kwargs={"realtime_factor": 0})
    runner.start()
    try:
        assert in_step.wait(5)
        done: list[bool] = []
        pauser = threading.Thread(target=lambda: done.append(world.pause(wait=5)))
        pauser.start()
        time.sleep(0.05)
        assert not done  # the step is still running: pause must not claim time is held
        release.set()
        pauser.join(5)
        assert done == [True]
        held = world.time
        time.sleep(0.05)
        assert world.time == held
        world.resume()
        assert world.pause(wait=0) is True  # no wait asked: returns at once
    finally:
        world.stop()
        runner.join(5)
    assert not runner.is_alive()
    assert world.pause(wait=5) is True  # not running: nothing to wait for


def test_viewer_without_display_is_a_clear_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    world = arm_world(tmp_path)
    with pytest.raises(SimError, match="DISPLAY is not set"):
        world.run(duration=0.01, viewer=True)


def test_extensions_edit_the_model_before_compiling(tmp_path: Path) -> None:
    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "scene.yaml").write_text(yaml.safe_dump({"robots": [{"urdf": "arm.urdf"}]}))

    def add_site(doc: MjcfDocument) -> None:
        doc.add_site("fore", "probe", pos=(0.3, 0, 0))

    world = World.from_scene(tmp_path / "scene.yaml", extensions=[add_site])
    site = world.model.site("probe")
    np.testing.assert_allclose(world.data.site_xpos[site.id], [0.8, 0, 0.5], atol=1e-9)

    def misplaced(doc: MjcfDocument) -> None:
        doc.add_site("nope", "x")

    with pytest.raises(SimError, match="no body named 'nope'"):
        World.from_scene(tmp_path / "scene.yaml", extensions=[misplaced])


def test_root_link_named_world_is_the_world_body(tmp_path: Path) -> None:
    from simbridge.sim.urdf import MjcfOptions, Transform, robot_to_mjcf
    from tests.sim.urdf_samples import joint, link, robot

    urdf = robot(
        link("world", ""),
        link("base"),
        joint("anchor", "fixed", "world", "base", '<origin xyz="0 0 0.3" rpy="0 0 0.5"/>'),
    )
    base = Transform.from_xyz_rpy((1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    doc, _ = robot_to_mjcf(parse_urdf(urdf), MjcfOptions(base=base))
    model = doc.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert model.body("world").id == 0
    np.testing.assert_allclose(data.xpos[model.body("base").id], [1.0, 0.0, 0.3])
    expected = forward_kinematics(parse_urdf(urdf), base=base)["base"]
    np.testing.assert_allclose(data.xmat[model.body("base").id].reshape(3, 3), expected.rotation)


def test_request_steps_needs_a_paused_world(tmp_path: Path) -> None:
    world = arm_world(tmp_path)
    with pytest.raises(SimError, match="paused world"):
        world.request_steps(3)


def test_scheduled_callbacks_fire_on_their_steps_when_the_loop_skips_idle_steps(
    tmp_path: Path,
) -> None:
    """Only scheduled callbacks: `step` skips the callback loop between due steps, yet each
    fires on exactly the steps a RateSchedule polled every step gives, also for one added
    by another callback, after a timestep change and after a reset."""
    world = arm_world(tmp_path)  # 2 ms steps
    fast: list[int] = []
    slow: list[int] = []
    late: list[int] = []
    world.add_step_callback(lambda w: fast.append(w.step_count), period=0.01)
    world.add_step_callback(lambda w: slow.append(w.step_count), period=0.03)

    def add_late(w: World) -> None:
        if w.step_count == 7:
            w.add_step_callback(lambda w2: late.append(w2.step_count), period=0.004)

    world.add_step_callback(add_late, period=0.002)
    world.step(30)
    assert fast == [5, 10, 15, 20, 25, 30]
    assert slow == [15, 30]
    assert late == [8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30]
    reference = RateSchedule(100.0)  # polled every step, as the loop did before skipping
    for step in range(1, 31):
        reference.due(step, 0.002)
    world.model.opt.timestep = 0.005
    fast.clear()
    world.step(6)
    assert fast == [n for n in range(31, 37) if reference.due(n, 0.005)]
    assert fast[-2:] == [34, 36]  # 10 ms is now every 2 steps
    world.model.opt.timestep = 0.002
    world.reset()
    fast.clear()
    world.step(10)
    assert fast == [5, 10]


class _Scope:
    """Logs when it is entered and left, with the world's step count."""

    def __init__(self, world: World, log: list[str]) -> None:
        self.world, self.log = world, log

    def __enter__(self) -> None:
        self.log.append(f"enter {self.world.step_count}")

    def __exit__(self, *exc: object) -> None:
        self.log.append(f"exit {self.world.step_count}")


def test_callback_scopes_wrap_the_callbacks_of_each_step_call(tmp_path: Path) -> None:
    """A scope (e.g. `Connector.batch()`) is entered before the first due callback and
    left at the end of `step`, also when a callback raises; idle steps enter nothing."""
    world = arm_world(tmp_path)  # 2 ms steps
    log: list[str] = []

    def fail(w: World) -> None:
        if w.step_count == 10:
            raise RuntimeError("callback failed")

    scope = world.add_callback_scope(_Scope(world, log))
    world.add_step_callback(lambda w: log.append(f"cb {w.step_count}"), period=0.01)
    world.add_step_callback(fail, period=0.02)
    world.step(5)
    assert log == ["enter 5", "cb 5", "exit 5"]
    log.clear()
    with pytest.raises(RuntimeError, match="callback failed"):
        world.step(5)
    assert log == ["enter 10", "cb 10", "exit 10"]
    log.clear()
    world.batch_window = 10.0  # within one step call they stay entered across steps
    world.step(10)
    assert log == ["enter 15", "cb 15", "cb 20", "exit 20"]
    scope.remove()
    log.clear()
    world.step(5)
    assert log == ["cb 25"]
    with pytest.raises(SimError, match="batch_window"):
        world.batch_window = -1


def test_run_keeps_scopes_entered_until_the_window_ends_or_it_sleeps(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Flat out, `run` leaves the scopes once per `batch_window` (so what several steps
    publish leaves in one write) and at its end; paced, before every sleep; with a
    window of 0, after each step's callbacks."""
    world = arm_world(tmp_path)  # 2 ms steps
    log: list[str] = []
    world.add_callback_scope(_Scope(world, log))
    world.add_step_callback(lambda w: log.append("cb"), period=0.01)
    world.batch_window = 3600.0
    world.run(duration=0.2, realtime_factor=0)  # 100 steps, 20 callbacks
    assert log == ["enter 5", *["cb"] * 20, "exit 100"]
    log.clear()
    world.batch_window = 0.0
    world.run(duration=0.1, realtime_factor=0)
    assert log == [x for n in range(105, 151, 5) for x in (f"enter {n}", "cb", f"exit {n}")]
    log.clear()
    world.batch_window = 3600.0
    sleep = time.sleep

    def logged_sleep(seconds: float) -> None:
        log.append("sleep")
        sleep(seconds)

    monkeypatch.setattr(time, "sleep", logged_sleep)
    world.run(duration=0.1, realtime_factor=1.0)  # sleeps between the 10 ms callbacks
    assert log.count("cb") == 10
    assert "sleep" in log
    entered = False
    for entry in log:  # never asleep with the scope entered
        entered = entry.startswith("enter") or (entered and not entry.startswith("exit"))
        assert not (entered and entry == "sleep"), log
    assert [x for x in log if x.startswith("exit")][-1] == "exit 200"


@pytest.mark.parametrize("boxes", [False, True])
def test_refresh_state_gives_what_mj_forward_gives(tmp_path: Path, boxes: bool) -> None:
    """The cheaper refresh for joint states and TF: poses, velocity terms and actuator
    forces equal `mj_forward`'s after every step of a moving arm (with contacts too)."""
    world = arm_world(tmp_path)
    if boxes:
        scene = {
            "physics": {"timestep": 0.002},
            "robots": [{"urdf": str(robot_urdf("niryo_one"))}],
            "objects": [{"name": "floor", "type": "plane"}]
            + [
                {
                    "name": f"box{i}",
                    "type": "box",
                    "size": [0.03, 0.03, 0.03],
                    "dynamic": True,
                    "mass": 0.05,
                    "pose": {"xyz": [0.25 + 0.04 * i, 0.0, 0.015]},
                }
                for i in range(4)
            ],
        }
        with warnings.catch_warnings():  # the gripper's zero pose is outside its limits
            warnings.simplefilter("ignore")
            world = World.from_scene(parse_scene(scene, robot_urdf("niryo_one").parent))
    for joint in [j for j in world.joint_names() if j in world.drives.joints][:3]:
        world.drives.set_position(joint, 0.6)
    reference = mujoco.MjData(world.model)
    fields = ("xpos", "xquat", "xmat", "qfrc_actuator", "actuator_force", "cvel")
    for _ in range(60):
        world.step(1)
        mujoco.mj_copyData(reference, world.model, world.data)
        mujoco.mj_forward(world.model, reference)
        world.refresh_state()
        for name in fields:
            np.testing.assert_allclose(
                getattr(world.data, name), getattr(reference, name), rtol=0, atol=1e-12
            )
    assert not boxes or world.data.ncon > 0 or reference.ncon > 0
