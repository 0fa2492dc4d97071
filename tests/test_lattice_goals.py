"""The lattice goal states of a target and the tour's relaxation over them, against brute force.

:func:`~armpath.planning.bounds.lattice_goals.lattice_goal_states` must list every lattice
state whose tool point lies within the tolerance (every state of a box checked one by one), and
its clearance pruning must drop no state that keeps the rule. The tour's relaxation over given
layers of states must equal the least over every order and every choice of one state per
target, each leg its largest joint change in whole commands, measured here independently.
"""

from __future__ import annotations

import itertools
import time
from pathlib import Path

import numpy as np
import pytest

from armpath.api import arm_and_scene, load_arm, load_scene
from armpath.budget import time_limit
from armpath.errors import TimeLimitError
from armpath.kinematics import landmark_positions, tool_position
from armpath.planning.bounds import lattice_goals
from armpath.planning.bounds import tour as tour_bounds
from armpath.planning.bounds.lattice_goals import lattice_goal_states
from armpath.planning.bounds.sampling import FamilySampler, Layer
from armpath.planning.tour import _targets_family


def _box_states(centre: np.ndarray, tip: np.ndarray, radius: int) -> np.ndarray:
    """Every state of the box of +-radius ticks about ``centre`` in the ``tip`` joints."""
    axes = [np.arange(-radius, radius + 1)] * int(tip.sum())
    box = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, int(tip.sum()))
    states = np.repeat(centre[None], box.shape[0], axis=0)
    states[:, tip] += box
    return states


@pytest.mark.parametrize(
    ("name", "deg", "radius", "tolerance"),
    [("seed", [10, -30, 40, 20, 30, 0], 7, 0.05), ("ur5", [20, -70, 80, -100, -80, 0], 5, 0.4)],
)
def test_every_state_within_the_tolerance_of_a_box_is_listed(name, deg, radius, tolerance):
    """The seed arm and the UR5 (whose tick moves the tool point farther: a wider tolerance
    holds as many states)."""
    arm = load_arm(name)
    grid = arm.lattice
    tip = np.array([True] * 5 + [False])
    centre = grid.nearest_ticks(np.radians(deg))
    rng = np.random.default_rng(3)
    target = tool_position(arm, grid.to_joint(centre)) + rng.normal(size=3) * 0.02
    found = lattice_goal_states(
        arm, target, tolerance, tip, centre, centre[tip] - radius, centre[tip] + radius
    )
    states = _box_states(centre, tip, radius)
    dist = np.linalg.norm(tool_position(arm, grid.to_joint(states)) - target, axis=1)
    truth = {tuple(s) for s in states[dist <= tolerance]}
    assert found.complete
    assert len(truth) >= 3
    assert {tuple(s) for s in found.ticks} == truth


def test_a_sliding_joint_and_a_held_joint_between_the_listed_ones_are_carried_exactly():
    """The kernel multiplies the arm out between the joints it lists, with the others folded
    in at their values: on the UR5 on its track (a sliding joint first), listing the slide and
    four of the arm's joints while the second of them is held at 35 deg finds exactly the
    states of the box, checked one by one with the arm's own forward kinematics."""
    arm = load_arm(str(Path(__file__).resolve().parents[1] / "examples" / "track_ur5.json"))
    grid = arm.lattice
    tip = np.array([True, True, False, True, True, True, False])
    centre = grid.nearest_ticks(np.array([800.0, *np.radians([20, 35, 80, -100, -80, 0])]))
    target = tool_position(arm, grid.to_joint(centre)) + np.array([0.03, -0.02, 0.04])
    tolerance = 0.6
    radius = 4
    found = lattice_goal_states(
        arm, target, tolerance, tip, centre, centre[tip] - radius, centre[tip] + radius
    )
    states = _box_states(centre, tip, radius)
    dist = np.linalg.norm(tool_position(arm, grid.to_joint(states)) - target, axis=1)
    truth = {tuple(s) for s in states[dist <= tolerance]}
    assert found.complete
    assert len(truth) >= 3
    assert {tuple(s) for s in found.ticks} == truth
    assert np.all(found.ticks[:, ~tip] == centre[~tip])


def test_turns_taken_at_each_box_where_the_boxes_span_too_many_to_tabulate():
    """The kernel tabulates each joint's sine and cosine over the half-ticks its boxes span; a
    second box far away (a single state 70,000 ticks off, no state near the target) makes the
    span too wide, and the turns are taken at each box instead: the same states, and the same
    boxes looked at plus the far one."""
    arm = load_arm("seed")
    grid = arm.lattice
    tip = np.array([True] * 5 + [False])
    centre = grid.nearest_ticks(np.radians([10, -30, 40, 20, 30, 0]))
    target = tool_position(arm, grid.to_joint(centre)) + np.array([0.01, 0.02, -0.01])
    constants = lattice_goals.kernel_constants(arm, target, 0.05, tip, centre)
    near_lo, near_hi = centre[tip] - 6, centre[tip] + 6
    far = centre[tip] + 70_000
    assert 2 * (far.max() - near_lo.min()) + 1 > lattice_goals.MAX_TABLE

    def listed(lo: np.ndarray, hi: np.ndarray) -> tuple[set, int]:
        out, _, count, boxes, status, _, _ = lattice_goals._enumerate(
            lo, hi, *constants, 10**9, 10**6, 0
        )
        assert status == 0  # every box looked at
        return {tuple(s) for s in out[:count]}, boxes

    tabulated, boxes = listed(near_lo[None], near_hi[None])
    turned, more_boxes = listed(np.stack([near_lo, far]), np.stack([near_hi, far]))
    assert len(tabulated) >= 3
    assert turned == tabulated
    assert more_boxes == boxes + 1


def _clear_state_near_a_weld() -> tuple:
    """The seed arm, its scene's world, a weld inside the workpiece and the lattice state
    nearest a clear family member there."""
    arm = load_arm("seed")
    world = load_scene(None).world
    weld = np.array([120.0, 106.0, 50.82])
    fam = _targets_family(arm, world, weld[None])
    sampler = FamilySampler(fam, 0.05)
    members = sampler.layer(weld, sampler.base, levels=0)
    clear = members.q[world.satisfied(arm, members.q)]
    return arm, world, weld, arm.lattice.nearest_ticks(clear[0])


def test_the_clearance_pruning_drops_no_state_that_keeps_the_rule(monkeypatch):
    """Near a weld inside the seed's workpiece many states collide; those that keep the rule
    are all listed with the pruning on (at every width, however little a look drops)."""
    monkeypatch.setattr(lattice_goals, "MIN_DROPPED_SHARE", 0.0)
    arm, world, weld, centre = _clear_state_near_a_weld()
    grid = arm.lattice
    tip = np.array([True] * 5 + [False])
    radius = 10  # 21 ticks wide: pruned at 16 and at 8 ticks
    found = lattice_goal_states(
        arm,
        weld,
        0.05,
        tip,
        centre,
        centre[tip] - radius,
        centre[tip] + radius,
        may_be_clear=lambda q, moved: world.may_be_clear_within(arm, q, moved),
    )
    states = _box_states(centre, tip, radius)
    near = states[np.linalg.norm(tool_position(arm, grid.to_joint(states)) - weld, axis=1) <= 0.05]
    truth = {tuple(s) for s in near[world.satisfied(arm, grid.to_joint(near))]}
    listed = found.ticks[world.satisfied(arm, grid.to_joint(found.ticks))]
    assert found.complete
    assert truth
    assert {tuple(s) for s in listed} == truth


def test_the_listing_resumed_chunk_by_chunk_finds_the_same_states(monkeypatch):
    """The kernel runs a chunk of boxes at a time and resumes from those it has not looked at:
    chunks of 7 boxes (the stack and the starts not begun handed back each time) list the
    same states, with the clearance pruning too, as one chunk; a budget of boxes smaller than
    the listing needs ends it incomplete."""
    arm, world, weld, centre = _clear_state_near_a_weld()
    grid = arm.lattice
    tip = np.array([True] * 5 + [False])
    target = tool_position(arm, grid.to_joint(centre))
    lo, hi = centre[tip] - 9, centre[tip] + 9
    pruned = {"may_be_clear": lambda q, moved: world.may_be_clear_within(arm, q, moved)}
    for point, kwargs in ((target, {}), (weld, pruned)):
        whole = lattice_goal_states(arm, point, 0.05, tip, centre, lo, hi, **kwargs)
        monkeypatch.setattr(lattice_goals, "CHUNK_BOXES", 7)
        chunked = lattice_goal_states(arm, point, 0.05, tip, centre, lo, hi, **kwargs)
        monkeypatch.setattr(lattice_goals, "CHUNK_BOXES", 1_000_000)
        assert whole.complete and chunked.complete
        assert chunked.boxes == whole.boxes
        assert {tuple(s) for s in chunked.ticks} == {tuple(s) for s in whole.ticks}
        assert len(whole.ticks) > 0 and whole.boxes > 100
    short = lattice_goal_states(arm, target, 0.05, tip, centre, lo, hi, max_boxes=100)
    assert not short.complete and short.boxes == 100


def test_the_listing_hears_a_time_limit():
    """Between chunks the listing looks at the clock: a limit already spent stops it with a
    TimeLimitError."""
    arm = load_arm("seed")
    grid = arm.lattice
    tip = np.array([True] * 5 + [False])
    centre = grid.nearest_ticks(np.radians([40.0, -20.0, 60.0, 0.0, 30.0, 0.0]))
    with time_limit(1e-6), pytest.raises(TimeLimitError):
        time.sleep(0.01)
        lattice_goal_states(
            arm,
            np.array([300.0, 0.0, 100.0]),
            0.05,
            tip,
            centre,
            centre[tip] - 50,
            centre[tip] + 50,
        )


def test_may_be_clear_within_allows_one_motion_to_obstacles_and_two_between_links():
    """The pruning's predicate against every pair's clearance measured: the UR5 of its cell at
    random configurations (some folded onto themselves), each with its own allowance."""
    arm, scene = arm_and_scene(None, Path(__file__).parents[1] / "examples" / "ur5_cell.toml")
    world = scene.world
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, size=(600, 6))
    moved = rng.uniform(0.0, 60.0, size=600)
    values, _ = world.pair_clearances(arm, q)
    slack = values - world.required(arm)
    is_self = np.array([p.is_self for p in world.pairs(arm)])
    truth = (slack[:, ~is_self].min(axis=1) >= -moved) & (
        slack[:, is_self].min(axis=1) >= -2.0 * moved
    )
    found = world.may_be_clear_within(arm, q, moved)
    assert np.array_equal(found, truth)
    # both kinds decide some: links folded onto each other, parts in the table or the floor
    assert (slack[:, is_self].min(axis=1) < -2.0 * moved).any()
    assert (slack[:, ~is_self].min(axis=1) < -moved).any()
    assert 0 < truth.sum() < truth.size


def test_may_be_clear_within_each_landmarks_motion_bounds_its_links():
    """The per-landmark allowance against every pair's clearance measured, each part's
    allowance the farther of its link's two ends (looked up by the link's name); and sound:
    a clear configuration near each one is never ruled out by how far it moved each
    landmark."""
    arm, scene = arm_and_scene(None, Path(__file__).parents[1] / "examples" / "ur5_cell.toml")
    world = scene.world
    rng = np.random.default_rng(6)
    q = rng.uniform(-np.pi, np.pi, size=(600, 6))
    n_landmarks = landmark_positions(arm, q[:1]).shape[1]
    moved = rng.uniform(0.0, 60.0, size=(600, n_landmarks))
    values, _ = world.pair_clearances(arm, q)
    slack = values - world.required(arm)
    link = {lk.name: lk for lk in arm.links}
    part_link = {p.name: p.link for p in world.parts(arm)}

    def link_moved(name: str) -> np.ndarray:
        return np.maximum(moved[:, link[name].start], moved[:, link[name].end])

    allowance = np.column_stack(
        [
            link_moved(pair.part) + link_moved(pair.other)
            if pair.is_self
            else link_moved(part_link[pair.part])
            for pair in world.pairs(arm)
        ]
    )
    truth = np.all(slack >= -allowance, axis=1)
    found = world.may_be_clear_within(arm, q, moved)
    assert np.array_equal(found, truth)
    # tighter than the one allowance for every point, and it decides some both ways
    assert not np.any(found & ~world.may_be_clear_within(arm, q, moved.max(axis=1)))
    assert (found != world.may_be_clear_within(arm, q, moved.max(axis=1))).any()
    assert 0 < truth.sum() < truth.size
    # a clear configuration a few degrees away: its landmarks' motion keeps the original
    near = q + rng.uniform(-0.15, 0.15, size=q.shape)
    clear = world.slack(arm, near) >= 0.0
    shift = np.linalg.norm(landmark_positions(arm, near) - landmark_positions(arm, q), axis=-1)
    assert clear.sum() > 50
    assert np.all(world.may_be_clear_within(arm, q[clear], shift[clear] + 1e-9))


def test_the_familys_clearance_cut_keeps_what_the_per_part_test_keeps():
    """The sampler's first cut by the farthest landmark only saves work: on random UR5
    configurations near the cell's parts and self pairs it keeps exactly what the world's
    per-part test keeps, including the configurations whose worst slack (a link pair's) lies
    beyond one link's motion but within both links' together."""
    arm, scene = arm_and_scene(None, Path(__file__).parents[1] / "examples" / "ur5_cell.toml")
    world = scene.world
    sampler = FamilySampler(_targets_family(arm, world, np.array([[400.0, 100.0, 200.0]])), 0.05)
    rng = np.random.default_rng(6)
    q = rng.uniform(-np.pi, np.pi, size=(2000, 6))
    moved = rng.uniform(0.0, 60.0, size=(2000, landmark_positions(arm, q[:1]).shape[1]))
    slack = world.slack(arm, q)
    truth = (slack >= 0.0) | world.may_be_clear_within(arm, q, moved)
    assert np.array_equal(sampler.may_be_clear(q, slack, moved), truth)
    # what a cut by one landmark's motion alone would have dropped, and both ways decided
    assert (truth & (slack < -moved.max(axis=1))).sum() > 10
    assert 0 < truth.sum() < truth.size


def _chebyshev_commands(a: np.ndarray, b: np.ndarray, period: np.ndarray) -> int:
    """Whole commands of a leg between configurations in command units, joints with a
    ``period`` measured the shorter way round (an independent spelling of the metric)."""
    gaps = []
    for x, y, p in zip(a, b, period, strict=True):
        d = abs(x - y)
        if p > 0:
            d = min(d % p, p - d % p)
        gaps.append(d)
    return int(np.ceil(max(gaps) - 1e-9))


def _three_seed_welds() -> tuple:
    """The seed arm, its scene, three of its welds (two inside the workpiece), a start and a
    sampler of the welds' family."""
    arm = load_arm("seed")
    world = load_scene(None).world
    welds = np.array([[120.0, 106.0, 50.82], [255.0, 88.0, 151.36], [190.0, -125.0, 81.98]])
    start = np.radians([0.0, -90.0, 90.0, 0.0, 45.0, 0.0])
    sampler = FamilySampler(_targets_family(arm, world, welds), 0.05, q_start=start)
    return arm, world, welds, start, sampler


def test_the_lattice_tour_relaxation_equals_brute_force(monkeypatch):
    arm, _, welds, start, sampler = _three_seed_welds()
    rng = np.random.default_rng(5)
    layers = []
    for w in welds:
        members = sampler.layer(w, sampler.base, levels=0)
        pick = rng.choice(members.size, size=6, replace=False)
        q = arm.lattice.to_joint(arm.lattice.nearest_ticks(members.q[pick]))
        u = sampler.units(q)
        layers.append(Layer(u, np.zeros_like(u), q, np.zeros((6, 3))))
    monkeypatch.setattr(tour_bounds, "_goal_layers", lambda *_a: layers)
    orders = list(itertools.permutations(range(3)))
    for back in (False, True):
        found, per_order = tour_bounds.lattice_tour_bound(
            sampler, start, welds, orders, back, [], lambda _m: None
        )
        u0 = sampler.units(start)
        for order in orders:
            best = np.inf
            for pick in itertools.product(range(6), repeat=3):
                path = [u0] + [layers[t].u[pick[k]] for k, t in enumerate(order)]
                if back:
                    path.append(u0)
                cost = sum(
                    _chebyshev_commands(a, b, sampler.period) for a, b in itertools.pairwise(path)
                )
                best = min(best, cost)
            assert per_order[order] == best
        assert found.commands == min(per_order.values())
        # every order at once (Held and Karp's programme over the sets visited): the same
        # least, and its path, through the listed states, costs that much
        every, none = tour_bounds.lattice_tour_bound(
            sampler, start, welds, None, back, [], lambda _m: None
        )
        assert none == {}
        assert every.commands == found.commands
        assert every.guide_order in per_order and per_order[every.guide_order] == every.commands
        assert every.clear_path_order == every.guide_order
        assert every.sampling["clear_path_commands"] == every.commands
        path = [u0]
        for t, q in zip(every.guide_order, every.guide_q, strict=True):
            assert np.any(np.all(layers[t].q == q, axis=1))
            path.append(sampler.units(q))
        if back:
            path.append(u0)
        legs = [_chebyshev_commands(a, b, sampler.period) for a, b in itertools.pairwise(path)]
        assert sum(legs) == every.commands
    # more pairs of states than the legs may measure (12 prefixes of two or three targets, each
    # 6 x 6 pairs): the caller samples the family instead; every order at once counts the
    # pairs its programme offers as it goes (tests/test_bounds.py counts them), none here
    args = (sampler, start, welds, orders, False, [], lambda _m: None)
    monkeypatch.setattr(tour_bounds, "MAX_LATTICE_PAIRS", 12 * 36 - 1)
    assert tour_bounds.lattice_tour_bound(*args) is None
    monkeypatch.setattr(tour_bounds, "MAX_LATTICE_PAIRS", 12 * 36)
    assert tour_bounds.lattice_tour_bound(*args) is not None
    args = (sampler, start, welds, None, False, [], lambda _m: None)
    monkeypatch.setattr(tour_bounds, "MAX_LATTICE_PAIRS_EVERY_ORDER", 0)
    assert tour_bounds.lattice_tour_bound(*args) is None


def test_the_lattice_listing_stops_once_the_legs_are_too_many(monkeypatch):
    """The tour bound lists each target's lattice states before it knows whether the legs
    between them can be measured: it stops listing as soon as the targets listed already
    have more pairs of states than the budget, by :func:`leg_multiplicity` (checked here
    against a count of the prefixes of every order), and samples the family instead."""
    for n in (2, 3, 4, 5):
        orders = list(itertools.permutations(range(n)))
        counted = np.zeros((n, n), dtype=np.int64)
        for prefix in {o[:k] for o in orders for k in range(2, n + 1)}:
            counted[prefix[-2], prefix[-1]] += 1
        assert np.array_equal(tour_bounds.leg_multiplicity(n, orders), counted)
    assert np.array_equal(
        tour_bounds.leg_multiplicity(3, [(0, 1, 2), (0, 2, 1)]),
        [[0, 1, 1], [0, 0, 1], [0, 1, 0]],
    )
    arm, world, welds, start, sampler = _three_seed_welds()
    listed = []

    class Found:
        complete = True

        def __init__(self, k: int) -> None:
            self.ticks = np.tile(arm.lattice.nearest_ticks(start), (10 * (k + 1), 1))

    def fake_listing(_arm, point, *_a, **_k):
        k = int(np.flatnonzero(np.all(welds == point, axis=1))[0])
        listed.append(k)
        return Found(k)

    monkeypatch.setattr(tour_bounds, "lattice_goal_states", fake_listing)
    monkeypatch.setattr(tour_bounds, "GOAL_THREADS", 1)  # in the targets' order
    assert world.satisfied(arm, start[None])[0]  # every listed state is the start's, clear
    every = tour_bounds.leg_multiplicity(3, list(itertools.permutations(range(3))))
    say = lambda _m: None  # noqa: E731
    # 10 and 20 states: 2 * (10 * 20) * 2 = 800 pairs after two targets
    assert tour_bounds._goal_layers(sampler, start, welds, say, every, 799) is None
    assert listed == [0, 1]
    listed.clear()
    layers = tour_bounds._goal_layers(sampler, start, welds, say, every, 10**9)
    assert listed == [0, 1, 2] and [lay.size for lay in layers] == [10, 20, 30]


@pytest.mark.slow
def test_two_welds_in_free_space_are_bounded_over_their_lattice_states():
    """Nothing prunes the seed arm's states in an empty scene: about 257,000 states at the two
    welds, all listed (within MAX_LATTICE_GOALS), and the tour planned in as many commands as
    they bound, so the plan is proven fewest."""
    import armpath

    doc = armpath.spotweld(
        "seed", [[300.0, 100.0, 200.0], [250.0, -100.0, 250.0]], scene="none"
    ).doc
    assert "lattice states within the tolerance" in doc["lower_bound"]["method"]
    assert doc["lower_bound"]["sampling"]["lattice_goal_states"] > 200_000
    assert doc["lower_bound_commands"] == doc["n_commands"]


@pytest.mark.slow
def test_a_tour_of_more_welds_than_are_listed_is_bounded_over_the_sampled_family(monkeypatch):
    """Past MAX_LATTICE_TARGETS welds (here set to one) the lattice states are not listed (each
    weld takes seconds: twelve in a given order once spent 200 s listing): the same two welds
    are bounded over the family's sampled members, never above the listed bound nor the plan."""
    import armpath

    welds = [[300.0, 100.0, 200.0], [250.0, -100.0, 250.0]]
    listed = armpath.spotweld("seed", welds, scene="none", order="given").doc
    monkeypatch.setattr(tour_bounds, "MAX_LATTICE_TARGETS", 1)
    sampled = armpath.spotweld("seed", welds, scene="none", order="given").doc
    assert "lattice states within the tolerance" in listed["lower_bound"]["method"]
    assert "lattice states within the tolerance" not in sampled["lower_bound"]["method"]
    assert "lattice_goal_states" not in sampled["lower_bound"]["sampling"]
    assert 0 < sampled["lower_bound_commands"] <= listed["lower_bound_commands"]
    assert sampled["lower_bound_commands"] <= sampled["n_commands"]


@pytest.mark.slow  # 11-16 s
def test_more_welds_than_every_order_samples_are_bounded_over_their_lattice_states(monkeypatch):
    """A tour of more welds than every order at once takes over the family's samples
    (:data:`SUBSET_TARGETS`), up to :data:`MAX_LATTICE_TARGETS`, is bounded every order at once
    over its lattice goal states alone (eight welds of the seed arm in free space: 86, which
    their plan meets, where the cheaper bound said 57), and takes the cheaper bound where they
    cannot be listed. Three seed welds with the limits lowered: the same bound as every order
    at once over the lattice states gives by way of the five-to-seven route, and where the
    states are too many, the cheaper bound (every weld entered once), no higher; all equal to the
    bound order by order."""
    import armpath.planning.tour as tour

    arm, world, welds, start, _ = _three_seed_welds()
    fam = _targets_family(arm, world, welds)
    ticks = arm.lattice.nearest_ticks(start)
    orders = list(itertools.permutations(range(3)))
    say = lambda _m: None  # noqa: E731
    listed = []  # the welds' states listed once (the listing is tested above)
    listing = tour_bounds._goal_layers

    def once(*args, **kwargs):
        if not listed:
            listed.append(listing(*args, **kwargs))
        return listed[0]

    monkeypatch.setattr(tour_bounds, "_goal_layers", once)
    # every leg direct, none through the workpiece's opening (the same for every route)
    monkeypatch.setattr(tour_bounds, "sampled_passages", lambda *_a, **_k: [])
    by_order, _, why = tour._family_bounds(fam, ticks, welds, orders, False, 0.05, say)
    assert why is None and "lattice states" in by_order.method
    monkeypatch.setattr(tour, "EXACT_ORDER_TARGETS", 1)
    every, _, _ = tour._family_bounds(fam, ticks, welds, orders, False, 0.05, say)
    assert "sets of targets visited" in every.method and "lattice states" in every.method
    assert every.commands == by_order.commands
    monkeypatch.setattr(tour, "SUBSET_TARGETS", 2)
    over, per_order, _ = tour._family_bounds(fam, ticks, welds, orders, False, 0.05, say)
    assert per_order == {} and over.method == every.method and over.commands == every.commands
    assert over.guide_order is not None and sorted(over.guide_order) == [0, 1, 2]
    monkeypatch.setattr(tour, "MAX_LATTICE_TARGETS", 2)
    cheap, _, _ = tour._family_bounds(fam, ticks, welds, orders, False, 0.05, say)
    assert "entered once" in cheap.method and cheap.commands <= every.commands
    monkeypatch.setattr(tour, "MAX_LATTICE_TARGETS", 8)
    monkeypatch.setattr(tour_bounds, "_goal_layers", lambda *_a, **_k: None)  # not listed
    cheap, _, _ = tour._family_bounds(fam, ticks, welds, orders, False, 0.05, say)
    assert "entered once" in cheap.method and cheap.commands <= every.commands
