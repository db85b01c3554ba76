"""Collision-free joint-space paths: straight line when free, else RRT-Connect plus shortcutting."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from simbridge.errors import PlanningError
from simbridge.planning.geometry import FloatArray
from simbridge.planning.kinematics import ArmKinematics

__all__ = ["JointPathPlanner", "PathOptions"]


@dataclass(frozen=True)
class PathOptions:
    """RRT-Connect settings: extension step (rad), edge check resolution (rad), effort, seed."""

    step_size: float = 0.3
    resolution: float = 0.02
    max_samples: int = 4000
    shortcut_attempts: int = 60
    seed: int = 0


def _bisection_order(count: int) -> list[int]:
    """Indices 1..count ordered coarse-to-fine, so a blocked edge is found early."""
    order: list[int] = []
    seen: set[int] = set()
    step = 1 << max(0, math.ceil(math.log2(max(count, 1))))
    while step >= 1:
        for i in range(step, count + 1, step):
            if i not in seen:
                seen.add(i)
                order.append(i)
        step //= 2
    return order


class _Tree:
    """A growing RRT: node array plus parent indices."""

    def __init__(self, root: FloatArray, capacity: int) -> None:
        self.nodes = np.empty((capacity + 1, root.shape[0]))
        self.parents = np.full(capacity + 1, -1, dtype=np.int64)
        self.nodes[0] = root
        self.size = 1

    def nearest(self, q: FloatArray) -> int:
        diff = self.nodes[: self.size] - q
        return int(np.argmin(np.einsum("ij,ij->i", diff, diff)))

    def add(self, q: FloatArray, parent: int) -> int:
        self.nodes[self.size] = q
        self.parents[self.size] = parent
        self.size += 1
        return self.size - 1

    def path_to_root(self, index: int) -> list[FloatArray]:
        path = []
        while index >= 0:
            path.append(self.nodes[index].copy())
            index = int(self.parents[index])
        return path


class JointPathPlanner:
    """Plans collision-free piecewise-linear joint paths for an :class:`ArmKinematics`."""

    def __init__(self, kinematics: ArmKinematics, options: PathOptions | None = None) -> None:
        self.kinematics = kinematics
        self.options = options or PathOptions()

    def edge_free(self, a: FloatArray, b: FloatArray) -> bool:
        """True when the straight joint-space segment a -> b (b included) is collision-free."""
        count = max(1, math.ceil(float(np.max(np.abs(b - a))) / self.options.resolution))
        delta = b - a
        kin = self.kinematics
        return all(not kin.in_collision(a + delta * (i / count)) for i in _bisection_order(count))

    def check_state(self, q: FloatArray, what: str) -> None:
        """Raise PlanningError if ``q`` is outside limits or in collision."""
        self.kinematics.check_limits(q, what)
        contacts = self.kinematics.contacts(q)
        if contacts:
            listed = "; ".join(c.describe() for c in contacts[:3])
            raise PlanningError(f"{what} is in collision: {listed}")

    def plan(
        self, start: FloatArray, goal: FloatArray, name: str = "goal", seed: int | None = None
    ) -> FloatArray:
        """Waypoints (n x dof) from ``start`` to ``goal``, collision-free along every edge."""
        start = np.asarray(start, dtype=np.float64)
        goal = np.asarray(goal, dtype=np.float64)
        self.check_state(start, "start configuration")
        self.check_state(goal, f"{name} configuration")
        if self.edge_free(start, goal):
            return np.vstack([start, goal])
        rng = np.random.default_rng(self.options.seed if seed is None else seed)
        path = self._rrt_connect(start, goal, rng, name)
        return self._shortcut(path, rng)

    def _extend(self, tree: _Tree, target: FloatArray) -> tuple[int, bool]:
        """Step from the nearest node toward ``target``; returns (new index or -1, reached)."""
        near = tree.nearest(target)
        origin = tree.nodes[near]
        delta = target - origin
        dist = float(np.linalg.norm(delta))
        reached = dist <= self.options.step_size
        new = target if reached else origin + delta * (self.options.step_size / dist)
        if not self.edge_free(origin, new):
            return -1, False
        return tree.add(new.copy(), near), reached

    def _connect(self, tree: _Tree, target: FloatArray) -> int:
        """Extend repeatedly toward ``target``; index of the node equal to target, else -1."""
        while True:
            index, reached = self._extend(tree, target)
            if index < 0:
                return -1
            if reached:
                return index
            if tree.size >= tree.nodes.shape[0]:
                return -1

    def _rrt_connect(
        self, start: FloatArray, goal: FloatArray, rng: np.random.Generator, name: str
    ) -> list[FloatArray]:
        kin, capacity = self.kinematics, self.options.max_samples * 8
        trees = (_Tree(start, capacity), _Tree(goal, capacity))
        for sample in range(self.options.max_samples):
            grow, other = (trees[0], trees[1]) if sample % 2 == 0 else (trees[1], trees[0])
            target = rng.uniform(kin.lower, kin.upper)
            index, _ = self._extend(grow, target)
            if index < 0:
                continue
            joined = self._connect(other, grow.nodes[index].copy())
            if joined >= 0:
                a_path = grow.path_to_root(index)
                b_path = other.path_to_root(joined)
                path = a_path[::-1] + b_path[1:]
                return path if grow is trees[0] else path[::-1]
            if max(t.size for t in trees) >= capacity - 1:
                break
        raise PlanningError(
            f"no collision-free path to {name} found after {self.options.max_samples} samples"
        )

    def _shortcut(self, path: list[FloatArray], rng: np.random.Generator) -> FloatArray:
        """Drop waypoints whose neighbours see each other, trying random pairs then neighbours."""
        for _ in range(self.options.shortcut_attempts):
            if len(path) <= 2:
                break
            i, j = sorted(rng.choice(len(path), size=2, replace=False).tolist())
            if j - i > 1 and self.edge_free(path[i], path[j]):
                path = path[: i + 1] + path[j:]
        index = 0
        while index + 2 < len(path):
            if self.edge_free(path[index], path[index + 2]):
                del path[index + 1]
            else:
                index += 1
        return np.vstack(path)
