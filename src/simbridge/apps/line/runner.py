"""Run the line headless: endpoint (local bus or ROS 1), the scene with every robot on its own
connection, one in-process node per robot and the supervisor; and its command line.

`main(argv)` is `simbridge demo line [--backend local|ros1] [--seed N] [--parts N] [--json]
[--video PATH] [--realtime F] [--record FILE] [--view [--view-port P]]`.
"""

from __future__ import annotations

import argparse
import json as json_text
import math
import sys
import threading
import time
from collections.abc import Callable, Sequence
from contextlib import ExitStack
from pathlib import Path

from simbridge.apps.line.drive import drive_in_process, drive_ros2
from simbridge.apps.line.result import DELIVERY_TOLERANCE_M, LineResult
from simbridge.apps.line.scene import (
    ARMS,
    CONVEYOR,
    SCENE_PATH,
    grasp_contacts,
    line_scene,
    part_name,
)
from simbridge.apps.line.task import LineTask
from simbridge.apps.line.view import LineView
from simbridge.apps.options import LINE, LINE_BACKENDS, add_line_arguments
from simbridge.apps.pick_and_place.video import VideoRecorder, check_video_path
from simbridge.apps.ros_master import DemoMaster
from simbridge.connector import ConnectorOptions
from simbridge.endpoint import (
    Backend,
    EndpointOptions,
    EndpointThread,
    LocalBus,
    make_backend,
)
from simbridge.endpoint.backends.ros1 import unique_node_name
from simbridge.errors import AppError, SimbridgeError
from simbridge.sim.record import RecordOptions
from simbridge.sim.runner import SimulationSession
from simbridge.sim.view import LiveView, ViewOptions
from simbridge.sim.world import World

__all__ = ["BACKENDS", "main", "run_line"]

BACKENDS = LINE_BACKENDS

SETTLE_S = 0.5
"""Simulated seconds the parts rest after the last one is set down, before measuring."""
_CAMERA_EYE = (1.25, 0.0, 0.75)
_CAMERA_TARGET = (0.12, 0.0, 0.0)


class _SimThread:
    """Runs the world (flat out, or paced at ``realtime_factor``) on a thread of its own
    until stopped or ``max_sim_s``;
    video frames are rendered and written there, on the thread that owns the GL context."""

    def __init__(
        self, world: World, max_sim_s: float, video: Path | None, realtime_factor: float = 0.0
    ) -> None:
        self.world, self.max_sim_s, self.video = world, max_sim_s, video
        self.realtime_factor = realtime_factor
        self.frames = 0
        self.error: BaseException | None = None
        self.started = time.perf_counter()
        self.wall_s = 0.0
        self.cpu_s = 0.0
        """CPU seconds of the whole process (every thread) while the world ran."""
        self._thread = threading.Thread(target=self._run, name="line-sim", daemon=True)

    def _run(self) -> None:
        recorder: VideoRecorder | None = None
        try:
            if self.video is not None:
                recorder = VideoRecorder(
                    self.world, self.video, eye=_CAMERA_EYE, target=_CAMERA_TARGET
                )
                capture = recorder.maybe_capture
                self.world.add_step_callback(lambda _w: capture())
            self.started, cpu = time.perf_counter(), time.process_time()
            self.world.run(self.max_sim_s, self.realtime_factor)
            self.wall_s = time.perf_counter() - self.started
            self.cpu_s = time.process_time() - cpu
            if recorder is not None:
                self.frames = recorder.frame_count
                recorder.save()
        except Exception as exc:  # reported by run_line
            self.error = exc

    def start(self) -> _SimThread:
        self._thread.start()
        return self

    @property
    def alive(self) -> bool:
        """Whether the world is still running."""
        return self._thread.is_alive()

    def wait_sim(self, seconds: float, timeout: float = 30.0) -> None:
        """Block until ``seconds`` more of sim time have passed (or the run ended)."""
        end = self.world.time + seconds
        deadline = time.monotonic() + timeout
        while self.world.time < end and self.alive and time.monotonic() < deadline:
            time.sleep(0.002)

    def stop(self) -> None:
        """Stop the world and wait for the thread (and the video) to finish."""
        self.world.stop()
        self._thread.join(120)


def _measure(world: World, task: LineTask) -> tuple[list[float], list[tuple[float, float, float]]]:
    errors, finals = [], []
    for index in range(len(task.parts)):
        x, y, z = (float(v) for v in world.data.xpos[world.model.body(part_name(index)).id])
        finals.append((x, y, z))
        errors.append(math.dist((x, y, z), task.target(index)))
    return errors, finals


def run_line(
    seed: int | None = None,
    parts: int = 3,
    video: str | Path | None = None,
    json: bool = False,
    *,
    scene: Path = SCENE_PATH,
    record: RecordOptions | None = None,
    view: ViewOptions | LineView | None = None,
    max_sim_s: float = 600.0,
    realtime_factor: float = 0.0,
    backend: str = "local",
    progress: Callable[[str], None] | None = print,
) -> LineResult:
    """Move ``parts`` parts (poses drawn from ``seed``, else seed 0) from the input area to
    the output slots with two arms and the conveyor, and measure where they ended up.

    The endpoint runs on the local bus (``backend`` "local"), or is a rospy node ("ros1",
    on the master at ROS_MASTER_URI, else a private roscore) whose topics, and so every
    robot's joint states, TF and action traffic, are real ROS 1 topics; every robot is
    served on its own connection; one node per robot (on the endpoint's graph) drives it
    through its controllers' actions. ``video`` writes
    a .gif (or .mp4), ``record`` a bag of every sim topic, ``view`` a live browser view
    (a `LineView` shows the run in a page kept across runs);
    ``json`` prints the summary as the last line; ``realtime_factor`` paces the run (0: as
    fast as possible). A failed step ends the run with ``error``
    set; setup problems (bad options, video path) raise AppError.
    """
    task = LineTask.random(seed if seed is not None else 0, parts)
    video_path = check_video_path(video) if video is not None else None
    say = progress or (lambda _text: None)
    began = time.perf_counter()
    error: str | None = None
    if backend not in BACKENDS:
        raise AppError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    with ExitStack() as stack:
        bus: Backend
        if backend == "local":
            bus, where = LocalBus(), "local bus"
        elif backend == "ros2":
            bus = make_backend("ros2", node_name="/simbridge_line")
            where = "ros2 backend"
        else:
            master = stack.enter_context(DemoMaster())
            bus = make_backend("ros1", node_name=unique_node_name("simbridge_line"))
            where = f"ros1 backend, ROS master {master.describe()}"
        endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), bus))
        session = SimulationSession(
            line_scene(task, scene),
            f"127.0.0.1:{endpoint.port}",
            ConnectorOptions(reconnect_initial=0.2),
            connect_timeout=5.0,
            record=record,
            extensions=grasp_contacts(task),
        )
        stack.enter_context(session)
        world = session.world
        if isinstance(view, LineView):
            view.show(world, seed or 0, realtime_factor)
        elif view is not None:
            say(f"[line] live view at {stack.enter_context(LiveView(world, view)).url}")
        sim = _SimThread(world, max_sim_s, video_path, realtime_factor)
        alive = lambda: sim.alive  # noqa: E731
        stack.callback(sim.stop)
        pause_service = f"{session.scene.ros.services_prefix.rstrip('/')}/pause"
        if backend == "ros2":
            world.pause()  # until the ROS 2 cells found every action server (they resume it)
        sim.start()
        say(
            f"[line] endpoint on port {endpoint.port} ({where}); {len(task.parts)} parts; "
            f"robots {', '.join((*ARMS, CONVEYOR))}, each on its own connection"
        )
        if backend == "ros2":
            say("[line] the robots are driven from a ROS 2 process of their own")
            # Time stands still from the summary until the cells' process is gone.
            drive = drive_ros2(
                task, seed or 0, pause_service=pause_service, alive=alive, say=say,
                on_summary=world.pause,
            )  # fmt: skip
            world.resume()
        else:
            drive = drive_in_process(
                stack, bus, endpoint.loop, task, pause_service=pause_service,
                sim_time=lambda: world.time, alive=alive, say=say, seed=seed or 0,
            )  # fmt: skip
        error = drive.error
        if error is not None:
            say(f"[line] failed: {error}")
        sim.wait_sim(SETTLE_S)
        sim.stop()
        if sim.error is not None:
            raise AppError(f"the simulation failed: {sim.error}") from sim.error
        errors, finals = _measure(world, task)
        sim_s = world.time
        wall_s = sim.wall_s or time.perf_counter() - began
        robots = drive.robots
    delivered = sum(e <= DELIVERY_TOLERANCE_M for e in errors)
    first = drive.first_goal_at or 0.0
    last = drive.last_delivery_at
    result = LineResult(
        parts=len(task.parts),
        delivered=delivered,
        placement_error_m=tuple(errors),
        cycle_s=(last - first) / len(task.parts) if last is not None else 0.0,
        sim_s=sim_s,
        wall_s=wall_s,
        cpu_s=sim.cpu_s,
        robots=robots,
        seed=seed if seed is not None else 0,
        backend=backend,
        error=error,
        planning_wall_s=drive.planning_wall_s,
        final_positions=tuple(finals),
        video=str(video_path) if video_path is not None and sim.frames else None,
    )
    if result.video is not None:
        say(f"[line] wrote {result.video} ({sim.frames} frames)")
    say(
        f"[line] {'success' if result.success else 'FAILED'}: {delivered}/{result.parts} parts "
        f"delivered, errors {', '.join(f'{e * 100:.2f}' for e in errors)} cm; "
        f"{result.cycle_s:.2f} s per part; {sim_s:.1f} s simulated in {wall_s:.1f} s "
        f"(x{result.realtime_factor:.1f})"
    )
    if json:
        print(json_text.dumps(result.to_dict()), flush=True)
    return result


def main(argv: Sequence[str] | None = None) -> int:
    """`simbridge demo line`: 0 when every part was delivered, 1 if not, 2 on errors."""
    parser = argparse.ArgumentParser(prog="simbridge demo line", description=LINE)
    add_line_arguments(parser)
    return run_from_args(parser.parse_args(argv))


def run_from_args(args: argparse.Namespace) -> int:
    """Run the demo with parsed options: 0 when every part was delivered, 1 if not, 2 on
    errors."""
    realtime = args.realtime if args.realtime is not None else (1.0 if args.view else 0.0)
    if not realtime >= 0:
        print(f"simbridge demo line: --realtime must be >= 0, got {realtime}", file=sys.stderr)
        return 2
    with ExitStack() as stack:
        view = (
            stack.enter_context(LineView(ViewOptions(port=args.view_port))) if args.view else None
        )
        try:
            result = run_line(
                args.seed,
                args.parts,
                args.video,
                args.json,
                record=RecordOptions(Path(args.record)) if args.record else None,
                view=view,
                realtime_factor=realtime,
                backend=args.backend,
            )
        except SimbridgeError as exc:
            print(f"simbridge demo line: {exc}", file=sys.stderr)
            return 2
        if view is not None:
            view.serve(lambda seed: _again(seed, args.parts, view, realtime, args.backend))
    return 0 if result.success else 1


def _again(seed: int, parts: int, view: LineView, realtime: float, backend: str) -> None:
    """A run the view's button asked for (no video or recording: those are the first run's)."""
    try:
        run_line(seed, parts, view=view, realtime_factor=realtime, backend=backend)
    except SimbridgeError as exc:
        print(f"simbridge demo line: {exc}", file=sys.stderr)
