"""simbridge on a Ray cluster: ARS rollouts on actors, perception datasets as tasks.

Ray is an optional extra (`pip install 'simbridge[ray]'`), imported only when something
here connects to a cluster; nothing else in simbridge needs it. docs/ray.md is the recipe:
start a cluster, then `simbridge train ... --ray ADDRESS` or `simbridge datagen ... --ray
ADDRESS`.

The names below load on first use, so a Ray worker that unpickles one module's class (the
datagen progress board, say) imports that module alone, not the Gymnasium environments
the ARS part needs (importing them took 2.6 s of a fresh worker's start here).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from simbridge.lazy import lazy_face

if TYPE_CHECKING:
    from simbridge.cluster.ars import (
        RayRollouts,
        RayTraining,
        RolloutWorker,
        make_vector,
        shares,
        train_ars_on_ray,
    )
    from simbridge.cluster.datagen import RayDataset, datagen_on_ray
    from simbridge.cluster.runtime import connect, node_id, ray_module

__all__ = [
    "RayDataset",
    "RayRollouts",
    "RayTraining",
    "RolloutWorker",
    "connect",
    "datagen_on_ray",
    "make_vector",
    "node_id",
    "ray_module",
    "shares",
    "train_ars_on_ray",
]

__getattr__, __dir__ = lazy_face(
    __name__,
    {
        "RayDataset": "datagen",
        "RayRollouts": "ars",
        "RayTraining": "ars",
        "RolloutWorker": "ars",
        "connect": "runtime",
        "datagen_on_ray": "datagen",
        "make_vector": "ars",
        "node_id": "runtime",
        "ray_module": "runtime",
        "shares": "ars",
        "train_ars_on_ray": "ars",
    },
)
