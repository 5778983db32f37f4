"""Help texts shown as written: typer renders them as rich markup, which reads ``[cell]``,
``[device]`` or ``[[module]]`` as (unknown) style tags and drops them.

Every command and command group of the CLI is built with the classes here (``cls=`` of
``app.command`` and ``typer.Typer``); they escape the square brackets of the help texts
once, when typer builds the click command, so the sources keep the plain words.
"""

from __future__ import annotations

from typing import Any

from rich.markup import escape
from typer.core import TyperCommand, TyperGroup

__all__ = ["PlainHelpCommand", "PlainHelpGroup", "plain_help"]


def plain_help(command: TyperCommand | TyperGroup) -> None:
    """Escape rich markup in the help texts of ``command`` and of its parameters, in place."""
    if command.help:
        command.help = escape(command.help)
    if command.short_help:
        command.short_help = escape(command.short_help)
    if command.epilog:
        command.epilog = escape(command.epilog)
    for param in command.params:
        text = getattr(param, "help", None)
        if text:
            param.help = escape(text)  # type: ignore[attr-defined]


class PlainHelpCommand(TyperCommand):
    """A typer command whose help texts are plain text (brackets shown, not read as markup)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        plain_help(self)


class PlainHelpGroup(TyperGroup):
    """A typer command group whose help texts are plain text."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        plain_help(self)
