"""Shared helpers for the sensor tests."""

from __future__ import annotations

import mujoco


def forward_model(xml: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Compile an MJCF scene and run one forward pass so body poses are current."""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data
