"""Reach planning: Task 1 replayed independently, fewest commands against an independent optimum."""

import json

import numpy as np
import pytest
from scipy.optimize import minimize

import independent
from armpath.commands import deg_to_ticks
from armpath.errors import CollisionError, JointLimitError, PlanningError, UnreachableError
from armpath.export import json_text, reach_result_dict
from armpath.model import seed_arm
from armpath.planning import ReachOptions, plan_reach
from armpath.scenes import seed_scene
from armpath.tasks import reach_task

ARM = seed_arm()
SCENE = seed_scene()
HOME = [0, -90, 0, 0, -90, 0]
LIMITS = np.array([np.inf, 125, 138, np.inf, 133.5, np.inf])


def independent_min_largest_change(target, start_deg, tol=0.0, starts=150, seed=0):
    """min over joint vectors reaching ``target`` (within tol) of max |theta - start| (deg).

    Multi-start SLSQP directly in joint space with the independent FK; shares nothing with the
    planner's solution-family search.
    """
    rng = np.random.default_rng(seed)
    s = np.asarray(start_deg[:5], float)
    lim = LIMITS[:5]
    bounds = [(-b, b) if np.isfinite(b) else (None, None) for b in lim] + [(0, None)]

    def tip(x):
        return independent.points(np.r_[x[:5], 0.0])[4]

    cons = [{"type": "ineq", "fun": lambda x: np.r_[x[5] - (x[:5] - s), x[5] + (x[:5] - s)]}]
    if tol == 0:
        cons.append({"type": "eq", "fun": lambda x: tip(x) - target})
    else:
        cons.append({"type": "ineq", "fun": lambda x: tol**2 - np.sum((tip(x) - target) ** 2)})
    best = np.inf
    for _ in range(starts):
        x0 = s + rng.uniform(-180, 180, 5)
        x0[1:3] = np.clip(x0[1:3], -lim[1:3], lim[1:3])
        x0[4] = np.clip(x0[4], -lim[4], lim[4])
        z0 = np.r_[x0, np.max(np.abs(x0 - s))]
        r = minimize(
            lambda z: z[5],
            z0,
            method="SLSQP",
            bounds=bounds,
            constraints=cons,
            options={"maxiter": 400, "ftol": 1e-12},
        )
        if r.success and np.linalg.norm(tip(r.x) - target) <= tol + 1e-6:
            best = min(best, float(np.max(np.abs(r.x[:5] - s))))
    return best


@pytest.fixture(scope="module")
def task1():
    result = reach_task(SCENE, ARM)
    doc = json.loads(json_text(reach_result_dict(result, ARM, SCENE)))
    return result, doc


def test_task1_meets_the_issue_targets(task1):
    _, doc = task1
    assert doc["n_commands"] <= 63
    assert doc["error_mm"] <= 0.05
    assert doc["lower_bound_commands"] == 63 == doc["n_commands"]
    assert doc["wall_thickness"] == "normal"
    assert doc["min_clearance_mm"] >= 1.0


def test_task1_replayed_independently(task1):
    _, doc = task1
    cmds = np.array(doc["commands"])
    assert cmds.shape == (doc["n_commands"], 6)
    assert cmds.dtype.kind == "i" and np.abs(cmds).max() <= 20
    assert doc["initial_deg"] == HOME
    states = independent.replay(doc["initial_deg"], cmds)
    assert np.all(np.abs(states) <= LIMITS + 1e-9)
    tip = independent.points(states[-1])[4]
    err = np.linalg.norm(tip - np.array(doc["target"]))
    assert err == pytest.approx(doc["error_mm"], abs=1e-9)
    assert doc["target"] == [20.0, -200.0, 120.0]
    np.testing.assert_allclose(tip, doc["tip"], atol=1e-9)
    # continuous motion: links BC, CD, DE sampled every 1 mm, 20 instants per command
    pts = independent.motion_points(doc["initial_deg"], cmds, 20)
    samples, is_tip = independent.link_samples(pts, spacing=1.0)
    wp = independent.Workpiece("normal").distance(samples.reshape(-1, 3)).reshape(samples.shape[:2])
    clearance = np.minimum(wp, samples[..., 2])
    is_tip = np.broadcast_to(is_tip, clearance.shape)
    assert clearance[~is_tip].min() >= 1.0
    assert clearance[is_tip].min() >= 0.0
    # the reported minimum is attained and no sample beats its proven lower bound
    assert clearance.min() >= doc["clearance"]["min_clearance_lower_bound_mm"] - 1e-9
    assert doc["min_clearance_mm"] <= clearance.min() + 1e-9


@pytest.mark.slow
def test_task1_lower_bound_matches_an_independent_optimum(task1):
    result, _ = task1
    lb = result.lower_bound
    t_ind = independent_min_largest_change(np.array([20.0, -200.0, 120.0]), HOME, starts=60)
    assert lb.exact_max_joint_change_deg == pytest.approx(t_ind, abs=1e-4)
    t_tol = independent_min_largest_change(
        np.array([20.0, -200.0, 120.0]), HOME, tol=0.05, starts=30
    )
    assert lb.max_joint_change_deg == pytest.approx(t_tol, abs=1e-4)
    assert lb.commands == int(np.ceil(t_tol / 2)) == 63


@pytest.mark.parametrize(
    ("target", "start"),
    [
        ((300.0, 250.0, 300.0), HOME),
        ((-150.0, 350.0, 50.0), HOME),
        ((-200.0, -300.0, 400.0), [90, -40, 60, 30, -45, 10]),
    ],
)
@pytest.mark.slow
def test_other_targets_reach_the_independent_optimum(target, start):
    target = np.array(target)
    result = plan_reach(ARM, SCENE.world, deg_to_ticks(start), target)
    t_ind = independent_min_largest_change(target, start, tol=0.05, starts=40)
    assert result.n_commands == result.lower_bound.commands == int(np.ceil(t_ind / 2 - 1e-9))
    assert result.error_mm <= 0.05
    states = independent.replay(start, result.sequence.commands)
    tip = independent.points(states[-1])[4]
    assert np.linalg.norm(tip - target) == pytest.approx(result.error_mm, abs=1e-9)
    assert result.clearance.certified_ok


@pytest.mark.slow
@pytest.mark.parametrize("target", [(0.0, -575.0, 140.01), (0.0, 575.0, 140.02)])
def test_a_target_just_beyond_the_stretched_arm_is_reached_within_the_tolerance(target):
    """The seed arm stretched along y puts its fingertip at (0, +-575, 140) mm; a target 0.01
    or 0.02 mm above lies just beyond its reach, within the 0.05 mm tolerance of it. The
    goal-state search solved the target exactly with two joints held on the lattice, found
    nothing, and reported that no lattice state "satisfies the clearance rule". Now the
    lattice states about the family's own sample are taken: the plan ends within the
    tolerance, the replay by the independent forward kinematics gives the error reported, and
    its command count is the independent optimum's."""
    target = np.array(target)
    result = plan_reach(ARM, SCENE.world, deg_to_ticks(HOME), target)
    assert result.error_mm <= 0.05
    states = independent.replay(HOME, result.sequence.commands)
    tip = independent.points(states[-1])[4]
    assert np.linalg.norm(tip - target) == pytest.approx(result.error_mm, abs=1e-9)
    t_ind = independent_min_largest_change(target, HOME, tol=0.05, starts=20)
    assert result.lower_bound.commands == int(np.ceil(t_ind / 2 - 1e-9))
    assert result.n_commands <= result.lower_bound.commands + 1
    assert result.clearance.certified_ok


@pytest.mark.slow
def test_lattice_can_need_one_more_command_than_the_continuous_bound():
    # 2 commands suffice in continuous joint space, but no lattice state within 2 commands is
    # within 0.05 mm (decided exhaustively by the independent model); the planner must say so
    target, start = np.array([5.0, 505.0, 80.0]), HOME
    result = plan_reach(ARM, SCENE.world, deg_to_ticks(start), target)
    t_ind = independent_min_largest_change(target, start, tol=0.05, starts=40)
    assert result.lower_bound.commands == int(np.ceil(t_ind / 2 - 1e-9)) == 2
    assert not independent.lattice_has_state_within(target, start, 2, 0.05)
    # the plan's three commands, replayed by the independent model, end within 0.05 mm
    commands = np.diff(result.sequence.states(), axis=0)
    assert commands.shape[0] == 3 and np.abs(commands).max() <= 20
    end_deg = (deg_to_ticks(start) + commands.sum(axis=0)) / 10.0
    replayed_error = np.linalg.norm(independent.points(end_deg)[-1] - target)
    assert replayed_error == pytest.approx(result.error_mm, abs=1e-6)
    assert result.n_commands == 3 and result.error_mm <= 0.05
    assert not result.is_provably_fewest
    assert len(result.fewer_commands_rejected) == 1
    assert (
        "2 commands: smallest fingertip error on the lattice is 0.0676 mm"
        in (result.fewer_commands_rejected[0])
    )


@pytest.mark.slow
def test_a_wide_tolerance_is_reached_off_the_target_in_fewer_commands():
    """With 20 mm to spare, Task 1's target is reached in the fewest commands of any state
    within the tolerance (the independent optimum over the whole ball, 61), not the 63 that
    end on the target itself: the lattice is searched off the target too."""
    target = np.array([20.0, -200.0, 120.0])
    result = plan_reach(
        ARM, SCENE.world, deg_to_ticks(HOME), target, ReachOptions(tolerance_mm=20.0)
    )
    t_ball = independent_min_largest_change(target, HOME, tol=20.0, starts=40)
    t_exact = independent_min_largest_change(target, HOME, starts=40)
    assert int(np.ceil(t_ball / 2 - 1e-9)) == 61 < int(np.ceil(t_exact / 2 - 1e-9)) == 63
    assert result.n_commands == result.lower_bound.commands == 61
    states = independent.replay(HOME, result.sequence.commands)
    error = np.linalg.norm(independent.points(states[-1])[4] - target)
    assert error == pytest.approx(result.error_mm, abs=1e-9)
    assert 1.0 < error <= 20.0  # off the target, within the tolerance
    assert result.clearance.certified_ok
    # then the smallest error: no state a tick from it on any of joints 1-5, within the same
    # 61 commands and the limits, comes nearer the target (independent FK)
    import itertools

    end = np.array(HOME) * 10 + np.asarray(result.sequence.commands).sum(axis=0)
    steps = np.array(list(itertools.product([-1, 0, 1], repeat=5)))
    near = np.repeat(end[None], len(steps), axis=0)
    near[:, :5] += steps
    fits = np.abs(near - np.array(HOME) * 10).max(axis=1) <= 20 * 61
    fits &= np.all(np.abs(near / 10.0) <= LIMITS, axis=1)
    errors = [np.linalg.norm(independent.points(q / 10.0)[4] - target) for q in near[fits]]
    assert min(errors) >= error - 1e-9


def test_tighter_tolerance_is_honoured():
    result = plan_reach(
        ARM, SCENE.world, deg_to_ticks(HOME), [20, -200, 120], ReachOptions(tolerance_mm=0.01)
    )
    assert result.error_mm <= 0.01


def test_unreachable_target_names_the_nearest_distance():
    with pytest.raises(UnreachableError, match=r"out of reach.*is 85\.0\d\d mm away"):
        plan_reach(ARM, SCENE.world, deg_to_ticks(HOME), [0, 0, 800])


def test_start_in_collision_is_refused():
    with pytest.raises(CollisionError, match=r"start state is in collision.*workpiece"):
        plan_reach(ARM, SCENE.world, deg_to_ticks([-90, -90, 0, 0, -90, 0]), [20, -200, 120])


def test_start_outside_limits_is_refused():
    with pytest.raises(JointLimitError, match="joint 2"):
        plan_reach(ARM, SCENE.world, deg_to_ticks([0, -130, 0, 0, -90, 0]), [20, -200, 120])


def test_target_inside_the_wall_is_refused():
    inside_wall = [210 + 132 - 4, 0, 90]  # mid-wall at half height
    with pytest.raises(CollisionError, match="inside workpiece"):
        plan_reach(ARM, SCENE.world, deg_to_ticks(HOME), inside_wall)


@pytest.mark.slow
def test_blocked_direct_motion_is_reported_or_planned_around():
    # a point on the far side of the workpiece, low down: every direct motion hits the wall
    target = [300, -170, 15]
    with pytest.raises(PlanningError, match=r"blocked|collision"):
        plan_reach(
            ARM,
            SCENE.world,
            deg_to_ticks(HOME),
            target,
            ReachOptions(extra_commands=0, plan_around=False),
        )
    result = plan_reach(
        ARM, SCENE.world, deg_to_ticks(HOME), target, ReachOptions(extra_commands=0)
    )
    assert result.method != "direct" and result.clearance.certified_ok
    assert result.n_commands >= result.lower_bound.commands
    assert "planned around" in result.fewer_commands_rejected[-1]
    states = independent.replay(HOME, result.sequence.commands)
    assert np.linalg.norm(independent.points(states[-1])[4] - target) <= 0.05
    pts = independent.motion_points(HOME, result.sequence.commands, 12)
    samples, is_tip = independent.link_samples(pts, spacing=1.0)
    wp = independent.Workpiece("normal").distance(samples.reshape(-1, 3)).reshape(samples.shape[:2])
    clearance = np.minimum(wp, samples[..., 2])
    assert clearance[~np.broadcast_to(is_tip, clearance.shape)].min() >= 1.0


def _de_to_base_column_mm(theta_deg: np.ndarray) -> float:
    """Distance of link DE to the base column AB (the z axis from 0 to 140 mm), from the
    independent FK with DE sampled every 0.01 mm."""
    pts = independent.points(theta_deg)
    s = np.linspace(0.0, 1.0, 6501)[:, None]
    de = pts[3] + s * (pts[4] - pts[3])
    z = np.clip(de[:, 2], 0.0, 140.0)
    return float(np.min(np.linalg.norm(de - np.c_[0 * z, 0 * z, z], axis=-1)))


def test_a_target_by_the_base_column_is_refused_at_once_with_the_reason():
    """``reach 0 0 0`` searched four command counts for 18 s before refusing; a target whose
    distance to the fixed base column plus the tolerance is under the 1 mm between links is
    now refused up front, naming the column and the tool's link. Independent check: every
    configuration the independent FK puts within the tolerance of such a target (multi-start
    least squares) brings DE within 1 mm of AB; 0.96 mm off the axis (0.96 + 0.05 > 1) the
    reason does not hold and is not given."""
    from scipy.optimize import least_squares

    world = SCENE.world
    assert world.fixed_link_blocker(ARM, [0.94, 0.0, 100.0], 0.05) is not None
    assert world.fixed_link_blocker(ARM, [0.96, 0.0, 100.0], 0.05) is None
    assert world.fixed_link_blocker(ARM, [0.0, 0.0, 300.0], 0.05) is None  # above the column
    target = np.array([0.3, 0.4, 100.0])
    with pytest.raises(CollisionError, match=r"lies 0\.5 mm from link AB, which no joint moves"):
        plan_reach(ARM, SCENE.world, deg_to_ticks(HOME), target)
    rng = np.random.default_rng(3)
    found = 0
    for _ in range(60):
        x0 = rng.uniform(-120.0, 120.0, 5)
        r = least_squares(lambda x: independent.points(np.r_[x, 0.0])[4] - target, x0)
        theta = np.r_[r.x, 0.0]
        if np.linalg.norm(independent.points(theta)[4] - target) <= 0.05:
            found += 1
            assert _de_to_base_column_mm(theta) < 1.0
    assert found >= 10


def test_a_wide_tolerance_is_reached_in_the_fewest_commands_the_lattice_allows():
    """With a 50 mm tolerance the closed form's search (about the target's own family and on
    the way to the nearest fingertip the box allows) found no lattice state within 37 commands
    and planned 38 against a bound of 37; the generic search's listing of every lattice state
    within the tolerance now finds one: 37, proven. Independent truth: the least largest
    joint change of any configuration within 50 mm (multi-start SLSQP on the independent FK)
    needs 37 commands, and the plan's replay ends within the tolerance."""
    target = np.array([300.0, 0.0, 300.0])
    result = plan_reach(
        ARM, SCENE.world, deg_to_ticks(HOME), target, ReachOptions(tolerance_mm=50.0)
    )
    t_ind = independent_min_largest_change(target, HOME, tol=50.0, starts=40)
    assert result.n_commands == result.lower_bound.commands == int(np.ceil(t_ind / 2 - 1e-9)) == 37
    assert result.lower_bound.proven and result.clearance.certified_ok
    states = independent.replay(HOME, result.sequence.commands)
    tip = independent.points(states[-1])[4]
    assert np.linalg.norm(tip - target) == pytest.approx(result.error_mm, abs=1e-9)
    assert result.error_mm <= 50.0
