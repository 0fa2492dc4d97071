"""Fewer commands for a certified motion by moving its states (armpath.planning.tighten).

Judged without the package's clearance code: the commands are replayed in integer ticks, the
arm's points along the continuous motion come from ``tests/independent.py``'s forward
kinematics and the post's and ball's distances are written here from scratch.
"""

from __future__ import annotations

import itertools

import numpy as np

import independent
from armpath.commands import CommandSequence, deg_to_ticks
from armpath.geometry import CollisionWorld
from armpath.model import seed_arm
from armpath.planning.tighten import MAX_COMMANDS, tightened
from armpath.scenes import load_scene
from test_plan import POST_SCENE, box_distance

ARM = seed_arm()


def _through(states_deg) -> CommandSequence:
    """Straight motions through the given states, one after another."""
    ticks = deg_to_ticks(np.asarray(states_deg, dtype=float))
    parts = [CommandSequence.straight(a, b) for a, b in itertools.pairwise(ticks)]
    seq = parts[0]
    for part in parts[1:]:
        seq = seq.then(part)
    return seq


def test_a_detour_in_free_space_comes_down_to_the_direct_count():
    """Two straight motions that wander off the line and back (15 commands) between two
    states 8 commands apart: with nothing in the way the states are placed nearer the line,
    and the second count tried (14, then the direct count) is certified."""
    world = CollisionWorld(())
    start = [10, -60, 20, 0, -80, 0]
    goal = [26, -50, 10, 5, -70, 0]
    seq = _through([start, [18, -55, 30, 0, -80, 0], goal])
    assert seq.n_commands == 15
    assert ARM.lattice.commands_needed(seq.final_ticks - seq.start_ticks) == 8
    out = tightened(ARM, world, seq)
    assert out.n_commands == 8
    np.testing.assert_array_equal(out.start_ticks, seq.start_ticks)
    np.testing.assert_array_equal(out.final_ticks, seq.final_ticks)
    states = independent.replay(start, out.commands)
    np.testing.assert_allclose(states[-1], goal)
    assert np.abs(out.commands).max() <= 20


def test_a_lift_over_the_ball_is_placed_round_it_in_fewer_commands(tmp_path):
    """The ball stands in the way of joint 1's sweep from 100 to 170 deg (the direct motion,
    35 commands, goes through it). Raising the shoulder 10 deg, sweeping and lowering it again
    is clear in 45 commands; with the lift spread over the sweep it needs 35, the direct
    count, so no plan has fewer. The independent replay keeps 1 mm from the post, the ball and
    the table all along the continuous motion."""
    path = tmp_path / "post.yaml"
    path.write_text(POST_SCENE)
    world = load_scene(path).world
    a = [100, -90, 0, 0, -90, 0]
    up = [100, -80, 0, 0, -90, 0]
    over = [170, -80, 0, 0, -90, 0]
    b = [170, -90, 0, 0, -90, 0]
    direct = independent.motion_points(a, _through([a, b]).commands, 4)
    samples, _ = independent.link_samples(direct, 1.0)
    ball = np.linalg.norm(samples.reshape(-1, 3) - [-150, -420, 120], axis=-1) - 50
    assert ball.min() < 0  # the direct motion goes through the ball
    seq = _through([a, up, over, b])
    assert seq.n_commands == 45
    out = tightened(ARM, world, seq)
    assert out.n_commands == 35
    np.testing.assert_array_equal(out.final_ticks, seq.final_ticks)
    assert np.abs(out.commands).max() <= 20
    states = independent.replay(a, out.commands)
    np.testing.assert_allclose(states[-1], b)
    pts = independent.motion_points(a, out.commands, 16)
    samples, _ = independent.link_samples(pts, 1.0)
    flat = samples.reshape(-1, 3)
    post = box_distance(flat, np.array([-330, 330, 100]), [30, 30, 100], 45)
    ball = np.linalg.norm(flat - [-150, -420, 120], axis=-1) - 50
    assert min(post.min(), ball.min(), flat[:, 2].min()) >= 1.0


def test_what_is_not_tried_is_given_back_unchanged():
    """A direct motion (nothing to gain) and one longer than MAX_COMMANDS come back as given."""
    world = CollisionWorld(())
    straight = _through([[0, -60, 20, 0, -80, 0], [30, -60, 20, 0, -80, 0]])
    assert tightened(ARM, world, straight) is straight
    n_legs = MAX_COMMANDS // 20 + 2
    wander = [[0, -60, 20, 0, -80, 0]]
    for i in range(n_legs):
        wander.append([0, -60, 20, 40 if i % 2 == 0 else 0, -80, 0])
    long = _through(wander)
    assert long.n_commands > MAX_COMMANDS
    assert tightened(ARM, world, long) is long


def test_the_work_budget_ends_the_placement(monkeypatch):
    """With room for one evaluation of the objective only, the free-space detour above comes
    back as given: the budget, not the optimiser, ends the call."""
    import armpath.planning.tighten as tighten

    world = CollisionWorld(())
    seq = _through([[10, -60, 20, 0, -80, 0], [18, -55, 30, 0, -80, 0], [26, -50, 10, 5, -70, 0]])
    per_evaluation = (seq.n_commands - 1) * tighten.SAMPLES_PER_COMMAND * (ARM.n_joints + 1)
    monkeypatch.setattr(tighten, "MAX_CONFIGURATIONS", per_evaluation + 1)
    assert tightened(ARM, world, seq) is seq
