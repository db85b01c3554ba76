"""The package's star-import matches its __all__."""

from __future__ import annotations

import simbridge.messages as package


def test_star_import_exports_exactly_all() -> None:
    namespace: dict[str, object] = {}
    exec("from simbridge.messages import *", namespace)
    exported = {name for name in namespace if name != "__builtins__"}
    assert exported == set(package.__all__)
    assert all(getattr(package, name) is namespace[name] for name in package.__all__)
    assert {"MessageRegistry", "default_registry", "show", "md5", "ServiceInfo"} <= exported


def test_default_registry_is_shared() -> None:
    assert package.default_registry() is package.default_registry()
