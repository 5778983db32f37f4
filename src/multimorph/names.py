"""One vocabulary for kinds: the name every command prints, and the aliases it accepts.

A module (and a sweep's cell, and a design target's stage) is of one of three kinds,
printed as :data:`KINDS` (``bending``, ``stretching``, ``twisting``). Its motion's short
name (``bend``, ``stretch``, ``twist``) is accepted on input as an alias, and a design
target's stage keeps it in its JSON (``"kind": "bend"``, a contract), printed by its kind.

Material laws are named with their order where they have one (``ogden-3``,
``reduced-polynomial-6``); the bare family (``ogden``) is accepted on input
(:func:`multimorph.materials.get_law`).
"""

from __future__ import annotations

__all__ = ["KINDS", "MOTION_OF_KIND", "kind_name", "motion_name"]

#: The kinds, as printed.
KINDS = ("bending", "stretching", "twisting")
#: Each kind's motion: a design target stage's ``kind`` in its JSON.
MOTION_OF_KIND = {"bending": "bend", "stretching": "stretch", "twisting": "twist"}
_KIND_OF_MOTION = {motion: kind for kind, motion in MOTION_OF_KIND.items()}


def kind_name(name: str) -> str:
    """The printed kind of ``name`` (a kind or its motion's alias); other names are
    returned as given, for the caller's check to refuse."""
    return _KIND_OF_MOTION.get(name, name)


def motion_name(name: str) -> str:
    """The motion of ``name`` (a kind or a motion): ``bending`` and ``bend`` give
    ``bend``; other names are returned as given."""
    return MOTION_OF_KIND.get(name, name)
