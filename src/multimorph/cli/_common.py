"""Shared CLI plumbing: JSON vs human output, errors as one line and a non-zero exit."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TypeVar

import typer
from rich.console import Console
from rich.markup import escape

from multimorph.errors import MultimorphError
from multimorph.io import to_jsonable

__all__ = ["EXIT_ERROR", "console", "emit_json", "err_console", "fail", "handle_errors"]

EXIT_ERROR = 2

console = Console()
err_console = Console(stderr=True)

F = TypeVar("F", bound=Callable[..., Any])


def emit_json(data: Any) -> None:
    """Print ``data`` as JSON on stdout (SI units, NaN/inf as null)."""
    sys.stdout.write(json.dumps(to_jsonable(data), indent=2) + "\n")
    sys.stdout.flush()


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
def handle_errors(as_json: bool = False) -> Iterator[None]:
    """Turn :class:`MultimorphError` (and file errors) into :func:`fail`."""
    try:
        yield
    except MultimorphError as exc:
        fail(str(exc), as_json=as_json)
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        fail(f"{exc.filename}: {exc.strerror}", as_json=as_json)
