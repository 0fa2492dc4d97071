"""Continuous clearance of command motions against dense brute-force replay."""

import numpy as np
import pytest

import independent
from armpath.commands import CommandSequence, deg_to_ticks
from armpath.geometry import CollisionWorld, HalfSpace
from armpath.model import seed_arm
from armpath.planning import motion_clearance
from armpath.scenes import seed_scene

ARM = seed_arm()
SCENE = seed_scene()


def _brute_force(initial_deg, commands, substeps=50):
    pts = independent.motion_points(initial_deg, commands, substeps)
    samples, tip = independent.link_samples(pts, spacing=1.0)
    flat = samples.reshape(-1, 3)
    wp = independent.Workpiece("normal").distance(flat).reshape(samples.shape[:2])
    table = samples[..., 2]
    c = np.minimum(wp, table)
    return c[~np.broadcast_to(tip, c.shape)].min(), c.min()


def test_motion_sweeping_over_the_workpiece():
    # swing the arm from pointing along +y round to +x, over the workpiece rim
    start = deg_to_ticks([0, -60, 0, 0, -60, 0])
    goal = deg_to_ticks([-70, -60, 0, 0, -60, 0])
    seq = CommandSequence.straight(start, goal)
    mc = motion_clearance(ARM, SCENE.world, seq)
    body_ref, all_ref = _brute_force([0, -60, 0, 0, -60, 0], seq.commands)
    # the true minimum lies in [lower bound, min_clearance]; brute-force samples can only
    # overestimate it (the independent model is exact, the samples are not)
    assert mc.min_clearance_lower_bound <= mc.min_clearance
    assert mc.min_clearance <= all_ref + 0.02
    assert mc.min_clearance_lower_bound <= all_ref + 0.02
    assert mc.min_clearance - mc.min_clearance_lower_bound <= 0.5
    assert mc.min_body_clearance <= body_ref + 0.02
    assert mc.worst_obstacle == "workpiece"


def test_collision_is_detected_and_located():
    # lower the arm into the workpiece: joint 1 turns the arm toward +x at low height
    start = deg_to_ticks([0, -90, 0, 0, -90, 0])
    goal = deg_to_ticks([-90, -90, 0, 0, -90, 0])
    seq = CommandSequence.straight(start, goal)
    mc = motion_clearance(ARM, SCENE.world, seq)
    assert not mc.certified_ok
    assert mc.min_clearance < 0
    assert mc.worst_obstacle == "workpiece"
    assert 1 <= mc.worst_command <= seq.n_commands


def test_certified_bound_is_sound_on_random_motions():
    rng = np.random.default_rng(3)
    world = SCENE.world
    for _ in range(5):
        start = rng.integers(-300, 300, 6) + deg_to_ticks([0, -60, 30, 0, -60, 0])
        cmds = rng.integers(-20, 21, (6, 6))
        seq = CommandSequence(start, cmds)
        mc = motion_clearance(ARM, world, seq)
        dense = world.clearances(ARM, seq.sample_motion(400)).min()
        assert mc.min_clearance <= dense + 1e-9
        assert mc.min_clearance_lower_bound <= dense + 1e-9


def test_empty_sequence_checks_the_start_state():
    seq = CommandSequence(deg_to_ticks([0, -90, 0, 0, -90, 0]), np.zeros((0, 6), int))
    mc = motion_clearance(ARM, SCENE.world, seq)
    assert mc.min_clearance == pytest.approx(75.0)
    assert mc.worst_part == "DE tip" and mc.worst_obstacle == "table"
    assert mc.certified_ok
    assert CollisionWorld((), 1.0).parts(ARM)[-1].is_tip


def test_a_long_motion_is_certified_a_chunk_at_a_time_as_at_once(monkeypatch):
    """Instants are evaluated 50,000 at a time and a very long sequence starts from its states
    alone (a million commands held 1.5 GB). With chunks of 7 instants and the first round
    capped below 4 a command, the same motion over the workpiece is certified alike: both
    bracket the brute-force minimum of the independent model, and the chunks change nothing
    when the first round is the same."""
    from armpath.planning import motion_check

    start = deg_to_ticks([0, -60, 0, 0, -60, 0])
    seq = CommandSequence.straight(start, deg_to_ticks([-70, -60, 0, 0, -60, 0]))
    whole = motion_clearance(ARM, SCENE.world, seq)
    monkeypatch.setattr(motion_check, "_EVALUATION_CHUNK", 7)
    chunked = motion_clearance(ARM, SCENE.world, seq)
    assert chunked == whole
    monkeypatch.setattr(motion_check, "_MAX_INITIAL_INSTANTS", seq.n_commands)
    sparse = motion_clearance(ARM, SCENE.world, seq)
    _, all_ref = _brute_force([0, -60, 0, 0, -60, 0], seq.commands)
    for mc in (whole, sparse):
        assert mc.certified_ok
        assert mc.min_clearance_lower_bound <= all_ref + 0.02 and mc.min_clearance <= all_ref + 0.02
        assert mc.min_clearance - mc.min_clearance_lower_bound <= 0.5


def test_a_motion_is_measured_a_chunk_at_a_time_as_at_once(monkeypatch):
    """The tool point's path length of a plan is summed 20,000 commands at a time; in chunks of
    3 commands it is the same, and it matches the independent kinematics' polyline."""
    from armpath.planning import motion as motion_module

    start = deg_to_ticks([0, -60, 0, 0, -60, 0])
    seq = CommandSequence.straight(start, deg_to_ticks([-70, -40, 20, 10, -60, 0]))
    whole = motion_module.plan_metrics(ARM, seq)
    monkeypatch.setattr(motion_module, "_METRIC_CHUNK", 3)
    assert motion_module.plan_metrics(ARM, seq).tip_path_mm == pytest.approx(whole.tip_path_mm)
    tips = independent.motion_points([0, -60, 0, 0, -60, 0], seq.commands, 64)[..., -1, :]
    assert whole.tip_path_mm == pytest.approx(
        np.linalg.norm(np.diff(tips.reshape(-1, 3), axis=0), axis=1).sum(), abs=1e-3
    )


def test_a_head_on_approach_ending_a_hair_off_a_surface_is_certified():
    """A SCARA's quill lowers its tool tip straight onto a table and stops 0.001 mm above it.
    The bound on each interval was the lower end's value less the most the clearance can fall
    in half the interval, which stays below 0.001 mm until an interval is narrower than the
    certificate's precision allows: 'not provable'. Now it is where the slopes from both ends
    meet, (a + b - c h) / 2, a proof here. Both bound the dense minimum from below (the
    table's distance is the tool tip's height, written here: 350 mm less the quill)."""
    from armpath.model.dh import dh_arm
    from arms import scara_rows

    arm = dh_arm(scara_rows(), name="scara", home=np.zeros(4))
    start = np.array([300, 400, 1400, 0])  # ticks: 30 deg, 40 deg, 140 mm, 0 deg
    goal = start + np.array([0, 0, 100, 0])  # the quill 10 mm lower, the tip 200 mm up
    table = 350.0 - goal[2] * 0.1 - 0.001
    world = CollisionWorld((HalfSpace("table", np.array([0, 0, table]), np.array([0, 0, 1.0])),))
    seq = CommandSequence.straight(start, goal, lattice=arm.lattice)
    mc = motion_clearance(arm, world, seq)
    dense = 350.0 - seq.sample_motion(400)[:, 2] - table
    assert mc.certified_ok and mc.min_tip_clearance == pytest.approx(0.001, abs=1e-9)
    assert 0.0 <= mc.min_clearance_lower_bound <= dense.min() + 1e-9


def test_a_tip_within_a_few_microns_of_a_surface_is_proven_clear_at_a_finer_resolution():
    """A trace at a tolerance of 0.005 mm keeps the tool tip as near a surface it follows (the
    seed crack: 0.0005 mm at a sampled instant), and its final check, resolving clearances to
    0.01 mm, could not prove it (-0.0044 mm) and refused the plan. Here the tip rises to within
    0.002 mm of a plate above the arm (the independent model, 2,000 instants a command): at
    0.01 mm the bound stays below zero, at 0.0002 mm it is proven, below the brute force's."""
    start_deg = [0, -30, 0, 0, 0, 0]
    seq = CommandSequence.straight(deg_to_ticks(start_deg), deg_to_ticks([-10, -32, 4, 0, 0, 0]))
    z = independent.motion_points(start_deg, seq.commands, 2000)[..., 2]
    assert z[..., 4].max() > z[..., :4].max() + 50.0  # the tip alone comes near the plate
    top = z[..., 4].max() + 0.002
    world = CollisionWorld((HalfSpace("plate", np.array([0.0, 0.0, top]), -np.eye(3)[2]),), 1.0)
    coarse = motion_clearance(ARM, world, seq)
    assert not coarse.certified_ok and not coarse.violated
    fine = motion_clearance(ARM, world, seq, tolerance=0.0002)
    assert fine.certified_ok and fine.worst_part == "DE tip"
    assert 0.0 <= fine.min_clearance_lower_bound <= 0.002 + 1e-9
    assert fine.min_clearance_lower_bound <= fine.min_clearance <= 0.002 + 1e-6


def _ball_under_the_tip(name, joint1_deg, gap_mm):
    """A 2 mm ball straight below the seed arm's fingertip (home pose, joint 1 at
    ``joint1_deg``), ``gap_mm`` below it: the fingertip, swinging with joint 1 at 75 mm height
    on a 510 mm circle, passes it at exactly that clearance there."""
    from armpath.geometry.primitives import Sphere

    t = np.radians(joint1_deg)
    return Sphere(name, [-510 * np.sin(t), 510 * np.cos(t), 75.0 - 2.0 - gap_mm], 2.0)


def test_a_plan_whose_check_runs_out_of_budget_is_checked_again_in_stretches(monkeypatch):
    """A trace keeping its tip ten-thousandths of a millimetre off a surface along hundreds of
    commands (0.01 mm tolerance on the seed crack) was refused after 12 minutes of planning:
    its final check ran out of its budget. The check now goes on half by half, each with the
    budget again. Here two balls lie 0.003 and 0.004 mm below the fingertip's path at joint 1
    = -5.2 and 4.8 deg (commands 3 and 8 of ten 2-deg turns from -10 deg): with a budget of
    150 evaluations the whole motion is not proven, its halves are, and the result names the
    nearer ball, 0.003 mm (the closed form) at command 3, with a proven lower bound between 0
    and that. With 100 a single command needs more than the budget: refused, not violated."""
    import armpath.planning.motion_check as mc

    world = CollisionWorld(
        (_ball_under_the_tip("a", -5.2, 0.003), _ball_under_the_tip("b", 4.8, 0.004))
    )
    cmds = np.zeros((10, 6), dtype=np.int64)
    cmds[:, 0] = 20
    seq = CommandSequence(deg_to_ticks([-10, -90, 0, 0, -90, 0]), cmds)
    monkeypatch.setattr(mc, "WHOLE_PLAN_EVALUATIONS", 150)
    whole = motion_clearance(ARM, world, seq, tolerance=0.0005, max_evaluations=150)
    assert not whole.certified_ok and not whole.violated and whole.evaluations >= 150
    found = mc.plan_clearance(ARM, world, seq, tolerance=0.0005)
    assert found.certified_ok and found.evaluations > 150
    assert (found.worst_obstacle, found.worst_command, found.limiting_command) == ("a", 3, 3)
    assert found.min_tip_clearance == pytest.approx(0.003, abs=2e-5)
    assert 0.0 <= found.min_clearance_lower_bound <= 0.003
    monkeypatch.setattr(mc, "WHOLE_PLAN_EVALUATIONS", 100)
    short = mc.plan_clearance(ARM, world, seq, tolerance=0.0005)
    assert not short.certified_ok and not short.violated and short.limiting_command == 3
