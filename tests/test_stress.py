"""The stress suite (issue 17): the independent replay itself, and a fixed sample of cases.

``benchmarks/stress.py`` generates seeded random cases and runs them through the library; the
replay that judges their results is ``tests/independent_replay.py``. Here the replay is shown to
accept known-good results (the seed tasks) and to reject corrupted ones (a command of 21 ticks, a
state beyond a limit, a motion through an obstacle between two clear states, a fingertip 1 mm
off its target, a trace off its curve, a weld off its point, a clearance bound that claims too
much), its formulas are checked against the other independent checkers, and a small fixed
sample of cases runs with 0 failures.
"""

from __future__ import annotations

import copy
import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

import independent
import independent_dh
import independent_replay as ir

ROOT = Path(__file__).resolve().parents[1]

#: The seed scene, written from SPEC section 3 (table z = 0, the hollow truncated cone).
SEED_SCENE = {
    "clearance": {"margin_mm": 1.0, "tool_tip_exempt_mm": 5.0, "self_margin_mm": 1.0},
    "obstacles": [
        {"type": "half_space", "name": "table", "point": [0, 0, 0], "normal": [0, 0, 1]},
        {
            "type": "hollow_frustum",
            "name": "workpiece",
            "base_center": [210.0, 0.0, 0.0],
            "height": 180.0,
            "r_bottom": 168.0,
            "r_top": 96.0,
            "wall": 8.0,
            "wall_thickness": "normal",
            "open_top": True,
            "closed_bottom": True,
        },
    ],
}
HOME = [0.0, -90.0, 0.0, 0.0, -90.0, 0.0]
WELDS_XY = [(320.0, -104.0), (120.0, 106.0), (190.0, -125.0), (255.0, 88.0)]


def _stress_module():
    spec = importlib.util.spec_from_file_location("stress", ROOT / "benchmarks" / "stress.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["stress"] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def stress():
    return _stress_module()


@pytest.fixture(scope="module")
def reach_doc():
    """Task 1 through the library: a known-good result."""
    from armpath.export import reach_result_dict
    from armpath.model.seed_arm import seed_arm
    from armpath.scenes import seed_scene
    from armpath.tasks import reach_task

    scene, arm = seed_scene(), seed_arm()
    return json.loads(json.dumps(reach_result_dict(reach_task(scene, arm), arm, scene)))


def _seed_scene() -> ir.Scene:
    return ir.Scene.from_spec(SEED_SCENE)


def _reach_truth() -> ir.Truth:
    return ir.Truth(start_deg=HOME, target=[20.0, -200.0, 120.0], tolerance=0.05)


# --- the replay's formulas against the other independent checkers ---------------------------


def test_seed_points_are_the_spec_test_vectors():
    vectors = {
        (30, -45, 60, 0, -30, 0): [
            (-90.1561, 156.1550, 320.3122),
            (-57.1567, 98.9983, 566.6233),
            (-65.5683, 113.5676, 629.4085),
        ],
        (-120, 20, -100, 45, 80, 10): [
            (-75.5305, 43.6076, 379.6216),
            (141.9510, -81.9554, 423.9019),
            (122.1386, -122.7828, 470.4379),
        ],
    }
    for q, cde in vectors.items():
        P = ir.SeedArm.points(np.array(q, float))
        np.testing.assert_allclose(P[2:], cde, atol=1e-4)
        doc = {"points": dict(zip("ABCDE", P.tolist(), strict=True))}
        assert ir.check_fk(None, q, doc) == []
        doc["points"]["E"] = (P[4] + [0.0, 0.0, 0.01]).tolist()
        assert ir.check_fk(None, q, doc)


def test_dh_product_agrees_with_independent_dh():
    rng = np.random.default_rng(5)
    for modified in (False, True):
        for _ in range(20):
            a, d = rng.uniform(-400, 400, 6), rng.uniform(-400, 400, 6)
            alpha, q = rng.uniform(-np.pi, np.pi, 6), rng.uniform(-np.pi, np.pi, 6)
            prismatic = rng.random(6) < 0.3
            offset = rng.uniform(-1, 1, 6)
            doc = {
                "convention": "modified" if modified else "standard",
                "units": {"length": "mm", "angle": "rad"},
                "links": [
                    {"a": a[i], "alpha": alpha[i], "d": d[i], "offset": offset[i]}
                    | ({"type": "prismatic"} if prismatic[i] else {})
                    for i in range(6)
                ],
            }
            robot = ir.DHRobot.from_file(doc)
            want = independent_dh.dh_pose(
                a, alpha, d, q, modified=modified, prismatic=prismatic, offset=offset
            )
            np.testing.assert_allclose(robot.pose(q), want, atol=1e-9)


def test_robot_file_units_convert():
    mm = {"links": [{"a": 300, "alpha": 90, "d": 100, "limits": [-90, 90]}] * 3}
    m = {
        "units": {"length": "m", "angle": "rad"},
        "links": [{"a": 0.3, "alpha": math.pi / 2, "d": 0.1, "limits": [-1.5708, 1.5708]}] * 3,
    }
    q = np.array([0.3, -0.2, 1.0])
    np.testing.assert_allclose(
        ir.DHRobot.from_file(mm).pose(q), ir.DHRobot.from_file(m).pose(q), atol=1e-9
    )
    assert ir.DHRobot.from_file(m).upper[0] == pytest.approx(1.5708)


def test_hollow_frustum_matches_the_seed_workpiece_checker():
    rng = np.random.default_rng(2)
    X = np.c_[rng.uniform(0, 420, 4000), rng.uniform(-210, 210, 4000), rng.uniform(-30, 210, 4000)]
    for wall in ("normal", "horizontal"):
        spec = copy.deepcopy(SEED_SCENE["obstacles"][1])
        spec["wall_thickness"] = wall
        mine = ir.obstacle_from_spec(spec).sdf(X)
        theirs = independent.Workpiece(wall).distance(X)
        np.testing.assert_allclose(mine, theirs, atol=1e-9)


def test_primitives_against_brute_force():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(3000, 3)) * 60
    box = ir.obstacle_from_spec(
        {
            "type": "box",
            "name": "b",
            "center": [5, -3, 2],
            "size": [40, 20, 10],
            "rotation_deg": [10, 40, -70],
        }
    )
    # brute force: the distance to a dense sample of the box's surface, signed by the inside
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec(np.radians([10, 40, -70])).as_matrix()
    g = np.linspace(-1, 1, 121)
    faces = []
    for axis in range(3):
        for side in (-1.0, 1.0):
            u, v = np.meshgrid(g, g)
            f = np.zeros((u.size, 3))
            others = [k for k in range(3) if k != axis]
            f[:, axis], f[:, others[0]], f[:, others[1]] = side, u.ravel(), v.ravel()
            faces.append(f * [20, 10, 5])
    surface = np.vstack(faces) @ R.T + [5, -3, 2]
    from scipy.spatial import cKDTree

    d = cKDTree(surface).query(X)[0]
    local = (X - [5, -3, 2]) @ R
    inside = np.all(np.abs(local) <= [20, 10, 5], axis=1)
    np.testing.assert_allclose(box.sdf(X), np.where(inside, -d, d), atol=0.3)
    # a cone frustum: the numpy profile distance equals shapely's distance to the profile
    import shapely

    cone = ir.obstacle_from_spec(
        {
            "type": "cone_frustum",
            "name": "c",
            "base_center": [0, 0, -20],
            "axis": [0, 1, 1],
            "r_bottom": 30,
            "r_top": 0,
            "height": 50,
        }
    )
    a = np.array([0, 1, 1]) / math.sqrt(2)
    rel = X - [0, 0, -20]
    z = rel @ a
    r = np.linalg.norm(rel - z[:, None] * a, axis=1)
    # the surface in the (r, z) half-plane: the edge on the axis, (0, 50) -> (0, 0), is not
    outline = shapely.LineString([(0, 0), (30, 0), (0, 50)])
    dist = shapely.distance(shapely.points(r, z), outline)
    ins = shapely.contains_xy(shapely.Polygon([(0, 0), (30, 0), (0, 50)]), r, z)
    np.testing.assert_allclose(cone.sdf(X), np.where(ins, -dist, dist), atol=1e-9)


def test_convex_mesh_distance(tmp_path):
    path = tmp_path / "cube.obj"
    V = [[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    faces = [f"f {q[0] + 1} {q[1] + 1} {q[2] + 1} {q[3] + 1}" for q in quads]
    path.write_text("\n".join([*(f"v {x} {y} {z}" for x, y, z in V), *faces]) + "\n")
    mesh = ir.obstacle_from_spec(
        {
            "type": "mesh",
            "name": "m",
            "file": "cube.obj",
            "scale": 10.0,
            "translation": [1, 2, 3],
            "rotation_deg": [0, 0, 30],
        },
        tmp_path,
    )
    box = ir.obstacle_from_spec(
        {
            "type": "box",
            "name": "b",
            "center": [1, 2, 3],
            "size": [20, 20, 20],
            "rotation_deg": [0, 0, 30],
        }
    )
    X = np.random.default_rng(4).normal(size=(2000, 3)) * 25
    np.testing.assert_allclose(mesh.sdf(X), box.sdf(X), atol=1e-9)


# --- known-good results are accepted ---------------------------------------------------------


def test_replay_accepts_task1(reach_doc):
    rep = ir.replay_result(reach_doc, _seed_scene(), _reach_truth())
    assert rep.ok, rep.problems
    assert rep.facts["error_mm"] <= 0.05
    assert rep.facts["min_clearance_sampled_mm"] == pytest.approx(75.0, abs=1e-6)


def _crack() -> ir.DenseCurve:
    wp = SEED_SCENE["obstacles"][1]
    return ir.frustum_section_curve(
        wp["base_center"],
        (0, 0, 1),
        wp["height"],
        wp["r_bottom"],
        wp["r_top"],
        (0, 0, 0),
        (1, 0, -2),
    )


def _weld_points(wall: str = "normal") -> np.ndarray:
    wp = SEED_SCENE["obstacles"][1]
    return np.array(
        [
            ir.hollow_frustum_inner_point(
                wp["base_center"],
                wp["height"],
                wp["r_bottom"],
                wp["r_top"],
                wp["wall"],
                wall,
                x,
                y,
            )
            for x, y in WELDS_XY
        ]
    )


def test_independent_crack_and_welds_are_the_spec_numbers():
    crack = _crack()
    L = np.linalg.norm(np.diff(np.vstack([crack.points, crack.points[:1]]), axis=0), axis=1).sum()
    assert abs(L - 865.946) < 2e-3  # README: 865.946 mm long
    np.testing.assert_allclose(_weld_points()[:, 2], [20.009, 50.824, 81.985, 151.364], atol=1e-3)


def test_replay_accepts_task2_and_task3(seed_run):
    out, _ = seed_run
    trace = json.loads((out / "trace.json").read_text())
    rep = ir.replay_result(trace, _seed_scene(), ir.Truth(start_deg=HOME, curve=_crack()))
    assert rep.ok, rep.problems
    assert rep.facts["max_deviation_mm"] <= trace["tolerance_mm"]
    assert rep.facts["curve_hausdorff_mm"] < 1e-3
    welds = json.loads((out / "spotweld.json").read_text())
    rep = ir.replay_result(
        welds, _seed_scene(), ir.Truth(start_deg=HOME, targets=_weld_points(), tolerance=0.05)
    )
    assert rep.ok, rep.problems


# --- corrupted results are rejected ----------------------------------------------------------


def _rejects(doc, truth=None, scene=None, what=""):
    rep = ir.replay_result(doc, scene or _seed_scene(), truth or ir.Truth())
    assert any(what in p for p in rep.problems), rep.problems
    return rep


def test_rejects_a_command_of_21_ticks(reach_doc):
    doc = copy.deepcopy(reach_doc)
    j = int(np.argmax(np.abs(doc["commands"][0])))
    step = 1 if doc["commands"][0][j] >= 0 else -1
    doc["commands"][0][j] = 21 * step  # the same final state: the next command gives it back
    doc["commands"][1][j] -= 21 * step - reach_doc["commands"][0][j]
    _rejects(doc, _reach_truth(), what="beyond 20 ticks")


def test_rejects_a_state_beyond_a_limit(reach_doc):
    doc = copy.deepcopy(reach_doc)
    doc["initial_deg"] = [0.0, -124.0, 0.0, 0.0, -90.0, 0.0]
    doc["commands"] = [[0, -11, 0, 0, 0, 0], [0, 11, 0, 0, 0, 0]]  # -125.1 deg on the way
    doc["final_deg"] = doc["initial_deg"]
    doc["n_commands"] = 2
    _rejects(doc, what="outside its limits")


def test_rejects_a_motion_through_an_obstacle_between_clear_states(reach_doc):
    """A small ball where link CD passes half-way through a command: every state is clear,
    only the continuous motion touches it."""
    states = np.array(reach_doc["initial_deg"]) * 10 + np.cumsum(
        np.r_[[np.zeros(6)], reach_doc["commands"]], axis=0
    )
    moves = [
        np.abs(np.diff(ir.SeedArm.points(states[k : k + 2] / 10)[:, 3], axis=0)).max()
        for k in range(len(states) - 1)
    ]
    k = int(np.argmax(moves))  # the command that moves D farthest
    mid = ir.SeedArm.points((states[k] + states[k + 1]) / 20)
    ball_center = (mid[2] + mid[3]) / 2  # the middle of CD half-way through command k
    scene_spec = copy.deepcopy(SEED_SCENE)
    scene_spec["obstacles"].append(
        {"type": "sphere", "name": "ball", "center": ball_center.tolist(), "radius": 0.5}
    )
    scene = ir.Scene.from_spec(scene_spec)
    assert np.all(ir.config_slack(ir.SeedArm(), scene, states / 10, 0.5) > 0)
    _rejects(reach_doc, _reach_truth(), scene, what="clearance broken: CD - ball")


def test_rejects_a_fingertip_1mm_off_its_target(reach_doc):
    truth = _reach_truth()
    truth.target = [20.0, -200.0, 121.0]
    _rejects(reach_doc, truth, what="exceeds the tolerance")
    doc = copy.deepcopy(reach_doc)
    doc["target"] = [20.0, -200.0, 121.0]
    doc["error_mm"] = 1.0
    _rejects(doc, what="exceeds the tolerance")


def test_rejects_a_clearance_bound_that_claims_too_much(reach_doc):
    doc = copy.deepcopy(reach_doc)
    doc["clearance"]["min_clearance_lower_bound_mm"] = 75.5
    _rejects(doc, _reach_truth(), what="reported clearance lower bound")


def test_rejects_a_trace_off_its_curve_and_welds_off_their_points(seed_run):
    out, _ = seed_run
    trace = json.loads((out / "trace.json").read_text())
    up = np.array([0.0, 0.0, 0.3])
    shifted = ir.DenseCurve(_crack().points + up, closed=True)
    _rejects(trace, ir.Truth(curve=shifted), what="from the curve asked for")
    doc = copy.deepcopy(trace)
    doc["curve"]["points_mm"] = (np.array(doc["curve"]["points_mm"]) + up).tolist()
    _rejects(doc, what="leaves the curve")
    welds = json.loads((out / "spotweld.json").read_text())
    moved = _weld_points()
    moved[0] += [0.0, 1.0, 0.0]
    _rejects(welds, ir.Truth(targets=moved), what="are not the independent ones")
    doc = copy.deepcopy(welds)
    doc["visits"][0]["after_command"] -= 1
    _rejects(doc, what="missed by")
    for result in (trace, welds):  # a bound above the plan's own commands cannot hold
        doc = copy.deepcopy(result)
        doc["lower_bound_commands"] = doc["n_commands"] + 1
        _rejects(doc, what="beat the claimed lower bound")


def test_an_overclaimed_lower_bound_is_rejected(stress):
    """The exhaustive lattice search behind the suite's check of a reach's lower bound."""
    home = np.array(HOME)
    doc = {"task": "reach", "lower_bound_commands": 2, "tolerance_mm": 0.05}
    one = ir.SeedArm.points(home + np.array([0.0, 1.5, 0.0, 0.0, 0.0, 0.0]))[4]  # 1 command
    with pytest.raises(stress.RejectedError, match="lower bound of 2"):
        stress._check_lower_bound(doc, ir.Truth(start_deg=HOME, target=one, tolerance=0.05))
    two = ir.SeedArm.points(home + np.array([3.0, 0.0, 0.0, 0.0, 0.0, 0.0]))[4]  # needs 2
    stress._check_lower_bound(doc, ir.Truth(start_deg=HOME, target=two, tolerance=0.05))


# --- the stress suite itself ------------------------------------------------------------------

#: The fixed sample: cheap kinematics cases (seed 17), planning cases of seed 1 that take a few
#: seconds (results and clear errors of every planning kind), two of them through the command
#: line, and scene files (seed 17).
KINEMATICS = (17, ["fk", "ik"], list(range(30)))
PLANNING = (1, [8, 9, 10, 12, 14, 20, 21, 23, 36, 37, 71, 78])
PLANNING_CLI = (1, [31, 40])
SCENES = (17, ["scene"], list(range(24)))


def _run(stress, seed, indices, kinds, cli_share=0.0):
    records: list[dict] = []
    stress.run_pool(seed, indices, kinds, 20.0, cli_share, 1, records.append)
    assert sorted(r["index"] for r in records) == sorted(indices)
    return records


def _no_failures(records):
    failures = [r for r in records if r["outcome"] == "failure"]
    assert not failures, "\n".join(
        f"case {r['index']} ({r['kind']}): {r.get('category')}: {r.get('message')}"
        for r in failures
    )


@pytest.mark.slow
def test_fixed_sample_kinematics_and_planning(stress):
    seed, kinds, indices = KINEMATICS
    records = _run(stress, seed, indices, kinds)
    seed, indices = PLANNING
    planning = _run(stress, seed, indices, list(stress.WEIGHTS))
    seed, indices = PLANNING_CLI
    cli = _run(stress, seed, indices, list(stress.WEIGHTS), cli_share=1.0)
    _no_failures(records + planning + cli)
    assert {r["kind"] for r in records} == {"fk", "ik"}
    assert {r["kind"] for r in planning} == {"reach", "plan", "trace"}
    assert all(r["cli"] for r in cli)
    outcomes = {r["outcome"] for r in planning}
    assert outcomes == {"result", "error"}  # both replayed results and clear errors


def test_fixed_sample_scene_files(stress):
    seed, kinds, indices = SCENES
    _no_failures(_run(stress, seed, indices, kinds))


@pytest.mark.extra
def test_bigger_sample_has_no_failures(stress):
    records: list[dict] = []
    stress.run_pool(3, list(range(120)), list(stress.WEIGHTS), 20.0, 0.05, 2, records.append)
    _no_failures(records)
