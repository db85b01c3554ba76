"""Build ROS 2 interface packages that have no wheel into the ROS 2 venv.

A package is a directory with `msg/`, `srv/` and/or `action/` (ROS 1 or ROS 2
layout; files in its `ros2/` folder replace those of the same name). It becomes a
standard `rosidl_generate_interfaces` package (package.xml
and CMakeLists.txt are generated; `Header`, `time` and `duration` become
`std_msgs/Header`, `builtin_interfaces/Time` and `builtin_interfaces/Duration`),
configured with cmake, built with ninja and installed into the venv, whose prefix
holds the ROS wheels' `share/`, `lib/` and site-packages. Builds are cached by a
hash of the generated sources: an unchanged package is not built again.

The ROS wheels were built in manylinux containers and some of their CMake files
name that machine's Python and numpy include directories; `fix_wheel_cmake_files`
points them at the venv's own before the first build.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import shutil
import subprocess
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from simbridge.errors import EndpointError
from simbridge.messages.loader import interface_files

__all__ = [
    "SHIPPED_ROS2_PACKAGES",
    "InterfaceBuildError",
    "InterfacePackage",
    "build_packages",
    "find_packages",
    "fix_wheel_cmake_files",
    "ros2_definition",
]

_log = logging.getLogger(__name__)

SHIPPED_ROS2_PACKAGES = (
    "control_msgs",
    "object_recognition_msgs",
    "tf2_msgs",
    "moveit_msgs",
    "niryo_moveit",
    "simbridge_msgs",
    "vision_msgs",
)
"""Shipped definitions with no ROS 2 wheel, built by `make ros2` (dependencies first)."""

_KINDS = ("msg", "srv", "action")
_BUILTIN = {
    "Header": "std_msgs/Header",
    "time": "builtin_interfaces/Time",
    "duration": "builtin_interfaces/Duration",
}
_FIELD = re.compile(r"^(\s*)([A-Za-z_][\w/]*)(\[[^\]]*\])?(\s+.*)$")
_BUILD_MACHINE_PATHS = (
    re.compile(r"/opt/python/cp\d+-cp\d+/include/python3\.\d+"),
    re.compile(r"/opt/python/cp\d+-cp\d+/lib/python3\.\d+/site-packages/numpy/_core/include"),
)


class InterfaceBuildError(EndpointError):
    """An interface package could not be built (missing tools, bad definitions, compile error)."""


@dataclass(frozen=True, slots=True)
class InterfacePackage:
    """One interface package, converted to ROS 2 layout, ready to generate."""

    name: str
    source: Path
    files: dict[str, str]
    """Relative path (`msg/Foo.msg`) -> ROS 2 definition text."""
    dependencies: tuple[str, ...]

    def digest(self) -> str:
        """Hash of everything that goes into the build."""
        data = json.dumps([self.name, sorted(self.files.items()), self.dependencies])
        return hashlib.sha256(data.encode()).hexdigest()


def ros2_definition(text: str, package: str) -> tuple[str, set[str]]:
    """A .msg/.srv/.action text in ROS 2 spelling, and the packages its fields use."""
    deps: set[str] = set()
    out: list[str] = []
    for line in text.splitlines():
        body = line.split("#", 1)[0]
        match = _FIELD.match(body)
        if body.strip() in ("", "---") or match is None:
            out.append(line)
            continue
        indent, type_name, array, rest = match.groups()
        type_name = _BUILTIN.get(type_name, type_name)
        if "/" in type_name:
            dep = type_name.split("/", 1)[0]
            if dep != package:
                deps.add(dep)
            else:
                type_name = type_name.split("/", 1)[1]
        comment = line[len(body) :]
        out.append(f"{indent}{type_name}{array or ''}{rest}{comment}")
    return "\n".join(out) + "\n", deps


def _package_name(path: Path) -> str:
    xml = path / "package.xml"
    if xml.exists():
        match = re.search(r"<name>\s*([\w]+)\s*</name>", xml.read_text())
        if match:
            return match.group(1)
    return path.name


def load_package(path: Path) -> InterfacePackage:
    """Read one package directory (msg/, srv/, action/; a `ros2/` folder's files replace
    those of the same name, as in the ROS 2 message registry)."""
    name = _package_name(path)
    files: dict[str, str] = {}
    deps: set[str] = set()
    for rel, file in interface_files(path, ros2=True).items():
        text, used = ros2_definition(file.read_text(), name)
        files[rel] = text
        deps |= used
        if rel.startswith("action/"):
            deps |= {"action_msgs", "builtin_interfaces", "unique_identifier_msgs"}
    if not files:
        raise InterfaceBuildError(
            f"{path} has no interface files: expected msg/*.msg, srv/*.srv or action/*.action"
        )
    return InterfacePackage(name, path, files, tuple(sorted(deps - {name})))


def find_packages(paths: Iterable[Path | str]) -> list[Path]:
    """Package directories in `paths`: each is a package or a directory of packages."""
    found: list[Path] = []
    for given in paths:
        path = Path(given)
        if not path.is_dir():
            raise InterfaceBuildError(f"{path} is not a directory")
        if any((path / kind).is_dir() for kind in _KINDS):
            found.append(path)
            continue
        inner = [p for p in sorted(path.iterdir()) if any((p / k).is_dir() for k in _KINDS)]
        if not inner:
            raise InterfaceBuildError(
                f"{path} is neither an interface package (msg/, srv/, action/) nor a "
                "directory of them"
            )
        found += inner
    return found


def _ordered(packages: list[InterfacePackage]) -> list[InterfacePackage]:
    """Dependencies among `packages` first."""
    by_name = {p.name: p for p in packages}
    done: list[InterfacePackage] = []
    seen: set[str] = set()

    def visit(pkg: InterfacePackage, stack: tuple[str, ...]) -> None:
        if pkg.name in seen:
            return
        if pkg.name in stack:
            raise InterfaceBuildError(f"interface packages depend on each other: {stack}")
        for dep in pkg.dependencies:
            if dep in by_name:
                visit(by_name[dep], (*stack, pkg.name))
        seen.add(pkg.name)
        done.append(pkg)

    for pkg in packages:
        visit(pkg, ())
    return done


def _tool(venv: Path, name: str) -> str | None:
    local = venv / "bin" / name
    return str(local) if local.exists() else shutil.which(name)


def _python_paths(python: Path) -> tuple[str, str]:
    code = (
        "import sysconfig, numpy; "
        "print(sysconfig.get_paths()['include']); print(numpy.get_include())"
    )
    out = subprocess.run(
        [str(python), "-c", code], capture_output=True, text=True, check=True, env=_clean_env()
    ).stdout.split("\n")
    return out[0], out[1]


def fix_wheel_cmake_files(venv: Path) -> int:
    """Point the wheels' CMake files at this venv's Python and numpy headers; returns how
    many files changed (0 once fixed)."""
    python_include, numpy_include = _python_paths(venv / "bin" / "python")
    if not Path(python_include, "Python.h").exists():
        raise InterfaceBuildError(
            f"Python headers are missing ({python_include}/Python.h): install your Python's "
            "development package (Debian: python3-dev)"
        )
    changed = 0
    for file in (venv / "share").glob("*/cmake/*.cmake"):
        text = file.read_text()
        fixed = _BUILD_MACHINE_PATHS[0].sub(python_include, text)
        fixed = _BUILD_MACHINE_PATHS[1].sub(numpy_include, fixed)
        if fixed != text:
            file.write_text(fixed)
            changed += 1
    return changed


def _clean_env() -> dict[str, str]:
    return {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONPATH", "PYTHONHOME") and not k.startswith("_ROS_WHEELS")
    }


def _package_xml(pkg: InterfacePackage) -> str:
    deps = "".join(f"  <depend>{d}</depend>\n" for d in pkg.dependencies)
    return f"""<?xml version="1.0"?>
<package format="3">
  <name>{pkg.name}</name>
  <version>0.0.0</version>
  <description>{pkg.name} interfaces, generated by simbridge from {pkg.source}</description>
  <maintainer email="simbridge@example.com">simbridge</maintainer>
  <license>Apache-2.0</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
{deps}  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
"""


def _cmake_lists(pkg: InterfacePackage) -> str:
    """A package's CMakeLists.txt. Only the C generators and type supports and Python's run
    (all rclpy loads): the C++ ones, half the generated code and the slow compiles (64 s
    against 210 s for tf2_msgs on a loaded machine), are dropped from the generator list
    that rosidl_generate_interfaces runs; nothing here is C++."""
    finds = "".join(f"find_package({d} REQUIRED)\n" for d in pkg.dependencies)
    files = " ".join(f'"{f}"' for f in pkg.files)
    deps = f" DEPENDENCIES {' '.join(pkg.dependencies)}" if pkg.dependencies else ""
    return f"""cmake_minimum_required(VERSION 3.16)
project({pkg.name})
find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
{finds}list(FILTER AMENT_EXTENSIONS_rosidl_generate_idl_interfaces EXCLUDE REGEX "_cpp:")
rosidl_generate_interfaces(${{PROJECT_NAME}} {files}{deps})
ament_export_dependencies(rosidl_default_runtime)
ament_package()
"""


def _run(cmd: Sequence[str], env: dict[str, str], log_file: Path, what: str) -> None:
    with log_file.open("a") as log:
        log.write(f"$ {' '.join(cmd)}\n")
        log.flush()
        result = subprocess.run(cmd, env=env, stdout=log, stderr=subprocess.STDOUT, check=False)
    if result.returncode != 0:
        tail = "".join(log_file.read_text().splitlines(keepends=True)[-25:])
        raise InterfaceBuildError(f"{what} failed (full log: {log_file}):\n{tail}")


def build_packages(
    paths: Iterable[Path | str],
    venv: Path,
    *,
    force: bool = False,
    progress: Callable[[str], None] = print,
) -> list[str]:
    """Build the interface packages in `paths` into `venv` (a ROS 2 venv); returns the
    names built (packages whose sources did not change since their last build are skipped)."""
    venv = venv.resolve()
    packages = _ordered([load_package(p) for p in find_packages(paths)])
    stamps = venv / "share" / "simbridge_interfaces"
    todo = [
        p
        for p in packages
        if force
        or not (stamps / f"{p.name}.sha256").exists()
        or (stamps / f"{p.name}.sha256").read_text().strip() != p.digest()
    ]
    for pkg in packages:
        if pkg not in todo:
            progress(f"{pkg.name}: up to date")
    if not todo:
        return []
    cmake, ninja = _tool(venv, "cmake"), _tool(venv, "ninja")
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    cxx = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++")
    missing = [n for n, t in (("cmake", cmake), ("ninja", ninja), ("a C compiler", compiler),
                              ("a C++ compiler", cxx)) if t is None]  # fmt: skip
    if missing:
        raise InterfaceBuildError(
            f"building ROS 2 interfaces needs {', '.join(missing)}: cmake and ninja come with "
            "the ROS 2 venv (`make ros2`), the compilers from your system (Debian: gcc g++)"
        )
    assert cmake is not None
    assert ninja is not None
    fix_wheel_cmake_files(venv)
    env = _clean_env()
    env["AMENT_PREFIX_PATH"] = str(venv)
    env["CMAKE_PREFIX_PATH"] = str(venv)
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    built: list[str] = []
    for pkg in todo:
        work = venv / "build" / "simbridge-interfaces" / pkg.name
        shutil.rmtree(work, ignore_errors=True)
        src, build = work / "src", work / "build"
        for rel, text in pkg.files.items():
            (src / rel).parent.mkdir(parents=True, exist_ok=True)
            (src / rel).write_text(text)
        (src / "package.xml").write_text(_package_xml(pkg))
        (src / "CMakeLists.txt").write_text(_cmake_lists(pkg))
        log_file = work / "build.log"
        progress(f"{pkg.name}: building ({len(pkg.files)} interfaces) into {venv}")
        configure = [
            cmake, "-S", str(src), "-B", str(build), "-G", "Ninja",
            f"-DCMAKE_MAKE_PROGRAM={ninja}", f"-DCMAKE_INSTALL_PREFIX={venv}",
            f"-DCMAKE_PREFIX_PATH={venv}", f"-DPython3_EXECUTABLE={venv / 'bin' / 'python'}",
            "-DBUILD_TESTING=OFF", "-DCMAKE_BUILD_TYPE=Release",
        ]  # fmt: skip
        _run(configure, env, log_file, f"configuring {pkg.name}")
        _run([cmake, "--build", str(build)], env, log_file, f"building {pkg.name}")
        _run([cmake, "--install", str(build)], env, log_file, f"installing {pkg.name}")
        stamps.mkdir(parents=True, exist_ok=True)
        (stamps / f"{pkg.name}.sha256").write_text(pkg.digest() + "\n")
        shutil.rmtree(build, ignore_errors=True)
        built.append(pkg.name)
        progress(f"{pkg.name}: built")
    return built
