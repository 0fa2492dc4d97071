"""A command sequence as a timed trajectory a controller or a ROS tool can take.

Each command moves every joint at once, linearly, over one command period (the arm's
``command_period_s``, 0.1 s unless its model or scene says, or the one given): the state after
command ``k`` is reached at ``t = k * period``. Three forms:

* :func:`trajectory_csv`: one row per state, ``time_s`` then each joint's value (deg, or mm
  for a prismatic joint);
* :func:`joint_trajectory`: the ROS ``trajectory_msgs/JointTrajectory`` message layout as JSON
  (``joint_names``; ``points`` with ``positions`` in rad, or m for a prismatic joint as ROS
  expects, ``velocities``, ``time_from_start`` as ``{sec, nanosec}``);
* :func:`step_counts`: per command, each joint's motor steps (its ticks times its steps per
  tick), for stepper controllers.

Times are whole nanoseconds (``k * period_ns``), so they increase strictly and exactly. A
point's velocity is the central difference of its neighbours (one-sided at the ends, zero at
the start and the end where the arm is at rest): what a spline-interpolating controller
expects. The motion armpath certified is the linear one between points; a controller that
splines through them deviates from it by its own interpolation.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError
from armpath.export import csv_text
from armpath.model.lattice import check_command_period, check_steps_per_tick
from armpath.model.serial_arm import JointKind, SerialArm

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

#: The export formats of ``armpath export``.
FORMATS = ("csv", "joint-trajectory", "steps")


def _period_ns(arm: SerialArm, period_s: float | None) -> int:
    """The command period in whole ns: ``period_s``, else the arm's (its controller's)."""
    chosen = arm.command_period_s if period_s is None else period_s
    return round(check_command_period(chosen) * 1e9)


def state_times_ns(
    arm: SerialArm, sequence: CommandSequence, period_s: float | None = None
) -> IntArray:
    """Time of each state ``(n_commands + 1,)``, integer nanoseconds from the start
    (``period_s`` per command; default: the arm's command period)."""
    return np.arange(sequence.n_commands + 1, dtype=np.int64) * _period_ns(arm, period_s)


def trajectory_csv(arm: SerialArm, sequence: CommandSequence, period_s: float | None = None) -> str:
    """CSV: ``time_s`` and each joint's value after each command (deg, mm if prismatic)."""
    t = state_times_ns(arm, sequence, period_s)
    values = sequence.grid.display(sequence.states())
    units = arm.lattice.units
    header = ["time_s"] + [f"{j.name}_{u}" for j, u in zip(arm.joints, units, strict=True)]
    rows = [
        [f"{int(tk) / 1e9:.9f}", *(f"{v:.6f}" for v in row)]
        for tk, row in zip(t, values, strict=True)
    ]
    return csv_text(header, rows)


def _ros_positions(arm: SerialArm, sequence: CommandSequence) -> FloatArray:
    """Joint positions as ROS expects them: rad, or m for a prismatic joint."""
    q = sequence.states_joint()
    to_m = arm.mm_per_unit / 1000.0
    prismatic = np.array([j.kind == JointKind.PRISMATIC for j in arm.joints])
    return np.asarray(np.where(prismatic, q * to_m, q))


def point_velocities(positions: ArrayLike, times_s: ArrayLike) -> FloatArray:
    """Velocities at the points: central differences inside, zero at the first and last
    point (the arm starts and ends at rest)."""
    p = np.asarray(positions, dtype=np.float64)
    t = np.asarray(times_s, dtype=np.float64)
    v = np.zeros_like(p)
    if p.shape[0] > 2:
        v[1:-1] = (p[2:] - p[:-2]) / (t[2:] - t[:-2])[:, None]
    return v


def joint_trajectory(
    arm: SerialArm, sequence: CommandSequence, period_s: float | None = None
) -> dict[str, Any]:
    """The ``trajectory_msgs/JointTrajectory`` message of the motion (a JSON-ready dict)."""
    t_ns = state_times_ns(arm, sequence, period_s)
    positions = _ros_positions(arm, sequence)
    velocities = point_velocities(positions, t_ns / 1e9)
    points = [
        {
            "positions": [float(x) for x in pos],
            "velocities": [float(x) for x in vel],
            "accelerations": [],
            "effort": [],
            "time_from_start": {
                "sec": int(tk // 1_000_000_000),
                "nanosec": int(tk % 1_000_000_000),
            },
        }
        for pos, vel, tk in zip(positions, velocities, t_ns, strict=True)
    ]
    return {
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
        "joint_names": [j.name for j in arm.joints],
        "points": points,
    }


def steps_per_tick_of(arm: SerialArm, steps_per_tick: ArrayLike | None) -> IntArray:
    """Each joint's motor steps per tick: one value for every joint, one per joint, or None
    (the arm's controller's: 1 unless its model or the scene's ``[arm]`` says)."""
    if steps_per_tick is None:
        steps = arm.lattice.steps_per_tick
        assert steps is not None
        return np.asarray(steps, dtype=np.int64)
    return check_steps_per_tick(steps_per_tick, arm.n_joints)


def step_counts(
    arm: SerialArm, sequence: CommandSequence, steps_per_tick: ArrayLike | None = None
) -> IntArray:
    """Motor steps of each joint in each command, ``(n_commands, n_joints)``."""
    return np.asarray(sequence.commands * steps_per_tick_of(arm, steps_per_tick)[None, :])


def steps_csv(
    arm: SerialArm,
    sequence: CommandSequence,
    steps_per_tick: ArrayLike | None = None,
    period_s: float | None = None,
) -> str:
    """CSV: per command, its start time (s) and each joint's motor steps."""
    steps = step_counts(arm, sequence, steps_per_tick)
    t = state_times_ns(arm, sequence, period_s)[:-1]
    header = ["command", "start_s"] + [f"{j.name}_steps" for j in arm.joints]
    rows = [
        [k + 1, f"{int(tk) / 1e9:.9f}", *(int(v) for v in row)]
        for k, (tk, row) in enumerate(zip(t, steps, strict=True))
    ]
    return csv_text(header, rows)


def export_text(
    arm: SerialArm,
    sequence: CommandSequence,
    fmt: str,
    period_s: float | None = None,
    steps_per_tick: ArrayLike | None = None,
) -> str:
    """The motion in ``fmt`` (one of :data:`FORMATS`) as text; ``steps_per_tick`` goes with
    ``"steps"`` only (given with another format, it would be ignored: refused)."""
    from armpath.export import json_text

    if steps_per_tick is not None and fmt != "steps":
        raise InvalidInputError(
            f"steps per tick (--steps-per-tick) go with the steps format, not {fmt!r}"
        )
    if fmt == "csv":
        return trajectory_csv(arm, sequence, period_s)
    if fmt == "joint-trajectory":
        return json_text(joint_trajectory(arm, sequence, period_s))
    if fmt == "steps":
        return steps_csv(arm, sequence, steps_per_tick, period_s)
    raise InvalidInputError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")


__all__ = [
    "FORMATS",
    "export_text",
    "joint_trajectory",
    "point_velocities",
    "state_times_ns",
    "step_counts",
    "steps_csv",
    "trajectory_csv",
]
