"""The 3D pictures of a device: solid bodies of the cells' size, legend, units, notes."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from multimorph.device import RodStrains, device_from_spec, frames_along, simulate_device
from multimorph.viz._bodies import body_polygons
from multimorph.viz._device_plots import shapes_figure
from test_device_simulate import SPEC, step_model

#: The base module of SPEC with 40 cells: κ = 40 1/m over 0.2 m bends it by 8 rad > 2π.
COILED = SPEC.replace('cells = 4\n\n[[module]]\nname = "tip"',
                      'cells = 40\n\n[[module]]\nname = "tip"')


def simulated(text: str):
    return simulate_device(device_from_spec(tomllib.loads(text)), 60e3, cell_model=step_model)


@pytest.fixture(scope="module")
def straight():
    return simulated(SPEC)


def test_bodies_at_zero_pressure_are_the_cells_outer_boxes(straight) -> None:
    # SPEC: 2 × 4 cells of d = 5 mm, w = 10 mm, h = 8 mm, straight along +y
    polygons, colours, owners = body_polygons(straight.bodies(0.0), {"base": "C0", "tip": "C1"})
    assert set(owners) == {"base", "tip"} and len(owners) == len(polygons)
    pts = np.concatenate(polygons)
    np.testing.assert_allclose(pts.min(axis=0), [-5.0, 0.0, -4.0], atol=1e-9)
    np.testing.assert_allclose(pts.max(axis=0), [5.0, 40.0, 4.0], atol=1e-9)
    assert len(set(colours)) >= 4  # two modules, their partition bands, the stripe


def test_frames_carry_twist_so_the_stripe_turns() -> None:
    # a pure twist of 1 rad over the segment turns the body's x axis by 1 rad about y
    frames = frames_along([RodStrains.bend_twist(0.02, twist=50.0)], 8)
    e1 = frames[-1, :3, 0]
    assert math.atan2(-e1[2], e1[0]) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(frames[:, :3, 3][:, [0, 2]], 0.0, atol=1e-15)  # still on y


def test_figure_has_a_legend_entry_per_module_and_axes_in_mm(straight) -> None:
    fig = shapes_figure(straight, [0.0, 60e3])
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["base (bending)", "tip (bending)"]
    axes = [ax for ax in fig.axes if ax.name == "3d"]
    assert len(axes) == 2
    for ax, p in zip(axes, ("0", "60"), strict=True):
        assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()) == ("x (mm)", "y (mm)",
                                                                       "z (mm)")
        assert ax.get_title() == f"P = {p} kPa"
        assert ax.get_box_aspect() is not None and np.ptp(ax.get_xlim()) == pytest.approx(
            np.ptp(ax.get_zlim()))  # equal aspect
    assert not [t for ax in axes for t in ax.texts if "coils" in t.get_text()]


def test_a_coiling_device_is_noted_in_the_summary_and_the_picture(straight) -> None:
    coiled = simulated(COILED)
    assert straight.notes() == [] and straight.to_dict()["notes"] == []
    notes = coiled.to_dict()["notes"]
    assert any(n.startswith("module 'base' coils past 360° from ") for n in notes)
    assert all(n.endswith("self-contact is not modelled") for n in notes)
    # bend |κ| L passes 2π where κ > 2π / 0.2 m = 31.4 1/m, at 22.5 kPa of the 24 samples
    assert "coils past 360° from 22.5 kPa" in notes[0]
    fig = shapes_figure(coiled, [10e3, 60e3])
    low, high = (" ".join(t.get_text() for t in ax.texts) for ax in fig.axes if ax.name == "3d")
    assert "coils past 360°" in high and "coils" not in low


def test_fingers_hang_from_a_hub_and_series_modules_do_not(straight) -> None:
    text = SPEC.replace('cells = 4\norientation = "180 deg"',
                        'cells = 4\nattach_to = "base"\ncount = 3\nradius = "8 mm"')
    fingers = simulated(text).bodies(0.0)
    (hub,) = fingers.hubs
    assert hub.radius == pytest.approx(8e-3 + 5e-3)  # copies' radius + half a cell width
    np.testing.assert_allclose(hub.frame[:3, 3], [0.0, 0.02, 0.0], atol=1e-15)  # base's end
    assert [b.key for b in fingers.bodies] == ["base", "tip#0", "tip#1", "tip#2"]
    assert straight.bodies(0.0).hubs == ()


def test_a_twisting_module_in_orange_draws_its_lighter_shaft() -> None:
    """The shaft is the module's colour lightened: a channel at 1 (the second module's
    orange) stays at 1 (it overflowed and matplotlib refused the picture)."""
    text = SPEC.replace('kind = "bending"\ncell = "hard"\ncells = 4\norientation = "180 deg"',
                        'kind = "twisting"\ncell = "hard"\ncells = 4\ntilt = "30 deg"\n'
                        'shaft_radius = "2 mm"')
    result = simulated(text)
    assert [m.kind for m in result.device.modules] == ["bending", "twisting"]
    _, faces, _ = body_polygons(result.bodies(60e3), {"base": "tab:blue", "tip": "tab:orange"})
    assert np.max(faces) <= 1.0 and np.min(faces) >= 0.0
    shapes_figure(result, [0.0, 60e3])  # draws
