"""Continuous clearance of command motions against dense brute-force replay."""

import numpy as np
import pytest

import independent
from armpath.commands import CommandSequence, deg_to_ticks
from armpath.geometry import CollisionWorld
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
