"""``armpath trajectory`` and ``armpath rcm``: smooth joint trajectories, their retiming and
commands, and seed 003's fixed-point rotation."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich import box
from rich.table import Table

from armpath.cli.common import (
    ModelOption,
    PeriodOption,
    _cli_errors,
    _commands_csv,
    _csv_rows,
    _fmt,
    _joint_units,
    _numbers,
    _to_display,
    app,
    err_console,
    out_console,
)
from armpath.errors import InvalidInputError
from armpath.export import (
    output_folder,
)
from armpath.kinematics import tool_position
from armpath.model.catalog import resolve_model


def _read_waypoints(path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Waypoints (deg) and optional times (s) from a CSV: one row per waypoint, joint angles in
    deg; a first column named ``t`` or ``time_s`` gives the times."""
    try:
        lines = [ln.strip() for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip()]
    except OSError as exc:
        raise InvalidInputError(f"cannot read waypoints file {path}: {exc.strerror}") from None
    if not lines:
        raise InvalidInputError(f"waypoints file {path} is empty")
    header = [h.strip().lower() for h in lines[0].split(",")]
    has_header = not all(_is_number(h) for h in header)
    rows = lines[1:] if has_header else lines
    try:
        data = np.array([[float(v) for v in row.split(",")] for row in rows], dtype=np.float64)
    except ValueError:
        raise InvalidInputError(f"waypoints file {path}: every value must be a number") from None
    if data.ndim != 2 or data.shape[0] < 2:
        raise InvalidInputError(f"waypoints file {path}: need at least 2 rows of equal length")
    if has_header and header[0] in ("t", "time_s"):
        return data[:, 1:], data[:, 0]
    return data, None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


@app.command()
def trajectory(
    waypoints: Annotated[
        Path,
        typer.Option(
            "--waypoints",
            help="CSV of joint waypoints in deg, one row each; a first column 't' (s) gives "
            "their times, otherwise they are spaced by the velocity/acceleration limits.",
        ),
    ],
    kind: Annotated[
        str, typer.Option(help="snap or jerk: the derivative whose square is minimised.")
    ] = "snap",
    max_velocity: Annotated[
        float,
        typer.Option(
            help="Joint speed limit, deg/s (time allocation; with --bounded or --retime a limit)."
        ),
    ] = 30.0,
    max_acceleration: Annotated[
        float, typer.Option(help="Joint acceleration limit, deg/s^2 (as --max-velocity).")
    ] = 60.0,
    max_jerk: Annotated[
        float | None,
        typer.Option(
            help="Joint jerk limit, deg/s^3, for --bounded and --retime (default: "
            "none; --retime then uses 10x the acceleration limit per s)."
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
    solver: Annotated[str, typer.Option(help="QP solver for --bounded: clarabel or osqp.")] = (
        "clarabel"
    ),
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
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="Write trajectory.csv (deg, sampled every period), commands.csv (ticks of "
            "0.1 deg) and trajectory.png here.",
        ),
    ] = None,
) -> None:
    """Minimum-snap (or minimum-jerk) joint trajectory through waypoints, rest to rest, and its
    commands on the 0.1 deg / 2 deg lattice (error feedback: within half a tick at every
    period)."""
    from armpath.trajectory import MotionLimits, allocate_times, minimum_snap, quantize

    with _cli_errors():
        W_deg, times = _read_waypoints(waypoints)
        if not (max_velocity > 0 and max_acceleration > 0):
            raise InvalidInputError("--max-velocity and --max-acceleration must be > 0")
        if max_jerk is not None and not max_jerk > 0:
            raise InvalidInputError("--max-jerk must be > 0")
        W = np.radians(W_deg)
        allocated = times is None
        if times is None:
            times = allocate_times(W, np.radians(max_velocity), np.radians(max_acceleration))
        limits = MotionLimits(
            velocity=np.radians(max_velocity),
            acceleration=np.radians(max_acceleration),
            jerk=None if max_jerk is None else np.radians(max_jerk),
        )
        if bounded and allocated:
            # No times given: the shortest duration at which the bounded QP is feasible.
            from armpath.trajectory import shortest_bounded

            with err_console.status("finding the shortest feasible duration ..."):
                traj = shortest_bounded(W, times, limits, kind=kind, solver=solver)
        elif bounded:
            traj = minimum_snap(W, times, kind=kind, limits=limits, solver=solver)
        else:
            traj = minimum_snap(W, times, kind=kind)
        quantized = quantize(traj, period)
        t = quantized.sample_times
        peaks = [np.degrees(traj.peak(d).max()) for d in (1, 2, 3)]
        how = "limits imposed" if bounded else "no limits imposed"
        table = Table(
            title=f"minimum-{kind} trajectory through {len(W)} waypoints ({how})", box=box.SIMPLE
        )
        for name in ("quantity", "value", "unit"):
            table.add_column(name)
        for row in (
            ("duration", f"{traj.duration:.3f}", "s"),
            ("largest joint speed", f"{peaks[0]:.2f}", "deg/s"),
            ("largest joint acceleration", f"{peaks[1]:.2f}", "deg/s^2"),
            ("largest joint jerk", f"{peaks[2]:.2f}", "deg/s^3"),
            ("commands", str(quantized.sequence.n_commands), f"one per {period:g} s period"),
            ("periods split (faster than 2 deg)", str(quantized.split_periods), ""),
            ("largest lattice error", f"{quantized.max_tick_error:.3f}", "ticks of 0.1 deg"),
        ):
            table.add_row(*row)
        out_console.print(table)
        retimed = []
        if retime:
            from armpath.trajectory import compare_retimings

            if max_jerk is None:
                limits = MotionLimits(
                    velocity=limits.velocity,
                    acceleration=limits.acceleration,
                    jerk=10.0 * np.radians(max_acceleration),
                )
            with err_console.status("retiming ..."):
                retimed = compare_retimings(W, times, limits, kind=kind)
            out_console.print(_retiming_table(retimed, limits))
        if out is not None:
            from armpath.viz.figures import plot_trajectory

            with output_folder(out) as folder:
                folder.write_text(
                    "trajectory.csv",
                    _csv_rows(
                        ["t_s"] + [f"q{j + 1}_deg" for j in range(W.shape[1])],
                        np.column_stack([t, np.degrees(traj.evaluate(t))]),
                    ),
                )
                folder.write_text("commands.csv", _commands_csv(quantized.sequence))
                plot_trajectory(folder.file("trajectory.png"), traj, f"minimum-{kind} trajectory")
                if retimed:
                    folder.write_text("retiming.csv", _retiming_csv(retimed, limits))
            for path in folder.written:
                out_console.print(f"wrote {path}", markup=False)


def _retiming_table(retimed: list[Any], limits: Any) -> Table:
    table = Table(title="retiming under the limits (deg/s, deg/s^2, deg/s^3)", box=box.SIMPLE)
    for name in (
        "method",
        "duration [s]",
        "peak speed",
        "peak accel.",
        "peak jerk",
        "limits",
        "compute [ms]",
    ):
        table.add_column(name, justify="right")
    for r in retimed:
        peaks = np.degrees([r.peak_velocity.max(), r.peak_acceleration.max(), r.peak_jerk.max()])
        table.add_row(
            r.method,
            f"{r.duration_s:.3f}",
            *(f"{v:.2f}" for v in peaks),
            r.verdict(limits),
            f"{1e3 * r.compute_s:.0f}",
        )
    return table


def _retiming_csv(retimed: list[Any], limits: Any) -> str:
    lines = [
        "method,duration_s,peak_velocity_deg_s,peak_acceleration_deg_s2,peak_jerk_deg_s3,"
        "velocity_met,acceleration_met,jerk_met,compute_ms"
    ]
    for r in retimed:
        met = r.within(limits)
        lines.append(
            f"{r.method},{r.duration_s:.6f},{np.degrees(r.peak_velocity.max()):.6f},"
            f"{np.degrees(r.peak_acceleration.max()):.6f},{np.degrees(r.peak_jerk.max()):.6f},"
            f"{met.get('velocity', '')},{met.get('acceleration', '')},{met.get('jerk', '')},"
            f"{1e3 * r.compute_s:.3f}"
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
    points: Annotated[int, typer.Option(help="Waypoints on the circle.")] = 24,
    duration: Annotated[float, typer.Option(help="Time for one turn, s.")] = 8.0,
    kind: Annotated[str, typer.Option(help="snap or jerk.")] = "snap",
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
) -> None:
    """Fixed-point rotation (seed 003): the tool tip stays on CENTRE while the tool turns once
    round a circle of directions (Rodrigues rotations, closed-form IK on the nearest branch,
    minimum-snap joints); prints how far the tip leaves the point, on the smooth trajectory and
    under the quantized commands."""
    from armpath.trajectory import joint_ticks, lattice_motion, quantize
    from armpath.trajectory.rcm import fixed_point_rotation

    with _cli_errors():
        arm = resolve_model(model)
        c0 = np.array(_numbers(centre.split(","), 3, "--centre"))
        a = np.array(_numbers(axis.split(","), 3, "--axis"))
        if np.linalg.norm(a) == 0:
            raise InvalidInputError("--axis must not be zero")
        if not (duration > 0):
            raise InvalidInputError(f"--duration must be > 0 s, got {duration}")
        with err_console.status("planning the rotation ..."):
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
            quantized = quantize(traj, period, joint_ticks(arm))
            t = quantized.sample_times
            smooth_tip = tool_position(arm, traj.evaluate(t))
            t_lat, q_lat = lattice_motion(quantized)
            lattice_dev = np.linalg.norm(tool_position(arm, q_lat) - c0, axis=1)
        smooth_dev = np.linalg.norm(smooth_tip - c0, axis=1)
        table = Table(
            title=f"{arm.name}: tool tip held on {_fmt(c0, 1)} mm, one turn in {duration:g} s",
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
            ("commands", str(quantized.sequence.n_commands), f"one per {period:g} s period"),
            ("periods split (faster than 2 ticks)", str(quantized.split_periods), ""),
        ):
            table.add_row(*row)
        out_console.print(table)
        if plan.max_tip_deviation > 0.1 * plan.radius:
            err_console.print(
                "the tip leaves the point by more than a tenth of the tool length: the circle "
                "probably crosses the wrist singularity (tool axis along joint 4)",
                markup=False,
            )
        if out is not None:
            from armpath.viz.animation import Animation, Overlay, write_animation
            from armpath.viz.figures import plot_tip_deviation

            units = _joint_units(arm)
            with output_folder(out) as folder:
                q_show = _to_display(arm, traj.evaluate(t))
                folder.write_text(
                    "rcm.csv",
                    _csv_rows(
                        ["t_s"]
                        + [f"q{j + 1}_{u}" for j, u in enumerate(units)]
                        + ["tip_x_mm", "tip_y_mm", "tip_z_mm", "tip_deviation_mm"],
                        np.column_stack([t, q_show, smooth_tip, smooth_dev]),
                    ),
                )
                folder.write_text("commands.csv", _commands_csv(quantized.sequence))
                plot_tip_deviation(
                    folder.file("rcm_tip_deviation.png"),
                    [(t, smooth_dev, "smooth trajectory"), (t_lat, lattice_dev, "commands")],
                    f"{arm.name}: tool tip distance from the fixed point",
                )
                if animate:
                    ring = np.vstack([plan.wrist_points, plan.wrist_points[:1]])
                    with err_console.status("writing rcm.gif ..."):
                        write_animation(
                            folder.file("rcm.gif"),
                            Animation(
                                arm,
                                traj.evaluate(t),
                                t,
                                f"{arm.name}: fixed-point rotation about {_fmt(c0, 0)} mm",
                                overlays=(
                                    Overlay(c0[None, :], "fixed point", "points"),
                                    Overlay(ring, "wrist circle", "line", "tab:purple"),
                                ),
                                caption=lambda k: f"tip off the point {smooth_dev[k]:6.2f} mm",
                            ),
                            max_frames=64,
                        )
            for path in folder.written:
                out_console.print(f"wrote {path}", markup=False)
