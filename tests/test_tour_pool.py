"""Issue 21: tours through pools of goal states (armpath.planning.tour_pool).

* the shortest paths through one member per target, forwards by prefix and backwards, agree
  with a brute force over every combination of members (whole commands per leg, joints that
  span a whole turn measured the shorter way round, written here from the arm's limits; the UR5
  cell, every joint +-360 deg; with and without the way back);
* the lazy search over pools of lattice states, with legs whose costs it cannot see (each leg's
  direct commands plus a hidden surcharge, some legs impossible, some ending at a whole-turn copy
  of their goal), finds the cheapest tour of a brute force over every order and combination of
  states when it charges unplanned legs their direct commands alone, after planning fewer legs
  than there are; with the median surcharge it finds a tour no cheaper than that, whose legs
  chain;
* the pools' members at the seed's welds keep the goal states' rule: independent forward
  kinematics puts the fingertip on the weld, independent distances keep every link 1 mm + 0.5
  mm (the pools' room, ``POOL_BODY_BUFFER_MM``) from the workpiece and the floor (the tool's
  own link 1 mm from the wall it touches);
* (tests/test_spotweld.py) the seed's Task 3 through them: at most 125 commands (121 measured),
  replayed independently.
"""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

import independent
from armpath.model.seed_arm import seed_arm
from armpath.planning import tour, tour_pool
from armpath.scenes import load_scene, seed_scene
from armpath.scenes.arm import scene_arm
from test_tour_guide import ur5_cell_guide, whole_command_legs
from test_ur5_cell import CELL


@pytest.fixture(scope="module")
def cell_guide():
    _, arm, _, guide = ur5_cell_guide()
    rng = np.random.default_rng(11)
    keep = []
    for lay in guide.layers:
        mask = np.zeros(lay.size, dtype=bool)
        mask[rng.choice(lay.size, min(lay.size, 14), replace=False)] = True
        keep.append(mask)
    return arm, guide.subset(keep)


@pytest.mark.parametrize("back", [False, True])
def test_member_paths_match_a_brute_force(cell_guide, back):
    arm, guide = cell_guide
    tip = guide.sampler.tip
    q0 = np.radians([0, -90, 90, -90, -90, 0])
    paths = tour_pool._MemberPaths(guide, q0, back)
    for order in [(0, 1, 2, 3), (2, 0, 3, 1), (3, 1, 0, 2)]:
        q = [guide.layers[t].q for t in order]
        # every combination at once: an array with one axis per target
        total = whole_command_legs(arm, q0[None], q[0], tip)[0].reshape(-1, 1, 1, 1)
        total = total + whole_command_legs(arm, q[0], q[1], tip)[:, :, None, None]
        total = total + whole_command_legs(arm, q[1], q[2], tip)[None, :, :, None]
        total = total + whole_command_legs(arm, q[2], q[3], tip)[None, None, :, :]
        if back:
            total = total + whole_command_legs(arm, q[3], q0[None], tip)[:, 0][None, None, None, :]
        assert paths.length(order) == pytest.approx(total.min())
        for axis, through in enumerate(paths.through(order)):
            others = tuple(a for a in range(4) if a != axis)
            np.testing.assert_allclose(through, total.min(axis=others))


class _Hidden:
    """Legs whose costs the search cannot see: direct commands (joints that span a whole turn
    the shorter way round, from the arm's limits) plus a surcharge fixed by the two states up to
    whole turns; about one in eight impossible; with ``copies``, about half end at a whole-turn
    copy of their goal on the first joint that has one."""

    def __init__(self, arm, seed):
        self.arm = arm
        grid = arm.lattice
        turn = 2 * np.pi / grid.tick
        wide = np.isfinite(arm.lower) & np.isfinite(arm.upper) & (arm.upper - arm.lower > 2 * np.pi)
        self.turn = np.where(wide, np.round(turn), 0).astype(np.int64)
        self.max_ticks = np.asarray(grid.max_ticks)
        self.seed = seed
        self.calls = 0

    def canon(self, s):
        return tuple(int(v % t) if t else int(v) for v, t in zip(s, self.turn, strict=True))

    def direct(self, a, b):
        d = np.asarray(b, dtype=float) - np.asarray(a, dtype=float)
        t = np.where(self.turn > 0, self.turn, 1)
        d = np.where(self.turn > 0, d - t * np.round(d / t), d)
        return float(np.ceil(np.max(np.abs(d) / self.max_ticks) - 1e-9))

    def _draw(self, a, b):
        rng = np.random.default_rng(abs(hash((self.seed, self.canon(a), self.canon(b)))) % 2**32)
        return rng.integers(0, 25), rng.random() < 0.125, rng.random() < 0.5

    def cost(self, a, b):
        extra, impossible, _ = self._draw(a, b)
        return np.inf if impossible else self.direct(a, b) + extra

    def __call__(self, a, b, copies):
        self.calls += 1
        extra, impossible, copy = self._draw(a, b)
        if impossible:
            return None
        end = np.array(b, dtype=np.int64)
        joints = np.flatnonzero(self.turn)
        if copies and copy and joints.size:
            end[joints[0]] += self.turn[joints[0]] * (1 if end[joints[0]] < 0 else -1)
        seq = SimpleNamespace(n_commands=int(self.direct(a, b) + extra), final_ticks=end)
        return SimpleNamespace(sequence=seq)


def _pools(arm, rng, sizes):
    out = []
    for t, m in enumerate(sizes):
        ticks = rng.integers(-900, 900, size=(m, arm.n_joints)).astype(float)
        out.append(
            tour_pool._Pool(
                t, ticks, arm.lattice.to_joint(ticks), np.ones(m, bool), np.zeros(m, bool)
            )
        )
    return out


def _brute(hidden, start, pools, orders, back):
    best = np.inf
    for order in orders:
        layers = [pools[t].ticks.astype(np.int64) for t in order]
        for pick in itertools.product(*(range(lay.shape[0]) for lay in layers)):
            states = [start] + [lay[i] for lay, i in zip(layers, pick, strict=True)]
            states += [start] if back else []
            best = min(best, sum(hidden.cost(a, b) for a, b in itertools.pairwise(states)))
    return best


@pytest.mark.parametrize(
    ("which", "back", "seed"),
    [("seed", False, 1), ("seed", True, 2), ("ur5", False, 3), ("ur5", True, 4)],
)
def test_lazy_search_finds_the_cheapest_tour_of_hidden_leg_costs(monkeypatch, which, back, seed):
    arm = seed_arm() if which == "seed" else scene_arm(load_scene(CELL))
    rng = np.random.default_rng(seed)
    start = np.zeros(arm.n_joints, dtype=np.int64)
    orders = [(0, 1, 2), (2, 0, 1), (1, 2, 0)]
    truth_hidden = _Hidden(arm, seed)
    for surcharge in (False, True):
        pools = _pools(arm, np.random.default_rng(seed), [6, 5, 7])
        if not surcharge:
            monkeypatch.setattr(tour_pool, "EXCESS_AFTER", 10**9)
        else:
            monkeypatch.undo()
        hidden = _Hidden(arm, seed)
        turns = tour_pool._Turns(arm)
        cache = tour_pool._LegCache(hidden, turns)
        monkeypatch.setattr(tour_pool, "POOL_LEG_PLANS", 10**6)
        graphs = [tour_pool._OrderGraph.build(start, o, pools, back, turns) for o in orders]
        found = tour_pool.lazy_search(graphs, cache, lambda pool, i: True)
        truth = _brute(truth_hidden, start, pools, orders, back)
        assert found is not None
        order, legs = found
        total = sum(leg.sequence.n_commands for leg in legs)
        if not surcharge:
            assert total == truth
            every_leg = 3 * (6 + 6 * 5 + 5 * 7 + (7 if back else 0))
            assert hidden.calls < every_leg / 2
        else:
            assert total >= truth
        # the legs chain from the start through one state of each target, up to whole turns
        assert len(legs) == 3 + back
        reached = [hidden.canon(leg.sequence.final_ticks) for leg in legs]
        for t, r in zip(order, reached, strict=False):
            assert r in {hidden.canon(s) for s in pools[t].ticks.astype(np.int64)}
        if back:
            assert reached[-1] == hidden.canon(start)
    del rng


@pytest.fixture(scope="module")
def seed_pools():
    scene = seed_scene()
    arm = seed_arm()
    pts = scene.spotweld_targets_mm()
    fam = tour._targets_family(arm, scene.world, pts)
    q0 = np.radians([0, -90, 0, 0, -90, 0])
    return fam, pts, q0, tour_pool.pool_guide(fam, pts, 0.05, q0)


def test_pool_members_are_capped_evenly(seed_pools, monkeypatch):
    fam, pts, q0, guide = seed_pools
    monkeypatch.setattr(tour_pool, "MAX_POOL_LAYER", 500)
    capped = tour_pool.pool_guide(fam, pts, 0.05, q0)
    for full, few in zip(guide.layers, capped.layers, strict=True):
        assert few.size == min(full.size, 500)
        # the capped members are members of the full pool, first and last among them
        rows = {tuple(np.round(q, 12)) for q in full.q}
        assert all(tuple(np.round(q, 12)) in rows for q in few.q)
        np.testing.assert_allclose(few.q[[0, -1]], full.q[[0, -1]])


@pytest.mark.slow
def test_pool_members_keep_the_goal_states_rule(seed_pools):
    _, pts, _, guide = seed_pools
    wp = independent.Workpiece("normal")
    for t, lay in enumerate(guide.layers):
        assert lay.size > 1000  # split next to the wall: thousands of members
        joints = independent.points(np.degrees(lay.q))  # (M, 5, 3) mm
        assert np.linalg.norm(joints[:, -1] - pts[t], axis=-1).max() <= 0.05 + 1e-9
        samples, is_tip = independent.link_samples(joints)
        to_wp = wp.distance(samples.reshape(-1, 3)).reshape(samples.shape[:2])
        to_floor = samples[..., 2]
        de = np.zeros(samples.shape[1], dtype=bool)
        de[-(int(np.ceil(independent.DE)) + 1) :] = True  # DE's samples come last (1 mm apart)
        body = ~is_tip
        # every link 1 mm + 0.5 mm from the floor; from the workpiece too, but the tool (DE),
        # which touches the wall at its tip, 1 mm; the tip itself outside both
        assert tour_pool.POOL_BODY_BUFFER_MM == 0.5
        assert to_floor[body].min() >= 1.5 - 1e-6
        assert to_wp[body & ~de[None, :]].min() >= 1.5 - 1e-6
        assert to_wp[body & de[None, :]].min() >= 1.0 - 1e-6
        assert min(to_wp[is_tip].min(), to_floor[is_tip].min()) >= -1e-9


@pytest.mark.slow
def test_the_pools_switch_leaves_them_out_and_they_never_lengthen_a_tour():
    """``pools=False`` plans without the pooling step (no pool is sampled), ``pools=True`` runs
    it; both tours, replayed independently in integer ticks with the seed's forward kinematics,
    put the fingertip within 0.05 mm of every weld, and the pooled one needs no more commands
    (its plan counts only when shorter)."""
    from armpath.api import arm_and_scene
    from armpath.tasks import spotweld_task

    arm, scene = arm_and_scene("seed", "none")
    welds = np.array([[300.0, 100.0, 200.0], [250.0, -100.0, 250.0], [320.0, 0.0, 150.0]])
    commands = {}
    for pools in (True, False):
        said: list[str] = []
        res = spotweld_task(
            scene, arm, targets_mm=welds, bound=False, pools=pools, on_progress=said.append
        )
        assert any("pools" in m for m in said) == pools
        seq = res.sequence
        states = independent.replay(seq.start_ticks / 10.0, seq.commands)
        tips = independent.points(states)[:, -1]
        for w in welds:
            assert np.linalg.norm(tips - w, axis=1).min() <= 0.05 + 1e-9
        commands[pools] = seq.n_commands
    assert commands[True] <= commands[False]
