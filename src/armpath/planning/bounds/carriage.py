"""A proven lower bound for an arm on a linear track: how far its carriage must travel.

An arm carried by a prismatic first joint (:func:`~armpath.planning.trace.carriage.carriage_joint`)
has one degree of freedom more than a tool frame needs, and the family bound samples one member
of its self-motion per tool frame: an estimate, not a proof. Its carriage gives a proof of
another kind. Whatever the arm's other joints do, the tool point stays within ``reach`` of a
point ``o`` fixed to the carriage: the largest distance proven by branch and bound
(:func:`~armpath.planning.bounds.farthest.farthest_tool_point`, ``o`` on the next joint's
axis), so a curve point ``p`` is within the tolerance of the tool point only with the
carriage at a value ``c`` where ``|p - o(c)| <= reach + tolerance``, an interval of ``c`` (the
carriage's limits too). Every point of every span must be visited so: the carriage must at
some time stand at or above the largest of the intervals' lower ends, ``A``, and at some time
at or below the smallest of their upper ends, ``B``; from where it starts, ``c0``, that takes
at least

* ``max(A - c0, c0 - B, 0)`` where ``A <= B``;
* the shorter of going up to ``A`` then down to ``B`` and going down to ``B`` then up to ``A``
  where ``A > B``,

whatever the order of the points or the passes; and each command moves the carriage at most
its step. Obstacles, the tool rule and the lattice are left out (a relaxation: still a bound).

A ball is round; an arm's reach is not. Where the next joint turns about an axis square to the
track (a vertical arm on a horizontal track), the tool points at one height along that axis
reach less far from it than the ball says away from the ball's centre: a UR5 on the track
cell's track reaches 1053.5 mm from a point at its shoulder's height, but only 988.7 mm from
its axis at the table's height, 348 mm below. So the points that decide ``A`` and ``B`` (up to
:data:`MAX_RINGS` bands of heights, :data:`RING_BAND_MM` high) take the proven largest
distance from the axis of the tool points at their heights
(:func:`~armpath.planning.bounds.farthest.farthest_from_axis`) where it is less.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from armpath.geometry.curves import Curve
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.planning.bounds.farthest import (
    AxisReach,
    farthest_from_axis,
    farthest_tool_point,
    next_axis,
)
from armpath.planning.bounds.value import CommandBound

FloatArray = NDArray[np.float64]

#: Most curve points whose carriage intervals are taken (spread evenly over the spans).
MAX_POINTS = 100_000
#: Spacing of the points along the spans (mm): the bound holds at any spacing (each point must
#: be visited); a finer one finds the extreme points more nearly.
POINT_SPACING_MM = 0.5
#: Added to the reach (mm) for where a point taken at a span's arc length may lie past it (the
#: curve's arc-length table is interpolated): far above that error, far below a command.
_ARC_SLACK_MM = 0.01
#: Bands of heights searched for the arm's reach from its axis (each a branch and bound of
#: about a second, cached on the arm): those of the points deciding ``A`` and ``B``.
MAX_RINGS = 2
#: Height of such a band (mm), about a deciding point's height: the points within it take
#: its reach (a wider band reaches farther: the track cell 988.7 mm in 0.1 mm, 990.3 in 10).
RING_BAND_MM = 0.5
#: Boxes each such search may take (the track cell's takes about 51,000; an arm of many joints
#: stops here, its reach still proven, only less tight, and no later than the ball's search).
RING_MAX_BOXES = 500_000


def carriage_travel_bound(
    arm: SerialArm,
    curve: Curve,
    spans_mm: list[tuple[float, float]],
    q_start: FloatArray,
    tolerance_mm: float,
) -> CommandBound | None:
    """The commands any plan that brings the tool point within ``tolerance_mm`` of every point
    of the spans (arc lengths mm) of ``curve``, from ``q_start`` (rad / mm), needs at least
    for the carriage (the first joint, prismatic) to travel where the arm reaches them (see
    the module). None where the arm has no carriage (:func:`points_travel_bound`) or the spans
    are empty."""
    if not spans_mm:
        return None
    total = sum(b - a for a, b in spans_mm)
    count = int(min(MAX_POINTS, max(2, math.ceil(total / POINT_SPACING_MM) + len(spans_mm))))
    per_span = [max(2, round(count * (b - a) / max(total, 1e-12))) for a, b in spans_mm]
    s = np.concatenate([np.linspace(a, b, k) for (a, b), k in zip(spans_mm, per_span, strict=True)])
    return points_travel_bound(
        arm, curve.at_arc_length(s), q_start, tolerance_mm + _ARC_SLACK_MM, "point of the curve"
    )


def points_travel_bound(
    arm: SerialArm,
    points_mm: FloatArray,
    q_start: FloatArray,
    tolerance_mm: float,
    what: str = "weld",
    back: bool = False,
) -> CommandBound | None:
    """The commands any plan that brings the tool point within ``tolerance_mm`` of each of
    ``points_mm (N, 3)`` (in any order), from ``q_start`` (rad / mm), and with ``back`` returns
    to it, needs at least for the carriage to travel where the arm reaches them (see the
    module; ``what`` names a point in the method's text). None where the arm's first joint is
    not prismatic, its lengths are not in mm, a later prismatic joint is unlimited, there are
    no points, or a point lies beyond the arm's reach from any carriage value."""
    if (
        arm.n_joints < 2
        or arm.joints[0].kind is not JointKind.PRISMATIC
        or arm.length_unit != "mm"
        or points_mm.shape[0] == 0
    ):
        return None
    farthest = farthest_tool_point(arm, 0)
    if farthest is None:
        return None
    reach = farthest.radius
    frame = arm.T_world_base @ arm.joints[0].T_parent_joint
    axis = frame[:3, :3] @ arm.joints[0].axis
    d = points_mm - farthest.centre  # the centre where it is with the carriage at 0
    along = d @ axis
    across2 = np.maximum(np.einsum("ij,ij->i", d, d) - along**2, 0.0)
    radius = reach + tolerance_mm
    if np.any(across2 > radius**2):  # a point no carriage value brings within reach
        return None
    half = np.sqrt(radius**2 - across2)
    narrowed = _reach_at_heights(arm, points_mm, axis, along, half, tolerance_mm)
    if narrowed is None:  # no tool point at some point's height
        return None
    half, rings = narrowed
    lower, upper = arm.joints[0].limits
    A = float(max(np.max(along - half), lower))
    B = float(min(np.min(along + half), upper))
    c0 = float(q_start[0])
    if back:  # a closed walk from c0 through A and B
        travel = 2.0 * (max(A, c0) - min(B, c0))
    elif A <= B:
        travel = max(A - c0, c0 - B, 0.0)
    else:
        up_first = max(A - c0, 0.0) + (max(c0, A) - B)
        down_first = max(c0 - B, 0.0) + (A - min(c0, B))
        travel = min(up_first, down_first)
    step = float(arm.lattice.max_step[0])
    value = travel / step
    returning = f" and back to {c0:g} mm" if back else ""
    return CommandBound(
        commands=math.ceil(value - 1e-9),
        value=value,
        method=(
            f"the carriage's travel: from {c0:g} mm to {A:.1f} mm or beyond and to {B:.1f} mm or "
            f"below{returning}, "
            f"where every {what} is within the arm's reach of it ({_reach_text(reach, rings, what)}"
            f", proven by branch and bound), {step:g} mm a command"
        ),
        parts={"carriage": value},
        sampling={
            "carriage_reach_mm": reach,
            "carriage_reach_found_mm": farthest.found,
            "carriage_reach_boxes": float(farthest.boxes),
            "carriage_points": float(points_mm.shape[0]),
            **(
                {
                    "carriage_axis_reach_mm": min(ring.radius for ring in rings),
                    "carriage_axis_reach_found_mm": min(ring.found for ring in rings),
                    "carriage_axis_reach_boxes": float(sum(ring.boxes for ring in rings)),
                }
                if rings
                else {}
            ),
        },
    )


def _reach_at_heights(
    arm: SerialArm,
    points_mm: FloatArray,
    track: FloatArray,
    along: FloatArray,
    half: FloatArray,
    tolerance_mm: float,
) -> tuple[FloatArray, list[AxisReach]] | None:
    """The half widths ``half`` of the points' carriage intervals (about ``along``, mm along
    the unit ``track``), narrowed where the arm's proven reach from its next joint's axis at
    the deciding points' heights is less (see the module), and the reaches taken; unchanged
    where that axis is not square to the track. None where no tool point lies at a point's
    height, or it is beyond that reach from the axis wherever the carriage is."""
    axis = next_axis(arm, 0)
    if axis is None or abs(float(axis[1] @ track)) > 1e-9:
        return half, []
    a_point, a_dir = axis
    height = (points_mm - a_point) @ a_dir
    square = points_mm - a_point - height[:, None] * a_dir
    # the distance from the axis across the track (the carriage changes the rest)
    across2 = np.maximum(np.einsum("ij,ij->i", square, square) - (square @ track) ** 2, 0.0)
    half = half.copy()
    narrowed = np.zeros(points_mm.shape[0], dtype=bool)
    rings: list[AxisReach] = []
    for _ in range(MAX_RINGS):
        deciding = [int(np.argmax(along - half)), int(np.argmin(along + half))]
        left = [i for i in deciding if not narrowed[i]]
        if not left:
            break
        lo = height[left[0]] - 0.5 * RING_BAND_MM
        hi = height[left[0]] + 0.5 * RING_BAND_MM
        ring = farthest_from_axis(
            arm, 0, lo - tolerance_mm, hi + tolerance_mm, max_boxes=RING_MAX_BOXES
        )
        if ring is None:
            break
        if ring.radius == -np.inf:  # no tool point at these heights
            return None
        band = ~narrowed & (height >= lo) & (height <= hi)
        radius = ring.radius + tolerance_mm
        if np.any(across2[band] > radius**2):
            return None
        half[band] = np.minimum(half[band], np.sqrt(radius**2 - across2[band]))
        narrowed |= band
        rings.append(ring)
    return half, rings


def _reach_text(reach: float, rings: list[AxisReach], what: str) -> str:
    """How far the arm reaches, in a carriage bound's method."""
    ball = f"{reach:.1f} mm from a point on its next joint's axis"
    if not rings:
        return ball
    radii = sorted({round(ring.radius, 1) for ring in rings})
    at = " and ".join(f"{r:.1f}" for r in radii)
    return f"{ball}, and {at} mm from that axis at the height of each deciding {what}"


def estimate_is_named(estimate_commands: float, plan_commands: float) -> bool:
    """Whether a redundant arm's family estimate (not proven) is named beside its carriage's
    bound: where it is at most the plan's commands. Above them its one sampled member per tool
    frame missed what the plan does, and it estimates nothing."""
    return estimate_commands <= plan_commands


def with_carriage(
    family: CommandBound | None,
    carriage: CommandBound | None,
    plan_commands: float = np.inf,
) -> CommandBound | None:
    """The bound to report: the family's, or its carriage's travel (an arm on a track) where
    that is higher or the family's is an estimate (a redundant arm's, not proven; its value is
    then kept in the carriage bound's sampling, and named in its method where
    :func:`estimate_is_named` beside the plan's ``plan_commands``)."""
    if carriage is None:
        return family
    if family is None:
        return carriage
    if family.proven:
        return family if family.value >= carriage.value else carriage
    named = f"; the family's estimate, not proven: ~{family.commands}"
    return replace(
        carriage,
        method=carriage.method + (named if estimate_is_named(family.value, plan_commands) else ""),
        sampling={**carriage.sampling, "family_estimate_commands": family.value},
    )


__all__ = ["carriage_travel_bound", "estimate_is_named", "points_travel_bound", "with_carriage"]
