"""An MJCF document under construction, with helpers for the sections simbridge fills."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence

import mujoco

from simbridge.errors import SimError

__all__ = ["MjcfDocument", "fmt"]


def fmt(values: float | Iterable[float]) -> str:
    """MJCF attribute text for a number or a vector, with round-trip precision."""
    if isinstance(values, int | float):
        return repr(float(values))
    return " ".join(repr(float(v)) for v in values)


class MjcfDocument:
    """A `<mujoco>` XML tree: edit it (add bodies, sites, cameras, sensors), then `compile()`."""

    SECTIONS = (
        "compiler",
        "option",
        "size",
        "visual",
        "default",
        "asset",
        "worldbody",
        "contact",
        "equality",
        "tendon",
        "actuator",
        "sensor",
    )

    def __init__(self, model_name: str = "simbridge") -> None:
        self.root = ET.Element("mujoco", model=model_name)
        for tag in self.SECTIONS:
            ET.SubElement(self.root, tag)
        self.compiler.attrib.update(
            angle="radian", autolimits="true", inertiafromgeom="false", balanceinertia="true"
        )

    def section(self, tag: str) -> ET.Element:
        """The top-level element `tag` (one of `SECTIONS`)."""
        elem = self.root.find(tag)
        if elem is None:
            raise SimError(f"MJCF has no <{tag}> section (valid: {', '.join(self.SECTIONS)})")
        return elem

    @property
    def compiler(self) -> ET.Element:
        """`<compiler>`: angle units, inertia handling."""
        return self.section("compiler")

    @property
    def option(self) -> ET.Element:
        """`<option>`: timestep, gravity, solver, integrator."""
        return self.section("option")

    @property
    def asset(self) -> ET.Element:
        """`<asset>`: meshes, textures, materials."""
        return self.section("asset")

    @property
    def worldbody(self) -> ET.Element:
        """`<worldbody>`: the body tree."""
        return self.section("worldbody")

    def body(self, name: str) -> ET.Element:
        """The `<body>` named `name` (a URDF link name), to mount sites, cameras or geoms on."""
        for elem in self.worldbody.iter("body"):
            if elem.get("name") == name:
                return elem
        names = [b.get("name", "") for b in self.worldbody.iter("body")]
        raise SimError(f"no body named '{name}' (bodies: {', '.join(names) or 'none'})")

    def body_names(self) -> list[str]:
        """Every body name, parents before children."""
        return [b.get("name", "") for b in self.worldbody.iter("body")]

    def add_site(
        self,
        body: str,
        name: str,
        pos: Sequence[float] = (0, 0, 0),
        quat_wxyz: Sequence[float] = (1, 0, 0, 0),
    ) -> ET.Element:
        """Add a site (a frame for sensors) on body `body`, in that body's frame."""
        return ET.SubElement(self.body(body), "site", name=name, pos=fmt(pos), quat=fmt(quat_wxyz))

    def to_xml(self) -> str:
        """The document as MJCF text, empty sections left out."""
        root = ET.Element(self.root.tag, self.root.attrib)
        for child in self.root:
            if len(child) or child.attrib:
                root.append(child)
        ET.indent(root)
        return ET.tostring(root, encoding="unicode")

    def compile(self) -> mujoco.MjModel:
        """Compile into an `MjModel`; MuJoCo's complaints become `SimError`."""
        try:
            return mujoco.MjModel.from_xml_string(self.to_xml())
        except ValueError as exc:
            raise SimError(f"MuJoCo rejected the model: {exc}") from None
