"""Labels of a simulated scene: which bodies are which labelled instance, of which class,
and the per-pixel lookups from MuJoCo's segmentation to instance and class ids.

The one place datasets (`simbridge.perception`) and live cameras (`labelers:` on a
`camera` sensor) take their ids from, so both agree for the same scene.
"""

from simbridge.sim.labels.declared import (
    DeclaredLabels,
    LabelledScene,
    declared_labels,
    parse_label_rules,
    scene_label_table,
)
from simbridge.sim.labels.table import (
    BodyRule,
    Instance,
    LabelledObject,
    LabelledParts,
    LabelledRobot,
    LabelTable,
)

__all__ = [
    "BodyRule",
    "DeclaredLabels",
    "Instance",
    "LabelTable",
    "LabelledObject",
    "LabelledParts",
    "LabelledRobot",
    "LabelledScene",
    "declared_labels",
    "parse_label_rules",
    "scene_label_table",
]
