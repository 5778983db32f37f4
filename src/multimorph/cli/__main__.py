"""``python -m multimorph.cli``: the same as the ``multimorph`` command."""

from multimorph.cli._app import main

main()
