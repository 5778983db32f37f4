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


def main() -> None:
    """Console-script entry point."""
    _register()
    app()
