"""simbridge on a Ray cluster: ARS rollouts on actors, perception datasets as tasks.

Ray is an optional extra (`pip install 'simbridge[ray]'`), imported only when something
here connects to a cluster; nothing else in simbridge needs it. docs/ray.md is the recipe:
start a cluster, then `simbridge train ... --ray ADDRESS` or `simbridge datagen ... --ray
ADDRESS`.
"""

from __future__ import annotations

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
