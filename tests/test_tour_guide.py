"""Issue 21: goal states of a tour chosen together (armpath.planning.tour_guide).

* the guided path through the clear members of every target is the shortest one: a brute force
  over every combination of members (whole commands per leg, joints spanning a whole turn
  measured the shorter way round, written here from the arm's limits) finds the same total;
* its members reach their targets and keep the margin plus the buffer (independent forward
  kinematics of the UR5 cell's arm, the cell's own clearance); the lattice goal states next to
  them reach their targets within the tolerance;
* the lattice goal state taken next to a guide's member is the one nearest it: a brute force over
  the lattice about a seed Task 3 member on the workpiece's inner wall (independent forward
  kinematics and clearance of tests/independent_replay.py) finds none nearer that reaches the
  weld within the tolerance and keeps the rule (the most accurate state, taken before, lay 4
  commands away along the wrist; the member itself, its tool point on the wall, was dropped);
* a guide built with a smaller buffer and then narrowed to a larger one holds exactly the
  members of a guide built with the larger one, each keeping its room (independent forward
  kinematics: the members still reach their welds);
* the lattice goal states within a command of each member of a path are all listed (a brute
  force over the lattice within 9 ticks of each member, independent forward kinematics), and
  the first of each weld's make a cheapest combination (every combination of them);
* (tests/test_ur5_cell.py) on the UR5 cell, the tour planned through them needs far fewer
  commands than through goal states each picked nearest the start (393 before).
"""

from __future__ import annotations

import itertools
import tomllib
from pathlib import Path

import numpy as np
import pytest

import independent_replay as ir
from armpath.ik.family import shift_into_limits
from armpath.ik.target import ToolTarget
from armpath.kinematics import position_jacobian, tool_position
from armpath.model.seed_arm import seed_arm
from armpath.planning import tour
from armpath.planning.reach_generic import generic_goal_states
from armpath.planning.tour_guide import TourGuide
from armpath.scenes import load_scene
from armpath.scenes.arm import scene_arm
from test_ur5_cell import CELL, ur5_landmarks


def ur5_cell_guide():
    """The UR5 cell's scene, arm, welds and the guide through them (tolerance 0.05 mm)."""
    scene = load_scene(CELL)
    arm = scene_arm(scene)
    pts = scene.spotweld_targets_mm()
    fam = tour._targets_family(arm, scene.world, pts)
    return scene, arm, pts, TourGuide.build(fam, pts, 0.05)


@pytest.fixture(scope="module")
def cell():
    return ur5_cell_guide()


def whole_command_legs(arm, a, b, tip):
    """Whole commands of every leg between members ``a`` (A, n) and ``b`` (B, n) rad: the
    largest change of the joints ``tip`` in steps, rounded up, a joint whose limits span a
    whole turn the shorter way round (written here from the arm's limits)."""
    step = (arm.lattice.tick * arm.lattice.max_ticks)[tip]
    turn = 2 * np.pi / step
    wraps = (arm.upper - arm.lower)[tip] >= 2 * np.pi
    d = (b[None, :, tip] - a[:, None, tip]) / step
    d = np.where(wraps, d - turn * np.round(d / turn), d)
    return np.ceil(np.abs(d).max(axis=-1) - 1e-9)


def _brute_total(arm, q0, layers, tip):
    """Every combination of one member per layer: the least sum of whole-command legs."""
    total = whole_command_legs(arm, q0[None], layers[0], tip)[0]
    for a, b in itertools.pairwise(layers):
        total = (total[:, None] + whole_command_legs(arm, a, b, tip)).min(axis=0)
    return float(total.min())


def test_the_guided_path_is_the_shortest_through_its_members(cell):
    _, arm, _, guide = cell
    q0 = np.radians([0, -90, 90, -90, -90, 0])
    rng = np.random.default_rng(5)
    for order in [(0, 1, 2), (3, 1, 0), (2, 0, 3, 1)]:
        # a few members per target, so that the brute force stays small
        picked = []
        for t in order:
            lay = guide.layers[t]
            keep = rng.choice(lay.size, min(lay.size, 30), replace=False)
            picked.append(keep)
        small = TourGuide(
            guide.arm,
            guide.world,
            guide.sampler,
            [
                type(guide.layers[t])(
                    guide.layers[t].u[k], guide.layers[t].err[k], guide.layers[t].q[k],
                    guide.layers[t].dirs[k],
                )
                for t, k in zip(order, picked, strict=True)
            ],
            guide.targets[list(order)],
            guide.tolerance_mm,
        )  # fmt: skip
        total, members = small.path(q0, tuple(range(len(order))), back=False)
        truth = _brute_total(
            arm, q0, [small.layers[i].q for i in range(len(order))], guide.sampler.tip
        )
        assert total == truth
        # the members it returns are those of a path of that length (turned nearest each other)
        prev = q0
        length = 0.0
        step = arm.lattice.tick * arm.lattice.max_ticks
        for q in members:
            assert np.allclose(shift_into_limits(arm, q[None], prev)[0], q)
            length += np.ceil(np.abs(q - prev)[guide.sampler.tip] / step[guide.sampler.tip]).max()
            prev = q
        assert length >= total - 1e-9


def test_guided_members_and_goal_states_reach_their_welds(cell):
    scene, arm, pts, guide = cell
    q0 = np.radians([0, -90, 90, -90, -90, 0])
    order = (0, 3, 1, 2)
    _, members = guide.path(q0, order, back=False)
    tips = np.array([ur5_landmarks(np.degrees(q))[-1] for q in members])
    assert np.abs(tips - pts[list(order)]).max() < 0.05
    values, _ = scene.world.pair_clearances(arm, np.array(members))
    is_tip = np.array([p.is_tip for p in scene.world.pairs(arm)])
    assert np.all(values[:, ~is_tip] >= scene.world.required(arm)[~is_tip] + 1.5 - 1e-9)
    goals = guide.goal_states(q0, order, members)
    assert goals is not None
    for t, states in zip(order, goals, strict=True):
        tips = np.array([ur5_landmarks(np.degrees(arm.lattice.to_joint(s)))[-1] for s in states])
        assert np.linalg.norm(tips - pts[t], axis=-1).max() <= 0.05


def test_a_narrowed_guide_holds_what_a_guide_built_so_holds(cell):
    scene, arm, pts, guide = cell  # built with the default buffer, 1.5 mm
    fam = tour._targets_family(arm, scene.world, pts)
    wide = TourGuide.build(fam, pts, 0.05, 0.5)
    narrowed = wide.with_buffer(1.5)
    for t in range(len(pts)):
        assert wide.layers[t].size > guide.layers[t].size > 0
        np.testing.assert_array_equal(narrowed.layers[t].q, guide.layers[t].q)
        np.testing.assert_array_equal(narrowed.room[t], guide.room[t])
        assert wide.room[t].min() >= 0.5 and narrowed.room[t].min() >= 1.5
        tips = np.array([ur5_landmarks(np.degrees(q))[-1] for q in wide.layers[t].q[::25]])
        assert np.linalg.norm(tips - pts[t], axis=-1).max() < 0.05


def test_a_guide_from_the_start_keeps_the_elbow_on_its_side_of_the_fold(cell):
    """The UR5's elbow cannot fold its forearm through the upper arm (163.6-196.4 deg either
    way): a guide given the start measures it on the start's side, as the tour's bound does, so
    no guided member or goal state asks the elbow to cross the fold (without the start, the
    seed of the UR5 cell's first leg of 116 commands: a member at 231.8 deg, 70 commands away
    the short way round, 116 the way the arm can go). Its guided path is the shortest through
    its members with the elbow measured so (brute force, the elbow not wrapped)."""
    scene, arm, pts, _ = cell
    q0 = np.radians([0, -90, 90, -90, -90, 0])
    fam = tour._targets_family(arm, scene.world, pts)
    guide = TourGuide.build(fam, pts, 0.05, q_start=q0)
    tip = guide.sampler.tip

    def elbow_deg(q):
        return (np.degrees(np.asarray(q)[..., 2]) + 180.0) % 360.0 - 180.0

    members = [elbow_deg(lay.q) for lay in guide.layers]
    assert all(np.abs(m).max() < 163.6 for m in members)  # no clear member inside the fold
    kept = [lay.q.copy() for lay in guide.layers]
    for q in kept:
        q[:, 2] = np.radians(elbow_deg(q))
    step = (arm.lattice.tick * arm.lattice.max_ticks)[tip]
    wraps = ((arm.upper - arm.lower)[tip] >= 2 * np.pi) & (np.flatnonzero(tip) != 2)
    turn = 2 * np.pi / step

    def legs(a, b):
        d = b[None, :, :] - a[:, None, :]
        d = np.where(wraps, d - turn * np.round(d / turn), d)
        return np.ceil(np.abs(d).max(axis=-1) - 1e-9)

    for order in [(0, 1, 2, 3), (0, 3, 2, 1), (1, 0, 3, 2)]:
        total, path = guide.path(q0, order, back=False)
        u = [kept[t][:, tip] / step for t in order]
        brute = legs((q0[tip] / step)[None], u[0])[0]
        for a, b in itertools.pairwise(u):
            brute = (brute[:, None] + legs(a, b)).min(axis=0)
        assert total == brute.min()
        # the members and the goal states next to them: the elbow within 163.6 deg of zero,
        # on the start's side, never across the fold
        assert all(abs(np.degrees(q[2])) < 163.6 for q in path)
        goals = guide.goal_states(q0, order, path)
        assert goals is not None
        for states in goals:
            assert np.abs(np.degrees(arm.lattice.to_joint(states)[:, 2])).max() < 163.6


def test_the_goal_state_next_to_a_member_is_the_nearest_clear_one():
    scene = load_scene()  # the seed scene: Task 3's welds on the workpiece's inner wall
    arm = seed_arm()
    pts = scene.spotweld_targets_mm()
    fam = tour._targets_family(arm, scene.world, pts)
    q0 = np.radians([0.0, -90.0, 0.0, 0.0, -90.0, 0.0])
    guide = TourGuide.build(fam, pts, 0.05, 0.5, q0)
    grid = arm.lattice
    seed_spec = tomllib.loads(
        (Path(__file__).parents[1] / "src/armpath/scenes/seed.toml").read_text()
    )
    world = ir.Scene.from_spec(seed_spec)
    # brute force: every lattice state within 6 ticks of a member's nearest (joint 6, which
    # does not move the tool point, kept), independent kinematics and clearance. A member is
    # a clear one of weld 1 (its tool point on the wall there), the nearest to the start
    # first, whose box holds a clear state within the tolerance (one in a few does: the
    # lattice is coarse against 0.05 mm), so the brute force has something to compare with
    box = np.stack(np.meshgrid(*[np.arange(-6, 7)] * 5, indexing="ij"), -1).reshape(-1, 5)
    layer = guide.layers[0]
    nearest_first = np.argsort(np.abs(layer.q - q0).max(axis=1), kind="stable")
    for k in nearest_first[:40]:
        q = guide.with_start(layer.q[k][None], q0)
        q = guide.sampler.within_windows(shift_into_limits(arm, q, q0))[0]
        start = grid.nearest_ticks(q)
        states = np.repeat(start[None], box.shape[0], axis=0)
        states[:, :5] += box
        deg = states / 10.0
        tips = ir.SeedArm.points(deg)[:, 4]
        within = np.linalg.norm(tips - pts[0], axis=-1) <= 0.05
        clear = np.zeros(len(states), dtype=bool)
        if np.any(within):
            clear[within] = ir.config_slack(ir.SeedArm(), world, deg[within], 0.5) >= 0.0
        if np.any(clear):
            break
    (pick,) = generic_goal_states(
        arm, scene.world, start, ToolTarget(pts[0], None), 0.05, 1, body_buffer=0.0,
        samples=q[None], nearest_member=True,
    )  # fmt: skip
    away = np.abs(deg - np.degrees(q)).max(axis=1) / 2.0  # commands of 2 deg
    assert np.count_nonzero(clear) >= 1
    pick_deg = pick / 10.0
    assert np.linalg.norm(ir.SeedArm.points(pick_deg)[4] - pts[0]) <= 0.05
    assert ir.config_slack(ir.SeedArm(), world, pick_deg[None], 0.5)[0] >= -1e-6
    pick_away = np.abs(pick_deg - np.degrees(q)).max() / 2.0
    assert pick_away <= away[clear].min() + 1e-9
    assert pick_away < 0.5  # within a command of the member
    # a weld given a hair inside the wall (coordinates rounded): the member solved onto it is
    # kept, and the lattice states next to it that keep out of the wall are found
    radial = np.r_[pts[0][:2] - (210.0, 0.0), 0.0]
    inside = pts[0] + 1e-6 * radial / np.linalg.norm(radial)
    assert scene.world.obstacles[1].signed_distance(inside) < 0.0
    J = position_jacobian(arm, q)
    q_in = q + np.linalg.pinv(J) @ (inside - tool_position(arm, q))
    (state,) = generic_goal_states(
        arm, scene.world, start, ToolTarget(inside, None), 0.05, 1, body_buffer=0.0,
        samples=q_in[None], nearest_member=True,
    )  # fmt: skip
    assert np.linalg.norm(ir.SeedArm.points(state / 10.0)[4] - inside) <= 0.05
    assert ir.config_slack(ir.SeedArm(), world, (state / 10.0)[None], 0.5)[0] >= -1e-6


@pytest.mark.slow
def test_the_lattice_states_near_a_path_are_all_listed_and_the_cheapest_come_first():
    """Three welds in free space: the lattice goal states within a command of each member of a
    guided path. Within 9 ticks of each member's nearest state, a brute force over the lattice
    (independent forward kinematics) finds exactly the listed ones that lie there; every
    listed state reaches its weld within the tolerance; the first state of each weld is a
    cheapest combination (whole commands of 20 ticks per leg from the start, and back to it
    or not), against every combination of the listed states."""
    from armpath.scenes import scene_from_dict

    arm = seed_arm()
    world = scene_from_dict({"name": "none"}).world
    pts = np.array([[300.0, 100.0, 200.0], [250.0, -100.0, 250.0], [320.0, 0.0, 150.0]])
    fam = tour._targets_family(arm, world, pts)
    start = np.array([0, -900, 0, 0, -900, 0])
    q0 = arm.lattice.to_joint(start)
    guide = TourGuide.build(fam, pts, 0.05, 0.5, q0)
    order = (1, 0, 2)
    _, members = guide.path(q0, order, back=False)
    near = guide.states_near(start, order, members, back=False)
    assert near is not None and [s.shape[1] for s in near] == [6, 6, 6]
    box = np.stack(np.meshgrid(*[np.arange(-9, 10)] * 5, indexing="ij"), -1).reshape(-1, 5)
    for t, q, states in zip(order, members, near, strict=True):
        assert np.all(states[:, 5] == 0)  # joint 6 (turns the tool about its point) stays
        tips = ir.SeedArm.points(states / 10.0)[:, 4]
        assert np.all(np.linalg.norm(tips - pts[t], axis=-1) <= 0.05)
        centre = np.round(np.degrees(q) * 10.0).astype(np.int64)
        centre[5] = 0
        every = np.repeat(centre[None], box.shape[0], axis=0)
        every[:, :5] += box
        hit = np.linalg.norm(ir.SeedArm.points(every / 10.0)[:, 4] - pts[t], axis=-1) <= 0.05
        inside = np.all(np.abs(states[:, :5] - centre[:5]) <= 9, axis=1)
        assert {tuple(s) for s in every[hit]} == {tuple(s) for s in states[inside]}
    assert all(s.shape[0] >= 1 for s in near)

    def commands(a, b):
        return int(np.max(-(-np.abs(b - a) // 20)))

    def total(picks, back):
        path = [start, *picks, *([start] if back else [])]
        return sum(commands(a, b) for a, b in itertools.pairwise(path))

    for back in (False, True):
        first = guide.states_near(start, order, members, back=back)
        assert first is not None
        assert [{tuple(x) for x in s} for s in first] == [{tuple(x) for x in s} for s in near]
        best = min(total(c, back) for c in itertools.product(*near))
        assert total([s[0] for s in first], back) == best
