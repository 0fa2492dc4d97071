"""Fewer commands for a certified motion by moving its states (armpath.planning.tighten).

Judged without the package's clearance code: the commands are replayed in integer ticks, the
arm's points along the continuous motion come from ``tests/independent.py``'s forward
kinematics and the post's and ball's distances are written here from scratch.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

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
    # nothing near: an evaluation measures its instants and no joint's step from them
    per_evaluation = (seq.n_commands - 1) * tighten.SAMPLES_PER_COMMAND
    monkeypatch.setattr(tighten, "MAX_CONFIGURATIONS", per_evaluation + 1)
    assert tightened(ARM, world, seq) is seq


def test_the_gradient_equals_a_forward_difference_at_every_instant(tmp_path):
    """The placement steps a joint only from the instants its step may bring within the
    buffer; its gradient must equal the forward difference taken from every instant, here
    over the post and the ball, on states scattered about the straight motion through the
    ball, so that some instants are in or near it and most are not."""
    import armpath.planning.tighten as tighten

    path = tmp_path / "post.yaml"
    path.write_text(POST_SCENE)
    world = load_scene(path).world
    seq = _through([[100, -90, 0, 0, -90, 0], [170, -90, 0, 0, -90, 0]])  # through the ball
    k = 30
    states = seq.states().astype(np.float64)
    work = tighten._Work()
    problem = tighten._Placement(ARM, world, states[0], states[-1], k, work)
    rng = np.random.default_rng(7)
    z = tighten._resampled(states, k)[1:-1].ravel() + rng.normal(0.0, 10.0, (k - 1) * 6)
    spent = work.left
    value, grad = problem.value_and_gradient(z, 1.0)
    spent -= work.left
    x = problem.states(z)
    t = problem.t[None, :, None]
    inst = (x[:-1, None, :] * (1.0 - t) + x[1:, None, :] * t).reshape(-1, 6)
    # the penalty written out from the world's pair clearances, stepped at every instant
    required = world.required(ARM)

    def penalty(q_ticks):
        values, _ = world.pair_clearances(ARM, ARM.lattice.to_joint(q_ticks))
        return (np.maximum(tighten.BUFFER - (values - required), 0.0) ** 2).sum(axis=-1)

    base = penalty(inst)
    assert 0 < np.count_nonzero(base) < base.size // 2  # some instants near, most not
    h = tighten._GRADIENT_TICKS
    per_inst = np.column_stack(
        [(penalty(inst + h * np.eye(6)[j]) - base) / h for j in range(6)]
    ).reshape(k, t.size, 6)
    full = np.zeros_like(x)
    full[:-1] += (per_inst * (1.0 - t)).sum(axis=1)
    full[1:] += (per_inst * t).sum(axis=1)
    change = np.diff(x, axis=0)
    beyond = np.maximum(np.abs(change) - problem.limit, 0.0)
    full[1:] += 2.0 * beyond * np.sign(change)
    full[:-1] -= 2.0 * beyond * np.sign(change)
    assert value == pytest.approx(base.sum() + (beyond**2).sum(), rel=1e-12)
    np.testing.assert_array_equal(grad, full[1:-1].ravel())
    assert np.any(grad != 0.0)
    # and it measured fewer configurations than stepping every instant would
    assert inst.shape[0] < spent < 7 * inst.shape[0]
