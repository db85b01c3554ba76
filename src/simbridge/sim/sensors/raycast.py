"""Batched ray casting against the collision world with one `mj_multiRay` call."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import SimError
from simbridge.sim.sensors.frames import Pose

__all__ = ["RayCaster", "RayHits", "body_ids", "check_range_limits", "collision_geom_groups"]

NUM_GEOM_GROUPS = 6

# Below this many rays per worker, thread hand-off costs more than it saves.
_MIN_RAYS_PER_THREAD = 4096
# A ray passes through at most this many ignored geoms before it counts as blocked.
_MAX_PASS_THROUGH = 16


def check_range_limits(name: str, range_min: float, range_max: float) -> None:
    """A ray sensor needs 0 <= range_min < range_max; SimError naming the sensor otherwise."""
    if not 0 <= range_min < range_max:
        raise SimError(
            f"lidar {name!r}: needs 0 <= range_min < range_max, got [{range_min}, {range_max}]"
        )


def body_ids(model: mujoco.MjModel, names: tuple[str, ...]) -> frozenset[int]:
    """Ids of the named bodies; SimError naming any unknown one."""
    ids = []
    for name in names:
        body = int(mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name))
        if body < 0:
            known = [model.body(i).name for i in range(model.nbody)]
            raise SimError(f"ray caster: body {name!r} is not in the model; bodies: {known}")
        ids.append(body)
    return frozenset(ids)


def collision_geom_groups(model: mujoco.MjModel) -> NDArray[np.uint8]:
    """Geom-group mask selecting the groups that hold collidable geoms.

    Visual-only geoms (contype = conaffinity = 0) usually live in groups of their own, so
    this keeps rays off them; a model without any collidable geom gets every group.
    """
    collidable = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    mask = np.zeros(NUM_GEOM_GROUPS, dtype=np.uint8)
    groups = model.geom_group[collidable]
    mask[groups[(groups >= 0) & (groups < NUM_GEOM_GROUPS)]] = 1
    return mask if mask.any() else np.ones(NUM_GEOM_GROUPS, dtype=np.uint8)


@dataclass(frozen=True)
class RayHits:
    """Per-ray results: distance (inf for no hit), hit geom (-1) and |cos(incidence)|."""

    distance: NDArray[np.float64]
    geom_id: NDArray[np.int32]
    cos_incidence: NDArray[np.float64]


class RayCaster:
    """Casts a fixed fan of unit rays, given in the sensor frame, from the sensor origin.

    Geoms of `exclude_body` (the body the sensor is mounted on) and of `ignore_bodies`
    (say, the rest of the robot) are seen through, as are geoms outside `geomgroup` and,
    as in MuJoCo, fully transparent geoms. MuJoCo releases
    the GIL while casting, so large fans are split over up to `threads` worker threads
    (0: one per CPU); `close()` stops them.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        directions: NDArray[np.float64],
        *,
        exclude_body: int,
        cutoff: float,
        geomgroup: tuple[int, ...] | None = None,
        ignore_bodies: frozenset[int] = frozenset(),
        threads: int = 1,
    ) -> None:
        if directions.ndim != 2 or directions.shape[1] != 3 or len(directions) == 0:
            raise SimError(f"ray directions must be an (N, 3) array, got shape {directions.shape}")
        if geomgroup is not None and len(geomgroup) != NUM_GEOM_GROUPS:
            raise SimError(f"geomgroup needs {NUM_GEOM_GROUPS} flags (0/1), got {geomgroup!r}")
        norms = np.linalg.norm(directions, axis=1, keepdims=True)
        self.directions = np.ascontiguousarray(directions / norms)
        self.exclude_body = exclude_body if exclude_body > 0 else -1
        self.cutoff = cutoff
        self.geomgroup = (
            collision_geom_groups(model)
            if geomgroup is None
            else np.array([1 if flag else 0 for flag in geomgroup], dtype=np.uint8)
        )
        self._ignored = np.zeros(model.nbody, dtype=bool)
        self._ignored[list(ignore_bodies)] = True
        if ignore_bodies and self.exclude_body > 0:
            self._ignored[self.exclude_body] = True
        count = len(self.directions)
        self._geom_id = np.zeros(count, dtype=np.int32)
        self._dist = np.zeros(count, dtype=np.float64)
        self._normal = np.zeros(3 * count, dtype=np.float64)
        workers = min(threads or os.cpu_count() or 1, max(1, count // _MIN_RAYS_PER_THREAD))
        bounds = np.linspace(0, count, workers + 1).astype(int)
        self._chunks = list(zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True))
        self._pool: ThreadPoolExecutor | None = None

    def __len__(self) -> int:
        return len(self.directions)

    def cast(self, model: mujoco.MjModel, data: mujoco.MjData, pose: Pose) -> RayHits:
        """Cast every ray from `pose` (sensor frame in world) and report the hits."""
        world_dirs = np.ascontiguousarray(self.directions @ pose.rotation.T)
        origin = np.ascontiguousarray(pose.position, dtype=np.float64)
        flat_dirs = world_dirs.ravel()

        def cast_chunk(bounds: tuple[int, int]) -> None:
            start, stop = bounds
            mujoco.mj_multiRay(
                model,
                data,
                origin,
                flat_dirs[3 * start : 3 * stop],
                self.geomgroup,
                1,
                self.exclude_body,
                self._geom_id[start:stop],
                self._dist[start:stop],
                self._normal[3 * start : 3 * stop],
                stop - start,
                self.cutoff,
            )

        if len(self._chunks) == 1:
            cast_chunk(self._chunks[0])
        else:
            if self._pool is None:
                self._pool = ThreadPoolExecutor(len(self._chunks), thread_name_prefix="raycast")
            list(self._pool.map(cast_chunk, self._chunks))
        if self._ignored.any():
            self._pass_through(model, data, origin, world_dirs)
        hit = self._geom_id >= 0
        distance = np.where(hit, self._dist, np.inf)
        normals = self._normal.reshape(-1, 3)
        cos_incidence = np.where(hit, np.abs(np.einsum("ij,ij->i", normals, world_dirs)), 0.0)
        return RayHits(distance, self._geom_id.copy(), cos_incidence)

    def close(self) -> None:
        """Stop the worker threads, if any were started."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def _pass_through(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        origin: NDArray[np.float64],
        world_dirs: NDArray[np.float64],
    ) -> None:
        """Continue every ray that hit an ignored body from its hit point, one by one."""
        body_of = model.geom_bodyid
        hit = self._geom_id >= 0
        blocked = np.flatnonzero(hit & self._ignored[body_of[np.where(hit, self._geom_id, 0)]])
        geom = np.zeros(1, dtype=np.int32)
        normal = np.zeros(3)
        for ray in blocked:
            direction = world_dirs[ray]
            travelled = float(self._dist[ray])
            body = int(body_of[self._geom_id[ray]])
            self._geom_id[ray] = -1
            for _ in range(_MAX_PASS_THROUGH):
                start = origin + direction * travelled
                step = mujoco.mj_ray(
                    model, data, start, direction, self.geomgroup, 1, body, geom, normal
                )
                if step < 0:
                    break
                travelled += step
                body = int(body_of[geom[0]])
                if not self._ignored[body]:
                    self._geom_id[ray] = geom[0]
                    self._dist[ray] = travelled
                    self._normal[3 * ray : 3 * ray + 3] = normal
                    break
