"""An arm on a linear track: a prismatic joint carrying a UR5 (seven joints, one more than a tool
frame needs). The numerical IK moves the carriage as far as a target needs, and a seam longer
than the arm reaches from one place is traced in one pass with the carriage moving along it.

Judged by an independent D-H product (``independent_dh``, the textbook formula) and the seam's
own geometry (a straight line): nothing here takes armpath's kinematics for the truth.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np
import pytest

import armpath
import independent_dh as idh
from armpath.geometry.curves import Polyline
from armpath.ik.family import GenericFamily
from armpath.ik.target import ToolTarget
from armpath.model.dh import robot_from_dict
from armpath.planning.trace.carriage import carriage_joint, carriage_schedule

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

#: The track along world x (its D-H z axis turned onto x by the base), then UR5's table (deg).
_ROWS = [
    {"type": "prismatic", "a": 0, "alpha": -90, "d": 0, "limits": [0, 2000]},
    {"a": 0, "alpha": 90, "d": 89.159, "offset": 0, "limits": [-360, 360]},
    {"a": 425, "alpha": 0, "d": 0, "offset": 180, "limits": [-360, 360]},
    {"a": 392.25, "alpha": 0, "d": 0, "offset": 0, "limits": [-360, 360]},
    {"a": 0, "alpha": 90, "d": 109.15, "offset": 180, "limits": [-360, 360]},
    {"a": 0, "alpha": 90, "d": 94.65, "offset": 180, "limits": [-360, 360]},
    {"a": 0, "alpha": 0, "d": 82.3, "offset": 0, "limits": [-360, 360]},
]
_BASE = np.array([[0.0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, 300], [0, 0, 0, 1]])
_TOOL_MM = 120.0
TRACK_UR5 = {
    "name": "track_ur5",
    "convention": "standard",
    "units": {"length": "mm", "angle": "deg"},
    "links": _ROWS,
    "base": _BASE.tolist(),
    "home": [500, 0, -90, 90, -90, -90, 0],
    "link_radii_mm": [100, 100, 75, 60, 50, 45, 45, 45],
}


def _pose(q: np.ndarray) -> np.ndarray:
    """The tool pose for joint values ``q`` (the track in mm, the others in rad)."""
    pris = np.array([r.get("type") == "prismatic" for r in _ROWS])
    offset = np.where(pris, 0.0, np.radians([r.get("offset", 0) for r in _ROWS]))
    T = idh.dh_pose(
        [r["a"] for r in _ROWS],
        np.radians([r["alpha"] for r in _ROWS]),
        [r["d"] for r in _ROWS],
        q,
        prismatic=pris,
        offset=offset,
    )
    tool = np.eye(4)
    tool[2, 3] = _TOOL_MM
    return _BASE @ T @ tool


def test_levenberg_marquardt_moves_the_carriage_as_far_as_the_target_needs():
    """A tool frame 1.5 m along the track from where the carriage starts is reached: the
    damping measures the carriage's move in the arm's size (in its own mm it held the carriage
    where it stood and the tool stayed over 0.5 m off)."""
    arm = _track_ur5_with_torch()
    q_goal = np.array([1500.0, 0.3, -1.2, 1.4, -1.6, -1.5, 0.2])
    goal = _pose(q_goal)
    fam = GenericFamily(arm, ToolTarget(goal[:3, 3]))
    start = np.array([[0.0, 0.3, -1.2, 1.4, -1.6, -1.5, 0.2]])
    q = fam.refine(start, iterations=60, rotations=goal[None, :3, :3])[0]
    got = _pose(q)
    position_mm, rotation = idh.pose_residual(got, goal)
    assert position_mm < 1e-6
    assert rotation < 1e-9
    assert 0.0 <= q[0] <= 2000.0 and q[0] > 1000.0  # the carriage went most of the way


def _track_ur5_with_torch():
    tool = np.eye(4)
    tool[2, 3] = _TOOL_MM
    return robot_from_dict(TRACK_UR5).with_tool(tool)


def _seam_line() -> Polyline:
    """The track cell's seam: 1.7 m beside the track, 1 mm above the table."""
    return Polyline("seam", np.array([[100.0, -550.0, 41.0], [1800.0, -550.0, 41.0]]))


@functools.cache
def _undirected_schedule():
    """The carriage's schedule along the track cell's seam, where it starts unknown."""
    return carriage_schedule(_track_ur5_with_torch(), _seam_line(), 0)


@pytest.mark.parametrize("start_mm", [None, 500.0, 1500.0])
def test_the_carriage_is_scheduled_evenly_where_the_arm_reaches_every_point(start_mm):
    """The schedule along a 1.7 m line beside the track: the carriage found (the track, not a
    seven-joint arm of revolute joints), its value rising evenly (no layer's change above twice
    the average), and at nine points along the line a configuration with the carriage there puts
    the tool on the point pointing down within 30 deg (an independent least-squares solve on
    the D-H product, from 12 starts). From a known start the schedule is directed: the arm
    reaches farther toward the end the carriage travels to (from 500 mm, the end at 1800 mm:
    the carriage ends farther back than undirected; from 1500 mm, the end at 100 mm: farther
    on)."""
    from scipy.optimize import least_squares

    arm = _track_ur5_with_torch()
    tip = np.ones(7, dtype=bool)
    tip[-1] = False  # the torch lies on the last axis
    assert carriage_joint(arm, tip) == 0
    iiwa = armpath.load_arm("iiwa14")
    assert carriage_joint(iiwa, np.ones(7, dtype=bool)) is None
    schedule = (
        carriage_schedule(arm, _seam_line(), 0, start_mm) if start_mm else _undirected_schedule()
    )
    v = schedule.value
    assert np.all(np.diff(v) >= 0.0)
    if start_mm is not None:
        undirected = _undirected_schedule().value
        if start_mm < 950.0:
            assert v[-1] < undirected[-1] - 20.0
        else:
            assert v[0] > undirected[0] + 20.0
    step = np.abs(np.diff(v))
    assert step.max() <= 2.0 * step.mean() + 1e-9
    rng = np.random.default_rng(1)
    for x in np.arange(100.0, 1801.0, 212.5):
        point = np.array([x, -550.0, 41.0])
        track = schedule.at(point)

        def residual(q6, point=point, track=track):
            T = _pose(np.concatenate([[track], q6]))
            down = T[:3, 2] @ np.array([0.0, 0.0, -1.0])
            return np.concatenate(
                [(T[:3, 3] - point) / 100.0, [max(0.0, np.cos(np.radians(30)) - down)]]
            )

        best = min(
            (least_squares(residual, rng.uniform(-np.pi, np.pi, 6)) for _ in range(12)),
            key=lambda r: r.cost,
        )
        assert np.linalg.norm(residual(best.x)) < 1e-6, (x, track)


def test_the_farthest_tool_point_is_proven_as_far_as_sampling_finds_it():
    """The largest distance from the carriage to the tool point, proven by branch and bound:
    50,000 configurations through the independent D-H product, each polished by a local
    maximisation from the ten farthest, come within the search's slack of it and never past
    it; 1218 mm (the lengths summed) before, about 1053 now."""
    from scipy.optimize import minimize

    from armpath.planning.bounds.farthest import DISTANCE_SLACK, farthest_tool_point

    arm = armpath.load_arm(scene=EXAMPLES / "track_cell.toml")  # this table, the 120 mm tool
    farthest = farthest_tool_point(arm, 0)
    assert farthest is not None
    centre = farthest.centre  # with the carriage at 0
    rng = np.random.default_rng(5)
    q = np.c_[np.zeros(50_000), rng.uniform(-np.pi, np.pi, (50_000, 6))]
    far = np.array([np.linalg.norm(_pose(x)[:3, 3] - centre) for x in q])
    best = float(far.max())
    for x in q[np.argsort(far)[-10:]]:
        res = minimize(lambda v: -np.linalg.norm(_pose(np.r_[0.0, v])[:3, 3] - centre), x[1:])
        best = max(best, -float(res.fun))
    assert best <= farthest.radius
    assert farthest.radius - best <= DISTANCE_SLACK + 0.05
    assert farthest.radius < 1060.0  # the lengths summed: 1218 mm


def test_the_farthest_tool_point_of_a_limited_elbow_is_the_law_of_cosines(tmp_path):
    """A carriage carrying two links of 400 and 300 mm on parallel axes: the tool point is
    farthest from the first axis with the elbow as straight as its limits let it be, by the
    law of cosines (elbow limited to 30..150 deg: 676.6 mm; to -60..150: straight, 700 mm);
    the proven distance lies within the search's slack above it."""
    from armpath.planning.bounds.farthest import DISTANCE_SLACK, farthest_tool_point

    for elbow, expected in (
        ([30, 150], np.sqrt(400**2 + 300**2 + 2 * 400 * 300 * np.cos(np.radians(30)))),
        ([-60, 150], 700.0),
    ):
        arm = robot_from_dict(
            {
                "name": "two_links_on_a_track",
                "convention": "standard",
                "units": {"length": "mm", "angle": "deg"},
                "links": [
                    {"type": "prismatic", "a": 0, "alpha": 0, "d": 0, "limits": [0, 1000]},
                    {"a": 400, "alpha": 0, "d": 0, "limits": [-170, 170]},
                    {"a": 300, "alpha": 0, "d": 0, "limits": elbow},
                ],
            }
        )
        farthest = farthest_tool_point(arm, 0)
        assert farthest is not None
        assert expected - 1e-9 <= farthest.radius <= expected + DISTANCE_SLACK, elbow
        assert farthest.found <= expected + 1e-9


def test_the_searchs_second_derivatives_of_the_tool_point_are_finite_differences():
    """The branch and bound's second derivatives of the tool point (the earlier joint's axis
    across the later one's column) against central differences of the independent D-H
    product, every pair of joints (the carriage's too), at 20 configurations."""
    from armpath.kinematics import forward_frames, jacobian_from_frames
    from armpath.planning.bounds.farthest import _point_hessians

    arm = armpath.load_arm(scene=EXAMPLES / "track_cell.toml")
    rng = np.random.default_rng(3)
    q = np.c_[rng.uniform(0, 2000, 20), rng.uniform(-np.pi, np.pi, (20, 6))]
    J = jacobian_from_frames(arm, forward_frames(arm, q))
    H = _point_hessians(J[:, 3:, :], J[:, :3, :])
    eps = 1e-4
    for m in range(q.shape[0]):
        for i in range(7):
            for j in range(7):
                di, dj = np.eye(7)[i] * eps, np.eye(7)[j] * eps
                fd = (
                    _pose(q[m] + di + dj)[:3, 3]
                    - _pose(q[m] + di - dj)[:3, 3]
                    - _pose(q[m] - di + dj)[:3, 3]
                    + _pose(q[m] - di - dj)[:3, 3]
                ) / (4 * eps * eps)
                assert np.allclose(H[m, :, i, j], fd, atol=2e-3 * max(1.0, np.abs(fd).max()))


@pytest.mark.slow
def test_the_farthest_tool_point_at_a_height_is_proven_as_far_as_a_constrained_search_finds_it():
    """The largest distance from the UR5's first axis (vertical, through the carriage) of a
    tool point at a given height, proven by branch and bound: a constrained maximisation on
    the independent D-H product (SLSQP from 40 starts, the height held within the band) comes
    within the search's slack of it and never past it. At the table's height (41 mm, 348 mm
    below the shoulder) it is about 988.7 mm, less than the 1053.5 mm ball gives there (994);
    no tool point lies 1250 mm above the shoulder (every length from it summed: 1223.35
    mm)."""
    from scipy.optimize import least_squares, minimize

    from armpath.planning.bounds.farthest import DISTANCE_SLACK, farthest_from_axis

    arm = armpath.load_arm(scene=EXAMPLES / "track_cell.toml")
    shoulder_z = 300.0 + 89.159  # the base's height and the first row's d
    rng = np.random.default_rng(11)
    for z_lo, z_hi in ((40.95, 41.05), (600.0, 610.0), (1000.0, 1010.0)):
        ring = farthest_from_axis(arm, 0, z_lo - shoulder_z, z_hi - shoulder_z)
        assert ring is not None
        # the axis is world z through the carriage (x = 0 with it at zero, y = 0)
        assert np.allclose(ring.axis_point, [0.0, 0.0, shoulder_z], atol=1e-9)
        assert np.allclose(np.abs(ring.axis_dir), [0.0, 0.0, 1.0], atol=1e-12)

        def tip(v: np.ndarray) -> np.ndarray:
            return _pose(np.r_[0.0, v])[:3, 3]

        best = -np.inf
        for _ in range(40):
            # each start first brought to the band's middle height, then the distance maximised
            start = least_squares(
                lambda v, z=0.5 * (z_lo + z_hi): [tip(v)[2] - z], rng.uniform(-np.pi, np.pi, 6)
            ).x
            res = minimize(
                lambda v: -float(np.hypot(*tip(v)[:2])),
                start,
                method="SLSQP",
                constraints=[
                    {"type": "ineq", "fun": lambda v, z=z_lo: tip(v)[2] - z},
                    {"type": "ineq", "fun": lambda v, z=z_hi: z - tip(v)[2]},
                ],
                options={"maxiter": 300},
            )
            z = tip(res.x)[2]
            if z_lo - 1e-9 <= z <= z_hi + 1e-9:
                best = max(best, -float(res.fun))
        assert best <= ring.radius
        assert ring.complete  # searched to its slack, not stopped by the budget of boxes
        assert ring.radius - best <= DISTANCE_SLACK + 0.05, (z_lo, best, ring.radius)
    assert 988.0 < farthest_from_axis(arm, 0, 40.95 - shoulder_z, 41.05 - shoulder_z).radius < 990
    above = farthest_from_axis(arm, 0, 1250.0, 1260.0)
    assert above is not None and above.radius == -np.inf


def test_the_carriage_bound_is_the_travel_to_where_the_arm_reaches_every_point():
    """The proven bound of an arm on a track: the tool point stays within the proven farthest
    distance of a point on the carriage, and at the seam's height within the proven farthest
    distance from the arm's first axis, so the carriage must travel to where every point of
    the seam is that near. Checked by scanning the carriage's values on a grid (where each
    point is within both distances), not by the bound's closed form."""
    from armpath.planning.bounds.carriage import (
        RING_BAND_MM,
        RING_MAX_BOXES,
        carriage_travel_bound,
    )
    from armpath.planning.bounds.farthest import farthest_from_axis, farthest_tool_point

    arm = armpath.load_arm(scene=EXAMPLES / "track_cell.toml")
    farthest = farthest_tool_point(arm, 0)
    assert farthest is not None
    reach = farthest.radius
    height = 50.0 - (300.0 + 89.159)  # the seam's, from the shoulder on the first axis
    ring = farthest_from_axis(
        arm,
        0,
        height - 0.5 * RING_BAND_MM - 0.1,
        height + 0.5 * RING_BAND_MM + 0.1,
        max_boxes=RING_MAX_BOXES,
    )
    assert ring is not None and ring.radius < reach
    # a seam along the track from x = -200 to 2600 mm, 500 mm beside it, at z = 50
    seam = Polyline("seam", np.array([[-200.0, 500.0, 50.0], [2600.0, 500.0, 50.0]]))
    start = np.r_[500.0, np.radians([0, -90, 90, -90, -90, 0])]
    bound = carriage_travel_bound(arm, seam, [(0.0, 2800.0)], start, 0.1)
    assert bound is not None and bound.proven
    # the carriage's values where each point is within reach, on a 0.05 mm grid
    grid = np.arange(0.0, 2000.0 + 1e-9, 0.05)
    x = np.linspace(-200.0, 2600.0, 561)
    o = farthest.centre  # the point fixed to the carriage, with the carriage at 0
    gap = np.hypot(x[:, None] - grid[None, :] - o[0], np.hypot(500.0 - o[1], 50.0 - o[2]))
    # the first axis is world z through (carriage, 0)
    from_axis = np.hypot(x[:, None] - grid[None, :], 500.0)
    near = (gap <= reach + 0.1) & (from_axis <= ring.radius + 0.1)
    lowest = grid[np.argmax(near, axis=1)]  # each point's least carriage value within reach
    highest = grid[near.shape[1] - 1 - np.argmax(near[:, ::-1], axis=1)]
    A, B = lowest.max(), highest.min()
    assert A > B  # the seam is longer than the arm reaches from one place
    travel = min(
        max(A - 500.0, 0.0) + (max(500.0, A) - B), max(500.0 - B, 0.0) + (A - min(500.0, B))
    )
    assert bound.value * 2.0 == pytest.approx(travel, abs=0.1)  # 2 mm a command
    assert bound.commands == int(np.ceil(bound.value - 1e-9))
    # not an arm on a track: no such bound
    assert (
        carriage_travel_bound(armpath.load_arm("ur5"), seam, [(0.0, 2800.0)], start[1:], 0.1)
        is None
    )


@pytest.mark.slow
def test_a_seam_longer_than_the_arm_reaches_is_traced_in_one_pass_on_its_track():
    """``examples/track_cell.toml`` (its robot file is this module's table): a 1.7 m seam 1 mm
    above a table, beside a track whose carriage moves 2 mm a command (the default lattice: 20
    ticks of 0.1 mm): one pass, the carriage moving along it. Before the
    carriage was scheduled along the curve it took three passes and 562 commands, two moves
    between them driving the track 287 and 106 commands; the reference then left the schedule
    for a pass that ran out of reach (401 commands, two passes) until a lift-off was charged
    its whole joint change. The commands are replayed with the independent D-H product: every
    state on the lattice and within the limits, the tool within the tolerance of the seam at
    every sampled instant of the pass, the pass covering the seam end to end."""
    assert json.loads((EXAMPLES / "track_ur5.json").read_text()) == TRACK_UR5
    result = armpath.trace(None, scene=EXAMPLES / "track_cell.toml")
    doc = result.doc
    assert len(doc["passes"]) == 1
    (i, j) = doc["passes"][0]

    # the states, replayed from the start by the commands: on the lattice and within limits
    tick = np.array([0.1] + [np.radians(0.1)] * 6)
    ticks = np.cumsum(np.vstack([result.sequence.start_ticks, result.commands]), axis=0)
    assert np.abs(result.commands).max() <= 20
    q = ticks * tick
    assert np.all(q[:, 0] >= 0.0) and np.all(q[:, 0] <= 2000.0)
    assert np.all(np.abs(q[:, 1:]) <= 2 * np.pi)

    # the pass, every command sampled 40 times: within 0.1 mm of the seam, end to end
    f = np.linspace(0.0, 1.0, 41)[:, None]
    pairs = zip(q[i:j], q[i + 1 : j + 1], strict=True)
    tips = np.array([_pose(a + t * (b - a))[:3, 3] for a, b in pairs for t in f])
    off_line = np.hypot(tips[:, 1] + 550.0, tips[:, 2] - 41.0)
    assert off_line.max() <= 0.1
    assert tips[:, 0].min() <= 100.0 + 0.1 and tips[:, 0].max() >= 1800.0 - 0.1

    # the carriage moved with the tool along the pass
    assert np.ptp(q[i : j + 1, 0]) > 200.0
    # its bound is proven (the carriage's travel; the family's estimate of a redundant arm is
    # named but not taken) and below the plan: within 5 % of it (245 against 240; 268 before
    # the schedule let the arm reach farther ahead of the carriage than behind it)
    bound = doc["lower_bound"]
    assert bound["proven"] and "carriage" in bound["method"]
    assert 0 < doc["lower_bound_commands"] <= result.n_commands
    assert result.n_commands <= 1.05 * doc["lower_bound_commands"]


@pytest.mark.slow
def test_a_tour_along_the_track_is_bounded_by_its_carriage():
    """The track cell's three spot welds along its table: the tour reaches each weld within
    the tolerance (replayed with the independent D-H product), and its lower bound is the
    carriage's travel, proven for any order (the family's estimate of this redundant arm,
    about 195, is only named), at most the plan's commands."""
    result = armpath.spotweld(None, scene=EXAMPLES / "track_cell.toml")
    doc = result.doc
    tick = np.array([0.1] + [np.radians(0.1)] * 6)
    ticks = np.cumsum(np.vstack([result.sequence.start_ticks, result.commands]), axis=0)
    for visit in doc["visits"]:
        tip = _pose(ticks[visit["after_command"]] * tick)[:3, 3]
        assert np.linalg.norm(tip - np.array(visit["target"])) <= 0.05 + 1e-9
    assert sorted(map(tuple, (v["target"] for v in doc["visits"]))) == sorted(
        [(200.0, -550.0, 41.0), (950.0, -650.0, 41.0), (1700.0, -550.0, 41.0)]
    )
    bound = doc["lower_bound"]
    assert bound["proven"] and "carriage" in bound["method"]
    assert 0 < doc["lower_bound_commands"] <= result.n_commands
    # the arm's reach from its axis at the table's height: within 5 % (195 against 190)
    assert result.n_commands <= 1.05 * doc["lower_bound_commands"]


def _walk_travel(allowed: list[np.ndarray], grid: np.ndarray, c0: float, back: bool) -> float:
    """The shortest carriage walk (mm) from ``c0`` that stands, in some order, at an allowed
    grid value of each point (``allowed``: a mask over ``grid`` per point), and with ``back``
    ends at ``c0``: every order, a 1-D distance transform along each (brute force)."""
    from itertools import permutations

    spacing = grid[1] - grid[0]

    def spread(cost: np.ndarray) -> np.ndarray:  # min over c' of cost[c'] + |c - c'|
        out = cost.copy()
        for k in range(1, out.size):
            out[k] = min(out[k], out[k - 1] + spacing)
        for k in range(out.size - 2, -1, -1):
            out[k] = min(out[k], out[k + 1] + spacing)
        return out

    best = np.inf
    for order in permutations(range(len(allowed))):
        cost = np.abs(grid - c0)
        for i in order:
            cost = np.where(allowed[i], cost, np.inf)
            cost = spread(cost) if i != order[-1] else cost
        total = cost + np.abs(grid - c0) if back else cost
        best = min(best, float(total.min()))
    return best


def test_a_tours_carriage_bound_is_the_shortest_walk_through_where_each_weld_is_reached():
    """Welds along the track cell's table: the carriage bound equals the shortest walk of the
    carriage, from where it starts (and back, when the tour returns), through a value where
    each weld is within the proven reach (of a point on the carriage, and of its first axis at
    the weld's height), found by trying every order on a 0.5 mm grid."""
    from armpath.planning.bounds.carriage import (
        RING_BAND_MM,
        RING_MAX_BOXES,
        points_travel_bound,
    )
    from armpath.planning.bounds.farthest import farthest_from_axis, farthest_tool_point

    arm = armpath.load_arm(scene=EXAMPLES / "track_cell.toml")
    farthest = farthest_tool_point(arm, 0)
    assert farthest is not None
    welds = np.array([[200.0, -550.0, 41.0], [1000.0, -650.0, 41.0], [1700.0, -550.0, 141.0]])
    grid = np.arange(0.0, 2000.0 + 1e-9, 0.5)
    # the point fixed to the carriage moves along world x (the track) with it
    centres = farthest.centre + grid[:, None] * np.array([1.0, 0.0, 0.0])
    allowed = []
    for w in welds:
        height = w[2] - (300.0 + 89.159)  # from the shoulder on the first axis (world z)
        half = 0.5 * RING_BAND_MM + 0.05
        ring = farthest_from_axis(arm, 0, height - half, height + half, RING_MAX_BOXES)
        assert ring is not None and ring.radius < farthest.radius
        from_axis = np.hypot(w[0] - grid, w[1])
        allowed.append(
            (np.linalg.norm(centres - w, axis=1) <= farthest.radius + 0.05)
            & (from_axis <= ring.radius + 0.05)
        )
    for c0 in (0.0, 500.0, 1500.0):
        start = np.r_[c0, np.radians([0, -90, 90, -90, -90, 0])]
        for back in (False, True):
            bound = points_travel_bound(arm, welds, start, 0.05, "weld", back)
            assert bound is not None and bound.proven
            walk = _walk_travel(allowed, grid, c0, back)
            assert bound.value * 2.0 == pytest.approx(walk, abs=1.0), (c0, back)


def test_a_point_at_a_height_no_tool_point_takes_has_no_carriage_bound():
    """Two links turning about parallel axes square to a track keep the tool point in one
    plane: a point 5 mm off it lies within the ball of the arm's reach but at a height no tool
    point takes, so no carriage value brings the arm to it (no bound; the ball alone gave one).
    In the plane, 300 mm from the axis, the bound is the travel to where the two links (700
    mm) reach it, as the law of cosines gives: sqrt(700^2 - 300^2) either side of it."""
    from armpath.planning.bounds.carriage import points_travel_bound
    from armpath.planning.bounds.farthest import farthest_from_axis, next_axis

    arm = robot_from_dict(
        {
            "name": "two_links_across_a_track",
            "convention": "standard",
            "units": {"length": "mm", "angle": "deg"},
            "links": [
                {"type": "prismatic", "a": 0, "alpha": -90, "d": 0, "limits": [0, 2000]},
                {"a": 400, "alpha": 0, "d": 0, "limits": [-170, 170]},
                {"a": 300, "alpha": 0, "d": 0, "limits": [-150, 150]},
            ],
        }
    )
    axis = next_axis(arm, 0)
    assert axis is not None
    a_point, a_dir = axis
    track = np.array([0.0, 0.0, 1.0])  # the prismatic joint's D-H z, the base's world z
    assert abs(a_dir @ track) < 1e-12
    side = np.cross(a_dir, track)
    start = np.array([100.0, 0.0, 0.0])
    off = a_point + 5.0 * a_dir + 300.0 * side + 1500.0 * track
    assert farthest_from_axis(arm, 0, 4.95, 5.05).radius == -np.inf
    assert points_travel_bound(arm, off[None], start, 0.05) is None
    on = a_point + 300.0 * side + 1500.0 * track
    bound = points_travel_bound(arm, on[None], start, 0.05)
    assert bound is not None
    least = 1500.0 - np.sqrt(700.05**2 - 300.0**2)  # the least carriage value reaching it
    assert bound.value * 2.0 == pytest.approx(least - 100.0, abs=0.6)  # the search's slack


def test_a_long_arm_on_a_track_is_bounded_by_the_first_order_search_alone():
    """Twenty joints on a track (more than ``HESSIAN_JOINTS`` free: their second derivatives
    are not formed, which would take the square of their count in memory per box): the
    search stops at its budget of boxes with a proven distance still beyond every one of
    3,000 random configurations' (forward kinematics of the independent D-H product)."""
    from armpath.planning.bounds.farthest import HESSIAN_JOINTS, farthest_tool_point

    rows = [{"type": "prismatic", "a": 0, "alpha": -90, "d": 0, "limits": [0, 1000]}] + [
        {"a": 50, "alpha": 90 if k % 2 else -90, "d": 20, "limits": [-170, 170]} for k in range(20)
    ]
    arm = robot_from_dict(
        {
            "name": "long",
            "convention": "standard",
            "units": {"length": "mm", "angle": "deg"},
            "links": rows,
        }
    )
    assert arm.n_joints - 2 > HESSIAN_JOINTS
    farthest = farthest_tool_point(arm, 0, max_boxes=5_000)
    assert farthest is not None and not farthest.complete
    rng = np.random.default_rng(8)
    q = np.c_[np.zeros(3_000), rng.uniform(-np.radians(170), np.radians(170), (3_000, 20))]
    pris = np.array([r.get("type") == "prismatic" for r in rows])
    tips = np.array(
        [
            idh.dh_pose(
                [r["a"] for r in rows],
                np.radians([r["alpha"] for r in rows]),
                [r["d"] for r in rows],
                x,
                prismatic=pris,
            )[:3, 3]
            for x in q
        ]
    )
    assert np.linalg.norm(tips - farthest.centre, axis=1).max() <= farthest.radius


def test_a_redundant_arms_family_estimate_is_named_only_where_it_is_below_the_plan():
    """Beside a carriage's proven bound the family's estimate (one member of the self-motion
    per tool frame, not proven) is named where it is at most the plan's commands; above them
    (the track cell's seam: 256 against a plan of 245) it estimates nothing and is only kept
    among the sampling figures. A proven family bound above the carriage's is reported itself."""
    from armpath.planning.bounds import CommandBound
    from armpath.planning.bounds.carriage import with_carriage

    carriage = CommandBound(240, 239.1, "the carriage's travel", sampling={"boxes": 1.0})
    estimate = CommandBound(256, 255.45, "the family", unproven_because="self-motion")
    below = with_carriage(estimate, carriage, 260.0)
    above = with_carriage(estimate, carriage, 245.0)
    assert below is not None and above is not None
    assert below.commands == above.commands == 240 and below.proven and above.proven
    assert below.method.endswith("the family's estimate, not proven: ~256")
    assert above.method == "the carriage's travel"
    for b in (below, above):
        assert b.sampling == {"boxes": 1.0, "family_estimate_commands": 255.45}
    proven = CommandBound(250, 249.5, "the family")
    assert with_carriage(proven, carriage, 245.0) is proven
    assert with_carriage(None, carriage) is carriage and with_carriage(estimate, None) is estimate
