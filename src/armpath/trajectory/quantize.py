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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.commands import (
    TICK_RAD,
    CommandSequence,
    commands_needed,
    split_move,
)
from armpath.errors import InvalidInputError
from armpath.kinematics import tool_position
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.trajectory.minsnap import PiecewisePolynomial

FloatArray = NDArray[np.float64]


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


def joint_ticks(arm: SerialArm) -> FloatArray:
    """Each joint's tick: 0.1 deg in rad if revolute, 0.1 model unit if prismatic."""
    return np.array(
        [0.1 if j.kind is JointKind.PRISMATIC else TICK_RAD for j in arm.joints], dtype=np.float64
    )


def quantize(
    traj: PiecewisePolynomial, period_s: float, tick: ArrayLike | None = None
) -> QuantizedTrajectory:
    """Commands that follow ``traj`` at the controller period. ``tick`` (per joint, in the
    trajectory's unit) defaults to 0.1 deg in rad for every joint; see ``joint_ticks``."""
    if not (np.isfinite(period_s) and period_s > 0):
        raise InvalidInputError(f"the controller period must be > 0 s, got {period_s}")
    J = traj.coefficients.shape[2]
    ticks = np.broadcast_to(
        np.asarray(TICK_RAD if tick is None else tick, dtype=np.float64), (J,)
    ).copy()
    if not np.all(ticks > 0):
        raise InvalidInputError("ticks must be > 0")
    n = int(np.ceil(traj.duration / period_s - 1e-9))
    t = traj.times[0] + period_s * np.arange(n + 1)
    t[-1] = min(t[-1], traj.times[-1])
    x = traj.evaluate(t) / ticks  # ticks, float
    states = np.rint(x).astype(np.int64)
    commands = []
    index = [0]
    split = 0
    for k in range(1, n + 1):
        delta = states[k] - states[k - 1]
        m = max(commands_needed(delta), 1)
        split += m > 1
        commands.append(split_move(delta, m))
        index.append(index[-1] + m)
    cmds = np.vstack(commands) if commands else np.zeros((0, x.shape[1]), dtype=np.int64)
    return QuantizedTrajectory(
        CommandSequence(states[0], cmds),
        float(period_s),
        ticks,
        t,
        np.array(index, dtype=np.int64),
        float(np.max(np.abs(states - x))),
        int(split),
    )


def lattice_motion(
    quantized: QuantizedTrajectory, substeps: int = 8
) -> tuple[FloatArray, FloatArray]:
    """The commanded motion: times (s) and joint values (trajectory unit), each period moving
    linearly from one sampled lattice state to the next, ``substeps`` points per period."""
    if substeps < 1:
        raise InvalidInputError("substeps must be >= 1")
    states = quantized.sequence.states()[quantized.state_index].astype(np.float64) * quantized.tick
    s = np.arange(substeps) / substeps
    t0 = quantized.sample_times[:-1, None]
    dt = np.diff(quantized.sample_times)[:, None]
    times = np.concatenate([(t0 + s[None, :] * dt).ravel(), quantized.sample_times[-1:]])
    steps = states[:-1, None, :] + s[None, :, None] * np.diff(states, axis=0)[:, None, :]
    return times, np.vstack([steps.reshape(-1, states.shape[1]), states[-1:]])


def tip_deviation(
    arm: SerialArm, traj: PiecewisePolynomial, quantized: QuantizedTrajectory, substeps: int = 8
) -> float:
    """Largest distance (model unit) between the tool point on the smooth trajectory and on the
    commanded lattice motion (``lattice_motion``) at the same times."""
    times, lattice = lattice_motion(quantized, substeps)
    smooth = traj.evaluate(times)
    return float(
        np.max(np.linalg.norm(tool_position(arm, smooth) - tool_position(arm, lattice), axis=1))
    )
