"""What a learning task adds to a scene: reset distribution, goal, reward and termination."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from types import EllipsisType

import numpy as np
from gymnasium import spaces
from numpy.typing import NDArray

from simbridge.gym.batch import WorldBatch
from simbridge.sim.world import ModelExtension, World

__all__ = ["Task"]


class Task(ABC):
    """A task on a `World`: subclass it with a reset distribution, reward and success test.

    The environment calls `bind` once after the world is built, `reset` at the start of
    every episode (after the world went back to its initial state) and `evaluate` (by
    default `reward`, `success` and `terminated`) after every step. Everything the task
    reads comes from the world (joint state, body poses), so the same code runs wherever
    the world's state comes from. `observe` adds entries (e.g. an object's pose) to the
    observation dict.
    """

    goal_space: spaces.Box
    """Bounds of the goal vector (part of the observation as "goal")."""
    batched: bool = False
    """Whether `evaluate_many` and `observe_many` read only the `WorldBatch`'s arrays
    (`batch_fields` and the state), never the worlds: a vector env then leaves the
    worlds' own data alone between resets."""
    batch_fields: tuple[str, ...] = ()
    """The derived fields (e.g. "xpos") the batched methods read from the `WorldBatch`."""

    def extensions(self) -> Sequence[ModelExtension]:
        """Edits of the MJCF document before compiling (e.g. a goal marker); none by default."""
        return ()

    def bind(self, world: World) -> None:  # noqa: B027 - optional hook
        """Look up bodies and joints once (nothing by default)."""

    @abstractmethod
    def reset(self, world: World, rng: np.random.Generator) -> NDArray[np.float64]:
        """Draw the episode's start state into `world` (teleport joints, move objects) from
        `rng` only, and return the goal (a point of `goal_space`)."""

    def observation_spaces(self) -> Mapping[str, spaces.Box]:
        """Spaces of the entries `observe` adds (none by default)."""
        return {}

    def observe(self, world: World, goal: NDArray[np.float64]) -> dict[str, NDArray[np.float32]]:
        """Task-specific observation entries, e.g. the goal relative to the robot (none by
        default)."""
        return {}

    def observe_into(
        self,
        world: World,
        goal: NDArray[np.float64],
        out: Mapping[str, NDArray[np.float32]],
        row: int | EllipsisType,
    ) -> None:
        """Write the `observe` entries into row `row` (`...`: all) of the arrays in `out`
        (the default copies what `observe` returns; override it to skip the dict and
        arrays)."""
        for key, value in self.observe(world, goal).items():
            out[key][row] = value

    @classmethod
    def observe_many(
        cls,
        tasks: Sequence[Task],
        batch: WorldBatch,
        goals: NDArray[np.float64],
        out: Mapping[str, NDArray[np.float32]],
    ) -> None:
        """`observe_into` of every world of a vector env (each with its own task, all of
        this class, bound to one model) into its row of `out`. The default asks each task
        on its world (`batch.worlds`). A subclass that sets `batched` does all rows at once
        from the batch's arrays, as long as every row gets the bits `observe_into` gives it
        (elementwise NumPy in the same order does)."""
        for row, (task, world, goal) in enumerate(zip(tasks, batch.worlds, goals, strict=True)):
            task.observe_into(world, goal, out, row)

    @classmethod
    def evaluate_many(
        cls,
        tasks: Sequence[Task],
        batch: WorldBatch,
        goals: NDArray[np.float64],
        actions: NDArray[np.float32],
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:
        """`evaluate` of every world of a vector env as arrays (reward, success,
        terminated), on the terms of `observe_many`."""
        results = [
            task.evaluate(world, goal, action)
            for task, world, goal, action in zip(tasks, batch.worlds, goals, actions, strict=True)
        ]
        return (
            np.array([r[0] for r in results], np.float64),
            np.array([r[1] for r in results], np.bool_),
            np.array([r[2] for r in results], np.bool_),
        )

    @abstractmethod
    def reward(self, world: World, goal: NDArray[np.float64], action: NDArray[np.float32]) -> float:
        """The reward for the step that just ended."""

    @abstractmethod
    def success(self, world: World, goal: NDArray[np.float64]) -> bool:
        """Whether the task is solved in the current state (reported as info["is_success"])."""

    def terminated(self, world: World, goal: NDArray[np.float64]) -> bool:
        """Whether the episode ends here (default: on success)."""
        return self.success(world, goal)

    def evaluate(
        self, world: World, goal: NDArray[np.float64], action: NDArray[np.float32]
    ) -> tuple[float, bool, bool]:
        """(reward, success, terminated) after a step: what the environment calls. The
        default asks `reward`, `success` and `terminated`; override it to share work
        between them (Reach measures its distance once)."""
        return (
            float(self.reward(world, goal, action)),
            bool(self.success(world, goal)),
            bool(self.terminated(world, goal)),
        )
