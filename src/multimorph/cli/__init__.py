"""The ``multimorph`` command line: thin layer over the library (parse, validate, call, write).

Each command lives in its own module ``cli/_<command>.py`` and is registered in
:mod:`multimorph.cli._app`.
"""

from multimorph.cli._app import app, main

__all__ = ["app", "main"]
