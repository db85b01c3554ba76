"""Headless OpenGL backend choice: MUJOCO_GL if set, else EGL on a GPU, else OSMesa."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from functools import cache
from typing import Protocol

from simbridge.errors import SimError

__all__ = [
    "GLContext",
    "configure_gl",
    "create_gl_context",
    "is_software_renderer",
    "probe_egl",
]

_BACKENDS = ("egl", "osmesa", "glfw")

_EGL_PROBE = """
from mujoco.egl import GLContext
from OpenGL import GL
context = GLContext(8, 8)
context.make_current()
print(GL.glGetString(GL.GL_RENDERER).decode())
context.free()
"""

_SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast", "swiftshader", "software")


class GLContext(Protocol):
    """What MuJoCo's GL context classes (mujoco.egl / osmesa / glfw) offer."""

    def make_current(self) -> None: ...

    def free(self) -> None: ...


def is_software_renderer(renderer: str) -> bool:
    """Whether a GL_RENDERER string names a CPU rasteriser (Mesa llvmpipe and the like)."""
    lowered = renderer.lower()
    return any(name in lowered for name in _SOFTWARE_RENDERERS)


def probe_egl(timeout_s: float = 30.0) -> str | None:
    """The GL_RENDERER of an EGL context, or None when none can be made (tried in a child
    process, so a broken driver cannot take this process down or pin PyOpenGL to EGL)."""
    env = dict(os.environ, MUJOCO_GL="egl", PYOPENGL_PLATFORM="egl")
    try:
        done = subprocess.run(
            [sys.executable, "-c", _EGL_PROBE],
            env=env,
            capture_output=True,
            timeout=timeout_s,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired):
        return None
    lines = done.stdout.decode(errors="replace").strip().splitlines()
    return lines[-1] if done.returncode == 0 and lines else None


@cache
def configure_gl() -> str:
    """Choose the offscreen backend once per process and export it.

    MUJOCO_GL wins when set; otherwise an explicit PYOPENGL_PLATFORM decides; otherwise
    EGL if it reaches a GPU, else OSMesa (Mesa's EGL on a CPU is no faster than OSMesa).
    The choice is written back to MUJOCO_GL and PYOPENGL_PLATFORM so child processes and
    later imports agree. Call it before anything imports PyOpenGL for the choice to reach
    mujoco's own Renderer too.
    """
    requested = os.environ.get("MUJOCO_GL", "").strip().lower()
    if not requested:
        platform = os.environ.get("PYOPENGL_PLATFORM", "").strip().lower()
        if platform in ("egl", "osmesa"):
            requested = platform
        else:
            renderer = probe_egl()
            gpu = renderer is not None and not is_software_renderer(renderer)
            requested = "egl" if gpu else "osmesa"
    if requested not in _BACKENDS:
        raise SimError(f"MUJOCO_GL={requested!r} is not usable headless; choose one of {_BACKENDS}")
    platform = os.environ.get("PYOPENGL_PLATFORM", "").strip().lower()
    if requested in ("egl", "osmesa") and platform and platform != requested:
        raise SimError(
            f"MUJOCO_GL={requested!r} but PYOPENGL_PLATFORM={platform!r}: they must agree;"
            f" unset PYOPENGL_PLATFORM or set it to {requested!r}"
        )
    os.environ["MUJOCO_GL"] = requested
    if requested in ("egl", "osmesa"):
        os.environ.setdefault("PYOPENGL_PLATFORM", requested)
    return requested


def create_gl_context(width: int, height: int) -> GLContext:
    """A current-able offscreen GL context of at least width x height on the chosen backend."""
    backend = configure_gl()
    try:
        module = importlib.import_module(f"mujoco.{backend}")
        context: GLContext = module.GLContext(width, height)
    except (ImportError, RuntimeError, OSError) as exc:
        raise SimError(f"cannot create a {backend} OpenGL context for rendering: {exc}") from exc
    return context
