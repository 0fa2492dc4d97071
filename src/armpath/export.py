"""Result files: JSON (SPEC section 6), CSV and XLSX command tables, atomic output folders.

Everything here is at the edge of the package: degrees and mm, units in every header.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from armpath import __version__
from armpath.commands import CommandSequence
from armpath.errors import ArmpathError, InvalidInputError, OutputError
from armpath.kinematics import tool_pose, tool_position
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.model.serialize import arm_to_dict
from armpath.schemas import SCHEMA_VERSION

if TYPE_CHECKING:  # the result types, for annotations only: writing a result needs no planner
    from armpath.ik.result import IKResult
    from armpath.ik.target import Orientation
    from armpath.planning.bounds import CommandBound
    from armpath.planning.motion import MotionPlan, PlanMetrics
    from armpath.planning.motion_check import MotionClearance
    from armpath.planning.reach import ReachResult
    from armpath.planning.tour import TourResult
    from armpath.planning.trace import TraceResult
    from armpath.scenes import Scene

FloatArray = NDArray[np.float64]


def units_dict(arm: SerialArm) -> dict[str, Any]:
    """The units of a result: lengths mm, angles deg, each joint's display unit, and what a
    command's numbers are (the arm's lattice)."""
    grid = arm.lattice
    if grid.is_default:
        commands = "ticks of 0.1 deg per joint, each in [-20, 20]"
    else:
        commands = (
            "integer ticks per joint, each within its joint's max_ticks_per_command; the tick "
            "of each joint is model.lattice.tick (deg or mm)"
        )
    return {"length": "mm", "angle": "deg", "joints": list(grid.units), "commands": commands}


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _deg_or_none(x: float | None) -> float | None:
    return None if x is None else float(np.degrees(x))


def model_dict(arm: SerialArm) -> dict[str, Any]:
    """The model's name, numbers, joint limits (deg; null = unlimited), command lattice, and
    its whole definition (:func:`~armpath.model.serialize.arm_to_dict`: a result replays with
    the same arm anywhere)."""
    limits: list[list[float] | None] = []
    for j in arm.joints:
        if not j.is_limited:
            limits.append(None)
        elif j.kind is JointKind.REVOLUTE:
            limits.append([float(np.degrees(j.limits[0])), float(np.degrees(j.limits[1]))])
        else:
            limits.append([float(j.limits[0]), float(j.limits[1])])
    return {
        "name": arm.name,
        "parameters": dict(arm.parameters),
        "joint_limits_deg": limits,
        "length_unit": arm.length_unit,
        "lattice": arm.lattice.describe(),
        "definition": arm_to_dict(arm),
    }


def clearance_dict(c: MotionClearance) -> dict[str, Any]:
    """The clearance of a whole motion; a clearance with nothing to measure it against (no
    obstacle, no pair of links) is null, and so are its part and obstacle."""
    return {
        "min_clearance_mm": _finite_or_none(c.min_clearance),
        "min_clearance_lower_bound_mm": _finite_or_none(c.min_clearance_lower_bound),
        "min_body_clearance_mm": _finite_or_none(c.min_body_clearance),
        "min_tool_tip_clearance_mm": _finite_or_none(c.min_tip_clearance),
        "min_self_clearance_mm": _finite_or_none(c.min_self_clearance),
        "certified": c.certified_ok,
        "closest_part": c.worst_part or None,
        "closest_obstacle": c.worst_obstacle or None,
        "during_command": c.worst_command,
        "configurations_evaluated": c.evaluations,
        "method": (
            "continuous motion (synchronous linear interpolation): bisection with a certified "
            "bound from the largest displacement of any arm point between samples"
        ),
    }


def _document_head(task: str, arm: SerialArm, scene: Scene) -> dict[str, Any]:
    """Fields every result document starts with: task, version, model, scene, units."""
    wall = scene.wall_thickness
    return {
        "task": task,
        "schema_version": SCHEMA_VERSION,
        "armpath_version": __version__,
        "model": model_dict(arm),
        "scene": scene.describe(),
        "wall_thickness": wall.value if wall else None,
        "units": units_dict(arm),
    }


def reach_result_dict(result: ReachResult, arm: SerialArm, scene: Scene) -> dict[str, Any]:
    """The JSON document of a reach plan (SPEC section 6)."""
    seq = result.sequence
    lb = result.lower_bound
    return {
        **_document_head("reach", arm, scene),
        "initial_deg": seq.grid.display(seq.start_ticks).tolist(),
        "commands": seq.commands.tolist(),
        "final_deg": seq.grid.display(seq.final_ticks).tolist(),
        "target": result.target_mm.tolist(),
        "tip": result.tip_mm.tolist(),
        "error_mm": result.error_mm,
        "tolerance_mm": result.tolerance_mm,
        "n_commands": result.n_commands,
        "lower_bound_commands": lb.commands,
        "provably_fewest": result.is_provably_fewest,
        "meets_bound": result.meets_bound,
        "tool_orientation": None
        if result.orientation is None
        else {
            **result.orientation.describe(),
            "angle_deg": None if result.angle_rad is None else float(np.degrees(result.angle_rad)),
        },
        "fewer_commands_rejected": list(result.fewer_commands_rejected),
        "method": result.method,
        "lower_bound": {
            "commands": lb.commands,
            "max_joint_change_deg": lb.max_joint_change_deg,
            "exact_max_joint_change_deg": lb.exact_max_joint_change_deg,
            "configuration_deg": list(lb.configuration_deg),
            "method": lb.method,
            "proven": lb.proven,
        },
        "min_clearance_mm": _finite_or_none(result.clearance.min_clearance),
        "clearance": clearance_dict(result.clearance),
        "search": {
            "lattice_states_examined": result.lattice_states_examined,
            "motions_checked": result.motion_checks,
        },
    }


def metrics_dict(m: PlanMetrics) -> dict[str, Any]:
    return {
        "commands": m.commands,
        "tip_path_mm": m.tip_path_mm,
        "energy_deg": m.energy_deg,
        "joint_travel_deg": list(m.joint_travel_deg),
    }


def _sequence_fields(seq: CommandSequence) -> dict[str, Any]:
    return {
        "initial_deg": seq.grid.display(seq.start_ticks).tolist(),
        "commands": seq.commands.tolist(),
        "final_deg": seq.grid.display(seq.final_ticks).tolist(),
        "n_commands": seq.n_commands,
    }


def _welds_from(scene: Scene) -> str:
    """Where the weld points come from (the scene's [tasks.spotweld])."""
    spec = scene.spotweld
    if spec is None or spec.points_mm is not None:
        return "the 3-D points given"
    if spec.surface == "outer":
        return f"outer face of {spec.workpiece}, above each xy point"
    return f"inner surface of {spec.workpiece}, under the wall_thickness convention"


def _orientation_met(
    arm: SerialArm, rule: Orientation | None, target_mm: Any, q: FloatArray
) -> dict[str, Any] | None:
    """The orientation rule at a target and the angle the tool meets it with at ``q`` (deg), or
    None without a rule (as the reach result's ``tool_orientation``)."""
    from armpath.ik.target import ToolTarget

    if rule is None:
        return None
    R = tool_pose(arm, q)[:3, :3]
    angle = ToolTarget(np.asarray(target_mm, dtype=np.float64), rule).angles(R)
    return {**rule.describe(), "angle_deg": float(np.degrees(angle))}


def tour_result_dict(
    result: TourResult, arm: SerialArm, scene: Scene, objective: str
) -> dict[str, Any]:
    """The JSON document of a spot-weld tour (the reach schema plus targets and visits)."""
    seq = result.sequence
    states = seq.states_joint()
    tip = tool_position(arm, states[-1])
    return {
        **_document_head("spotweld", arm, scene),
        "z_from": _welds_from(scene),
        **_sequence_fields(seq),
        "targets": [list(v.target_mm) for v in sorted(result.visits, key=lambda v: v.target_index)],
        "order": [v.target_index + 1 for v in result.visits],
        "visits": [
            {
                "target": list(v.target_mm),
                "after_command": v.after_command,
                "error_mm": v.error_mm,
                "tool_orientation": _orientation_met(
                    arm,
                    None if result.orientations is None else result.orientations[v.target_index],
                    v.target_mm,
                    states[v.after_command],
                ),
            }
            for v in result.visits
        ],
        "returns_to_start": result.returns_to_start,
        "tip": tip.tolist(),
        "error_mm": result.max_error_mm,
        "tolerance_mm": result.tolerance_mm,
        "objective": objective,
        "metrics": metrics_dict(result.metrics),
        "lower_bound_commands": None if result.lower_bound is None else result.lower_bound.commands,
        "lower_bound": _bound_dict(result.lower_bound, seq.n_commands),
        "no_bound_because": result.no_bound_because,
        "goal_states_bound_commands": result.order_lower_bounds[result.order],
        "goal_states_bound_method": (
            "for the chosen order: fewest commands of direct motions (obstacles ignored) "
            "through one of the candidate goal states per target (what ranks the orders); a "
            "bound for these goal states, not over every configuration"
        ),
        "orders_ranked": len(result.order_lower_bounds),
        "orders": [
            {
                "order": [i + 1 for i in o],
                "lower_bound_commands": b,
                "family_bound_commands": result.order_family_bounds.get(o),
                "planned_commands": result.orders_planned.get(o),
                "not_planned_because": result.orders_not_planned.get(o),
            }
            for o, b in sorted(result.order_lower_bounds.items(), key=lambda kv: (kv[1], kv[0]))
            if o in result.orders_planned or o in result.orders_not_planned
        ],
        "legs": [
            {
                "commands": leg.sequence.n_commands,
                "direct_commands": leg.direct_commands,
                "method": leg.method,
                "search_samples": leg.searched_samples,
            }
            for leg in result.legs
        ],
        "min_clearance_mm": _finite_or_none(result.clearance.min_clearance),
        "clearance": clearance_dict(result.clearance),
    }


def fk_document(arm: SerialArm, q: FloatArray) -> dict[str, Any]:
    """The forward kinematics of one joint state ``q`` (rad / model units) as ``armpath fk
    --json`` prints it: the joint values (deg, mm), the arm's points and the tool point (mm),
    the tool pose (4x4, mm), and warnings (joint limits; the seed arm below its table)."""
    from armpath.kinematics import landmark_positions

    pts = landmark_positions(arm, q)
    pose = tool_pose(arm, q)
    warnings = []
    try:
        arm.check_limits(q, what="pose")
    except ArmpathError as exc:
        warnings.append(str(exc))
    if arm.name == "seed" and np.min(pts[1:, 2]) < 0:
        warnings.append("part of the arm is below the table (z < 0)")
    return {
        "model": arm.name,
        "joints": [float(v) for v in arm.lattice.joint_display(q)],
        "points": {n: [float(c) for c in p] for n, p in zip(arm.landmark_names, pts, strict=True)},
        "tip": [float(c) for c in pose[:3, 3]],
        "pose": [[float(c) for c in row] for row in pose],
        "units": {"length": "mm", "angle": "deg", "joints": list(arm.lattice.units)},
        "warnings": warnings,
    }


def ik_document(arm: SerialArm, result: IKResult, target: FloatArray, pose: bool) -> dict[str, Any]:
    """The solutions of ``target`` (a 4x4 pose, or with ``pose`` False a point, mm) as
    ``armpath ik --json`` prints them: joint values in deg (mm), residuals, flags, and why
    there is none (``count`` 0)."""
    inside: Any = result.within_limits if result.within_limits is not None else []
    return {
        "model": arm.name,
        "method": result.method,
        "target": (
            {"pose": [[float(c) for c in r] for r in target]}
            if pose
            else {"position": [float(c) for c in target]}
        ),
        "count": result.count,
        "family_dimension": result.family_dimension,
        "solutions": [[float(v) for v in s] for s in arm.lattice.joint_display(result.solutions)],
        "residuals": [
            {"position_mm": float(p), "rotation_deg": float(np.degrees(r))}
            for p, r in zip(result.position_residual, result.rotation_residual_rad, strict=True)
        ],
        "within_limits": [bool(v) for v in inside],
        "near_double": [bool(v) for v in result.near_double],
        "near_singular": [bool(v) for v in result.near_singular],
        "reason": result.reason,
        "units": {"length": "mm", "angle": "deg", "joints": list(arm.lattice.units)},
    }


def _bound_dict(bound: CommandBound | None, commands: int) -> dict[str, Any] | None:
    """A lower bound, how it was computed, and the plan's gap to it (commands and percent of
    the bound)."""
    if bound is None:
        return None
    gap = commands - bound.commands
    return {
        **bound.describe(),
        "gap_commands": gap,
        "gap_percent": round(100.0 * gap / bound.commands, 2) if bound.commands else None,
    }


def trace_result_dict(result: TraceResult, arm: SerialArm, scene: Scene) -> dict[str, Any]:
    """The JSON document of a traced curve (the reach schema plus the curve, passes, coverage).

    Arc lengths are measured along the curve from its start; an arc of a closed curve may end
    past the curve's length (it runs on through the start).
    """
    seq = result.sequence
    curve = result.curve
    reach = result.reachability
    L = curve.length
    s_dense = np.linspace(0.0, L, 2001)
    tip = tool_position(arm, seq.states_joint()[-1])

    def point(s: float) -> list[float]:
        return [float(x) for x in curve.at_arc_length(s)]

    covered = result.covered_mm
    reachable = reach.reachable_mm
    return {
        **_document_head("trace", arm, scene),
        **_sequence_fields(seq),
        "tip": tip.tolist(),
        "tolerance_mm": result.tolerance_mm,
        "curve": {
            "definition": curve.describe(),
            "length_mm": L,
            "closed": curve.closed,
            "arc_length_mm": s_dense.tolist(),
            "points_mm": curve.at_arc_length(s_dense).tolist(),
        },
        "surface": reach.surface,
        "passes": [[p.first, p.last] for p in result.passes],
        "pass_details": [
            {
                "states": [p.first, p.last],
                "commands": p.last - p.first,
                "start_mm": p.start_mm,
                "end_mm": p.end_mm,
                "length_mm": p.covered_mm,
                "direction": "backward" if p.backward else "forward",
                "max_deviation_mm": p.max_deviation_mm,
                "max_deviation_bound_mm": p.max_deviation_bound_mm,
                "ends_because": p.ends_because,
            }
            for p in result.passes
        ],
        "transits": [
            {"states": [t.first, t.last], "commands": t.last - t.first, "method": t.method}
            for t in result.transits
        ],
        "covered": [{"start_mm": p.start_mm, "end_mm": p.end_mm} for p in result.passes],
        "lower_bound_commands": None if result.lower_bound is None else result.lower_bound.commands,
        "lower_bound": _bound_dict(result.lower_bound, seq.n_commands),
        "not_traced": [
            {"start_mm": a.start_mm, "end_mm": a.end_mm, "reason": why}
            for a, why in result.not_traced
        ],
        "reachable": [
            {"start_mm": a.start_mm, "end_mm": a.end_mm, "length_mm": a.length_mm}
            for a in reach.reachable
        ],
        "unreachable": [
            {
                "start_mm": a.start_mm,
                "end_mm": a.end_mm,
                "length_mm": a.length_mm,
                "start_point_mm": point(a.start_mm),
                "end_point_mm": point(a.end_mm),
                "reason": a.reason,
                "blocked_by": list(a.blocked_by),
                "limiting_at_start": list(a.limiting_at_start),
                "limiting_at_end": list(a.limiting_at_end),
            }
            for a in reach.unreachable
        ],
        "reachability_method": (
            f"solution family searched at every {reach.scan_s_mm[1] - reach.scan_s_mm[0]:.2f} mm "
            f"of arc length; ends of unreachable arcs bisected to {reach.resolution_mm:g} mm"
        ),
        "max_deviation_mm": result.max_deviation_mm,
        "max_deviation_bound_mm": result.max_deviation_bound_mm,
        "tool_axis": None
        if result.axis_rule is None
        else {
            **result.axis_rule.describe(),
            "max_angle_deg": _deg_or_none(result.max_axis_angle_rad),
            "max_angle_bound_deg": _deg_or_none(result.max_axis_angle_bound_rad),
            "method": (
                "angle of the tool's approach axis from the rule's axis over the continuous "
                "motion of every pass: "
                + (
                    "largest instant of samples every 1/32 command, refined (the surface normal "
                    "turns with the tool point: no proven bound)"
                    if result.axis_rule.normal
                    else "branch and bound with the tool frame's largest turning rate (proven)"
                )
            ),
        },
        "deviation_method": (
            "distance from the fingertip to the curve over the continuous motion of every pass: "
            "branch and bound with the fingertip's largest speed (proven bound)"
        ),
        "coverage": {
            "covered_mm": covered,
            "reachable_mm": reachable,
            "curve_mm": L,
            "of_reachable": result.covered_reachable_mm / reachable if reachable > 0 else 0.0,
            "of_curve": covered / L,
        },
        "metrics": metrics_dict(result.metrics),
        "min_clearance_mm": _finite_or_none(result.clearance.min_clearance),
        "clearance": clearance_dict(result.clearance),
    }


def plan_result_dict(
    plan: MotionPlan,
    arm: SerialArm,
    scene: Scene,
    objective: str,
    target_mm: FloatArray | None,
    tolerance_mm: float | None,
    orientation: Orientation | None = None,
) -> dict[str, Any]:
    """The JSON document of a general motion plan (``armpath plan``); with an
    ``orientation`` rule of the tool at the target, the rule and the angle reached."""
    seq = plan.sequence
    tip = tool_position(arm, seq.states_joint()[-1])
    doc: dict[str, Any] = {
        **_document_head("plan", arm, scene),
        **_sequence_fields(seq),
        "tip": tip.tolist(),
        "objective": objective,
        "metrics": metrics_dict(plan.metrics),
        "direct_commands": plan.direct_commands,
        # a joint goal's straight motion bounds every plan to it; a point's goal states are a
        # few of the lattice states at the point, so the direct motion to them bounds nothing
        "lower_bound_commands": plan.direct_commands if target_mm is None else None,
        "method": plan.method,
        "search_samples": plan.searched_samples,
        "min_clearance_mm": _finite_or_none(plan.clearance.min_clearance),
        "clearance": clearance_dict(plan.clearance),
    }
    if target_mm is not None:
        doc["target"] = np.asarray(target_mm).tolist()
        doc["error_mm"] = float(np.linalg.norm(tip - target_mm))
        doc["tolerance_mm"] = tolerance_mm
        doc["tool_orientation"] = _orientation_met(
            arm, orientation, target_mm, seq.states_joint()[-1]
        )
    return doc


def write_sequence_files(
    folder: OutputFolder, stem: str, doc: dict[str, Any], arm: SerialArm, seq: CommandSequence
) -> None:
    """Write ``stem.json``, ``stem.csv`` and ``stem.xlsx`` of any result document."""
    for suffix in RESULT_FILE_SUFFIXES:
        write_result_file(folder, f"{stem}{suffix}", doc, arm, seq)


#: The files a result is written as: its JSON document, its command table (CSV) and both as
#: a workbook (the command table and a summary sheet).
RESULT_FILE_SUFFIXES = (".json", ".csv", ".xlsx")


def write_result_file(
    folder: OutputFolder, name: str, doc: dict[str, Any], arm: SerialArm, seq: CommandSequence
) -> None:
    """Write the result document ``doc`` as ``name`` in ``folder``, by its suffix (one of
    :data:`RESULT_FILE_SUFFIXES`)."""
    suffix = Path(name).suffix.lower()
    if suffix == ".json":
        folder.write_text(name, json_text(doc))
        return
    if suffix not in RESULT_FILE_SUFFIXES:
        raise InvalidInputError(
            f"a result is written as {', '.join(RESULT_FILE_SUFFIXES)}, got {name!r}"
        )
    header, rows = command_table(arm, seq)
    if suffix == ".csv":
        folder.write_text(name, csv_text(header, rows))
    else:
        write_xlsx(
            folder.file(name),
            {"commands": (header, rows), "summary": (["quantity", "value"], summary_rows(doc))},
        )


def command_table(arm: SerialArm, seq: CommandSequence) -> tuple[list[str], list[list[Any]]]:
    """Header and rows of the command table (SPEC section 6): one row per command."""
    n = arm.n_joints
    header = (
        ["step"]
        + [f"d{i + 1}_ticks" for i in range(n)]
        + [f"theta{i + 1}_{u}" for i, u in enumerate(seq.grid.units)]
        + ["tip_x_mm", "tip_y_mm", "tip_z_mm"]
    )
    states = seq.states()[1:]
    tips = tool_position(arm, seq.grid.to_joint(states)) if len(states) else np.zeros((0, 3))
    degs = seq.grid.display(states)
    rows = [
        [
            k + 1,
            *map(int, seq.commands[k]),
            *map(float, degs[k]),
            *(round(float(v), 6) for v in tips[k]),
        ]
        for k in range(seq.n_commands)
    ]
    return header, rows


def csv_text(header: list[str], rows: list[list[Any]]) -> str:
    lines = [",".join(header)]
    lines += [",".join(_csv_cell(v) for v in row) for row in rows]
    return "\n".join(lines) + "\n"


def _csv_cell(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.10g}"
    return str(v)


def write_xlsx(path: Path, sheets: dict[str, tuple[list[str], list[list[Any]]]]) -> None:
    """Write tables to an XLSX workbook, one sheet each (bold header row, frozen), row by row
    (a workbook held whole took 2 GB and 52 s for 450,000 commands)."""
    from openpyxl import Workbook
    from openpyxl.cell import WriteOnlyCell
    from openpyxl.styles import Font

    wb = Workbook(write_only=True)
    bold = Font(bold=True)
    for name, (header, rows) in sheets.items():
        ws = wb.create_sheet(title=name[:31])
        ws.freeze_panes = "A2"
        head = []
        for value in header:
            cell = WriteOnlyCell(ws, value=value)
            cell.font = bold
            head.append(cell)
        ws.append(head)
        for row in rows:
            ws.append(row)
    wb.save(path)


def summary_rows(doc: dict[str, Any]) -> list[list[Any]]:
    """Key/value rows of a result document's scalar and short-list fields, floats tidied as in
    the JSON (:func:`_tidy`: 75.0, not 75.00000000000006)."""
    rows: list[list[Any]] = []
    for key, value in _tidy(doc).items():
        if isinstance(value, bool | int | float | str) or value is None:
            rows.append([key, value])
        elif (
            isinstance(value, list)
            and len(value) <= 6
            and all(isinstance(v, int | float) for v in value)
        ):
            rows.append([key, ", ".join(f"{v:g}" for v in value)])
    return rows


#: Significant digits of the floats written to result files: enough for a nanometre in a
#: kilometre, few enough to drop binary noise (29.999999999999996 is written 30.0).
JSON_DIGITS = 12


def _tidy(value: Any) -> Any:
    """``value`` with every float rounded to :data:`JSON_DIGITS` significant digits and every
    non-finite float (no obstacle to measure against) replaced by null."""
    if isinstance(value, float | np.floating):
        x = float(value)
        return float(f"{x:.{JSON_DIGITS}g}") if np.isfinite(x) else None
    if isinstance(value, dict):
        return {k: _tidy(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_tidy(v) for v in value]
    if isinstance(value, np.ndarray):
        return _tidy(value.tolist())
    if isinstance(value, np.integer):
        return int(value)
    return value


def json_line(doc: dict[str, Any]) -> str:
    """``doc`` as one line of JSON, floats tidied like :func:`json_text`."""
    return json.dumps(_tidy(doc), allow_nan=False)


def json_text(doc: dict[str, Any]) -> str:
    """A result document as JSON text: floats tidied (see :func:`_tidy`), never NaN or inf."""
    return json.dumps(_tidy(doc), indent=2, allow_nan=False) + "\n"


#: The file in an output folder that lists what armpath wrote there last.
MANIFEST = ".armpath-files"


class OutputFolder:
    """Stage result files in a temporary folder, then move them into place together.

    The temporary folder is created next to the destination at construction, so an unwritable
    destination fails *before* any computation; on error nothing is left behind.
    """

    def __init__(self, path: str | Path, prune: bool = True) -> None:
        self.path = Path(path).expanduser()
        self.prune = prune
        if self.path.exists() and not self.path.is_dir():
            raise OutputError(f"output folder {self.path} exists and is not a folder")
        anchor = self.path
        while not anchor.exists():
            anchor = anchor.parent
        if not anchor.is_dir():
            raise OutputError(f"cannot create output folder {self.path}: {anchor} is not a folder")
        try:
            self._staging = Path(tempfile.mkdtemp(prefix=".armpath-", dir=anchor))
        except OSError as exc:
            raise OutputError(
                f"output folder {self.path} is not writable: no folder can be made in "
                f"{anchor} ({exc.strerror})"
            ) from None
        self.written: list[Path] = []
        #: files of an earlier run the commit removed (see :meth:`commit`)
        self.removed: list[Path] = []

    def file(self, name: str) -> Path:
        """Path inside the staging folder to write ``name`` to."""
        return self._staging / name

    def write_text(self, name: str, text: str) -> None:
        self.file(name).write_text(text, encoding="utf-8")

    def staged(self) -> list[str]:
        """Names of the files staged so far."""
        return sorted(p.name for p in self._staging.iterdir())

    def unstage(self, names: Iterable[str]) -> None:
        """Drop the staged files ``names`` (a task cut short leaves none of its files)."""
        for name in names:
            self.file(name).unlink(missing_ok=True)

    def commit(self) -> list[Path]:
        """Move every staged file into the destination folder; returns their final paths.

        With ``prune`` (a command's whole output folder), files an earlier armpath run wrote
        into the same folder (listed in its :data:`MANIFEST`) that this run did not write again
        are removed (listed in :attr:`removed`), so the folder never mixes two runs' results;
        files armpath did not write are left alone. Without it (one file written beside
        others: an animation, an HTML page) nothing else is touched.
        """
        try:
            self.path.mkdir(parents=True, exist_ok=True)
            names = sorted(p.name for p in self._staging.iterdir())
            for name in names:  # a file moved into place replaces what is there: only files
                there = self.path / name
                if there.is_symlink() or (there.exists() and not there.is_file()):
                    raise OutputError(
                        f"{there} exists and is not a regular file (a link, a device, a pipe "
                        "or a folder): armpath writes a file by replacing it; give another path"
                    )
            earlier = self._earlier_files() if self.prune else set()
            for name in names:
                os.replace(self._staging / name, self.path / name)
            for name in sorted(earlier - set(names)):
                gone = self.path / name
                if gone.is_file():
                    gone.unlink()
                    self.removed.append(gone)
            if self.prune:
                (self.path / MANIFEST).write_text("\n".join(names) + "\n", encoding="utf-8")
            self.written = [self.path / n for n in names]
        except OSError as exc:
            raise OutputError(
                f"cannot write to output folder {self.path}: {exc.strerror}"
            ) from None
        finally:
            self.discard()
        return self.written

    def _earlier_files(self) -> set[str]:
        """Names an earlier run listed in the folder's manifest (plain names only)."""
        try:
            text = (self.path / MANIFEST).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            return set()
        return {n for n in text.split() if n and Path(n).name == n and n != MANIFEST}

    def discard(self) -> None:
        shutil.rmtree(self._staging, ignore_errors=True)


@contextlib.contextmanager
def output_folder(path: str | Path, prune: bool = True) -> Iterator[OutputFolder]:
    """Context manager: stage files, commit on success, discard on any exception (``prune``:
    see :meth:`OutputFolder.commit`)."""
    folder = OutputFolder(path, prune)
    try:
        yield folder
    except OSError as exc:  # a full disk or an unwritable file while writing the results
        folder.discard()
        where = f" ({Path(exc.filename).name})" if exc.filename else ""
        raise OutputError(
            f"cannot write the results{where}: {exc.strerror or exc}; nothing was written to "
            f"{folder.path}"
        ) from None
    except BaseException:
        folder.discard()
        raise
    folder.commit()


def write_reach_files(
    folder: OutputFolder,
    stem: str,
    result: ReachResult,
    arm: SerialArm,
    scene: Scene,
) -> dict[str, Any]:
    """Write ``stem.json``, ``stem.csv`` and ``stem.xlsx`` into ``folder``; returns the JSON."""
    doc = reach_result_dict(result, arm, scene)
    write_sequence_files(folder, stem, doc, arm, result.sequence)
    return doc
