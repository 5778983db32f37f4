"""Rod kinematics: circular arcs, pure twist, composition (issue 4)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from multimorph.device import RodStrains, centerline, chain, segment_transform


@pytest.mark.parametrize("kappa", [1.0, 25.0, 80.0])
def test_constant_curvature_is_a_circular_arc(kappa):
    # bend toward -z with curvature kappa: all points lie on a circle of radius 1/kappa
    # centred at (0, 0, -1/kappa) in the y-z plane
    seg = RodStrains.bend_twist(0.05, bend=kappa)
    pts = centerline([seg], points_per_segment=50)
    centre = np.array([0.0, 0.0, -1.0 / kappa])
    radii = np.linalg.norm(pts - centre, axis=1)
    np.testing.assert_allclose(radii, 1.0 / kappa, rtol=1e-12)
    np.testing.assert_allclose(pts[:, 0], 0.0, atol=1e-15)
    # the end tangent is rotated by theta = kappa * L about x, downward
    T = segment_transform(seg)
    theta = kappa * 0.05
    np.testing.assert_allclose(T[:3, 1], [0.0, np.cos(theta), -np.sin(theta)], atol=1e-12)


def test_arc_length_scales_with_stretch():
    seg = RodStrains.bend_twist(0.1, bend=10.0, stretch=1.3)
    pts = centerline([seg], points_per_segment=2000)
    arc = np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))
    assert arc == pytest.approx(0.13, rel=1e-6)


def test_pure_twist_keeps_axis_straight():
    seg = RodStrains.bend_twist(0.08, twist=30.0)
    pts = centerline([seg], points_per_segment=20)
    np.testing.assert_allclose(pts[:, [0, 2]], 0.0, atol=1e-15)
    T = segment_transform(seg)
    np.testing.assert_allclose(T[:3, 3], [0.0, 0.08, 0.0], atol=1e-15)
    # the cross-section (x axis) is rotated by twist * L about the tangent
    phi = 30.0 * 0.08
    np.testing.assert_allclose(T[:3, 0], [np.cos(phi), 0.0, -np.sin(phi)], atol=1e-12)


strain = st.floats(-60.0, 60.0)


@settings(max_examples=40, deadline=None)
@given(strain, strain, strain, st.floats(0.8, 1.5), strain, strain, st.floats(0.8, 1.5))
def test_composition_equals_product_of_transforms(a, b, c, s1, d, e, s2):
    seg1 = RodStrains(0.03, (a, b, c), s1)
    seg2 = RodStrains(0.02, (d, e, 0.5 * a), s2)
    frames = chain([seg1, seg2])
    np.testing.assert_allclose(frames[-1], segment_transform(seg1) @ segment_transform(seg2),
                               atol=1e-13)
    # a segment split in two equals the whole segment (semigroup property)
    half = RodStrains(0.015, seg1.curvature, s1)
    np.testing.assert_allclose(segment_transform(half) @ segment_transform(half),
                               segment_transform(seg1), atol=1e-12)
    R = frames[-1][:3, :3]
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)


def test_small_angle_series_matches_closed_form():
    tiny = RodStrains(1e-3, (1e-3, 2e-3, -1e-3), 1.0)
    T = segment_transform(tiny)
    np.testing.assert_allclose(T[:3, 3], [0.0, 1e-3, 0.0], atol=1e-9)
