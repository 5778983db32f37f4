"""The bad-input corpus: one mutation each of a shipped example or data file, per command.

Each :class:`Case` is a command line of ``multimorph`` (``material fit``, ``cell``,
``simulate``, ``design``, ``sweep``) run on a mutated copy of a file the package ships
(``examples/*.toml``, ``materials/data/*``), with what a clean refusal must look like: the
exit code (2), and a text the one error line must contain (the spec field, the option, or
the file and line). Every case must be refused before any computation, and write nothing.

Used by ``tests/test_bad_inputs.py`` (in-process, the model stubbed out: the corpus runs in
seconds) and by ``benchmarks/bad_inputs.py`` (subprocesses with the real model: the before /
after counts of issue 20).

Placeholders in ``argv``: ``{spec}`` the first file written (the mutated input), ``{dir}``
the run folder, ``{out}`` the output folder ``{dir}/out``.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
DATA = ROOT / "src" / "multimorph" / "materials" / "data"

#: The classes of bad input of issue 20 (each case has one).
CLASSES = ("missing-key", "unknown-key", "typo-key", "wrong-type", "sign", "nan-inf", "huge",
           "units", "geometry", "unknown-material", "file", "syntax", "output", "option",
           "code")


@dataclass(frozen=True)
class Case:
    """One bad input.

    Attributes
    ----------
    id : str
        ``<command>/<class>/<what>``.
    command : str
        ``material-fit``, ``cell``, ``simulate``, ``design`` or ``sweep``.
    kind : str
        One of :data:`CLASSES`.
    argv : tuple of str
        The command line after ``multimorph`` (with placeholders).
    expect : str
        Text the single error line must contain (field, option, or file and line).
    files : tuple of (str, bytes)
        Files written into the run folder; the first one is ``{spec}``.
    setup : str
        Extra preparation: ``out-file`` (``{out}`` is a file), ``out-under-file``,
        ``out-readonly``, ``out-foreign`` (a non-empty folder that is not a sweep),
        ``locked`` (another run holds ``{out}``), ``spec-dir`` (the spec is a folder),
        ``no-spec`` (the spec does not exist), ``scheduler`` (an unreachable scheduler).
    code : int
        Expected exit status.
    """

    id: str
    command: str
    kind: str
    argv: tuple[str, ...]
    expect: str
    files: tuple[tuple[str, bytes], ...]
    setup: str = ""
    code: int = 2


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def _in_cell(text: str, cell: str, key: str, line: str) -> tuple[str, str]:
    """(old, new) for :func:`sub`: the cell table ``[cells."<cell>"]`` down to its ``key``
    line, and the same with that line replaced by ``line`` (unique even where another cell
    has the same value)."""
    m = re.search(rf'\[cells\."{cell}"\]\n(?:.*\n)*?{key} = "[^"]*"', text)
    assert m is not None, f"corpus: no {key} in cells.{cell}"
    old = m.group(0)
    return old, old[:old.rindex(f"{key} = ")] + line


def sub(text: str, old: str, new: str) -> str:
    """``text`` with the single occurrence of ``old`` replaced (fails loudly otherwise)."""
    n = text.count(old)
    if n != 1:
        raise AssertionError(f"corpus: {old!r} occurs {n} times in the base file")
    return text.replace(old, new)


# ----------------------------------------------------------------- generic file mutations
EMPTY = b""
BINARY = bytes(range(256)) * 4
NON_UTF8 = "# caf\u00e9\n".encode("latin-1")


def _file_cases(command: str, base: bytes, name: str, argv: tuple[str, ...],
                toml: bool) -> Iterator[Case]:
    yield Case(f"{command}/file/empty", command, "file", argv, name, ((name, EMPTY),))
    yield Case(f"{command}/file/binary", command, "file", argv, name, ((name, BINARY),))
    if toml:  # the CSV reader reads Latin-1 on purpose (lab instruments write it)
        yield Case(f"{command}/file/non-utf8", command, "file", argv, name,
                   ((name, NON_UTF8 + base),))
    yield Case(f"{command}/file/missing", command, "file", argv, name, ((name, base),),
               setup="no-spec")
    yield Case(f"{command}/file/folder", command, "file", argv, name, ((name, base),),
               setup="spec-dir")
    if toml:
        yield Case(f"{command}/syntax/unclosed-string", command, "syntax", argv,
                   f"{name}: invalid TOML", ((name, base + b'\nbroken = "no end\n'),))
        yield Case(f"{command}/syntax/duplicate-table", command, "syntax", argv,
                   f"{name}: invalid TOML", ((name, base + b"\n[target]\n[target]\n"),))
        yield Case(f"{command}/syntax/bare-word", command, "syntax", argv,
                   f"{name}: invalid TOML", ((name, base + b"\nkey = sixty kPa\n"),))


def _output_cases(command: str, files: tuple[tuple[str, bytes], ...],
                  argv: tuple[str, ...]) -> Iterator[Case]:
    for setup in ("out-file", "out-under-file", "out-readonly", "locked"):
        yield Case(f"{command}/output/{setup}", command, "output", argv, "--out", files,
                   setup=setup)


# ----------------------------------------------------------------- [cell] tables
def _cell_table_cases(command: str, text: str, name: str, argv: tuple[str, ...],
                      field: str, lines: dict[str, str]) -> Iterator[Case]:
    """Mutations of one cell table; ``lines`` maps each key to its line in ``text``."""

    def case(kind: str, what: str, new: str, expect: str, key: str) -> Case:
        body = sub(text, lines[key], new) if key else new
        return Case(f"{command}/{kind}/{what}", command, kind, argv, expect,
                    ((name, body.encode()),))

    tw, sw, ew = lines["top_wall"], lines["side_wall"], lines["end_wall"]
    yield case("missing-key", "top_wall", "", f"{field}.top_wall", "top_wall")
    yield case("unknown-key", "roof", tw + '\nroof = "1 mm"', "roof", "top_wall")
    yield case("typo-key", "top_wal", tw.replace("top_wall", "top_wal"), "top_wal",
               "top_wall")
    yield case("wrong-type", "bool", "top_wall = true", f"{field}.top_wall", "top_wall")
    yield case("wrong-type", "array", "top_wall = [1, 2]", f"{field}.top_wall", "top_wall")
    yield case("wrong-type", "table", "top_wall = {a = 1}", f"{field}.top_wall", "top_wall")
    yield case("sign", "negative-wall", 'top_wall = "-0.8 mm"', f"{field}.top_wall",
               "top_wall")
    yield case("sign", "zero-wall", 'end_wall = "0 mm"', f"{field}.end_wall", "end_wall")
    yield case("nan-inf", "nan-string", 'side_wall = "nan mm"', f"{field}.side_wall",
               "side_wall")
    yield case("nan-inf", "inf-string", 'side_wall = "inf mm"', f"{field}.side_wall",
               "side_wall")
    yield case("nan-inf", "toml-nan", "end_wall = nan", f"{field}.end_wall", "end_wall")
    yield case("huge", "1e300-mm", 'top_wall = "1e300 mm"', f"{field}.top_wall", "top_wall")
    yield case("huge", "bare-20-is-metres", "end_wall = 20", f"{field}.end_wall", "end_wall")
    yield case("units", "pressure-for-length", 'top_wall = "0.8 kPa"', f"{field}.top_wall",
               "top_wall")
    yield case("units", "unknown-unit", 'top_wall = "0.8 furlongz"', f"{field}.top_wall",
               "top_wall")
    yield case("geometry", "side-walls-fill-width", 'side_wall = "7 mm"', "side_wall",
               "side_wall")
    yield case("geometry", "end-walls-fill-length", 'end_wall = "12 mm"', "end_wall",
               "end_wall")
    yield case("geometry", "walls-fill-height", 'top_wall = "9 mm"', "top_wall", "top_wall")
    del sw, ew


def _inline_material_cases(command: str, text: str, name: str, argv: tuple[str, ...],
                           field: str, block: str) -> Iterator[Case]:
    """Mutations of an inline Gent material; ``block`` is its unique ``mu``/``jm`` lines."""

    def case(kind: str, what: str, old: str, new: str, expect: str) -> Case:
        return Case(f"{command}/{kind}/{what}", command, kind, argv, expect,
                    ((name, sub(text, block, block.replace(old, new, 1)).encode()),))

    mu = block.splitlines()[0]
    yield case("sign", "negative-mu", mu, 'mu = "-245 kPa"', field)
    yield case("units", "mu-in-mm", mu, 'mu = "245 mm"', f"{field}.mu")
    yield case("nan-inf", "mu-inf", mu, 'mu = "inf kPa"', field)
    yield case("wrong-type", "jm-string", "jm = 20", 'jm = "twenty"', f"{field}.jm")
    yield case("missing-key", "jm", "jm = 20", "", "jm")
    yield case("typo-key", "jmm", "jm = 20", "jmm = 20", "jmm")


# ----------------------------------------------------------------- material fit
def material_fit_cases() -> Iterator[Case]:
    cmd = "material-fit"
    plain = _text(DATA / "treloar1944" / "uniaxial.csv")
    mar = _text(DATA / "marechal2021" / "dragon_skin_30.csv")
    argv = ("material", "fit", "{spec}", "--out", "{out}")
    pl = plain.splitlines()

    def plain_case(kind: str, what: str, body: str, expect: str,
                   extra: tuple[str, ...] = (), name: str = "pull.csv") -> Case:
        return Case(f"{cmd}/{kind}/{what}", cmd, kind, argv + extra, expect,
                    ((name, body.encode()),))

    yield from _file_cases(cmd, plain.encode(), "pull.csv", argv, toml=False)
    yield plain_case("file", "comments-only", "# nothing here\n# at all\n", "pull.csv")
    yield plain_case("file", "header-only", pl[0] + "\n", "pull.csv, line 1")
    yield plain_case("missing-key", "stress-unit", sub(plain, pl[0], "stretch,nominal_stress"),
                     "pull.csv, line 1")
    yield plain_case("unknown-key", "columns", sub(plain, pl[0], "x,y"), "pull.csv, line 1")
    yield plain_case("typo-key", "strech", sub(plain, pl[0], "strech,nominal_stress_mpa"),
                     "pull.csv, line 1")
    yield plain_case("units", "stress-in-mm", sub(plain, pl[0], "stretch,stress (mm)"),
                     "pull.csv, line 1")
    yield plain_case("units", "stress-unknown-unit",
                     sub(plain, pl[0], "stretch,stress (furlongz)"), "pull.csv, line 1")
    yield plain_case("wrong-type", "word-in-cell", sub(plain, pl[3], "1.2400,abc"),
                     "pull.csv, line 4")
    yield plain_case("nan-inf", "nan-cell", sub(plain, pl[3], "1.2400,nan"),
                     "pull.csv, line 4")
    yield plain_case("nan-inf", "inf-cell", sub(plain, pl[5], "inf,0.4"), "pull.csv, line 6")
    yield plain_case("sign", "negative-stretch", sub(plain, pl[2], "-1.1250,0.1344"),
                     "pull.csv, line 3")
    yield plain_case("sign", "decreasing-stretch", sub(plain, pl[4], "1.0500,0.3169"),
                     "pull.csv, line 5")
    yield plain_case("syntax", "extra-column", sub(plain, pl[3], "1.2400,0.2256,7"),
                     "pull.csv, line 4")
    yield plain_case("syntax", "missing-column", sub(plain, pl[3], "1.2400"),
                     "pull.csv, line 4")
    yield plain_case("syntax", "semicolon-row", sub(plain, pl[3], "1.2400;0.2256"),
                     "pull.csv, line 4")
    yield plain_case("syntax", "every-row-twice",
                     "\n".join([pl[0], *(r for row in pl[1:] for r in (row, row))]) + "\n",
                     "pull.csv, line 3")
    yield plain_case("syntax", "one-row-twice", sub(plain, pl[6], pl[6] + "\n" + pl[6]),
                     "pull.csv, line 8")
    yield plain_case("unknown-key", "case-column",
                     "stretch,stress (kPa),case\n1.1,10,uniaxial\n1.2,20,sideways\n",
                     "pull.csv, line 3")
    yield plain_case("huge", "huge-stretch",
                     sub(plain, pl[-1], "1e12," + pl[-1].split(",")[1]),
                     f"pull.csv, line {len(pl)}")
    # Marechal format
    ml = mar.splitlines()
    hdr = next(i for i, ln in enumerate(ml) if ln.startswith("Time (s)"))

    def mar_case(kind: str, what: str, body: str, expect: str,
                 extra: tuple[str, ...] = ()) -> Case:
        return Case(f"{cmd}/{kind}/{what}", cmd, kind, argv + extra, expect,
                    (("ds30.csv", body.encode()),))

    yield mar_case("syntax", "marechal-header", sub(mar, ml[hdr], ml[hdr].replace(
        "Engineering Stress (MPa)", "Eng Stress")), "ds30.csv")
    yield mar_case("wrong-type", "marechal-strain-word",
                   sub(mar, ml[hdr + 3], "0.4;0.08695;0.0452644982333333;abc;0.04149"),
                   f"ds30.csv, line {hdr + 4}")
    yield mar_case("syntax", "marechal-four-columns",
                   sub(mar, ml[hdr + 3], "0.4;0.08695;0.0452644982333333;0.09084"),
                   f"ds30.csv, line {hdr + 4}")
    yield mar_case("syntax", "marechal-duplicate-row",
                   sub(mar, ml[hdr + 3], ml[hdr + 3] + "\n" + ml[hdr + 3]),
                   f"ds30.csv, line {hdr + 5}")
    yield mar_case("option", "marechal-equibiaxial", mar, "ds30.csv",
                   ("--case", "equibiaxial"))
    # options
    base = ((("pull.csv", plain.encode())),)
    for what, extra, expect in (
            ("model-typo", ("--model", "gnet"), "--model"),
            ("order-zero", ("--model", "reduced-polynomial", "--order", "0"), "--order"),
            ("order-nine", ("--model", "reduced-polynomial", "--order", "9"), "--order"),
            ("order-for-gent", ("--order", "3"), "--order"),
            ("order-word", ("--order", "three"), "--order"),
            ("range-below-one", ("--range", "0.5"), "--range"),
            ("range-nan", ("--range", "nan"), "--range"),
            ("range-word", ("--range", "abc"), "--range"),
            ("range-too-narrow", ("--range", "1.05"), "--range"),
            ("case-typo", ("--case", "uniaxal"), "--case"),
            ("residual-typo", ("--residual", "squared"), "--residual"),
            ("format-typo", ("--format", "excel"), "--format"),
            ("format-force-on-plain", ("--format", "force"), "pull.csv, line 1"),
            ("gauge-negative", ("--gauge-length", "-3 mm"), "--gauge-length"),
            ("gauge-units", ("--gauge-length", "3 kPa"), "--gauge-length"),
            ("width-nan", ("--width", "nan mm"), "--width"),
            ("no-such-option", ("--modle", "gent"), "--modle")):
        kind = "option"
        yield Case(f"{cmd}/{kind}/{what}", cmd, kind, argv + extra, expect, base)
    yield from _output_cases(cmd, base, argv)


# ----------------------------------------------------------------- cell
def cell_cases() -> Iterator[Case]:
    cmd = "cell"
    text = _text(EXAMPLES / "cell.toml")
    argv = ("cell", "{spec}", "--out", "{out}")
    name = "cell.toml"
    lines = {k: next(ln for ln in text.splitlines() if ln.startswith(f"{k} ="))
             for k in ("top_wall", "side_wall", "end_wall")}
    yield from _cell_table_cases(cmd, text, name, argv, "cell", lines)
    yield from _inline_material_cases(cmd, text, name, argv, "cell.material",
                                      'mu = "245 kPa"\njm = 20\n')
    yield Case(f"{cmd}/unknown-material/model-typo", cmd, "unknown-material", argv, "gnet",
               ((name, text.replace('model = "gent"', 'model = "gnet"', 1).encode()),))
    body = sub(text, "[cell.material]\nmodel = \"gent\"\nname = \"elastomer-III (Gent fit, "
                     "assumed)\"\nmu = \"245 kPa\"\njm = 20\nbreak_stretch = 6.0\n",
               'material = "unobtainium"\n')
    yield Case(f"{cmd}/unknown-material/library-name", cmd, "unknown-material", argv,
               "cell.material", ((name, body.encode()),))
    for what, old, new, expect, kind in (
            ("break-stretch-word", "break_stretch = 6.0", 'break_stretch = "six"',
             "break_stretch", "wrong-type"),
            ("break-stretch-below-one", "break_stretch = 6.0", "break_stretch = 0.5",
             "break_stretch", "sign"),
            ("bottom-mu-nan", 'mu = "1.2 MPa"', 'mu = "nan MPa"', "cell.bottom_material",
             "nan-inf"),
            ("symmetric-word", "[cell.material]", 'symmetric = "yes"\n\n[cell.material]',
             "cell.symmetric", "wrong-type"),
            ("no-cell-table", "[cell]\n", "[cel]\n", "[cel]", "typo-key")):
        yield Case(f"{cmd}/{kind}/{what}", cmd, kind, argv, expect,
                   ((name, sub(text, old, new).encode()),))
    yield from _file_cases(cmd, text.encode(), name, argv, toml=True)
    files = ((name, text.encode()),)
    for what, extra in (("pmax-word", ("--pmax", "abc")), ("pmax-negative", ("--pmax", "-5 kPa")),
                        ("pmax-length", ("--pmax", "60 mm")), ("pmax-nan", ("--pmax", "nan kPa")),
                        ("pmax-huge", ("--pmax", "1e30 kPa")), ("pmax-zero", ("--pmax", "0"))):
        yield Case(f"{cmd}/option/{what}", cmd, "option", argv + extra, "--pmax", files)
    yield Case(f"{cmd}/option/no-such-option", cmd, "option", (*argv, "--pmaxx", "1"),
               "--pmaxx", files)
    yield from _output_cases(cmd, files, (*argv, "--pmax", "60 kPa"))


# ----------------------------------------------------------------- simulate
def simulate_cases() -> Iterator[Case]:
    cmd = "simulate"
    text = _text(EXAMPLES / "gripper.toml")
    jar = _text(EXAMPLES / "jar_lifter.toml")
    argv = ("simulate", "{spec}", "--out", "{out}", "--frames", "0")
    name = "gripper.toml"

    def case(kind: str, what: str, old: str, new: str, expect: str, src: str = text,
             extra: tuple[str, ...] = ()) -> Case:
        return Case(f"{cmd}/{kind}/{what}", cmd, kind, argv + extra, expect,
                    ((name, sub(src, old, new).encode()),))

    pm = 'pmax = "60 kPa"'
    yield case("missing-key", "device-pmax", '\npmax = "180 kPa"', "",
               "device.pmax", src=jar)
    yield case("sign", "pmax-negative", pm, 'pmax = "-60 kPa"', "device.pmax")
    yield case("units", "pmax-length", pm, 'pmax = "60 mm"', "device.pmax")
    yield case("nan-inf", "pmax-nan", pm, 'pmax = "nan kPa"', "device.pmax")
    yield case("huge", "pmax-1e40", pm, 'pmax = "1e40 kPa"', "device.pmax")
    yield case("typo-key", "pmx", pm, 'pmx = "60 kPa"', "pmx")
    yield case("typo-key", "kind", 'kind = "twisting"', 'kind = "twistin"', "twistin")
    yield case("missing-key", "module-cell", 'cell = "twister"\n', "", "module 'twister'.cell")
    # the example's own lines (it is a designed device since stop 37: its numbers move
    # when it is designed again)
    cells = re.search(r"^cells = \d+$", text, re.M).group(0)
    yield case("sign", "cells-zero", cells, "cells = 0", "cells")
    yield case("huge", "cells-1e9", cells, "cells = 1000000000", "cells")
    yield case("huge", "count-1e9", "count = 3", "count = 1000000000", "count")
    yield case("wrong-type", "cells-float", cells, "cells = 2.5", "cells")
    yield case("wrong-type", "cells-string", cells, 'cells = "6"', "cells")
    yield case("sign", "count-negative", "count = 3", "count = -3", "count")
    tilt = re.search(r'^tilt = "[^"]*"$', text, re.M).group(0)
    yield case("units", "tilt-no-unit-string", tilt, 'tilt = "30"', "tilt")
    yield case("units", "tilt-bare-number", tilt, "tilt = 30", "tilt")
    yield case("units", "tilt-length", tilt, 'tilt = "30 mm"', "tilt")
    yield case("units", "tilt-percent", tilt, 'tilt = "30 %"', "tilt")
    yield case("geometry", "tilt-95-deg", tilt, 'tilt = "95 deg"', "tilt")
    radius = re.search(r'^radius = "[^"]*"$', text, re.M).group(0)
    yield case("units", "orientation-no-unit-string", radius,
               radius + '\norientation = "180"', "orientation")
    yield case("sign", "radius-negative", radius, 'radius = "-10 mm"', "radius")
    yield case("nan-inf", "shaft-nan", 'shaft_radius = "5 mm"', 'shaft_radius = "nan mm"',
               "shaft_radius")
    yield case("unknown-key", "attach-to-nobody", 'attach_to = "twister"',
               'attach_to = "nobody"', "nobody")
    yield case("unknown-key", "cell-name", 'cell = "fingers"', 'cell = "fniger"', "fniger")
    yield case("unknown-material", "library-name", *_in_cell(text, "twister", "material",
                                                             'material = "unobtainium"'),
               "cells.twister.material")
    yield case("geometry", "twist-side-walls", *_in_cell(text, "twister", "side_wall",
                                                         'side_wall = "7 mm"'), "cells.twister")
    yield case("sign", "finger-top-wall", *_in_cell(text, "fingers", "top_wall",
                                                    'top_wall = "-1 mm"'),
               "cells.fingers.top_wall")
    yield case("unknown-key", "top-table", "[device]", "[devise]", "devise")
    yield case("unknown-key", "module-colour", "strips = 3", 'strips = 3\ncolour = "red"',
               "colour")
    yield case("sign", "strips-zero", "strips = 3", "strips = 0", "strips")
    yield case("unknown-key", "duplicate-module", 'name = "fingers"', 'name = "twister"',
               "twister")
    yield case("geometry", "stretching-asymmetric", 'bottom_wall = "1.07 mm"\nside_wall = '
               '"1.61 mm"', 'bottom_wall = "1.2 mm"\nside_wall = "1.61 mm"', "sealer", src=jar)
    body = text.split("[[module]]")[0]
    yield Case(f"{cmd}/missing-key/modules", cmd, "missing-key", argv, "module",
               ((name, body.encode()),))
    yield from _file_cases(cmd, text.encode(), name, argv, toml=True)
    files = ((name, text.encode()),)
    for what, extra, expect in (
            ("snapshots-word", ("--snapshots", "abc"), "--snapshots"),
            ("snapshots-negative", ("--snapshots", "-5 kPa"), "--snapshots"),
            ("snapshots-above-pmax", ("--snapshots", "20 kPa,100 kPa"), "--snapshots"),
            ("snapshots-length", ("--snapshots", "20 mm"), "--snapshots"),
            ("pmax-word", ("--pmax", "abc"), "--pmax"),
            ("pmax-negative", ("--pmax", "-1 kPa"), "--pmax"),
            ("frames-negative", ("--frames", "-1"), "--frames"),
            ("frames-huge", ("--frames", "100000000"), "--frames"),
            ("frames-word", ("--frames", "many"), "--frames")):
        yield Case(f"{cmd}/option/{what}", cmd, "option", argv + extra, expect, files)
    yield from _output_cases(cmd, files, argv)


# ----------------------------------------------------------------- design
def design_cases() -> Iterator[Case]:
    cmd = "design"
    text = _text(EXAMPLES / "target_gripper.toml")
    argv = ("design", "{spec}", "--out", "{out}", "--budget", "20", "--robustness", "0",
            "--no-gradient")
    name = "target.toml"
    ang = 'angle = "90 deg"\npressure'
    st0 = "stage[0] (fingers)"

    def case(kind: str, what: str, old: str, new: str, expect: str) -> Case:
        return Case(f"{cmd}/{kind}/{what}", cmd, kind, argv, expect,
                    ((name, sub(text, old, new).encode()),))

    yield case("units", "angle-no-unit-string", ang, 'angle = "90"\npressure', f"{st0}.angle")
    yield case("units", "angle-bare-number", ang, "angle = 90\npressure", f"{st0}.angle")
    yield case("units", "angle-length", ang, 'angle = "90 mm"\npressure', f"{st0}.angle")
    yield case("units", "angle-percent", ang, 'angle = "90 %"\npressure', f"{st0}.angle")
    yield case("sign", "angle-zero", ang, 'angle = "0 deg"\npressure', f"{st0}.angle")
    yield case("nan-inf", "angle-nan", ang, 'angle = "nan deg"\npressure', f"{st0}.angle")
    yield case("typo-key", "kind", 'kind = "bend"', 'kind = "bnd"', f"{st0}.kind")
    yield case("missing-key", "kind", 'kind = "bend"\n', "", f"{st0}.kind")
    yield case("missing-key", "angle", ang, "pressure", f"{st0}.angle")
    yield case("sign", "pressure-negative", 'pressure = "30 kPa"', 'pressure = "-30 kPa"',
               f"{st0}.pressure")
    yield case("units", "pressure-length", 'pressure = "30 kPa"', 'pressure = "30 mm"',
               f"{st0}.pressure")
    yield case("unknown-key", "pressure-and-band", 'pressure = "30 kPa"',
               'pressure = "30 kPa"\nband = ["10 kPa", "30 kPa"]', st0)
    yield case("sign", "band-reversed", 'band = ["30 kPa", "40 kPa"]',
               'band = ["40 kPa", "30 kPa"]', "band")
    yield case("wrong-type", "band-one-value", 'band = ["30 kPa", "40 kPa"]',
               'band = ["30 kPa"]', "band")
    yield case("sign", "count-zero", "count = 3 ", "count = 0 ", f"{st0}.count")
    yield case("wrong-type", "count-string", "count = 3 ", 'count = "3" ', f"{st0}.count")
    yield case("huge", "count-1e9", "count = 3 ", "count = 1000000000 ", f"{st0}.count")
    yield case("typo-key", "angel", ang, 'angel = "90 deg"\npressure', "angel")
    yield case("geometry", "stages-out-of-order", 'band = ["30 kPa", "40 kPa"]',
               'band = ["10 kPa", "20 kPa"]', "twister")
    yield case("missing-key", "max-pressure", 'max_pressure = "60 kPa"\n', "", "max_pressure")
    yield case("sign", "max-pressure-zero", 'max_pressure = "60 kPa"', 'max_pressure = "0 kPa"',
               "max_pressure")
    yield case("huge", "max-pressure-1e30", 'max_pressure = "60 kPa"',
               'max_pressure = "1e30 kPa"', "max_pressure")
    yield case("unknown-material", "library-name", '"ecoflex-00-30", ', '"unobtainium", ',
               "constraints.materials[0]")
    yield case("missing-key", "materials-empty", 'materials = ["ecoflex-00-30", '
               '"ecoflex-00-50", "dragon-skin-fx-pro", "dragon-skin-10",\n             '
               '"platsil-gel-10", "dragon-skin-20"]', "materials = []", "materials")
    yield case("sign", "inline-material-negative", 'materials = ["ecoflex-00-30", ',
               'materials = [{model = "gent", mu = "-50 kPa", jm = 20}, ',
               "constraints.materials[0]")
    yield case("sign", "min-wall-negative", 'min_wall = "1 mm"', 'min_wall = "-1 mm"',
               "min_wall")
    yield case("wrong-type", "max-length-word", 'max_length = "200 mm"', 'max_length = "abc"',
               "max_length")
    yield case("sign", "safety-negative", "min_safety_factor = 1.2", "min_safety_factor = -1",
               "min_safety_factor")
    yield case("wrong-type", "separation-word", 'min_separation = "-10 %"',
               'min_separation = "abc %"', "min_separation")
    yield case("sign", "tolerance-negative", 'pressure = "10 %"', 'pressure = "-10 %"',
               "tolerance.pressure")
    yield case("typo-key", "max-widht", 'max_width = "30 mm"', 'max_widht = "30 mm"',
               "max_widht")
    yield case("unknown-key", "top-table", "[target]", "[targets]", "targets")
    yield case("unknown-key", "shaft-on-bend", "count = 3 ", 'count = 3\nshaft_radius = "5 mm"'
               " ", "shaft_radius")
    yield case("sign", "min-cells-zero", "min_safety_factor = 1.2",
               "min_safety_factor = 1.2\nmin_cells = 0", "constraints.min_cells")
    yield case("huge", "parts-9", 'band = ["30 kPa", "40 kPa"]',
               'band = ["30 kPa", "40 kPa"]\nparts = 9', "parts")
    yield case("unknown-key", "parts-with-count", "count = 3 ", "count = 3\nparts = 2 ",
               "parts")
    yield from _file_cases(cmd, text.encode(), name, argv, toml=True)
    files = ((name, text.encode()),)
    for what, extra, expect in (
            ("wall-tolerance-word", ("--wall-tolerance", "abc"), "--wall-tolerance"),
            ("wall-tolerance-negative", ("--wall-tolerance", "-0.1 mm"), "--wall-tolerance"),
            ("default-cv-negative", ("--default-cv", "-1"), "--default-cv"),
            ("default-cv-nan", ("--default-cv", "nan"), "--default-cv"),
            ("budget-zero", ("--budget", "0"), "--budget"),
            ("population-two", ("--population", "2"), "--population"),
            ("population-huge", ("--population", "1000000000"), "--population"),
            ("robustness-huge", ("--robustness", "1000000000"), "--robustness"),
            ("seed-word", ("--seed", "abc"), "--seed")):
        yield Case(f"{cmd}/option/{what}", cmd, "option", argv + extra, expect, files)
    yield from _output_cases(cmd, files, argv)


# ----------------------------------------------------------------- sweep
def sweep_cases() -> Iterator[Case]:
    cmd = "sweep"
    text = _text(EXAMPLES / "sweep_ht.toml")
    argv = ("sweep", "{spec}", "--out", "{out}", "--scheduler", "sync")
    name = "sweep.toml"

    def case(kind: str, what: str, old: str, new: str, expect: str,
             extra: tuple[str, ...] = ()) -> Case:
        return Case(f"{cmd}/{kind}/{what}", cmd, kind, argv + extra, expect,
                    ((name, sub(text, old, new).encode()),))

    be = 'backend = "calibrated-fast"'
    yield case("code", "backend-os-system", be, 'backend = "os:system"', "sweep.backend")
    yield case("code", "backend-module-path", be, 'backend = "subprocess:run"',
               "sweep.backend")
    yield case("typo-key", "backend-name", be, 'backend = "romm"', "sweep.backend")
    yield case("typo-key", "backend-name-calibrated", be, 'backend = "calibrated-fats"',
               "sweep.backend")
    yield case("wrong-type", "backend-number", be, "backend = 5", "sweep.backend")
    yield case("huge", "num-1e9", "num = 7", "num = 1000000000", "num")
    yield case("huge", "two-params-1e5-each", "num = 7",
               'num = 100000\n\n[[sweep.parameter]]\nname = "ws/d"\nstart = 0.05\n'
               "stop = 0.1\nnum = 100000", "designs")
    yield case("sign", "num-zero", "num = 7", "num = 0", "num")
    yield case("sign", "num-negative", "num = 7", "num = -3", "num")
    yield case("wrong-type", "num-float", "num = 7", "num = 2.5", "num")
    yield case("wrong-type", "start-word", "start = 0.03", 'start = "abc"', "start")
    yield case("nan-inf", "start-nan", "start = 0.03", "start = nan", "start")
    yield case("nan-inf", "stop-inf", "stop = 0.09", "stop = inf", "stop")
    yield case("unknown-key", "parameter-name", 'name = "ht/d"', 'name = "ht/dd"', "ht/dd")
    yield case("typo-key", "nmu", "num = 7", "nmu = 7", "nmu")
    yield case("missing-key", "pmax", 'pmax = "500 kPa"\n', "", "sweep.pmax")
    yield case("sign", "pmax-negative", 'pmax = "500 kPa"', 'pmax = "-1 kPa"', "sweep.pmax")
    yield case("units", "pmax-length", 'pmax = "500 kPa"', 'pmax = "500 mm"', "sweep.pmax")
    yield case("huge", "pmax-1e30", 'pmax = "500 kPa"', 'pmax = "1e30 kPa"', "sweep.pmax")
    yield case("typo-key", "outputs", 'outputs = ["characteristic", "curves"]',
               'outputs = ["characteristic", "curvez"]', "sweep.outputs")
    yield case("typo-key", "combine", be, be + '\ncombine = "product"', "sweep.combine")
    yield case("missing-key", "samples", be, be + '\ncombine = "random"', "sweep.samples")
    yield case("huge", "samples-1e10", be, be + '\ncombine = "random"\nsamples = 10000000000',
               "sweep.samples")
    yield case("geometry", "all-designs-invalid", "start = 0.03\nstop = 0.09",
               "start = 0.5\nstop = 0.6", "invalid")
    yield case("sign", "log-range-from-zero", "start = 0.03", 'start = 0.0\nscale = "log"',
               "log")
    yield case("typo-key", "pmx", 'pmax = "500 kPa"', 'pmx = "500 kPa"', "pmx")
    yield case("unknown-key", "material-path", 'name = "ht/d"', 'name = "cell.material.jmm"',
               "cell.material.jmm")
    yield case("wrong-type", "options-number", be, be + "\noptions = 5", "sweep.options")
    yield case("unknown-key", "rom-option", "num = 7", "num = 7\n\n[sweep.options]\nfoo = 1",
               "sweep.options")
    yield case("wrong-type", "seed-word", be, be + '\nseed = "abc"', "sweep.seed")
    yield case("wrong-type", "values-empty", "start = 0.03\nstop = 0.09\nnum = 7",
               "values = []", "values")
    yield case("unknown-key", "values-and-range", "num = 7", "num = 7\nvalues = [0.05]",
               "sweep.parameter[0]")
    yield case("sign", "cell-top-wall", 'top_wall = "1 mm"', 'top_wall = "-1 mm"',
               "cell.top_wall")
    block = '[cell.material]\nmodel = "gent"\nname = "gent-245kPa-jm20"\nmu = "245 kPa"\njm = 20\n'
    yield case("missing-key", "cell-material", block, "", "cell.material")
    yield case("unknown-material", "cell-material", block, 'material = "unobtainium"\n',
               "cell.material")
    yield case("unknown-key", "top-table", "[sweep]", "[sweeps]", "sweeps")
    yield from _file_cases(cmd, text.encode(), name, argv, toml=True)
    files = ((name, text.encode()),)
    for what, extra, expect, setup in (
            ("scheduler-unreachable", ("--scheduler", "tcp://127.0.0.1:1"), "--scheduler",
             ""),
            ("scheduler-typo", ("--scheduler", "processes"), "--scheduler", ""),
            ("workers-zero", ("--workers", "0"), "--workers", ""),
            ("workers-huge", ("--scheduler", "threads", "--workers", "100000"), "--workers",
             ""),
            ("batch-size-zero", ("--batch-size", "0"), "--batch-size", ""),
            ("retries-negative", ("--retries", "-1"), "--retries", ""),
            ("plugin-not-callable", ("--allow-plugin", "os:sep"), "--allow-plugin", ""),
            ("plugin-missing-module", ("--allow-plugin", "no_such_mod:f"), "--allow-plugin",
             ""),
            ("out-foreign-folder", (), "--out", "out-foreign")):
        yield Case(f"{cmd}/option/{what}", cmd, "option", argv + extra, expect, files,
                   setup=setup)
    yield from _output_cases(cmd, files, argv)


def prepare(case: Case, folder: Path) -> tuple[list[str], Path]:
    """Write the case's files and set-up into ``folder``; the argv with placeholders filled."""
    for name, data in case.files:
        (folder / name).write_bytes(data)
    spec = folder / case.files[0][0]
    out = folder / "out"
    if case.setup == "out-file":
        out.write_text("not a folder\n")
    elif case.setup == "out-under-file":
        (folder / "blocker").write_text("a file\n")
        out = folder / "blocker" / "out"
    elif case.setup == "out-readonly":
        ro = folder / "ro"
        ro.mkdir()
        ro.chmod(0o555)
        out = ro / "out"
    elif case.setup == "out-foreign":
        out.mkdir()
        (out / "notes.txt").write_text("my own notes\n")
    elif case.setup == "spec-dir":
        spec.unlink()
        spec.mkdir()
    elif case.setup == "no-spec":
        spec.unlink()
    argv = [a.replace("{spec}", str(spec)).replace("{out}", str(out))
            .replace("{dir}", str(folder)) for a in case.argv]
    return argv, out


def snapshot(folder: Path) -> set[tuple[str, int]]:
    """Every path under ``folder`` (hidden ones too) with its size (-1 for folders)."""
    out = set()
    for p in folder.rglob("*"):
        out.add((str(p.relative_to(folder)), -1 if p.is_dir() else p.stat().st_size))
    return out


def all_cases() -> list[Case]:
    """Every case of the corpus, in a fixed order (ids are unique)."""
    cases = [*material_fit_cases(), *cell_cases(), *simulate_cases(), *design_cases(),
             *sweep_cases()]
    ids = [c.id for c in cases]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise AssertionError(f"corpus: duplicate case ids {dup}")
    return cases
