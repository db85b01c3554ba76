"""Print simbridge's import graph inside one package and the circles in it.

Every import counts: those under `if TYPE_CHECKING:` and inside functions too, since a
reader has to follow a type-hint import as much as any other. Imports are read from the
source (nothing is imported), and an import of a name resolves to the module that holds it
(`from simbridge.sim.world import World` is an import of the package face `sim.world`).

Usage: python scripts/import_graph.py [PACKAGE] [--packages] [--src DIR]

  PACKAGE     dotted name below simbridge (`sim`, `endpoint`, `sim.ros`); the whole of
              simbridge when left out. Lines name modules relative to it, `(face)` being
              its own `__init__`.
  --packages  one line per subpackage (and per module directly inside PACKAGE) instead of
              one per module: what each part imports of the others.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections.abc import Iterable
from pathlib import Path

DEFAULT_SRC = Path(__file__).resolve().parent.parent / "src" / "simbridge"


def module_names(src: Path) -> dict[str, Path]:
    """Every module below `src` by dotted name relative to it (a package by its own name)."""
    names: dict[str, Path] = {}
    for path in sorted(src.rglob("*.py")):
        parts = list(path.relative_to(src).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        if parts:
            names[".".join(parts)] = path
    return names


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The module that `name` lies in: itself, or the deepest module above it."""
    while name and name not in modules:
        name = name.rpartition(".")[0]
    return name or None


def module_imports(name: str, modules: dict[str, Path], root: str = "simbridge") -> set[str]:
    """The modules of `root` that module `name` imports anywhere in its source."""
    path = modules[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = f"{root}.{package}" if package else root
                for _ in range(node.level - 1):
                    anchor = anchor.rpartition(".")[0]
                base = f"{anchor}.{base}" if base else anchor
            targets = [base, *(f"{base}.{alias.name}" for alias in node.names)]
        for target in targets:
            if target.startswith(root + "."):
                resolved = _resolve(target.removeprefix(root + "."), modules)
                if resolved is not None and resolved != name:
                    found.add(resolved)
    return found


def within(name: str, package: str) -> bool:
    """Whether module `name` is `package` or lies below it (everything lies below "")."""
    return not package or name == package or name.startswith(package + ".")


def graph(modules: dict[str, Path], package: str = "") -> dict[str, set[str]]:
    """Each module of `package` and the modules of `package` it imports."""
    return {
        name: {target for target in module_imports(name, modules) if within(target, package)}
        for name in modules
        if within(name, package)
    }


def part_of(name: str, package: str) -> str:
    """The part of `package` that module `name` belongs to: the subpackage or module
    directly inside it, or the package itself for its face."""
    rest = name.removeprefix(package).removeprefix(".") if package else name
    if not rest:
        return package
    head = rest.split(".")[0]
    return f"{package}.{head}" if package else head


def collapse(edges: dict[str, set[str]], package: str) -> dict[str, set[str]]:
    """The graph between the parts of `package` (a part's imports of itself dropped)."""
    parts: dict[str, set[str]] = {}
    for name, targets in edges.items():
        part = part_of(name, package)
        mine = parts.setdefault(part, set())
        mine.update(part_of(target, package) for target in targets)
        mine.discard(part)
    return parts


def circles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one node (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in sorted(edges.get(node, ())):
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                group.append(member)
                if member == node:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 4 * len(edges) + 100))
    for node in sorted(edges):
        if node not in index:
            visit(node)
    return sorted(found)


def report(edges: dict[str, set[str]], package: str) -> Iterable[str]:
    """The lines printed: one per node with its imports, then the circles."""

    def short(name: str) -> str:
        rest = name.removeprefix(package).removeprefix(".") if package else name
        return rest or "(face)"

    for name in sorted(edges, key=lambda n: (short(n) != "(face)", short(n))):
        targets = ", ".join(sorted(short(t) for t in edges[name])) or "-"
        yield f"{short(name)} -> {targets}"
    found = circles(edges)
    yield ""
    yield f"circles ({len(found)}):"
    for group in found:
        yield "  " + " <-> ".join(short(member) for member in group)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("package", nargs="?", default="", help="e.g. sim, endpoint, sim.ros")
    parser.add_argument("--packages", action="store_true", help="one line per part")
    parser.add_argument("--src", type=Path, default=DEFAULT_SRC, help="the simbridge folder")
    args = parser.parse_args(argv)
    modules = module_names(args.src)
    if args.package and args.package not in modules:
        parser.error(f"no package {args.package!r} in {args.src}")
    edges = graph(modules, args.package)
    if args.packages:
        edges = collapse(edges, args.package)
    for line in report(edges, args.package):
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
