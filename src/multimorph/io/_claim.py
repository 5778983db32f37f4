"""Output folders checked and claimed before any work.

A command that writes into a folder (``--out``) first checks that the folder can be written
(:func:`check_output_dir`: not a file, not under a file, writable), then holds a lock on it
for the whole run (:func:`claim_output`), so that a second run writing the same folder at the
same time is told at once instead of both computing and one overwriting the other.

The lock is an ``flock`` on a small file named after the folder's absolute path, kept in the
user's cache (``$XDG_CACHE_HOME/multimorph/locks``, else ``~/.cache/multimorph/locks``, else
the temporary folder): nothing is written next to the output before the run succeeds, and
the kernel releases the lock when a process dies, however it dies.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import hashlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from multimorph.errors import SpecError

__all__ = ["OutputBusyError", "check_output_dir", "claim_output", "lock_dir"]


class OutputBusyError(SpecError):
    """Another run holds the output folder (the message names the option and the folder)."""


def _nearest_existing(path: Path) -> Path:
    cur = path
    while not cur.exists() and not cur.is_symlink():
        if cur.parent == cur:
            break
        cur = cur.parent
    return cur


def _probe_writable(folder: Path) -> bool:
    """Whether a file can be created in ``folder`` (permissions and read-only mounts)."""
    if not os.access(folder, os.W_OK | os.X_OK):
        return False
    try:
        fd, name = tempfile.mkstemp(prefix=".multimorph-probe-", dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(name)
    return True


def check_output_dir(path: str | os.PathLike[str], *, option: str = "--out",
                     files: Iterable[str] = (), in_place: bool = False) -> Path:
    """Check, before any work, that ``path`` can become (or already is) an output folder.

    Parameters
    ----------
    path : path-like
        The output folder (created later, when the results are written).
    option : str
        Name used in messages (the command-line option, e.g. ``"--out"``).
    files : iterable of str
        Names the command will write into the folder; none may be an existing folder.
    in_place : bool
        The command writes inside the folder only (a sweep), not first next to it (the
        atomic output folders of the other commands need its parent writable too).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    SpecError
        ``path`` is a file, lies under a file, is not writable (or its nearest existing
        parent is not), or one of ``files`` exists there as a folder.
    """
    p = Path(path)
    if p.is_dir():
        for name in files:
            if (p / name).is_dir():
                raise SpecError(f"{option}: {p / name} is a folder; the run writes a file of "
                                "that name there")
        if not _probe_writable(p):
            raise SpecError(f"{option}: {p} is not writable")
        parent = p.absolute().parent
        if not in_place and not _probe_writable(parent):
            raise SpecError(f"{option}: {parent} is not writable (results are written next "
                            f"to {p.name} first, then moved in)")
        return p
    if p.exists() or p.is_symlink():
        raise SpecError(f"{option}: {p} exists and is not a folder")
    where = _nearest_existing(p.parent if str(p.parent) else Path("."))
    if not where.is_dir():
        raise SpecError(f"{option}: cannot create {p}: {where} is a file, not a folder")
    if not _probe_writable(where):
        raise SpecError(f"{option}: cannot create {p}: {where} is not writable")
    return p


def lock_dir() -> Path:
    """The folder of output locks (created if needed)."""
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    for cand in (Path(base) / "multimorph" / "locks",
                 Path(tempfile.gettempdir()) / f"multimorph-locks-{os.getuid()}"):
        try:
            cand.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(cand, os.W_OK | os.X_OK):
            return cand
    raise SpecError("no writable folder for output locks (tried ~/.cache/multimorph/locks "
                    "and the temporary folder)")


def _lock_file(path: Path) -> Path:
    key = os.path.realpath(os.path.abspath(path))
    return lock_dir() / (hashlib.sha256(key.encode()).hexdigest()[:32] + ".lock")


@contextlib.contextmanager
def claim_output(path: str | os.PathLike[str], *, option: str = "--out",
                 files: Iterable[str] = (), in_place: bool = False) -> Iterator[Path]:
    """Check ``path`` (:func:`check_output_dir`) and hold it for the duration of the block.

    Raises
    ------
    SpecError
        The folder cannot be written (see :func:`check_output_dir`).
    OutputBusyError
        Another process holds it (another ``multimorph`` run writing the same folder).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "run"
    >>> with claim_output(out):
    ...     pass
    """
    p = check_output_dir(path, option=option, files=files, in_place=in_place)
    lock = _lock_file(p)
    while True:
        fh = open(lock, "a+")
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            fh.seek(0)
            holder = fh.read().strip()
            fh.close()
            if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                raise SpecError(f"{option}: cannot lock {p} ({exc.strerror})") from None
            raise OutputBusyError(
                f"{option}: {p} is being written by another multimorph run"
                + (f" ({holder})" if holder else "")
                + "; wait for it to finish or choose another folder") from None
        # the file may have been unlinked by the previous holder between open and flock
        try:
            same = os.stat(lock).st_ino == os.fstat(fh.fileno()).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        fh.close()
    try:
        fh.seek(0)
        fh.truncate()
        fh.write(f"process {os.getpid()}")
        fh.flush()
        yield p
    finally:
        with contextlib.suppress(OSError):
            os.unlink(lock)
        fh.close()
