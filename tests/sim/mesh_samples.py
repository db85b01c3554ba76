"""Mesh files written by the tests (COLLADA and STL variants real robot packages contain)."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import trimesh

# A unit cube [0, 1]^3 in file units: 8 corners, 12 triangles (outward).
_CUBE = trimesh.creation.box(extents=(1, 1, 1))
_CUBE.apply_translation((0.5, 0.5, 0.5))
VERTS = np.asarray(_CUBE.vertices)
FACES = np.asarray(_CUBE.faces)


def _floats(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in np.asarray(values).ravel())


def _effect(eid: str, rgba: tuple[float, ...] | None, texture: bool) -> str:
    if texture:
        return f"""<effect id="{eid}"><profile_COMMON>
  <newparam sid="surf"><surface type="2D"><init_from>img</init_from></surface></newparam>
  <newparam sid="samp"><sampler2D><source>surf</source></sampler2D></newparam>
  <technique sid="c"><lambert><diffuse><texture texture="samp" texcoord="UV"/></diffuse>
  </lambert></technique></profile_COMMON></effect>"""
    colour = " ".join(str(c) for c in rgba or (1, 1, 1, 1))
    return f"""<effect id="{eid}"><profile_COMMON><technique sid="c"><lambert>
  <diffuse><color>{colour}</color></diffuse></lambert></technique></profile_COMMON></effect>"""


def collada(
    *,
    unit: float = 1.0,
    up: str = "Z_UP",
    colours: tuple[tuple[float, float, float, float], ...] = ((1.0, 0.0, 0.0, 1.0),),
    vertex_colours: np.ndarray | None = None,
    texture: str | None = None,
) -> str:
    """A cube as COLLADA: faces split evenly over one material per entry of `colours`
    (or per-vertex colours, or one texture image file mapped by UVs)."""
    n_mat = 1 if texture or vertex_colours is not None else len(colours)
    effects = "".join(
        _effect(f"e{i}", colours[i] if i < len(colours) else None, texture is not None)
        for i in range(n_mat)
    )
    materials = "".join(
        f'<material id="m{i}"><instance_effect url="#e{i}"/></material>' for i in range(n_mat)
    )
    images = (
        f'<library_images><image id="img"><init_from>{texture}</init_from></image></library_images>'
        if texture
        else ""
    )
    sources = f"""<source id="p"><float_array id="pa" count="{VERTS.size}">{_floats(VERTS)}
  </float_array><technique_common><accessor source="#pa" count="{len(VERTS)}" stride="3">
  <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
  </accessor></technique_common></source>"""
    inputs = '<input semantic="VERTEX" source="#v" offset="0"/>'
    if vertex_colours is not None:
        sources += f"""<source id="c"><float_array id="ca" count="{vertex_colours.size}">
  {_floats(vertex_colours)}</float_array><technique_common>
  <accessor source="#ca" count="{len(vertex_colours)}" stride="4"><param name="R" type="float"/>
  <param name="G" type="float"/><param name="B" type="float"/><param name="A" type="float"/>
  </accessor></technique_common></source>"""
        inputs += '<input semantic="COLOR" source="#c" offset="0"/>'
    if texture:
        uv = VERTS[:, :2]  # planar mapping: u = x, v = y
        sources += f"""<source id="t"><float_array id="ta" count="{uv.size}">{_floats(uv)}
  </float_array><technique_common><accessor source="#ta" count="{len(uv)}" stride="2">
  <param name="S" type="float"/><param name="T" type="float"/></accessor>
  </technique_common></source>"""
        inputs += '<input semantic="TEXCOORD" source="#t" offset="0" set="0"/>'
    chunks = np.array_split(np.arange(len(FACES)), n_mat)
    triangles = "".join(
        f'<triangles material="s{i}" count="{len(idx)}">{inputs}<p>'
        f"{' '.join(str(int(k)) for k in FACES[idx].ravel())}</p></triangles>"
        for i, idx in enumerate(chunks)
    )
    bind = "".join(
        f'<instance_material symbol="s{i}" target="#m{i}">'
        '<bind_vertex_input semantic="UV" input_semantic="TEXCOORD" input_set="0"/>'
        "</instance_material>"
        for i in range(n_mat)
    )
    return f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="u" meter="{unit}"/><up_axis>{up}</up_axis></asset>
  {images}
  <library_effects>{effects}</library_effects>
  <library_materials>{materials}</library_materials>
  <library_geometries><geometry id="g"><mesh>{sources}
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>{triangles}
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n">
    <instance_geometry url="#g"><bind_material><technique_common>{bind}
    </technique_common></bind_material></instance_geometry>
  </node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"""


def ascii_stl(path: Path) -> None:
    """The unit cube as an ASCII STL (MuJoCo reads only binary STL)."""
    lines = ["solid cube"]
    for tri in VERTS[FACES]:
        normal = np.cross(tri[1] - tri[0], tri[2] - tri[0])
        lines.append(f"  facet normal {_floats(normal / np.linalg.norm(normal))}")
        lines.append("    outer loop")
        lines.extend(f"      vertex {_floats(v)}" for v in tri)
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append("endsolid cube")
    path.write_text("\n".join(lines) + "\n")


def binary_stl(path: Path, mesh: trimesh.Trimesh, truncate: int = 0) -> None:
    """`mesh` as binary STL, the last `truncate` bytes cut off (a broken download)."""
    data = bytearray(b"\0" * 80 + struct.pack("<I", len(mesh.faces)))
    for tri in np.asarray(mesh.vertices)[np.asarray(mesh.faces)]:
        data += struct.pack("<12fH", 0, 0, 0, *tri.ravel(), 0)
    path.write_bytes(bytes(data[: len(data) - truncate]))
