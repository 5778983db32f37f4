"""Shared CLI plumbing: JSON vs human output, errors as one line and a non-zero exit."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import typer
from rich.console import Console
from rich.markup import escape

from multimorph.errors import MultimorphError
from multimorph.io import to_jsonable

__all__ = ["EXIT_ERROR", "OUT_ROOT", "check_tables", "console", "default_out", "emit_json",
           "err_console", "fail", "handle_errors", "in_file", "pressure_option", "warn"]

EXIT_ERROR = 2
#: Where a command writes when no --out is given: ``OUT_ROOT/<command>-<spec stem>``.
OUT_ROOT = "multimorph-out"

console = Console()
err_console = Console(stderr=True)

F = TypeVar("F", bound=Callable[..., Any])


def default_out(command: str, spec: Any, suffix: str = "") -> Path:
    """The output folder of ``command`` run on the file ``spec`` without ``--out``:
    ``multimorph-out/<command>-<spec stem><suffix>`` (one scheme for every command)."""
    return Path(OUT_ROOT) / f"{command}-{Path(spec).stem}{suffix}"


def emit_json(data: Any) -> None:
    """Print ``data`` as JSON on stdout (SI units, NaN/inf as null)."""
    sys.stdout.write(json.dumps(to_jsonable(data), indent=2) + "\n")
    sys.stdout.flush()


def warn(message: str) -> None:
    """Print a warning on one line of stderr (the run goes on)."""
    message = " ".join(str(message).split())
    err_console.print(f"[yellow]warning:[/] {escape(message)}", highlight=False, soft_wrap=True)


def pressure_option(value: str, option: str, *, mu: float | None = None) -> float:
    """A pressure option (``"60 kPa"``; bare numbers in Pa) in Pa: positive, finite and, with
    ``mu``, at most :data:`multimorph.limits.MAX_PRESSURE_RATIO` μ (SpecError naming it)."""
    import math

    from multimorph.errors import SpecError
    from multimorph.limits import check_pressure_scale
    from multimorph.units import to_si

    p = to_si(value, "Pa", field=option)
    if not (math.isfinite(p) and p > 0):
        raise SpecError(f"{option}: must be a positive, finite pressure, got {value!r}")
    if mu is not None:
        check_pressure_scale(p, mu, option)
    return p


@contextmanager
def in_file(path: object) -> Iterator[None]:
    """Prefix a :class:`~multimorph.errors.SpecError` raised while parsing a spec with the
    spec file's name (``gripper.toml: module 'fingers'.cells: ...``)."""
    from multimorph.errors import SpecError

    try:
        yield
    except SpecError as exc:
        text = str(exc)
        if text.startswith(str(path)):
            raise
        try:
            new = type(exc)(f"{path}: {text}")
        except TypeError:
            new = SpecError(f"{path}: {text}")
        raise new from None


def check_tables(table: dict[str, Any], allowed: tuple[str, ...], spec: object) -> None:
    """Refuse top-level tables of a spec file other than ``allowed`` (SpecError naming them)."""
    from multimorph.errors import SpecError

    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise SpecError(f"{spec}: unknown table(s) {', '.join(f'[{k}]' for k in unknown)}; "
                        f"expected {', '.join(f'[{k}]' for k in allowed)}")


def fail(message: str, *, as_json: bool = False) -> None:
    """Report an error on one line (and as JSON ``{"error": ...}`` with --json); exit 2."""
    message = " ".join(str(message).split())
    if as_json:
        emit_json({"error": message})
    # the message is plain text: "[cell]" must not be read as rich markup
    err_console.print(f"[bold red]error:[/] {escape(message)}", highlight=False,
                      soft_wrap=True)
    raise typer.Exit(EXIT_ERROR)


@contextmanager
def _notices() -> Iterator[None]:
    """Print the library's notices (logger ``multimorph.compile``: the model is being
    compiled) on stderr, one line each, while a command runs."""
    import logging

    class Notice(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            err_console.print(record.getMessage(), highlight=False, markup=False,
                              soft_wrap=True)

    logger = logging.getLogger("multimorph.compile")
    handler, level = Notice(logging.INFO), logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


#: Distinct calibrated-model warnings a command prints before it only counts them.
MAX_WARNINGS = 3


@contextmanager
def handle_errors(as_json: bool = False) -> Iterator[None]:
    """Turn :class:`MultimorphError` (and file errors) into :func:`fail`; a cell outside the
    calibrated model's support (``CalibrationWarning``) is told once per message on stderr,
    as a one-line warning (the JSON says it too: ``calibration.inside``)."""
    import warnings

    told: set[str] = set()

    def tell(message: Any, category: Any, *args: Any, **kwargs: Any) -> None:
        if category.__name__ != "CalibrationWarning":
            shown(message, category, *args, **kwargs)
            return
        text = str(message)
        if text not in told:
            told.add(text)
            if len(told) <= MAX_WARNINGS:
                err_console.print(f"[yellow]warning:[/] {text}", highlight=False,
                                  soft_wrap=True)

    shown = warnings.showwarning
    try:
        with warnings.catch_warnings(), _notices():
            from multimorph.calibrated import CalibrationWarning

            warnings.simplefilter("always", CalibrationWarning)
            warnings.showwarning = tell
            try:
                yield
            finally:
                if len(told) > MAX_WARNINGS:
                    err_console.print(
                        f"[yellow]warning:[/] … and {len(told) - MAX_WARNINGS} more cells "
                        "outside the calibrated model's support (see above)",
                        highlight=False, soft_wrap=True)
    except MultimorphError as exc:
        fail(str(exc), as_json=as_json)
    except OSError as exc:  # a file or folder the run could not read or write
        where = f"{exc.filename}: " if exc.filename else ""
        fail(f"{where}{exc.strerror or exc}", as_json=as_json)
