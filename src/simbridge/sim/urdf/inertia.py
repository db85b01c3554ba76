"""Check URDF inertials and compute replacements from collision geometry."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from simbridge.sim.urdf.meshes import MeshCache
from simbridge.sim.urdf.robot import Box, Collision, Cylinder, Inertial, Link, Mesh, Origin, Sphere

__all__ = ["InertiaPolicy", "inertial_from_collisions", "inertial_problem", "resolve_inertial"]

Matrix = NDArray[np.float64]
MIN_INERTIA = 1e-12
"""Principal moments (kg m^2) at or below this count as zero (e.g. iCub's 1e-20 values)."""


@dataclass(frozen=True)
class InertiaPolicy:
    """How to replace unusable inertials: density of collision volumes, fallback point mass."""

    density: float = 1000.0
    fallback_mass: float = 0.01
    fallback_inertia: float = 1e-5


def inertial_problem(inertial: Inertial) -> str | None:
    """Why `inertial` cannot be simulated (None if it can)."""
    values = [inertial.mass, *inertial.tensor.ravel(), *inertial.origin.xyz, *inertial.origin.rpy]
    if any(math.isnan(v) for v in values):
        return "has NaN values"
    if inertial.mass <= 0.0:
        return f"has mass {inertial.mass} (must be positive)"
    eigen = np.linalg.eigvalsh(inertial.tensor)
    if float(eigen.min()) <= MIN_INERTIA:
        return (
            "has an inertia tensor that is not positive definite "
            f"(eigenvalues {' '.join(f'{e:.3g}' for e in eigen)}; MuJoCo needs > {MIN_INERTIA:g})"
        )
    return None


def _primitive(
    collision: Collision, density: float, meshes: MeshCache
) -> tuple[float, Matrix, Matrix]:
    """Mass, centre of mass and inertia about it, all in the collision origin's frame."""
    geom = collision.geometry
    zero = np.zeros(3)
    if isinstance(geom, Box):
        x, y, z = geom.size
        mass = density * x * y * z
        diag = mass / 12.0 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])
        return mass, zero, np.diag(diag)
    if isinstance(geom, Cylinder):
        r, h = geom.radius, geom.length
        mass = density * math.pi * r * r * h
        side = mass * (3 * r * r + h * h) / 12.0
        return mass, zero, np.diag([side, side, mass * r * r / 2.0])
    if isinstance(geom, Sphere):
        mass = density * 4.0 / 3.0 * math.pi * geom.radius**3
        return mass, zero, np.eye(3) * (0.4 * mass * geom.radius**2)
    assert isinstance(geom, Mesh)
    if geom.path is None:
        return 0.0, zero, np.zeros((3, 3))
    flat = meshes.flat_box(geom.path, geom.scale)
    if flat is not None:  # collides as a thin box, so weighs as one
        centre, size = flat
        mass, _, inertia = _primitive(Collision(Box(size)), density, meshes)
        return mass, np.array(centre), inertia
    mesh = meshes.load(geom.path, geom.scale)
    if not mesh.is_volume:
        mesh = mesh.convex_hull
    mesh.density = density
    return float(mesh.mass), np.asarray(mesh.center_mass), np.asarray(mesh.moment_inertia)


def inertial_from_collisions(
    collisions: Sequence[Collision], density: float, meshes: MeshCache
) -> Inertial | None:
    """Inertial of the union of `collisions` at uniform `density` (None if they have no volume)."""
    parts = []
    for col in collisions:
        mass, com, inertia = _primitive(col, density, meshes)
        if mass > 0:
            tf = col.origin.transform
            parts.append((mass, tf.apply(com), tf.rotation @ inertia @ tf.rotation.T))
    total = sum(p[0] for p in parts)
    if total <= 0:
        return None
    com = np.sum([p[0] * p[1] for p in parts], axis=0) / total
    tensor = np.zeros((3, 3))
    for mass, c, inertia in parts:
        d = c - com
        tensor += inertia + mass * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return Inertial(
        total,
        Origin((float(com[0]), float(com[1]), float(com[2]))),
        float(tensor[0, 0]),
        float(tensor[0, 1]),
        float(tensor[0, 2]),
        float(tensor[1, 1]),
        float(tensor[1, 2]),
        float(tensor[2, 2]),
    )


def resolve_inertial(
    link: Link, moving: bool, policy: InertiaPolicy, meshes: MeshCache
) -> tuple[Inertial | None, str | None]:
    """The inertial to simulate `link` with, and a warning when the URDF's was replaced.

    A link without `<inertial>` that does not move on its own (fixed joint or root) stays
    massless, as URDF allows; anything else unusable is computed from collision geometry,
    or falls back to a small point mass when the link has no collision volume.
    """
    if link.inertial is not None:
        problem = inertial_problem(link.inertial)
        if problem is None:
            return link.inertial, None
        reason = f"inertial {problem}"
    elif not moving:
        return None, None
    else:
        reason = "has no <inertial> but moves"
    computed = inertial_from_collisions(link.collisions, policy.density, meshes)
    if computed is not None:
        return computed, (
            f"link '{link.name}': {reason}; using mass {computed.mass:.6g} kg and inertia "
            f"computed from its collision geometry at density {policy.density:g} kg/m^3"
        )
    if not moving:
        return None, f"link '{link.name}': {reason} and it has no collision volume; left massless"
    fallback = Inertial(
        policy.fallback_mass,
        Origin(),
        policy.fallback_inertia,
        0.0,
        0.0,
        policy.fallback_inertia,
        0.0,
        policy.fallback_inertia,
    )
    return fallback, (
        f"link '{link.name}': {reason} and it has no collision volume; using a "
        f"{policy.fallback_mass:g} kg point mass"
    )
