"""The shipped tasks and their environment factories (the registered ids' entry points)."""

from __future__ import annotations

from simbridge.gym.tasks.nav import NAV_SCENE, NavTask, make_nav
from simbridge.gym.tasks.pick_and_place import (
    PICK_AND_PLACE_SCENE,
    PickAndPlaceEnvTask,
    make_pick_and_place,
)
from simbridge.gym.tasks.reach import REACH_SCENE, ReachTask, make_reach

__all__ = [
    "NAV_SCENE",
    "PICK_AND_PLACE_SCENE",
    "REACH_SCENE",
    "NavTask",
    "PickAndPlaceEnvTask",
    "ReachTask",
    "make_nav",
    "make_pick_and_place",
    "make_reach",
]
