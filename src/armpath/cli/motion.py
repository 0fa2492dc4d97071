"""``armpath trajectory`` and ``armpath rcm``: smooth joint trajectories, their retiming and
commands, and seed 003's fixed-point rotation.

Every input that sets the size of the work is checked before any work, each refusal one
``error:`` line naming the option (:mod:`armpath.budget`): the waypoints file is read line by
line (:mod:`armpath.cli.tables`: at most ``MAX_WAYPOINTS`` rows of ``MAX_JOINTS`` joints), the
controller periods (duration / period) are at most ``MAX_PERIODS``, the periods times joints
at most ``MAX_TRAJECTORY_VALUES`` and the commands (one a period at least, and a joint's net
motion at its lattice's most ticks a command) at most ``MAX_COMMANDS``; with ``--model`` the
waypoints have the arm's joints and lie within its limits; the motion limits must lie in
``(0, MAX_VELOCITY_DEG_S]`` and so on. The per-period CSV files are written ``CSV_CHUNK`` rows
at a time.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
import typer
from numpy.typing import NDArray
from rich import box
from rich.markup import escape
from rich.table import Table

from armpath.budget import (
    MAX_COMMANDS,
    MAX_JOINTS,
    MAX_PERIOD_S,
    MAX_PERIODS,
    MAX_WAYPOINTS,
    check_size,
    check_time,
)
from armpath.cli.common import (
    BUILTIN_NAMES,
    ModelOption,
    PeriodOption,
    TimeLimitOption,
    TipLinkOption,
    _cli_errors,
    _fmt,
    _joint_units,
    _numbers,
    _to_display,
    app,
    err_console,
    out_console,
    print_written,
    progress,
)
from armpath.cli.tables import read_number_table
from armpath.errors import ArmpathWarning, InvalidInputError

if TYPE_CHECKING:
    from armpath.export import OutputFolder
    from armpath.model.lattice import Lattice
    from armpath.model.serial_arm import SerialArm

#: Largest joint speed limit accepted (deg/s).
MAX_VELOCITY_DEG_S = 1e6
#: Largest joint acceleration limit accepted (deg/s^2).
MAX_ACCELERATION_DEG_S2 = 1e9
#: Largest joint jerk limit accepted (deg/s^3).
MAX_JERK_DEG_S3 = 1e12
#: How far (ticks) the QP's position limits lie beyond the lattice values at the joint limits:
#: less than half a tick, so the commands, each state within half a tick of the trajectory,
#: stay within the limits.
ROUNDING_SLACK_TICKS = 0.45
#: Rows of a per-period CSV file formatted at once.
CSV_CHUNK = 50_000
#: Largest number of points of a line in a plot (longer series keep the largest value of each
#: stretch) and of states handed to an animation.
PLOT_POINTS = 20_000
ANIMATION_STATES = 2_048


def _read_waypoints(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Waypoints (deg, or mm for a prismatic joint) and optional times (s) from a table
    (:func:`~armpath.cli.tables.read_number_table`): one row per waypoint, at least 2 and at
    most ``MAX_WAYPOINTS``, of at most ``MAX_JOINTS`` joints; a first column named ``t`` or
    ``time_s`` gives the times (strictly increasing)."""
    name = f"--waypoints {path}"
    header, data = read_number_table(
        path,
        "--waypoints",
        "waypoints",
        MAX_WAYPOINTS,
        MAX_JOINTS + 1,
        f"a time and up to {MAX_JOINTS} joints",
    )
    if len(data) < 2:
        raise InvalidInputError(f"{name}: need at least 2 waypoint rows, got 1")
    timed = header is not None and header[0] in ("t", "time_s")
    if timed and data.shape[1] < 2:
        raise InvalidInputError(f"{name}: a time column and no joint column")
    check_size(data.shape[1] - timed, MAX_JOINTS, f"{name}: joints (columns)", "--waypoints")
    if header is not None and timed:
        t = data[:, 0]
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            raise InvalidInputError(
                f"{name}: the times ({header[0]}) must increase strictly from row to row; "
                f"waypoint {bad[0] + 2} is at {t[bad[0] + 1]:g} s after {t[bad[0]]:g} s"
            )
        return data[:, 1:], t
    return data, None


def _without_repeats(
    shown: np.ndarray, joint: np.ndarray, name: str
) -> tuple[np.ndarray, np.ndarray]:
    """Untimed waypoints (as given, and in joint units) without the rows the same as the one
    before, each dropped with a warning: a motion from a point to itself takes no time in the
    timing, so it would be crossed in a millisecond (the speed peaking there) or not solved
    with limits; a time column holds the arm still there instead."""
    same = np.flatnonzero(np.all(shown[1:] == shown[:-1], axis=1)) + 1
    if same.size:
        rows = ", ".join(str(int(k) + 1) for k in same[:5]) + (" ..." if same.size > 5 else "")
        warnings.warn(
            f"{name}: {same.size} waypoint(s) the same as the one before dropped (waypoints "
            f"{rows}, counted from 1); give a first column t of times to hold the arm there",
            ArmpathWarning,
            stacklevel=2,
        )
    keep = np.setdiff1d(np.arange(shown.shape[0]), same)
    return shown[keep], joint[keep]


def _check_choice(value: str, choices: Any, option: str) -> None:
    if value not in choices:
        raise InvalidInputError(f"{option} must be one of {tuple(choices)}, got {value!r}")


def _check_rate(value: float, option: str, largest: float, unit: str) -> None:
    """A motion limit (or the controller period) must be a finite number in ``(0, largest]``."""
    if not (math.isfinite(value) and 0 < value <= largest):
        raise InvalidInputError(
            f"{option} must be a number in (0, {largest:g}] {unit}, got {value}"
        )


def _check_seconds(value: float, option: str) -> None:
    if not (math.isfinite(value) and value > 0):
        raise InvalidInputError(f"{option} must be a positive number of seconds, got {value}")


def _check_periods(duration_s: float, period_s: float, options: str) -> None:
    """Refuse a trajectory of ``duration_s`` with more controller periods than
    ``MAX_PERIODS``, or more than ``MAX_COMMANDS`` commands at one a period."""
    ratio = duration_s / period_s
    periods = max(1.0, float(np.ceil(ratio - 1e-9))) if math.isfinite(ratio) else math.inf
    how = f"{duration_s:.6g} s in periods of {period_s:g} s"
    check_size(periods, MAX_PERIODS, f"controller periods ({how})", options)
    check_size(periods, MAX_COMMANDS, f"commands (at least one a period: {how})", options)


def _check_net_motion(waypoints: np.ndarray, lattice: Lattice, option: str) -> None:
    """Refuse waypoints (rad / the model's length unit) whose first and last rows are more
    commands apart than ``MAX_COMMANDS`` on ``lattice``."""
    net = np.abs(waypoints[-1] - waypoints[0]) / lattice.tick
    commands = np.ceil((net - 1.0) / lattice.max_ticks)
    j = int(np.argmax(commands))
    check_size(
        float(commands[j]),
        MAX_COMMANDS,
        f"commands (joint {j + 1} moves {_amount(float(net[j]))} ticks from the first waypoint "
        f"to the last, at most {int(lattice.max_ticks[j])} a command)",
        option,
    )


def _trajectory_joints(
    model: str | None, tip_link: str | None, waypoints_display: np.ndarray, name: str
) -> tuple[SerialArm | None, Lattice, np.ndarray]:
    """The arm of ``armpath trajectory`` (``None`` without ``--model``), its command lattice
    (without a model the seed controller's, 0.1 deg and 20 ticks, on every column) and the
    waypoints in rad / the model's length unit. With a model the waypoints have one column per
    joint, deg or mm, each row within the joint limits."""
    from armpath.model.lattice import Lattice

    n = waypoints_display.shape[1]
    if model is None:
        if tip_link is not None:
            raise InvalidInputError("--tip-link names a link of the --model URDF; give --model")
        return None, Lattice.uniform(n), np.radians(waypoints_display)
    from armpath.model.catalog import resolve_model

    arm = resolve_model(model, tip_link)
    if n != arm.n_joints:
        raise InvalidInputError(
            f"{name}: the rows have {n} joint values, {arm.name} (--model) has {arm.n_joints} "
            f"joints ({', '.join(arm.lattice.units)})"
        )
    W = arm.lattice.joint_from_display(waypoints_display)
    outside = ~arm.within_limits(W)
    if np.any(outside):
        row = int(np.argmax(outside))
        arm.check_limits(W[row], what=f"{name}: waypoint {row + 1}")
    return arm, arm.lattice, W


def _unchecked_limits_warning(waypoints_display: np.ndarray) -> str | None:
    """Without ``--model`` no joint limits apply; where the waypoints have the seed arm's six
    columns and one lies beyond its limits, a warning that says so (a newcomer takes the seed
    arm for the default), in the words of :meth:`SerialArm.check_limits`."""
    from armpath.errors import JointLimitError
    from armpath.model import seed_arm

    arm = seed_arm()
    if waypoints_display.shape[1] != arm.n_joints:
        return None
    W = arm.lattice.joint_from_display(waypoints_display)
    outside = ~arm.within_limits(W)
    if not np.any(outside):
        return None
    row = int(np.argmax(outside))
    try:
        arm.check_limits(W[row], what=f"waypoint {row + 1}")
    except JointLimitError as exc:
        return (
            f"warning: no joint limits are checked without --model: {exc}, the seed arm's "
            "(--model seed checks them)"
        )
    return None


def _position_limits(arm: SerialArm) -> tuple[np.ndarray, np.ndarray]:
    """Position limits (rad / length unit) for the QP: each joint's lowest and highest lattice
    value within its limits widened by ``ROUNDING_SLACK_TICKS``, an unlimited side at the
    largest value a joint state may hold. A trajectory within them rounds to commands within
    the limits (each state within half a tick of it), and a waypoint on a limit lies strictly
    inside them (on the bound itself the QP's optimum is degenerate there)."""
    from armpath.budget import MAX_STATE_TICKS

    low, high = arm.limits_in_ticks()
    tick = arm.lattice.tick
    return (
        np.where(np.isfinite(low), low - ROUNDING_SLACK_TICKS, -MAX_STATE_TICKS) * tick,
        np.where(np.isfinite(high), high + ROUNDING_SLACK_TICKS, MAX_STATE_TICKS) * tick,
    )


def _limits_warning(arm: SerialArm, states: np.ndarray, kind: str, bounded: bool) -> str | None:
    """Which joint the commands (ticks ``states``) take farthest past its limits, or None."""
    low, high = arm.limits_in_ticks()
    below = np.maximum(low - states.min(axis=0), 0.0)
    above = np.maximum(states.max(axis=0) - high, 0.0)
    past = np.maximum(below, above)
    if not np.any(past > 0):
        return None
    j = int(np.argmax(past))
    side, limit = ("lower", low[j]) if below[j] >= above[j] else ("upper", high[j])
    lattice = arm.lattice
    amount = float(past[j] * lattice.tick_display[j])
    unit = lattice.units[j]
    limit_text = f"{limit * lattice.tick_display[j]:.6g} {unit}"
    why = (
        "--bounded held the trajectory within them; its rounding to the lattice did not"
        if bounded
        else f"the free minimum-{kind} curve overshoots between waypoints: --bounded keeps "
        "every joint within its limits"
    )
    return (
        f"warning: the commands take joint {j + 1} {amount:.4g} {unit} past its {side} limit "
        f"({limit_text}); {why}"
    )


def _timing_rows(quantized: Any) -> list[tuple[str, str, str]]:
    """The table rows of the commands' own timing: one command a period, so they take
    ``n_commands * period`` s, which is the trajectory's duration only when no period is split
    (a period whose move needs more than one command) and the period divides it."""
    period = quantized.period_s
    return [
        ("commands", str(quantized.sequence.n_commands), f"one per {period:g} s period"),
        ("commands take", f"{quantized.commands_take_s:.3f}", "s at one a period"),
    ]


def _timing_warning(quantized: Any, duration_s: float, option: str) -> str | None:
    """Why the commands do not keep the trajectory's timing (a period split into several
    commands, or a period longer than the whole trajectory), or None when they do (to within
    the last period, which ends with the trajectory)."""
    period = quantized.period_s
    why = []
    if quantized.split_periods:
        why.append(
            f"{quantized.split_periods} of {quantized.n_periods} periods move a joint farther "
            "than one command may and are split into several"
        )
    if period > duration_s * (1 + 1e-9):
        why.append(f"the period is longer than the {duration_s:.3g} s trajectory")
    if not why:
        return None
    return (
        f"warning: the commands take {quantized.commands_take_s:.4g} s at one a period, not "
        f"the trajectory's "
        f"{duration_s:.4g} s ({'; '.join(why)}): a shorter {option} keeps its timing"
    )


def _amount(x: float) -> str:
    """A count for a message: every digit up to 1e15 (so 20,000,021 is not shown as 2e+07)."""
    return f"{x:,.0f}" if abs(x) < 1e15 else f"{x:.3g}"


def _write_csv(
    folder: OutputFolder,
    name: str,
    header: list[str],
    rows: Callable[[int, int], np.ndarray],
    n_rows: int,
    fmt: str,
) -> None:
    """Write ``name``: the header, then ``rows(start, stop)`` for every stretch of
    ``CSV_CHUNK`` rows, each value formatted with ``fmt`` (printf style)."""
    with folder.file(name).open("w", encoding="utf-8", newline="") as fh:
        fh.write(",".join(header) + "\n")
        for start in range(0, n_rows, CSV_CHUNK):
            check_time(f"writing {name}")
            np.savetxt(fh, rows(start, min(start + CSV_CHUNK, n_rows)), fmt=fmt, delimiter=",")


def _write_commands_csv(folder: OutputFolder, sequence: Any) -> None:
    """``commands.csv``: ``step, d1..dn`` in ticks, one row per command."""
    cmds = sequence.commands
    _write_csv(
        folder,
        "commands.csv",
        ["step"] + [f"d{j + 1}_ticks" for j in range(cmds.shape[1])],
        lambda a, b: np.column_stack([np.arange(a + 1, b + 1), cmds[a:b]]),
        cmds.shape[0],
        "%d",
    )


def _envelope(t: np.ndarray, y: np.ndarray, points: int = PLOT_POINTS) -> tuple[Any, Any]:
    """At most about ``points`` of the series ``(t, y)`` for a plot: the largest ``y`` of each
    stretch (so the peaks, and the largest value, stay)."""
    if t.size <= points:
        return t, y
    step = -(-t.size // points)
    starts = np.arange(0, t.size, step)
    pick = starts + np.array([np.argmax(y[a : a + step]) for a in starts])
    return t[pick], y[pick]


def _evenly(n: int, count: int) -> NDArray[np.int64]:
    """At most ``count`` indices spread evenly over ``0 .. n - 1``, both ends included."""
    return np.unique(np.linspace(0, n - 1, min(n, count)).round().astype(np.int64))


#: ``--kind`` of ``armpath trajectory`` and ``armpath rcm`` and ``--solver``: the parser's
#: choices (--help lists them; another value is a usage error, exit status 2); the same as
#: :data:`armpath.trajectory.minsnap.ORDERS` and :data:`~armpath.trajectory.minsnap.QP_SOLVERS`
#: (``tests/test_cli.py`` checks), spelled out so that --help need not import the solvers.
TrajectoryKind = Literal["snap", "jerk"]
QpSolver = Literal["clarabel", "osqp"]


@app.command()
def trajectory(
    waypoints: Annotated[
        Path,
        typer.Option(
            "--waypoints",
            help="Joint waypoints in deg, one row each (CSV, or values separated by spaces); "
            "a first column 't' (s) gives their times, otherwise they are spaced by the "
            f"velocity/acceleration limits. At most {MAX_WAYPOINTS:,} rows of {MAX_JOINTS} joints.",
        ),
    ],
    kind: Annotated[
        TrajectoryKind,
        typer.Option(help="snap or jerk: the derivative whose square is minimised."),
    ] = "snap",
    max_velocity: Annotated[
        float,
        typer.Option(
            help="Joint speed limit, deg/s (time allocation; with --bounded or --retime a "
            f"limit); in (0, {MAX_VELOCITY_DEG_S:g}]."
        ),
    ] = 30.0,
    max_acceleration: Annotated[
        float,
        typer.Option(
            help="Joint acceleration limit, deg/s^2 (as --max-velocity); in "
            f"(0, {MAX_ACCELERATION_DEG_S2:g}]."
        ),
    ] = 60.0,
    max_jerk: Annotated[
        float | None,
        typer.Option(
            help="Joint jerk limit, deg/s^3, for --bounded and --retime (default: "
            "none; --retime then uses 10x the acceleration limit per s); in "
            f"(0, {MAX_JERK_DEG_S3:g}]."
        ),
    ] = None,
    bounded: Annotated[
        bool,
        typer.Option(
            "--bounded/--free",
            help="Impose the limits inside the minimum-snap QP (Clarabel or OSQP); without a "
            "'t' column the segment times are then compressed to the shortest feasible "
            "duration. --free: the equality-only optimum (one sparse linear solve).",
        ),
    ] = False,
    solver: Annotated[
        QpSolver, typer.Option(help="QP solver for --bounded: clarabel or osqp.")
    ] = "clarabel",
    retime: Annotated[
        bool,
        typer.Option(
            "--retime",
            help="Also compare retimings under the limits: uniform scaling, the shortest "
            "bounded QP, toppra (time-optimal on the same path) and ruckig (jerk-limited "
            "between the waypoints); writes retiming.csv with --out.",
        ),
    ] = False,
    period: PeriodOption = 0.01,
    model: Annotated[
        str | None,
        typer.Option(
            "--model",
            help=f"The arm ({BUILTIN_NAMES}, or a robot file: .json D-H table or .urdf) whose "
            "command lattice and joint limits apply: --waypoints then has one column per "
            "joint, deg or mm (a prismatic joint, whose limits are then mm/s, mm/s^2, "
            "mm/s^3), every waypoint within the limits, and --bounded also keeps the joints "
            "within them. Default: any number of joints in deg on the seed controller's "
            "lattice (0.1 deg, 20 ticks a command), no limits.",
            show_default=False,
        ),
    ] = None,
    tip_link: TipLinkOption = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="Write trajectory.csv (deg, or mm for a prismatic joint, sampled every "
            "period), commands.csv (ticks) and trajectory.png here.",
        ),
    ] = None,
    time_limit: TimeLimitOption = None,
) -> None:
    """Minimum-snap (or minimum-jerk) joint trajectory through waypoints, rest to rest, and its
    commands on the command lattice (the seed controller's 0.1 deg / 2 deg, or --model's; error
    feedback: within half a tick at every period). A period that moves a joint more than one
    command may is split into several commands, and then the commands (one a period) take
    longer than the trajectory: the table says how long and a warning why; so too where the
    commands leave --model's joint limits. At most 5,000,000 controller periods (duration /
    --period), 10,000,000 periods times joints and 1,000,000 commands."""
    from armpath.export import output_folder
    from armpath.trajectory import (
        ORDERS,
        QP_SOLVERS,
        MotionLimits,
        allocate_times,
        minimum_snap,
        quantize,
    )
    from armpath.trajectory.minsnap import segment_durations_ok

    with _cli_errors(time_limit):
        _check_choice(kind, ORDERS, "--kind")
        _check_choice(solver, QP_SOLVERS, "--solver")
        _check_rate(max_velocity, "--max-velocity", MAX_VELOCITY_DEG_S, "deg/s")
        _check_rate(max_acceleration, "--max-acceleration", MAX_ACCELERATION_DEG_S2, "deg/s^2")
        if max_jerk is not None:
            _check_rate(max_jerk, "--max-jerk", MAX_JERK_DEG_S3, "deg/s^3")
        _check_rate(period, "--period", MAX_PERIOD_S, "s")
        W_shown, times = _read_waypoints(waypoints)
        arm, lattice, W = _trajectory_joints(model, tip_link, W_shown, f"--waypoints {waypoints}")

        def rate(value: float) -> np.ndarray:
            """A limit given in deg (mm) per s^k in rad (length unit) per s^k, per joint."""
            return lattice.joint_from_display(np.full(lattice.n_joints, value))

        allocated = times is None
        if times is None:
            if not np.any(W_shown != W_shown[0]):
                raise InvalidInputError(
                    f"--waypoints {waypoints}: every row is the same, so there is no motion to "
                    "time (give a first column t of times to hold the arm still that long)"
                )
            W_shown, W = _without_repeats(W_shown, W, f"--waypoints {waypoints}")
            times = allocate_times(W, rate(max_velocity), rate(max_acceleration))
            options = "--period (or --max-velocity, --max-acceleration)"
        else:
            options = "--period (or the times in --waypoints)"
            if not segment_durations_ok(np.diff(times), ORDERS[kind]):
                raise InvalidInputError(
                    f"--waypoints {waypoints}: segment times from {np.diff(times).min():.3g} "
                    f"to {np.diff(times).max():.3g} s are outside what the {kind} solve can take"
                )
        # The size of the work, before any: the duration (at the shortest feasible one, when
        # --bounded compresses the times, at least each segment's largest move at full speed).
        if bounded and allocated:
            duration = (
                float(np.sum(np.max(np.abs(np.diff(W_shown, axis=0)), axis=1))) / max_velocity
            )
        else:
            duration = float(times[-1] - times[0])
        _check_periods(duration, period, options)
        _check_net_motion(W, lattice, "--waypoints")
        if retime and not np.any(W_shown != W_shown[0]):
            raise InvalidInputError(
                f"--retime: the waypoints of {waypoints} do not move (every row the same); "
                "there is no path to retime"
            )
        limits = MotionLimits(
            velocity=rate(max_velocity),
            acceleration=rate(max_acceleration),
            jerk=None if max_jerk is None else rate(max_jerk),
        )
        # The QP keeps the joints within the arm's limits too (on the lattice, so the commands
        # round within them); the retimings compared keep the path and take the rates alone.
        bounds = limits
        if arm is not None:
            lower, upper = _position_limits(arm)
            bounds = dataclasses.replace(limits, lower=lower, upper=upper)
        folder_cm = output_folder(out) if out is not None else contextlib.nullcontext()
        with folder_cm as folder:
            with progress(f"minimum-{kind} trajectory through {len(W)} waypoints ...") as say:
                if bounded and allocated:
                    # No times given: the shortest duration at which the bounded QP is feasible.
                    from armpath.trajectory import shortest_bounded

                    say("finding the shortest feasible duration ...")
                    traj = shortest_bounded(W, times, bounds, kind=kind, solver=solver)
                elif bounded:
                    traj = minimum_snap(W, times, kind=kind, limits=bounds, solver=solver)
                else:
                    traj = minimum_snap(W, times, kind=kind)
                say("converting to commands ...")
                quantized = quantize(traj, period, lattice, option=options)
                peaks = [lattice.joint_display(traj.peak(d)) for d in (1, 2, 3)]
            retimed = []
            if retime:  # before anything is printed: a retiming that fails prints no table
                from armpath.trajectory import compare_retimings

                if max_jerk is None:
                    limits = MotionLimits(
                        velocity=limits.velocity,
                        acceleration=limits.acceleration,
                        jerk=rate(10.0 * max_acceleration),
                    )
                with progress("retiming ..."):
                    retimed = compare_retimings(W, times, limits, kind=kind)
            how = "limits imposed" if bounded else "no limits imposed"
            on = f"{arm.name}, " if arm is not None else ""
            table = Table(
                title=escape(f"minimum-{kind} trajectory through {len(W)} waypoints ({on}{how})"),
                box=box.SIMPLE,
            )
            for name in ("quantity", "value", "unit"):
                table.add_column(name)
            peak_rows = [
                (f"largest {what}{' (prismatic)' if unit == 'mm' else ''}", f"{value:.2f}",
                 f"{unit}/s{power}")
                for what, power, peak in zip(
                    ("joint speed", "joint acceleration", "joint jerk"),
                    ("", "^2", "^3"),
                    peaks,
                    strict=True,
                )
                for unit, value in _by_unit(peak, lattice)
            ]  # fmt: skip
            for row in (
                ("duration", f"{traj.duration:.3f}", "s"),
                *peak_rows,
                *_timing_rows(quantized),
                (f"periods split (> {_step_text(lattice)})", str(quantized.split_periods), ""),
                ("largest lattice error", f"{quantized.max_tick_error:.3f}", _ticks_text(lattice)),
            ):
                table.add_row(*row)
            out_console.print(table)
            for warning in (
                _timing_warning(quantized, traj.duration, "--period"),
                _unchecked_limits_warning(W_shown)
                if arm is None
                else _limits_warning(arm, quantized.sequence.states(), kind, bounded),
            ):
                if warning:
                    err_console.print(warning, markup=False)
            if retime:
                out_console.print(_retiming_table(retimed, limits, lattice))
            if folder is not None:
                from armpath.viz.figures import plot_trajectory

                with progress("writing the files ...") as say:
                    t = quantized.sample_times
                    _write_csv(
                        folder,
                        "trajectory.csv",
                        ["t_s"] + [f"q{j + 1}_{u}" for j, u in enumerate(lattice.units)],
                        lambda a, b: np.column_stack(
                            [t[a:b], lattice.joint_display(traj.evaluate(t[a:b]))]
                        ),
                        t.size,
                        "%.6f",
                    )
                    _write_commands_csv(folder, quantized.sequence)
                    say("plotting ...")
                    plot_trajectory(
                        folder.file("trajectory.png"),
                        traj,
                        f"{on}minimum-{kind} trajectory",
                        lattice=lattice,
                    )
                    if retimed:
                        folder.write_text("retiming.csv", _retiming_csv(retimed, limits, lattice))
        if folder is not None:
            print_written(folder)


def _by_unit(values_display: np.ndarray, lattice: Lattice) -> list[tuple[str, float]]:
    """The largest of per-joint values (display units) among the joints of each unit, deg
    first: ``[("deg", 43.75), ("mm", 12.0)]``."""
    mask = np.array(lattice.units)
    return [(u, float(np.max(values_display[mask == u]))) for u in lattice.unit_kinds]


def _step_text(lattice: Lattice) -> str:
    """The most a command moves each kind of joint: ``20 ticks: 2 deg``."""
    parts = sorted(
        {
            f"{int(m)} ticks: {m * t:.6g} {u}"
            for m, t, u in zip(lattice.max_ticks, lattice.tick_display, lattice.units, strict=True)
        }
    )
    return ", ".join(parts)


def _ticks_text(lattice: Lattice) -> str:
    """The unit of a lattice error: ``ticks of 0.1 deg``."""
    sizes = sorted({lattice.tick_text(j) for j in range(lattice.n_joints)})
    return "ticks of " + ", ".join(sizes)


def _retiming_table(retimed: list[Any], limits: Any, lattice: Lattice) -> Table:
    kinds = lattice.unit_kinds
    units = "; ".join(f"{u}/s, {u}/s^2, {u}/s^3" for u in kinds)
    if len(kinds) > 1:
        units += ": the revolute joints' peaks, below them the prismatic joints'"
    table = Table(title=f"retiming under the limits ({units})", box=box.SIMPLE)
    for name in (
        "method",
        "duration [s]",
        "peak speed",
        "peak accel.",
        "peak jerk",
        "limits",
        "compute [ms]",
    ):
        table.add_column(escape(name), justify="right")
    for r in retimed:
        peaks = np.reshape(_retiming_peaks(r, lattice), (len(kinds), 3))
        for k, unit_peaks in enumerate(peaks):
            first = k == 0
            table.add_row(
                r.method if first else "",
                f"{r.duration_s:.3f}" if first else "",
                *(f"{v:.2f}" for v in unit_peaks),
                r.verdict(limits) if first else "",
                f"{1e3 * r.compute_s:.0f}" if first else "",
            )
    return table


def _retiming_peaks(r: Any, lattice: Lattice) -> list[float]:
    """A retiming's peak speed, acceleration and jerk among the joints of each unit (deg
    first), in display units."""
    by_derivative = [
        _by_unit(lattice.joint_display(p), lattice)
        for p in (r.peak_velocity, r.peak_acceleration, r.peak_jerk)
    ]
    return [by_derivative[d][k][1] for k in range(len(by_derivative[0])) for d in range(3)]


def _retiming_csv(retimed: list[Any], limits: Any, lattice: Lattice) -> str:
    peaks = [
        f"peak_{name}_{u}_s{power}"
        for u in lattice.unit_kinds
        for name, power in (("velocity", ""), ("acceleration", "2"), ("jerk", "3"))
    ]
    lines = [
        ",".join(
            [
                "method",
                "duration_s",
                *peaks,
                "velocity_met",
                "acceleration_met",
                "jerk_met",
                "compute_ms",
            ]
        )
    ]
    for r in retimed:
        met = r.within(limits)
        lines.append(
            ",".join(
                [
                    r.method,
                    f"{r.duration_s:.6f}",
                    *(f"{v:.6f}" for v in _retiming_peaks(r, lattice)),
                ]
                + [str(met.get(name, "")) for name in ("velocity", "acceleration", "jerk")]
                + [f"{1e3 * r.compute_s:.3f}"]
            )
        )
    return "\n".join(lines) + "\n"


@app.command()
def rcm(
    model: ModelOption = "welder003",
    centre: Annotated[
        str, typer.Option(help="The point the tool tip stays on, 'x,y,z' in mm.")
    ] = "900,0,0",
    axis: Annotated[
        str, typer.Option(help="Axis of the circle the wrist runs round, 'x,y,z'.")
    ] = "1,0,0",
    cone: Annotated[
        float,
        typer.Option(help="Angle of the circle from the axis, deg (90: a great circle)."),
    ] = 90.0,
    points: Annotated[
        int, typer.Option(help=f"Waypoints on the circle (3 to {MAX_WAYPOINTS - 1:,}).")
    ] = 24,
    duration: Annotated[float, typer.Option(help="Time for one turn, s.")] = 8.0,
    kind: Annotated[
        TrajectoryKind,
        typer.Option(help="snap or jerk: the derivative whose square is minimised."),
    ] = "snap",
    period: PeriodOption = 0.01,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="Write rcm.csv (joints and tip every period), commands.csv (ticks of 0.1 deg "
            "or 0.1 mm), rcm_tip_deviation.png and, with --animate, rcm.gif here.",
        ),
    ] = None,
    animate: Annotated[
        bool, typer.Option("--animate/--no-animate", help="Write rcm.gif (with --out).")
    ] = True,
    time_limit: TimeLimitOption = None,
) -> None:
    """Fixed-point rotation (seed 003): the tool tip stays on CENTRE while the tool turns once
    round a circle of directions (Rodrigues rotations, closed-form IK on the nearest branch,
    minimum-snap joints); prints how far the tip leaves the point, on the smooth trajectory and
    under the quantized commands. At most 5,000,000 controller periods (--duration / --period)
    and 1,000,000 commands."""
    from armpath.export import output_folder
    from armpath.kinematics import tool_position
    from armpath.model.catalog import resolve_model
    from armpath.trajectory import ORDERS, lattice_motion, quantize
    from armpath.trajectory.minsnap import segment_durations_ok
    from armpath.trajectory.quantize import MOTION_CHUNK
    from armpath.trajectory.rcm import fixed_point_rotation
    from armpath.workspace.sampling import check_count

    with _cli_errors(time_limit):
        _check_choice(kind, ORDERS, "--kind")
        _check_rate(period, "--period", MAX_PERIOD_S, "s")
        _check_seconds(duration, "--duration")
        check_count(points, "--points", MAX_WAYPOINTS - 1, "points on the circle", least=3)
        if not (0.0 < cone <= 90.0):
            raise InvalidInputError(f"--cone must be in (0, 90] deg, got {cone}")
        options = "--period or --duration"
        if duration < points * period:
            raise InvalidInputError(
                f"--duration {duration:g} s gives each of the {points} segments round the circle "
                f"less than one controller period (--period {period:g} s): at least "
                f"{points * period:g} s"
            )
        _check_periods(duration, period, options)
        if not segment_durations_ok([duration / points], ORDERS[kind]):
            raise InvalidInputError(
                f"--duration {duration:g} s over {points} points gives segments of "
                f"{duration / points:.3g} s, outside what the {kind} solve can take"
            )
        c0 = np.array(_numbers(centre.split(","), 3, "--centre"))
        a = np.array(_numbers(axis.split(","), 3, "--axis"))
        if not np.any(a):
            raise InvalidInputError("--axis must not be zero")
        arm = resolve_model(model)
        folder_cm = output_folder(out) if out is not None else contextlib.nullcontext()
        with folder_cm as folder:
            with progress("planning the rotation ...") as say:
                plan = fixed_point_rotation(
                    arm,
                    c0,
                    circle_axis=a,
                    cone_deg=cone,
                    n_points=points,
                    duration_s=duration,
                    kind=kind,
                )
                traj = plan.trajectory
                say("converting to commands ...")
                quantized = quantize(traj, period, arm.lattice, option=options)
                t = quantized.sample_times
                say("measuring the tip deviation ...")
                smooth_tip = np.vstack(
                    [
                        tool_position(arm, traj.evaluate(t[k : k + MOTION_CHUNK]))
                        for k in range(0, t.size, MOTION_CHUNK)
                    ]
                )
                smooth_dev = np.linalg.norm(smooth_tip - c0, axis=1)
                lattice = []
                n = quantized.n_periods
                for k in range(0, n, MOTION_CHUNK):
                    check_time("measuring the tip deviation of the commands")
                    t_part, q_part = lattice_motion(quantized, 8, k, min(k + MOTION_CHUNK, n))
                    dev = np.linalg.norm(tool_position(arm, q_part) - c0, axis=1)
                    lattice.append((t_part, dev))
                t_lat = np.concatenate([tp for tp, _ in lattice])
                lattice_dev = np.concatenate([d for _, d in lattice])
            table = Table(
                title=escape(
                    f"{arm.name}: tool tip held on {_fmt(c0, 1)} mm, one turn in {duration:g} s"
                ),
                box=box.SIMPLE,
            )
            for name in ("quantity", "value", "unit"):
                table.add_column(name)
            for row in (
                ("tool length (sphere radius)", f"{plan.radius:.1f}", "mm"),
                ("waypoints on the circle", str(points), ""),
                ("tip error at the waypoints", f"{plan.waypoint_tip_error:.2e}", "mm"),
                ("largest tip deviation, smooth trajectory", f"{plan.max_tip_deviation:.3f}", "mm"),
                ("largest tip deviation, quantized commands", f"{lattice_dev.max():.3f}", "mm"),
                *_timing_rows(quantized),
                ("periods split (> 20 ticks: 2 deg, 2 mm)", str(quantized.split_periods), ""),
            ):
                table.add_row(*row)
            out_console.print(table)
            warning = _timing_warning(quantized, traj.duration, "--period (or a longer --duration)")
            if warning:
                err_console.print(warning, markup=False)
            if plan.max_tip_deviation > 0.1 * plan.radius:
                err_console.print(
                    "the tip leaves the point by more than a tenth of the tool length: the circle "
                    "probably crosses the wrist singularity (tool axis along joint 4)",
                    markup=False,
                )
            if folder is not None:
                from armpath.viz.animation import Animation, Overlay, write_animation
                from armpath.viz.figures import plot_tip_deviation

                units = _joint_units(arm)
                with progress("writing the files ...") as say:
                    _write_csv(
                        folder,
                        "rcm.csv",
                        ["t_s"]
                        + [f"q{j + 1}_{u}" for j, u in enumerate(units)]
                        + ["tip_x_mm", "tip_y_mm", "tip_z_mm", "tip_deviation_mm"],
                        lambda a, b: np.column_stack(
                            [
                                t[a:b],
                                _to_display(arm, traj.evaluate(t[a:b])),
                                smooth_tip[a:b],
                                smooth_dev[a:b],
                            ]
                        ),
                        t.size,
                        "%.6f",
                    )
                    _write_commands_csv(folder, quantized.sequence)
                    say("plotting ...")
                    plot_tip_deviation(
                        folder.file("rcm_tip_deviation.png"),
                        [
                            (*_envelope(t, smooth_dev), "smooth trajectory"),
                            (*_envelope(t_lat, lattice_dev), "commands"),
                        ],
                        f"{arm.name}: tool tip distance from the fixed point",
                    )
                    if animate:
                        say("writing rcm.gif ...")
                        ring = np.vstack([plan.wrist_points, plan.wrist_points[:1]])
                        shown = _evenly(t.size, ANIMATION_STATES)
                        write_animation(
                            folder.file("rcm.gif"),
                            Animation(
                                arm,
                                traj.evaluate(t[shown]),
                                t[shown],
                                f"{arm.name}: fixed-point rotation about {_fmt(c0, 0)} mm",
                                overlays=(
                                    Overlay(c0[None, :], "fixed point", "points"),
                                    Overlay(ring, "wrist circle", "line", "tab:purple"),
                                ),
                                caption=lambda k: (
                                    f"tip off the point {smooth_dev[shown[k]]:6.2f} mm"
                                ),
                            ),
                            max_frames=64,
                        )
        if folder is not None:
            print_written(folder)
