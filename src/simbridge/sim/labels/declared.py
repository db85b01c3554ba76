"""What a scene declares about labels, read without the rest of its `perception:` section:
the `labels:` entries (bodies grouped into one instance) and the `classes:` order.

Both the dataset generator (`simbridge.perception`) and the live cameras (a `camera`
sensor with `labelers:`) read them here, so a scene's instance and class ids are the same
in a dataset and on the camera's topics.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import mujoco

from simbridge.errors import PerceptionError
from simbridge.sim.labels.table import BodyRule, LabelledParts, LabelTable
from simbridge.sim.scene.located import LineList, LineMap, Where

__all__ = [
    "DeclaredLabels",
    "LabelledScene",
    "declared_labels",
    "parse_label_rules",
    "scene_label_table",
]


class LabelledScene(LabelledParts, Protocol):
    """A scene as labels see it (`Scene` fits): its labelled parts and raw `perception:`."""

    @property
    def perception(self) -> Mapping[str, object] | None: ...

    @property
    def source(self) -> Path | None: ...


@dataclass(frozen=True)
class DeclaredLabels:
    """The `perception:` section's `labels:` entries and `classes:` order."""

    rules: tuple[BodyRule, ...] = ()
    classes: tuple[str, ...] = ()


def _error(where: Where, message: str) -> PerceptionError:
    return PerceptionError(str(where.error(message)))


def _key(data: Mapping[str, object], where: Where, name: str) -> Where:
    line = data.key_lines.get(name) if isinstance(data, LineMap) else None
    return where.child(f".{name}", line)


def _names(value: object, where: Where, what: str) -> tuple[str, ...]:
    """A list of non-empty strings (one string is a list of one)."""
    if isinstance(value, str):
        value = [value]
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise _error(where, f"expected a list of {what}, got {value!r}")
    return tuple(value)


def parse_label_rules(value: object, where: Where) -> tuple[BodyRule, ...]:
    """`labels: [{name, class, bodies: [globs]}]`; errors name the file, line and entry."""
    if value is None:
        return ()
    if not isinstance(value, list):
        raise _error(where, f"expected a list of entries, got {value!r}")
    lines = value.item_lines if isinstance(value, LineList) else [None] * len(value)
    rules = []
    for i, (entry, line) in enumerate(zip(value, lines, strict=True)):
        at = where.child(f"[{i}]", line)
        if not isinstance(entry, Mapping):
            raise _error(at, f"expected a mapping of keys, got {entry!r}")
        known = ("name", "class", "bodies")
        for key in entry:
            if key not in known:
                raise _error(
                    _key(entry, at, str(key)),
                    f"unknown key '{key}' (valid: {', '.join(known)})",
                )
        name = entry.get("name")
        if not name:
            raise _error(at, "missing key 'name' (the instance's name)")
        if not isinstance(name, str):
            raise _error(_key(entry, at, "name"), f"expected a non-empty string, got {name!r}")
        category = entry.get("class", name)
        if not isinstance(category, str) or not category:
            raise _error(_key(entry, at, "class"), f"expected a non-empty string, got {category!r}")
        if not entry.get("bodies"):
            raise _error(at, "missing key 'bodies' (body names or glob patterns)")
        bodies = _names(entry["bodies"], _key(entry, at, "bodies"), "names")
        rules.append(BodyRule(name, category, bodies))
    return tuple(rules)


def declared_labels(scene: LabelledScene) -> DeclaredLabels:
    """The `labels:` and `classes:` of `scene.perception` (none without the section)."""
    section = scene.perception
    if section is None:
        return DeclaredLabels()
    source = str(scene.source) if scene.source is not None else None
    where = Where("perception", source, getattr(section, "line", None))
    classes = section.get("classes")
    return DeclaredLabels(
        rules=parse_label_rules(section.get("labels"), _key(section, where, "labels")),
        classes=()
        if classes is None
        else _names(classes, _key(section, where, "classes"), "class names"),
    )


def scene_label_table(
    model: mujoco.MjModel,
    scene: LabelledScene,
    robot_bodies: Mapping[str, Sequence[int]],
) -> LabelTable:
    """The instances and classes of a scene as simulated (no distractors): the ids a
    dataset of the same scene gives its objects, robots and `labels:` entries."""
    declared = declared_labels(scene)
    return LabelTable.build(
        model,
        scene,
        robot_bodies=robot_bodies,
        rules=declared.rules,
        distractors=(),
        classes=declared.classes,
    )
