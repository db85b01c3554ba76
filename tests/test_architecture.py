"""Project-wide rules: every package's public API imports, and layers only import downward."""

from __future__ import annotations

import ast
import importlib
import pkgutil
from pathlib import Path

import pytest
from scripts.import_graph import circles, graph, module_names, within

import simbridge

SRC = Path(simbridge.__file__).parent

# Each layer may import itself and the layers listed after it (errors, assets, tcp, progress
# and lazy anywhere: tcp is the socket options both the connector and the endpoint set,
# progress the status line of any long work, lazy the faces that load names on first use).
LAYERS = [
    "cli",
    "cluster",
    "apps",
    "gym",
    "planning",
    "perception",
    "sim",
    "connector",
    "endpoint",
    "protocol",
    "messages",
]
ALLOWED: dict[str, set[str]] = {
    "cli": set(LAYERS),
    # Ray runs beside apps and gym and drives them (only it and cli know Ray exists).
    "cluster": {"cluster", "gym", "planning", "perception", "sim", "connector", "messages"},
    "apps": {
        "apps",
        "planning",
        "perception",
        "sim",
        "connector",
        "endpoint",
        "protocol",
        "messages",
    },
    # Learning envs sit beside apps: scenes from sim (apps' scene files by path only), the
    # connector for the policy node on the ROS side.
    "gym": {"gym", "planning", "sim", "connector", "messages"},
    "planning": {"planning", "sim", "messages"},
    # Datasets of labelled images: scenes posed and rendered by sim, nothing above it.
    "perception": {"perception", "sim"},
    "sim": {"sim", "connector", "protocol", "messages"},
    "connector": {"connector", "protocol", "messages"},
    "endpoint": {"endpoint", "protocol", "messages"},
    "protocol": {"protocol"},
    "messages": {"messages"},
}
ANYWHERE = {"errors", "assets", "tcp", "progress", "lazy", "__init__"}

PACKAGES = sorted(
    name for _, name, is_pkg in pkgutil.walk_packages([str(SRC)], prefix="simbridge.") if is_pkg
)


OPTIONAL_ROS = {"rospy", "rosgraph", "genpy", "rclpy"}
"""ROS libraries a face loads only for the names that need them; such a name is checked
where its library is installed (the ros2 face's in the ROS 2 venv, tests/endpoint/test_faces.py)."""


def _resolves(module: object, name: str) -> bool:
    """Whether `module` has `name`, loading it if its face loads on first use; True when
    that needs a ROS library not installed here."""
    try:
        return hasattr(module, name)
    except ModuleNotFoundError as exc:
        if exc.name not in OPTIONAL_ROS:
            raise
        return True


@pytest.mark.parametrize("package", ["simbridge", *PACKAGES])
def test_public_api_imports(package: str) -> None:
    module = importlib.import_module(package)
    exported = getattr(module, "__all__", None)
    assert exported, f"{package} has no __all__"
    missing = [name for name in exported if not _resolves(module, name)]
    assert not missing, f"{package}.__all__ names missing attributes: {missing}"


def _layer(path: Path) -> str:
    rel = path.relative_to(SRC)
    return rel.parts[0].removesuffix(".py")


def _imported_layers(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    found: set[str] = set()
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        for name in names:
            parts = name.split(".")
            if parts[0] == "simbridge" and len(parts) > 1:
                found.add(parts[1])
    return found


def test_lower_layers_never_import_higher_ones() -> None:
    violations = []
    for path in sorted(SRC.rglob("*.py")):
        layer = _layer(path)
        if layer in ANYWHERE:
            continue
        allowed = ALLOWED[layer] | ANYWHERE
        for target in _imported_layers(path) - allowed:
            violations.append(f"{path.relative_to(SRC)} ({layer}) imports simbridge.{target}")
    assert not violations, "\n".join(violations)


# ---- inside endpoint/ -------------------------------------------------------------------
#
# Every import counts here, those under TYPE_CHECKING and inside functions included: a
# type-hint import is still a dependency a reader has to follow.

ENDPOINT = "endpoint"

SHARED_LEAVES = {"endpoint.typecheck"}
"""Endpoint modules every part may import; they import nothing else of the endpoint."""

# What each part of endpoint/ may import of it (itself, and the shared leaves).
ENDPOINT_PARTS: dict[str, set[str]] = {
    "endpoint.speed": {"endpoint.speed"},
    "endpoint.backends": {"endpoint.backends", "endpoint.speed"},
    "endpoint.backends.ros1": {"endpoint.backends.ros1", "endpoint.backends", "endpoint.speed"},
    "endpoint.backends.ros2": {"endpoint.backends.ros2", "endpoint.backends", "endpoint.speed"},
}
"""The most specific entry that contains a module applies (so ros1 and ros2 never import
each other)."""

MODULES = module_names(SRC)
"""Every module of simbridge by dotted name below `simbridge.`."""


def _endpoint_graph() -> dict[str, set[str]]:
    """Each endpoint module's imports of other endpoint modules."""
    return graph(MODULES, ENDPOINT)


def test_endpoint_has_no_import_circles() -> None:
    found = circles(_endpoint_graph())
    assert not found, "\n".join(" <-> ".join(group) for group in found)


def test_circles_are_found() -> None:
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_endpoint_parts_import_only_what_lies_below_them() -> None:
    violations = []
    for name, targets in sorted(_endpoint_graph().items()):
        parts = [part for part in ENDPOINT_PARTS if within(name, part)]
        if not parts:
            continue
        allowed = ENDPOINT_PARTS[max(parts, key=len)]
        for target in sorted(targets - SHARED_LEAVES):
            if not any(within(target, part) for part in allowed):
                violations.append(f"{name} imports {target}")
    assert not violations, "\n".join(violations)


def test_shared_leaves_import_nothing_of_the_endpoint() -> None:
    graph = _endpoint_graph()
    leaning = {leaf: graph[leaf] for leaf in SHARED_LEAVES if graph[leaf]}
    assert not leaning


# ---- inside sim/ ------------------------------------------------------------------------
#
# As inside endpoint/, every import counts (TYPE_CHECKING and function-local ones too).

SIM = "sim"

SIM_LEVELS: list[set[str]] = [
    {"sim.urdf"},
    {"sim.control", "sim.sensors"},
    {"sim.scene"},
    {"sim.world", "sim.labels"},
    {"sim.ros", "sim.record", "sim.view"},
    {"sim.runner"},
]
"""The parts of sim/, lowest first: a part imports itself and the parts of lower levels,
never a sibling on its own level nor anything above (the face `sim` may import them all).
Labels (who is what, for datasets and live cameras) read a scene's entries; cameras take
them through a protocol of their own, so sensors stay below scenes.
The top-level runner (SimulationSession, run_scene) sits above ROS, recording and view."""


def _sim_graph() -> dict[str, set[str]]:
    """Each sim module's imports of other sim modules."""
    return graph(MODULES, SIM)


def _sim_level(name: str) -> tuple[int, str] | None:
    """(level, part) of a sim module; None for the face."""
    for level, parts in enumerate(SIM_LEVELS):
        for part in parts:
            if within(name, part):
                return level, part
    return None


def test_sim_has_no_import_circles() -> None:
    found = circles(_sim_graph())
    assert not found, "\n".join(" <-> ".join(group) for group in found)


def test_every_sim_module_has_a_level() -> None:
    unplaced = [name for name in _sim_graph() if name != SIM and _sim_level(name) is None]
    assert not unplaced


def test_sim_parts_import_only_lower_levels() -> None:
    violations = []
    for name, targets in sorted(_sim_graph().items()):
        mine = _sim_level(name)
        if mine is None:
            continue
        for target in sorted(targets):
            theirs = _sim_level(target)
            if theirs is None or (theirs[1] != mine[1] and theirs[0] >= mine[0]):
                violations.append(f"{name} imports {target}")
    assert not violations, "\n".join(violations)
