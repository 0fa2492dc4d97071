"""How far one command can follow a circle within the tolerance (planning/bounds/band.py): the
tool point's Hessian against finite differences, the Taylor bounds against sampled commands,
the dual bound against a brute-force grid, and the per-configuration arc limit against the
longest command SLSQP finds with that middle configuration."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import least_squares, minimize

from armpath.kinematics import position_jacobian, tool_point_joints, tool_position
from armpath.model.catalog import ur5
from armpath.model.seed_arm import seed_arm
from armpath.planning.bounds.band import (
    Circle,
    _dual_bound,
    arc_limits,
    command_arc_limit,
    taylor_bounds,
    tool_point_hessian,
)

TOL = 0.1


@pytest.fixture(scope="module", params=["seed", "ur5"])
def arm(request):
    return seed_arm() if request.param == "seed" else ur5()


def _finite_hessian(arm, q, h=1e-4):
    n = arm.n_joints
    out = np.zeros((3, n, n))
    for a, b in itertools.product(range(n), repeat=2):
        e, f = np.eye(n)[a] * h, np.eye(n)[b] * h
        P = tool_position(arm, np.stack([q + e + f, q + e - f, q - e + f, q - e - f]))
        out[:, a, b] = (P[0] - P[1] - P[2] + P[3]) / (4 * h * h)
    return out


def test_hessian_matches_finite_differences(arm):
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = np.clip(rng.uniform(-2.5, 2.5, arm.n_joints), arm.lower, arm.upper)
        H = tool_point_hessian(arm, q)
        assert np.abs(H - _finite_hessian(arm, q)).max() < 1e-4 * max(np.abs(H).max(), 1.0)


def test_taylor_bounds_hold_for_sampled_commands(arm):
    """Chord and bend of random commands (joint changes up to the steps, many at a corner of
    the box) lie within the bounds, and so do their differences from the quadratic model."""
    tb = taylor_bounds(arm)
    tip = tool_point_joints(arm)
    steps = np.where(tip, arm.lattice.max_step, 0.0)
    rng = np.random.default_rng(4)
    worst = np.zeros(4)
    for k in range(300):
        m = np.clip(rng.uniform(-3.0, 3.0, arm.n_joints), arm.lower, arm.upper)
        D = steps * (np.sign(rng.uniform(-1, 1, arm.n_joints)) if k % 2 else rng.uniform(-1, 1))
        p0, a, p1 = tool_position(arm, np.stack([m - D / 2, m, m + D / 2]))
        c, w = p1 - p0, (p0 + p1) / 2 - a
        J, H = position_jacobian(arm, m), tool_point_hessian(arm, m)
        model_w = np.einsum("kab,a,b->k", H, D, D) / 8
        worst = np.maximum(
            worst,
            [
                np.linalg.norm(c),
                np.linalg.norm(w),
                np.linalg.norm(c - J @ D),
                np.linalg.norm(w - model_w),
            ],
        )
    assert worst[0] <= tb.chord and worst[1] <= tb.bend
    assert worst[2] <= tb.chord_error and worst[3] <= tb.bend_error
    assert worst[0] > 0.3 * tb.chord  # the corners come near the bound: not a vacuous one


def test_dual_bound_against_a_grid():
    """max g'D over a box and indefinite quadratic constraints: never below a fine grid's
    best feasible point, and within 5 % of it (the relaxation is tight on these)."""
    rng = np.random.default_rng(5)
    for _ in range(6):
        g = rng.normal(size=3)
        steps = rng.uniform(0.5, 1.5, 3)
        A = rng.normal(size=(3, 3))
        A = A + A.T
        jr = rng.normal(size=3)
        limits = np.array([0.5, 0.3])
        axes = [np.linspace(-s, s, 81) for s in steps]
        D = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        ok = (np.einsum("ia,ab,ib->i", D, A, D) <= limits[0]) & ((D @ jr) ** 2 <= limits[1])
        grid = float((D[ok] @ g).max())
        bound = _dual_bound(g, [A, np.outer(jr, jr)], limits, steps)
        assert bound >= grid - 1e-9
        assert bound <= 1.05 * grid + 0.05
        # split boxes: still a bound, and no higher than the one box's
        split = _dual_bound(g, [A, np.outer(jr, jr)], limits, steps, nodes=50)
        assert grid - 1e-9 <= split <= bound + 1e-9
    # no constraint but the box: the box's corner
    g = np.array([1.0, -2.0, 0.5])
    steps = np.array([0.1, 0.2, 0.3])
    assert _dual_bound(g, [], np.zeros(0), steps) == pytest.approx(0.65, rel=1e-9)


def _on_circle(arm, circle, angle, q_start, free=None):
    """A configuration with the tool point on ``circle`` at ``angle`` (least squares from
    ``q_start`` over the joints ``free``, default all)."""
    free = np.ones(arm.n_joints, dtype=bool) if free is None else free
    b = circle.normal
    u = np.cross(b, [1.0, 0.0, 0.0] if abs(b[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(b, u)
    target = circle.centre + circle.radius_mm * (np.cos(angle) * u + np.sin(angle) * v)

    def full(x):
        q = np.array(q_start, dtype=np.float64)
        q[free] = x
        return q

    found = least_squares(
        lambda x: tool_position(arm, full(x)) - target,
        q_start[free],
        bounds=(arm.lower[free], arm.upper[free]),
        xtol=1e-14,
        ftol=1e-14,
    )
    assert np.linalg.norm(tool_position(arm, full(found.x)) - target) < 1e-4
    return full(found.x)


def _moved_inward(arm, circle, q, depth_mm):
    """The configuration nearest ``q`` (minimum-norm steps) whose tool point lies
    ``depth_mm`` nearer the axis of the horizontal ``circle``."""
    inward = (circle.centre - tool_position(arm, q)) * [1.0, 1.0, 0.0]
    target = tool_position(arm, q) + depth_mm * inward / np.linalg.norm(inward)
    moved = q.copy()
    for _ in range(5):
        J = position_jacobian(arm, moved)
        moved = moved + np.linalg.pinv(J) @ (target - tool_position(arm, moved))
    return moved


def _longest_found(arm, circle, m, tries=12, inner=None):
    """The longest arc between the nearest points of a command's ends that SLSQP finds over
    joint changes within the steps, the middle configuration ``m``, the tool point within the
    tolerance at 17 instants (and, given ``inner``, at most that far inside the circle in its
    plane: the half band)."""
    tip = tool_point_joints(arm)
    steps = np.where(tip, arm.lattice.max_step, 0.0)
    instants = np.linspace(-0.5, 0.5, 17)
    b = circle.normal

    def points(D):
        return tool_position(arm, m[None] + instants[:, None] * D[None])

    def distance(P):
        d = P - circle.centre
        along = d @ b
        return np.hypot(np.linalg.norm(d - along[:, None] * b, axis=1) - circle.radius_mm, along)

    def angle(P):
        d = P - circle.centre
        u = d[0] - (d[0] @ b) * b
        u /= np.linalg.norm(u)
        return np.arctan2(d @ np.cross(b, u), d @ u)

    def within(P, share):
        gap = share * TOL - distance(P)
        if inner is None:
            return gap
        d = P - circle.centre
        rho = np.linalg.norm(d - (d @ b)[:, None] * b, axis=1)
        return np.minimum(gap, rho - (circle.radius_mm - share * inner))

    rng = np.random.default_rng(6)
    d = tool_position(arm, m) - circle.centre
    tangent = np.cross(b, d)
    tangent /= np.linalg.norm(tangent)
    along = np.linalg.pinv(position_jacobian(arm, m)[:, tip]) @ tangent
    best = 0.0
    for k in range(tries):
        D0 = np.zeros(arm.n_joints)  # along the tangent, then random ones
        D0[tip] = along * (1.0 + k % 4)
        if k >= 4:
            D0 = rng.uniform(-1, 1, arm.n_joints) * steps * 0.3
        for sign in (1.0, -1.0):
            found = minimize(
                lambda D, sign=sign: -sign * (angle(points(D))[-1]),
                D0,
                method="SLSQP",
                bounds=list(zip(-steps, steps, strict=True)),
                constraints=[{"type": "ineq", "fun": lambda D: within(points(D), 0.995)}],
                options={"maxiter": 300},
            )
            D = found.x
            for _ in range(20):  # one that ends a little outside: a little shorter
                P = points(D)
                if within(P, 1.0).min() >= 0.0:
                    best = max(best, circle.radius_mm * abs(angle(P)[-1]))
                    break
                D = 0.995 * D
    return best


@pytest.mark.parametrize(
    ("which", "circle"),
    [
        ("seed", Circle(np.array([330.0, 60.0, 260.0]), np.array([0.0, 0.0, 1.0]), 25.0)),
        ("ur5", Circle(np.array([330.0, -200.0, 0.0]), np.array([0.0, 0.0, 1.0]), 80.0)),
    ],
)
def test_arc_limit_bounds_the_longest_command_found(which, circle):
    """At configurations on the circle, no command SLSQP finds through them covers more than
    the proven limit, and the limit is at most 15 % above the longest found."""
    arm = seed_arm() if which == "seed" else ur5()
    q = np.asarray(arm.home, dtype=np.float64)
    ratios = []
    for angle in np.linspace(0.0, 2 * np.pi, 4, endpoint=False):
        q = _on_circle(arm, circle, angle, q)
        limit = command_arc_limit(arm, q, circle, TOL)
        found = _longest_found(arm, circle, q)
        assert found <= limit
        ratios.append(limit / found)
    assert max(ratios) <= 1.15, ratios


def test_arc_limit_near_a_singular_wrist():
    """The seed arm with its wrist straight (joint 5 at 0: joints 4 and 6 in line), where its
    null space bends the path both ways (the constraints far from convex): the limit still
    lies within 15 % of the longest command SLSQP finds."""
    arm = seed_arm()
    circle = Circle(np.array([330.0, 60.0, 260.0]), np.array([0.0, 0.0, 1.0]), 25.0)
    start = np.radians([96.1, 9.1, 105.2, 24.3, 0.0, 0.0])
    free = np.array([True, True, True, True, False, False])
    q = _on_circle(arm, circle, np.radians(130.0), start, free)
    assert q[4] == 0.0
    found = _longest_found(arm, circle, q)
    limit = command_arc_limit(arm, q, circle, TOL)
    assert found <= limit <= 1.15 * found


def test_arc_limit_for_a_middle_anywhere_in_the_band():
    """Taken anywhere within the tolerance (at its inner edge, the chord's most room), the
    limit at a configuration on the circle covers the longest command SLSQP finds through a
    configuration nearby whose tool point lies at the inner edge, and lies above the limit
    for its own middle."""
    arm = seed_arm()
    circle = Circle(np.array([330.0, 60.0, 260.0]), np.array([0.0, 0.0, 1.0]), 25.0)
    q = np.asarray(arm.home, dtype=np.float64)
    for angle in (0.5, 2.5):
        q = _on_circle(arm, circle, angle, q)
        # the nearest configuration with its tool point at the inner edge (minimum-norm steps)
        q_inner = _moved_inward(arm, circle, q, 0.99 * TOL)
        assert np.abs(q_inner - q).max() < np.radians(0.05)
        anywhere = command_arc_limit(arm, q, circle, TOL, anywhere=True)
        assert anywhere > command_arc_limit(arm, q, circle, TOL)
        found = _longest_found(arm, circle, q_inner)
        assert found <= anywhere <= 1.15 * found


def test_the_half_band_s_limit_covers_the_longest_command_found_within_it():
    """A band only 0.02 mm deep inside the circle (the tool point kept out of a solid whose
    face the circle lies on; 0.1 mm outside): at configurations of the seed arm on its 25 mm
    circle, their tool point moved to that inner edge, no command SLSQP finds within the half
    band covers more than the limit with ``inner_mm``, which lies within 20 % of the longest
    found and below the whole band's limit."""
    arm = seed_arm()
    circle = Circle(np.array([330.0, 60.0, 260.0]), np.array([0.0, 0.0, 1.0]), 25.0)
    inner = 0.02
    q = np.asarray(arm.home, dtype=np.float64)
    for angle in (0.5, 2.5):
        q = _on_circle(arm, circle, angle, q)
        q_inner = _moved_inward(arm, circle, q, 0.99 * inner)
        half = command_arc_limit(arm, q, circle, TOL, anywhere=True, inner_mm=inner)
        assert half < command_arc_limit(arm, q, circle, TOL, anywhere=True)
        found = _longest_found(arm, circle, q_inner, inner=inner)
        assert found <= half <= 1.2 * found
        assert command_arc_limit(arm, q, circle, TOL, anywhere=True, inner_mm=TOL) == (
            command_arc_limit(arm, q, circle, TOL, anywhere=True)
        )


def test_a_batchs_limits_are_each_configurations_own():
    """:func:`arc_limits` over a batch (compiled, on threads) gives each configuration's one-box
    limit, as :func:`command_arc_limit` with one box gives it alone; 0 out of the band."""
    arm = seed_arm()
    circle = Circle(np.array([330.0, 60.0, 260.0]), np.array([0.0, 0.0, 1.0]), 25.0)
    q = np.asarray(arm.home, dtype=np.float64)
    qs = []
    for angle in np.linspace(0.0, 2 * np.pi, 20, endpoint=False):
        q = _on_circle(arm, circle, angle, q)
        qs.append(q)
    qs.append(np.asarray(arm.home, dtype=np.float64))  # far from the circle
    batch = arc_limits(arm, np.array(qs), circle, TOL, anywhere=False)
    alone = [command_arc_limit(arm, c, circle, TOL, nodes=1) for c in qs]
    assert batch == pytest.approx(alone, rel=1e-12)
    assert batch[-1] == 0.0 and np.all(batch[:-1] > 2.0)
