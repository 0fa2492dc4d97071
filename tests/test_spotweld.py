"""Task 3 (spot welds inside the workpiece): the CLI's JSON replayed by the independent checker."""

import itertools
import json

import numpy as np
import pytest

import independent

HOME = [0, -90, 0, 0, -90, 0]
LIMITS = np.array([np.inf, 125, 138, np.inf, 133.5, np.inf])
XY = [(320, -104), (120, 106), (190, -125), (255, 88)]


@pytest.fixture(scope="module")
def task3(seed_run):
    """Task 3 as ``armpath run`` writes it (tests/conftest.py runs it once per session)."""
    out, _ = seed_run
    return json.loads((out / "spotweld.json").read_text()), out


def test_targets_lie_on_the_inner_wall(task3):
    doc, _ = task3
    wp = independent.Workpiece("normal")
    assert doc["wall_thickness"] == "normal"
    targets = np.array(doc["targets"])
    np.testing.assert_allclose(targets[:, :2], XY)
    r = np.hypot(targets[:, 0] - 210, targets[:, 1])
    np.testing.assert_allclose(r, wp.r_in(targets[:, 2]), atol=1e-9)
    np.testing.assert_allclose(wp.distance(targets), 0.0, atol=1e-9)


def test_every_weld_reached_within_tolerance(task3):
    doc, _ = task3
    cmds = np.array(doc["commands"])
    assert cmds.dtype.kind == "i" and cmds.shape == (doc["n_commands"], 6)
    assert np.abs(cmds).max() <= 20
    assert doc["initial_deg"] == HOME
    states = independent.replay(doc["initial_deg"], cmds)
    assert np.all(np.abs(states) <= LIMITS + 1e-9)  # linear motion: the states bound it
    visits = doc["visits"]
    assert sorted(tuple(v["target"]) for v in visits) == sorted(map(tuple, doc["targets"]))
    ks = [v["after_command"] for v in visits]
    assert ks == sorted(ks) and ks[-1] == doc["n_commands"]
    for v in visits:
        tip = independent.points(states[v["after_command"]])[4]
        err = float(np.linalg.norm(tip - np.array(v["target"])))
        assert err <= 0.05
        assert err == pytest.approx(v["error_mm"], abs=1e-9)
        # the fingertip touches the wall from inside, never enters it
        assert independent.Workpiece("normal").distance(tip)[0] >= -1e-9


def test_continuous_motion_keeps_the_clearance_rule(task3):
    doc, _ = task3
    cmds = np.array(doc["commands"])
    pts = independent.motion_points(doc["initial_deg"], cmds, 12)
    samples, is_tip = independent.link_samples(pts, spacing=1.0)
    wp = independent.Workpiece("normal").distance(samples.reshape(-1, 3)).reshape(samples.shape[:2])
    clearance = np.minimum(wp, samples[..., 2])
    is_tip = np.broadcast_to(is_tip, clearance.shape)
    assert clearance[~is_tip].min() >= 1.0
    assert clearance[is_tip].min() >= -1e-9
    assert clearance.min() >= doc["clearance"]["min_clearance_lower_bound_mm"] - 1e-9
    assert doc["clearance"]["certified"]
    # links that are not neighbours stay apart (AB-CD, AB-DE, BC-DE)
    for (i, j), (k, m) in [((0, 1), (2, 3)), ((0, 1), (3, 4)), ((1, 2), (3, 4))]:
        s = np.linspace(0, 1, 200)
        a = pts[:, i, None] + s[None, :, None] * (pts[:, j] - pts[:, i])[:, None]
        b = pts[:, k, None] + s[None, :, None] * (pts[:, m] - pts[:, k])[:, None]
        # every sample pair's squared distance, |a|^2 + |b|^2 - 2 a.b (a batched product)
        d2 = (
            (a * a).sum(-1)[:, :, None]
            + (b * b).sum(-1)[:, None, :]
            - 2 * (a @ b.transpose(0, 2, 1))
        )
        d = np.sqrt(np.maximum(d2.min(axis=(1, 2)), 0.0))
        assert d.min() >= 1.0  # a sampled distance is never below the true one


def test_order_is_the_best_planned_and_every_order_ranked(task3):
    doc, _ = task3
    orders = doc["orders"]
    assert sorted(tuple(o["order"]) for o in orders) == sorted(itertools.permutations(range(1, 5)))
    planned = [o for o in orders if o["planned_commands"] is not None]
    assert planned and min(o["planned_commands"] for o in planned) == doc["n_commands"]
    # the bound over every order and goal configuration never exceeds the plan nor the bound
    # through the planner's own goal states (the family holds them)
    assert 0 < doc["lower_bound_commands"] <= doc["goal_states_bound_commands"] <= doc["n_commands"]
    assert doc["lower_bound"]["gap_commands"] == doc["n_commands"] - doc["lower_bound_commands"]
    assert all(o["family_bound_commands"] >= doc["lower_bound_commands"] for o in orders)
    # issue 21: the bound is the exact relaxation over the lattice goal states (no sampling
    # error; tests/test_lattice_goals.py checks its listing and programme by brute force), and
    # the plan is within 5 % of it (121 against 117)
    assert "lattice states within the tolerance" in doc["lower_bound"]["method"]
    assert doc["lower_bound"]["sampling"]["lattice_goal_states"] > 1000
    assert doc["n_commands"] <= 1.05 * doc["lower_bound_commands"]
    # every order whose bound is below the plan was planned (the few beyond the best two; the
    # plan through the pools of goal states is below every other order's goal-state bound)
    below = [o for o in orders if o["lower_bound_commands"] < doc["n_commands"]]
    assert all(o["planned_commands"] is not None for o in below)
    chosen = next(o for o in orders if o["order"] == doc["order"])
    assert chosen["planned_commands"] == doc["n_commands"]
    # the chosen order's bound counts the goal states its legs reach
    assert chosen["lower_bound_commands"] <= doc["n_commands"]
    # the README's Task 3 (goal states chosen together): 133 commands on the machine where it
    # was measured, 135 (legs 73 + 15 + 31 + 16 against 73 + 14 + 31 + 15) with the same code
    # and package versions on another (see tests/test_ur5_cell.py's spot welds); through the
    # lattice goal states nearest the guide's members (each tried alone first): 127 (70 + 19 +
    # 23 + 15) on the second; the kept legs merged where certified straight motions need fewer
    # commands: 126 (69 + 19 + 23 + 15); through pools of goal states whose legs are planned
    # when a lazy shortest path over them needs them (armpath.planning.tour_pool): 122 (order
    # 2-4-1-3, 69 + 13 + 25 + 15); the pools' members keeping 0.5 mm rather than 1.5 mm and
    # their searched legs' states placed: 121 (69 + 12 + 25 + 15); the limit leaves another
    # machine room
    assert doc["n_commands"] <= 125
    # the legs add up and each needs at least its direct-motion count
    assert sum(leg["commands"] for leg in doc["legs"]) == doc["n_commands"]
    assert all(leg["commands"] >= leg["direct_commands"] for leg in doc["legs"])


def test_files_and_figures_written(task3):
    doc, out = task3
    names = {p.name for p in out.iterdir()}
    assert {"spotweld.json", "spotweld.csv", "spotweld.xlsx"} <= names
    assert {"spotweld_motion.png", "spotweld_joints.png"} <= names
    rows = (out / "spotweld.csv").read_text().strip().splitlines()
    assert len(rows) == doc["n_commands"] + 1


def test_the_bound_that_gives_up_a_tour_is_the_least_through_its_goal_states():
    """What a tour's plan is given up against (the fewest direct-motion commands from where the
    arm is through one goal state per target still to go, in order, optionally back) equals
    brute force over every choice of goal states, each leg's commands counted independently
    (the largest tick change over 20, rounded up): so a plan given up could not have needed
    fewer commands than its legs so far plus this."""
    from armpath.model.seed_arm import seed_arm
    from armpath.planning.tour import _order_bounds

    lattice = seed_arm().lattice
    rng = np.random.default_rng(7)
    for back in (False, True):
        state = rng.integers(-900, 900, 6)
        goals = [rng.integers(-900, 900, (int(rng.integers(1, 5)), 6)) for _ in range(4)]
        orders = [(2, 0, 3), (1, 3), (3, 1, 0, 2)]
        found = _order_bounds(state, goals, orders, back, lattice)

        def legs(a, b):
            return int(np.ceil(np.abs(np.asarray(b) - np.asarray(a)).max() / 20))

        for order in orders:
            best = min(
                sum(legs(a, b) for a, b in itertools.pairwise([state, *picks]))
                + (legs(picks[-1], state) if back else 0)
                for picks in itertools.product(*(goals[t] for t in order))
            )
            assert found[order] == best


WELDS_FREE = [
    [300.0, 100.0, 200.0],
    [250.0, -100.0, 250.0],
    [320.0, 0.0, 150.0],
    [280.0, 50.0, 300.0],
    [350.0, -50.0, 220.0],
    [260.0, 120.0, 180.0],
]


@pytest.mark.slow
def test_every_order_bounded_at_once_equals_order_by_order():
    """Five welds in free space: the bound over every order at once (the programme over the
    sets of welds visited) equals the bound order by order over all 120 orders, on the same
    samples (one round of the search), and so does the path through the clear samples."""
    from armpath.model.seed_arm import seed_arm
    from armpath.planning.bounds import tour_bound
    from armpath.planning.tour import _targets_family
    from armpath.scenes import scene_from_dict

    arm = seed_arm()
    welds = np.array(WELDS_FREE[:5])
    fam = _targets_family(arm, scene_from_dict({"name": "none"}).world, welds)
    start = np.radians(HOME)
    orders = list(itertools.permutations(range(5)))
    each, per_order = tour_bound(fam, start, welds, 0.05, orders, rounds=1)
    every, none = tour_bound(fam, start, welds, 0.05, None, rounds=1)
    assert every.value == each.value and every.commands == min(per_order.values())
    assert every.sampling["clear_path_commands"] == each.sampling["clear_path_commands"]
    assert none == {} and every.sampling["orders"] == 120.0
    assert per_order[every.guide_order] == every.commands
    assert "sets of targets visited" in every.method


@pytest.mark.slow
def test_six_welds_are_bounded_over_every_order(monkeypatch):
    """Six welds in free space (720 orders), where the cheaper bound (every weld entered once,
    from the start or another weld) said 17. Their 742,972 lattice goal states bound every
    order at once (the programme over the sets of welds visited, capped by the costs still to
    go from each state's nearest states of the other welds) by the plan's own commands: 73,
    the fewest. Its path is the plan's guide; the plan, replayed with the independent
    kinematics, reaches every weld within the tolerance. The family's sampled members, where
    the states are not listed, bound it within 5 % with 120,000 live samples (71; the default
    50,000: 67): its first sampling holds more samples than that budget, and the search goes
    on past it where the cells that may hold a cheaper path than the incumbent fit in it."""
    import armpath
    from armpath.planning.bounds import tour as tour_bounds

    doc = armpath.spotweld("seed", WELDS_FREE, scene="none").doc
    bound = doc["lower_bound"]
    assert "sets of targets visited" in bound["method"] and "lattice states" in bound["method"]
    assert bound["sampling"]["orders"] == 720 and bound["sampling"]["lattice_goal_states"] > 7e5
    assert doc["lower_bound_commands"] == doc["n_commands"] <= 80
    cmds = np.array(doc["commands"])
    assert cmds.shape == (doc["n_commands"], 6) and np.abs(cmds).max() <= 20
    states = independent.replay(doc["initial_deg"], cmds)
    assert np.all(np.abs(states) <= LIMITS + 1e-9)
    visits = doc["visits"]
    assert sorted(tuple(v["target"]) for v in visits) == sorted(map(tuple, WELDS_FREE))
    for v in visits:
        tip = independent.points(states[v["after_command"]])[4]
        assert np.linalg.norm(tip - np.array(v["target"])) <= 0.05
    # the sampled bound, the lattice states not listed
    monkeypatch.setattr(tour_bounds, "MAX_LATTICE_TARGETS", 0)
    sampled = armpath.spotweld("seed", WELDS_FREE, scene="none", bound_samples=120_000).doc
    bound = sampled["lower_bound"]
    assert "sets of targets visited" in bound["method"] and bound["sampling"]["orders"] == 720
    assert "lattice states" not in bound["method"] and bound["sampling"]["rounds"] >= 2
    assert 70 <= sampled["lower_bound_commands"] <= doc["lower_bound_commands"]
    assert sampled["n_commands"] <= 1.05 * sampled["lower_bound_commands"]


def test_more_than_24_orders_are_compared_from_the_bounds_order_and_the_best_ranked():
    """With more orders than the guide and the pools compare, they take the bound's best order
    first, then the best ranked after it, 24 in all; up to 24, every order as given."""
    from armpath.planning.bounds import CommandBound
    from armpath.planning.tour import MAX_GUIDED_ORDERS, _guided_orders

    few = list(itertools.permutations(range(4)))
    assert _guided_orders(few, few[::-1], None) is few
    orders = list(itertools.permutations(range(6)))
    ranking = orders[::-1]
    bound = CommandBound(65, 65.0, "every order at once", guide_order=(3, 5, 0, 2, 4, 1))
    chosen = _guided_orders(orders, ranking, bound)
    assert len(chosen) == MAX_GUIDED_ORDERS == 24
    assert chosen[0] == (3, 5, 0, 2, 4, 1)
    assert chosen[1:] == [o for o in ranking if o != chosen[0]][:23]
    assert _guided_orders(orders, ranking, None) == ranking[:24]


@pytest.mark.slow
def test_a_tour_too_long_to_bound_says_why_it_has_no_bound(tmp_path, monkeypatch):
    """A tour of more welds than the bound over every goal configuration takes (24; 2 here,
    to keep the test short) was shown 'lower bound: not computed', --bound being on, with no
    reason. The table now names the limit and the tour's count; the plan still reaches each
    weld (its visits within the tolerance of the listed points)."""
    import armpath.planning.tour as tour
    from cli_in_process import run_in_process

    monkeypatch.setattr(tour, "MAX_BOUND_TARGETS", 2)
    welds = [[300.0, -50.0, 150.0], [310.0, -50.0, 150.0], [320.0, -50.0, 150.0]]
    scene = tmp_path / "welds.toml"
    scene.write_text(f'name = "welds"\n[tasks.spotweld]\npoints_mm = {welds}\n')
    r = run_in_process(["spotweld", "--scene", str(scene), "--order", "given"], tmp_path)
    assert r.returncode == 0, r.stderr
    text = " ".join(r.stdout.replace("│", " ").split())  # the table's cells, unwrapped
    assert "not computed: the bound over every goal configuration takes at most 2 welds" in text
    assert "this tour has 3" in text
    r = run_in_process(["spotweld", "--scene", str(scene), "--order", "given", "--json"], tmp_path)
    doc = json.loads(r.stdout)
    assert doc["lower_bound"] is None and len(doc["visits"]) == 3
    assert doc["no_bound_because"].endswith("takes at most 2 welds, this tour has 3")
    assert all(v["error_mm"] <= 0.05 for v in doc["visits"])
    # the result says why it has no bound (the table's words come from it), and a bound
    # computed has no reason beside it
    args = ["spotweld", "--scene", str(scene), "--order", "given", "--json"]
    doc = json.loads(run_in_process([*args, "--no-bound"], tmp_path).stdout)
    assert doc["lower_bound"] is None and doc["no_bound_because"] == "not asked for"
    monkeypatch.setattr(tour, "MAX_BOUND_TARGETS", 24)
    doc = json.loads(run_in_process(args, tmp_path).stdout)
    assert doc["lower_bound_commands"] <= doc["n_commands"] and doc["no_bound_because"] is None


@pytest.mark.slow
def test_a_tour_for_the_shortest_tool_path_keeps_the_planned_tour_of_least_path(monkeypatch):
    """``objective="path"`` (or ``"energy"``) chose the tour of fewest commands, as commands
    do: the seed's Task 3 with --objective path moved the fingertip 2285 mm against the
    default's 2150. Of the tours planned, the one of least tool point path is kept now: its
    path, each tour replayed by the independent kinematics (64 instants a command, the
    fingertip's polyline), is the least of all those planned, and no longer than the tour of
    fewest commands among them."""
    from armpath.model.seed_arm import seed_arm
    from armpath.planning import tour as tour_module
    from armpath.planning.choices import Objective
    from armpath.planning.motion import MotionOptions
    from armpath.scenes import scene_from_dict

    seen = []
    real = tour_module._least_in

    def spy(arm, start, tours, opts):
        seen.append(list(tours))
        return real(arm, start, tours, opts)

    monkeypatch.setattr(tour_module, "_least_in", spy)
    start = np.round(np.array(HOME) * 10).astype(np.int64)
    r = tour_module.plan_tour(
        seed_arm(), scene_from_dict({"name": "none"}).world, start, WELDS_FREE[:4],
        options=MotionOptions(objective=Objective.PATH), bound=False, pools=False, orders_to_plan=6,
    )  # fmt: skip
    (tours,) = seen
    assert len(tours) >= 2

    def tip_path(commands):
        states = independent.replay(HOME, commands)
        t = np.linspace(0.0, 1.0, 65)[:-1]
        q = states[:-1, None, :] + t[None, :, None] * np.diff(states, axis=0)[:, None, :]
        tips = independent.points(np.vstack([q.reshape(-1, 6), states[-1:]]))[:, 4]
        return np.linalg.norm(np.diff(tips, axis=0), axis=1).sum()

    paths = [tip_path(np.vstack([leg.sequence.commands for leg in legs])) for legs, _ in tours]
    kept = tip_path(r.sequence.commands)
    assert kept == pytest.approx(min(paths), abs=0.05)
    fewest = min(range(len(tours)), key=lambda i: sum(g.sequence.n_commands for g in tours[i][0]))
    assert kept <= paths[fewest] + 0.05
    assert r.metrics.tip_path_mm == pytest.approx(kept, abs=0.05)


def test_a_weld_listed_twice_is_pointed_out():
    """Two welds within the tolerance of each other (a point listed twice) were accepted
    without a word; the second was reached with no command of its own. Now a warning names
    them, with how far apart they are, whatever their order (brute force over the pairs);
    targets farther apart, or with different tool rules, are not named."""
    import warnings

    from armpath.errors import ArmpathWarning
    from armpath.ik.target import AxisCone
    from armpath.planning.tour import _warn_of_twins

    pts = np.array([[400, 100, 300], [300, -200, 400], [400, 100, 300.03], [0, 0, 500.0]])
    with pytest.warns(ArmpathWarning) as said:
        _warn_of_twins(pts, None, 0.05)
    (message,) = [str(w.message) for w in said]
    near = [
        (i + 1, j + 1)
        for i, j in itertools.combinations(range(len(pts)), 2)
        if np.linalg.norm(pts[i] - pts[j]) <= 0.05
    ]
    assert near == [(1, 3)]
    assert message.startswith("targets 1 and 3 (0.030 mm apart) lie within the 0.05 mm")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _warn_of_twins(pts, None, 0.02)  # 0.03 mm apart: farther than the tolerance
        down, up = AxisCone(np.array([0, 0, -1.0]), 0.1), AxisCone(np.array([0, 0, 1.0]), 0.1)
        _warn_of_twins(pts, [down, down, up, down], 0.05)  # the same point, other rules
    with pytest.warns(ArmpathWarning, match="targets 1 and 3"):
        _warn_of_twins(pts, [down, up, AxisCone(np.array([0, 0, -1.0]), 0.1), up], 0.05)


def test_every_weld_out_of_reach_is_named_at_once():
    """A tour stopped at the first weld out of reach (a PUMA 560 raised on its pedestal in the
    UR5 cell missed three of its four welds): fixing the cell took a run per weld. Every weld
    without goal states is now named in the one error, the reachable ones not; each is as far
    from the arm's reach as a reach to it alone says."""
    from armpath.errors import UnreachableError
    from armpath.model.seed_arm import seed_arm
    from armpath.planning.reach import plan_reach
    from armpath.planning.tour import plan_tour
    from armpath.scenes import scene_from_dict

    world = scene_from_dict({"name": "none"}).world
    start = np.round(np.array(HOME) * 10).astype(np.int64)
    far = [np.array([0.0, 0.0, 900.0]), np.array([900.0, 0.0, 100.0])]
    welds = np.vstack([WELDS_FREE[0], far[0], WELDS_FREE[1], far[1]])
    with pytest.raises(UnreachableError) as said:
        plan_tour(seed_arm(), world, start, welds, bound=False, pools=False)
    message = str(said.value)
    assert "target 1:" not in message and "target 3:" not in message
    for k, p in zip((2, 4), far, strict=True):
        with pytest.raises(UnreachableError) as alone:
            plan_reach(seed_arm(), world, start, p)
        assert f"target {k}: {alone.value}" in message
