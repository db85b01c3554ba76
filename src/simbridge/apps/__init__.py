"""Applications built on simbridge: the pick-and-place demo (Unity's Robotics Hub tutorial)."""

from __future__ import annotations

from simbridge.apps.pick_and_place import PickAndPlaceResult, run_pick_and_place
from simbridge.apps.pick_and_place.runner import main as pick_and_place_main

__all__ = ["PickAndPlaceResult", "pick_and_place_main", "run_pick_and_place"]
