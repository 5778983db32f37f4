"""The typer application; each command module registers itself here (one line each)."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import Annotated

import typer
from rich.markup import escape

from multimorph.cli._help import PlainHelpGroup

app = typer.Typer(
    cls=PlainHelpGroup,
    name="multimorph",
    help="Design sequentially multimodal, single-input soft pneumatic actuators (pneu-nets).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def version_line() -> str:
    """``multimorph <version>``, and the code version (commit) when it says more."""
    from multimorph import __version__
    from multimorph._provenance import code_version

    code = code_version()
    return f"multimorph {__version__}" + (f" (code {code})" if code != __version__ else "")


def _show_version(value: bool) -> None:
    if value:
        sys.stdout.write(version_line() + "\n")
        raise typer.Exit(0)


@app.callback()
def _options(
    version: Annotated[bool, typer.Option(
        "--version", is_eager=True, callback=_show_version,
        help="Print the version (and the code's commit in a git checkout) and exit.")] = False,
) -> None:
    """Design sequentially multimodal, single-input soft pneumatic actuators (pneu-nets)."""


def _register() -> None:
    # one line per command module; each module defines ``register(app)``; once per process
    if app.registered_commands:
        return
    from multimorph.cli._cell import register as cell
    from multimorph.cli._demo import register as demo
    from multimorph.cli._design import register as design
    from multimorph.cli._fem import register as fem
    from multimorph.cli._material import register as material
    from multimorph.cli._plot import register as plot
    from multimorph.cli._simulate import register as simulate
    from multimorph.cli._sweep import register as sweep

    for register in (material, demo, sweep, plot, simulate, fem, design, cell):
        register(app)


def run(argv: Sequence[str] | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); return the exit status.

    A malformed command line (unknown option, a value of the wrong type, out of range) is
    reported on one line naming the option, like every other bad input, with exit status 2
    (click's usage-error status).
    """
    from multimorph.cli._common import EXIT_ERROR, err_console

    _register()
    try:
        code = app(args=list(sys.argv[1:] if argv is None else argv), standalone_mode=False,
                   prog_name="multimorph")
    except typer.TyperException as exc:  # typer's click: usage errors, bad option values
        ctx = getattr(exc, "ctx", None)
        if type(exc).__name__ == "NoArgsIsHelpError":
            sys.stderr.write(exc.format_message() + "\n")
            return EXIT_ERROR
        message = " ".join(exc.format_message().split())
        hint = (f" (see {ctx.command_path} --help)"
                if ctx is not None and getattr(ctx, "command_path", "") else "")
        err_console.print(f"[bold red]error:[/] {escape(message)}{hint}", highlight=False,
                          soft_wrap=True)
        return int(getattr(exc, "exit_code", EXIT_ERROR))
    except typer.Abort:
        err_console.print("aborted", highlight=False)
        return 1
    return code if isinstance(code, int) else 0


def main() -> None:
    """Console-script entry point."""
    sys.exit(run())
