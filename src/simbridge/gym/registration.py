"""The `simbridge/...` environment ids, registered with Gymnasium on `import simbridge.gym`."""

from __future__ import annotations

from typing import Any

import gymnasium

from simbridge.gym.tasks.nav import make_nav
from simbridge.gym.tasks.pick_and_place import make_pick_and_place
from simbridge.gym.tasks.reach import make_reach
from simbridge.gym.vector import EnvFactory, SceneVectorEnv

__all__ = ["ENV_IDS", "register_envs"]

_FACTORIES: dict[str, tuple[EnvFactory, int]] = {
    "simbridge/Reach-v0": (make_reach, 50),
    "simbridge/PickAndPlace-v0": (make_pick_and_place, 250),
    "simbridge/DiffDriveNav-v0": (make_nav, 400),
}
ENV_IDS = tuple(_FACTORIES)
"""Every registered id."""


def _vector_entry(factory: EnvFactory) -> Any:
    def make_vector(
        num_envs: int, max_episode_steps: int | None = None, **kwargs: Any
    ) -> SceneVectorEnv:
        return SceneVectorEnv(factory, num_envs, max_episode_steps=max_episode_steps, **kwargs)

    return make_vector


def register_envs() -> None:
    """Register every id (idempotent): single envs get a `TimeLimit` of the step count
    shown, vectors (`gymnasium.make_vec`) are `SceneVectorEnv`s unless "sync"/"async"."""
    for env_id, (factory, steps) in _FACTORIES.items():
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point=factory,
            vector_entry_point=_vector_entry(factory),
            max_episode_steps=steps,
        )
