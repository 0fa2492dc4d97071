"""The command lattice: validation, exact replay, even splitting, continuous sampling."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armpath.commands import (
    MAX_INCREMENT_TICKS,
    CommandSequence,
    commands_needed,
    deg_to_ticks,
    split_move,
    ticks_to_deg,
    ticks_to_rad,
)
from armpath.errors import CommandError, InvalidInputError

deltas = st.lists(st.integers(-5000, 5000), min_size=6, max_size=6)


@settings(max_examples=300, deadline=None)
@given(deltas, st.integers(0, 5))
def test_split_move_is_legal_exact_and_even(delta, extra):
    d = np.array(delta)
    n = commands_needed(d) + extra
    cmds = split_move(d, n)
    assert cmds.shape == (n, 6)
    assert np.all(np.abs(cmds) <= MAX_INCREMENT_TICKS)
    np.testing.assert_array_equal(cmds.sum(axis=0), d)
    # every joint advances monotonically and by at most one tick more or less than its share
    if n:
        assert np.all(cmds * np.sign(d) >= 0)
        share = np.abs(d) / n
        assert np.all(np.abs(np.abs(cmds) - share) < 1.0 + 1e-12)


def test_commands_needed_is_the_ceiling():
    assert commands_needed([0, 0, 0, 0, 0, 0]) == 0
    assert commands_needed([20, -20, 0, 0, 0, 0]) == 1
    assert commands_needed([21, 0, 0, 0, 0, 0]) == 2
    assert commands_needed([0, 0, -1260, 1240, 0, 3]) == 63


def test_too_few_commands_are_refused():
    with pytest.raises(CommandError, match="at least 3"):
        split_move([41, 0, 0, 0, 0, 0], 2)


def test_replay_is_exact_integer_arithmetic():
    rng = np.random.default_rng(0)
    cmds = rng.integers(-20, 21, (100_000, 6))
    seq = CommandSequence(np.array([0, -900, 0, 0, -900, 0]), cmds)
    states = seq.states()
    assert states.dtype == np.int64
    np.testing.assert_array_equal(states[-1], seq.start_ticks + cmds.sum(axis=0))
    np.testing.assert_array_equal(seq.final_ticks, states[-1])
    # degrees are exact decimal multiples of 0.1
    degs = ticks_to_deg(states[-1])
    np.testing.assert_array_equal(np.rint(degs * 10).astype(int), states[-1])


@pytest.mark.parametrize("bad", [21, -21, 100])
def test_out_of_range_increments_are_refused(bad):
    with pytest.raises(CommandError, match=r"\[-20, 20\]"):
        CommandSequence(np.zeros(6, int), [[0, 0, bad, 0, 0, 0]])


def test_non_integer_ticks_are_refused():
    with pytest.raises(CommandError, match="integer ticks"):
        CommandSequence(np.zeros(6, int), [[0, 0.5, 0, 0, 0, 0]])


def test_deg_to_ticks_requires_the_lattice():
    np.testing.assert_array_equal(
        deg_to_ticks([0, -90, 0.1, 133.5, -0.3, 720]), [0, -900, 1, 1335, -3, 7200]
    )
    with pytest.raises(InvalidInputError, match=r"multiples of 0\.1"):
        deg_to_ticks([0.05, 0, 0, 0, 0, 0])
    with pytest.raises(InvalidInputError, match="finite"):
        deg_to_ticks([np.nan, 0, 0, 0, 0, 0])


def test_sample_motion_is_synchronous_linear_interpolation():
    seq = CommandSequence(
        np.array([0, 0, 0, 0, 0, 0]), [[20, -10, 0, 4, 0, 0], [-3, 0, 20, 0, 0, 1]]
    )
    path = seq.sample_motion(4)
    assert path.shape == (9, 6)
    np.testing.assert_allclose(path[0], 0)
    np.testing.assert_allclose(path[4], ticks_to_rad([20, -10, 0, 4, 0, 0]))
    np.testing.assert_allclose(path[2], ticks_to_rad([10, -5, 0, 2, 0, 0]))
    np.testing.assert_allclose(path[-1], ticks_to_rad(seq.final_ticks))
    np.testing.assert_allclose(path[6], ticks_to_rad([20 - 1.5, -10, 10, 4, 0, 0.5]))


def test_straight_uses_fewest_commands():
    seq = CommandSequence.straight([0, -900, 0, 0, -900, 0], [203, 338, 1248, 1251, -1078, 0])
    assert seq.n_commands == 63
    np.testing.assert_array_equal(seq.final_ticks, [203, 338, 1248, 1251, -1078, 0])
