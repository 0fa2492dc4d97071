"""The ``armpath`` command line (typer).

Angles on the command line are degrees, lengths mm; command increments are ticks of 0.1 deg.
Every error armpath detects is printed as one line ``error: ...`` on stderr with exit status 1;
usage errors exit with status 2.
"""

from __future__ import annotations

import contextlib
import json
import math
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from armpath import __version__
from armpath.commands import deg_to_ticks, ticks_to_deg
from armpath.errors import ArmpathError, InvalidInputError
from armpath.export import (
    OutputFolder,
    json_text,
    output_folder,
    reach_result_dict,
    write_reach_files,
)
from armpath.kinematics import landmark_positions
from armpath.model.seed_arm import SeedArmGeometry, seed_arm
from armpath.model.serial_arm import SerialArm
from armpath.planning.reach import ReachOptions, ReachResult, plan_reach
from armpath.scenes import Scene, load_scene
from armpath.tasks import SEED_TASKS, reach_task

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


@app.command(context_settings=LOOSE)
def fk(
    angles: Annotated[
        list[str], typer.Argument(help="θ1 … θ6 in degrees", show_default=False, metavar="θ1 … θ6")
    ],
    json_out: Annotated[bool, typer.Option("--json", help="Print JSON on stdout.")] = False,
) -> None:
    """Forward kinematics of the seed arm: joint points A–E and the fingertip (mm)."""
    with _cli_errors():
        arm = seed_arm()
        theta = _numbers(angles, arm.n_joints, "joint angles θ1 … θ6 (deg)")
        pts = landmark_positions(arm, np.radians(theta))
        names = arm.landmark_names
        if json_out:
            doc = {
                "points": {n: [float(c) for c in p] for n, p in zip(names, pts, strict=True)},
                "tip": [float(c) for c in pts[-1]],
                "units": {"length": "mm", "angle": "deg"},
            }
            typer.echo(json.dumps(doc))
        else:
            table = Table(title=f"seed arm, θ = {_fmt(theta, 1)} deg")
            for col in ("point", "x [mm]", "y [mm]", "z [mm]"):
                table.add_column(escape(col), justify="right")
            for n, p in zip(names, pts, strict=True):
                table.add_row(n, *(f"{c:.4f}" for c in p))
            table.add_row("tip", *(f"{c:.4f}" for c in pts[-1]))
            out_console.print(table)
        warnings = []
        try:
            arm.check_limits(np.radians(theta), what="pose")
        except ArmpathError as exc:
            warnings.append(str(exc))
        if np.min(pts[1:, 2]) < 0:
            warnings.append("part of the arm is below the table (z < 0)")
        for w in warnings:
            err_console.print(f"warning: {w}", markup=False, soft_wrap=True)


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
    folder: OutputFolder, stem: str, result: ReachResult, arm: SerialArm, scene: Scene
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
    json_out: Annotated[
        bool, typer.Option("--json", help="Print the result JSON on stdout.")
    ] = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write reach.json, reach.csv, reach.xlsx and PNG figures here."),
    ] = None,
    tolerance: Annotated[float, typer.Option(help="Largest fingertip error accepted, mm.")] = 0.05,
    wall: WallOption = None,
    scene_file: Annotated[
        Path | None, typer.Option("--scene", help="Scene file (TOML). Default: the seed scene.")
    ] = None,
    link_radius: LinkRadiusOption = 0.0,
) -> None:
    """Reach a point with the fingertip in the fewest commands, then the smallest error."""
    with _cli_errors():
        arm = _arm(link_radius)
        xyz = _numbers(target, 3, "target X Y Z (mm)")
        theta = list(start) if start is not None else list(np.degrees(arm.home))
        start_ticks = deg_to_ticks(
            _numbers([str(t) for t in theta], 6, "--from θ1 … θ6 (deg)"), what="--from angles"
        )
        options = ReachOptions(tolerance_mm=tolerance)
        scene = _scene(scene_file, wall)
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            result = plan_reach(arm, scene.world, start_ticks, xyz, options)
            if folder is not None:
                _write_reach(folder, "reach", result, arm, scene)
        written = folder.written if folder is not None else []
        if json_out:
            typer.echo(json_text(reach_result_dict(result, arm, scene)), nl=False)
        else:
            out_console.print(_reach_summary(result, arm, scene))
            for path in written:
                out_console.print(f"wrote {path}", markup=False)


@app.command()
def run(
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("armpath-out"),
    wall: WallOption = None,
    link_radius: LinkRadiusOption = 0.0,
) -> None:
    """Run every seed task implemented so far (today: Task 1, reach the tool box)."""
    with _cli_errors():
        scene = _scene(None, wall)
        arm = _arm(link_radius)
        ((_, title),) = SEED_TASKS
        with output_folder(out) as folder:
            with err_console.status(f"{title} ..."):
                result = reach_task(scene, arm)
            _write_reach(folder, "reach", result, arm, scene)
            doc = reach_result_dict(result, arm, scene)
            folder.write_text("summary.md", _summary_markdown([(title, doc)]))
        written = folder.written
        table = Table(
            title=f"armpath {__version__}: seed tasks, scene {scene.name}, "
            f"wall thickness {doc['wall_thickness']}"
        )
        for col in ("task", "commands", "lower bound", "error [mm]", "min clearance [mm]"):
            table.add_column(escape(col), justify="left" if col == "task" else "right")
        table.add_row(
            f"1 reach {_fmt(doc['target'], 0)} mm",
            str(doc["n_commands"]),
            str(doc["lower_bound_commands"]),
            f"{doc['error_mm']:.4f}",
            f"{doc['min_clearance_mm']:.3f}",
        )
        out_console.print(table)
        out_console.print(f"wrote to {folder.path.resolve()}:", markup=False)
        for path in written:
            out_console.print(f"  {path.name}", markup=False)


def _summary_markdown(tasks: list[tuple[str, dict[str, Any]]]) -> str:
    lines = [
        f"# armpath {__version__}: seed tasks",
        "",
        "| task | commands | lower bound | fingertip error [mm] | min clearance [mm] | wall |",
        "|---|---:|---:|---:|---:|---|",
    ]
    for title, doc in tasks:
        lines.append(
            f"| {title} | {doc['n_commands']} | {doc['lower_bound_commands']} | "
            f"{doc['error_mm']:.4f} | {doc['min_clearance_mm']:.3f} | {doc['wall_thickness']} |"
        )
    return "\n".join(lines) + "\n"


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
