"""Issue 21: the chart of tool directions with the family's singular directions blown up
(``armpath.planning.bounds.chart``), checked against independent truth.

* the chart covers every real direction: each one's virtual direction, worked out here from
  the chart's definition (the angle from the centre stretched back, the azimuth kept), maps
  onto it; the circle maps to :data:`RING_RADIUS`, the chart's edge and beyond to themselves;
* the UR5's singular directions at a point are where its wrist is singular (joint 5 at 0 or
  180 deg: the axes of joints 4 and 6 in line, which the kinematics of the UR family gives,
  not the search): every direction found has such a member and lies across the base axis,
  and every member of a fine brute-force sampling with joint 5 within half a degree of it lies
  near a direction found;
* a one-target bound from a wrist-singular start, whose best goal lies 13 deg from the
  singularity, is never above the fewest whole commands to the clear members of a brute-force
  sampling of 100,000 tool directions and equals it (without the blow-ups it stays at 3 of 7).
"""

from __future__ import annotations

import numpy as np
import pytest

from armpath.geometry import CollisionWorld
from armpath.geometry.curves import Polyline
from armpath.kinematics import tool_position
from armpath.model.catalog import resolve_model
from armpath.planning import bounds
from armpath.planning.bounds import chart, sampling
from armpath.planning.trace.family import curve_family, fibonacci_directions


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_the_blown_up_chart_covers_every_direction():
    rng = np.random.default_rng(5)
    caps = (
        chart.BlowUp(_unit(np.array([0.3, -0.2, 0.9])), 0.1, 0.2),
        chart.BlowUp(_unit(np.array([-0.5, 0.8, -0.1])), 0.05, 0.1),
    )
    real = _unit(rng.normal(size=(4000, 3)))
    # the virtual direction of each real one, from the chart's definition
    virtual = real.copy()
    for cap in caps:
        r = np.arccos(np.clip(real @ cap.center, -1.0, 1.0))
        near = r < cap.outer
        rho = cap.inner + (r[near] - chart.RING_RADIUS) / (cap.outer - chart.RING_RADIUS) * (
            cap.outer - cap.inner
        )
        across = _unit(real[near] - np.outer(real[near] @ cap.center, cap.center))
        virtual[near] = np.cos(rho)[:, None] * cap.center + np.sin(rho)[:, None] * across
    outside = chart.outside_holes(virtual, caps)
    close = (
        np.array([min(np.arccos(np.clip(v @ c.center, -1, 1)) for c in caps) for v in real])
        < chart.RING_RADIUS
    )
    assert np.all(outside | close)
    np.testing.assert_allclose(chart.to_real(virtual[~close], caps), real[~close], atol=1e-12)
    for k, cap in enumerate(caps):
        on = chart.ring(cap, 36)
        assert np.all(chart.ring_of(on, caps) == k)
        got = np.arccos(np.clip(chart.to_real(on, caps) @ cap.center, -1.0, 1.0))
        np.testing.assert_allclose(got, chart.RING_RADIUS, atol=1e-10)  # arccos near 1
        # a point of the hole is moved out onto the circle, its azimuth kept
        inside = _unit(cap.center + 0.3 * cap.inner * _unit(np.cross(cap.center, [1.0, 0, 0])))
        out = chart.snapped(inside[None], caps)[0]
        assert np.arccos(out @ cap.center) == pytest.approx(cap.inner, abs=1e-12)
        assert np.cross(cap.center, inside) @ np.cross(cap.center, out) > 0
    far = real[chart.outside_holes(real, caps)]
    far = far[
        [min(np.arccos(np.clip(v @ c.center, -1, 1)) - c.outer for c in caps) > 0 for v in far]
    ]
    np.testing.assert_array_equal(chart.to_real(far, caps), far)


@pytest.fixture(scope="module")
def ur5_point():
    arm = resolve_model("ur5")
    E = np.array([450.0, 95.0, 100.0])
    curve = Polyline("t", np.array([E, E + np.array([1.0, 0.0, 0.0])]))
    fam = curve_family(arm, CollisionWorld(()), curve)
    return arm, fam, E


def test_the_ur5_singular_directions_are_where_its_wrist_is_singular(ur5_point):
    _, fam, E = ur5_point
    sampler = sampling.FamilySampler(fam, 0.05)
    caps = sampler._blow_ups(E, None)
    assert len(caps) >= 2
    centers = np.array([c.center for c in caps])
    for c in centers:
        q, _ = fam.members(E, c[None])
        assert np.min(np.abs(np.sin(q[:, 4]))) < 1e-6  # a member with the wrist singular
        assert abs(c[2]) < 1e-6  # along joint 4's axis, across the base's
    # every member of a brute-force sampling near the singular wrist lies near a centre
    dirs = fibonacci_directions(60000)
    q, index = fam.members(E, dirs)
    near = np.abs(np.sin(q[:, 4])) < np.sin(np.radians(0.5))
    assert np.any(near)
    angle = np.degrees(np.arccos(np.clip(dirs[index[near]] @ centers.T, -1.0, 1.0))).min(axis=1)
    assert angle.max() < 1.0


def test_a_bound_through_the_singular_wrist_agrees_with_brute_force():
    arm = resolve_model("ur5")
    start = arm.lattice.to_joint(arm.lattice.from_display([42, 92, 139, -105, -180, 118], "s"))
    target = tool_position(arm, start) + np.array([-23.0, 27.0, -143.0])
    curve = Polyline("t", np.array([target, target + np.array([1.0, 0.0, 0.0])]))
    fam = curve_family(arm, CollisionWorld(()), curve)
    # brute force: the fewest whole commands to a clear member of 100,000 directions
    sampler = sampling.FamilySampler(fam, 0.05, q_start=start)
    dirs = fibonacci_directions(100_000)
    q, index = fam.members(target, dirs)
    clear = fam.world.slack(arm, q) >= 0.0
    exact = sampling.Layer(
        sampler.units(q[clear]), np.zeros((int(clear.sum()), 5)), q[clear], dirs[index[clear]]
    )
    brute = float(sampler.distance_from(start, exact, whole=True).min())
    assert brute == 7.0
    b, _ = bounds.tour_bound(fam, start, target[None], 0.05, [(0,)], rounds=4)
    assert b.commands <= brute
    assert b.commands == brute
