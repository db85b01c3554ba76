"""The pick-and-place graph kept up across runs: endpoint, planner node, optional
recording and live view, and a run per task (each in a world of its own).

With a live view the page gets a "Pick and place again" button: each press queues a
run with the next seed, which `serve` performs on the caller's thread. Between runs the
shown world keeps stepping (at the run's real-time factor, else real time), so the page
stays live and its controls (pause, joints, moving the cube) act.
"""

from __future__ import annotations

import dataclasses
import queue
import threading
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path

from simbridge.apps.idle import next_request
from simbridge.apps.options import PICK_AND_PLACE_BACKENDS
from simbridge.apps.pick_and_place.planner_node import LocalPlannerNode
from simbridge.apps.pick_and_place.result import PickAndPlaceResult
from simbridge.apps.pick_and_place.ros1_graph import Ros1Graph
from simbridge.apps.pick_and_place.scene import SCENE_PATH, build_world
from simbridge.apps.pick_and_place.sim_side import ExecutionOptions, PickAndPlaceSim
from simbridge.apps.pick_and_place.task import PickAndPlaceTask
from simbridge.apps.pick_and_place.video import VideoRecorder
from simbridge.connector import Connector, ConnectorOptions
from simbridge.endpoint import EndpointOptions, EndpointThread, LocalBus, make_backend
from simbridge.endpoint.backends.ros1 import unique_node_name
from simbridge.errors import AppError
from simbridge.sim import World
from simbridge.sim.record import Recorder, RecordOptions
from simbridge.sim.ros import StatePublisher, description_params
from simbridge.sim.scene import RosSettings
from simbridge.sim.view import LiveView, ViewOptions

__all__ = ["AGAIN_LABEL", "BACKENDS", "PickAndPlaceDemo"]

BACKENDS = PICK_AND_PLACE_BACKENDS
AGAIN_LABEL = "Pick and place again (new seed)"
"""The demo's button in the live view."""


class PickAndPlaceDemo:
    """Start with `with`; `run(task)` as often as wanted; `serve()` answers the view's
    button until interrupted."""

    def __init__(
        self,
        backend: str = "local",
        *,
        scene: Path = SCENE_PATH,
        options: ExecutionOptions | None = None,
        progress: Callable[[str], None] | None = print,
        record: RecordOptions | None = None,
        view: ViewOptions | None = None,
    ) -> None:
        if backend not in BACKENDS:
            raise AppError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
        self.backend = backend
        self.scene = scene
        self.options = options or ExecutionOptions()
        self.say = progress or (lambda _text: None)
        self.results: list[PickAndPlaceResult] = []
        self.world: World | None = None
        self.view: LiveView | None = None
        self.recorder: Recorder | None = None
        self.port = 0
        """The endpoint's port, once started."""
        self._record = record
        self._view_options = view
        self._requests: queue.Queue[int] = queue.Queue(maxsize=1)
        self._last_seed: int | None = None
        self._stack = ExitStack()

    def __enter__(self) -> PickAndPlaceDemo:
        try:
            self._start()
        except BaseException:
            self._stack.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _start(self) -> None:
        stack, say = self._stack, self.say
        if self.backend == "local":
            bus = LocalBus()
            endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), bus))
            stack.enter_context(LocalPlannerNode(bus, self.scene))
            say(f"[pick-and-place] endpoint on port {endpoint.port} (local bus), planner node up")
        elif self.backend == "ros2":
            from simbridge.apps.pick_and_place.ros2_planner import (  # noqa: PLC0415 - rclpy
                Ros2PlannerNode,
            )

            stack.enter_context(Ros2PlannerNode(self.scene))
            ros2 = make_backend("ros2", node_name="/simbridge_endpoint")
            endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), ros2))
            say(f"[pick-and-place] endpoint on port {endpoint.port} (ros2 backend), planner up")
        else:
            graph = stack.enter_context(Ros1Graph(self.scene))
            say(f"[pick-and-place] ROS master {graph.master.describe()}, planner node up")
            ros1 = make_backend("ros1", node_name=unique_node_name("simbridge_endpoint"))
            endpoint = stack.enter_context(EndpointThread(EndpointOptions(port=0), ros1))
            say(f"[pick-and-place] endpoint on port {endpoint.port} (ros1 backend)")
        self.port = endpoint.port
        if self._record is not None:
            self.recorder = Recorder(self._record, clock=self._sim_time)
            stack.callback(self._close_recorder)

    def _sim_time(self) -> float:
        return self.world.time if self.world is not None else 0.0

    def _close_recorder(self) -> None:
        if self.recorder is not None:
            self.say(f"[pick-and-place] {self.recorder.close().summary()}")
            self.recorder = None

    def run(
        self, task: PickAndPlaceTask, seed: int | None = None, video: Path | None = None
    ) -> PickAndPlaceResult:
        """One pick and place of `task` in a fresh world (shown in the view, if any)."""
        world = build_world(task, self.scene)
        self.world = world
        self._last_seed = seed
        if self._view_options is not None:
            self._show(world)
        recorder = VideoRecorder(world, video) if video is not None else None
        connector = Connector("127.0.0.1", self.port, ConnectorOptions(reconnect_initial=0.2))
        if self.recorder is not None:
            self.recorder.attach(connector)
        with connector.connect():
            sim = PickAndPlaceSim(
                world, connector, task, backend=self.backend, seed=seed,
                options=self.options, progress=self.say, recorder=recorder,
            )  # fmt: skip
            # What RViz shows (`simbridge rviz pick-and-place`) and a recording holds: the
            # arm's model, joint states and TF.
            for name, description in description_params(world).items():
                connector.set_param(name, description)
            state = StatePublisher(world, connector, RosSettings(clock=False))
            state.start()
            try:
                result = sim.run()
            finally:
                state.close()
        if recorder is not None:
            result = dataclasses.replace(result, video=str(recorder.save()))
            self.say(f"[pick-and-place] wrote {result.video} ({recorder.frame_count} frames)")
        verdict = "success" if result.success else "FAILED"
        self.say(
            f"[pick-and-place] {verdict}: cube {result.cube_error_m * 100:.2f} cm from the "
            f"target, tilted {result.tilt_deg:.1f} deg; {result.sim_time:.2f} s simulated in "
            f"{result.wall_time:.2f} s"
        )
        self.results.append(result)
        return result

    def _show(self, world: World) -> None:
        if self.view is None:
            self.view = self._stack.enter_context(LiveView(world, self._view_options))
            self.view.add_button(
                AGAIN_LABEL,
                self.again,
                hint="draw a new cube and target from the next seed and run the task again",
            )
            self.say(f"[pick-and-place] live view at {self.view.url}")
        else:
            self.view.show(world)

    def again(self) -> None:
        """Queue a run with the next seed (what the view's button does); a press while
        one is already queued is ignored."""
        seed = (self._last_seed if self._last_seed is not None else 0) + 1
        self._last_seed = seed
        try:
            self._requests.put_nowait(seed)
        except queue.Full:
            self.say("[pick-and-place] a run is already queued; press ignored")

    def serve(self, stop: threading.Event | None = None) -> None:
        """Run what the view's button queues until `stop` is set (or Ctrl-C)."""
        stop = stop or threading.Event()
        if self.view is not None:
            self.say(f"[pick-and-place] serving {self.view.url}: '{AGAIN_LABEL}' runs again")
        try:
            while (seed := self._next_request(stop)) is not None:
                self.say(f"[pick-and-place] again with seed {seed}")
                self.run(PickAndPlaceTask.random(seed), seed)
        except KeyboardInterrupt:
            pass

    def _next_request(self, stop: threading.Event) -> int | None:
        """The next queued seed, the shown world stepping meanwhile (apps/idle.py)."""
        world = self.world if self.view is not None else None
        factor = self.options.realtime_factor
        return next_request(self._requests, stop, world, factor, "pick-and-place-idle")

    def close(self) -> None:
        """Stop the view, the recorder and the graph."""
        self._stack.close()
