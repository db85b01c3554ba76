"""Who is what: labelled instances (an object, a robot, a group of bodies, a distractor),
their classes, and the lookup from MuJoCo geom to instance and class.

Shared by datasets (`simbridge.perception`) and live cameras (`labelers:` on a `camera`
sensor), so both give a scene's parts the same ids. Instance ids are 1, 2, ... in a fixed
order (scene objects, robots, `labels:` entries, distractor slots), the same in every
frame; class ids are 1, 2, ... in the order of `classes:` or of first use. 0 is "nothing
labelled" in both.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np
from numpy.typing import NDArray

from simbridge.errors import PerceptionError

__all__ = ["BodyRule", "Instance", "LabelTable", "LabelledObject", "LabelledParts", "LabelledRobot"]


class LabelledObject(Protocol):
    """A scene object as labels see it (`ObjectSpec` fits)."""

    @property
    def name(self) -> str: ...

    @property
    def label(self) -> str | None: ...


class LabelledRobot(Protocol):
    """A scene robot as labels see it (`RobotSpec` fits)."""

    @property
    def name(self) -> str | None: ...

    @property
    def label(self) -> str | None: ...


class LabelledParts(Protocol):
    """A scene's objects and robots, whose `label:` keys make instances (`Scene` fits)."""

    @property
    def objects(self) -> Sequence[LabelledObject]: ...

    @property
    def robots(self) -> Sequence[LabelledRobot]: ...


@dataclass(frozen=True)
class BodyRule:
    """A `labels:` entry: the bodies matching `bodies` (glob patterns) are one instance."""

    name: str
    category: str
    bodies: tuple[str, ...]


@dataclass(frozen=True)
class Instance:
    """One labelled thing: stable id, name, class, its bodies and geoms."""

    id: int
    name: str
    category: str
    category_id: int
    kind: str
    """"object", "robot", "bodies" (a `labels:` entry) or "distractor"."""
    bodies: tuple[int, ...]
    geoms: tuple[int, ...]

    @property
    def root_body(self) -> int:
        """The body whose frame is the instance's pose (its first body)."""
        return self.bodies[0]


class LabelTable:
    """Instances and classes of a compiled scene, and per-geom lookups for label images."""

    def __init__(
        self, model: mujoco.MjModel, instances: Sequence[Instance], categories: Sequence[str]
    ) -> None:
        self.instances = tuple(instances)
        self.categories = tuple(categories)
        self.by_name = {i.name: i for i in self.instances}
        # Index geom id + 1 (segmentation's -1 is "no geom") -> instance id / class id.
        self.geom_instance = np.zeros(model.ngeom + 1, dtype=np.uint16)
        self.geom_category = np.zeros(model.ngeom + 1, dtype=np.uint16)
        for inst in self.instances:
            for geom in inst.geoms:
                self.geom_instance[geom + 1] = inst.id
                self.geom_category[geom + 1] = inst.category_id

    @classmethod
    def build(
        cls,
        model: mujoco.MjModel,
        scene: LabelledParts,
        *,
        robot_bodies: Mapping[str, Sequence[int]],
        rules: Sequence[BodyRule],
        distractors: Sequence[tuple[str, str, int]],
        classes: Sequence[str] = (),
    ) -> LabelTable:
        """Instances from the scene's `label:` keys, `rules` and distractor slots
        (name, class, body id); `classes` fixes the order of class ids."""
        names = [model.body(b).name for b in range(model.nbody)]
        claimed: dict[int, str] = {}
        groups: list[tuple[str, str, str, list[int]]] = []  # name, class, kind, bodies
        for rule in rules:
            matched = [
                b
                for b, n in enumerate(names)
                if any(fnmatch.fnmatchcase(n, p) for p in rule.bodies)
            ]
            if not matched:
                raise PerceptionError(
                    f"perception labels '{rule.name}': no body matches {list(rule.bodies)} "
                    f"(bodies: {', '.join(names[1:])})"
                )
            for body in matched:
                if body in claimed:
                    raise PerceptionError(
                        f"perception labels '{rule.name}': body '{names[body]}' is already "
                        f"labelled by '{claimed[body]}'"
                    )
                claimed[body] = rule.name
            groups.append((rule.name, rule.category, "bodies", matched))
        ordered: list[tuple[str, str, str, list[int]]] = []
        for obj in scene.objects:
            if obj.label is not None:
                ordered.append((obj.name, obj.label, "object", [model.body(obj.name).id]))
        for robot in scene.robots:
            if robot.label is None:
                continue
            name = robot.name or ""
            bodies = [b for b in robot_bodies.get(name, ()) if b not in claimed]
            ordered.append((name, robot.label, "robot", sorted(bodies)))
        ordered += groups
        ordered += [(name, category, "distractor", [body]) for name, category, body in distractors]
        taken = [name for name, _, _, _ in ordered]
        for i, name in enumerate(taken):
            if name in taken[:i]:
                raise PerceptionError(f"perception: two labelled instances are called '{name}'")
        categories = list(classes)
        for _, category, _, _ in ordered:
            if category not in categories:
                categories.append(category)
        geom_body = model.geom_bodyid
        instances = []
        for index, (name, category, kind, bodies) in enumerate(ordered, start=1):
            body_set = set(bodies)
            geoms = tuple(int(g) for g in range(model.ngeom) if int(geom_body[g]) in body_set)
            instances.append(
                Instance(
                    index,
                    name,
                    category,
                    categories.index(category) + 1,
                    kind,
                    tuple(bodies),
                    geoms,
                )
            )
        return cls(model, instances, categories)

    def instance_image(self, segmentation: NDArray[np.int32]) -> NDArray[np.uint16]:
        """Instance id per pixel from a MuJoCo segmentation image (object id, type)."""
        return self.geom_instance[_geom_index(segmentation)]

    def category_image(self, segmentation: NDArray[np.int32]) -> NDArray[np.uint16]:
        """Class id per pixel from a MuJoCo segmentation image (object id, type)."""
        return self.geom_category[_geom_index(segmentation)]


_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)  # an int: comparing arrays with the enum is slow


def _geom_index(segmentation: NDArray[np.int32]) -> NDArray[np.intp]:
    """Geom id + 1 per pixel (0 where no geom was drawn)."""
    ids = segmentation[..., 0].astype(np.intp) + 1
    ids[segmentation[..., 1] != _GEOM] = 0
    return ids
