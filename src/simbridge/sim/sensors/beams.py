"""A lidar's beams: its ray fan cast from the mount, with seeded Gaussian range noise."""

from __future__ import annotations

import dataclasses
from typing import Protocol

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.sim.sensors.frames import MountedFrame, Pose
from simbridge.sim.sensors.raycast import RayCaster, RayHits, body_ids

__all__ = ["BeamOptions", "LidarBeams"]


class BeamOptions(Protocol):
    """The options every lidar config has for its beams (see Lidar2DConfig)."""

    @property
    def range_max(self) -> float: ...
    @property
    def noise_stddev(self) -> float: ...
    @property
    def seed(self) -> int: ...
    @property
    def geomgroup(self) -> tuple[int, ...] | None: ...
    @property
    def ignore_bodies(self) -> tuple[str, ...]: ...


class LidarBeams:
    """Unit beams given in the sensor frame, cast from a mount that they see through;
    what the 2D and 3D lidars share, so both cast and add noise the same way."""

    def __init__(
        self,
        model: mujoco.MjModel,
        directions: NDArray[np.float64],
        frame: MountedFrame,
        options: BeamOptions,
        *,
        threads: int = 1,
    ) -> None:
        self._caster = RayCaster(
            model,
            directions,
            exclude_body=frame.body_id,
            cutoff=options.range_max * 1.01,
            geomgroup=options.geomgroup,
            ignore_bodies=body_ids(model, options.ignore_bodies),
            threads=threads,
        )
        self._noise_stddev = options.noise_stddev
        self._rng = np.random.default_rng(options.seed)

    def __len__(self) -> int:
        return len(self._caster)

    @property
    def directions(self) -> NDArray[np.float64]:
        """The beams' unit directions in the sensor frame, one row each."""
        return self._caster.directions

    def cast(self, model: mujoco.MjModel, data: mujoco.MjData, pose: Pose) -> RayHits:
        """Cast every beam from `pose` now; distances carry the range noise (inf stays inf)."""
        hits = self._caster.cast(model, data, pose)
        if self._noise_stddev > 0:
            noise = self._rng.normal(0.0, self._noise_stddev, len(hits.distance))
            hits = dataclasses.replace(hits, distance=hits.distance + noise)
        return hits

    def close(self) -> None:
        """Stop the ray-casting worker threads, if any were started."""
        self._caster.close()
