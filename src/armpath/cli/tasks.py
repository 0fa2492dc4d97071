"""The planning commands: ``reach``, ``plan``, ``spotweld``, ``trace``, and ``run`` (the seed
scene's three tasks, the blind zones and the report)."""

from __future__ import annotations

import contextlib
import math
import re
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer
from rich.markup import escape
from rich.table import Table

from armpath import __version__
from armpath.budget import MAX_CURVE_POINTS, MAX_SEARCHES
from armpath.cli.common import (
    BUILTIN_NAMES,
    LOOSE,
    VERBOSE,
    AnimateOption,
    BackgroundJob,
    BoundSamplesOption,
    JsonOption,
    LinkRadiusOption,
    ObjectiveOption,
    SceneOption,
    SeedOption,
    TimeLimitOption,
    TipLinkOption,
    WallOption,
    _animate_into,
    _animate_needs_out,
    _cli_errors,
    _fmt,
    _numbers,
    _point_mm,
    _units_text,
    app,
    err_console,
    joint_state,
    out_console,
    print_written,
    progress,
    task_setup,
)
from armpath.errors import (
    CollisionError,
    InvalidInputError,
    PlanningError,
    TimeLimitError,
    UnreachableError,
)
from armpath.ik.target import (
    DEFAULT_ANGLE_TOLERANCE_DEG,
    DEFAULT_AXIS_TOLERANCE_DEG,
    refuse_alone,
    rule_tolerances,
)
from armpath.planning.choices import Objective, VisitOrder
from armpath.planning.trace.reachability import MAX_SCAN_POINTS
from armpath.report import commands_text, coverage_percent_text, coverage_text
from armpath.tolerances import POINT_TOLERANCE_MM, TRACE_TOLERANCE_MM

if TYPE_CHECKING:
    from armpath.export import OutputFolder
    from armpath.geometry.curves import Curve
    from armpath.ik.target import Orientation
    from armpath.model.serial_arm import SerialArm
    from armpath.planning.motion import MotionOptions, MotionPlan
    from armpath.planning.reach import ReachResult
    from armpath.planning.tour import TourResult
    from armpath.planning.trace import AxisRule, TraceResult
    from armpath.scenes import Scene

#: What a task of ``armpath run`` may end in while the others still run: no plan found.
TASK_FAILURES = (UnreachableError, PlanningError, CollisionError)


def _mm(value: float | None, digits: int = 3) -> str:
    """A length in mm, or a dash when there was nothing to measure (null in the JSON)."""
    return "-" if value is None else f"{value:.{digits}f}"


def _clearance_text(c: dict[str, Any], proven: bool = False) -> str:
    """The clearance of a whole continuous motion in words (mm): the closest approach and what
    it is between, the links, the tool tip and the links to each other."""
    verdict = "certified" if c["certified"] else "NOT certified"
    if c["min_clearance_mm"] is None and c["min_self_clearance_mm"] is None:
        return f"no obstacles and no link pairs to keep apart; {verdict}"
    parts = []
    if c["min_clearance_mm"] is not None:
        bound = (
            f", proven >= {_mm(c['min_clearance_lower_bound_mm'])} mm"
            if proven and c["min_clearance_lower_bound_mm"] is not None
            else ""
        )
        where = "the start state" if c["during_command"] == 0 else f"command {c['during_command']}"
        parts.append(
            f"{_mm(c['min_clearance_mm'])} mm ({c['closest_part']} to {c['closest_obstacle']}, "
            f"{where}{bound})"
        )
        parts.append(f"links {_mm(c['min_body_clearance_mm'])} mm")
        if c["min_tool_tip_clearance_mm"] is not None:
            parts.append(f"tool tip {_mm(c['min_tool_tip_clearance_mm'])} mm (may touch)")
    else:
        parts.append("no obstacles")
    if c["min_self_clearance_mm"] is not None:
        parts.append(f"links to each other {_mm(c['min_self_clearance_mm'])} mm")
    return "; ".join(parts) + f"; whole continuous motion, {verdict}"


def _scene_text(name: str, wall: str | None) -> str:
    """The scene's name and, when it has a hollow workpiece, how its wall is measured (as
    text, not markup: a name may hold brackets)."""
    return escape(f"{name}; workpiece wall measured {wall}" if wall else name)


def _rejected_text(reasons: tuple[str, ...]) -> str:
    """Why fewer commands were not taken, each reason once: consecutive counts refused for
    the same reason joined into a range ("54-57 commands: every goal state ... in
    collision")."""
    groups: list[list[Any]] = []  # [first count, last count, reason], or [None, None, text]
    for text in reasons:
        m = re.fullmatch(r"(\d+) commands: (.*)", text, flags=re.DOTALL)
        if m is None:
            groups.append([None, None, text])
            continue
        n, why = int(m.group(1)), m.group(2)
        last = groups[-1] if groups else None
        if last is not None and last[0] is not None and last[2] == why and n == last[1] + 1:
            last[1] = n
            continue
        groups.append([n, n, why])
    parts = []
    for lo, hi, why in groups:
        if lo is None:
            parts.append(why)
        else:
            counts = str(lo) if lo == hi else f"{lo}-{hi}"
            parts.append(f"{counts} commands: {why}")
    return "; ".join(parts)


def _reach_summary(result: ReachResult, arm: SerialArm, scene: Scene) -> Table:
    from armpath.export import clearance_dict

    seq = result.sequence
    grid = seq.grid
    lb = result.lower_bound
    table = Table(title=escape(f"reach ({arm.name})"), show_header=False)
    table.add_column("quantity", style="bold")
    table.add_column("value")
    units = _units_text(grid.units)
    table.add_row("target", f"{_fmt(result.target_mm, 3)} mm")
    if result.orientation is not None and result.angle_rad is not None:
        described = result.orientation.describe()
        angle_deg = float(np.degrees(result.angle_rad))
        table.add_row("tool orientation", _orientation_text(described, angle_deg))
    table.add_row("start", f"{_fmt(grid.display(seq.start_ticks), 1)} {units}")
    if result.is_provably_fewest:
        claim = f"lower bound {lb.commands}: provably fewest"
    elif result.meets_bound:
        claim = f"bound {lb.commands} found over the solution family: fewest found"
    else:
        claim = f"lower bound {lb.commands}" + ("" if lb.proven else ", found over the family")
    table.add_row("commands", f"{result.n_commands}  ({claim})")
    if not result.meets_bound and result.fewer_commands_rejected:
        table.add_row("fewer commands", escape(_rejected_text(result.fewer_commands_rejected)))
    if result.method != "direct":
        table.add_row("method", f"{result.method} (every direct motion is blocked)")
    table.add_row(
        "tool point error", f"{result.error_mm:.4f} mm  (tolerance {result.tolerance_mm} mm)"
    )
    table.add_row("final joints", f"{_fmt(grid.display(seq.final_ticks), 1)} {units}")
    table.add_row("tool point", f"{_fmt(result.tip_mm, 4)} mm")
    span = np.abs(seq.final_ticks - seq.start_ticks) * grid.tick_display
    if grid.is_default:
        change = (
            f"{span.max(initial=0.0):.1f} {units} (least possible off the lattice "
            f"{lb.max_joint_change_deg:.2f} {units})"
        )
    else:  # the largest of each unit's joints (a SCARA's turns in deg, its quill in mm)
        parts = []
        for unit in dict.fromkeys(grid.units):
            k = max((i for i, u in enumerate(grid.units) if u == unit), key=lambda i: span[i])
            parts.append(f"{span[k]:.2f} {unit} (q{k + 1})")
        change = ", ".join(parts)
    table.add_row("largest joint change", change)
    table.add_row("min clearance", _clearance_text(clearance_dict(result.clearance), proven=True))
    wall = scene.wall_thickness
    table.add_row("scene", _scene_text(scene.name, wall.value if wall else None))
    return table


def _travel_unit(doc: dict[str, Any]) -> str:
    """The unit of a result's joint travel: ``deg``, or ``(deg, mm for q3)`` for an arm with a
    prismatic joint, whose travel adds its mm."""
    units = doc["units"]["joints"]
    slides = [f"q{i + 1}" for i, unit in enumerate(units) if unit == "mm"]
    return f"(deg, mm for {', '.join(slides)})" if slides else "deg"


def _write_reach(
    folder: OutputFolder,
    stem: str,
    result: ReachResult,
    arm: SerialArm,
    scene: Scene,
    animate: bool = False,
) -> None:
    from armpath.export import write_reach_files
    from armpath.viz.figures import plot_joint_angles, plot_motion_3d

    write_reach_files(folder, stem, result, arm, scene)
    title = (
        f"reach {_fmt(result.target_mm, 0)} mm: {commands_text(result.n_commands)}, "
        f"error {result.error_mm:.4f} mm"
    )
    plot_motion_3d(
        folder.file(f"{stem}_motion.png"), arm, scene, result.sequence, result.target_mm, title
    )
    plot_joint_angles(folder.file(f"{stem}_joints.png"), result.sequence, title)
    if animate:
        _animate_into(folder, stem, arm, scene, result.sequence, title, result.target_mm)


FromOption = Annotated[
    str | None,
    typer.Option(
        "--from",
        metavar="θ1 … θn",
        help="Start joint values, one per joint: deg (mm for prismatic joints), on the arm's "
        "lattice. Default: the arm's home pose (the seed arm: 0 -90 0 0 -90 0).",
        show_default=False,
    ),
]
ToolAxisOption = Annotated[
    str | None,
    typer.Option(
        "--tool-axis",
        metavar="X Y Z",
        help="Keep the tool's approach axis within --axis-tolerance of this world direction at "
        "the target.",
        show_default=False,
    ),
]
TraceToolAxisOption = Annotated[
    str | None,
    typer.Option(
        "--tool-axis",
        metavar="normal|X Y Z",
        help="Keep the tool's approach axis within --axis-tolerance of the surface's inward "
        "normal at each point ('normal': a torch kept near the normal), or of a fixed world "
        "direction, along the whole continuous motion of every pass. Default: any direction "
        "from outside the surface.",
        show_default=False,
    ),
]
WeldToolAxisOption = Annotated[
    str | None,
    typer.Option(
        "--tool-axis",
        metavar="normal|X Y Z",
        help="At each weld, keep the tool's approach axis within --axis-tolerance of the "
        "nearest surface's inward normal there ('normal': each weld within 5 mm of an "
        "obstacle's surface) or of a fixed world direction.",
        show_default=False,
    ),
]


def _direction(text: str, option: str) -> np.ndarray:
    return np.array(_numbers(text.replace(",", " ").split(), 3, f"{option} X Y Z"))


def axis_rule(tool_axis: str | None, axis_tolerance_deg: float | None) -> AxisRule | None:
    """The tool-axis rule of ``--tool-axis normal|X Y Z --axis-tolerance DEG`` on a surface."""
    from armpath.planning.trace import AxisRule

    refuse_alone("--axis-tolerance", axis_tolerance_deg, "--tool-axis", tool_axis)
    if tool_axis is None:
        return None
    names = ("--tool-axis", "--axis-tolerance")
    if tool_axis.strip() == "normal":
        return AxisRule.of("normal", axis_tolerance_deg, names)
    return AxisRule.of(_direction(tool_axis, "--tool-axis"), axis_tolerance_deg, names)


AxisToleranceOption = Annotated[
    float | None,
    typer.Option(
        "--axis-tolerance",
        help=f"Largest angle of the tool axis from --tool-axis, deg (default "
        f"{DEFAULT_AXIS_TOLERANCE_DEG:g}).",
        show_default=False,
    ),
]
PoseOption = Annotated[
    tuple[float, float, float] | None,
    typer.Option(
        "--pose",
        metavar="RX RY RZ",
        help="Reach a whole pose: the tool frame's rotation as a rotation vector, deg, kept "
        "within --angle-tolerance.",
        show_default=False,
    ),
]
AngleToleranceOption = Annotated[
    float | None,
    typer.Option(
        "--angle-tolerance",
        help=f"Largest rotation angle from --pose, deg (default {DEFAULT_ANGLE_TOLERANCE_DEG:g}).",
        show_default=False,
    ),
]
TaskModelOption = Annotated[
    str | None,
    typer.Option(
        "--model",
        help=f"The arm: a built-in model ({BUILTIN_NAMES}) or a robot file (.json D-H, .urdf). "
        "Default: the scene's \\[arm], else the seed arm.",
        show_default=False,
    ),
]


def orientation_rule(
    tool_axis: str | None,
    axis_tolerance_deg: float | None,
    pose_deg: tuple[float, float, float] | None,
    angle_tolerance_deg: float | None,
    approach: tuple[float, float, float] = (0.0, 0.0, 1.0),
) -> Orientation | None:
    """The orientation rule of ``--tool-axis``/``--axis-tolerance`` (for the tool's
    ``approach`` axis) or ``--pose``/``--angle-tolerance`` (at most one of them; a tolerance
    without its rule is refused, not ignored)."""
    from armpath.ik.target import AxisCone, PoseOrientation

    axis_tolerance_deg, angle_tolerance_deg = rule_tolerances(
        axis_tolerance_deg,
        angle_tolerance_deg,
        tool_axis,
        pose_deg,
        ("--tool-axis", "--axis-tolerance", "--pose", "--angle-tolerance"),
    )
    if tool_axis is not None:
        if tool_axis.strip() == "normal":
            raise InvalidInputError(
                "--tool-axis normal follows a surface along a curve (trace); give a direction "
                "X Y Z here"
            )
        return AxisCone(
            _direction(tool_axis, "--tool-axis"),
            np.radians(axis_tolerance_deg),
            np.asarray(approach),
        )
    if pose_deg is not None:
        from scipy.spatial.transform import Rotation

        rv = np.radians(_numbers([str(v) for v in pose_deg], 3, "--pose RX RY RZ (deg)"))
        return PoseOrientation(
            Rotation.from_rotvec(rv).as_matrix(), np.radians(angle_tolerance_deg)
        )
    return None  # fmt: skip


@app.command(context_settings=LOOSE)
def reach(
    target: Annotated[
        list[str] | None,
        typer.Argument(
            help="X Y Z of the target in mm. Default: the scene's \\[tasks.reach] target_mm.",
            show_default=False,
            metavar="X Y Z",
        ),
    ] = None,
    start: FromOption = None,
    model: TaskModelOption = None,
    tip_link: TipLinkOption = None,
    tool_axis: ToolAxisOption = None,
    axis_tolerance: AxisToleranceOption = None,
    pose: PoseOption = None,
    angle_tolerance: AngleToleranceOption = None,
    json_out: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write reach.json, reach.csv, reach.xlsx and PNG figures here."),
    ] = None,
    tolerance: Annotated[
        float | None,
        typer.Option(
            help="Largest tool point error accepted, mm. Default: the scene's \\[tasks.reach] "
            f"tolerance_mm, else {POINT_TOLERANCE_MM:g}.",
            show_default=False,
        ),
    ] = None,
    wall: WallOption = None,
    scene_file: SceneOption = None,
    link_radius: LinkRadiusOption = None,
    animate: AnimateOption = False,
    seed: SeedOption = 0,
    time_limit: TimeLimitOption = None,
) -> None:
    """Reach a point with the tool in the fewest commands, then the smallest error.

    The seed arm takes its closed-form solution family (the bound is a proof); any other arm,
    tool or orientation rule takes the search over its whole solution family. When every
    direct motion is blocked, the motion is planned around the obstacles instead (the
    summary's method says so).
    """
    from armpath.export import json_text, output_folder, reach_result_dict
    from armpath.planning.reach import ReachOptions, plan_reach

    with _cli_errors(time_limit):
        arm, scene = task_setup(model, scene_file, wall, link_radius, tip_link)
        if target:
            xyz = _point_mm(target, "target X Y Z (mm)")
        elif scene.reach_target_mm is not None:
            xyz = list(scene.reach_target_mm)
        else:
            raise InvalidInputError(
                f"give the target X Y Z (mm): scene {scene.source} names no [tasks.reach] target_mm"
            )
        start_ticks = joint_state(arm, start, "--from")
        rule = orientation_rule(tool_axis, axis_tolerance, pose, angle_tolerance, arm.approach_axis)
        options = ReachOptions(tolerance_mm=scene.tolerance_mm("reach", tolerance))
        _animate_needs_out(animate, out)
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            with progress("planning the reach ..."):
                result = plan_reach(
                    arm, scene.world, start_ticks, xyz, options, seed=seed, orientation=rule
                )
            if folder is not None:
                _write_reach(folder, "reach", result, arm, scene, animate)
        if json_out:
            typer.echo(json_text(reach_result_dict(result, arm, scene)), nl=False)
        else:
            out_console.print(_reach_summary(result, arm, scene))
            print_written(folder)


def _orientation_text(rule: dict[str, Any], angle_deg: float) -> str:
    """The angle reached from an orientation rule (its ``describe()``), with its tolerance:
    ``tool axis 16.787 deg from (0, 0, -1) (at most 20 deg)``."""
    if rule["type"] == "axis_cone":
        toward = ", ".join(f"{float(v) + 0.0:.4g}" for v in rule["direction"])
        what = f"tool axis {angle_deg:.3f} deg from ({toward})"
    else:
        what = f"tool frame {angle_deg:.3f} deg from the pose asked"
    return f"{what} (at most {rule['tolerance_deg']:g} deg)"


def _plan_summary(doc: dict[str, Any], title: str) -> Table:
    table = Table(title=escape(title), show_header=False)
    table.add_column("quantity", style="bold")
    table.add_column("value")
    m = doc["metrics"]
    if doc["lower_bound_commands"] is not None:
        count = f"{doc['n_commands']}  (direct-motion bound {doc['lower_bound_commands']})"
    else:
        count = (
            f"{doc['n_commands']}  (a direct motion to its goal state needs "
            f"{doc['direct_commands']}; armpath reach finds the fewest to the point and "
            "proves it where its listing of the lattice states near the point completes)"
        )
    table.add_row("commands", count)
    if "error_mm" in doc:
        table.add_row(
            "tool point error", f"{doc['error_mm']:.4f} mm  (tolerance {doc['tolerance_mm']} mm)"
        )
    if doc.get("tool_orientation"):
        rule = doc["tool_orientation"]
        table.add_row("tool orientation", _orientation_text(rule, rule["angle_deg"]))
    table.add_row("method", str(doc["method"]))
    table.add_row(
        "objectives",
        f"{commands_text(m['commands'])}, tool path {m['tip_path_mm']:.1f} mm, "
        f"energy (joint travel, weighted) {m['energy_deg']:.1f} {_travel_unit(doc)} "
        f"(objective: {doc['objective']})",
    )
    units = _units_text(tuple(doc["units"]["joints"]))
    table.add_row("final joints", f"{_fmt(doc['final_deg'], 1)} {units}")
    table.add_row("min clearance", _clearance_text(doc["clearance"]))
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
    orientation: Orientation | None = None,
) -> None:
    from armpath.export import plan_result_dict
    from armpath.planning.reach import plan_to_point

    with progress("planning ...") as say:
        plan = plan_to_point(
            arm, scene.world, start_ticks, xyz, tolerance, options, orientation, on_progress=say
        )
    doc = plan_result_dict(plan, arm, scene, options.objective.value, xyz, tolerance, orientation)
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
    from armpath.export import json_text, write_sequence_files

    if folder is not None:
        from armpath.viz.figures import plot_joint_angles, plot_motion_3d

        write_sequence_files(folder, stem, doc, arm, plan.sequence)
        title = f"{stem}: {commands_text(plan.sequence.n_commands)} ({plan.method})"
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
    model: TaskModelOption = None,
    tip_link: TipLinkOption = None,
    start: FromOption = None,
    to: Annotated[
        str | None,
        typer.Option(
            "--to",
            metavar="θ1 … θn",
            help="Goal joint values, one per joint: deg (mm for prismatic joints), on the "
            "arm's lattice.",
            show_default=False,
        ),
    ] = None,
    to_xyz: Annotated[
        tuple[float, float, float] | None,
        typer.Option("--to-xyz", metavar="X Y Z", help="Goal point of the tool, mm."),
    ] = None,
    tool_axis: ToolAxisOption = None,
    axis_tolerance: AxisToleranceOption = None,
    pose: PoseOption = None,
    angle_tolerance: AngleToleranceOption = None,
    objective: ObjectiveOption = Objective.COMMANDS,
    weights: Annotated[
        str | None,
        typer.Option(
            metavar="W1,…,Wn",
            help="Energy weights, one per joint, separated by commas (default all 1).",
            show_default=False,
        ),
    ] = None,
    tolerance: Annotated[
        float, typer.Option(help="Largest tool point error accepted with --to-xyz, mm.")
    ] = POINT_TOLERANCE_MM,
    json_out: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write plan.json, plan.csv, plan.xlsx and PNG figures here."),
    ] = None,
    wall: WallOption = None,
    link_radius: LinkRadiusOption = None,
    seed: SeedOption = 0,
    searches: Annotated[
        int,
        typer.Option(
            min=1,
            max=MAX_SEARCHES,
            help="Successful searches (seeds) to try when the direct motion is blocked; "
            "the best is kept.",
        ),
    ] = 1,
    animate: AnimateOption = False,
    time_limit: TimeLimitOption = None,
) -> None:
    """Plan a collision-free command sequence to a joint goal or a tool point.

    Obstacles and the clearance rule come from the scene file. The direct motion is used when
    it is clear; otherwise RRT-Connect with shortcuts finds a path, which is put on the command
    lattice and certified along its whole continuous motion. To a tool point, two straight
    motions through a waypoint in the openings of hollow obstacles compete too (the fewer
    commands win): the way into a hollow workpiece.
    """
    from armpath.export import output_folder, plan_result_dict
    from armpath.planning.motion import MotionOptions, plan_motion

    with _cli_errors(time_limit):
        if (to is None) == (to_xyz is None):
            raise InvalidInputError("give exactly one goal: --to θ1 … θn or --to-xyz X Y Z")
        _animate_needs_out(animate, out)
        arm, scene = task_setup(model, scene_file, wall, link_radius, tip_link)
        start_ticks = joint_state(arm, start, "--from")
        rule = orientation_rule(tool_axis, axis_tolerance, pose, angle_tolerance, arm.approach_axis)
        if rule is not None and to_xyz is None:
            raise InvalidInputError("--tool-axis and --pose go with --to-xyz")
        energy = None
        if weights is not None:
            energy = tuple(_numbers(weights.replace(",", " ").split(), arm.n_joints, "--weights"))
        options = MotionOptions(
            objective=objective,
            energy_weights=energy,
            seed=seed,
            searches=searches,
        )
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            if to_xyz is not None:
                xyz = np.array(_point_mm([str(v) for v in to_xyz], "--to-xyz X Y Z (mm)"))
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
                    rule,
                )
            else:
                goal = joint_state(arm, to, "--to")
                with progress("planning ...") as say:
                    result = plan_motion(
                        arm, scene.world, start_ticks, goal[None, :], options, on_progress=say
                    )
                doc = plan_result_dict(result, arm, scene, objective.value, None, None)
                _emit_plan(result, doc, arm, scene, folder, json_out, "plan", None, animate)
        if folder is not None and not json_out:
            print_written(folder)


def _bound_text(bound: dict[str, Any] | None, scope: str, missing: str = "not computed") -> str:
    """A lower bound of a trace or tour and the plan's gap to it, in one line (``missing``:
    what to say without one)."""
    from armpath.planning.bounds.carriage import estimate_is_named
    from armpath.report import MEETS_BOUND, bound_scope, plan_gap, unproven

    if bound is None:
        return missing
    sampling = bound.get("sampling") or {}
    estimate = ""
    family = sampling.get("family_estimate_commands")  # a carriage's, beside it
    plan = bound["commands"] + (bound["gap_commands"] or 0)
    if family is not None and estimate_is_named(family, plan):
        estimate = f"; the family's estimate (not proven) ~{math.ceil(family - 1e-9)}"
    if not bound.get("proven", True):
        return f"~{bound['commands']} commands ({unproven(bound)}; {scope}); {plan_gap(bound)}"
    if bound["gap_commands"] == 0:  # a proven bound the plan meets: no plan has fewer
        return f">= {bound['commands']} commands ({scope}, {bound_scope(bound)}); {MEETS_BOUND}"
    error = sampling.get("largest_error_on_path_commands")
    weak = (
        f"; weak: {error:.1f} commands of sampling error were taken off it (a larger "
        "--bound-samples lets the search split its samples finer)"
        if error is not None and error > 0.25 * max(bound["value_commands"], 1.0)
        else ""
    )
    return (
        f">= {bound['commands']} commands ({scope}, {bound_scope(bound)}){estimate}; "
        f"{plan_gap(bound)}{weak}"
    )


def _tour_summary(doc: dict[str, Any], bound_skipped: bool = False) -> Table:
    table = Table(title="spot welds", show_header=False)
    table.add_column("quantity", style="bold")
    table.add_column("value")
    table.add_row(
        "commands",
        f"{doc['n_commands']}  (bound for the chosen goal states and order: "
        f"{doc['goal_states_bound_commands']})",
    )
    if bound_skipped:
        missing = "not computed (--no-bound)"
    else:
        missing = f"not computed: {doc['no_bound_because']}"
    # --order given bounds that order alone (one ranked); a single weld has only one
    given = doc["orders_ranked"] == 1 and len(doc["targets"]) > 1
    scope = "the order given" if given else "every order"
    if doc["returns_to_start"]:
        scope += ", back to the start"
    table.add_row("lower bound", _bound_text(doc["lower_bound"], scope, missing))
    table.add_row("order", " → ".join(str(i) for i in doc["order"]))
    for v in doc["visits"]:
        table.add_row(
            f"  weld {_fmt(v['target'], 2)} mm",
            f"after command {v['after_command']}, error {v['error_mm']:.4f} mm",
        )
    if doc["returns_to_start"]:
        last = doc["visits"][-1]["after_command"] if doc["visits"] else 0
        table.add_row(
            "  back to the start",
            f"commands {last + 1}-{doc['n_commands']}"
            if doc["n_commands"] > last
            else "already there",
        )
    table.add_row(
        "largest error", f"{doc['error_mm']:.4f} mm  (tolerance {doc['tolerance_mm']} mm)"
    )
    table.add_row("min clearance", _clearance_text(doc["clearance"]))
    m = doc["metrics"]
    table.add_row(
        "objectives",
        f"{commands_text(m['commands'])}, tool path {m['tip_path_mm']:.1f} mm, "
        f"joint travel {m['energy_deg']:.1f} {_travel_unit(doc)}",
    )
    table.add_row("scene", _scene_text(doc["scene"]["name"], doc["wall_thickness"]))
    return table


def _write_tour(
    folder: OutputFolder,
    result: TourResult,
    doc: dict[str, Any],
    arm: SerialArm,
    scene: Scene,
    animate: bool = False,
) -> None:
    from armpath.export import write_sequence_files
    from armpath.viz.figures import plot_joint_angles, plot_motion_3d

    write_sequence_files(folder, "spotweld", doc, arm, result.sequence)
    title = (
        f"spot welds: {commands_text(result.n_commands)}, largest error "
        f"{result.max_error_mm:.4f} mm"
    )
    targets = np.array(doc["targets"])  # labelled 1..N as listed in the scene
    plot_motion_3d(folder.file("spotweld_motion.png"), arm, scene, result.sequence, targets, title)
    plot_joint_angles(
        folder.file("spotweld_joints.png"),
        result.sequence,
        title,
        marks=[(v.after_command, f"weld {v.target_index + 1}") for v in result.visits],
    )
    if animate:
        _animate_into(folder, "spotweld", arm, scene, result.sequence, title, targets)


@app.command()
def spotweld(
    order: Annotated[
        VisitOrder,
        typer.Option(
            help="Visiting order: auto (every order ranked by its lower bound, the best planned; "
            "up to 8 welds) or given (as listed)."
        ),
    ] = VisitOrder.AUTO,
    return_home: Annotated[
        bool, typer.Option("--return", help="Return to the initial pose at the end.")
    ] = False,
    json_out: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write spotweld.json, .csv, .xlsx and PNG figures here."),
    ] = None,
    tolerance: Annotated[
        float | None,
        typer.Option(
            help="Largest tool point error accepted at each weld, mm. Default: the scene's "
            f"\\[tasks.spotweld] tolerance_mm, else {POINT_TOLERANCE_MM:g}.",
            show_default=False,
        ),
    ] = None,
    objective: ObjectiveOption = Objective.COMMANDS,
    wall: WallOption = None,
    scene_file: SceneOption = None,
    model: TaskModelOption = None,
    tip_link: TipLinkOption = None,
    tool_axis: WeldToolAxisOption = None,
    axis_tolerance: AxisToleranceOption = None,
    link_radius: LinkRadiusOption = None,
    start: FromOption = None,
    seed: SeedOption = 0,
    bound: Annotated[
        bool,
        typer.Option(
            "--bound/--no-bound",
            help="Prove a lower bound on the commands of any tour over every order and goal "
            "configuration and report the gap (the seed's Task 3: about half its time; "
            "--no-bound: the plan and its goal states' bound only).",
        ),
    ] = True,
    bound_samples: BoundSamplesOption = None,
    pools: Annotated[
        bool,
        typer.Option(
            "--pools/--no-pools",
            help="Plan the orders whose shortest paths through the welds' clear goal "
            "configurations are shortest once more, through pools of goal states at every weld, "
            "each leg planned when a lazy shortest path over the pools needs it (the seed's "
            "Task 3: 121 commands rather than 126, 26 s rather than 12 s without the bound); "
            "--no-pools: the guided orders' goal states only.",
        ),
    ] = True,
    animate: AnimateOption = False,
    time_limit: TimeLimitOption = None,
) -> None:
    """Task 3: reach the scene's spot welds (the seed scene: on the workpiece's inner wall,
    through the open top), in the best order; any arm (--model or the scene's \\[arm])."""
    from armpath.export import json_text, output_folder, tour_result_dict
    from armpath.planning.motion import MotionOptions
    from armpath.tasks import spotweld_task

    with _cli_errors(time_limit):
        arm, scene = task_setup(model, scene_file, wall, link_radius, tip_link)
        start_ticks = None if start is None else joint_state(arm, start, "--from")
        options = MotionOptions(objective=objective, seed=seed)
        _animate_needs_out(animate, out)
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            with progress("planning the spot welds ...") as say:
                result = spotweld_task(
                    scene,
                    arm,
                    order,
                    return_home,
                    tolerance,
                    options,
                    on_progress=say,
                    tool_axis=axis_rule(tool_axis, axis_tolerance),
                    start_ticks=start_ticks,
                    bound=bound,
                    bound_samples=bound_samples,
                    pools=pools,
                )
            doc = tour_result_dict(result, arm, scene, objective.value)
            if folder is not None:
                _write_tour(folder, result, doc, arm, scene, animate)
        if json_out:
            typer.echo(json_text(doc), nl=False)
        else:
            out_console.print(_tour_summary(doc, bound_skipped=not bound))
            print_written(folder)


def _trace_summary(doc: dict[str, Any], bound_skipped: bool = False) -> Table:
    from armpath.report import arc_text, by_band, by_carriage

    table = Table(
        title=escape(f"trace {doc['curve']['definition'].get('name', 'curve')}"),
        show_header=False,
    )
    table.add_column("quantity", style="bold")
    table.add_column("value")
    transit = sum(t["commands"] for t in doc["transits"])
    table.add_row(
        "commands",
        f"{doc['n_commands']}  ({transit} moving onto the curve or between passes, "
        f"{doc['n_commands'] - transit} tracing)",
    )
    missing = (
        "not computed (--no-bound)"
        if bound_skipped
        else "none: the solution family has no member within the limits on a traced span"
    )
    bound = doc.get("lower_bound")
    # a carriage's travel and the band's arcs hold for any passes in any order, the family's
    # for one a span
    anywhere = bound is not None and (by_carriage(bound) or by_band(bound))
    scope = "any passes" if anywhere else "one pass per span"
    table.add_row("lower bound", _bound_text(bound, scope, missing))
    table.add_row("passes", str(len(doc["passes"])))
    for p in doc["pass_details"]:
        table.add_row(
            f"  states {p['states'][0]}-{p['states'][1]}",
            f"{arc_text(p, doc)} ({p['length_mm']:.2f} mm"
            + (", traced from its end" if p.get("direction") == "backward" else "")
            + f"), largest deviation {p['max_deviation_mm']:.4f} mm"
            + (f"; ends short: {p['ends_because']}" if p.get("ends_because") else ""),
        )
    cov = doc["coverage"]
    table.add_row(
        "covered",
        f"{coverage_text(cov)} ({coverage_percent_text(cov)}); curve {cov['curve_mm']:.2f} mm",
    )
    for u in doc.get("not_traced", []):
        table.add_row(
            "not traced",
            f"{arc_text(u, doc)} (reachable): {u['reason']}",
        )
    for u in doc["unreachable"]:
        table.add_row(
            "unreachable",
            f"{arc_text(u, doc)} ({u['length_mm']:.2f} mm), "
            f"from {_fmt(u['start_point_mm'], 2)} to {_fmt(u['end_point_mm'], 2)} mm: "
            f"{u['reason']}",
        )
    table.add_row(
        "largest deviation",
        f"{doc['max_deviation_mm']:.4f} mm (proven <= {doc['max_deviation_bound_mm']:.4f}; "
        f"tolerance {doc['tolerance_mm']} mm; continuous tool path)",
    )
    axis = doc.get("tool_axis")
    if axis is not None and axis["max_angle_deg"] is not None:
        against = "the surface normal" if axis["type"] == "normal" else "its direction"
        bound = (
            f"proven <= {axis['max_angle_bound_deg']:.3f} deg"
            if axis["max_angle_bound_deg"] is not None
            else "refined sampling"
        )
        table.add_row(
            "tool axis",
            f"at most {axis['max_angle_deg']:.3f} deg from {against} ({bound}; tolerance "
            f"{axis['tolerance_deg']:g} deg; continuous motion of every pass)",
        )
    table.add_row("min clearance", _clearance_text(doc["clearance"]))
    table.add_row("scene", _scene_text(doc["scene"]["name"], doc["wall_thickness"]))
    return table


def _write_trace(
    folder: OutputFolder,
    result: TraceResult,
    doc: dict[str, Any],
    arm: SerialArm,
    scene: Scene,
    animate: bool = False,
) -> None:
    from armpath.export import write_sequence_files
    from armpath.report import passes_text
    from armpath.viz.figures import plot_trace_3d, plot_trace_deviation

    write_sequence_files(folder, "trace", doc, arm, result.sequence)
    curve = result.curve
    title = (
        f"trace: {commands_text(result.n_commands)}, {passes_text(len(result.passes))}, "
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
        curve_name=curve.name,
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


def _curve_from_points(path: Path, closed: bool) -> Curve:
    """The polyline through the points (mm) of ``--curve``'s table, named after the file."""
    from armpath.budget import MAX_COORDINATE_MM
    from armpath.cli.tables import read_number_table
    from armpath.geometry.curves import Polyline

    _, points = read_number_table(
        path, "--curve", "curve points", MAX_CURVE_POINTS, 3, "x, y, z in mm"
    )
    name = f"--curve {path}"
    if points.shape[1] != 3:
        raise InvalidInputError(
            f"{name}: each row needs 3 values (x, y, z in mm), got {points.shape[1]}"
        )
    far = np.flatnonzero(np.abs(points).max(axis=1) > MAX_COORDINATE_MM)
    if far.size:
        raise InvalidInputError(
            f"{name}: point {far[0] + 1} lies beyond the largest coordinate accepted "
            f"({MAX_COORDINATE_MM:g} mm)"
        )
    try:
        return Polyline(path.stem or "curve", points, closed)
    except InvalidInputError as exc:
        raise InvalidInputError(f"{name}: {exc}") from None


@app.command()
def trace(
    tolerance: Annotated[
        float | None,
        typer.Option(
            help="Largest distance of the continuous tool path from the curve, mm. Default: the "
            f"scene's \\[tasks.trace] tolerance_mm, else {TRACE_TOLERANCE_MM:g}.",
            show_default=False,
        ),
    ] = None,
    json_out: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write trace.json, .csv, .xlsx and PNG figures here."),
    ] = None,
    wall: WallOption = None,
    scene_file: SceneOption = None,
    model: TaskModelOption = None,
    tip_link: TipLinkOption = None,
    tool_axis: TraceToolAxisOption = None,
    axis_tolerance: AxisToleranceOption = None,
    link_radius: LinkRadiusOption = None,
    start: FromOption = None,
    seed: SeedOption = 0,
    bound: Annotated[
        bool,
        typer.Option(
            "--bound/--no-bound",
            help="Prove a lower bound on the commands of any plan and report the gap "
            "(the seed's Task 2: about a third of its time; --no-bound: the plan only).",
        ),
    ] = True,
    bound_samples: BoundSamplesOption = None,
    curve_file: Annotated[
        Path | None,
        typer.Option(
            "--curve",
            help="Trace these points instead of the scene's curve: one 'x,y,z' row each, mm "
            "(CSV, or values separated by spaces; a first line of column names is skipped), "
            f"straight pieces between them; at most {MAX_CURVE_POINTS:,} points.",
            show_default=False,
        ),
    ] = None,
    scan_step: Annotated[
        float,
        typer.Option(
            "--scan-step",
            help="How far apart the curve's reachability is scanned, mm (a longer curve needs a "
            f"larger one: at most {MAX_SCAN_POINTS:,} points).",
        ),
    ] = 4.0,
    closed: Annotated[
        bool,
        typer.Option(
            "--closed/--open",
            help="With --curve: a closed curve (a piece from the last point back to the "
            "first) or an open one; points whose last repeats the first are closed either "
            "way.",
        ),
    ] = False,
    animate: AnimateOption = False,
    time_limit: TimeLimitOption = None,
) -> None:
    """Task 2: go once around the scene's curve (the crack), or --curve's points, with the
    tool, every reachable part, fewest passes and commands; report the unreachable arcs and
    why. Any arm (--model or the scene's \\[arm]); --tool-axis keeps the torch near the surface
    normal or a direction."""
    from armpath.export import json_text, output_folder, trace_result_dict
    from armpath.planning.motion import MotionOptions
    from armpath.planning.trace import TraceOptions
    from armpath.tasks import trace_task

    with _cli_errors(time_limit):
        if closed and curve_file is None:
            raise InvalidInputError("--closed closes the curve of --curve; give --curve")
        if not (math.isfinite(scan_step) and scan_step > 0.0):
            raise InvalidInputError(
                f"--scan-step must be a finite length > 0 mm, got {scan_step:g}"
            )
        curve = None if curve_file is None else _curve_from_points(curve_file, closed)
        arm, scene = task_setup(model, scene_file, wall, link_radius, tip_link)
        start_ticks = None if start is None else joint_state(arm, start, "--from")
        rule = axis_rule(tool_axis, axis_tolerance)
        options = TraceOptions(
            tolerance_mm=scene.tolerance_mm("trace", tolerance),
            scan_step_mm=scan_step,
            motion=MotionOptions(seed=seed),
            axis_rule=rule,
            bound=bound,
            bound_samples=bound_samples,
        )
        _animate_needs_out(animate, out)
        staged = output_folder(out) if out is not None else contextlib.nullcontext()
        with staged as folder:
            with progress("tracing the curve ...") as say:
                result = trace_task(scene, arm, options, say, start_ticks, curve=curve)
            doc = trace_result_dict(result, arm, scene)
            if folder is not None:
                _write_trace(folder, result, doc, arm, scene, animate)
        if json_out:
            typer.echo(json_text(doc), nl=False)
        else:
            out_console.print(_trace_summary(doc, bound_skipped=not bound))
            print_written(folder)


@app.command()
def run(
    out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("armpath-out"),
    scene_file: SceneOption = None,
    model: TaskModelOption = None,
    tip_link: TipLinkOption = None,
    wall: WallOption = None,
    link_radius: LinkRadiusOption = None,
    html: Annotated[
        bool, typer.Option("--html", help="Also write the report as summary.html.")
    ] = False,
    seed: SeedOption = 0,
    bound: Annotated[
        bool,
        typer.Option(
            "--bound/--no-bound",
            help="Prove the lower bounds of the trace and the tour and report the gaps "
            "(the seed tasks: about 40 % of the run; --no-bound: the plans only).",
        ),
    ] = True,
    bound_samples: BoundSamplesOption = None,
    pools: Annotated[
        bool,
        typer.Option(
            "--pools/--no-pools",
            help="Plan the tour's cheapest orders once more through pools of goal states, as "
            "armpath spotweld does (--no-pools: the seed tasks without the bound in two thirds "
            "of the time, Task 3 in 126 commands rather than 121).",
        ),
    ] = True,
    time_limit: TimeLimitOption = None,
) -> None:
    """Run a scene's tasks for its arm (default: the seed scene's three tasks: 1, reach the
    tool box; 2, trace the crack; 3, spot welds inside the workpiece; then the seed arm's blind
    zones). Writes each task's result (JSON, CSV, XLSX), figures and animations (GIF), and a
    one-page report summary.md. A task that finds no plan is reported there and the others'
    results are written; the run then ends with its error (exit 1); where no task finds one,
    nothing is written. So too where --time-limit runs out: the tasks finished by then are
    written, the rest reported as not finished."""
    from armpath.cli.workspace import _blind_zones, _write_blind_zones
    from armpath.export import output_folder, reach_result_dict, tour_result_dict, trace_result_dict
    from armpath.planning.bounds.search import check_max_samples
    from armpath.planning.motion import MotionOptions
    from armpath.planning.trace import TraceOptions
    from armpath.report import summary_html, summary_markdown
    from armpath.tasks import SEED_TASKS, reach_task, spotweld_task, trace_task

    with _cli_errors(time_limit):
        check_max_samples(bound_samples)  # before any task runs
        arm, scene = task_setup(model, scene_file, wall, link_radius, tip_link)
        titles = dict(SEED_TASKS)
        has = {
            "reach": scene.reach_target_mm is not None,
            "trace": scene.trace is not None,
            "spotweld": scene.spotweld is not None,
        }
        if not any(has.values()):
            raise InvalidInputError(
                f"scene {scene.source} defines no task: give it [tasks.reach], [tasks.trace] "
                "or [tasks.spotweld]"
            )
        seed_job = scene_file is None and model in (None, "seed")
        if not seed_job:
            titles = {
                "reach": f"Task 1: reach ({', '.join(f'{v:g}' for v in scene.reach_target_mm)}) mm"
                if scene.reach_target_mm is not None
                else "Task 1: reach",
                "trace": f"Task 2: trace the {scene.trace.curve.name}"
                if scene.trace is not None
                else "Task 2: trace",
                "spotweld": "Task 3: spot welds",
            }
        blind = None
        # the blind zones (the seed arm's and its workpiece's) are independent of the tasks:
        # they are computed on the other core meanwhile
        blind_job = (
            BackgroundJob(
                lambda: _blind_zones(
                    arm, scene, 5.0, 1_000_000, 3, seed, _background_say(), scan_step_mm=16.0
                )
            )
            if seed_job
            else None
        )

        def do_reach(folder: OutputFolder) -> dict[str, Any]:
            with progress(f"{titles['reach']} ..."):
                result = reach_task(scene, arm, seed=seed)
            _write_reach(folder, "reach", result, arm, scene, animate=True)
            return reach_result_dict(result, arm, scene)

        def do_trace(folder: OutputFolder) -> dict[str, Any]:
            with progress(f"{titles['trace']} ...") as say:
                options = TraceOptions(
                    tolerance_mm=scene.tolerance_mm("trace"),
                    motion=MotionOptions(seed=seed),
                    bound=bound,
                    bound_samples=bound_samples,
                )
                traced = trace_task(scene, arm, options, on_progress=say)
            doc = trace_result_dict(traced, arm, scene)
            _write_trace(folder, traced, doc, arm, scene, animate=True)
            return doc

        def do_spotweld(folder: OutputFolder) -> dict[str, Any]:
            with progress(f"{titles['spotweld']} ...") as say:
                tour = spotweld_task(
                    scene,
                    arm,
                    options=MotionOptions(seed=seed),
                    on_progress=say,
                    bound=bound,
                    bound_samples=bound_samples,
                    pools=pools,
                )
            doc = tour_result_dict(tour, arm, scene, Objective.COMMANDS.value)
            _write_tour(folder, tour, doc, arm, scene, animate=True)
            return doc

        # a task that finds no plan (out of reach, no clear motion) is reported and the others
        # run on: their results are written, then the run ends with the failure's error line.
        # Where the time limit runs out, the tasks finished by then are written, the one under
        # way leaves none of its files, and those after it are not run.
        failed: list[tuple[str, str]] = []
        unfinished: list[tuple[str, str]] = []
        ran_out: TimeLimitError | None = None
        docs: dict[str, dict[str, Any]] = {}
        try:
            with output_folder(out) as folder:
                for key, job in (
                    ("reach", do_reach),
                    ("trace", do_trace),
                    ("spotweld", do_spotweld),
                ):
                    if not has[key]:
                        continue
                    if ran_out is not None:
                        unfinished.append((titles[key], "not run: the time limit had run out"))
                        continue
                    before = set(folder.staged())
                    try:
                        docs[key] = job(folder)
                    except TASK_FAILURES as exc:
                        failed.append((titles[key], str(exc)))
                    except TimeLimitError as exc:
                        folder.unstage(set(folder.staged()) - before)
                        unfinished.append((titles[key], str(exc)))
                        ran_out = exc
                reach_doc, trace_doc, tour_doc = (
                    docs.get(key) for key in ("reach", "trace", "spotweld")
                )
                if not docs:
                    # no task found a plan: nothing is written (one reason said once)
                    if ran_out is not None:  # with the failures before it, if any
                        raise TimeLimitError("; ".join([*_no_plan_lines(failed), str(ran_out)]))
                    reasons = list(dict.fromkeys(why for _, why in failed))
                    raise PlanningError(
                        reasons[0]
                        if len(reasons) == 1
                        else "; ".join(f"{title}: {why}" for title, why in failed)
                    )
                if blind_job is not None and ran_out is not None:
                    unfinished.append(
                        ("Blind zones of the seed arm", "not run: the time limit had run out")
                    )
                elif blind_job is not None:
                    with progress("blind zones ...") as say:
                        say("blind zones: arm plane, meridian map and workpiece faces")
                        blind = blind_job.result()
                    _write_blind_zones(folder, blind)
                tasks = [
                    (titles[key], doc)
                    for key, doc in (
                        ("reach", reach_doc),
                        ("trace", trace_doc),
                        ("spotweld", tour_doc),
                    )
                    if doc is not None
                ]
                heading = "seed tasks" if seed_job else f"{arm.name} in scene {scene.name}"
                report = summary_markdown(
                    tasks,
                    blind.summary() if blind is not None else (),
                    [*folder.staged(), "summary.md", *(["summary.html"] if html else [])],
                    heading=heading,
                    failed=failed,
                    unfinished=unfinished,
                )
                folder.write_text("summary.md", report)
                if html:
                    folder.write_text("summary.html", summary_html(report))
        finally:
            if blind_job is not None:
                blind_job.cancel()  # (done by then, unless a task failed)
        _print_run(folder, scene, arm, reach_doc, trace_doc, tour_doc, blind, heading, seed_job)
        if failed or ran_out is not None:
            problems = _no_plan_lines(failed)
            problems += [f"{title}: {why}" for title, why in unfinished]
            message = (
                "; ".join(problems) + f" (the finished tasks' results are written to {folder.path})"
            )
            raise PlanningError(message) if ran_out is None else TimeLimitError(message)


def _no_plan_lines(failed: list[tuple[str, str]]) -> list[str]:
    """One line per task of ``run`` that found no plan (its title, why)."""
    return [f"{title} found no plan: {why}" for title, why in failed]


def _background_say() -> Callable[[str], None]:
    """Where a background job's progress goes: with ``-v`` timed lines on stderr as they
    happen (between the tasks' own), otherwise nowhere (the run reports the job when it
    waits for it)."""
    if not VERBOSE["on"]:
        return lambda _message: None
    started = time.monotonic()

    def say(message: str) -> None:
        elapsed = time.monotonic() - started
        err_console.print(f"armpath: [{elapsed:6.1f} s] {message}", markup=False, soft_wrap=True)

    return say


def _print_run(
    folder: OutputFolder,
    scene: Scene,
    arm: SerialArm,
    reach_doc: dict[str, Any] | None,
    trace_doc: dict[str, Any] | None,
    tour_doc: dict[str, Any] | None,
    blind: Any,
    heading: str,
    seed_job: bool,
) -> None:
    """The run's table of results on stdout and the files it wrote (``seed_job``: the seed
    scene's tasks, whose heading does not name the scene)."""
    from armpath.report import (
        ESTIMATE_NOTE,
        bound_cell,
        bound_scope,
        over_lattice,
        passes_text,
        proven,
        tip_and_links_text,
        uncovered_arcs,
    )

    written = folder.written
    wall = scene.wall_thickness
    table = Table(
        title=escape(
            f"armpath {__version__}: {heading}"
            + (f", scene {scene.name}" if seed_job else "")  # another run's heading names it
            + (f", wall thickness {wall.value}" if wall else "")
        )
    )
    for col in ("task", "commands", "lower bound", "error [mm]", "min clearance [mm]"):
        table.add_column(escape(col), justify="left" if col == "task" else "right")
    # the footnote * describes the trace's and the tour's bound, where one was computed
    bounded = [d for d in (trace_doc, tour_doc) if d is not None and d.get("lower_bound")]

    def starred(doc: dict[str, Any]) -> str:
        return f"{bound_cell(doc)}*" if doc.get("lower_bound") else bound_cell(doc)

    if reach_doc is not None:
        table.add_row(
            f"1 reach {_fmt(reach_doc['target'], 0)} mm",
            str(reach_doc["n_commands"]),
            bound_cell(reach_doc),
            f"{reach_doc['error_mm']:.4f}",
            _mm(reach_doc["min_clearance_mm"]),
        )
    if trace_doc is not None:
        table.add_row(
            f"2 trace the {trace_doc['curve']['definition'].get('name', 'curve')}, "
            f"{passes_text(len(trace_doc['passes']))}",
            str(trace_doc["n_commands"]),
            starred(trace_doc),
            f"{trace_doc['max_deviation_mm']:.4f} (deviation)",
            tip_and_links_text(trace_doc, "tip"),
        )
    if tour_doc is not None:
        table.add_row(
            f"3 spot welds, order {'-'.join(str(i) for i in tour_doc['order'])}",
            str(tour_doc["n_commands"]),
            f"{starred(tour_doc)}, {tour_doc['goal_states_bound_commands']}**",
            f"{tour_doc['error_mm']:.4f} (largest)",
            tip_and_links_text(tour_doc, "tip"),
        )
    out_console.print(table)
    if trace_doc is not None:
        cov = trace_doc["coverage"]
        out_console.print(
            "; ".join(
                [
                    f"Task 2: {coverage_text(cov)}",
                    "error column = largest deviation of the continuous tool path",
                    *(f"{what} {at} mm ({why})" for what, at, why in uncovered_arcs(trace_doc)),
                ]
            ),
            markup=False,
            soft_wrap=True,
        )
    if reach_doc is not None and not proven(reach_doc):
        out_console.print(f"~ Task 1: {ESTIMATE_NOTE}.", markup=False, soft_wrap=True)
    if trace_doc is not None or tour_doc is not None:
        tour_bound = None if tour_doc is None else tour_doc.get("lower_bound")
        notes = []
        if bounded:
            notes.append(
                "* Tasks 2 and 3: bound over every configuration of the arm that may be clear at "
                "the curve's points or the welds, obstacles ignored between them (trace: one pass "
                "per traced arc; tour: every order)"
                + (
                    f"; Task 3 over every order and {bound_scope(tour_bound)}."
                    if tour_bound is not None and over_lattice(tour_bound)
                    else "."
                )
            )
        if len(bounded) < sum(d is not None for d in (trace_doc, tour_doc)):
            notes.append("- no lower bound computed.")
        if tour_doc is not None:
            notes.append("** Task 3: direct motions between the chosen goal states of this order.")
        out_console.print(" ".join(notes), markup=False, soft_wrap=True)
    if blind is not None:
        for line in blind.summary():
            out_console.print(f"Blind zones: {line}", markup=False, soft_wrap=True)
    out_console.print(f"wrote to {folder.path.resolve()}:", markup=False)
    for path in written:
        out_console.print(f"  {path.name}", markup=False)
    if folder.removed:
        out_console.print(
            "removed (an earlier command's results in this folder): "
            + ", ".join(path.name for path in folder.removed),
            markup=False,
            soft_wrap=True,
        )
