"""URDF import: load time per robot of the example-robot-data corpus (dev dependency).

Each robot is built into a scene (URDF parse, mesh conversion, MJCF, MuJoCo compile) twice:
cold, with an empty mesh cache (what a first `simbridge sim` pays), and warm (every later
load). Sizes: 1-DoF joints, bodies, MuJoCo meshes and textures.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from simbridge.sim.scene import parse_scene
from simbridge.sim.world import World


def _load(path: Path, share: Path) -> World:
    scene = {
        "robots": [{"urdf": str(path), "search_paths": [str(share)], "effort_limits": "ignore"}],
        "objects": [{"name": "floor", "type": "plane"}],
        "ros": {"enabled": False},
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return World.from_scene(parse_scene(scene, path.parent))


def run() -> list[dict[str, Any]]:
    from tests.sim.corpus import CORPUS, SHARE, corpus_files

    rows: list[dict[str, Any]] = []
    saved = os.environ.get("XDG_CACHE_HOME")
    with tempfile.TemporaryDirectory() as cache:
        os.environ["XDG_CACHE_HOME"] = cache  # an empty mesh cache: the cold load
        try:
            for rel in corpus_files():
                path = CORPUS / rel
                start = time.perf_counter()
                try:
                    world = _load(path, SHARE)
                except Exception:  # a robot that fails (see the corpus test) is not fatal
                    rows.append({"robot": rel, "cold_s": "fails", "warm_s": "fails"})
                    continue
                cold = time.perf_counter() - start
                start = time.perf_counter()
                _load(path, SHARE)
                warm = time.perf_counter() - start
                model = world.model
                rows.append(
                    {
                        "robot": rel,
                        "joints": len(world.joint_names()),
                        "bodies": model.nbody - 1,
                        "meshes": model.nmesh,
                        "textures": model.ntex,
                        "cold_s": round(cold, 2),
                        "warm_s": round(warm, 2),
                    }
                )
        finally:
            if saved is None:
                os.environ.pop("XDG_CACHE_HOME", None)
            else:
                os.environ["XDG_CACHE_HOME"] = saved
    return rows


if __name__ == "__main__":
    from benchmarks.table import format_table

    print(format_table(run()))
