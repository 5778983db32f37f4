"""Exceptions raised by multimorph. Every message names the offending field or file."""

from __future__ import annotations

__all__ = [
    "DataFileError",
    "FitError",
    "LockupError",
    "MultimorphError",
    "OutsideSupportError",
    "SpecError",
    "UnknownMaterialError",
]


class MultimorphError(Exception):
    """Base class: any error multimorph raises on purpose (CLI exits non-zero with its text)."""


class SpecError(MultimorphError, ValueError):
    """A specification (TOML, value object) is invalid; the message names the field."""


class DataFileError(MultimorphError, ValueError):
    """A test-data file cannot be read; the message names the file, the line and the problem."""

    def __init__(self, path: object, problem: str, line: int | None = None) -> None:
        where = f"{path}" if line is None else f"{path}, line {line}"
        super().__init__(f"{where}: {problem}")
        self.path = path
        self.line = line
        self.problem = problem


class LockupError(MultimorphError, ValueError):
    """A limiting-chain material (Gent) was evaluated at or beyond its lock-up stretch."""


class UnknownMaterialError(SpecError, KeyError):
    """A material name is not in the library."""

    def __str__(self) -> str:  # KeyError would add quotes
        return str(self.args[0])


class OutsideSupportError(MultimorphError):
    """A cell outside the calibrated model's support where no fallback was asked for: the
    model gives no prediction (not a cell that fails to activate)."""


class FitError(MultimorphError, RuntimeError):
    """A material fit could not be set up (bad data, unknown model)."""
