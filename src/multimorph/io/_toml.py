"""Reading TOML spec files with precise errors."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

from multimorph.errors import SpecError

__all__ = ["load_toml"]


def load_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Parse a TOML file; a missing or malformed file raises :class:`SpecError` naming it."""
    p = Path(path)
    if p.is_dir():
        raise SpecError(f"{p}: is a folder, not a spec file")
    if not p.is_file():
        raise SpecError(f"{p}: no such file")
    try:
        return tomllib.loads(p.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise SpecError(f"{p}: not a UTF-8 text file ({exc.reason})") from None
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"{p}: invalid TOML: {exc}") from None
