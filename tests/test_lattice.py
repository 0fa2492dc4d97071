"""The arm's own command lattice (issue 18, item 2) and the arm document results carry.

Counts are checked against the definition written out by hand (the largest
``ceil(|d_i| / max_ticks_i)``), replays in integer ticks, and forward kinematics of a model
rebuilt from its document against the original.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import independent_dh as idh
from armpath.commands import CommandSequence
from armpath.errors import CommandError, InvalidInputError
from armpath.geometry import CollisionWorld, Sphere
from armpath.kinematics import landmark_positions, tool_pose
from armpath.model.catalog import resolve_model
from armpath.model.dh import DHRow, dh_arm
from armpath.model.lattice import Lattice
from armpath.model.seed_arm import seed_arm
from armpath.model.serial_arm import JointKind
from armpath.model.serialize import arm_from_dict, arm_to_dict
from armpath.planning.motion import path_to_sequence, plan_motion
from armpath.planning.motion_check import motion_clearance

STEPPER_TICK_DEG = 0.0225  # a 1.8 deg stepper with 1/8 microsteps and a 10:1 gearbox


def stepper_seed():
    """The seed arm driven by steppers: 0.0225 deg a step, joints 1-3 at most 60 steps (1.35
    deg) a command, joints 4-6 at most 120 (2.7 deg)."""
    return seed_arm().with_lattice(
        tick=np.radians(STEPPER_TICK_DEG), max_ticks=[60, 60, 60, 120, 120, 120]
    )


def test_the_seed_lattice_is_the_seed_controllers():
    g = seed_arm().lattice
    assert g.is_default and g.n_joints == 6
    np.testing.assert_allclose(np.degrees(g.tick), 0.1, rtol=1e-15)
    assert g.max_ticks.tolist() == [20] * 6
    np.testing.assert_allclose(np.degrees(g.max_step), 2.0, rtol=1e-15)
    assert g.display([900, -900, 1, 0, 0, 0]).tolist() == [90.0, -90.0, 0.1, 0.0, 0.0, 0.0]


def test_commands_needed_and_split_on_an_uneven_lattice():
    g = stepper_seed().lattice
    rng = np.random.default_rng(3)
    for _ in range(200):
        d = rng.integers(-2000, 2001, 6)
        need = max(int(np.ceil(abs(int(d[i])) / [60, 60, 60, 120, 120, 120][i])) for i in range(6))
        assert g.commands_needed(d) == need
        for n in (need, need + 3):
            cmds = g.split(d, n)
            assert cmds.shape == (n, 6) and np.all(cmds.sum(axis=0) == d)
            assert np.all(np.abs(cmds) <= [60, 60, 60, 120, 120, 120])
    with pytest.raises(CommandError, match="needs at least"):
        g.split([61, 0, 0, 0, 0, 0], 1)


def test_a_sequence_is_checked_against_each_joints_limit():
    g = stepper_seed().lattice
    ok = CommandSequence(np.zeros(6, int), [[60, -60, 0, 120, -120, 0]], g)
    assert ok.final_ticks.tolist() == [60, -60, 0, 120, -120, 0]
    np.testing.assert_allclose(ok.grid.display(ok.final_ticks), [1.35, -1.35, 0, 2.7, -2.7, 0])
    with pytest.raises(CommandError, match=r"joint 1: increment 61 ticks is outside \[-60, 60\]"):
        CommandSequence(np.zeros(6, int), [[61, 0, 0, 0, 0, 0]], g)
    # the seed controller's sequence refuses what the stepper's allows
    with pytest.raises(CommandError, match="at most 2 deg"):
        CommandSequence(np.zeros(6, int), [[0, 0, 0, 120, 0, 0]])


def test_display_units_and_lattice_membership():
    welder = resolve_model("welder003")  # joint 3 prismatic, mm
    g = welder.lattice
    assert g.units == ("deg", "deg", "mm", "deg", "deg", "deg")
    ticks = g.from_display([10.0, -20.5, 123.4, 0, 0, 0], "--from")
    assert ticks.tolist() == [100, -205, 1234, 0, 0, 0]
    with pytest.raises(InvalidInputError, match="joint 3 is not a whole number of its ticks"):
        g.from_display([10.0, -20.5, 123.45, 0, 0, 0], "--from")
    # angles all within +-6.28 "deg" and off the lattice: likely radians, and said so; values
    # beyond that range get no such hint
    radians = "every angle lies within +-6.28 deg: were they given in radians?"
    with pytest.raises(InvalidInputError, match=re.escape(radians)):
        g.from_display(np.radians([0, -30, 30, 0, 30, 0]), "start_deg")
    with pytest.raises(InvalidInputError, match=r"\(the command lattice\)$"):
        g.from_display([10.05, -20.5, 123.4, 0, 0, 0], "--from")
    # joint values in the model's own units (rad: a robot file's home) get no such hint
    with pytest.raises(InvalidInputError, match=r"\(the command lattice\)$"):
        g.to_ticks(np.radians([0.05, -30, 30, 0, 30, 0]), "home")
    metres = Lattice([1e-4, np.radians(0.1)], [20, 20], [True, False], "m")
    np.testing.assert_allclose(metres.tick_display, [0.1, 0.1])
    with pytest.raises(InvalidInputError, match="ticks must be"):
        Lattice([np.radians(20.0)], [1], [False])  # 20 deg a tick: beyond 10 deg
    with pytest.raises(InvalidInputError, match="max ticks per command"):
        Lattice([np.radians(0.1)], [0], [False])


def test_path_to_sequence_follows_any_lattice_with_legal_commands():
    rng = np.random.default_rng(11)
    for _ in range(50):
        most = rng.integers(1, 200, 4)
        g = Lattice(np.radians(rng.uniform(0.01, 0.5, 4)), most, np.zeros(4, bool))
        path = np.cumsum(rng.normal(0, 300, (6, 4)), axis=0)
        start, goal = np.round(path[0]).astype(int), np.round(path[-1]).astype(int)
        seq = path_to_sequence(path, start, goal, g)
        assert np.all(np.abs(seq.commands) <= most)
        assert seq.start_ticks.tolist() == start.tolist()
        assert seq.final_ticks.tolist() == goal.tolist()
        # at most one command more than the path's length in the command metric
        metric = np.abs(np.diff(path, axis=0)) / most
        assert seq.n_commands <= int(np.ceil(metric.max(axis=1).sum() - 1e-9)) + 1


def test_plan_around_a_ball_on_a_stepper_lattice_replays():
    arm = stepper_seed()
    g = arm.lattice
    # a ball on the circle the forearm sweeps when joint 1 turns from 0 to 90 deg
    ball = np.array([-390.0 * np.sin(np.pi / 4), 390.0 * np.cos(np.pi / 4), 140.0])
    world = CollisionWorld((Sphere("ball", ball, 60.0),))
    start = g.from_display([0, -90, 0, 0, -90, 0], "start")
    goal = g.from_display([90, -90, 0, 0, -90, 0], "goal")
    plan = plan_motion(arm, world, start, goal[None])
    seq = plan.sequence
    assert seq.grid.same_as(g)
    states = seq.states()
    assert states[0].tolist() == start.tolist() and states[-1].tolist() == goal.tolist()
    assert np.all(np.abs(np.diff(states, axis=0)) <= g.max_ticks)
    # fewest possible: the largest ceil(|change| / max ticks) over the joints, by hand
    change = np.abs(goal - start)
    assert seq.n_commands >= max(int(np.ceil(change[i] / g.max_ticks[i])) for i in range(6))
    assert plan.method != "direct" and motion_clearance(arm, world, seq).certified_ok
    # the middle of every command, replayed with the textbook product: clear of the ball
    mid = g.to_joint(states[:-1] + 0.5 * np.diff(states, axis=0))
    pts = landmark_positions(arm, mid)
    for a, b in ((1, 2), (2, 3), (3, 4)):
        s = np.linspace(0, 1, 60)
        p = pts[:, a, None] + s[None, :, None] * (pts[:, b] - pts[:, a])[:, None]
        assert np.linalg.norm(p - ball, axis=-1).min() >= 61.0 - 1e-6


@pytest.mark.parametrize("name", ["seed", "welder003", "painter004", "puma560", "ur5"])
def test_an_arm_document_rebuilds_the_same_arm(name):
    arm = resolve_model(name)
    doc = json.loads(json.dumps(arm_to_dict(arm)))  # plain JSON types
    back = arm_from_dict(doc)
    q = np.random.default_rng(5).uniform(-2, 2, (40, arm.n_joints))
    np.testing.assert_array_equal(tool_pose(back, q), tool_pose(arm, q))
    np.testing.assert_array_equal(landmark_positions(back, q), landmark_positions(arm, q))
    assert back.lattice.same_as(arm.lattice)
    assert [(lk.start, lk.end, lk.radius, lk.checked) for lk in back.links] == [
        (lk.start, lk.end, lk.radius, lk.checked) for lk in arm.links
    ]
    np.testing.assert_array_equal(back.home, arm.home)


def test_an_arm_document_of_a_dh_table_matches_the_textbook_product():
    rows = [
        DHRow(a=0.0, alpha=np.pi / 2, d=89.2),
        DHRow(a=-425.0, alpha=0.0, d=0.0),
        DHRow(a=-392.0, alpha=0.0, d=0.0),
        DHRow(a=0.0, alpha=np.pi / 2, d=109.3),
        DHRow(a=0.0, alpha=-np.pi / 2, d=94.75),
        DHRow(a=0.0, alpha=0.0, d=82.5),
    ]
    arm = dh_arm(rows, name="ur-like").with_lattice(max_ticks=[10, 20, 30, 40, 50, 60])
    back = arm_from_dict(json.loads(json.dumps(arm_to_dict(arm))))
    q = np.random.default_rng(9).uniform(-3, 3, 6)
    a = [r.a for r in rows]
    alpha = [r.alpha for r in rows]
    d = [r.d for r in rows]
    np.testing.assert_allclose(tool_pose(back, q), idh.dh_pose(a, alpha, d, q), atol=1e-9)
    assert back.lattice.max_ticks.tolist() == [10, 20, 30, 40, 50, 60]


def test_bad_arm_documents_are_one_clear_error():
    doc = arm_to_dict(seed_arm())
    with pytest.raises(InvalidInputError, match="document version"):
        arm_from_dict({**doc, "version": 99})
    broken = {**doc, "joints": doc["joints"][:1]}
    with pytest.raises(InvalidInputError):
        arm_from_dict(broken)
    missing = r"^model: incomplete arm: joint 1 has no 'T_parent_joint'$"
    with pytest.raises(InvalidInputError, match=missing):
        arm_from_dict({**doc, "joints": [{"name": "j"}]})
    # what is wrong, in words rather than an exception's repr
    bad_kind = {**doc, "joints": [{**doc["joints"][0], "kind": "spherical"}, *doc["joints"][1:]]}
    with pytest.raises(
        InvalidInputError,
        match=r"^model: malformed arm: joint 1: kind must be 'revolute' or 'prismatic', got "
        r"'spherical'$",
    ):
        arm_from_dict(bad_kind)
    # each wrong value named by its key, none read as something else
    for where, key, value, says in (
        ("joint", "limits", [1.0], r"joint 3: limits must be \[lower, upper\]"),
        ("joint", "limits", None, r"joint 3: limits must be \[lower, upper\]"),
        ("joint", "max_ticks", 2.5, r"joint 3: max_ticks must be a whole number of at most"),
        ("joint", "max_ticks", float("inf"), r"joint 3: max_ticks must be a whole number .*inf"),
        ("joint", "max_ticks", 1e30, r"joint 3: max_ticks must be a whole number .*1e\+30"),
        ("joint", "T_parent_joint", [["1"] * 4] * 4, r"joint 3: T_parent_joint must be 4 x 4"),
        ("joint", "tick", "x", r"joint 3: tick must be a number, got 'x'"),
        ("joint", "axis", "z", r"joint 3: axis must be 3 numbers, got 'z'"),
        ("link", "start", "J1", r"link 3: start must be a whole number .*'J1'"),
        ("link", "checked", "yes", r"link 3: checked must be true or false"),
        ("landmark", "offset", [1, 2], r"landmark 3: offset must be 3 numbers"),
        (None, "home", "zero", r"the document: home must be 6 numbers"),
        (None, "home", [True] * 6, r"the document: home must be 6 numbers"),
        (None, "name", [1], r"the document: name must be text"),
        (None, "parameters", [1, 2], r"parameters must be a list of \[name, number\] pairs"),
        (None, "joints", [], r"joints is empty: a serial arm needs at least one joint"),
    ):
        bad = json.loads(json.dumps(doc))
        (bad if where is None else bad[where + "s"][2])[key] = value
        with pytest.raises(InvalidInputError, match=r"^model: malformed arm: .*" + says):
            arm_from_dict(bad)
    # a null tick is the joint's default tick, as for a joint built without one
    default = json.loads(json.dumps(doc))
    default["joints"][2]["tick"] = None
    assert arm_from_dict(default).lattice.tick[2] == seed_arm().lattice.tick[2]


@pytest.mark.parametrize(
    ("rows", "cols", "low", "high"),
    [
        (5000, 5, -3, 3),  # many repeats: neighbourhoods of lattice states
        (2000, 6, -3600, 3600),  # whole tick ranges: packed into one key
        (3000, 5, -(2**40), 2**40),  # too wide to pack: sorted column by column
        (40, 1, 0, 0),  # one column, all equal
        (1, 3, 7, 7),
    ],
)
def test_unique_states_equals_numpy_unique_rows(rows, cols, low, high):
    """Same rows, order, first indices and inverse as ``np.unique(..., axis=0)``."""
    from armpath.model.lattice import unique_states

    a = np.random.default_rng(rows + cols).integers(low, high + 1, (rows, cols))
    want = np.unique(a, axis=0, return_index=True, return_inverse=True)
    got = unique_states(a, return_index=True, return_inverse=True)
    for w, g in zip(want, got, strict=True):
        np.testing.assert_array_equal(g, w.reshape(g.shape))
    np.testing.assert_array_equal(unique_states(a), want[0])
    np.testing.assert_array_equal(unique_states(a, return_inverse=True)[1], want[2].reshape(-1))
    assert np.array_equal(want[0][want[2].reshape(-1)], a)


def test_joint_limits_in_whole_ticks():
    """The seed arm's limits (deg, from the spec) and the UR5's +-360 deg in ticks of 0.1 deg;
    unlimited joints stay infinite. A joint whose limit lies a hair inside a tick keeps that
    tick (the limit read in a unit whose division by the tick is not exact)."""
    from armpath.api import load_arm

    low, high = load_arm("seed").limits_in_ticks()
    np.testing.assert_array_equal(high, [np.inf, 1250, 1380, np.inf, 1335, np.inf])
    np.testing.assert_array_equal(low, -high)
    low, high = load_arm("ur5").limits_in_ticks()
    np.testing.assert_array_equal(low, np.full(6, -3600.0))
    np.testing.assert_array_equal(high, np.full(6, 3600.0))
    # a limit 1e-12 rad inside 130 deg still reaches tick 1300; one a tenth of a tick inside
    # does not
    from dataclasses import replace

    tick = float(load_arm("seed").lattice.tick[1])
    for inside, ticks in ((1e-12, 1300.0), (0.1 * tick, 1299.0)):
        seed = load_arm("seed")
        joints = list(seed.joints)
        joints[1] = replace(joints[1], limits=(-(1300 * tick - inside), 1300 * tick - inside))
        low, high = replace(seed, joints=tuple(joints)).limits_in_ticks()
        assert (low[1], high[1]) == (-ticks, ticks)


def test_random_configurations_are_drawn_from_one_box_of_the_joint_limits():
    """The box random starts and samples are drawn from was written in five places, an
    unlimited side filled four ways (+-pi, +-the arm's size or +-1000 for a prismatic joint, a
    turn about home): a rail without limits was sampled within +-3.14 mm by the trace's family.
    Now one: the limits, a turn for a revolute joint's unlimited side, +-the arm's size (its
    fixed offsets summed: each joint's placement from the last, d then a of the row before:
    400, 300, then 250 across and 50 down to the quill) for a prismatic one's."""
    rows = [
        DHRow(0.0, np.pi / 2, 0.0, kind=JointKind.PRISMATIC),  # a rail, unlimited
        DHRow(300.0, 0.0, 400.0),  # unlimited
        DHRow(250.0, 0.0, 0.0, limits=(-2.0, np.inf)),
        DHRow(0.0, 0.0, 50.0, kind=JointKind.PRISMATIC, limits=(0.0, 200.0)),
    ]
    arm = dh_arm(rows, name="rail")
    size = 400.0 + 300.0 + np.hypot(250.0, 50.0)
    assert arm.size == pytest.approx(size)
    lower, upper = arm.sampling_box()
    np.testing.assert_allclose(lower, [-size, -np.pi, -2.0, 0.0])
    np.testing.assert_allclose(upper, [size, np.pi, np.pi, 200.0])


def test_a_model_without_a_home_starts_on_its_lattice():
    """A model that gives no home starts at zero moved into its limits; where a limit is off
    the lattice (10.05 deg, 3.15 mm), the nearest whole tick within it (10.1 deg, 3.2 mm), so
    that tasks can start there; limits that hold no tick keep the limit nearest zero."""
    d = np.pi / 180
    rows = [
        DHRow(100.0, 0.0, 0.0, limits=(10.05 * d, 50 * d)),
        DHRow(100.0, 0.0, 0.0, limits=(-50 * d, -10.05 * d)),
        DHRow(0.0, 0.0, 0.0, kind=JointKind.PRISMATIC, limits=(3.15, 200.0)),
        DHRow(100.0, 0.0, 0.0, limits=(-30 * d, 30 * d)),
        DHRow(100.0, 0.0, 0.0, limits=(10.01 * d, 10.09 * d)),  # no whole tick inside
    ]
    arm = dh_arm(rows, name="off-lattice limits")
    shown = arm.lattice.joint_display(arm.home)
    np.testing.assert_allclose(shown, [10.1, -10.1, 3.2, 0.0, 10.01], atol=1e-9)
    ticks = np.round(arm.home[:4] / arm.lattice.tick[:4])
    np.testing.assert_allclose(arm.home[:4], ticks * arm.lattice.tick[:4], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(ticks, [101, -101, 32, 0])


def test_a_scenes_ticks_take_the_models_home_onto_them(tmp_path):
    """A scene that sets the ticks (a stepper's 0.0225 deg) left a model's home off them where
    it was not a whole number of the new ticks, and every task stopped ('the arm's home pose:
    joint 2 is not a whole number of its ticks'). Without [arm] home_deg the home is now the
    nearest state on the new ticks within the limits: 10.01 deg is 444.9 ticks, so 445 ticks,
    10.0125 deg; the default home at a limit of -3.99925 deg, -178 ticks (-4.005 deg), not
    -177 (-3.9825, beyond the limit). A home_deg off the ticks is still refused."""
    from armpath.scenes import load_scene
    from armpath.scenes.arm import scene_arm

    robot = tmp_path / "arm.json"
    links = [
        {"a": 0, "alpha": 90, "d": 300, "limits": [-170, 170]},
        {"a": 400, "alpha": 0, "d": 0, "limits": [-120, 120]},
        {"a": 300, "alpha": 0, "d": 0, "limits": [-170, -3.99925]},
    ]
    doc = {"name": "three", "convention": "standard", "units": {"length": "mm", "angle": "deg"}}
    robot.write_text(json.dumps(doc | {"links": links}))
    with_home = tmp_path / "arm_home.json"
    with_home.write_text(json.dumps(doc | {"links": links, "home": [0, 10.01, -45]}))
    for model, home in ((robot, [0.0, 0.0, -178 * 0.0225]), (with_home, [0.0, 445 * 0.0225, -45])):
        cell = tmp_path / f"{model.stem}.toml"
        cell.write_text(f'name = "stepper"\n[arm]\nmodel = "{model.name}"\ntick = 0.0225\n')
        arm = scene_arm(load_scene(cell))
        shown = arm.lattice.joint_display(arm.home)
        np.testing.assert_allclose(shown, home, atol=1e-9)
        ticks = shown / STEPPER_TICK_DEG
        np.testing.assert_allclose(ticks, np.round(ticks), atol=1e-6)
    cell.write_text(cell.read_text() + "home_deg = [0, 10.01, -45]\n")
    with pytest.raises(InvalidInputError, match="home_deg"):
        scene_arm(load_scene(cell))
