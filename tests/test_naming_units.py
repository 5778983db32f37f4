"""One naming scheme and one unit per axis (issue 21): kinds and law names printed one way
and accepted by their aliases, every command's default folder
``multimorph-out/<command>-<spec stem>``, and every plot axis labelled with one unit."""

from __future__ import annotations

import re
import tomllib

import pytest

from multimorph.names import KINDS, kind_name, motion_name


# ------------------------------------------------------------------ kinds and law names
def test_kinds_have_one_printed_name_and_accept_the_motion_as_alias() -> None:
    assert KINDS == ("bending", "stretching", "twisting")
    assert [kind_name(k) for k in ("bend", "stretch", "twist", "bending")] == [
        "bending", "stretching", "twisting", "bending"]
    assert motion_name("twisting") == "twist" and motion_name("bend") == "bend"
    assert kind_name("wiggling") == "wiggling"  # left for the caller's check to refuse


def test_a_device_module_of_kind_bend_is_a_bending_module() -> None:
    from multimorph.device import device_from_spec
    from test_device_simulate import SPEC

    device = device_from_spec(tomllib.loads(SPEC.replace('kind = "bending"', 'kind = "bend"')))
    assert [m.kind for m in device.modules] == ["bending", "bending"]


def test_a_design_stage_of_kind_bending_is_a_bend_stage() -> None:
    from multimorph.design import target_from_spec
    from test_design_spec import BASE

    text = BASE.replace('kind = "bend"', 'kind = "bending"').replace('kind = "twist"',
                                                                     'kind = "twisting"')
    target = target_from_spec(tomllib.loads(text))
    assert [s.kind for s in target.stages] == ["bend", "twist"]  # the JSON keeps "bend"


def test_a_sweep_of_kind_bend_sweeps_bending_cells() -> None:
    from multimorph.sweep import parse_sweep_spec
    from test_sweep_spec import spec

    text = 'kind = "bend"\n\n[[sweep.parameter]]\nname = "cell.top_wall"\nvalues = ["1 mm"]\n'
    assert parse_sweep_spec(spec(text)).kind == "bending"


def test_ogden_is_accepted_and_printed_with_its_order() -> None:
    from multimorph.materials import get_law

    assert get_law("ogden").name == get_law("ogden-3").name == "ogden-3"
    assert get_law("Reduced_Polynomial").name == "reduced-polynomial-6"


# ------------------------------------------------------------------ output folders
@pytest.mark.parametrize("command", ["cell", "simulate", "design", "fem", "sweep"])
def test_every_command_says_its_default_folder(command: str) -> None:
    from multimorph.cli._common import default_out
    from test_cli_help import COMMANDS

    assert str(default_out(command, "examples/x.toml")) == f"multimorph-out/{command}-x"
    (found,) = [c for path, c in COMMANDS if path == [command]]
    (out,) = [p for p in found.params if "--out" in getattr(p, "opts", ())]
    assert f"multimorph-out/{command}-<" in out.help


# ------------------------------------------------------------------ one unit per axis
def _units(label: str) -> list[str]:
    return re.findall(r"\(([^()]*)\)", label)


def _check(labels: list[str]) -> None:
    """Each label names at most one unit: one parenthesised group, no list inside it."""
    labels = [label for label in labels if label]
    assert labels
    for label in labels:
        units = _units(label)
        assert len(units) <= 1, label
        assert not any(re.search(r",| or |/ ", u) for u in units), label
        assert "°" not in label and "MPa" not in label, label


def _matplotlib_labels(fig) -> list[str]:
    return [text for ax in fig.axes for text in (ax.get_xlabel(), ax.get_ylabel())]


@pytest.fixture(scope="module")
def mixed():
    """A device with a bending and a stretching module (stand-in cell model)."""
    from multimorph.device import device_from_spec, simulate_device
    from test_device_simulate import SPEC, step_model

    text = SPEC.replace('bottom_wall = "2 mm"', 'bottom_wall = "1 mm"').replace(
        'kind = "bending"\ncell = "hard"', 'kind = "stretching"\ncell = "hard"')
    return simulate_device(device_from_spec(tomllib.loads(text)), 60e3, cell_model=step_model)


def test_the_sequence_plots_give_the_stretch_its_own_axis(mixed) -> None:
    from multimorph.viz._device_plots import module_curves_figure
    from multimorph.viz._report import sequence_figure

    assert {s.module.kind for s in mixed.strains.values()} == {"bending", "stretching"}
    fig = module_curves_figure(mixed)
    labels = _matplotlib_labels(fig)
    _check(labels)
    assert "angle (deg)" in labels and "stretch λ−1 (%)" in labels
    page = sequence_figure(mixed)
    _check([page.layout.xaxis.title.text, page.layout.yaxis.title.text,
            page.layout.yaxis2.title.text])
    assert {t.yaxis for t in page.data if t.name and "stretching" in t.name} == {"y2"}


def test_fit_cell_and_comparison_axes_have_one_unit_each(tmp_path) -> None:
    import matplotlib

    from multimorph.fe.report import comparison_curves, plot_comparison
    from multimorph.fe.report._comparison import QUANTITY_LABELS
    from multimorph.materials import fit_material, read_test_data
    from multimorph.viz._fitplot import _draw
    from test_fe_comparison_figure import _device_comparison

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    data = read_test_data("src/multimorph/materials/data/treloar1944/uniaxial.csv")
    fit = fit_material("neo-hooke", data, stretch_range=4.0)
    ax = Figure().add_subplot()
    _draw(ax, fit, data.curves[0])
    assert ax.get_ylabel() == "nominal stress (kPa)"  # kPa, also for natural rubber's MPa
    _check([ax.get_xlabel(), ax.get_ylabel()])
    fig = plot_comparison(comparison_curves(_device_comparison()), tmp_path / "c.png")
    _check(_matplotlib_labels(fig) + list(QUANTITY_LABELS.values()))
