"""The typer application; each command module registers itself here (one line each)."""

from __future__ import annotations

import typer

app = typer.Typer(
    name="multimorph",
    help="Design sequentially multimodal, single-input soft pneumatic actuators (pneu-nets).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _register() -> None:
    # one line per command module; each module defines ``register(app)``
    from multimorph.cli import _material

    _material.register(app)
    from multimorph.cli import _demo

    _demo.register(app)
    from multimorph.cli import _sweep

    _sweep.register(app)
    from multimorph.cli import _plot

    _plot.register(app)
    from multimorph.cli import _simulate

    _simulate.register(app)
    from multimorph.cli import _fem; _fem.register(app)  # noqa: E702, I001
    from multimorph.cli import _design; _design.register(app)  # noqa: E702, I001
    from multimorph.cli import _cell; _cell.register(app)  # noqa: E702, I001


def main() -> None:
    """Console-script entry point."""
    _register()
    app()
