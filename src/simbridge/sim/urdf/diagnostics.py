"""How the importer reports what it replaced or ignored: `UrdfWarning`s naming the file."""

from __future__ import annotations

__all__ = ["UrdfWarning"]


class UrdfWarning(UserWarning):
    """Something in a URDF was replaced or ignored; the text names the file and element.

    The command line prints these as `simbridge: warning: ...`.
    """
