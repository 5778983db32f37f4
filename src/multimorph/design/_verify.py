"""Verification hook: hand a design's cells to the finite-element check (:mod:`multimorph.fe`).

Each distinct cell of the design is traced with FE (:func:`multimorph.fe.simulate_cell`, a
coarse mesh by default) and its characteristic pressures compared with the reduced model's.
FE runs take minutes per cell; this is a check of the chosen design, not part of the search.
"""

from __future__ import annotations

from typing import Any

from multimorph.design._evaluate import Evaluation
from multimorph.design._target import TargetSpec
from multimorph.errors import MultimorphError

__all__ = ["fe_available", "verify_fe"]

_NEEDED = ("simulate_cell", "FESettings")


def fe_available() -> tuple[bool, str]:
    """Whether the FE room can verify a design, and if not, what is missing."""
    try:
        from multimorph import fe
    except ImportError as exc:
        return False, f"multimorph.fe cannot be imported ({exc})"
    missing = [n for n in _NEEDED if not callable(getattr(fe, n, None))]
    if missing:
        return False, (f"multimorph.fe lacks {', '.join(missing)} (the finite-element model "
                       "of issue 5 is not finished)")
    try:
        import felupe  # noqa: F401

        from multimorph.fe import MissingExtraError  # noqa: F401
    except ImportError as exc:
        return False, (f"the FE dependencies are not installed ({exc}); install "
                       "'multimorph[fe]'")
    return True, ""


def verify_fe(target: TargetSpec, design: Evaluation, *, mesh: str = "coarse",
              progress: Any = None) -> dict[str, Any]:
    """FE check of every stage cell of ``design``: Pc and Ph from FE vs the reduced model.

    Returns
    -------
    dict
        Per stage: ``rom`` and ``fe`` critical/hardening pressures (Pa) and their relative
        differences, plus FE solver statistics.

    Raises
    ------
    MultimorphError
        When the FE room is missing or incomplete (the message names what is missing).
    """
    ok, why = fe_available()
    if not ok:
        raise MultimorphError(f"--verify-fe: {why}")
    from multimorph import fe

    p_max = target.constraints.max_pressure
    out: dict[str, Any] = {}
    for i, stage in enumerate(target.stages):
        cell = design.candidate.cells[i]
        r_rom = design.responses[i]
        res = fe.simulate_cell(cell, fe.FESettings(mesh=mesh, p_max=p_max))
        ch_fe = res.response.characteristic
        ch_rom = r_rom.characteristic
        row: dict[str, Any] = {"status": res.stats.get("status") if hasattr(res, "stats")
                               else None}
        for key in ("critical", "hardening"):
            a, b = getattr(ch_rom, key), getattr(ch_fe, key)
            row[key] = {"rom": a, "fe": b,
                        "relative_difference": None if a is None or b is None else (b - a) / a}
        out[stage.name] = row
        if progress is not None:
            progress(i + 1, len(target.stages))
    return out
