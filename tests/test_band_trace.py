"""The band bound of a trace along a circle (planning/bounds/band_trace.py): the fitted circle
against the curve's own geometry, the family's arc limit against the longest commands SLSQP
finds anywhere on the circle, the least approach against SLSQP's nearest configuration on it,
and the bound against the plans the tracer makes."""

from __future__ import annotations

import itertools
import math
import re

import numpy as np
import pytest
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from armpath.geometry import CollisionWorld
from armpath.geometry.curves import ParametricCurve, Polyline
from armpath.ik.solve import complete_solver
from armpath.kinematics import position_jacobian, tool_point_joints, tool_position
from armpath.model.catalog import ur5
from armpath.model.seed_arm import seed_arm
from armpath.planning.bounds import band_trace
from armpath.planning.bounds.band import Circle
from armpath.planning.bounds.band_trace import (
    WINDOW_FIT_SHARE,
    WINDOW_HALF_MM,
    FamilyLimit,
    LocalBand,
    _band_over,
    _cell_limit,
    _curve_arcs,
    _largest_cell,
    _stretch_and_slop,
    along_commands,
    family_arc_limit,
    fitted_circle,
    least_approach,
    local_arc_limits,
)
from armpath.planning.bounds.sampling import FamilySampler
from armpath.planning.trace.family import curve_family, solve_frames
from test_band import TOL, _longest_found, _on_circle

CENTRE, RADIUS = np.array([330.0, 60.0, 260.0]), 25.0


def _seed_circle():
    return ParametricCurve(
        "circle", f"{CENTRE[0]} + {RADIUS}*cos(t)", f"{CENTRE[1]} + {RADIUS}*sin(t)",
        f"{CENTRE[2]}", 0.0, 2 * np.pi,
    )  # fmt: skip


def test_fitted_circle_of_a_tilted_circle_a_polygon_and_an_ellipse():
    """A circle in a tilted plane is found exactly (centre, radius, normal); a regular polygon
    inscribed in a circle lies within its sagitta of the fitted one and farther than half of
    it; an ellipse is no circle."""
    curve = ParametricCurve(
        "tilted", "100 + 40*cos(t)", "-50 + 40*sin(t)*cos(0.5)", "200 + 40*sin(t)*sin(0.5)",
        0.0, 2 * np.pi,
    )  # fmt: skip
    circle, deviation = fitted_circle(curve, [(0.0, curve.length)])
    assert deviation < 1e-6
    assert circle.radius_mm == pytest.approx(40.0, abs=1e-6)
    assert np.allclose(circle.centre, [100.0, -50.0, 200.0], atol=1e-6)
    assert abs(abs(circle.normal @ [0.0, -math.sin(0.5), math.cos(0.5)]) - 1.0) < 1e-9
    sides, R = 24, 50.0
    angles = 2 * np.pi * np.arange(sides) / sides
    polygon = Polyline("polygon", np.column_stack([R * np.cos(angles), R * np.sin(angles),
                                                   np.zeros(sides)]), closed=True)  # fmt: skip
    sagitta = R * (1.0 - math.cos(math.pi / sides))
    _, deviation = fitted_circle(polygon, [(0.0, polygon.length)])
    assert 0.5 * sagitta - 1e-3 <= deviation <= sagitta + 1e-9
    ellipse = ParametricCurve("ellipse", "60*cos(t)", "40*sin(t)", "0", 0.0, 2 * np.pi)
    assert fitted_circle(ellipse, [(0.0, ellipse.length)])[1] > 5.0


@pytest.fixture(scope="module")
def free_circle():
    arm = seed_arm()
    return arm, curve_family(arm, CollisionWorld(()), _seed_circle())


@pytest.mark.slow  # 34 s, the quick run's longest (CI runs it)
def test_family_limit_covers_the_longest_commands_found(free_circle):
    """The seed arm in free space on the README's 25 mm circle: no command SLSQP finds
    through members at six points of the circle (two configurations each, from different
    starts) or through the sample whose cell gives the limit (its tool point moved to the
    band's inner edge) covers more than the family's
    limit, which lies within 40 % of the longest found (the sample's own limit, and its
    neighbours' widening, above it)."""
    arm, fam = free_circle
    circle = Circle(CENTRE, np.array([0.0, 0.0, 1.0]), RADIUS)
    sampler = FamilySampler(fam, TOL, 60, np.asarray(arm.home, dtype=np.float64))
    layers = [fam.curve.length * np.arange(6) / 6]
    band = LocalBand.of_circle(circle, TOL)
    limit = family_arc_limit(sampler, lambda _s: band, layers, cyclic=True, directions=60)
    assert limit.samples > 100 and limit.refined >= 1
    assert limit.arc_mm >= limit.sample_arc_mm
    # through the configuration nearest the sample that gives the limit whose tool point lies
    # at the band's inner edge (where the limit takes the middle: the most room)
    q = limit.q.copy()
    inward = (CENTRE - tool_position(arm, q)) * [1.0, 1.0, 0.0]
    target = tool_position(arm, q) + 0.99 * TOL * inward / np.linalg.norm(inward)
    for _ in range(5):
        q = q + np.linalg.pinv(position_jacobian(arm, q)) @ (target - tool_position(arm, q))
    found = [_longest_found(arm, circle, q)]
    at = [limit.s_mm]
    rng = np.random.default_rng(7)
    for angle in np.linspace(0.0, 2 * np.pi, 6, endpoint=False):
        for _ in range(2):
            start = np.clip(np.asarray(arm.home) + rng.normal(0.0, 0.4, 6), arm.lower, arm.upper)
            found.append(_longest_found(arm, circle, _on_circle(arm, circle, angle, start), 6))
            at.append(RADIUS * angle)
    assert max(found) <= limit.arc_mm
    assert limit.arc_mm <= 1.4 * max(found)
    # and none covers more than the limit where its middle lies (the layers' own)
    local = local_arc_limits(limit, np.array(at), True, 0.0, fam.curve.length)
    assert np.all(np.array(found) <= local) and np.all(local <= limit.arc_mm)
    # one limit per layer: the six asked for and those the splits added halfway between them
    assert limit.layer_arc_mm.size == limit.layer_s_mm.size >= 6
    assert set(np.round(layers[0], 6)) <= set(np.round(limit.layer_s_mm, 6))
    assert limit.layer_arc_mm.max() == limit.arc_mm


def _off(arm, q, target):
    return np.linalg.norm(tool_position(arm, q) - target)


def _nearest_on_circle(arm, start, steps, angle, seed):
    """SLSQP's least largest-joint distance (commands) from ``start`` to a configuration
    whose tool point lies within the tolerance of the circle point at ``angle``."""
    target = CENTRE + RADIUS * np.array([math.cos(angle), math.sin(angle), 0.0])
    rng = np.random.default_rng(seed)
    q0 = _on_circle(arm, Circle(CENTRE, np.array([0.0, 0.0, 1.0]), RADIUS), angle,
                    np.clip(start + rng.normal(0.0, 0.3, 6), arm.lower, arm.upper))  # fmt: skip
    x0 = np.r_[q0, np.abs((q0 - start) / steps).max()]
    found = minimize(
        lambda x: x[-1],
        x0,
        method="SLSQP",
        bounds=[*zip(arm.lower, arm.upper, strict=True), (0.0, None)],
        constraints=[
            {"type": "ineq", "fun": lambda x: x[-1] - np.abs((x[:-1] - start) / steps)},
            {"type": "ineq", "fun": lambda x: 0.99 * TOL - _off(arm, x[:-1], target)},
        ],
        options={"maxiter": 300},
    )
    q = found.x[:-1]
    if np.linalg.norm(tool_position(arm, q) - target) > TOL:
        return math.inf
    return float(np.abs((q - start) / steps)[tool_point_joints(arm)].max())


def test_least_approach_is_below_the_nearest_configuration_found(free_circle):
    """From the seed arm's home, the least approach to the circle is no more than the least
    largest-joint distance SLSQP finds to a configuration on it (from twelve points round
    it, two starts each), and within two commands of it."""
    arm, fam = free_circle
    start = np.asarray(arm.home, dtype=np.float64)
    steps = arm.lattice.max_step
    bound = least_approach(fam, start, [(0.0, fam.curve.length)], TOL, 10.0, 600)
    found = min(
        _nearest_on_circle(arm, start, steps, angle, seed)
        for angle in np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
        for seed in range(2)
    )
    assert bound <= found
    assert found - bound <= 2.0


def test_splitting_the_nearest_cells_raises_the_least_approach_below_brute_force(monkeypatch):
    """A UR5 from its home to the arc 400-440 mm along an 80 mm circle, where its wrist lies
    near its straight pose: splitting the nearest cells of directions and of the curve
    raises the least approach by more than a command and a half over the even sampling
    alone, and it stays at or below, and within a command of, the least largest-joint
    distance (the tool point's joints, each the shorter way round) to any solution of the
    arm's closed-form IK at 20,000 random tool rotations at each of nine points of the arc.
    Its progress tells each whole command the bound passes, once."""
    arm = ur5()
    centre, radius = np.array([330.0, -200.0, 150.0]), 80.0
    curve = ParametricCurve(
        "ur5 circle", f"{centre[0]} + {radius}*cos(t)", f"{centre[1]} + {radius}*sin(t)",
        f"{centre[2]}", 0.0, 2 * np.pi,
    )  # fmt: skip
    fam = curve_family(arm, CollisionWorld(()), curve)
    start = np.asarray(arm.home, dtype=np.float64)
    span = (400.0, 440.0)
    told: list[str] = []
    split = least_approach(fam, start, [span], TOL, on_progress=told.append)
    # each whole command the bound passes is told once, the last at or below the bound
    said = [float(re.search(r"at least ([0-9.]+) commands", t)[1]) for t in told]
    assert said and all(math.floor(a) < math.floor(b) for a, b in itertools.pairwise(said))
    assert said[-1] <= split + 0.005 and math.floor(said[-1]) == math.floor(split)
    monkeypatch.setattr(band_trace, "APPROACH_SPLIT_ROUNDS", 0)
    monkeypatch.setattr(band_trace, "APPROACH_SPLIT_POINTS", 0)
    even = least_approach(fam, start, [span], TOL)
    solver, tip = complete_solver(arm), np.asarray(tool_point_joints(arm))
    rng, brute = np.random.default_rng(0), math.inf
    for s in np.linspace(*span, 9):
        E = centre + radius * np.array([math.cos(s / radius), math.sin(s / radius), 0.0])
        q, _ = solve_frames(arm, solver, E, Rotation.random(20_000, random_state=rng).as_matrix())
        q = q[arm.within_limits(q)]
        turned = np.remainder(q - start + np.pi, 2 * np.pi) - np.pi
        brute = min(brute, float(np.abs(turned / arm.lattice.max_step)[:, tip].max(axis=1).min()))
    assert even + 1.5 < split <= brute
    assert brute - split <= 1.0


def test_the_lazily_refined_largest_cell_is_every_cells_refined_in_full():
    """On random limits and neighbours (some samples alone), the largest cell found refining
    from the top down equals the largest over every cell taken at the lower of its coarse and
    its refined limit, each computed in full."""
    rng = np.random.default_rng(11)
    for _ in range(20):
        m = int(rng.integers(5, 40))
        coarse = rng.uniform(5.0, 9.0, m)
        fine = coarse - rng.uniform(0.0, 1.5, m)
        neighbours = np.full((m, 4), -1)
        for i in range(m):
            if rng.uniform() < 0.85:
                k = rng.choice(m, size=int(rng.integers(1, 5)), replace=False)
                neighbours[i, : k.size] = k
        best, where = _largest_cell(coarse, neighbours, lambda i, fine=fine: float(fine[i]))
        cells, widest = [], 0.0
        for i in range(m):
            row = neighbours[i][neighbours[i] >= 0]
            if row.size:
                c = _cell_limit(coarse[i], coarse[row])
                widest = max(widest, c - coarse[i])
                cells.append(min(c, _cell_limit(fine[i], fine[row])))
            else:
                cells.append(None)
        full = [c if c is not None else min(coarse[i], fine[i]) + widest
                for i, c in enumerate(cells)]  # fmt: skip
        assert best == pytest.approx(max(full), rel=1e-12)
        assert full[where] == pytest.approx(best, rel=1e-12)


def _brute_along(x, w, spans, end, cyclic, length, points=400_000):
    """The integral of 1 / u over the spans less their ends by the midpoint rule, ``u(s)``
    the largest limit of the intervals between neighbouring layers (``x``, ``w`` per span)
    within that limit of ``s`` (round a closed curve: the nearer way)."""
    total = 0.0
    for a, b in spans:
        h = (b - a - 2 * end) / points
        s = a + end + h * (np.arange(points) + 0.5)
        u = np.full(points, -np.inf)
        for xs, ws in zip(x, w, strict=True):
            pairs = list(zip(xs, ws, strict=True))
            if cyclic:
                pairs.append((xs[0] + length, ws[0]))
            for (x0, w0), (x1, w1) in itertools.pairwise(pairs):
                width = max(w0, w1)
                gap = np.maximum(np.maximum(x0 - s, s - x1), 0.0)
                if cyclic:  # the interval a turn before or after, if nearer
                    gap = np.minimum.reduce([
                        gap, np.maximum(np.maximum(x0 - length - s, s - x1 + length), 0.0),
                        np.maximum(np.maximum(x0 + length - s, s - x1 - length), 0.0),
                    ])  # fmt: skip
                u = np.where(gap <= width, np.maximum(u, width), u)
        total += float(np.sum(h / u))
    return total


def test_along_commands_integrates_the_limits_where_each_part_of_the_curve_lies():
    """The fewest commands along, from the layers' own limits, against the integral of the
    definition by the midpoint rule over 400,000 points (spans on an open curve and one round
    a closed one): the two agree to 1e-4, lie between the traced length over the largest and
    over the least limit, and equal the traced length over the limit where all are alike."""
    rng = np.random.default_rng(5)
    for case in range(12):
        cyclic = case % 3 == 0
        if cyclic:
            length = 157.0
            x = [np.sort(rng.uniform(0.0, length, int(rng.integers(3, 12))))]
            spans = [(float(x[0][0]) + 1.0, float(x[0][0]) + 1.0 + length)]
        else:
            length = 400.0
            spans = [(10.0, 130.0), (200.0, 380.0)][: 1 + case % 2]
            x = [np.linspace(a, b, int(rng.integers(2, 9))) for a, b in spans]
        w = [rng.uniform(3.0, 12.0, xs.size) for xs in x]
        limit = FamilyLimit(
            float(np.concatenate(w).max()), np.zeros(6), 0.0, 0.0, 1, 0,
            np.concatenate(x), np.concatenate([np.full(xs.size, k) for k, xs in enumerate(x)]),
            np.concatenate(w),
        )  # fmt: skip
        end = 0.3
        along = along_commands(limit, spans, end, cyclic, length)
        brute = _brute_along(x, w, spans, end, cyclic, length)
        assert along == pytest.approx(brute, rel=1e-4)
        traced = sum(b - a - 2 * end for a, b in spans)
        low, high = np.concatenate(w).min(), np.concatenate(w).max()
        assert traced / high - 1e-9 <= along <= traced / low + 1e-9
        alike = FamilyLimit(7.0, np.zeros(6), 0.0, 0.0, 1, 0, limit.layer_s_mm,
                            limit.layer_span, np.full(limit.layer_s_mm.size, 7.0))  # fmt: skip
        assert along_commands(alike, spans, end, cyclic, length) == pytest.approx(traced / 7.0)


@pytest.fixture(scope="module")
def ur5_seam():
    """The UR5 cell's seam family (the tilted plane's section of the workpiece's outer face)."""
    from pathlib import Path

    from armpath.scenes import load_scene
    from armpath.scenes.arm import scene_arm

    scene = load_scene(Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml")
    arm = scene_arm(scene)
    return curve_family(arm, scene.world, scene.trace_curve())


def test_the_half_band_holds_every_point_of_the_tube_outside_the_workpiece(ur5_seam):
    """Windows of the UR5 cell's seam (an ellipse on the workpiece's cone): the band's inner
    half-width (how far inside its circle a tool point within the tolerance of the curve and
    outside the workpiece may lie) is never passed by 200,000 random such points, the
    workpiece's own signed distance deciding what is outside; it lies within 20 % of the
    farthest inside found, and well below the tolerance (the half band is narrower)."""
    fam = ur5_seam
    curve, solid = fam.curve, fam.surface
    assert solid is not None and solid.name == "workpiece"
    rng = np.random.default_rng(3)
    for s in (40.0, 150.0, 290.0):
        window = [(s - WINDOW_HALF_MM, s + WINDOW_HALF_MM)]
        band = _band_over(fam, window, TOL, WINDOW_FIT_SHARE, WINDOW_HALF_MM)
        assert band is not None and band.deviation_mm < 0.25 * TOL
        p = curve.at_arc_length(rng.uniform(*window[0], 200_000))
        step = rng.normal(size=p.shape)
        step *= (TOL * rng.uniform(size=p.shape[0]) ** (1 / 3) / np.linalg.norm(step, axis=1))[
            :, None
        ]
        x = (p + step)[solid.signed_distance(p + step) >= 0.0]
        b = band.circle.normal
        inplane = (x - band.circle.centre) - np.outer((x - band.circle.centre) @ b, b)
        inside = band.circle.radius_mm - np.linalg.norm(inplane, axis=1)
        assert inside.max() <= band.inner_mm
        assert band.inner_mm - band.deviation_mm <= 1.2 * (inside.max() + band.deviation_mm)
        assert band.inner_mm < 0.8 * band.outer_mm


def test_a_frustum_s_face_bends_no_more_than_its_bound():
    """The workpiece's conical face: the curvature bound lies above the parallel's normal
    curvature (cos of the cone's half-angle over the distance from the axis), measured by the
    outward normal's turn along the parallel, and within 0.2 % of one over that distance (the
    bound leaves the half-angle out); inf at a rim, where two faces meet within the radius."""
    from armpath.geometry.primitives import hollow_frustum

    solid = hollow_frustum("w", [0.0, 0.0, 0.0], 160.0, 110.0, 70.0, 8.0)
    z, radius, h = 80.0, 0.1, 1e-2
    r = 110.0 - 40.0 * z / 160.0 + 1e-9
    p = np.array([[r * math.cos(a), r * math.sin(a), z] for a in (0.0, h / r)])
    n = solid.outward_normal(p)
    turn = np.linalg.norm(n[1] - n[0]) / np.linalg.norm(p[1] - p[0])
    cos_half = 160.0 / math.hypot(160.0, 40.0)
    assert turn == pytest.approx(cos_half / r, rel=1e-3)
    bound = float(solid.face_curvature_bound(p[:1], radius)[0])
    assert turn <= bound <= 1.002 / r
    rim = np.array([[110.0 - 1e-3, 0.0, 0.05]])
    assert np.isinf(solid.face_curvature_bound(rim, radius)[0])


@pytest.mark.parametrize("which", ["polygon", "ellipse"])
def test_curve_arcs_cover_the_arc_between_the_nearest_curve_points(which):
    """The band's arcs (between the circle points nearest two tool points) measured along the
    curve (:func:`_curve_arcs`): for 4,000 random pairs of points within the tolerance of a
    24-gon inscribed in a 50 mm circle (corners, where the nearest point is no longer
    radial) and of an ellipse of radii 90 and 80 mm (each against the circle fitted to a
    36 mm window of it), the arc of the curve between their nearest points, found on 200,001
    points of it, never exceeds it; a circle's own band leaves its arcs as they are."""
    if which == "polygon":
        angles = 2 * np.pi * np.arange(24) / 24
        curve = Polyline(
            "polygon", np.column_stack([50 * np.cos(angles), 50 * np.sin(angles), np.zeros(24)]),
            closed=True,
        )  # fmt: skip
        window = (0.0, curve.length)
    else:
        curve = ParametricCurve("e", "90*cos(t)", "80*sin(t)", "0", 0.0, 2 * np.pi)
        window = (100.0, 172.0)
    circle, deviation = fitted_circle(curve, [window])
    s = np.linspace(*window, max(int(window[1] - window[0]), 2) + 1)
    stretch, slop = _stretch_and_slop(curve.at_arc_length(s), s, circle, TOL, TOL + deviation)
    assert 1.0 - 1e-3 < stretch < 1.05 and slop >= 0.0
    band = LocalBand(circle, deviation, TOL + deviation, TOL + deviation, stretch, slop, 36.0)
    from scipy.spatial import cKDTree

    dense_s = np.linspace(0.0, curve.length, 200_001)
    tree = cKDTree(curve.at_arc_length(dense_s))
    b = circle.normal / np.linalg.norm(circle.normal)
    e1 = _unit(np.cross(b, [1.0, 0.0, 0.0]))
    e2 = np.cross(b, e1)
    rng = np.random.default_rng(11)
    widest = 0.0
    for length in (2.0, 8.0, 20.0):
        s0 = rng.uniform(window[0], window[1] - length, 1000)
        ends = []
        for x in (s0, s0 + length):
            p = curve.at_arc_length(x)
            p = p + TOL * rng.uniform(0.0, 1.0, (p.shape[0], 1)) * _unit(rng.normal(size=p.shape))
            ends.append(p)
        angle = [np.arctan2((p - circle.centre) @ e2, (p - circle.centre) @ e1) for p in ends]
        on_circle = circle.radius_mm * np.abs(np.angle(np.exp(1j * (angle[1] - angle[0]))))
        along = np.abs(dense_s[tree.query(ends[1])[1]] - dense_s[tree.query(ends[0])[1]])
        assert np.all(along <= _curve_arcs(on_circle, band) + 0.01)
        widest = max(widest, float(np.max(along - on_circle)))
    # the curve's arcs do exceed the circle's (the polygon's by 0.09 mm): the measure is needed
    assert widest > (0.05 if which == "polygon" else 0.0)
    own = LocalBand.of_circle(circle, TOL)
    assert np.allclose(_curve_arcs(np.array([3.0, 12.0]), own), [3.0, 12.0])


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.mark.slow
def test_a_near_circle_is_bounded_by_windows_above_the_family(tmp_path):
    """The UR5 cell tracing an ellipse of radii 80.6 and 79.4 mm in free space beside its
    workpiece: it lies 0.6 mm from its fitted circle (no circle for the band), but within
    0.025 mm of the circle fitted within each 36 mm window, so the band bound is taken by
    windows; it lies above the family's own bound and at most the plan, and no command of the
    plan, replayed (the arc of the curve between the points nearest its tool point at 41
    instants), covers more than the proven limit."""
    from pathlib import Path

    from armpath.scenes import load_scene
    from armpath.scenes.arm import scene_arm
    from armpath.tasks import trace_task

    scene = load_scene(Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml")
    arm = scene_arm(scene)
    a_mm, b_mm = 80.6, 79.4
    curve = ParametricCurve(
        "ellipse", f"330 + {a_mm}*cos(t)", f"-200 + {b_mm}*sin(t)", "150", 0.0, 2 * np.pi
    )
    assert fitted_circle(curve, [(0.0, curve.length)])[1] > 0.5
    r = trace_task(scene, arm, curve=curve)
    b = r.lower_bound
    assert b is not None and b.sampling.get("band_window_mm") == WINDOW_HALF_MM
    assert "fitted to the curve within 36 mm" in b.method
    assert b.sampling["family_bound_commands"] < b.value <= b.commands <= r.n_commands
    assert b.sampling["circle_deviation_mm"] <= WINDOW_FIT_SHARE * 0.1
    # replay: the arc of the curve covered by each command of the pass, by an independent
    # nearest-point search on a fine polyline of the ellipse
    t = np.linspace(0.0, 2 * np.pi, 200_001)
    dense = np.column_stack(
        [330 + a_mm * np.cos(t), -200 + b_mm * np.sin(t), np.full(t.size, 150.0)]
    )
    s_dense = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))]
    from scipy.spatial import cKDTree

    tree = cKDTree(dense)
    states = r.sequence.states_joint()
    p = r.passes[0]
    u = np.linspace(0.0, 1.0, 41)
    widest = 0.0
    for k in range(p.first, p.last):
        q = states[k] + u[:, None] * (states[k + 1] - states[k])
        s = s_dense[tree.query(tool_position(arm, q))[1]]
        s = np.unwrap(s * 2 * np.pi / s_dense[-1]) * s_dense[-1] / (2 * np.pi)
        widest = max(widest, float(s.max() - s.min()))
    assert 0.0 < widest <= b.sampling["command_arc_limit_mm"]
