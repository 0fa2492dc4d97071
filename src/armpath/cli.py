"""The ``armpath`` command line (typer).

Angles on the command line are degrees, lengths mm; command increments are ticks of 0.1 deg.
Every error armpath detects is printed as one line ``error: ...`` on stderr with exit status 1;
usage errors exit with status 2.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from armpath import __version__
from armpath.commands import CommandSequence, deg_to_ticks, ticks_to_deg
from armpath.errors import ArmpathError, InvalidInputError
from armpath.export import (
    OutputFolder,
    json_text,
    output_folder,
    plan_result_dict,
    reach_result_dict,
    tour_result_dict,
    trace_result_dict,
    write_reach_files,
    write_sequence_files,
)
from armpath.geometry.primitives import SolidOfRevolution
from armpath.ik import solve_ik
from armpath.kinematics import landmark_positions, tool_pose, tool_position, z_axis_chain
from armpath.model.catalog import resolve_model
from armpath.model.seed_arm import SeedArmGeometry, seed_arm
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.planning.motion import MotionOptions, MotionPlan, Objective, plan_motion
from armpath.planning.reach import ReachOptions, ReachResult, goal_states, plan_reach
from armpath.planning.tour import TourResult
from armpath.planning.trace import TraceOptions, TraceResult
from armpath.report import passes_text, summary_html, summary_markdown
from armpath.scenes import Scene, load_scene
from armpath.tasks import SEED_TASKS, reach_task, spotweld_task, trace_task

app = typer.Typer(
    add_completion=False,
    pretty_exceptions_enable=False,
    no_args_is_help=True,
    help=(
        "Motion design for serial arms driven by quantized joint commands "
        "(0.1 deg ticks, at most 2 deg per joint per command). Angles in deg, lengths in mm."
    ),
)
out_console = Console(highlight=False)
err_console = Console(stderr=True, highlight=False)

LOOSE = {"ignore_unknown_options": True}  # lets negative numbers through as arguments

WallOption = Annotated[
    str | None, typer.Option(help="Workpiece wall thickness measured 'normal' or 'horizontal'.")
]
LinkRadiusOption = Annotated[
    float, typer.Option(help="Radius of the links' capsules, mm (the seeds use 0).")
]
SceneOption = Annotated[
    Path | None,
    typer.Option("--scene", help="Scene file (TOML or YAML). Default: the seed scene."),
]
ObjectiveOption = Annotated[
    Objective,
    typer.Option(
        help="What to minimise: number of commands, fingertip path length, or weighted joint "
        "travel (energy). Every plan reports all three."
    ),
]
JsonOption = Annotated[bool, typer.Option("--json", help="Print the result JSON on stdout.")]
AnimateOption = Annotated[
    bool,
    typer.Option(
        "--animate", help="Also write an animation of the motion (<task>.gif) into --out."
    ),
]


def _animate_into(
    folder: OutputFolder,
    stem: str,
    arm: SerialArm,
    scene: Scene,
    seq: CommandSequence,
    title: str,
    targets: np.ndarray | None = None,
    curve: np.ndarray | None = None,
) -> None:
    """Write ``stem.gif``: the arm through the commands, the targets and the curve."""
    from armpath.viz.animation import sequence_animation, write_animation

    with err_console.status(f"animating {stem} ..."):
        write_animation(
            folder.file(f"{stem}.gif"),
            sequence_animation(arm, scene, seq, title, targets, curve),
            max_frames=64,
        )


def _animate_needs_out(animate: bool, out: Path | None) -> None:
    if animate and out is None:
        raise InvalidInputError("--animate needs --out FOLDER to write the GIF into")


SeedOption = Annotated[int, typer.Option(help="Random seed of the planner (same seed, same plan).")]


@contextlib.contextmanager
def _cli_errors() -> Iterator[None]:
    """Turn armpath's errors into a one-line message and exit status 1."""
    try:
        yield
    except ArmpathError as exc:
        err_console.print(f"error: {exc}", markup=False, soft_wrap=True)
        raise typer.Exit(1) from None


def _numbers(values: list[str], count: int, what: str) -> list[float]:
    if len(values) != count:
        raise InvalidInputError(f"{what}: expected {count} numbers, got {len(values)}: {values}")
    out = []
    for v in values:
        try:
            x = float(v)
        except ValueError:
            raise InvalidInputError(f"{what}: {v!r} is not a number") from None
        if not math.isfinite(x):
            raise InvalidInputError(f"{what}: {v!r} is not a finite number")
        out.append(x)
    return out


def _scene(scene_file: Path | None, wall: str | None) -> Scene:
    scene = load_scene(scene_file)
    return scene.with_wall_thickness(wall) if wall else scene


def _arm(link_radius_mm: float) -> SerialArm:
    if not (math.isfinite(link_radius_mm) and link_radius_mm >= 0):
        raise InvalidInputError(f"--link-radius must be >= 0 mm, got {link_radius_mm}")
    return seed_arm(SeedArmGeometry(link_radius_mm=link_radius_mm))


def _fmt(v: Any, digits: int = 4) -> str:
    return "(" + ", ".join(f"{x:.{digits}f}" for x in np.asarray(v, dtype=float)) + ")"


ModelOption = Annotated[
    str,
    typer.Option(
        "--model",
        help="Built-in model (seed, welder003, painter004, puma560, ur5) or a robot file "
        "(.json D-H table or .urdf).",
    ),
]


PeriodOption = Annotated[float, typer.Option(help="Controller period, s (one command each).")]


def _joint_units(arm: SerialArm) -> list[str]:
    return ["mm" if j.kind is JointKind.PRISMATIC else "deg" for j in arm.joints]


def _to_display(arm: SerialArm, q: np.ndarray) -> np.ndarray:
    """Joint values for output: deg for revolute joints, mm for prismatic ones."""
    out = np.array(q, dtype=float, copy=True)
    for i, j in enumerate(arm.joints):
        if j.kind is JointKind.REVOLUTE:
            out[..., i] = np.degrees(out[..., i])
    return out


def _from_display(arm: SerialArm, values: list[float]) -> np.ndarray:
    q = np.array(values, dtype=float)
    for i, j in enumerate(arm.joints):
        if j.kind is JointKind.REVOLUTE:
            q[i] = np.radians(q[i])
    return q


@app.command(context_settings=LOOSE)
def fk(
    angles: Annotated[
        list[str],
        typer.Argument(
            help="Joint values: deg for revolute joints, mm for prismatic ones",
            show_default=False,
            metavar="q1 … qn",
        ),
    ],
    model: ModelOption = "seed",
    json_out: Annotated[bool, typer.Option("--json", help="Print JSON on stdout.")] = False,
) -> None:
    """Forward kinematics: the arm's joint points and the tool pose (mm, deg).

    For the seed arm the points are A–E and the fingertip; for other models the joint frame
    origins and the tool frame (4x4 pose, row-major).
    """
    with _cli_errors():
        arm = resolve_model(model)
        units = _joint_units(arm)
        what = f"joint values q1 … q{arm.n_joints} ({', '.join(units)})"
        q = _from_display(arm, _numbers(angles, arm.n_joints, what))
        pts = landmark_positions(arm, q)
        pose = tool_pose(arm, q)
        names = arm.landmark_names
        if json_out:
            doc = {
                "model": arm.name,
                "joints": [float(v) for v in _to_display(arm, q)],
                "points": {n: [float(c) for c in p] for n, p in zip(names, pts, strict=True)},
                "tip": [float(c) for c in pose[:3, 3]],
                "pose": [[float(c) for c in row] for row in pose],
                "units": {"length": "mm", "angle": "deg", "joints": units},
            }
            typer.echo(json.dumps(doc))
        else:
            shown = _fmt(_to_display(arm, q), 1)
            table = Table(title=f"{arm.name}, q = {shown} ({', '.join(sorted(set(units)))})")
            for col in ("point", "x [mm]", "y [mm]", "z [mm]"):
                table.add_column(escape(col), justify="right")
            for n, p in zip(names, pts, strict=True):
                table.add_row(n, *(f"{c:.4f}" for c in p))
            if arm.name == "seed":
                table.add_row("tip", *(f"{c:.4f}" for c in pts[-1]))
            out_console.print(table)
            if arm.name != "seed":
                rows = "\n".join("  " + "  ".join(f"{c:11.6f}" for c in r) for r in pose)
                out_console.print(f"tool pose (rotation | position mm):\n{rows}")
        warnings = []
        try:
            arm.check_limits(q, what="pose")
        except ArmpathError as exc:
            warnings.append(str(exc))
        if arm.name == "seed" and np.min(pts[1:, 2]) < 0:
            warnings.append("part of the arm is below the table (z < 0)")
        for w in warnings:
            err_console.print(f"warning: {w}", markup=False, soft_wrap=True)


def _pose_argument(text: str) -> np.ndarray:
    values = _numbers(text.replace(",", " ").split(), 16, "--pose (row-major 4x4)")
    T = np.array(values).reshape(4, 4)
    if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise InvalidInputError(f"--pose: the last row must be 0 0 0 1, got {T[3].tolist()}")
    R = T[:3, :3]
    err = float(np.abs(R @ R.T - np.eye(3)).max())
    if err > 1e-4 or np.linalg.det(R) < 0:
        raise InvalidInputError(
            f"--pose: the upper-left 3x3 block is not a rotation (|R R^T - I| = {err:.2g})"
        )
    U, _, Vt = np.linalg.svd(R)
    T[:3, :3] = U @ Vt  # nearest rotation: poses are often printed to a few digits
    return T


@app.command(context_settings=LOOSE)
def ik(
    model: ModelOption = "seed",
    pose: Annotated[
        str | None,
        typer.Option(help="Target tool pose: 16 numbers, row-major 4x4, lengths mm."),
    ] = None,
    xyz: Annotated[
        tuple[float, float, float] | None,
        typer.Option(help="Target tool position only, mm (numerical solver)."),
    ] = None,
    method: Annotated[
        str,
        typer.Option(
            help="auto, spherical-wrist, three-parallel, general (Raghavan-Roth) or numerical."
        ),
    ] = "auto",
    seeds: Annotated[int, typer.Option(help="Seeds of the numerical solver.")] = 48,
    json_out: JsonOption = False,
) -> None:
    """Inverse kinematics: every solution for a tool pose (or position), deg / mm.

    Complete methods return every real solution: closed form for arms with a spherical wrist
    or three parallel axes (UR type), Raghavan-Roth elimination for any other 6R arm. Each
    solution carries its forward-kinematics residual. Exit status 1 if there is no solution.
    """
    with _cli_errors():
        if (pose is None) == (xyz is None):
            raise InvalidInputError("give exactly one target: --pose '16 numbers' or --xyz X Y Z")
        if seeds < 1:
            raise InvalidInputError(f"--seeds must be >= 1, got {seeds}")
        arm = resolve_model(model)
        if pose is not None:
            target = _pose_argument(pose)
            result = solve_ik(arm, target, method=method, seeds=seeds)
        else:
            assert xyz is not None
            target = np.array(_numbers([str(v) for v in xyz], 3, "--xyz"))
            result = solve_ik(arm, target, position_only=True, seeds=seeds)
        units = _joint_units(arm)
        sols = _to_display(arm, result.solutions)
        inside: Any = result.within_limits if result.within_limits is not None else []
        doc = {
            "model": arm.name,
            "method": result.method,
            "target": (
                {"pose": [[float(c) for c in r] for r in target]}
                if pose is not None
                else {"position": [float(c) for c in target]}
            ),
            "count": result.count,
            "solutions": [[float(v) for v in s] for s in sols],
            "residuals": [
                {"position_mm": float(p), "rotation_deg": float(np.degrees(r))}
                for p, r in zip(result.position_residual, result.rotation_residual_rad, strict=True)
            ],
            "within_limits": [bool(v) for v in inside],
            "near_double": [bool(v) for v in result.near_double],
            "near_singular": [bool(v) for v in result.near_singular],
            "reason": result.reason,
            "units": {"length": "mm", "angle": "deg", "joints": units},
        }
        if json_out:
            typer.echo(json.dumps(doc))
        else:
            unit_note = ", ".join(f"q{i + 1} {u}" for i, u in enumerate(units) if u != "deg")
            table = Table(
                title=escape(
                    f"{arm.name}: {result.count} solution(s), {result.method}; angles deg"
                    + (f", {unit_note}" if unit_note else "")
                ),
                box=box.SIMPLE_HEAD,
            )
            table.add_column("#", justify="right")
            for i in range(arm.n_joints):
                table.add_column(f"q{i + 1}", justify="right")
            table.add_column("resid. mm", justify="right")
            table.add_column("notes")
            for k, s in enumerate(sols):
                notes = []
                if len(inside) and not inside[k]:
                    notes.append("off limits")
                if result.near_double[k]:
                    notes.append("near-double")
                if result.near_singular[k]:
                    notes.append("near-singular")
                table.add_row(
                    str(k + 1),
                    *(f"{v:.4f}" for v in s),
                    f"{result.position_residual[k]:.0e}",
                    ", ".join(notes),
                )
            Console(highlight=False, width=max(out_console.width, 120)).print(table)
        if result.count == 0:
            raise InvalidInputError(f"no solution ({result.method}): {result.reason}")


def _reach_summary(result: ReachResult, arm: SerialArm, scene: Scene) -> Table:
    seq = result.sequence
    lb = result.lower_bound
    c = result.clearance
    table = Table(title="reach", show_header=False)
    table.add_column("quantity", style="bold")
    table.add_column("value")
    table.add_row("target", f"{_fmt(result.target_mm, 3)} mm")
    table.add_row("start", f"{_fmt(ticks_to_deg(seq.start_ticks), 1)} deg")
    proof = "provably fewest" if result.is_provably_fewest else "not proven fewest"
    table.add_row("commands", f"{result.n_commands}  (lower bound {lb.commands}: {proof})")
    if result.method != "direct":
        table.add_row("method", f"{result.method} (every direct motion is blocked)")
    table.add_row(
        "fingertip error", f"{result.error_mm:.4f} mm  (tolerance {result.tolerance_mm} mm)"
    )
    table.add_row("final joints", f"{_fmt(ticks_to_deg(seq.final_ticks), 1)} deg")
    table.add_row("fingertip", f"{_fmt(result.tip_mm, 4)} mm")
    table.add_row(
        "largest joint change",
        f"{np.abs(seq.final_ticks - seq.start_ticks).max() / 10:.1f} deg "
        f"(least possible {lb.max_joint_change_deg:.3f} deg)",
    )
    where = "start state" if c.worst_command == 0 else f"command {c.worst_command}"
    table.add_row(
        "min clearance",
        f"{c.min_clearance:.3f} mm  ({c.worst_part} to {c.worst_obstacle}, {where}; whole "
        f"continuous motion, proven >= {c.min_clearance_lower_bound:.3f} mm)",
    )
    wall = scene.wall_thickness
    table.add_row("scene", f"{scene.name}; wall thickness measured {wall.value if wall else '-'}")
    return table


def _write_reach(
    folder: OutputFolder,
    stem: str,
    result: ReachResult,
    arm: SerialArm,
    scene: Scene,
    animate: bool = False,
) -> None:
    from armpath.viz.figures import plot_joint_angles, plot_motion_3d

    write_reach_files(folder, stem, result, arm, scene)
    title = (
        f"reach {_fmt(result.target_mm, 0)} mm: {result.n_commands} commands, "
        f"error {result.error_mm:.4f} mm"
    )
    plot_motion_3d(
        folder.file(f"{stem}_motion.png"), arm, scene, result.sequence, result.target_mm, title
    )
    plot_joint_angles(folder.file(f"{stem}_joints.png"), result.sequence, title)
    if animate:
        _animate_into(folder, stem, arm, scene, result.sequence, title, result.target_mm)


@app.command(context_settings=LOOSE)
def reach(
    target: Annotated[
        list[str],
        typer.Argument(help="X Y Z of the target in mm", show_default=False, metavar="X Y Z"),
    ],
    start: Annotated[
        tuple[float, float, float, float, float, float] | None,
        typer.Option(
            "--from",
            help="Start joint angles θ1 … θ6 in deg (multiples of 0.1). "
            "Default: the arm's initial pose (0 -90 0 0 -90 0).",
        ),
    ] = None,
    json_out: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write reach.json, reach.csv, reach.xlsx and PNG figures here."),
    ] = None,
    tolerance: Annotated[float, typer.Option(help="Largest fingertip error accepted, mm.")] = 0.05,
    wall: WallOption = None,
    scene_file: SceneOption = None,
    link_radius: LinkRadiusOption = 0.0,
    animate: AnimateOption = False,
) -> None:
    """Reach a point with the fingertip in the fewest commands, then the smallest error.

    When every direct motion is blocked, the motion is planned around the obstacles instead
    (the summary's method says so).
    """
    with _cli_errors():
        arm = _arm(link_radius)
        xyz = _numbers(target, 3, "target X Y Z (mm)")
        theta = list(start) if start is not None else list(np.degrees(arm.home))
        start_ticks = deg_to_ticks(
            _numbers([str(t) for t in theta], 6, "--from θ1 … θ6 (deg)"), what="--from angles"
        )
        options = ReachOptions(tolerance_mm=tolerance)
        _animate_needs_out(animate, out)
        scene = _scene(scene_file, wall)
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            result = plan_reach(arm, scene.world, start_ticks, xyz, options)
            if folder is not None:
                _write_reach(folder, "reach", result, arm, scene, animate)
        written = folder.written if folder is not None else []
        if json_out:
            typer.echo(json_text(reach_result_dict(result, arm, scene)), nl=False)
        else:
            out_console.print(_reach_summary(result, arm, scene))
            for path in written:
                out_console.print(f"wrote {path}", markup=False)


def _plan_summary(doc: dict[str, Any], title: str) -> Table:
    table = Table(title=title, show_header=False)
    table.add_column("quantity", style="bold")
    table.add_column("value")
    m = doc["metrics"]
    table.add_row(
        "commands", f"{doc['n_commands']}  (direct-motion bound {doc['lower_bound_commands']})"
    )
    if "error_mm" in doc:
        table.add_row(
            "fingertip error", f"{doc['error_mm']:.4f} mm  (tolerance {doc['tolerance_mm']} mm)"
        )
    table.add_row("method", str(doc["method"]))
    table.add_row(
        "objectives",
        f"{m['commands']} commands, fingertip path {m['tip_path_mm']:.1f} mm, "
        f"joint travel {m['energy_deg']:.1f} deg (objective: {doc['objective']})",
    )
    table.add_row("final joints", f"{_fmt(doc['final_deg'], 1)} deg")
    c = doc["clearance"]
    table.add_row(
        "min clearance",
        f"{c['min_clearance_mm']:.3f} mm  ({c['closest_part']} to {c['closest_obstacle']}; "
        f"body {c['min_body_clearance_mm']:.3f} mm; whole continuous motion, certified)",
    )
    return table


def _plan_to_point(
    arm: SerialArm,
    scene: Scene,
    start_ticks: np.ndarray,
    xyz: np.ndarray,
    tolerance: float,
    options: MotionOptions,
    folder: OutputFolder | None,
    json_out: bool,
    stem: str,
    animate: bool = False,
) -> None:
    goals, _ = goal_states(arm, scene.world, start_ticks, xyz, tolerance)
    plan = plan_motion(arm, scene.world, start_ticks, goals, options)
    doc = plan_result_dict(plan, arm, scene, options.objective.value, xyz, tolerance)
    _emit_plan(plan, doc, arm, scene, folder, json_out, stem, xyz, animate)


def _emit_plan(
    plan: MotionPlan,
    doc: dict[str, Any],
    arm: SerialArm,
    scene: Scene,
    folder: OutputFolder | None,
    json_out: bool,
    stem: str,
    target: np.ndarray | None,
    animate: bool = False,
) -> None:
    if folder is not None:
        from armpath.viz.figures import plot_joint_angles, plot_motion_3d

        write_sequence_files(folder, stem, doc, arm, plan.sequence)
        title = f"{stem}: {plan.sequence.n_commands} commands ({plan.method})"
        plot_motion_3d(folder.file(f"{stem}_motion.png"), arm, scene, plan.sequence, target, title)
        plot_joint_angles(folder.file(f"{stem}_joints.png"), plan.sequence, title)
        if animate:
            _animate_into(folder, stem, arm, scene, plan.sequence, title, target)
    if json_out:
        typer.echo(json_text(doc), nl=False)
    else:
        out_console.print(_plan_summary(doc, stem))


@app.command(context_settings=LOOSE)
def plan(
    scene_file: SceneOption = None,
    start: Annotated[
        tuple[float, float, float, float, float, float] | None,
        typer.Option(
            "--from",
            help="Start joint angles θ1 … θ6 in deg (multiples of 0.1). Default: the arm's "
            "initial pose.",
        ),
    ] = None,
    to: Annotated[
        tuple[float, float, float, float, float, float] | None,
        typer.Option("--to", help="Goal joint angles θ1 … θ6 in deg (multiples of 0.1)."),
    ] = None,
    to_xyz: Annotated[
        tuple[float, float, float] | None,
        typer.Option("--to-xyz", help="Goal point X Y Z of the fingertip, mm."),
    ] = None,
    objective: ObjectiveOption = Objective.COMMANDS,
    weights: Annotated[
        tuple[float, float, float, float, float, float] | None,
        typer.Option(help="Energy weights of joints 1 … 6 (default all 1)."),
    ] = None,
    tolerance: Annotated[
        float, typer.Option(help="Largest fingertip error accepted with --to-xyz, mm.")
    ] = 0.05,
    json_out: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write plan.json, plan.csv, plan.xlsx and PNG figures here."),
    ] = None,
    wall: WallOption = None,
    link_radius: LinkRadiusOption = 0.0,
    seed: SeedOption = 0,
    searches: Annotated[
        int,
        typer.Option(
            min=1,
            help="Successful searches (seeds) to try when the direct motion is blocked; "
            "the best is kept.",
        ),
    ] = 1,
    animate: AnimateOption = False,
) -> None:
    """Plan a collision-free command sequence to a joint goal or a fingertip point.

    Obstacles and the clearance rule come from the scene file. The direct motion is used when
    it is clear; otherwise RRT-Connect with shortcuts finds a path, which is put on the command
    lattice and certified along its whole continuous motion.
    """
    with _cli_errors():
        if (to is None) == (to_xyz is None):
            raise InvalidInputError("give exactly one goal: --to θ1 … θ6 or --to-xyz X Y Z")
        _animate_needs_out(animate, out)
        arm = _arm(link_radius)
        theta = list(start) if start is not None else list(np.degrees(arm.home))
        start_ticks = deg_to_ticks(
            _numbers([str(t) for t in theta], 6, "--from θ1 … θ6 (deg)"), what="--from angles"
        )
        options = MotionOptions(
            objective=objective,
            energy_weights=tuple(weights) if weights else None,
            seed=seed,
            searches=searches,
        )
        scene = _scene(scene_file, wall)
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            if to_xyz is not None:
                xyz = np.array(_numbers([str(v) for v in to_xyz], 3, "--to-xyz X Y Z (mm)"))
                _plan_to_point(
                    arm,
                    scene,
                    start_ticks,
                    xyz,
                    tolerance,
                    options,
                    folder,
                    json_out,
                    "plan",
                    animate,
                )
            else:
                assert to is not None
                goal = deg_to_ticks(
                    _numbers([str(t) for t in to], 6, "--to θ1 … θ6 (deg)"), what="--to angles"
                )
                result = plan_motion(arm, scene.world, start_ticks, goal[None, :], options)
                doc = plan_result_dict(result, arm, scene, objective.value, None, None)
                _emit_plan(result, doc, arm, scene, folder, json_out, "plan", None, animate)
        if folder is not None and not json_out:
            for path in folder.written:
                out_console.print(f"wrote {path}", markup=False)


def _tour_summary(doc: dict[str, Any]) -> Table:
    table = Table(title="spot welds", show_header=False)
    table.add_column("quantity", style="bold")
    table.add_column("value")
    table.add_row(
        "commands",
        f"{doc['n_commands']}  (bound for the chosen goal states and order: "
        f"{doc['lower_bound_commands']})",
    )
    table.add_row("order", " → ".join(str(i) for i in doc["order"]))
    for v in doc["visits"]:
        table.add_row(
            f"  weld {_fmt(v['target'], 2)} mm",
            f"after command {v['after_command']}, error {v['error_mm']:.4f} mm",
        )
    table.add_row(
        "largest error", f"{doc['error_mm']:.4f} mm  (tolerance {doc['tolerance_mm']} mm)"
    )
    c = doc["clearance"]
    table.add_row(
        "min clearance",
        f"{c['min_clearance_mm']:.3f} mm (tool tip, may touch); links "
        f"{c['min_body_clearance_mm']:.3f} mm; whole continuous motion, certified",
    )
    m = doc["metrics"]
    table.add_row(
        "objectives",
        f"{m['commands']} commands, fingertip path {m['tip_path_mm']:.1f} mm, "
        f"joint travel {m['energy_deg']:.1f} deg",
    )
    table.add_row("wall thickness", f"measured {doc['wall_thickness']}")
    return table


def _write_tour(
    folder: OutputFolder,
    result: TourResult,
    doc: dict[str, Any],
    arm: SerialArm,
    scene: Scene,
    animate: bool = False,
) -> None:
    from armpath.viz.figures import plot_joint_angles, plot_motion_3d

    write_sequence_files(folder, "spotweld", doc, arm, result.sequence)
    title = f"spot welds: {result.n_commands} commands, largest error {result.max_error_mm:.4f} mm"
    targets = np.array(doc["targets"])  # labelled 1..N as listed in the scene
    plot_motion_3d(folder.file("spotweld_motion.png"), arm, scene, result.sequence, targets, title)
    plot_joint_angles(folder.file("spotweld_joints.png"), result.sequence, title)
    if animate:
        _animate_into(folder, "spotweld", arm, scene, result.sequence, title, targets)


@app.command()
def spotweld(
    order: Annotated[
        str,
        typer.Option(help="Visiting order: 'auto' (best over all orders) or 'given' (as listed)."),
    ] = "auto",
    return_home: Annotated[
        bool, typer.Option("--return", help="Return to the initial pose at the end.")
    ] = False,
    json_out: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write spotweld.json, .csv, .xlsx and PNG figures here."),
    ] = None,
    tolerance: Annotated[float, typer.Option(help="Largest fingertip error accepted, mm.")] = 0.05,
    objective: ObjectiveOption = Objective.COMMANDS,
    wall: WallOption = None,
    scene_file: SceneOption = None,
    link_radius: LinkRadiusOption = 0.0,
    seed: SeedOption = 0,
    animate: AnimateOption = False,
) -> None:
    """Task 3: reach the spot welds on the workpiece's inner wall through the open top."""
    with _cli_errors():
        if order not in ("auto", "given"):
            raise InvalidInputError(f"--order must be 'auto' or 'given', got {order!r}")
        arm = _arm(link_radius)
        scene = _scene(scene_file, wall)
        options = MotionOptions(objective=objective, seed=seed)
        _animate_needs_out(animate, out)
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            with err_console.status("planning the spot welds ...") as status:
                result = spotweld_task(
                    scene, arm, order, return_home, tolerance, options,
                    on_progress=lambda msg: status.update(msg),
                )  # fmt: skip
            doc = tour_result_dict(result, arm, scene, objective.value)
            if folder is not None:
                _write_tour(folder, result, doc, arm, scene, animate)
        if json_out:
            typer.echo(json_text(doc), nl=False)
        else:
            out_console.print(_tour_summary(doc))
            for path in folder.written if folder is not None else []:
                out_console.print(f"wrote {path}", markup=False)


def _trace_summary(doc: dict[str, Any]) -> Table:
    table = Table(
        title=f"trace {doc['curve']['definition'].get('name', 'curve')}", show_header=False
    )
    table.add_column("quantity", style="bold")
    table.add_column("value")
    transit = sum(t["commands"] for t in doc["transits"])
    table.add_row(
        "commands",
        f"{doc['n_commands']}  ({transit} moving onto the curve or between passes, "
        f"{doc['n_commands'] - transit} tracing)",
    )
    table.add_row("passes", str(len(doc["passes"])))
    for p in doc["pass_details"]:
        table.add_row(
            f"  states {p['states'][0]}-{p['states'][1]}",
            f"arc {p['start_mm']:.2f} .. {p['end_mm']:.2f} mm ({p['length_mm']:.2f} mm), "
            f"largest deviation {p['max_deviation_mm']:.4f} mm",
        )
    cov = doc["coverage"]
    table.add_row(
        "covered",
        f"{cov['covered_mm']:.2f} mm of {cov['reachable_mm']:.2f} mm reachable "
        f"({100 * cov['of_reachable']:.2f} %); curve {cov['curve_mm']:.2f} mm",
    )
    for u in doc["unreachable"]:
        table.add_row(
            "unreachable",
            f"arc {u['start_mm']:.2f} .. {u['end_mm']:.2f} mm ({u['length_mm']:.2f} mm), "
            f"from {_fmt(u['start_point_mm'], 2)} to {_fmt(u['end_point_mm'], 2)} mm: "
            f"{u['reason']}",
        )
    table.add_row(
        "largest deviation",
        f"{doc['max_deviation_mm']:.4f} mm (proven <= {doc['max_deviation_bound_mm']:.4f}; "
        f"tolerance {doc['tolerance_mm']} mm; continuous tip path)",
    )
    c = doc["clearance"]
    table.add_row(
        "min clearance",
        f"{c['min_clearance_mm']:.3f} mm (tool tip, may touch); links "
        f"{c['min_body_clearance_mm']:.3f} mm; whole continuous motion, "
        f"{'certified' if c['certified'] else 'NOT certified'}",
    )
    table.add_row("wall thickness", f"measured {doc['wall_thickness']}")
    return table


def _write_trace(
    folder: OutputFolder,
    result: TraceResult,
    doc: dict[str, Any],
    arm: SerialArm,
    scene: Scene,
    animate: bool = False,
) -> None:
    from armpath.viz.figures import plot_trace_3d, plot_trace_deviation

    write_sequence_files(folder, "trace", doc, arm, result.sequence)
    curve = result.curve
    title = (
        f"trace: {result.n_commands} commands, {passes_text(len(result.passes))}, "
        f"largest deviation {result.max_deviation_mm:.3f} mm"
    )
    unreachable = result.reachability.unreachable
    gaps = [curve.at_arc_length(np.linspace(a.start_mm, a.end_mm, 200)) for a in unreachable]
    plot_trace_3d(
        folder.file("trace_3d.png"),
        arm,
        scene,
        result.sequence,
        curve.sample(2001),
        [(p.first, p.last) for p in result.passes],
        gaps,
        title,
    )
    plot_trace_deviation(
        folder.file("trace_deviation.png"),
        curve.wrap(result.deviation_s_mm),
        result.deviation_mm,
        result.tolerance_mm,
        [(a.start_mm, a.end_mm) for a in unreachable],
        curve.length,
        title,
    )
    if animate:
        _animate_into(folder, "trace", arm, scene, result.sequence, title, None, curve.sample(801))


@app.command()
def trace(
    tolerance: Annotated[
        float,
        typer.Option(help="Largest distance of the continuous fingertip path from the curve, mm."),
    ] = 0.1,
    json_out: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write trace.json, .csv, .xlsx and PNG figures here."),
    ] = None,
    wall: WallOption = None,
    scene_file: SceneOption = None,
    link_radius: LinkRadiusOption = 0.0,
    seed: SeedOption = 0,
    animate: AnimateOption = False,
) -> None:
    """Task 2: go once around the scene's curve (the crack) with the fingertip, every reachable
    part, fewest passes and commands; report the unreachable arcs and why."""
    with _cli_errors():
        arm = _arm(link_radius)
        scene = _scene(scene_file, wall)
        options = TraceOptions(tolerance_mm=tolerance, motion=MotionOptions(seed=seed))
        _animate_needs_out(animate, out)
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            with err_console.status("tracing the curve ...") as status:
                result = trace_task(scene, arm, options, lambda msg: status.update(msg))
            doc = trace_result_dict(result, arm, scene)
            if folder is not None:
                _write_trace(folder, result, doc, arm, scene, animate)
        if json_out:
            typer.echo(json_text(doc), nl=False)
        else:
            out_console.print(_trace_summary(doc))
            for path in folder.written if folder is not None else []:
                out_console.print(f"wrote {path}", markup=False)


@app.command()
def workspace(
    model: ModelOption = "seed",
    samples: Annotated[
        int, typer.Option(help="Joint vectors to sample (streamed in chunks of --chunk).")
    ] = 4_000_000,
    voxel: Annotated[float, typer.Option(help="Voxel edge, mm.")] = 20.0,
    method: Annotated[
        str, typer.Option(help="uniform, or stratified (a Latin hypercube per chunk).")
    ] = "uniform",
    seed: Annotated[int, typer.Option(help="Random seed (same seed, same workspace).")] = 0,
    chunk: Annotated[int, typer.Option(help="Samples per chunk (bounds the memory).")] = 1_000_000,
    obstacles: Annotated[
        bool,
        typer.Option(
            "--obstacles",
            help="Keep only configurations that satisfy the scene's clearance rule "
            "(obstacles and self-collision; the seed scene unless --scene).",
        ),
    ] = False,
    scene_file: SceneOption = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out", help="Write workspace.npz, workspace.csv and workspace_sections.png here."
        ),
    ] = None,
) -> None:
    """Reachable workspace of the tool point by sampling joint space into voxels: volume,
    bounding box and sections."""
    import time

    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from armpath.workspace import sample_workspace

    with _cli_errors():
        arm = resolve_model(model)
        world = load_scene(scene_file).world if obstacles else None
        folder_cm = output_folder(out) if out is not None else contextlib.nullcontext()
        with folder_cm as folder:
            t0 = time.perf_counter()
            with Progress(
                TextColumn("sampling"),
                BarColumn(),
                TextColumn("{task.completed:,}/{task.total:,}"),
                TimeRemainingColumn(),
                console=err_console,
                transient=True,
            ) as bar:
                task = bar.add_task("sampling", total=samples)
                grid = sample_workspace(
                    arm,
                    samples,
                    voxel,
                    seed=seed,
                    method=method,
                    chunk=chunk,
                    world=world,
                    progress=lambda done, total: bar.update(task, completed=done),
                )
            seconds = time.perf_counter() - t0
            lo, hi = grid.bounding_box()
            rows: list[tuple[str, str, str]] = [
                ("model", arm.name, ""),
                ("samples", f"{grid.samples}", ""),
                *([("kept (clearance rule)", f"{grid.kept}", "")] if obstacles else []),
                ("voxel", f"{grid.voxel:g}", "mm"),
                ("occupied voxels", f"{grid.n_occupied}", ""),
                ("volume", f"{grid.volume / 1e9:.4f}", "m^3"),
                ("x range", f"{lo[0]:.0f} .. {hi[0]:.0f}", "mm"),
                ("y range", f"{lo[1]:.0f} .. {hi[1]:.0f}", "mm"),
                ("z range", f"{lo[2]:.0f} .. {hi[2]:.0f}", "mm"),
                ("time", f"{seconds:.1f}", "s"),
                ("rate", f"{grid.samples / seconds / 1e6:.2f}", "million samples/s"),
            ]
            table = Table(title=f"workspace of {arm.name}", box=box.SIMPLE)
            for name in ("quantity", "value", "unit"):
                table.add_column(name)
            for row in rows:
                table.add_row(*row)
            out_console.print(table)
            if folder is not None:
                from armpath.viz.workspace_figures import plot_workspace_sections

                np.savez_compressed(
                    folder.file("workspace.npz"),
                    occupied=grid.occupied,
                    origin_mm=grid.origin,
                    voxel_mm=grid.voxel,
                    samples=grid.samples,
                    kept=grid.kept,
                )
                folder.write_text(
                    "workspace.csv",
                    "quantity,value,unit\n"
                    + "".join(f"{n},{v.replace(',', ' ')},{u}\n" for n, v, u in rows),
                )
                # vertical section through axis 1, horizontal one half-way up the workspace
                centre = np.asarray(z_axis_chain(arm)[0, :3, 3]).copy()
                centre[2] = 0.5 * (lo[2] + hi[2])
                plot_workspace_sections(
                    folder.file("workspace_sections.png"),
                    grid,
                    centre,
                    f"{arm.name}: {grid.volume / 1e9:.4f} m^3 reachable "
                    f"({grid.samples:,} samples, {grid.voxel:g} mm voxels)",
                )
        if out is not None and folder is not None:
            for path in folder.written:
                out_console.print(f"wrote {path}", markup=False)


def _only_workpiece(scene: Scene) -> SolidOfRevolution:
    if len(scene.workpieces) != 1:
        raise InvalidInputError(
            f"scene {scene.name!r} has {len(scene.workpieces)} hollow workpieces; "
            "blind zones need exactly one"
        )
    return scene.workpieces[0]


@dataclasses.dataclass(frozen=True)
class _BlindZones:
    plane: Any
    meridian: Any
    faces: list[Any]
    pixel: float

    def summary(self) -> list[str]:
        """One line each: the central blind zone in the plane and in 3-D, each face."""
        out = [
            f"central blind zone: {self.plane.blind_area / 100:.0f} cm^2 in the arm plane "
            f"(joints 2, 3, 5; {self.plane.reach_area / 100:.0f} cm^2 reachable), "
            f"{self.meridian.revolved_blind_volume() / 1e6:.2f} litres in 3-D",
        ]
        out += [
            f"workpiece {f.face} face: {f.blind_area_mm2 / 100:.1f} of {f.area_mm2 / 100:.1f} cm^2 "
            f"unreachable ({100 * f.blind_fraction:.1f} %, {len(f.heights)} circles)"
            for f in self.faces
        ]
        return out


def _blind_zones(
    arm: SerialArm,
    scene: Scene,
    pixel: float,
    samples: int,
    bands: int,
    seed: int,
    status: Any,
    scan_step_mm: float = 8.0,
) -> _BlindZones:
    from armpath.workspace.blindzones import arm_plane_map, meridian_map, surface_blindness

    status.update("blind zones: sampling the arm plane ...")
    plane = arm_plane_map(arm, pixel, samples, seed=seed)
    status.update("blind zones: sampling the meridian map ...")
    meridian = meridian_map(arm, pixel, 2 * samples, seed=seed + 1)
    faces = (
        surface_blindness(
            arm,
            scene.world,
            _only_workpiece(scene),
            bands,
            scan_step_mm=scan_step_mm,
            resolution_mm=scan_step_mm / 16.0,
            progress=lambda m: status.update(m),
        )
        if bands > 0
        else []
    )
    return _BlindZones(plane, meridian, faces, pixel)


def _write_blind_zones(folder: OutputFolder, bz: _BlindZones) -> None:
    from armpath.viz.workspace_figures import plot_blind_maps, plot_face_blindness

    rows = [
        f"{f.face},{z:.2f},{length:.2f},{blind:.2f}\n"
        for f in bz.faces
        for z, length, blind in zip(f.heights, f.length_mm, f.blind_mm, strict=True)
    ]
    folder.write_text(
        "blindzones.csv", "face,height_mm,circumference_mm,unreachable_mm\n" + "".join(rows)
    )
    np.savez_compressed(
        folder.file("blindzones.npz"),
        plane_reach=bz.plane.reach,
        plane_blind=bz.plane.blind,
        plane_origin_mm=bz.plane.origin,
        meridian_reach=bz.meridian.reach,
        meridian_blind=bz.meridian.blind,
        meridian_origin_mm=bz.meridian.origin,
        pixel_mm=bz.pixel,
    )
    plot_blind_maps(
        folder.file("blind_maps.png"),
        [(bz.plane, "arm plane (y, z)"), (bz.meridian, "about the axis (rho, z)")],
        "seed arm: reachable fingertip positions and enclosed blind zones",
    )
    if bz.faces:
        plot_face_blindness(
            folder.file("face_blindness.png"),
            bz.faces,
            "workpiece faces the fingertip cannot reach",
        )


@app.command()
def blindzones(
    pixel: Annotated[float, typer.Option(help="Pixel edge of the plane maps, mm.")] = 5.0,
    samples: Annotated[
        int, typer.Option(help="Joint samples of each plane map (the 3-D meridian map: twice).")
    ] = 2_000_000,
    bands: Annotated[
        int, typer.Option(help="Horizontal circles per workpiece face (0: skip the faces).")
    ] = 9,
    seed: Annotated[int, typer.Option(help="Random seed of the sampling.")] = 0,
    wall: WallOption = None,
    link_radius: LinkRadiusOption = 0.0,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="Write blindzones.csv, blindzones.npz, blind_maps.png and face_blindness.png "
            "here.",
        ),
    ] = None,
) -> None:
    """Blind zones of the seed arm: the central blind zone in the arm plane and in 3-D (areas
    mm^2, volume mm^3), and the parts of the workpiece's outer and inner faces the fingertip
    cannot reach without a collision (areas mm^2, fractions)."""
    with _cli_errors():
        if samples < 1:
            raise InvalidInputError(f"--samples must be >= 1, got {samples}")
        if bands < 0:
            raise InvalidInputError(f"--bands must be >= 0, got {bands}")
        scene = _scene(None, wall)
        arm = _arm(link_radius)
        folder_cm = output_folder(out) if out is not None else contextlib.nullcontext()
        with folder_cm as folder:
            with err_console.status("blind zones ...") as status:
                bz = _blind_zones(arm, scene, pixel, samples, bands, seed, status)
            table = Table(title="blind zones of the seed arm", box=box.SIMPLE)
            for name in ("where", "blind", "of", "unit"):
                table.add_column(name)
            table.add_row(
                "arm plane (joints 2, 3, 5)",
                f"{bz.plane.blind_area:.0f}",
                f"{bz.plane.reach_area:.0f} reachable",
                "mm^2",
            )
            table.add_row(
                "3-D, about the vertical axis",
                f"{bz.meridian.revolved_blind_volume():.4g}",
                "",
                "mm^3",
            )
            for f in bz.faces:
                table.add_row(
                    f"workpiece {f.face} face",
                    f"{f.blind_area_mm2:.0f} ({100 * f.blind_fraction:.1f} %)",
                    f"{f.area_mm2:.0f}",
                    "mm^2",
                )
            out_console.print(table)
            wall_convention = scene.wall_thickness
            out_console.print(
                f"scene {scene.name}: wall thickness measured "
                f"{wall_convention.value if wall_convention else '-'}; {pixel:g} mm pixels; "
                f"faces by {bands} horizontal circles each",
                markup=False,
            )
            if folder is not None:
                _write_blind_zones(folder, bz)
        if out is not None and folder is not None:
            for path in folder.written:
                out_console.print(f"wrote {path}", markup=False)


@app.command("design-sweep")
def design_sweep(
    total: Annotated[
        float, typer.Option(help="Total link length AB + BC + CD + DE of every candidate, mm.")
    ] = 715.0,
    samples: Annotated[int, typer.Option(help="Joint samples per candidate.")] = 1_000_000,
    pixel: Annotated[float, typer.Option(help="Pixel edge of the meridian maps, mm.")] = 10.0,
    seed: Annotated[int, typer.Option(help="Random seed (every candidate uses it).")] = 0,
    jobs: Annotated[int, typer.Option(help="Local worker processes (-1: every core).")] = -1,
    scheduler: Annotated[
        str | None,
        typer.Option(help="Address of a Dask scheduler (e.g. tcp://host:8786) to run on."),
    ] = None,
    top: Annotated[int, typer.Option(help="Candidates listed, best first.")] = 10,
    out: Annotated[
        Path | None, typer.Option("--out", help="Write design_sweep.csv and design_sweep.png here.")
    ] = None,
) -> None:
    """Design study of the seed arm: link lengths (AB, BC = CD, DE at a fixed total) and the
    range of joint 3 against the reach volume above the table (m^3) and the central blind zone
    (litres). Objective: the largest reach volume; ties (within 0.5 %) go to the smaller blind
    zone."""
    from armpath.workspace.design import design_grid, evaluate_design, ranked, sweep

    with _cli_errors():
        if samples < 1:
            raise InvalidInputError(f"--samples must be >= 1, got {samples}")
        if top < 1:
            raise InvalidInputError(f"--top must be >= 1, got {top}")
        candidates = design_grid(total)
        folder_cm = output_folder(out) if out is not None else contextlib.nullcontext()
        with folder_cm as folder:
            where = f"Dask at {scheduler}" if scheduler else "joblib on this machine"
            with err_console.status(f"evaluating {len(candidates)} designs ({where}) ..."):
                results = ranked(
                    sweep(
                        candidates,
                        pixel_mm=pixel,
                        samples=samples,
                        seed=seed,
                        scheduler=scheduler,
                        n_jobs=jobs,
                    )
                )
                reference = evaluate_design(SeedArmGeometry(), pixel, samples, seed)
            columns = list(reference.row())
            shown = {
                "AB_mm": "AB mm",
                "BC_mm": "BC=CD mm",
                "DE_mm": "DE mm",
                "theta3_deg": "θ3 ±deg",
                "reach_volume_m3": "reach m^3",
                "blind_volume_l": "blind l",
                "nearest_to_B_mm": "nearest to B mm",
            }
            table = Table(
                title=f"seed-arm designs, total length {total:g} mm (best first)", box=box.SIMPLE
            )
            for name in ("#", *shown.values()):
                table.add_column(name, justify="right")

            def cells(r: dict[str, float]) -> list[str]:
                return [f"{r[k]:.4g}" for k in shown]

            for k, r in enumerate(results[:top]):
                table.add_row(str(k + 1), *cells(r.row()))
            table.add_row("seed", *cells(reference.row()))
            out_console.print(table)
            best = results[0]
            out_console.print(
                f"recommendation: AB {best.geometry.ab_mm:g}, BC = CD {best.geometry.bc_mm:g}, "
                f"DE {best.geometry.de_mm:g} mm, joint 3 within ±{best.geometry.range_deg[2]:g}°: "
                f"{best.reach_volume_mm3 / 1e9:.4f} m^3 above the table "
                f"({100 * (best.reach_volume_mm3 / reference.reach_volume_mm3 - 1):+.1f} % on the "
                f"seed arm), blind zone {best.blind_volume_mm3 / 1e6:.3g} l "
                f"(seed arm {reference.blind_volume_mm3 / 1e6:.3g} l)",
                markup=False,
            )
            if folder is not None:
                from armpath.viz.workspace_figures import plot_design_sweep

                folder.write_text(
                    "design_sweep.csv",
                    "rank,"
                    + ",".join(columns)
                    + "\n"
                    + "".join(
                        f"{k + 1}," + ",".join(f"{v:.6g}" for v in r.row().values()) + "\n"
                        for k, r in enumerate(results)
                    ),
                )
                plot_design_sweep(folder.file("design_sweep.png"), results, reference)
        if out is not None and folder is not None:
            for path in folder.written:
                out_console.print(f"wrote {path}", markup=False)


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


def _commands_csv(sequence: Any) -> str:
    """``step, d1..dn`` in ticks, one row per command."""
    cmds = sequence.commands
    return _csv_rows(
        ["step"] + [f"d{j + 1}_ticks" for j in range(cmds.shape[1])],
        np.column_stack([np.arange(1, len(cmds) + 1), cmds]),
        "{:d}",
    )


def _csv_rows(header: list[str], rows: np.ndarray, fmt: str = "{:.6f}") -> str:
    return (
        ",".join(header)
        + "\n"
        + "".join(",".join(fmt.format(v) for v in row) + "\n" for row in rows)
    )


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


@app.command()
def view(
    model: ModelOption = "seed",
    scene_file: SceneOption = None,
    result: Annotated[
        Path | None,
        typer.Option(
            "--result",
            help="A result JSON (reach, trace, spotweld, plan) to replay; its model and scene "
            "come with it.",
        ),
    ] = None,
    host: Annotated[str, typer.Option(help="Address to serve on.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to serve on.")] = 8080,
    export_html: Annotated[
        Path | None,
        typer.Option(
            "--export-html",
            help="Write a self-contained HTML replay of --result to this file and exit "
            "(opens offline in any browser).",
        ),
    ] = None,
    fps: Annotated[float, typer.Option(help="Commands per second in the HTML replay.")] = 15.0,
) -> None:
    """Interactive 3D viewer in the browser: the arm in its scene, a slider per joint (0.1
    steps within the limits), live fingertip position and clearance (collisions in red), a
    target point to plan a reach to, and the replay of a result (play, pause, step,
    timeline)."""
    from armpath.results import load_result

    with _cli_errors():
        loaded = load_result(result, scene_file) if result is not None else None
        if export_html is not None:
            if loaded is None:
                raise InvalidInputError("--export-html needs --result FILE")
            if export_html.suffix.lower() not in (".html", ".htm"):
                raise InvalidInputError(f"--export-html must end in .html, got {export_html.name}")
            from armpath.viewer.app import replay_html

            with err_console.status("recording the replay ..."):
                page = replay_html(loaded, fps=fps)
            with output_folder(export_html.parent) as folder:
                folder.write_text(export_html.name, page)
            out_console.print(f"wrote {export_html}", markup=False)
            return
        if not (0 < port < 65536):
            raise InvalidInputError(f"--port must be in 1..65535, got {port}")
        from armpath.viewer.app import ArmViewer

        if loaded is not None:
            arm, scene = loaded.arm, loaded.scene
        else:
            arm = seed_arm() if model == "seed" else resolve_model(model)
            scene = _scene(scene_file, None)
        viewer = ArmViewer(arm, scene, host=host, port=port, result=loaded)
        out_console.print(
            f"armpath viewer on http://{host}:{viewer.server.get_port()} (Ctrl-C to stop)",
            markup=False,
        )
        try:
            while True:
                time.sleep(3600)
        except KeyboardInterrupt:
            viewer.stop()


@app.command()
def animate(
    result: Annotated[Path, typer.Argument(help="A result JSON (reach, trace, spotweld, plan).")],
    out: Annotated[
        Path | None,
        typer.Option("--out", help="GIF or MP4 file to write. Default: the result's name, .gif."),
    ] = None,
    scene_file: SceneOption = None,
    fps: Annotated[int, typer.Option(help="Frames per second.")] = 15,
    frames: Annotated[int, typer.Option(help="Largest number of frames.")] = 120,
) -> None:
    """Animate a result: the arm through its commands in the scene, the fingertip's path, the
    targets and the curve (GIF with Pillow, MP4 with ffmpeg)."""
    from armpath.results import load_result
    from armpath.viz.animation import result_animation, write_animation

    with _cli_errors():
        if fps < 1 or frames < 2:
            raise InvalidInputError("--fps must be >= 1 and --frames >= 2")
        loaded = load_result(result, scene_file)
        target = out if out is not None else result.with_suffix(".gif")
        with output_folder(target.parent) as folder, err_console.status("animating ..."):
            n = write_animation(
                folder.file(target.name), result_animation(loaded), fps=fps, max_frames=frames
            )
        out_console.print(f"wrote {target} ({n} frames)", markup=False)


@app.command()
def run(
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("armpath-out"),
    wall: WallOption = None,
    link_radius: LinkRadiusOption = 0.0,
    html: Annotated[
        bool, typer.Option("--html", help="Also write the report as summary.html.")
    ] = False,
) -> None:
    """Run the seed scene's three tasks: 1, reach the tool box; 2, trace the crack; 3, spot welds
    inside the workpiece; then summarise the seed arm's blind zones. Writes each task's result
    (JSON, CSV, XLSX), figures and animations (GIF), and a one-page report summary.md."""
    with _cli_errors():
        scene = _scene(None, wall)
        arm = _arm(link_radius)
        titles = dict(SEED_TASKS)
        with output_folder(out) as folder:
            with err_console.status(f"{titles['reach']} ..."):
                result = reach_task(scene, arm)
            _write_reach(folder, "reach", result, arm, scene, animate=True)
            reach_doc = reach_result_dict(result, arm, scene)
            with err_console.status(f"{titles['trace']} ...") as status:
                traced = trace_task(scene, arm, on_progress=lambda msg: status.update(msg))
            trace_doc = trace_result_dict(traced, arm, scene)
            _write_trace(folder, traced, trace_doc, arm, scene, animate=True)
            with err_console.status(f"{titles['spotweld']} ...") as status:
                tour = spotweld_task(scene, arm, on_progress=lambda msg: status.update(msg))
            tour_doc = tour_result_dict(tour, arm, scene, Objective.COMMANDS.value)
            _write_tour(folder, tour, tour_doc, arm, scene, animate=True)
            with err_console.status("blind zones ...") as status:
                blind = _blind_zones(arm, scene, 5.0, 1_000_000, 3, 0, status, scan_step_mm=16.0)
            _write_blind_zones(folder, blind)
            tasks = [
                (titles["reach"], reach_doc),
                (titles["trace"], trace_doc),
                (titles["spotweld"], tour_doc),
            ]
            report = summary_markdown(tasks, blind.summary(), [*folder.staged(), "summary.md"])
            folder.write_text("summary.md", report)
            if html:
                folder.write_text("summary.html", summary_html(report))
        written = folder.written
        table = Table(
            title=f"armpath {__version__}: seed tasks, scene {scene.name}, "
            f"wall thickness {reach_doc['wall_thickness']}"
        )
        for col in ("task", "commands", "lower bound", "error [mm]", "min clearance [mm]"):
            table.add_column(escape(col), justify="left" if col == "task" else "right")
        table.add_row(
            f"1 reach {_fmt(reach_doc['target'], 0)} mm",
            str(reach_doc["n_commands"]),
            str(reach_doc["lower_bound_commands"]),
            f"{reach_doc['error_mm']:.4f}",
            f"{reach_doc['min_clearance_mm']:.3f}",
        )
        cov = trace_doc["coverage"]
        table.add_row(
            f"2 trace the crack, {passes_text(len(trace_doc['passes']))}",
            str(trace_doc["n_commands"]),
            "-",
            f"{trace_doc['max_deviation_mm']:.4f} (deviation)",
            f"{trace_doc['min_clearance_mm']:.3f} (tip); "
            f"{trace_doc['clearance']['min_body_clearance_mm']:.3f} (links)",
        )
        table.add_row(
            f"3 spot welds, order {'-'.join(str(i) for i in tour_doc['order'])}",
            str(tour_doc["n_commands"]),
            f"{tour_doc['lower_bound_commands']}*",
            f"{tour_doc['error_mm']:.4f} (largest)",
            f"{tour_doc['min_clearance_mm']:.3f} (tip); "
            f"{tour_doc['clearance']['min_body_clearance_mm']:.3f} (links)",
        )
        out_console.print(table)
        out_console.print(
            f"Task 2: {cov['covered_mm']:.2f} mm of the {cov['reachable_mm']:.2f} mm reachable "
            f"covered; error column = largest deviation of the continuous fingertip path; "
            + "; ".join(
                f"unreachable {u['start_mm']:.2f}..{u['end_mm']:.2f} mm ({u['reason']})"
                for u in trace_doc["unreachable"]
            ),
            markup=False,
            soft_wrap=True,
        )
        out_console.print(
            "* Task 3's bound: direct motions between the chosen goal states, obstacles ignored.",
            markup=False,
        )
        for line in blind.summary():
            out_console.print(f"Blind zones: {line}", markup=False, soft_wrap=True)
        out_console.print(f"wrote to {folder.path.resolve()}:", markup=False)
        for path in written:
            out_console.print(f"  {path.name}", markup=False)


@app.callback(invoke_without_command=True)
def _root(
    version: Annotated[bool, typer.Option("--version", help="Print the version and exit.")] = False,
) -> None:
    if version:
        out_console.print(f"armpath {__version__}")
        raise typer.Exit(0)


def main() -> None:
    """Console entry point."""
    try:
        app()
    except ArmpathError as exc:  # pragma: no cover - commands already convert these
        err_console.print(f"error: {exc}", markup=False)
        sys.exit(1)
