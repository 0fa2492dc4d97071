"""Models from D-H tables / robot files, and inverse kinematics with every solution.

Truth comes from ``independent_dh`` (textbook D-H products and a brute-force multi-start
least-squares IK written without armpath code) and from the generating joint vectors.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from armpath.errors import InvalidInputError
from armpath.ik import (
    General6RSolver,
    SphericalWristSolver,
    ThreeParallelSolver,
    complete_solver,
    solve_ik,
    solve_numerical,
)
from armpath.kinematics import tool_pose
from armpath.model.catalog import BUILTIN_MODELS, resolve_model
from armpath.model.dh import DHRow, dh_arm, load_robot_file, robot_from_dict
from armpath.model.serial_arm import JointKind
from arms import scara_rows
from independent_dh import brute_force_ik, dh_pose, pose_residual


def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def _random_table(rng, n=6):
    a = rng.uniform(-500, 500, n)
    d = rng.uniform(-500, 500, n)
    alpha = rng.uniform(-np.pi, np.pi, n)
    return a, alpha, d


def _arm(a, alpha, d, convention="standard"):
    rows = [DHRow(a=x, alpha=y, d=z) for x, y, z in zip(a, alpha, d, strict=True)]
    return dh_arm(rows, convention)


def _contains(solutions, q, prismatic=None, tol=1e-6):
    if len(solutions) == 0:
        return False
    diff = np.asarray(solutions) - q
    mask = np.ones(len(q), bool) if prismatic is None else ~np.asarray(prismatic)
    diff[:, mask] = _wrap(diff[:, mask])
    return bool(np.any(np.all(np.abs(diff) < tol, axis=1)))


# ------------------------------------------------------------------------------------------
# Models
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_dh_models_match_textbook_products(convention):
    rng = np.random.default_rng(1)
    for _ in range(20):
        a, alpha, d = _random_table(rng)
        offset = rng.uniform(-1, 1, 6)
        prismatic = rng.random(6) < 0.3
        rows = [
            DHRow(
                a=a[i],
                alpha=alpha[i],
                d=d[i],
                offset=offset[i],
                kind=JointKind.PRISMATIC if prismatic[i] else JointKind.REVOLUTE,
            )
            for i in range(6)
        ]
        arm = dh_arm(rows, convention)
        q = rng.uniform(-np.pi, np.pi, 6)
        q[prismatic] = rng.uniform(-300, 300, prismatic.sum())
        truth = dh_pose(
            a, alpha, d, q, modified=convention == "modified", prismatic=prismatic, offset=offset
        )
        assert np.allclose(tool_pose(arm, q), truth, atol=1e-9)


def test_robot_file_units_are_converted(tmp_path):
    rng = np.random.default_rng(2)
    a, alpha, d = _random_table(rng)
    links_mm = [
        {"a": x, "alpha": float(np.degrees(y)), "d": z, "limits": [-170, 170]}
        for x, y, z in zip(a, alpha, d, strict=True)
    ]
    links_m = [
        {"a": x / 1000, "alpha": y, "d": z / 1000, "type": "revolute", "limits": [-2.967, 2.967]}
        for x, y, z in zip(a, alpha, d, strict=True)
    ]
    (tmp_path / "mm.json").write_text(json.dumps({"convention": "standard", "links": links_mm}))
    doc_m = {"convention": "standard", "links": links_m, "units": {"length": "m", "angle": "rad"}}
    (tmp_path / "m.json").write_text(json.dumps(doc_m))
    arm_mm = load_robot_file(tmp_path / "mm.json")
    arm_m = resolve_model(str(tmp_path / "m.json"))
    q = rng.uniform(-2, 2, 6)
    truth = dh_pose(a, alpha, d, q)
    assert np.allclose(tool_pose(arm_mm, q), truth, atol=1e-9)
    assert np.allclose(tool_pose(arm_m, q), truth, atol=1e-9)
    assert np.degrees(arm_mm.upper[0]) == pytest.approx(170)
    assert arm_m.upper[0] == pytest.approx(2.967)


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ({"links": []}, "non-empty list"),
        ({"convention": "craig", "links": [{"a": 1}]}, "convention must be one of"),
        ({"links": [{"a": 1, "limits": [10, -10]}]}, "lower 10.0 exceeds upper"),
        ({"links": [{"a": "x"}]}, "links[0].a must be a number"),
        ({"links": [{"a": 1, "twist": 2}]}, "unknown key(s) ['twist']"),
        ({"links": [{"a": 1}], "units": {"length": "inch"}}, "units.length must be 'mm' or 'm'"),
        ({"links": [{"a": 1, "type": "spherical"}]}, "type must be 'revolute' or 'prismatic'"),
    ],
)
def test_robot_file_errors_name_the_field(doc, message):
    with pytest.raises(InvalidInputError) as info:
        robot_from_dict(doc)
    assert message in str(info.value)


def _urdf_from_dh(a, alpha, d):
    """A URDF whose joints reproduce a standard D-H table, with a fixed tool joint (metres)."""

    def rpy(R):
        return (
            np.arctan2(R[2, 1], R[2, 2]),
            np.arcsin(-np.clip(R[2, 0], -1, 1)),
            np.arctan2(R[1, 0], R[0, 0]),
        )

    links = "".join(f'<link name="l{i}"/>' for i in range(8))
    joints = []
    prev = np.eye(4)
    for i in range(6):
        origin = prev @ np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, d[i]], [0, 0, 0, 1.0]])
        xyz = " ".join(f"{v / 1000:.17g}" for v in origin[:3, 3])
        r = " ".join(f"{v:.17g}" for v in rpy(origin[:3, :3]))
        kind = "continuous" if i == 5 else "revolute"
        limit = '<limit lower="-3" upper="3" effort="1" velocity="1"/>' if i < 5 else ""
        joints.append(
            f'<joint name="j{i + 1}" type="{kind}"><parent link="l{i}"/><child link="l{i + 1}"/>'
            f'<origin xyz="{xyz}" rpy="{r}"/><axis xyz="0 0 1"/>{limit}</joint>'
        )
        ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
        prev = np.array([[1, 0, 0, a[i]], [0, ca, -sa, 0], [0, sa, ca, 0], [0, 0, 0, 1.0]])
    xyz = " ".join(f"{v / 1000:.17g}" for v in prev[:3, 3])
    r = " ".join(f"{v:.17g}" for v in rpy(prev[:3, :3]))
    joints.append(
        f'<joint name="tool" type="fixed"><parent link="l6"/><child link="l7"/>'
        f'<origin xyz="{xyz}" rpy="{r}"/></joint>'
    )
    return f'<robot name="dhbot">{links}{"".join(joints)}</robot>'


def test_urdf_chain_matches_dh(tmp_path):
    rng = np.random.default_rng(3)
    a, alpha, d = _random_table(rng)
    path = tmp_path / "bot.urdf"
    path.write_text(_urdf_from_dh(a, alpha, d))
    arm = load_robot_file(path)
    assert arm.n_joints == 6 and arm.name == "dhbot [l7]"  # the tip link is named
    assert np.isinf(arm.upper[5]) and arm.upper[0] == pytest.approx(3.0)
    for q in rng.uniform(-2.5, 2.5, (10, 6)):
        assert np.allclose(tool_pose(arm, q), dh_pose(a, alpha, d, q), atol=1e-9)
    # and the complete IK works on the URDF model directly
    q = rng.uniform(-2.5, 2.5, 6)
    result = solve_ik(arm, dh_pose(a, alpha, d, q))
    assert _contains(result.solutions, q)


# ------------------------------------------------------------------------------------------
# General 6R: Raghavan-Roth elimination
# ------------------------------------------------------------------------------------------


def test_general_6r_recovers_the_generating_solution_in_random_arms():
    """4000 random general arms and poses: the generating joint vector is found in >= 99.9 %
    and every returned solution reproduces the pose (checked with the textbook D-H product)."""
    rng = np.random.default_rng(20261122)
    misses = 0
    total = 0
    counts = []
    for _ in range(400):
        a, alpha, d = _random_table(rng)
        solver = General6RSolver(_arm(a, alpha, d))
        Q = rng.uniform(-np.pi, np.pi, (10, 6))
        targets = np.array([dh_pose(a, alpha, d, q) for q in Q])
        for q, target, result in zip(Q, targets, solver.solve_batch(targets), strict=True):
            total += 1
            counts.append(result.count)
            misses += not _contains(result.solutions, q)
            assert result.count <= 16
            for s in result.solutions:
                pos, rot = pose_residual(dh_pose(a, alpha, d, s), target)
                assert pos < 1e-6 and rot < 1e-9
    assert total == 4000
    assert misses <= 4, f"generating solution missed in {misses} of {total}"
    assert 2.0 < np.mean(counts) < 8.0


@pytest.mark.slow
def test_general_6r_finds_what_brute_force_finds():
    """Multi-start least squares (scipy, 150 starts) finds no solution the elimination lacks."""
    rng = np.random.default_rng(7)
    for _ in range(3):
        a, alpha, d = _random_table(rng)
        q = rng.uniform(-np.pi, np.pi, 6)
        target = dh_pose(a, alpha, d, q)
        ours = General6RSolver(_arm(a, alpha, d)).solve(target)
        brute = brute_force_ik(a, alpha, d, target, starts=150)
        assert len(brute) >= 2
        for s in brute:
            assert _contains(ours.solutions, s, tol=1e-5)
        assert ours.count >= len(brute)


# ------------------------------------------------------------------------------------------
# Closed form: spherical wrist (Pieper)
# ------------------------------------------------------------------------------------------


def _closed_form_agrees(a, alpha, d, closed, general, Q):
    """For each joint vector of ``Q``: the closed form recovers it and reproduces the pose by
    the textbook product; where neither solver flags a near-double root, both return the same
    set. Returns how many poses were compared."""
    compared = 0
    targets = np.array([dh_pose(a, alpha, d, q) for q in Q])
    for q, target, c, g in zip(
        Q, targets, closed.solve_batch(targets), general.solve_batch(targets), strict=True
    ):
        assert _contains(c.solutions, q)
        for s in c.solutions:
            pos, rot = pose_residual(dh_pose(a, alpha, d, s), target)
            assert pos < 1e-6 and rot < 1e-9
        if g.count and not g.near_double.any() and not c.near_double.any():
            compared += 1
            assert c.count == g.count
            for s in g.solutions:
                assert _contains(c.solutions, s, tol=1e-5)
    return compared


def test_spherical_wrist_closed_form_matches_the_general_solver():
    """Random arms with a spherical wrist (a4 = a5 = d5 = 0, oblique twists): the closed form
    recovers every generating vector and returns the same set as the elimination."""
    rng = np.random.default_rng(11)
    compared = 0
    for _ in range(40):
        a, alpha, d = _random_table(rng)
        a[3] = a[4] = d[4] = 0.0
        arm = _arm(a, alpha, d)
        closed = SphericalWristSolver(arm)
        general = General6RSolver(arm)
        Q = rng.uniform(-np.pi, np.pi, (10, 6))
        compared += _closed_form_agrees(a, alpha, d, closed, general, Q)
    assert compared > 300


@pytest.mark.parametrize("name", ["seed", "puma560", "welder003"])
def test_builtin_spherical_wrist_arms(name):
    arm = BUILTIN_MODELS[name]()
    prismatic = np.array([j.kind is JointKind.PRISMATIC for j in arm.joints])
    rng = np.random.default_rng(5)
    Q = rng.uniform(-np.pi, np.pi, (200, 6))
    Q[:, prismatic] = rng.uniform(0, 700, (200, prismatic.sum()))
    solver = SphericalWristSolver(arm)
    targets = tool_pose(arm, Q)
    results = solver.solve_batch(targets)
    for q, target, result in zip(Q, targets, results, strict=True):
        assert _contains(result.solutions, q, prismatic)
        assert np.allclose(tool_pose(arm, result.solutions), target, atol=1e-6)
        assert result.count <= (4 if prismatic.any() else 8)
    if name == "puma560":  # generic poses of a PUMA have 8 solutions
        assert np.mean([r.count == 8 for r in results]) > 0.95


def test_three_parallel_closed_form_matches_the_general_solver():
    """Random arms with axes 2-4 parallel and axes 5, 6 meeting, and the reverse (axes 3-5
    parallel, 1, 2 meeting): the closed form recovers every generating vector, reproduces the
    pose by the textbook product and returns the same set as the elimination."""
    rng = np.random.default_rng(12)
    compared = 0
    for k in range(24):
        a, alpha, d = _random_table(rng)
        if k % 2:
            alpha[2] = alpha[3] = a[0] = 0.0
        else:
            alpha[1] = alpha[2] = a[4] = 0.0
        if k % 3 == 0:  # right-angle twists elsewhere, as in real arms
            alpha[[0, 4] if k % 2 else [0, 3]] = np.pi / 2
        arm = _arm(a, alpha, d)
        closed = complete_solver(arm)
        assert isinstance(closed, ThreeParallelSolver)
        assert closed.layout == ("reversed" if k % 2 else "forward")
        general = General6RSolver(arm)
        Q = rng.uniform(-np.pi, np.pi, (20, 6))
        compared += _closed_form_agrees(a, alpha, d, closed, general, Q)
    assert compared > 400


@pytest.mark.parametrize("name", ["puma560", "ur5", "painter004"])
def test_batch_arrays_match_single_calls(name):
    """``solve_batch`` returns padded arrays (NaN past each pose's count) whose per-pose views
    equal what ``solve`` returns for that pose alone."""
    arm = BUILTIN_MODELS[name]()
    solver = complete_solver(arm)
    Q = np.random.default_rng(4).uniform(-np.pi, np.pi, (12, 6))
    targets = tool_pose(arm, Q)
    batch = solver.solve_batch(targets)
    assert len(batch) == 12 and batch.solutions.shape[0] == 12
    for i in range(12):
        k = int(batch.counts[i])
        assert 0 < k <= batch.solutions.shape[1]
        assert np.isnan(batch.solutions[i, k:]).all() and np.isfinite(batch.solutions[i, :k]).all()
        single = solver.solve(targets[i])
        assert single.count == k and single.method == batch[i].method
        assert np.array_equal(single.solutions, batch[i].solutions)
        assert np.array_equal(single.position_residual, batch[i].position_residual)
        assert np.all(np.diff(single.solutions[:, 0]) >= 0)  # sorted
    assert len(batch[2:5]) == 3 and batch[-1].count == batch.counts[-1]
    with pytest.raises(IndexError):
        batch[12]


def test_ur5_and_painter_through_the_elimination():
    rng = np.random.default_rng(8)
    for name in ("ur5", "painter004"):
        arm = BUILTIN_MODELS[name]()
        Q = rng.uniform(-np.pi, np.pi, (300, 6))
        results = General6RSolver(arm).solve_batch(tool_pose(arm, Q))
        found = np.mean([_contains(r.solutions, q) for q, r in zip(Q, results, strict=True)])
        assert found >= 0.99, (name, found)


# ------------------------------------------------------------------------------------------
# Numerical solver and the CLI
# ------------------------------------------------------------------------------------------


def test_numerical_solver_redundant_arm_and_position_only():
    rng = np.random.default_rng(9)
    a, alpha, d = _random_table(rng, 7)
    rows = [
        DHRow(a=x, alpha=y, d=z, limits=(-3.0, 3.0)) for x, y, z in zip(a, alpha, d, strict=True)
    ]
    arm = dh_arm(rows)
    q = rng.uniform(-2.5, 2.5, 7)
    target = tool_pose(arm, q)
    result = solve_numerical(arm, target, seeds=24)
    assert result.count >= 1
    for s in result.solutions:
        pos, rot = pose_residual(tool_pose(arm, s), target)
        assert pos < 1e-6 and rot < 1e-9
        assert np.all(np.abs(s) <= 3.0 + 1e-12)
    seed = BUILTIN_MODELS["seed"]()
    goal = np.array([300.0, 100.0, 200.0])
    pos_only = solve_ik(seed, goal, position_only=True, seeds=16)
    assert pos_only.count >= 1 and pos_only.within_limits is not None
    assert np.allclose(tool_pose(seed, pos_only.solutions)[:, :3, 3], goal, atol=1e-6)
    far = solve_numerical(seed, np.array([5000.0, 0, 0]), position_only=True, seeds=4)
    assert far.count == 0 and "closest reached" in far.reason


def test_a_joint_that_does_not_move_the_tool_point_is_held():
    """A SCARA's last joint only turns its tool about the tool point: a position's solutions
    were 48 random turns of it. It is now held (at home, or at --near's value), leaving the
    two elbows, which the planar two-link closed form written here gives; the seed arm's joint
    6 likewise. Each replays on the textbook D-H product."""
    rows = scara_rows()
    scara = dh_arm(rows, name="scara")
    goal = np.array([350.0, 100.0, 250.0])
    for near, held in ((None, 0.0), (np.array([0.1, 0.2, 10.0, 1.25]), 1.25)):
        result = solve_ik(scara, goal, position_only=True, near=near)
        assert result.count == 2 and result.family_dimension == 0
        assert "q4 held" in result.method
        np.testing.assert_allclose(result.solutions[:, 3], held)
        # the planar two-link arm: r^2 = a1^2 + a2^2 + 2 a1 a2 cos(q2)
        r2 = goal[0] ** 2 + goal[1] ** 2
        elbow = np.arccos((r2 - 300.0**2 - 250.0**2) / (2 * 300.0 * 250.0))
        assert sorted(result.solutions[:, 1]) == pytest.approx([-elbow, elbow], abs=1e-9)
        np.testing.assert_allclose(result.solutions[:, 2], 400.0 - 50.0 - goal[2], atol=1e-9)
        for q in result.solutions:
            T = dh_pose(
                [r.a for r in rows], [r.alpha for r in rows], [r.d for r in rows], q,
                prismatic=[False, False, True, False],
            )  # fmt: skip
            assert np.linalg.norm(T[:3, 3] - goal) < 1e-6
    seed = BUILTIN_MODELS["seed"]()
    result = solve_ik(seed, np.array([200.0, 100.0, 150.0]), position_only=True)
    assert result.family_dimension == 2 and "q6 held" in result.method
    np.testing.assert_allclose(result.solutions[:, 5], seed.home[5])


#: KUKA's published D-H table of the LBR iiwa 14 R820 (a, alpha, d in mm), written out here.
_IIWA_DH = ([0.0] * 7, np.radians([-90, 90, 90, -90, -90, 90, 0]), [360, 0, 420, 0, 400, 0, 126])


def _commands_between(arm, q, r):
    d = np.asarray(q) - np.asarray(r)
    d = (d + np.pi) % (2 * np.pi) - np.pi  # all revolute here
    return float(np.max(np.abs(d) / (arm.lattice.tick * arm.lattice.max_ticks)))


def test_numerical_tolerances_are_physical_and_the_search_retries():
    """iiwa14 poses made by its own forward kinematics are found within 1e-6 mm and 1e-8 rad
    (checked on the textbook D-H product), the answer says the solutions are a 1-dimensional
    family, and a search whose first starts all fail draws more before giving up."""
    iiwa = BUILTIN_MODELS["iiwa14"]()
    rng = np.random.default_rng(14)
    lo, hi = iiwa.lower, iiwa.upper
    fails_once = 0
    for _ in range(4):
        q = rng.uniform(0.8 * lo, 0.8 * hi)
        target = dh_pose(*_IIWA_DH, q)
        result = solve_ik(iiwa, target)
        assert result.count >= 1 and result.family_dimension == 1
        for s in result.solutions:
            pos, rot = pose_residual(dh_pose(*_IIWA_DH, s), target)
            assert pos < 1e-6 and rot < 1e-8
        # one start alone often fails; the retrying search then finds a solution
        for rng_seed in range(6):
            single = solve_numerical(iiwa, target, seeds=1, rng_seed=rng_seed, retry=False)
            if single.count == 0:
                fails_once += 1
                again = solve_numerical(iiwa, target, seeds=1, rng_seed=rng_seed)
                assert again.count >= 1
    assert fails_once >= 1
    far = np.eye(4)
    far[:3, 3] = [2000.0, 0.0, 400.0]
    none = solve_ik(iiwa, far)
    assert none.count == 0 and "3072 starts" in none.reason and "1e-06 mm" in none.reason


def test_near_picks_the_family_member_nearest_a_state():
    """A state one degree off a pose's generating solution: the first solution of ``near`` is
    a member of the family within one command of it (the generating one is 0.05 commands
    away), and the list is ordered by commands from that state."""
    iiwa = BUILTIN_MODELS["iiwa14"]()
    rng = np.random.default_rng(3)
    q = rng.uniform(0.7 * iiwa.lower, 0.7 * iiwa.upper)
    target = tool_pose(iiwa, q)
    near = q + np.radians(1.0)
    result = solve_ik(iiwa, target, near=near)
    assert result.family_dimension == 1 and result.count >= 2
    first = result.solutions[0]
    pos, rot = pose_residual(tool_pose(iiwa, first), target)
    assert pos < 1e-6 and rot < 1e-8
    dist = [_commands_between(iiwa, s, near) for s in result.solutions]
    assert dist[0] <= _commands_between(iiwa, q, near) + 1e-9
    assert dist == sorted(dist)
    ur5 = BUILTIN_MODELS["ur5"]()
    pos_only = solve_ik(ur5, np.array([300.0, 200.0, 300.0]), position_only=True, near=ur5.home)
    # the UR5's tool point lies on joint 6's axis: that joint is held, the family is 2-D
    assert pos_only.family_dimension == 2 and "q6 held" in pos_only.method
    np.testing.assert_allclose(pos_only.solutions[:, 5], ur5.home[5], atol=1e-9)
    assert np.allclose(tool_pose(ur5, pos_only.solutions)[:, :3, 3], [300, 200, 300], atol=1e-6)
    pose = " ".join(f"{v:.12g}" for v in target.reshape(-1))
    near_deg = " ".join(f"{v:.6f}" for v in np.degrees(near))
    out = _armpath("ik", "--model", "iiwa14", "--pose", pose, "--near", near_deg, "--json")
    assert out.returncode == 0, out.stderr
    doc = json.loads(out.stdout)
    assert doc["family_dimension"] == 1
    assert _commands_between(iiwa, np.radians(doc["solutions"][0]), near) <= dist[0] + 1e-6
    table = _armpath("ik", "--model", "iiwa14", "--pose", pose)
    assert "sample(s) of a 1-dimensional family of solutions" in table.stdout


def _armpath(*args):
    return subprocess.run(
        [sys.executable, "-m", "armpath", *args], capture_output=True, text=True, timeout=600
    )


def test_cli_ik_on_a_robot_file(tmp_path):
    rng = np.random.default_rng(12)
    a, alpha, d = _random_table(rng)
    doc = {
        "convention": "standard",
        "units": {"length": "mm", "angle": "rad"},
        "links": [{"a": x, "alpha": y, "d": z} for x, y, z in zip(a, alpha, d, strict=True)],
    }
    path = tmp_path / "robot.json"
    path.write_text(json.dumps(doc))
    q = rng.uniform(-np.pi, np.pi, 6)
    target = dh_pose(a, alpha, d, q)
    proc = _armpath(
        "ik",
        "--model",
        str(path),
        "--pose",
        " ".join(str(float(v)) for v in target.ravel()),
        "--json",
    )
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["units"]["angle"] == "deg" and out["count"] == len(out["solutions"])
    sols = np.radians(np.array(out["solutions"]))
    assert _contains(sols, q)
    for s, r in zip(sols, out["residuals"], strict=True):
        assert r["position_mm"] < 1e-6
        assert pose_residual(dh_pose(a, alpha, d, s), target)[0] < 1e-6
    fk = _armpath("fk", "--model", str(path), *map(str, np.degrees(q)), "--json")
    assert np.allclose(json.loads(fk.stdout)["pose"], target, atol=1e-9)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["ik", "--model", "puma560", "--pose", "1 2 3"], "expected 16 numbers"),
        (["ik", "--model", "puma560", "--xyz", "1", "2", "3", "--pose", "1"], "exactly one"),
        (["ik", "--model", "nosuch", "--xyz", "1", "2", "3"], "unknown model 'nosuch'"),
        (
            ["ik", "--model", "puma560", "--pose", "2 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"],
            "not a rotation",
        ),
        (
            ["ik", "--model", "puma560", "--pose", "1 0 0 9000 0 1 0 0 0 0 1 0 0 0 0 1"],
            "no solution",
        ),
        (["fk", "--model", "puma560", "1", "2"], "expected 6 numbers"),
    ],
)
def test_cli_ik_errors(args, message):
    proc = _armpath(*args)
    assert proc.returncode == 1
    assert message in proc.stderr
    assert proc.stderr.count("\n") == 1
    assert proc.stdout == ""  # no empty table of solutions before the error


# ------------------------------------------------------------------------------------------
# Seed 004: the painting robot's example
# ------------------------------------------------------------------------------------------

#: The pose printed in seed 004 for (20, 30, 20, 25, 80, 0) deg (mm).
PAPER_POSE = np.array(
    [
        [-0.0478066, -0.774265, 0.631053, 1450.49],
        [0.0998169, 0.62491, 0.77429, 528.48],
        [-0.993857, 0.100006, 0.04741, 1023.93],
        [0, 0, 0, 1],
    ]
)
#: Seed 004's table 1: the real solutions (deg), rows 2 and 4 inside the joint ranges.
PAPER_TABLE = np.array(
    [
        [20.0212, 129.852, -181.088, 154.534, -74.0757, 8.56948],
        [20.0, 30.0, 20.0, 25.0, 80.0, 0.0],
        [16.1045, 130.806, -175.564, -67.8718, 69.7369, 130.717],
        [16.0113, 31.0786, 13.1693, -106.549, -76.0736, -118.13],
    ]
)


def _deg_match(solutions_rad, row_deg, tol_deg):
    diff = (np.degrees(solutions_rad) - row_deg + 180.0) % 360.0 - 180.0
    hits = np.flatnonzero(np.all(np.abs(diff) < tol_deg, axis=1))
    return int(hits[0]) if hits.size else -1


def test_seed004_painter_reproduces_the_papers_pose_and_table():
    arm = BUILTIN_MODELS["painter004"]()
    T = tool_pose(arm, np.radians(PAPER_TABLE[1]))
    assert np.abs(T[:3, :3] - PAPER_POSE[:3, :3]).max() < 1e-6  # printed to 6 digits
    assert np.abs(T[:3, 3] - PAPER_POSE[:3, 3]).max() < 0.01  # printed to 0.01 mm
    result = solve_ik(arm, T)
    assert result.count == 4
    # the table agrees with the exact solutions to 0.0012 deg (its row 3 is the least precise)
    matched = [_deg_match(result.solutions, row, 2e-3) for row in PAPER_TABLE]
    assert sorted(matched) == [0, 1, 2, 3]
    assert [bool(result.within_limits[k]) for k in matched] == [False, True, False, True]
    # every table row is a solution of the same pose (to the table's printed digits)
    for row in PAPER_TABLE:
        assert np.abs(tool_pose(arm, np.radians(row))[:3, 3] - T[:3, 3]).max() < 0.05


def test_cli_ik_on_the_papers_printed_pose():
    pose = " ".join(f"{v:g}" for v in PAPER_POSE.ravel())
    proc = _armpath("ik", "--model", "painter004", "--pose", pose, "--json")
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["count"] == 4 and out["units"]["angle"] == "deg"
    sols = np.radians(np.array(out["solutions"]))
    for row in PAPER_TABLE:  # the printed pose has 6 digits: solutions agree to ~0.005 deg
        assert _deg_match(sols, row, 0.01) >= 0
    assert max(r["position_mm"] for r in out["residuals"]) < 1e-6


def test_solution_sets_agree_with_eaik():
    """EAIK (subproblem decomposition, an independent analytic solver) on the geometries it
    supports: PUMA 560, UR5, random spherical-wrist arms whose first axes meet or are
    parallel, and random arms with three parallel axes (either way round). Every solution EAIK
    returns is one of ours, and the counts agree wherever EAIK itself finds the generating
    vector."""
    from eaik.IK_DH import DhRobot

    rng = np.random.default_rng(13)
    tables = [
        (
            [0, 431.8, 20.32, 0, 0, 0],
            np.radians([90, 0, -90, 90, -90, 0]),
            [0, 0, 150.05, 431.8, 0, 0],
        ),
        (
            [0, -425, -392.25, 0, 0, 0],
            np.radians([90, 0, 0, 90, -90, 0]),
            [89.159, 0, 0, 109.15, 94.65, 82.3],
        ),
    ]
    for k in range(6):  # spherical wrists on random positioning arms with axes 1, 2 meeting
        a, alpha, d = _random_table(rng)  # or axes 2, 3 parallel (EAIK's decompositions)
        a[3] = a[4] = d[4] = 0.0
        alpha[3], alpha[4] = np.pi / 2, -np.pi / 2
        if k % 2:
            alpha[1] = 0.0
        else:
            a[0] = 0.0
        tables.append((a, alpha, d))
    for k in range(4):  # three parallel axes: 2-4 with axes 5, 6 meeting, or 3-5 with 1, 2
        a, alpha, d = _random_table(rng)
        if k % 2:
            alpha[2] = alpha[3] = a[0] = 0.0
        else:
            alpha[1] = alpha[2] = a[4] = 0.0
        tables.append((a, alpha, d))
    compared = equal = peer_misses = 0
    for a, alpha, d in tables:
        a, alpha, d = (np.asarray(x, float) for x in (a, alpha, d))
        peer = DhRobot(alpha, a, d)
        assert peer.hasKnownDecomposition()
        solver = complete_solver(_arm(a, alpha, d))  # closed form or elimination, as for users
        Q = rng.uniform(-np.pi, np.pi, (40, 6))
        targets = np.array([dh_pose(a, alpha, d, q) for q in Q])
        for q, target, ours in zip(Q, targets, solver.solve_batch(targets), strict=True):
            sol = peer.IK(target)
            theirs = np.asarray(sol.Q, float).reshape(-1, 6)[~np.asarray(sol.is_LS, bool)]
            assert _contains(ours.solutions, q)
            for s in theirs:
                assert _contains(ours.solutions, s, tol=1e-5)
            compared += 1
            if not _contains(theirs, q, tol=1e-5):
                peer_misses += 1
                continue
            equal += ours.count == len(theirs)
    assert compared == 480 and peer_misses <= 24, peer_misses
    assert equal >= 0.97 * (compared - peer_misses), (equal, compared, peer_misses)


def _distinct_pairwise(q, prismatic, within):
    """The rule as written once: each row, in order, dropped when a kept one is within
    ``within`` in every joint, revolute differences taken modulo a turn."""
    kept = []
    for k in range(q.shape[0]):
        d = q[kept] - q[k]
        d[:, ~prismatic] = (d[:, ~prismatic] + np.pi) % (2 * np.pi) - np.pi
        if not np.any(np.all(np.abs(d) <= within, axis=1)):
            kept.append(k)
    return kept


@pytest.mark.parametrize("seed", range(4))
def test_numerical_solutions_are_deduplicated_as_pairwise(seed):
    """The k-d tree's distinct solutions equal the pairwise rule's, with near-copies, copies a
    whole turn away and copies across the +-pi seam among them."""
    from armpath.ik.numerical import distinct_solutions

    rng = np.random.default_rng(seed)
    prismatic = np.array([False, False, True, False, False, False])
    base = rng.uniform(-np.pi, np.pi, (300, 6))
    base[:40, rng.integers(0, 6)] = np.pi - rng.uniform(0, 2e-6, 40)  # at the seam
    copies = base[rng.integers(0, 300, 600)] + rng.uniform(-1.5e-6, 1.5e-6, (600, 6))
    turns = rng.integers(-2, 3, (600, 6)) * 2 * np.pi
    copies[:, ~prismatic] += turns[:, ~prismatic]
    q = np.vstack([base, copies])[rng.permutation(900)]
    kept = distinct_solutions(q, prismatic, 1e-6)
    assert kept.tolist() == _distinct_pairwise(q, prismatic, 1e-6)
    assert 300 <= kept.size < 900  # some copies kept (beyond 1e-6), most dropped


def test_one_target_at_a_time_and_many_poses_by_solve_batch():
    """``solve_ik`` given two poses stacked solved the first and dropped the second without a
    word; it now refuses any shape but its one target's, and ``solve_batch`` solves each pose
    (the generating joint values among the solutions, every one replayed by the textbook D-H
    product)."""
    from armpath.ik import complete_solver

    rng = np.random.default_rng(7)
    a, alpha, d = _random_table(rng)
    arm = _arm(a, alpha, d)
    Q = rng.uniform(-2.5, 2.5, (2, 6))
    T = np.stack([dh_pose(a, alpha, d, q) for q in Q])
    for target, position_only, needle in (
        (T, False, r"got shape \(2, 4, 4\); complete_solver\(arm\).solve_batch"),
        (T[0, :3, 3], False, "a point alone needs position_only=True"),
        (T[:, :3, 3], True, r"a 3-vector \(position_only\), got shape \(2, 3\)"),
    ):
        with pytest.raises(InvalidInputError, match=needle):
            solve_ik(arm, target, position_only=position_only)
    for q, target, result in zip(Q, T, complete_solver(arm).solve_batch(T), strict=True):
        assert _contains(result.solutions, q)
        for found in result.solutions:
            assert max(pose_residual(dh_pose(a, alpha, d, found), target)) < 1e-6


@pytest.mark.parametrize("name", ["iiwa14", "ur5", "scara"])
def test_compiled_levenberg_marquardt_takes_the_numpy_steps(name):
    """The compiled Levenberg-Marquardt (each row through its iterations in one loop) against
    the numpy form (rows stepped together, batched solves): after 1, 2 and 5 iterations the
    same configurations to 1e-9 rad, in each mode (the point alone, a full rotation per row,
    an approach axis per row), with a box that holds one joint and clips the others; after
    60, as many rows on the target (give or take two of 40: a row on the edge of converging
    goes either way on rounding)."""
    from armpath.ik.family import GenericFamily
    from armpath.ik.target import ToolTarget

    arm = dh_arm(scara_rows(), name="scara") if name == "scara" else BUILTIN_MODELS[name]()
    n = arm.n_joints
    rng = np.random.default_rng(3)
    goal = tool_pose(arm, np.clip(rng.uniform(-1.0, 1.0, n), arm.lower, arm.upper))
    fam = GenericFamily(arm, ToolTarget(goal[:3, 3]))
    starts = np.clip(rng.uniform(-2.0, 2.0, (40, n)), arm.lower, arm.upper)
    lower, upper = np.full(n, -2.5), np.full(n, 2.5)
    lower[0] = upper[0] = starts[0, 0]  # joint 1 held where the first row has it
    modes = [{}, {"axes": np.tile(goal[:3, 2], (40, 1))}]
    if n >= 6:
        modes.append({"rotations": np.tile(goal[:3, :3], (40, 1, 1))})
    for mode in modes:
        for box in ({}, {"lower": lower, "upper": upper}):
            for iterations in (1, 2, 5):
                a = fam.refine(starts, iterations, compiled=False, **mode, **box)
                b = fam.refine(starts, iterations, **mode, **box)
                assert np.abs(a - b).max() < 1e-9, (list(mode), list(box), iterations)
            a = fam.refine(starts, 60, compiled=False, **mode)
            b = fam.refine(starts, 60, **mode)
            on_a = np.linalg.norm(tool_pose(arm, a)[:, :3, 3] - goal[:3, 3], axis=1) < 1e-6
            on_b = np.linalg.norm(tool_pose(arm, b)[:, :3, 3] - goal[:3, 3], axis=1) < 1e-6
            assert abs(int(on_a.sum()) - int(on_b.sum())) <= 2 and on_b.sum() >= 5


def test_compiled_levenberg_marquardt_on_threads_takes_the_same_steps(monkeypatch):
    """The compiled Levenberg-Marquardt's parallel twin (rows on numba's threads) against its
    serial one: bit for bit the same configurations, each row's steps being its own (iiwa14,
    200 rows, a full rotation per row, 30 iterations; both kernels forced)."""
    from armpath.ik import lm_kernel
    from armpath.ik.family import GenericFamily
    from armpath.ik.target import ToolTarget

    arm = BUILTIN_MODELS["iiwa14"]()
    rng = np.random.default_rng(5)
    goal = tool_pose(arm, np.clip(rng.uniform(-1.0, 1.0, arm.n_joints), arm.lower, arm.upper))
    fam = GenericFamily(arm, ToolTarget(goal[:3, 3]))
    starts = np.clip(rng.uniform(-2.0, 2.0, (200, arm.n_joints)), arm.lower, arm.upper)
    rotations = np.tile(goal[:3, :3], (200, 1, 1))
    ran: list[str] = []
    serial, parallel = lm_kernel.refine_rows_serial, lm_kernel.refine_rows_parallel
    for name, kernel, tag in (
        ("refine_rows_serial", serial, "s"),
        ("refine_rows_parallel", parallel, "p"),
    ):
        monkeypatch.setattr(lm_kernel, name, lambda *a, k=kernel, t=tag: ran.append(t) or k(*a))
    monkeypatch.setattr(lm_kernel, "threads_pay_off", lambda *_: False)
    a = fam.refine(starts, 30, rotations=rotations)
    monkeypatch.setattr(lm_kernel, "threads_pay_off", lambda *_: True)
    b = fam.refine(starts, 30, rotations=rotations)
    assert ran == ["s", "p"]
    assert np.array_equal(a, b)
    on = np.linalg.norm(tool_pose(arm, b)[:, :3, 3] - goal[:3, 3], axis=1) < 1e-6
    assert on.sum() >= 20  # the rows do converge (not a comparison of untouched starts)


@pytest.mark.parametrize("name", ["seed", "ur5", "iiwa14"])
def test_compiled_newton_projection_takes_the_pseudo_inverse_steps(name):
    """The tracer's projection onto a tool point (compiled minimum-norm Newton steps) against
    the same steps written with numpy's pseudo-inverse, the numpy forward kinematics and
    Jacobian: 200 starts, each 0.02 rad from a configuration whose tool point is the target;
    the same configurations to 1e-8 rad (rounding grows near a singular start), the tool point
    on the target to 1e-6 mm where the numpy steps get there, and a held joint left where it
    was."""
    from armpath.ik.lm_kernel import project_point
    from armpath.kinematics import compiled_chain, position_jacobian

    arm = BUILTIN_MODELS[name]()
    n = arm.n_joints
    rng = np.random.default_rng(11)
    moving = np.ones(n, dtype=bool)
    moving[0] = name == "seed"  # the others: joint 1 held
    for _ in range(200):
        q = np.clip(rng.uniform(-2.0, 2.0, n), arm.lower, arm.upper)
        E = tool_pose(arm, q + rng.normal(0.0, 0.02, n))[:3, 3]
        want = q.copy()
        for _ in range(5):
            e = E - tool_pose(arm, want)[:3, 3]
            if np.linalg.norm(e) < 1e-9:
                break
            want[moving] += np.linalg.pinv(position_jacobian(arm, want)[:, moving]) @ e
        got = project_point(q, E, moving, 5, *compiled_chain(arm)[:5])
        assert np.abs(got - want).max() < 1e-8
        assert got[0] == q[0] or moving[0]
        if np.linalg.norm(tool_pose(arm, want)[:3, 3] - E) < 1e-9:
            assert np.linalg.norm(tool_pose(arm, got)[:3, 3] - E) < 1e-6
