"""The complete example in docs/scenes.md loads and runs (so the documentation stays true)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from simbridge.sim.scene import parse_scene
from simbridge.sim.world import World

DOCS = Path(__file__).resolve().parents[2] / "docs" / "scenes.md"


def test_documented_example_builds_and_holds_still() -> None:
    blocks = re.findall(r"```yaml\n(.*?)```", DOCS.read_text(), flags=re.DOTALL)
    data = yaml.safe_load(blocks[0])
    data["objects"] = [o for o in data["objects"] if o["type"] != "mesh"]  # no mesh file shipped
    scene = parse_scene(data, DOCS.parent)
    world = World.from_scene(scene)
    assert world.drives.spec("joint_6").force_limit == 5
    assert world.drives.spec("joint_6").stiffness == 2000
    assert world.drives.spec("joint_1").force_limit == 10  # the URDF's effort limit
    world.step(1000)
    positions = world.joint_positions()
    assert positions["joint_2"] == pytest.approx(-0.3, abs=5e-3)
    assert positions["joint_3"] == pytest.approx(0.6, abs=5e-3)
    assert world.link_pose("cube").xyz[2] == pytest.approx(0.215, abs=2e-3)  # rests on the table
    for block in blocks[1:]:
        parse_scene(yaml.safe_load(block), DOCS.parent)


def test_run_scene_headless_without_endpoint(tmp_path: Path) -> None:
    from simbridge.sim.ros import run_scene
    from tests.sim.urdf_samples import GRAVITY_ARM

    (tmp_path / "arm.urdf").write_text(GRAVITY_ARM)
    (tmp_path / "scene.yaml").write_text("robots: [{urdf: arm.urdf}]\n")
    stats = run_scene(tmp_path / "scene.yaml", duration=0.1, realtime_factor=0)
    assert stats.steps == 50
    assert stats.sim_time == pytest.approx(0.1)
