"""Project-wide rules: every package's public API imports, and layers only import downward."""

from __future__ import annotations

import ast
import importlib
import pkgutil
from pathlib import Path

import pytest

import simbridge

SRC = Path(simbridge.__file__).parent

# Each layer may import itself and the layers listed after it (errors, assets and tcp
# anywhere: tcp is the socket options both the connector and the endpoint set).
LAYERS = [
    "cli",
    "cluster",
    "apps",
    "gym",
    "planning",
    "sim",
    "connector",
    "endpoint",
    "protocol",
    "messages",
]
ALLOWED: dict[str, set[str]] = {
    "cli": set(LAYERS),
    # Ray runs beside apps and gym and drives them (only it and cli know Ray exists).
    "cluster": {"cluster", "gym", "planning", "sim", "connector", "messages"},
    "apps": {"apps", "planning", "sim", "connector", "endpoint", "protocol", "messages"},
    # Learning envs sit beside apps: scenes from sim (apps' scene files by path only), the
    # connector for the policy node on the ROS side.
    "gym": {"gym", "planning", "sim", "connector", "messages"},
    "planning": {"planning", "sim", "messages"},
    "sim": {"sim", "connector", "protocol", "messages"},
    "connector": {"connector", "protocol", "messages"},
    "endpoint": {"endpoint", "protocol", "messages"},
    "protocol": {"protocol"},
    "messages": {"messages"},
}
ANYWHERE = {"errors", "assets", "tcp", "__init__"}

PACKAGES = sorted(
    name for _, name, is_pkg in pkgutil.walk_packages([str(SRC)], prefix="simbridge.") if is_pkg
)


@pytest.mark.parametrize("package", ["simbridge", *PACKAGES])
def test_public_api_imports(package: str) -> None:
    module = importlib.import_module(package)
    exported = getattr(module, "__all__", None)
    assert exported, f"{package} has no __all__"
    missing = [name for name in exported if not hasattr(module, name)]
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
