"""How a solver run ended: one vocabulary for the ROM tracer, the FE path driver and the fit.

Every member is a string (the word written to JSON summaries, e.g. ``"completed"`` or
``"converged"``) with an integer :attr:`Outcome.code` (what the ROM's JAX tracer carries in
its loop state; 0 is success) and a :attr:`Outcome.message` in words. The detail of a
particular run (the pressure where a step stalled, the parameter on a bound) stays in that
run's own message.

Examples
--------
>>> Outcome.MAX_STEPS.message
'ran out of steps before p_max (the path is too long to trace up to it)'
>>> Outcome.from_code(0), Outcome.from_code(0).ok
(<Outcome.COMPLETED: 'completed'>, True)
>>> Outcome.CONVERGED == "converged"
True
"""

from __future__ import annotations

from enum import StrEnum

__all__ = ["Outcome"]


class Outcome(StrEnum):
    """How a path trace, a path driver or a fit ended (a string, a code and a message)."""

    #: the path reached its highest pressure (ROM tracer code 0; FE pressure stepping)
    COMPLETED = "completed"
    #: the step budget ran out first
    MAX_STEPS = "max_steps"
    #: the step size fell below its smallest value (a limit point, lock-up, a failed solve)
    STALLED = "stalled"
    #: the reference state is not an equilibrium or not finite (ROM tracer)
    BAD_START = "bad_start"
    #: a stop rule of the caller ended the path (the rule's reason says which)
    STOPPED = "stopped"
    #: not finished yet (the FE driver's state while it runs)
    RUNNING = "running"
    #: a fit converged
    CONVERGED = "converged"
    #: a fit converged with a parameter on a bound
    AT_BOUND = "at_bound"
    #: a fit ran out of function evaluations
    MAX_EVALUATIONS = "max_evaluations"
    #: a fit failed
    FAILED = "failed"

    @property
    def code(self) -> int:
        """The integer code (0 = completed); the ROM tracer's ``status``."""
        return _CODES[self]

    @property
    def message(self) -> str:
        """What the outcome means, in words."""
        return _MESSAGES[self]

    @property
    def ok(self) -> bool:
        """Whether the run gives a usable result (completed, stopped by a rule, or a fit
        that converged, also with a parameter on a bound)."""
        return self in (Outcome.COMPLETED, Outcome.STOPPED, Outcome.CONVERGED,
                        Outcome.AT_BOUND)

    @classmethod
    def from_code(cls, code: int) -> Outcome:
        """The outcome of an integer code (:attr:`code`)."""
        try:
            return _BY_CODE[int(code)]
        except KeyError:
            raise ValueError(f"no outcome has the code {code!r}") from None


_CODES = {member: i for i, member in enumerate(Outcome)}
_BY_CODE = {i: member for member, i in _CODES.items()}
_MESSAGES = {
    Outcome.COMPLETED: "reached p_max",
    Outcome.MAX_STEPS: "ran out of steps before p_max (the path is too long to trace up to "
                       "it)",
    Outcome.STALLED: "step size underflow",
    Outcome.BAD_START: "the reference state is not an equilibrium or not finite",
    Outcome.STOPPED: "stopped by a stop rule",
    Outcome.RUNNING: "still running",
    Outcome.CONVERGED: "converged",
    Outcome.AT_BOUND: "converged with a parameter on a bound",
    Outcome.MAX_EVALUATIONS: "ran out of function evaluations",
    Outcome.FAILED: "failed",
}
