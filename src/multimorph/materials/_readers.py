"""Test-data readers: tensile curves as :class:`LoadCurve` / :class:`TestData` value objects.

Three file formats are read, each into nominal (first Piola–Kirchhoff) stress in Pa against
stretch:

``marechal``
    The Soft Robotics Materials Database format (Marechal et al. 2021): ``key;value`` header
    lines (specimen dimensions, machine, material name), then the columns
    ``Time (s);True Strain;True Stress (MPa);Engineering Strain;Engineering Stress (MPa)``.
    The engineering columns are used: stretch = 1 + strain, nominal stress = engineering
    stress. The tests pull to failure, so the last point gives the stretch at break.
``plain``
    A CSV (``,`` ``;`` or tab) with a header naming a stretch-like column (``stretch``,
    ``lambda``, ``strain``, ``engineering_strain_percent``, ``true strain`` …) and a stress
    column with its unit (``nominal_stress_mpa``, ``stress (kPa)``, ``stress [Pa]`` …),
    optionally a load-case column (``case``: uniaxial / equibiaxial / pure_shear).
``force``
    Raw force–displacement (``force (N)``, ``displacement (mm)``) converted with the specimen
    dimensions (defaults: ASTM D412 die C, gauge length 33 mm, width 6 mm, thickness 3 mm).

Every malformed file raises :class:`~multimorph.errors.DataFileError` naming the file, the
line and the problem.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from multimorph.errors import DataFileError, SpecError
from multimorph.materials._loadcases import LOAD_CASES, canonical_case

__all__ = ["LoadCurve", "Specimen", "TestData", "read_test_data"]

FORMATS = ("auto", "marechal", "plain", "force")

_MARECHAL_COLUMNS = ("time (s)", "true strain", "true stress (mpa)", "engineering strain",
                     "engineering stress (mpa)")


# --------------------------------------------------------------------------- value objects
@dataclass(frozen=True, eq=False)
class LoadCurve:
    """One homogeneous load case: nominal stress against stretch.

    Parameters
    ----------
    case : {"uniaxial", "equibiaxial", "pure_shear"}
        Load case (aliases such as ``"UT"``, ``"planar"`` accepted).
    stretch : array_like
        Loading stretch λ (-), positive and non-decreasing.
    stress : array_like
        Nominal stress (Pa) along the loading direction, same length.
    source : str, optional
        File the curve was read from.
    break_stretch : float, optional
        Stretch at failure for pull-to-failure tests (kept by :meth:`truncate`).

    Examples
    --------
    >>> c = LoadCurve("UT", [1.1, 1.5, 2.0], [1e4, 3e4, 5e4])
    >>> c.case, c.truncate(1.6).stretch.tolist()
    ('uniaxial', [1.1, 1.5])
    """

    case: str
    stretch: np.ndarray
    stress: np.ndarray
    source: str | None = None
    break_stretch: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "case", canonical_case(self.case))
        lam = np.array(self.stretch, dtype=float).ravel()
        p = np.array(self.stress, dtype=float).ravel()
        if lam.shape != p.shape:
            raise SpecError(f"{self.case} curve: {lam.size} stretches but {p.size} stresses")
        if not (np.all(np.isfinite(lam)) and np.all(np.isfinite(p))):
            raise SpecError(f"{self.case} curve: stretches and stresses must be finite")
        if np.any(lam <= 0):
            raise SpecError(f"{self.case} curve: stretches must be positive")
        if np.any(np.diff(lam) < 0):
            raise SpecError(f"{self.case} curve: stretches must not decrease")
        lam.setflags(write=False)
        p.setflags(write=False)
        object.__setattr__(self, "stretch", lam)
        object.__setattr__(self, "stress", p)

    def __len__(self) -> int:
        return int(self.stretch.size)

    @property
    def max_stretch(self) -> float:
        """Largest stretch in the curve (-)."""
        return float(self.stretch.max()) if self.stretch.size else math.nan

    def truncate(self, max_stretch: float, min_stretch: float = 0.0) -> LoadCurve:
        """The points with ``min_stretch <= λ <= max_stretch`` (the design range)."""
        keep = (self.stretch >= min_stretch) & (self.stretch <= max_stretch)
        return replace(self, stretch=self.stretch[keep], stress=self.stress[keep])


@dataclass(frozen=True, eq=False)
class TestData:
    """Tensile test data of one material: one or more :class:`LoadCurve` (one per case).

    Attributes
    ----------
    curves : tuple of LoadCurve
    name : str
        Material name from the file (Marechal ``Material`` key) or the file stem.
    source : str, optional
        Path of the file read.
    metadata : mapping
        Header ``key: value`` pairs (specimen, machine, supplier …) as strings.
    notes : tuple of str
        What the reader noticed but kept, naming the lines (negative stresses in tension,
        one stretch with several stresses): the command line prints them as warnings.
    """

    __test__ = False  # not a pytest test class

    curves: tuple[LoadCurve, ...]
    name: str = ""
    source: str | None = None
    metadata: Mapping[str, str] = field(default_factory=dict)
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "notes", tuple(self.notes))
        curves = tuple(self.curves)
        cases = [c.case for c in curves]
        if len(set(cases)) != len(cases):
            raise SpecError("test data: at most one curve per load case")
        object.__setattr__(self, "curves", tuple(sorted(curves,
                                                        key=lambda c: LOAD_CASES.index(c.case))))
        object.__setattr__(self, "metadata", dict(self.metadata))

    @property
    def cases(self) -> tuple[str, ...]:
        return tuple(c.case for c in self.curves)

    def curve(self, case: str) -> LoadCurve:
        case = canonical_case(case)
        for c in self.curves:
            if c.case == case:
                return c
        raise SpecError(f"test data {self.name!r} has no {case} curve (has {self.cases})")

    @property
    def n_points(self) -> int:
        return sum(len(c) for c in self.curves)

    @property
    def break_stretch(self) -> float | None:
        """Uniaxial stretch at break for pull-to-failure data (else ``None``)."""
        for c in self.curves:
            if c.case == "uniaxial" and c.break_stretch is not None:
                return c.break_stretch
        return None

    def truncate(self, max_stretch: float, min_stretch: float = 0.0) -> TestData:
        """Keep the points with ``min_stretch <= λ <= max_stretch`` in every curve."""
        return replace(self, curves=tuple(c.truncate(max_stretch, min_stretch)
                                          for c in self.curves))


@dataclass(frozen=True)
class Specimen:
    """Tensile specimen dimensions (m) for force–displacement data.

    Defaults: ASTM D412 die C dumbbell, gauge length 33 mm, width 6 mm, thickness 3 mm
    (the Marechal et al. 2021 specimens).
    """

    gauge_length: float = 33e-3
    width: float = 6e-3
    thickness: float = 3e-3

    def __post_init__(self) -> None:
        for k in ("gauge_length", "width", "thickness"):
            v = getattr(self, k)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise SpecError(f"specimen {k} must be a positive length in m, got {v!r}")

    @property
    def area(self) -> float:
        """Reference cross-section (m²)."""
        return self.width * self.thickness


# --------------------------------------------------------------------------- entry point
def read_test_data(
    path: str | os.PathLike[str],
    case: str | None = None,
    format: str = "auto",
    *,
    specimen: Specimen | None = None,
) -> TestData:
    """Read a tensile-test file into :class:`TestData` (nominal stress in Pa vs stretch).

    Parameters
    ----------
    path : path-like
        The CSV file.
    case : str, optional
        Load case of every row when the file has no case column; default: the file stem if
        it names a case (``pure_shear.csv``), else ``"uniaxial"``. With a case column, only
        the rows of ``case`` are kept.
    format : {"auto", "marechal", "plain", "force"}
        File format; ``"auto"`` recognises a Marechal header or a force column.
    specimen : Specimen, optional
        Specimen dimensions for ``force`` files. Default: comment lines of the file such as
        ``# gauge length: 25 mm``, ``# width = 4 mm``, ``# thickness: 2 mm``, and for what
        they leave out ASTM D412 die C (33 mm, 6 mm, 3 mm).

    Returns
    -------
    TestData

    Raises
    ------
    DataFileError
        Unreadable or malformed file; the message names the file, the line and the problem.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "ut.csv"
    >>> _ = f.write_text("stretch,stress (kPa)\\n1.5,20\\n2.0,35\\n")
    >>> d = read_test_data(f)
    >>> d.cases, d.curves[0].stress.tolist()
    (('uniaxial',), [20000.0, 35000.0])
    """
    p = Path(path)
    if format not in FORMATS:
        raise SpecError(f"format must be one of {', '.join(FORMATS)}, got {format!r}")
    lines = _read_lines(p)
    if format == "auto":
        format = _detect(p, lines)
    if case is not None:
        try:
            case = canonical_case(case)
        except SpecError as exc:
            raise DataFileError(p, str(exc)) from None
    if format == "marechal":
        return _read_marechal(p, lines, case)
    if format == "force":
        return _read_columns(p, lines, case, specimen or _specimen_from_comments(p, lines),
                             force=True)
    return _read_columns(p, lines, case, None, force=False)


def _read_lines(p: Path) -> list[str]:
    if not p.exists():
        raise DataFileError(p, "no such file")
    if not p.is_file():
        raise DataFileError(p, "not a regular file")
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise DataFileError(p, f"cannot read ({exc.strerror})") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        try:
            text = raw.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover - latin-1 decodes any byte
            raise DataFileError(p, "not a text file") from None
    if "\x00" in text:
        raise DataFileError(p, "not a text file (contains NUL bytes)")
    if not text.strip():
        raise DataFileError(p, "empty file")
    return text.splitlines()


def _detect(p: Path, lines: list[str]) -> str:
    for line in lines[:40]:
        low = line.strip().lower()
        if low.startswith("parameter;info") or low.startswith("time (s);true strain"):
            return "marechal"
    for line in lines:
        if line.strip() and not line.lstrip().startswith("#"):
            return "force" if "force" in line.lower() or "load (" in line.lower() else "plain"
    raise DataFileError(p, "no header line (only comments)")


# --------------------------------------------------------------------------- row checks
#: Largest plausible stretch of a tensile test (elastomers break below ~15).
MAX_STRETCH = 100.0


class _Rows:
    """Data rows of one file as they are read: a repeated row is refused (it would count
    twice and shrink the fit's error bars), and what is kept but worth a warning is noted:
    negative stresses in tension and one stretch given several stresses."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.first: dict[tuple[str, ...], int] = {}
        self.last: dict[str, tuple[int, float, float]] = {}
        self.negative: list[int] = []
        self.repeated: list[tuple[int, int, float]] = []

    def add(self, lineno: int, cells: tuple[str, ...], case: str, lam: float,
            stress: float) -> None:
        if cells in self.first:
            raise DataFileError(self.path, f"repeats line {self.first[cells]} exactly (a copied "
                                           "row would count twice and shrink the fit's error "
                                           "bars); remove it", lineno)
        self.first[cells] = lineno
        if lam > 1.0 and stress < 0:
            self.negative.append(lineno)
        prev = self.last.get(case)
        if prev is not None and prev[1] == lam and prev[2] != stress:
            self.repeated.append((prev[0], lineno, lam))
        self.last[case] = (lineno, lam, stress)

    def notes(self) -> tuple[str, ...]:
        out = []
        if self.negative:
            out.append(f"{_lines(self.negative)}: negative stress in tension (a load-cell "
                       "offset?); relative-residual fits leave such points out")
        if self.repeated:
            pairs = ", ".join(f"{a} and {b} (stretch {lam:.6g})"
                              for a, b, lam in self.repeated[:5])
            more = f" and {len(self.repeated) - 5} more" if len(self.repeated) > 5 else ""
            out.append(f"lines {pairs}{more}: one stretch with two different stresses; "
                       "both are fitted")
        return tuple(out)


def _lines(numbers: list[int]) -> str:
    shown = ", ".join(str(n) for n in numbers[:10])
    more = f" and {len(numbers) - 10} more" if len(numbers) > 10 else ""
    return f"line{'s' if len(numbers) > 1 else ''} {shown}{more}"


# --------------------------------------------------------------------------- Marechal
def _float(p: Path, lineno: int, cell: str, what: str) -> float:
    text = cell.strip()
    try:
        v = float(text)
    except ValueError:
        raise DataFileError(p, f"{what}: {text!r} is not a number", lineno) from None
    if not math.isfinite(v):
        raise DataFileError(p, f"{what}: {text!r} is not a finite number", lineno)
    return v


def _read_marechal(p: Path, lines: list[str], case: str | None) -> TestData:
    if case not in (None, "uniaxial"):
        raise DataFileError(p, f"Marechal files hold uniaxial tests, not {case}")
    meta: dict[str, str] = {}
    header_at = None
    for i, line in enumerate(lines):
        cells = [c.strip() for c in line.split(";")]
        if [c.lower() for c in cells[:5]] == list(_MARECHAL_COLUMNS):
            header_at = i
            break
        if cells and cells[0] and cells[0].upper() != "PARAMETER":
            if len(cells) < 2:
                raise DataFileError(p, f"header line is not 'key;value': {line.strip()!r}",
                                    i + 1)
            meta[cells[0]] = cells[1]
    if header_at is None:
        raise DataFileError(p, "no column header 'Time (s);True Strain;True Stress (MPa);"
                               "Engineering Strain;Engineering Stress (MPa)' found")
    lam: list[float] = []
    stress: list[float] = []
    rows = _Rows(p)
    for i in range(header_at + 1, len(lines)):
        line = lines[i].strip()
        if not line or not line.strip(";"):
            continue
        cells = line.split(";")
        while len(cells) > 5 and not cells[-1].strip():
            cells.pop()
        if len(cells) != 5:
            raise DataFileError(p, f"expected 5 ';'-separated columns, found {len(cells)}",
                                i + 1)
        e = _float(p, i + 1, cells[3], "Engineering Strain")
        stress_mpa = _float(p, i + 1, cells[4], "Engineering Stress (MPa)")
        _check_stretch(p, i + 1, 1.0 + e, lam[-1] if lam else None)
        rows.add(i + 1, tuple(c.strip() for c in cells), "uniaxial", 1.0 + e, stress_mpa * 1e6)
        lam.append(1.0 + e)
        stress.append(stress_mpa * 1e6)
    if not lam:
        raise DataFileError(p, "no data rows after the column header", header_at + 1)
    for key in ("Specimen Thickness (mm)", "Thickness (mm)", "Specimen Width (mm)",
                "Width (mm)", "Specimen Length (mm)", "Length (mm)"):
        if key in meta:
            try:
                float(meta[key])
            except ValueError:
                raise DataFileError(p, f"{key}: {meta[key]!r} is not a number") from None
    name = meta.get("Material", p.stem)
    curve = LoadCurve("uniaxial", lam, stress, source=str(p), break_stretch=max(lam))
    return TestData((curve,), name=name, source=str(p), metadata=meta, notes=rows.notes())


def _check_stretch(p: Path, lineno: int, lam: float, prev: float | None) -> None:
    if not lam > 0:
        raise DataFileError(p, f"stretch {lam:.6g} is not positive", lineno)
    if lam > MAX_STRETCH:
        raise DataFileError(p, f"stretch {lam:.6g} is beyond any elastomer (more than "
                               f"{MAX_STRETCH:g}); check the column and its unit", lineno)
    if prev is not None and lam < prev:
        raise DataFileError(p, f"stretch decreases ({prev:.6g} then {lam:.6g}); "
                               "expected a monotonic loading curve", lineno)


# --------------------------------------------------------------------------- plain / force
_UNIT_ALIASES = {
    "pa": "Pa", "kpa": "kPa", "mpa": "MPa", "gpa": "GPa", "psi": "psi", "kpsi": "kpsi",
    "n/mm2": "N/mm^2", "n/mm^2": "N/mm^2", "kgf/cm2": "kgf/cm^2", "kgf/cm^2": "kgf/cm^2",
    "n": "N", "kn": "kN", "mn": "mN", "lbf": "lbf", "kgf": "kgf",
    "m": "m", "mm": "mm", "cm": "cm", "um": "um", "in": "inch", "inch": "inch",
    "%": "percent", "percent": "percent", "pct": "percent",
}


@dataclass(frozen=True)
class _Column:
    index: int
    kind: str  # stretch | strain | true_strain | stress | true_stress | force | disp | case
    unit: str | None


def _split_name(name: str) -> tuple[str, str | None]:
    """Split a header cell into a lower-case base name and a unit string (or None)."""
    text = name.strip().strip('"').strip()
    match = re.search(r"[\(\[]\s*([^\)\]]*?)\s*[\)\]]\s*$", text)
    if match:
        return text[: match.start()].strip().lower(), match.group(1)
    low = text.lower().replace(" ", "_")
    parts = low.split("_")
    if len(parts) > 1 and parts[-1] in _UNIT_ALIASES:
        return "_".join(parts[:-1]), parts[-1]
    return low, None


def _classify(name: str) -> tuple[str | None, str | None]:
    base, unit = _split_name(name)
    b = base.replace("-", "_").replace(" ", "_")
    if b in ("case", "load_case", "loadcase", "mode", "test"):
        return "case", None
    if "stretch" in b or b in ("lambda", "lam", "l"):
        return "stretch", unit
    if "strain" in b:
        if b.endswith("_percent") or b.endswith("_pct"):
            unit = unit or "percent"
        return ("true_strain" if "true" in b or "log" in b else "strain"), unit
    if "stress" in b or b in ("p", "pk1", "nominal"):
        return ("true_stress" if "true" in b or "cauchy" in b else "stress"), unit
    if "force" in b or b == "load":
        return "force", unit
    if "displacement" in b or "extension" in b or b in ("disp", "elongation", "position"):
        return "disp", unit
    return None, unit


def _unit_factor(p: Path, lineno: int, column: str, unit: str | None, si: str) -> float:
    from multimorph.units import registry

    if unit is None or not unit.strip():
        if si == "dimensionless":
            return 1.0
        raise DataFileError(p, f"column {column!r} has no unit; write it in the header, "
                               f"e.g. '{column} ({'kPa' if si == 'Pa' else si})'", lineno)
    u = unit.strip()
    ureg = registry()
    for cand in (_UNIT_ALIASES.get(u.lower()), u):
        if cand is None:
            continue
        try:
            q = ureg.Quantity(1.0, cand)
            return float(q.to(si).magnitude)
        except Exception:
            continue
    raise DataFileError(p, f"column {column!r}: unit {u!r} is not a unit of {si}", lineno)


def _case_from_stem(p: Path) -> str | None:
    """A file named after a load case (``uniaxial.csv``, ``pure_shear.csv``) holds that case."""
    try:
        return canonical_case(p.stem)
    except SpecError:
        return None


_SPECIMEN_KEYS = {"gauge length": "gauge_length", "gauge_length": "gauge_length",
                  "length": "gauge_length", "width": "width", "thickness": "thickness"}


def _specimen_from_comments(p: Path, lines: list[str]) -> Specimen:
    """Specimen dimensions from ``# key: value`` comment lines (defaults: die C)."""
    from multimorph.units import to_si

    found: dict[str, float] = {}
    for i, line in enumerate(lines):
        hit = re.match(r"\s*#\s*(?:specimen\s+)?([A-Za-z _]+?)\s*[:=]\s*(.+?)\s*$", line)
        if not hit or hit.group(1).strip().lower() not in _SPECIMEN_KEYS:
            continue
        key = _SPECIMEN_KEYS[hit.group(1).strip().lower()]
        try:
            found[key] = to_si(hit.group(2), "m", field=key.replace("_", " "))
        except SpecError as exc:
            raise DataFileError(p, str(exc), i + 1) from None
    try:
        return Specimen(**found)
    except SpecError as exc:
        raise DataFileError(p, str(exc)) from None


def _sniff_delimiter(header: str) -> str:
    for d in (";", "\t", ","):
        if d in header:
            return d
    return ","


def _read_columns(p: Path, lines: list[str], case: str | None, specimen: Specimen | None,
                  *, force: bool) -> TestData:
    body = [(i + 1, ln) for i, ln in enumerate(lines)
            if ln.strip() and not ln.lstrip().startswith("#")]
    if not body:
        raise DataFileError(p, "no header line (only comments)")
    hline, header = body[0]
    delim = _sniff_delimiter(header)
    names = [c.strip() for c in header.split(delim)]
    while names and not names[-1]:
        names.pop()
    cols: dict[str, _Column] = {}
    for j, n in enumerate(names):
        kind, unit = _classify(n)
        if kind is None:
            continue
        if kind in ("stretch", "strain", "true_strain"):
            key = "x"
        elif kind in ("stress", "true_stress"):
            key = "y"
        else:
            key = kind
        if key in cols:
            raise DataFileError(p, f"two columns for the same quantity: "
                                   f"{names[cols[key].index]!r} and {n!r}", hline)
        cols[key] = _Column(j, kind, unit)
    if force:
        if "force" not in cols or "disp" not in cols:
            raise DataFileError(p, "a force-displacement file needs a 'force (N)' and a "
                                   f"'displacement (mm)' column; header is {header.strip()!r}",
                                hline)
        assert specimen is not None
        fx = _unit_factor(p, hline, names[cols["force"].index], cols["force"].unit, "N")
        fd = _unit_factor(p, hline, names[cols["disp"].index], cols["disp"].unit, "m")
    else:
        if "x" not in cols or "y" not in cols:
            raise DataFileError(
                p, "expected a stretch (or strain) column and a stress column with its unit, "
                   f"e.g. 'stretch,nominal_stress (MPa)'; header is {header.strip()!r}", hline)
        xcol, ycol = cols["x"], cols["y"]
        if xcol.kind == "stretch":
            fx = _unit_factor(p, hline, names[xcol.index], None, "dimensionless")
        else:
            fx = _unit_factor(p, hline, names[xcol.index], xcol.unit, "dimensionless")
        fy = _unit_factor(p, hline, names[ycol.index], ycol.unit, "Pa")
    data: dict[str, tuple[list[float], list[float], list[int]]] = {}
    seen = _Rows(p)
    for lineno, line in body[1:]:
        cells = [c.strip() for c in line.split(delim)]
        while len(cells) > len(names) and not cells[-1]:
            cells.pop()
        if len(cells) != len(names):
            raise DataFileError(p, f"expected {len(names)} columns, found {len(cells)}", lineno)
        if "case" in cols:
            try:
                row_case = canonical_case(cells[cols["case"].index].strip('"'))
            except SpecError as exc:
                raise DataFileError(p, str(exc), lineno) from None
            if case is not None and row_case != case:
                continue
        else:
            row_case = case or _case_from_stem(p) or "uniaxial"
        if force:
            f = _float(p, lineno, cells[cols["force"].index], names[cols["force"].index]) * fx
            u = _float(p, lineno, cells[cols["disp"].index], names[cols["disp"].index]) * fd
            lam = 1.0 + u / specimen.gauge_length  # type: ignore[union-attr]
            nominal = f / specimen.area  # type: ignore[union-attr]
        else:
            x = _float(p, lineno, cells[xcol.index], names[xcol.index]) * fx
            y = _float(p, lineno, cells[ycol.index], names[ycol.index]) * fy
            lam = x if xcol.kind == "stretch" else (
                1.0 + x if xcol.kind == "strain" else math.exp(x))
            # sigma_11 = lambda_1 P_11 in all three homogeneous cases (F diagonal, J = 1)
            nominal = y / lam if ycol.kind == "true_stress" else y
        lams, ps, rows = data.setdefault(row_case, ([], [], []))
        _check_stretch(p, lineno, lam, lams[-1] if lams else None)
        seen.add(lineno, tuple(cells), row_case, lam, nominal)
        lams.append(lam)
        ps.append(nominal)
        rows.append(lineno)
    if not data:
        raise DataFileError(p, "no data rows" + (f" for load case {case}" if case else ""),
                            hline)
    curves = tuple(LoadCurve(c, v[0], v[1], source=str(p)) for c, v in data.items())
    meta = {"format": "force" if force else "plain", "header": header.strip()}
    if force and specimen is not None:
        meta.update({"gauge_length_m": repr(specimen.gauge_length),
                     "width_m": repr(specimen.width), "thickness_m": repr(specimen.thickness)})
    return TestData(curves, name=p.stem, source=str(p), metadata=meta, notes=seen.notes())


def as_curves(data: Any) -> tuple[LoadCurve, ...]:
    """Normalise fit input: TestData, a LoadCurve, an iterable of them, or a mapping
    ``{case: (stretch, stress_Pa)}``."""
    if isinstance(data, TestData):
        return data.curves
    if isinstance(data, LoadCurve):
        return (data,)
    if isinstance(data, Mapping):
        return tuple(LoadCurve(k, *v) for k, v in data.items())
    if isinstance(data, Iterable) and not isinstance(data, str | bytes):
        items = tuple(data)
        if all(isinstance(c, LoadCurve) for c in items):
            return items
    raise SpecError("fit data must be TestData, LoadCurve(s) or {case: (stretch, stress)}")
