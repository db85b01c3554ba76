"""The `robot_description` parameter of a loaded robot, with mesh URIs RViz can open.

A URDF names meshes as `package://pkg/...` or paths relative to its own file. RViz
resolves `package://` through a ROS package path that need not know the robot's
package, and relative paths against nothing, so every mesh the sim found is rewritten to
the absolute `file://` URI of the very file the sim loaded. The rest of the text stays
as it was (comments, namespaces, attribute order).
"""

from __future__ import annotations

import html
import logging
import re
from xml.sax.saxutils import quoteattr

from simbridge.sim.urdf.robot import Mesh, Robot

__all__ = ["robot_description"]

_log = logging.getLogger("simbridge.sim.urdf")

_MESH_FILENAME = re.compile(r"""(<mesh\b[^>]*?\bfilename\s*=\s*)("[^"]*"|'[^']*')""")


def robot_description(robot: Robot) -> str:
    """`robot.xml` with each mesh's `filename` the `file://` URI of the file it resolved to.

    Meshes the sim did not find keep their URI (and a warning is logged): RViz will not
    find them either.
    """
    found: dict[str, str] = {}
    missing: set[str] = set()
    for link in robot.links.values():
        for shape in [v.geometry for v in link.visuals] + [c.geometry for c in link.collisions]:
            if isinstance(shape, Mesh):
                if shape.path is not None:
                    found[shape.filename] = shape.path.resolve().as_uri()
                else:
                    missing.add(shape.filename)
    if missing:
        _log.warning(
            "robot %s: mesh(es) %s were not found; RViz will not draw them",
            robot.name,
            ", ".join(sorted(missing)),
        )

    def rewrite(match: re.Match[str]) -> str:
        written = html.unescape(match.group(2)[1:-1])
        uri = found.get(written)
        return match.group(0) if uri is None else match.group(1) + quoteattr(uri)

    return _MESH_FILENAME.sub(rewrite, robot.xml)
