"""What code produced a result: the package version and, in a git checkout, the commit."""

from __future__ import annotations

import subprocess
from functools import lru_cache
from pathlib import Path

__all__ = ["code_version"]


@lru_cache(maxsize=1)
def code_version() -> str:
    """``"<version>"`` or ``"<version>+g<commit>[.dirty]"`` when run from a git checkout.

    Examples
    --------
    >>> code_version().startswith("0.")
    True
    """
    from multimorph import __version__

    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists():
        return __version__
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "--short=12", "HEAD"],
                              capture_output=True, text=True, timeout=10, check=True)
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain",
                                "--untracked-files=no", "--", "src"],
                               capture_output=True, text=True, timeout=10, check=True)
    except (OSError, subprocess.SubprocessError):
        return __version__
    tag = f"{__version__}+g{head.stdout.strip()}"
    return tag + (".dirty" if dirty.stdout.strip() else "")
