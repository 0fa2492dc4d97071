"""From a smooth joint trajectory to controller commands on the 0.1 deg / +-2 deg lattice.

The trajectory is sampled at the controller period. The lattice state after each period is the
sample rounded to whole ticks, and the command is its difference from the previous state. This is
error feedback: each command carries the rounding left by the ones before, so the error never
accumulates and stays within half a tick at every sample. A period that would need more than 2 deg
on some joint is split into the fewest legal commands (the trajectory is then too fast for the
controller there; such periods are counted).

A revolute joint's tick is 0.1 deg. The seed controller has no prismatic joints; for arms that do
(seed 003's welder), ``joint_ticks`` gives them 0.1 model unit (0.1 mm) per tick, the same
lattice in length.

Sizes are bounded (:mod:`armpath.budget`): at most ``MAX_PERIODS`` controller periods and
``MAX_COMMANDS`` commands (every period is at least one command), refused before the samples or
the commands are built; the commanded motion and the tip deviation are evaluated a bounded
number of periods at a time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import (
    MAX_COMMANDS,
    MAX_PERIODS,
    MAX_STATE_TICKS,
    MAX_TRAJECTORY_VALUES,
    check_size,
    check_time,
)
from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError
from armpath.kinematics import tool_position
from armpath.model.lattice import DEFAULT_MAX_TICKS, DEFAULT_REVOLUTE_TICK_RAD, Lattice
from armpath.model.serial_arm import SerialArm
from armpath.trajectory.minsnap import PiecewisePolynomial

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
#: Periods of the commanded motion evaluated at once by ``tip_deviation``.
MOTION_CHUNK = 16_384


@dataclass(frozen=True)
class QuantizedTrajectory:
    """Commands for a trajectory sampled every ``period_s`` seconds.

    ``sample_times`` (s) are the sampled times. ``state_index[k]`` is the row of
    ``sequence.states()`` reached at sample ``k``; it equals ``k`` unless periods were split.
    ``max_tick_error`` is the largest ``|state - q / tick|`` over the samples, in ticks;
    ``tick`` is each joint's tick in the trajectory's unit (rad, or model unit if prismatic).
    """

    sequence: CommandSequence
    period_s: float
    tick: FloatArray
    sample_times: FloatArray
    state_index: NDArray[np.int64]
    max_tick_error: float
    split_periods: int

    @property
    def n_periods(self) -> int:
        return int(self.sample_times.shape[0] - 1)

    @property
    def commands_take_s(self) -> float:
        """How long the commands take at one a period (s): the trajectory's duration only when
        no period is split and the period divides it."""
        return float(self.sequence.n_commands * self.period_s)

    @cached_property
    def sampled_ticks(self) -> IntArray:
        """The lattice state (ticks) at each sample time, ``(n_periods + 1, joints)``."""
        return np.asarray(self.sequence.states()[self.state_index], dtype=np.int64)


def joint_ticks(arm: SerialArm) -> FloatArray:
    """Each joint's tick (rad if revolute, model unit if prismatic): the arm's lattice."""
    return np.asarray(arm.lattice.tick, dtype=np.float64)


def quantize(
    traj: PiecewisePolynomial,
    period_s: float,
    tick: ArrayLike | Lattice | None = None,
    *,
    option: str = "the period",
) -> QuantizedTrajectory:
    """Commands that follow ``traj`` at the controller period on a command lattice: an arm's
    ``arm.lattice``, or ``tick`` per joint (in the trajectory's unit) with the seed
    controller's 20 ticks a command; ``None``: 0.1 deg and 20 ticks on every joint.

    Refused (naming ``option``, what to change) before the samples are built: more than
    ``MAX_PERIODS`` periods, more than ``MAX_COMMANDS`` commands at one a period or for the
    joints' net motion at 20 ticks a command, more than ``MAX_TRAJECTORY_VALUES`` periods
    times joints; and before the commands are built: more than
    ``MAX_COMMANDS`` commands in all, or joint values beyond ``MAX_STATE_TICKS`` ticks.
    """
    if not (np.isfinite(period_s) and period_s > 0):
        raise InvalidInputError(f"the controller period must be > 0 s, got {period_s}")
    J = traj.coefficients.shape[2]
    if isinstance(tick, Lattice):
        grid = tick
        if grid.n_joints != J:
            raise InvalidInputError(f"the lattice has {grid.n_joints} joints, the trajectory {J}")
    else:
        ticks_in = np.broadcast_to(
            np.asarray(DEFAULT_REVOLUTE_TICK_RAD if tick is None else tick, dtype=np.float64), (J,)
        ).copy()
        if not np.all(np.isfinite(ticks_in) & (ticks_in > 0)):
            raise InvalidInputError("ticks must be finite and > 0")
        grid = Lattice(ticks_in, np.full(J, DEFAULT_MAX_TICKS), np.zeros(J, bool))
    ticks = np.array(grid.tick)
    most = grid.max_ticks
    duration = traj.duration
    ratio = duration / period_s  # a float: may be beyond any integer (or inf)
    periods = max(1.0, float(np.ceil(ratio - 1e-9))) if math.isfinite(ratio) else math.inf
    how = f"a {duration:.6g} s trajectory in periods of {period_s:g} s"
    check_size(periods, MAX_PERIODS, f"controller periods ({how})", option)
    check_size(periods, MAX_COMMANDS, f"commands (at least one a period: {how})", option)
    check_size(
        periods * J,
        MAX_TRAJECTORY_VALUES,
        f"joint values of the trajectory ({how}, {J} joints)",
        option,
    )
    ends = traj.evaluate(traj.times[[0, -1]]) / ticks
    _check_state_range(ends)
    spans = np.abs(ends[1] - ends[0])
    j_far = int(np.argmax(spans / most))
    net = float(spans[j_far])
    check_size(
        float(np.ceil((net - 1.0) / most[j_far])),
        MAX_COMMANDS,
        f"commands (a joint moves {_amount(net)} ticks from start to end, at most "
        f"{most[j_far]} a command)",
        option,
    )
    n = int(periods)
    check_time("sampling the trajectory at the controller period")
    t = traj.times[0] + period_s * np.arange(n + 1)
    t[-1] = min(t[-1], traj.times[-1])
    x = (
        np.vstack(  # ticks, float; evaluated a bounded number of samples at a time
            [traj.evaluate(t[k : k + MOTION_CHUNK * 8]) for k in range(0, t.size, MOTION_CHUNK * 8)]
        )
        / ticks
    )
    _check_state_range(x)
    states = np.rint(x).astype(np.int64)
    delta = np.diff(states, axis=0)
    # fewest legal commands for each period (at least one: one command per period)
    m = np.maximum(grid.commands_needed_many(delta) if delta.size else np.zeros(0, np.int64), 1)
    total = int(m.sum())
    check_size(
        total,
        MAX_COMMANDS,
        f"commands ({total:,} for {n:,} periods, {int(np.count_nonzero(m > 1)):,} of them split)",
        option,
    )
    check_time("converting the trajectory to commands")
    return QuantizedTrajectory(
        CommandSequence(states[0], _split_periods(delta, m), grid),
        float(period_s),
        ticks,
        t,
        np.concatenate([[0], np.cumsum(m)]).astype(np.int64),
        float(np.max(np.abs(states - x))),
        int(np.count_nonzero(m > 1)),
    )


def _amount(x: float) -> str:
    """A count for a message: every digit up to 1e15 (so 20,000,021 is not shown as 2e+07)."""
    return f"{x:,.0f}" if abs(x) < 1e15 else f"{x:.3g}"


def _check_state_range(x: FloatArray) -> None:
    """Joint values (ticks) must be finite and small enough to round to exact integers."""
    if not np.all(np.isfinite(x)) or np.max(np.abs(x), initial=0.0) > MAX_STATE_TICKS:
        raise InvalidInputError(
            f"joint values must be finite and within +-{MAX_STATE_TICKS:.3g} ticks to be "
            f"quantized, got up to {np.max(np.abs(x), initial=0.0):.3g} ticks"
        )


def _split_periods(delta: IntArray, m: IntArray) -> IntArray:
    """Each period's move ``delta[k]`` split into ``m[k]`` legal commands that track the straight
    line (as ``commands.split_move``: command ``i`` of ``m`` moves ``floor((i+1) d / m) -
    floor(i d / m)``), all periods at once."""
    total = int(m.sum())
    if total == delta.shape[0]:
        return delta  # no period needs more than one command
    period = np.repeat(np.arange(delta.shape[0]), m)
    i = (np.arange(total) - np.repeat(np.cumsum(m) - m, m))[:, None]
    d = delta[period]
    mm = m[period][:, None]
    return np.asarray((i + 1) * d // mm - i * d // mm, dtype=np.int64).reshape(total, -1)


def lattice_motion(
    quantized: QuantizedTrajectory, substeps: int = 8, start: int = 0, stop: int | None = None
) -> tuple[FloatArray, FloatArray]:
    """The commanded motion: times (s) and joint values (trajectory unit), each period moving
    linearly from one sampled lattice state to the next, ``substeps`` points per period.

    ``start``, ``stop``: only periods ``start .. stop - 1`` (default: all), the final state
    included when ``stop`` is the last period; consecutive ranges join up to the whole motion,
    so long motions can be evaluated a part at a time."""
    if not (isinstance(substeps, int | np.integer) and 1 <= substeps <= 1024):
        raise InvalidInputError(f"substeps must be a whole number in 1..1024, got {substeps}")
    n = quantized.n_periods
    stop = n if stop is None else stop
    if not 0 <= start <= stop <= n:
        raise InvalidInputError(f"periods {start}..{stop} are not within 0..{n}")
    states = quantized.sampled_ticks[start : stop + 1].astype(np.float64) * quantized.tick
    sample_times = quantized.sample_times[start : stop + 1]
    s = np.arange(substeps) / substeps
    t0 = sample_times[:-1, None]
    dt = np.diff(sample_times)[:, None]
    steps = states[:-1, None, :] + s[None, :, None] * np.diff(states, axis=0)[:, None, :]
    times = (t0 + s[None, :] * dt).ravel()
    joints = steps.reshape(-1, states.shape[1])
    if stop == n:
        return np.concatenate([times, sample_times[-1:]]), np.vstack([joints, states[-1:]])
    return times, joints


def tip_deviation(
    arm: SerialArm, traj: PiecewisePolynomial, quantized: QuantizedTrajectory, substeps: int = 8
) -> float:
    """Largest distance (model unit) between the tool point on the smooth trajectory and on the
    commanded lattice motion (``lattice_motion``) at the same times, ``MOTION_CHUNK`` periods at
    a time."""
    worst = 0.0
    n = quantized.n_periods
    for start in range(0, n, MOTION_CHUNK):
        check_time("measuring the tip deviation of the commands")
        times, lattice = lattice_motion(quantized, substeps, start, min(start + MOTION_CHUNK, n))
        smooth = traj.evaluate(times)
        gap = np.linalg.norm(tool_position(arm, smooth) - tool_position(arm, lattice), axis=1)
        worst = max(worst, float(np.max(gap)))
    return worst
