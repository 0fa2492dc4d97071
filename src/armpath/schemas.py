"""JSON Schemas of the result documents (``reach``, ``plan``, ``trace``, ``spotweld``).

Every result armpath writes (the CLI's ``--json`` and ``--out`` files, ``Result.save``) says
its ``schema_version``; :func:`result_schema` describes that version's fields, their types and
units (draft 2020-12), and ``armpath schema KIND`` prints it. A field added later keeps the
version (readers ignore what they do not know); a field renamed, removed or changed in meaning
raises it.
"""

from __future__ import annotations

from typing import Any

from armpath.errors import InvalidInputError

#: The version of the result documents' layout described here.
SCHEMA_VERSION = 1
#: The result kinds with a schema (the ``task`` of a document).
RESULT_KINDS = ("reach", "plan", "trace", "spotweld")

_DIALECT = "https://json-schema.org/draft/2020-12/schema"


def _num(description: str, nullable: bool = False) -> dict[str, Any]:
    return {"type": ["number", "null"] if nullable else "number", "description": description}


def _int(description: str, nullable: bool = False) -> dict[str, Any]:
    return {"type": ["integer", "null"] if nullable else "integer", "description": description}


def _str(description: str, nullable: bool = False) -> dict[str, Any]:
    return {"type": ["string", "null"] if nullable else "string", "description": description}


def _bool(description: str) -> dict[str, Any]:
    return {"type": "boolean", "description": description}


def _obj(
    description: str,
    properties: dict[str, Any] | None = None,
    required: tuple[str, ...] = (),
    nullable: bool = False,
) -> dict[str, Any]:
    out: dict[str, Any] = {"type": ["object", "null"] if nullable else "object"}
    out["description"] = description
    if properties:
        out["properties"] = properties
    if required:
        out["required"] = list(required)
    return out


def _array(description: str, items: dict[str, Any], length: int | None = None) -> dict[str, Any]:
    out: dict[str, Any] = {"type": "array", "description": description, "items": items}
    if length is not None:
        out["minItems"] = out["maxItems"] = length
    return out


_POINT = _array("x, y, z (mm)", {"type": "number"}, 3)
_JOINTS = _array(
    "one value per joint: deg (mm for a prismatic joint)", {"type": ["number", "null"]}
)
_ARC = _obj(
    "a stretch of the curve by arc length from its start",
    {"start_mm": _num("start (mm)"), "end_mm": _num("end (mm)")},
    ("start_mm", "end_mm"),
)

_CLEARANCE = _obj(
    "the clearance of the whole continuous motion (synchronous linear interpolation between "
    "states), certified by a bound between samples",
    {
        "min_clearance_mm": _num("smallest clearance of any part to any obstacle (mm)", True),
        "min_clearance_lower_bound_mm": _num("proven lower bound of it (mm)", True),
        "min_body_clearance_mm": _num(
            "smallest clearance of the links, tool tip excluded (mm)", True
        ),
        "min_tool_tip_clearance_mm": _num("smallest clearance of the tool tip (mm)", True),
        "min_self_clearance_mm": _num("smallest distance between links (mm)", True),
        "certified": _bool("whether every pair keeps its required clearance over the motion"),
        "closest_part": _str("the part of the arm closest to an obstacle", True),
        "closest_obstacle": _str("the obstacle (or link) it is closest to", True),
        "during_command": _int("the command during which it is closest (0: the start)", True),
        "configurations_evaluated": _int("configurations the certificate evaluated"),
        "method": _str("how the clearance was certified"),
    },
    ("min_clearance_mm", "certified", "method"),
)

_METRICS = _obj(
    "the plan's score on every objective",
    {
        "commands": _int("number of commands"),
        "tip_path_mm": _num("length of the tool point's continuous path (mm)"),
        "energy_deg": _num("weighted joint travel (deg)"),
        "joint_travel_deg": _JOINTS,
    },
    ("commands", "tip_path_mm", "energy_deg"),
)

_HEAD: dict[str, Any] = {
    "task": _str("the result kind"),
    "schema_version": {"const": SCHEMA_VERSION, "description": "this layout's version"},
    "armpath_version": _str("the armpath version that wrote it"),
    "model": _obj(
        "the arm: name, parameters, limits, command lattice and the full definition that "
        "replays it anywhere (lengths in the model's length_unit, angles rad in definition)",
        {
            "name": _str("the model's name"),
            "length_unit": _str("the model's length unit: mm or m"),
            "lattice": _obj("the controller's command lattice: tick and most ticks per joint"),
            "definition": _obj("the whole model (armpath robot document)"),
        },
        ("name",),
    ),
    "scene": _obj(
        "the scene: its obstacles, clearance rule and the definition that rebuilds it",
        {
            "name": _str("the scene's name"),
            "source": _str("where it was read from"),
            "obstacles": _array("the obstacles (mm)", {"type": "object"}),
            "clearance_margin_mm": _num("clearance every link keeps (mm)"),
            "tool_tip_exempt_mm": _num("length of the tool tip that may touch (mm)"),
            "definition": _obj("the scene file's content", nullable=True),
        },
        ("name",),
    ),
    "wall_thickness": _str(
        "how the workpiece's wall thickness is read: normal or horizontal", True
    ),
    "units": _obj(
        "the units of the document",
        {
            "length": _str("length unit of positions"),
            "angle": _str("angle unit of joint values"),
            "joints": _array("unit of each joint's values", {"type": "string"}),
            "commands": _str("what a command's integers count"),
        },
    ),
    "initial_deg": _JOINTS,
    "commands": _array(
        "the commands: one row per command, each joint's increment in integer ticks",
        {"type": "array", "items": {"type": "integer"}},
    ),
    "final_deg": _JOINTS,
    "n_commands": _int("number of commands"),
    "tip": {**_POINT, "description": "the tool point after the last command (mm)"},
    "min_clearance_mm": _num("smallest clearance along the motion (mm)", True),
    "clearance": _CLEARANCE,
}
_HEAD_REQUIRED = (
    "task",
    "schema_version",
    "model",
    "scene",
    "initial_deg",
    "commands",
    "final_deg",
    "n_commands",
    "clearance",
)

_TARGET = {**_POINT, "description": "the target point (mm)"}
_ORIENTATION = _obj("the tool orientation asked for and met, or null", nullable=True)

_KINDS: dict[str, tuple[str, dict[str, Any], tuple[str, ...]]] = {
    "reach": (
        "A point reached in the fewest commands, then the smallest error (armpath reach).",
        {
            "target": _TARGET,
            "error_mm": _num("distance of the tool point from the target at the end (mm)"),
            "tolerance_mm": _num("largest error accepted (mm)"),
            "lower_bound_commands": _int("proven fewest commands of any plan", True),
            "provably_fewest": _bool("whether n_commands equals the proven bound"),
            "meets_bound": _bool("whether the plan meets the bound"),
            "tool_orientation": _ORIENTATION,
            "fewer_commands_rejected": _array(
                "why each smaller command count was rejected", {"type": ["string", "object"]}
            ),
            "method": _str("direct, or planned around obstacles"),
            "lower_bound": _obj("the lower bound and how it was proven", nullable=True),
            "search": _obj("what the lattice search examined"),
        },
        ("target", "error_mm", "tolerance_mm", "lower_bound_commands"),
    ),
    "plan": (
        "A clear motion to joint values or to a point (armpath plan).",
        {
            "objective": _str("what was minimised: commands, path or energy"),
            "metrics": _METRICS,
            "direct_commands": _int(
                "commands of the straight joint-space motion to the goal (state)", True
            ),
            "lower_bound_commands": _int(
                "fewest commands any plan to the joint goal needs (its straight motion); null "
                "for a point goal, whose bound over every pose at the point armpath reach proves",
                True,
            ),
            "method": _str("direct or the search that found the motion"),
            "search_samples": _int("states the search sampled", True),
            "target": _TARGET,
            "error_mm": _num("distance of the tool point from the target (mm)"),
            "tolerance_mm": _num("largest error accepted (mm)"),
            "tool_orientation": _ORIENTATION,
        },
        ("objective", "metrics", "method"),
    ),
    "trace": (
        "A curve followed by the tool, every reachable part, with certified deviation "
        "(armpath trace).",
        {
            "tolerance_mm": _num("largest deviation accepted (mm)"),
            "curve": _obj(
                "the curve: its definition, length and the points it was checked on",
                {
                    "length_mm": _num("length (mm)"),
                    "closed": _bool("whether it closes on itself"),
                    "points_mm": _array("points along it (mm)", _POINT),
                },
                ("length_mm",),
            ),
            "surface": _str("the obstacle whose surface the curve lies on", True),
            "passes": _array(
                "each pass as [first state, last state]",
                {"type": "array", "items": {"type": "integer"}},
            ),
            "pass_details": _array(
                "each pass: its states, commands, arc, direction (forward: from start_mm to end_mm,"
                " backward: from end_mm) and deviation",
                _obj(
                    "a pass",
                    {
                        "states": _array(
                            "its first and last state (indices of the states: 0 the start)",
                            {"type": "integer"},
                            2,
                        ),
                        "commands": _int("its commands"),
                        "start_mm": _num("arc length where its traced arc begins (mm)"),
                        "end_mm": _num("arc length where it ends (mm; past the length: round)"),
                        "length_mm": _num("length it traces (mm)"),
                        "direction": {"enum": ["forward", "backward"], "description": "its way"},
                        "max_deviation_mm": _num("its largest deviation (mm)"),
                        "max_deviation_bound_mm": _num("proven upper bound of it (mm)"),
                        "ends_because": _str(
                            "why it ends short of the end of the arc it was traced toward "
                            "(empty where it reaches it)"
                        ),
                    },
                    ("states", "commands", "start_mm", "end_mm", "direction"),
                ),
            ),
            "transits": _array(
                "the motions onto the curve and between passes",
                _obj(
                    "a transit",
                    {
                        "states": _array("its first and last state", {"type": "integer"}, 2),
                        "commands": _int("its commands"),
                        "method": _str("how it was planned"),
                    },
                    ("states", "commands", "method"),
                ),
            ),
            "covered": _array("the arcs traced", _ARC),
            "not_traced": _array("the arcs not traced and why", _ARC),
            "reachable": _array("the arcs some clear pose reaches", _ARC),
            "unreachable": _array("the arcs no clear pose reaches, and why", _ARC),
            "reachability_method": _str("how reachability was decided"),
            "max_deviation_mm": _num("largest deviation of the continuous tool path (mm)", True),
            "max_deviation_bound_mm": _num("proven upper bound of it (mm)", True),
            "tool_axis": _ORIENTATION,
            "deviation_method": _str("how the deviation was certified"),
            "coverage": _obj(
                "how much of the curve was traced",
                {
                    "covered_mm": _num("traced length (mm)"),
                    "reachable_mm": _num("reachable length (mm)"),
                    "curve_mm": _num("curve length (mm)"),
                    "of_reachable": _num("covered / reachable"),
                    "of_curve": _num("covered / curve"),
                },
            ),
            "metrics": _METRICS,
            "lower_bound_commands": _int(
                "fewest commands of any plan tracing what this one traces (null: not "
                "computed; an estimate where lower_bound.proven is false)",
                True,
            ),
            "lower_bound": _obj("the lower bound, how it was computed and the gap", nullable=True),
        },
        ("tolerance_mm", "curve", "passes", "covered", "not_traced", "coverage"),
    ),
    "spotweld": (
        "Spot welds visited in the best order (armpath spotweld).",
        {
            "z_from": _str("how the welds' points were given"),
            "targets": _array("the welds in the scene's order (mm)", _POINT),
            "order": _array("the visiting order (1-based weld numbers)", {"type": "integer"}),
            "visits": _array(
                "each weld as visited: its point, the command after which it is reached, the error",
                _obj(
                    "a visit",
                    {
                        "target": _POINT,
                        "after_command": _int("the command after which the weld is reached"),
                        "error_mm": _num("error there (mm)"),
                        "tool_orientation": _ORIENTATION,
                    },
                    ("target", "after_command", "error_mm"),
                ),
            ),
            "returns_to_start": _bool("whether the tour ends back at the start"),
            "error_mm": _num("largest weld error (mm)"),
            "tolerance_mm": _num("largest error accepted (mm)"),
            "objective": _str("what was minimised"),
            "metrics": _METRICS,
            "lower_bound_commands": _int(
                "fewest commands of any tour: every order (or the given one) and every goal "
                "configuration, obstacles ignored (null: not computed; an estimate where "
                "lower_bound.proven is false)",
                True,
            ),
            "lower_bound": _obj("the lower bound, how it was computed and the gap", nullable=True),
            "no_bound_because": _str("why lower_bound is null (null where it was computed)", True),
            "goal_states_bound_commands": _int(
                "bound of the chosen order through the candidate goal states (ranks the orders)"
            ),
            "goal_states_bound_method": _str("how goal_states_bound_commands is counted"),
            "orders_ranked": _int("visiting orders ranked by their bounds"),
            "orders": _array(
                "the best-ranked orders with their bounds and plans",
                _obj(
                    "an order",
                    {
                        "order": _array("the welds in order (1-based)", {"type": "integer"}),
                        "lower_bound_commands": _int(
                            "fewest commands of direct motions (obstacles ignored) through one "
                            "of the candidate goal states per weld: a bound for these goal states "
                            "only, what ranks the orders (family_bound_commands is over every "
                            "configuration)"
                        ),
                        "family_bound_commands": _int(
                            "the order's bound over every goal configuration (null: not computed "
                            "per order)",
                            True,
                        ),
                        "planned_commands": _int("commands of its plan (null: not planned)", True),
                        "not_planned_because": _str("why it was not planned", True),
                    },
                    ("order", "lower_bound_commands"),
                ),
            ),
            "legs": _array(
                "each leg of the tour",
                _obj(
                    "a leg",
                    {
                        "commands": _int("its commands"),
                        "direct_commands": _int(
                            "commands of the straight joint-space motion to its goal state", True
                        ),
                        "method": _str("direct or the search that found it"),
                        "search_samples": _int("states the search sampled", True),
                    },
                    ("commands", "method"),
                ),
            ),
        },
        ("targets", "order", "visits", "error_mm", "metrics"),
    ),
}


def result_schema(kind: str) -> dict[str, Any]:
    """The JSON Schema of result documents of ``kind`` (one of :data:`RESULT_KINDS`)."""
    if kind not in _KINDS:
        raise InvalidInputError(
            f"result kind must be one of {', '.join(RESULT_KINDS)}, got {kind!r}"
        )
    title, fields, required = _KINDS[kind]
    head = dict(_HEAD)
    head["task"] = {"const": kind, "description": "the result kind"}
    return {
        "$schema": _DIALECT,
        "$id": f"https://armpath.invalid/schemas/v{SCHEMA_VERSION}/{kind}.json",
        "title": f"armpath {kind} result",
        "description": title,
        "type": "object",
        "properties": {**head, **fields},
        "required": [*_HEAD_REQUIRED, *required],
    }


__all__ = ["RESULT_KINDS", "SCHEMA_VERSION", "result_schema"]
