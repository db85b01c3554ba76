"""Applications built on simbridge: the pick-and-place, mobile-robot, line and bridge demos.

Their modules load on first use, so `simbridge.apps.options` (the demos' command-line
options) costs no MuJoCo or endpoint import.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.apps.pick_and_place import PickAndPlaceResult, run_pick_and_place
    from simbridge.apps.pick_and_place.runner import main as pick_and_place_main

__all__ = ["PickAndPlaceResult", "pick_and_place_main", "run_pick_and_place"]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "PickAndPlaceResult": "pick_and_place",
        "run_pick_and_place": "pick_and_place",
        "pick_and_place_main": "pick_and_place.runner:main",
    },
)
