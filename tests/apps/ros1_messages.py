"""Test support: genpy Python modules for registry types, as a catkin workspace would build them.

`rosservice call` needs the service's Python module (niryo_moveit.srv, like the tutorial's
catkin package builds). This writes the .msg/.srv texts from the message registry into a
package tree, runs Debian's genpy generators on them, and returns the environment that
lets ROS tools import them. It also proves the registry's texts hash to the same md5sums
as genpy's, since the tools check those against the running node.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

from simbridge.messages import MessageRegistry

__all__ = ["GENPY", "generate_python_messages"]

GENPY = Path("/usr/lib/genpy")
DEBIAN_PYTHON = Path("/usr/lib/python3/dist-packages")
SYSTEM_PYTHON = "/usr/bin/python3"

_PACKAGE_XML = """<?xml version="1.0"?>
<package format="2">
  <name>{name}</name>
  <version>0.0.0</version>
  <description>{name} messages generated for simbridge tests</description>
  <maintainer email="tests@example.com">simbridge tests</maintainer>
  <license>Apache-2.0</license>
  <buildtool_depend>catkin</buildtool_depend>
</package>
"""


def _run(args: list[str]) -> None:
    done = subprocess.run(
        [SYSTEM_PYTHON, *args], capture_output=True, text=True, check=False, timeout=60
    )
    if done.returncode != 0:
        raise RuntimeError(f"genpy failed: {' '.join(args)}\n{done.stdout}\n{done.stderr}")


def generate_python_messages(
    registry: MessageRegistry, services: list[str], root: Path
) -> dict[str, str]:
    """Generate Python modules for ``services`` and their message types that Debian lacks.

    Returns the ROS_PACKAGE_PATH and PYTHONPATH entries to add to a ROS tool's environment.
    """
    sources, python = root / "src", root / "python"
    types: set[str] = set()
    for service in services:
        info = registry.service(service)
        for part in (info.request, info.response):
            types.update(registry.dependencies(part))
    messages = {t for t in types if not t.endswith(("Request", "Response"))}
    packages: dict[str, list[str]] = {}
    for name in sorted(messages):
        package, base = name.split("/")
        folder = sources / package / "msg"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / f"{base}.msg").write_text(registry.text(name))
        packages.setdefault(package, [])
    for service in services:
        info = registry.service(service)
        package, base = service.split("/")
        folder = sources / package / "srv"
        folder.mkdir(parents=True, exist_ok=True)
        text = registry.text(info.request) + "---\n" + registry.text(info.response)
        (folder / f"{base}.srv").write_text(text)
    includes = [f"-I{p}:{sources / p / 'msg'}" for p in sorted({*packages})]
    for package in sorted({*packages, *(s.split("/")[0] for s in services)}):
        if (DEBIAN_PYTHON / package).is_dir():
            continue
        (sources / package / "package.xml").write_text(_PACKAGE_XML.format(name=package))
        (python / package).mkdir(parents=True, exist_ok=True)
        (python / package / "__init__.py").write_text("")
        for kind, script in (("msg", "genmsg_py.py"), ("srv", "gensrv_py.py")):
            files = sorted((sources / package / kind).glob(f"*.{kind}"))
            if not files:
                continue
            out = python / package / kind
            generator = str(GENPY / script)
            _run([generator, "-p", package, "-o", str(out), *includes, *map(str, files)])
            _run([generator, "--initpy", "-p", package, "-o", str(out)])
    return {"ROS_PACKAGE_PATH": str(sources), "PYTHONPATH": str(python)}
