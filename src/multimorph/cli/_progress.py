"""Progress of a long command on stderr: a rich bar on a terminal, plain lines otherwise.

A bar redraws itself in place, which a log file or a pipe cannot show (rich stays silent
there). When stderr is not a terminal the same updates become lines such as::

    [design] global search: 1200/5000 candidates, 12.3 s

at most one a second (``interval``), always the first and the last.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TextIO

__all__ = ["LineProgress", "progress"]


class LineProgress:
    """Progress as plain lines on ``stream`` (a log file, a pipe), at most one per
    ``interval`` seconds, the first update always shown, :meth:`close` showing the last.

    Parameters
    ----------
    command : str
        The command's name, the prefix of every line (``[design]``).
    unit : str
        What is counted (``"candidates"``), after ``done/total``.
    stream : text stream, optional
        Where the lines go (default: ``sys.stderr`` at each write).
    interval : float
        Least time between two lines (s).
    clock : callable
        Monotonic time in seconds (a test passes its own).
    """

    def __init__(self, command: str, unit: str = "", *, stream: TextIO | None = None,
                 interval: float = 1.0, clock: Callable[[], float] = time.monotonic) -> None:
        self.command, self.unit, self.interval, self.clock = command, unit, interval, clock
        self._stream = stream
        self._start = clock()
        self._shown_at: float | None = None
        self._state: tuple[float | None, float | None, str | None, str | None] | None = None
        self._pending = False

    def update(self, done: float | None, total: float | None = None, *,
               phase: str | None = None, detail: str | None = None) -> None:
        """Record the progress: ``done`` of ``total`` ``unit`` in ``phase`` (None: as
        before); ``detail`` replaces the count in the line."""
        old = self._state
        self._state = (done if done is not None or old is None else old[0],
                       total if total is not None or old is None else old[1],
                       phase if phase is not None or old is None else old[2],
                       detail)
        now = self.clock()
        if self._shown_at is None or now - self._shown_at >= self.interval:
            self._show(now)
        else:
            self._pending = True

    def close(self) -> None:
        """Show the last state if it has not been shown."""
        if self._pending:
            self._show(self.clock())

    def line(self, now: float) -> str:
        """The line of the current state at time ``now``."""
        done, total, phase, detail = self._state or (0.0, None, None, None)
        where = f"{phase}: " if phase else ""
        return (f"[{self.command}] {where}{_count(done, total, self.unit, detail)}, "
                f"{now - self._start:.1f} s")

    def _show(self, now: float) -> None:
        stream = self._stream or sys.stderr
        stream.write(self.line(now) + "\n")
        stream.flush()
        self._shown_at, self._pending = now, False


def _count(done: float | None, total: float | None, unit: str, detail: str | None) -> str:
    """``"1200/5000 candidates"`` (or ``detail`` when given)."""
    if detail:
        return detail
    def number(x: float) -> str:
        return str(int(x)) if float(x).is_integer() else f"{x:.4g}"

    return (number(done or 0) + ("" if total is None else f"/{number(total)}")
            + (f" {unit}" if unit else ""))


@contextmanager
def progress(command: str, *, unit: str = "", quiet: bool = False, keep: bool = False
             ) -> Iterator[Callable[..., None]]:
    """Progress of ``command`` on stderr; yields ``update(done, total=None, *, phase=None,
    detail=None)``.

    On a terminal: a rich bar (shown from the first update; gone at the end unless
    ``keep``); otherwise :class:`LineProgress` lines. ``quiet``: nothing at all.
    """
    from multimorph.cli._common import err_console

    if quiet:
        yield lambda *args, **kwargs: None
        return
    if not err_console.is_terminal:
        lines = LineProgress(command, unit)
        try:
            yield lines.update
        finally:
            lines.close()
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    bar = Progress(TextColumn("[bold]{task.description}[/]"), BarColumn(),
                   TextColumn("{task.fields[detail]}"), TimeElapsedColumn(),
                   console=err_console, transient=not keep)
    tasks: list[Any] = []

    def update(done: float | None, total: float | None = None, *,
               phase: str | None = None, detail: str | None = None) -> None:
        if not tasks:  # the bar appears once the work starts (every check passed)
            bar.start()
            tasks.append(bar.add_task(command, total=total, detail=""))
        task = bar.tasks[0]
        done = task.completed if done is None else done
        fields: dict[str, Any] = {"completed": done, "detail": _count(
            done, task.total if total is None else total, unit, detail)}
        if total is not None:
            fields["total"] = total
        if phase is not None:
            fields["description"] = f"{command}: {phase}"
        bar.update(tasks[0], **fields)

    try:
        yield update
    finally:
        bar.stop()
