"""simbridge.lazy: package faces that import a name's module at its first use."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest


@pytest.fixture
def package(tmp_path: Path) -> Iterator[str]:
    """A package `lazypkg` whose face exports `Thing` (from `things`) and `Alias` (`other`
    of `things`), and whose module `loud` would fail to import."""
    root = tmp_path / "lazypkg"
    root.mkdir()
    (root / "__init__.py").write_text(
        "from simbridge.lazy import lazy_face\n"
        "__all__ = ['Alias', 'Loud', 'Thing']\n"
        "__getattr__, __dir__ = lazy_face(\n"
        "    __name__, {'Thing': 'things', 'Alias': 'things:other', 'Loud': 'loud'}\n"
        ")\n"
    )
    (root / "things.py").write_text("class Thing: ...\nother = 42\n")
    (root / "loud.py").write_text("raise ImportError('loud was imported')\n")
    sys.path.insert(0, str(tmp_path))
    try:
        yield "lazypkg"
    finally:
        sys.path.remove(str(tmp_path))
        for name in [n for n in sys.modules if n == "lazypkg" or n.startswith("lazypkg.")]:
            del sys.modules[name]


def test_a_name_loads_its_module_at_first_use_and_no_sibling(package: str) -> None:
    face = importlib.import_module(package)
    assert f"{package}.things" not in sys.modules
    thing = face.Thing
    assert thing is sys.modules[f"{package}.things"].Thing
    assert vars(face)["Thing"] is thing  # kept: later uses are plain attribute reads
    assert face.Alias == 42  # 'module:attribute' where the module names it otherwise
    assert f"{package}.loud" not in sys.modules
    with pytest.raises(ImportError, match="loud was imported"):
        _ = face.Loud


def test_an_unknown_name_is_an_attribute_error_naming_the_package(package: str) -> None:
    face = importlib.import_module(package)
    with pytest.raises(AttributeError, match="module 'lazypkg' has no attribute 'Nothing'"):
        _ = face.Nothing
    assert {"Alias", "Loud", "Thing"} <= set(dir(face))


def test_the_apps_face_gives_the_runner_main_under_its_exported_name() -> None:
    import simbridge.apps
    from simbridge.apps.pick_and_place import runner

    assert simbridge.apps.pick_and_place_main is runner.main
