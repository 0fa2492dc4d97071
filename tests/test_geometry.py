"""Analytic obstacle distances against brute force and an independent inside test."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import independent
from armpath.errors import InvalidInputError
from armpath.geometry import (
    Box,
    Capsule,
    CollisionWorld,
    HalfSpace,
    Sphere,
    WallThickness,
    cone_frustum,
    cylinder,
    hollow_frustum,
)
from armpath.geometry.primitives import TOUCHING
from armpath.model import seed_arm
from armpath.scenes import seed_scene

WORKPIECE = {
    conv: hollow_frustum("workpiece", (210, 0, 0), 180, 168, 96, 8, conv)
    for conv in ("normal", "horizontal")
}


def test_wall_conventions():
    normal, horizontal = WORKPIECE["normal"], WORKPIECE["horizontal"]
    assert normal.horizontal_wall == pytest.approx(8 * np.sqrt(1 + 0.4**2))
    assert normal.horizontal_wall == pytest.approx(8.6163, abs=1e-4)
    assert horizontal.horizontal_wall == 8.0
    np.testing.assert_allclose(
        normal.inner_radius([0, 90, 180]), [168 - 8.6163, 132 - 8.6163, 96 - 8.6163], atol=1e-4
    )
    # the normal thickness of the wall is 8: a point on the outer surface is 8 from the inner one
    p = np.array([[210 + 132.0, 0, 90]])  # outer surface at z = 90
    n = np.array([1.0, 0, 0.4]) / np.sqrt(1.16)  # outward normal of the cone wall
    inner = p - 8 * n
    assert WORKPIECE["normal"].signed_distance(inner)[0] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("conv", ["normal", "horizontal"])
def test_signed_distance_against_brute_force(conv):
    rng = np.random.default_rng(7)
    pts = np.column_stack(
        [rng.uniform(0, 420, 4000), rng.uniform(-210, 210, 4000), rng.uniform(-20, 220, 4000)]
    )
    # many points near the walls too
    theta = rng.uniform(0, 2 * np.pi, 2000)
    z = rng.uniform(-5, 190, 2000)
    r = 168 - 0.4 * z + rng.normal(0, 6, 2000)
    near = np.column_stack([210 + r * np.cos(theta), r * np.sin(theta), z])
    pts = np.vstack([pts, near])
    ours = WORKPIECE[conv].signed_distance(pts)
    ref = independent.Workpiece(conv).distance(pts)
    np.testing.assert_allclose(ours, ref, atol=1e-9)
    # the sign is exactly the independent inside test
    inside = independent.Workpiece(conv).inside(pts)
    assert np.all((ours < 0) == inside | (np.abs(ours) < 1e-9))


def test_known_distances():
    w = WORKPIECE["normal"]
    # above the rim centre line, straight up
    rim_mid = 96 - 8.6163 / 2
    assert w.signed_distance([[210 + rim_mid, 0, 200]])[0] == pytest.approx(20.0)
    # on the axis above the bottom plate, distance to the plate top (z = 8)
    assert w.signed_distance([[210, 0, 50]])[0] == pytest.approx(42.0)
    # inside the bottom plate
    assert w.signed_distance([[210, 0, 3]])[0] == pytest.approx(-3.0)
    # outside on the table next to the foot: the closest point is the foot's outer corner
    assert w.signed_distance([[210 + 180, 0, 0]])[0] == pytest.approx(12.0)
    # beside the wall at mid height: horizontal gap times the cosine of the wall's slope
    assert w.signed_distance([[210 + 142, 0, 90]])[0] == pytest.approx(10.0 / np.sqrt(1.16))


def _dense_min(obstacle, a, b, samples=20001):
    s = np.linspace(0, 1, samples)
    return np.array(
        [obstacle.signed_distance(a[i] + s[:, None] * (b[i] - a[i])).min() for i in range(len(a))]
    )


@pytest.mark.parametrize("convention", ["normal", "horizontal"])
def test_segment_distance_against_dense_sampling(convention):
    rng = np.random.default_rng(11)
    w = WORKPIECE[convention]
    a = rng.uniform([-50, -250, -10], [450, 250, 300], (300, 3))
    b = a + rng.normal(0, 150, (300, 3))
    ours = w.segment_distance(a, b)
    dense = _dense_min(w, a, b)
    spacing = np.linalg.norm(b - a, axis=-1) / 20000
    # never below what 1-Lipschitz allows between dense samples (every value is attained) ...
    assert np.all(ours >= dense - spacing / 2 - 1e-9)
    # ... and for segments that stay outside, exact: never above the dense minimum
    outside = dense > spacing
    assert outside.sum() > 150 and (~outside).sum() > 30
    assert np.all(ours[outside] <= dense[outside] + 1e-9)
    # segments that enter the wall touch or go below zero
    assert np.all(ours[dense < -spacing] <= TOUCHING)


def test_segment_distance_exact_on_constructed_tangents():
    """Segments built to touch the outer cone, the rim circle and the inner floor circle."""
    w = WORKPIECE["normal"]
    slope = (168 - 96) / 180
    n_out = np.array([1.0, 0.0, slope]) / np.hypot(1.0, slope)  # outward normal of the cone
    foot = np.array([210 + 168 - slope * 90, 0.0, 90.0])  # on the outer wall at z = 90
    tangent = np.array([0.0, 1.0, 0.0])  # horizontal tangent there (a circle of the cone)
    gen = np.array([-slope, 0.0, 1.0]) / np.hypot(1.0, slope)  # along the generator
    for gap in (0.0, 0.3, 5.0):
        c = foot + gap * n_out
        # along the generator the distance is constant = gap
        d = w.segment_distance([c - 40 * gen], [c + 40 * gen])[0]
        assert d == pytest.approx(gap, abs=1e-9)
        # a horizontal chord touching the cone from outside: the minimum is at the midpoint
        d = w.segment_distance([c - 50 * tangent], [c + 50 * tangent])[0]
        assert d == pytest.approx(gap, abs=1e-9)
    # the rim: a segment passing 2 mm above the top circle of the outer wall
    rim = np.array([210 + 96.0, 0.0, 180.0])
    d = w.segment_distance([rim + np.array([-30, 0, 2])], [rim + np.array([30, 0, 2])])[0]
    assert d == pytest.approx(2.0, abs=1e-9)


def test_segment_distance_bounds_bracket_the_true_minimum():
    rng = np.random.default_rng(12)
    w = WORKPIECE["normal"]
    a = rng.uniform([-50, -250, -10], [450, 250, 300], (300, 3))
    b = a + rng.normal(0, 150, (300, 3))
    dense = _dense_min(w, a, b)
    slack = np.linalg.norm(b - a, axis=-1) / 20000 / 2  # how far below the samples the truth can be
    value, lower = w.segment_distance_bounds(a, b)
    assert np.all(lower <= dense + 1e-9) and np.all(value >= dense - slack - 1e-9)
    outside = value > TOUCHING
    # outside, the bound is the exact value less a rounding allowance
    assert np.all(value[outside] - lower[outside] <= 1e-6)
    # touching or entering: no bound unless asked for
    assert np.all(np.isneginf(lower[~outside]))
    # asking to certify 'clearance >= 0' bounds the depth of the entering segments to 0.01 mm
    value, lower = w.segment_distance_bounds(a, b, certify=0.0)
    assert np.all(lower <= dense + 1e-9) and np.all(np.isfinite(lower))
    assert np.all(value[~outside] - lower[~outside] <= 0.01 + 1e-9)
    assert np.all(value[~outside] <= dense[~outside] + 1e-9)


def test_a_big_batch_split_between_threads_equals_one_call(monkeypatch):
    """A batch of segments past the threads' threshold is measured in slices on threads
    (forced here, whatever the machine's load): the values are those of one call over the
    whole batch, in order, and bracket dense sampling as one call's do."""
    import os

    from armpath import jit
    from armpath.geometry import kernels
    from armpath.geometry.primitives import REVOLUTION_THREAD_BATCH

    w = WORKPIECE["normal"]
    rng = np.random.default_rng(13)
    n = 2 * REVOLUTION_THREAD_BATCH + 7
    a = rng.uniform([-50, -250, -10], [450, 250, 300], (n, 3))
    b = a + rng.normal(0, 150, (n, 3))
    whole = kernels.segments_to_revolution(a, b, w.origin, w.axis, w.profile, w.boundary_edges)
    calls = []
    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    monkeypatch.setattr(jit, "threads_pay_off", lambda n_items, t: calls.append(n_items) or True)
    split = w.segment_distance_exact(a, b)
    assert calls == [n]
    np.testing.assert_array_equal(split, whole)
    few = rng.choice(n, 40, replace=False)
    dense = _dense_min(w, a[few], b[few])
    spacing = np.linalg.norm(b[few] - a[few], axis=-1) / 20000
    assert np.all(split[few] >= dense - spacing / 2 - 1e-9)
    outside = dense > spacing
    assert np.all(split[few][outside] <= dense[outside] + 1e-9)


def _random_segments(rng, n, center, spread, length):
    a = center + rng.normal(0, spread, (n, 3))
    return a, a + rng.normal(0, length, (n, 3))


@pytest.mark.parametrize(
    "make",
    [
        lambda: Sphere("s", [10, -20, 30], 25),
        lambda: Capsule("c", [0, 0, 0], [40, 30, -20], 12),
        lambda: Box(
            "b", [5, 5, 5], [30, 10, 20], Rotation.from_rotvec([0.3, -0.5, 0.9]).as_matrix()
        ),
        lambda: cylinder("cy", [0, 0, -20], [0.2, 0.4, 1.0], 25, 60),
        lambda: cone_frustum("cf", [0, 0, -20], [1.0, 0.0, 0.3], 40, 10, 50),
        lambda: cone_frustum("cone", [0, 0, -20], [0.0, 0.0, 1.0], 40, 0, 50),
    ],
    ids=["sphere", "capsule", "box", "cylinder", "frustum", "cone"],
)
def test_primitive_segment_distance_against_dense_sampling(make):
    obstacle = make()
    rng = np.random.default_rng(5)
    a, b = _random_segments(rng, 400, np.zeros(3), 60, 50)
    value, lower = obstacle.segment_distance_bounds(a, b, certify=0.0)
    dense = _dense_min(obstacle, a, b, 4001)
    spacing = np.linalg.norm(b - a, axis=-1) / 4000
    assert np.all(value <= dense + 1e-9)
    assert np.all(lower <= dense + 1e-9)
    assert np.all(value >= dense - spacing / 2 - 1e-9)  # exact, inside too (certified)
    assert (dense < 0).sum() > 10 and (dense > 0).sum() > 100


def test_primitive_point_distances_closed_form():
    box = Box("b", [1, 2, 3], [1, 2, 3])
    np.testing.assert_allclose(
        box.signed_distance([[1, 2, 3], [4, 2, 3], [3, 5, 7]]), [-1, 2, np.sqrt(3)]
    )
    cyl = cylinder("c", [0, 0, 0], [0, 0, 1], 2, 10)
    np.testing.assert_allclose(
        cyl.signed_distance([[0, 0, 5], [5, 0, 5], [0, 0, 13], [5, 0, 14]]), [-2, 3, 3, 5]
    )
    ball = Sphere("s", [0, 0, 0], 2)
    np.testing.assert_allclose(ball.signed_distance([[3, 4, 0]]), [3])
    for bad in (
        lambda: Sphere("s", [0, 0], 1),
        lambda: Sphere("s", [0, 0, 0], -1),
        lambda: Box("b", [0, 0, 0], [1, 1, 0]),
        lambda: Box("b", [0, 0, 0], [1, 1, 1], np.diag([1, 1, -1])),
        lambda: cylinder("c", [0, 0, 0], [0, 0, 0], 1, 1),
        lambda: cone_frustum("f", [0, 0, 0], [0, 0, 1], 0, 0, 1),
    ):
        with pytest.raises(InvalidInputError):
            bad()


def test_half_space():
    table = HalfSpace("table", np.zeros(3), np.array([0, 0, 2.0]))
    np.testing.assert_allclose(table.signed_distance([[1, 2, 3], [0, 0, -4]]), [3, -4])
    np.testing.assert_allclose(table.segment_distance([[0, 0, 5]], [[9, 9, -1]]), [-1])


def test_bad_obstacles_are_refused():
    with pytest.raises(InvalidInputError, match="wall"):
        hollow_frustum("w", (0, 0, 0), 180, 168, 96, 200)
    with pytest.raises(InvalidInputError, match="one of"):
        hollow_frustum("w", (0, 0, 0), 180, 168, 96, 8, "diagonal")
    with pytest.raises(InvalidInputError, match="normal"):
        HalfSpace("t", np.zeros(3), np.zeros(3))


def test_arm_clearance_at_home():
    arm = seed_arm()
    world = seed_scene().world
    q = arm.home
    c = world.clearances(arm, q)
    parts = [p.name for p in world.parts(arm)]
    assert parts == ["BC", "CD", "DE", "DE tip"]
    # at home BC, CD run along +y at z = 140 and DE points down to z = 75
    table = world.obstacle_names.index("table")
    np.testing.assert_allclose(c[:, table], [140, 140, 80, 75], atol=1e-9)
    # CD passes over the workpiece rim: z = 140 is below the rim (180), so it goes through the wall?
    # No: CD spans y in [255, 510] at x = 0, far from the workpiece (x >= 42).
    wp = world.obstacle_names.index("workpiece")
    ref = (
        independent.Workpiece("normal")
        .distance(np.array([[0, y, 140] for y in np.linspace(0, 510, 5101)]))
        .min()
    )
    assert c[:2, wp].min() == pytest.approx(ref, abs=0.02)
    assert CollisionWorld((), 1.0).describe()["clearance_margin_mm"] == 1.0
    assert WallThickness("normal") is WallThickness.NORMAL


def test_broad_phase_verdict_equals_the_exact_clearances():
    """``satisfied`` skips exact distances behind enclosing balls; its verdict must not change."""
    arm = seed_arm()
    extra = (
        Box("box", [-200, 200, 50], [40, 40, 50], Rotation.from_rotvec([0, 0, 0.5]).as_matrix()),
        Sphere("ball", [0, -300, 200], 40),
        cylinder("post", [-250, -250, 0], [0, 0, 1], 30, 300),
        Capsule("bar", [100, -300, 300], [300, 100, 250], 20),
        cone_frustum("cone", [-300, 0, 0], [0, 0, 1], 80, 20, 150),
    )
    world = CollisionWorld(seed_scene().world.obstacles + extra)
    rng = np.random.default_rng(8)
    lim = np.radians([180, 125, 138, 180, 133.5, 180])
    q = rng.uniform(-lim, lim, (4000, 6))
    values, _ = world.pair_clearances(arm, q)
    for margin in (0.0, 1.4, 25.0):
        exact = np.all(values - world.required(arm) >= margin, axis=-1)
        np.testing.assert_array_equal(world.satisfied(arm, q, margin), exact)
        assert 0.05 < exact.mean() < 0.95
    ball_center, ball_radius = extra[0].enclosing_ball()
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * 40
    assert np.all(np.linalg.norm(corners, axis=-1) <= ball_radius + 1e-9)
    for o in extra[2:]:
        center, radius = o.enclosing_ball()
        # no point of the surface beyond the ball: sample far points along random directions
        dirs = rng.normal(size=(500, 3))
        dirs /= np.linalg.norm(dirs, axis=-1, keepdims=True)
        assert np.all(o.signed_distance(center + (radius + 1e-6) * dirs) > 0)
    assert ball_center.shape == (3,)


def test_a_segment_through_the_wall_is_never_reported_as_touching():
    """Regression (stress suite): a segment that enters the hollow workpiece's wall and leaves it
    again (both ends outside the solid) was given the value 0 of its crossings, which the tool
    tip's rule (>= 0) accepted. Its value must be negative and at least as deep as the
    independent distance (shapely in the profile plane) sampled along it."""
    wp = seed_scene().world.obstacles[1]
    rng = np.random.default_rng(7)
    ref = independent.Workpiece("normal")
    # radial segments at random heights and angles from outside the cone into the cavity
    z = rng.uniform(15.0, 170.0, 200)
    phi = rng.uniform(0.0, 2 * np.pi, 200)
    r_out = 168.0 - 0.4 * z
    u = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], -1)
    centre = np.stack([np.full_like(z, 210.0), np.zeros_like(z), z], -1)
    a = centre + (r_out + 5.0)[:, None] * u
    b = centre + (r_out - 25.0)[:, None] * u
    assert np.all(ref.distance(a) > 0) and np.all(ref.distance(b) > 0)
    value, _ = wp.segment_distance_bounds(a, b)
    t = np.linspace(0.0, 1.0, 3001)
    dense = ref.distance((a[:, None] + t[None, :, None] * (b - a)[:, None]).reshape(-1, 3))
    deepest = dense.reshape(len(z), -1).min(axis=1)
    assert np.all(deepest < -3.0)  # through an 8 mm wall
    assert np.all(value <= deepest + 1e-6)
    assert np.all(value >= -8.616 / 2 - 1e-6)  # no deeper than half the wall
