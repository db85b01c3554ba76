"""The sensor base class: rate scheduling in sim time, lazy outputs, stamped messages."""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping

import mujoco

from simbridge.errors import SimError
from simbridge.sim.sensors.frames import MountedFrame, Pose
from simbridge.sim.sensors.rosmsg import Publication
from simbridge.sim.sensors.schedule import RateSchedule, step_index

__all__ = ["Sensor"]


class Sensor(ABC):
    """A simulated sensor publishing one or more topics at a fixed rate in sim time.

    Each output topic can be switched on or off (`set_wanted`), e.g. by the ROS layer
    following subscriptions; a sensor with no wanted output does no work at all
    (`active` is False) but keeps its schedule so rates stay exact when it wakes.
    """

    def __init__(
        self,
        name: str,
        frame: MountedFrame,
        rate_hz: float,
        *,
        frame_id: str,
        outputs: Mapping[str, str],
        data_in_frame: Pose | None = None,
    ) -> None:
        self.name = name
        self.frame = frame
        self.frame_id = frame_id
        self._data_in_frame = data_in_frame
        self.schedule = RateSchedule(rate_hz)
        self._outputs = dict(outputs)
        self._wanted = dict.fromkeys(outputs, True)
        self._seq = dict.fromkeys(outputs, 0)
        self._last_time = -math.inf

    @property
    def outputs(self) -> dict[str, str]:
        """Topic -> ROS 1 message type of every output this sensor can publish."""
        return dict(self._outputs)

    def set_wanted(self, topic: str, wanted: bool) -> None:
        """Switch one output on or off (for instance: does anybody subscribe?)."""
        if topic not in self._outputs:
            raise SimError(
                f"sensor {self.name!r} has no output topic {topic!r}; "
                f"topics: {sorted(self._outputs)}"
            )
        self._wanted[topic] = wanted

    def set_all_wanted(self, wanted: bool) -> None:
        """Switch every output on or off."""
        for topic in self._wanted:
            self._wanted[topic] = wanted

    def wanted(self, topic: str) -> bool:
        """Whether `topic` is currently produced."""
        return self._wanted[topic]

    @property
    def active(self) -> bool:
        """True when at least one output is wanted; inactive sensors cost nothing."""
        return any(self._wanted.values())

    def due(self, model: mujoco.MjModel, data: mujoco.MjData) -> bool:
        """Whether a reading falls due at the step `data.time` is at, and some output is
        wanted; advances the schedule either way. A clock that went backwards (a
        simulation reset) restarts the sensor first."""
        now = float(data.time)
        if now < self._last_time:
            self.reset()
        self._last_time = now
        step = step_index(now, float(model.opt.timestep))
        return self.schedule.due(step, float(model.opt.timestep)) and self.active

    def poll(self, model: mujoco.MjModel, data: mujoco.MjData) -> list[Publication]:
        """Messages due at `data.time` (empty between ticks or when inactive). `data`'s
        derived quantities must match its state (`mj_forward` after `mj_step`)."""
        return self.measure(model, data) if self.due(model, data) else []

    def reset(self) -> None:
        """Restart the schedule (after the simulation clock went back to zero)."""
        self.schedule.reset()

    def world_pose(self, data: mujoco.MjData) -> Pose:
        """The sensor frame's pose in world coordinates."""
        return self.frame.world_pose(data)

    def static_frame(self, model: mujoco.MjModel) -> tuple[str, str, Pose] | None:
        """(parent body, frame_id, pose in parent) to put on /tf_static when the data frame
        is not itself a body of the model (an offset mount or a camera optical frame)."""
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, self.frame_id) >= 0:
            return None
        parent = model.body(self.frame.body_id).name or "world"
        pose = self.frame.offset
        if self._data_in_frame is not None:
            pose = pose.compose(self._data_in_frame)
        return parent, self.frame_id, pose

    def close(self) -> None:  # noqa: B027 - optional hook, most sensors hold nothing
        """Release rendering or other resources (nothing by default)."""

    def _publication(self, topic: str, message: object) -> Publication:
        return Publication(topic, self._outputs[topic], message)

    def _next_seq(self, topic: str) -> int:
        seq = self._seq[topic]
        self._seq[topic] = seq + 1
        return seq

    @abstractmethod
    def measure(self, model: mujoco.MjModel, data: mujoco.MjData) -> list[Publication]:
        """Take a reading now and return the wanted outputs as messages."""
