"""Applications built on simbridge: the pick-and-place, mobile-robot, line and bridge demos.

Their modules load on first use, so `simbridge.apps.options` (the demos' command-line
options) costs no MuJoCo or endpoint import.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from simbridge.apps.pick_and_place import PickAndPlaceResult, run_pick_and_place
    from simbridge.apps.pick_and_place.runner import main as pick_and_place_main

__all__ = ["PickAndPlaceResult", "pick_and_place_main", "run_pick_and_place"]

_LAZY = {
    "PickAndPlaceResult": ("simbridge.apps.pick_and_place", "PickAndPlaceResult"),
    "run_pick_and_place": ("simbridge.apps.pick_and_place", "run_pick_and_place"),
    "pick_and_place_main": ("simbridge.apps.pick_and_place.runner", "main"),
}


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'simbridge.apps' has no attribute {name!r}")
    module, attribute = _LAZY[name]
    return getattr(importlib.import_module(module), attribute)
