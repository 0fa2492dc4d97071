"""Tracing a curve with the tool point: command sequences whose continuous tool path stays on it.

1. **Reachability** (:mod:`~armpath.planning.trace.reachability`) splits the curve into
   reachable arcs, searching the solution family of every arm
   (:mod:`~armpath.planning.trace.family`).
2. **Reference path** (:mod:`~armpath.planning.trace.reference`): dynamic programming through
   the family, as few passes as possible.
3. **Commands** (:mod:`~armpath.planning.trace.tracer`): the lattice command that carries the
   tool point farthest along the curve, checked exactly.
4. **Passes and transits.** The arm moves from the start to each pass, and between passes
   (lifting off the surface), with the collision-free planner
   (:func:`~armpath.planning.motion.plan_motion`).
5. **Certification.** The whole sequence's clearance is certified along the continuous motion
   (:func:`~armpath.planning.motion_check.motion_clearance`); the tool's deviation from the curve
   during every pass is bounded by branch and bound
   (:mod:`~armpath.planning.trace.certificate`), so the reported largest deviation is the true
   maximum of the continuous path to within ``2 um``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time, current_deadline
from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError, PlanningError, TimeLimitError
from armpath.geometry.curves import Curve, arc_within_round
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import tick_jacobian, tool_position
from armpath.model.serial_arm import SerialArm
from armpath.planning.bounds import CommandBound, trace_bound
from armpath.planning.bounds.band_trace import band_forecast, band_trace_bound, with_band
from armpath.planning.bounds.carriage import carriage_travel_bound, with_carriage
from armpath.planning.bounds.lattice_goals import lattice_state_exists
from armpath.planning.bounds.search import check_max_samples
from armpath.planning.bounds.trace import LAYER_INSET_MM
from armpath.planning.motion import (
    MotionOptions,
    MotionPlan,
    PlanMetrics,
    active_joints,
    merged_certified,
    plan_metrics,
    plan_motion,
    search_clearance_extra,
)
from armpath.planning.motion_check import (
    CERTIFY_RESOLUTION_MM,
    WHOLE_PLAN_EVALUATIONS,
    MotionClearance,
    check_state_clear,
    motion_clearance,
    plan_clearance,
)
from armpath.planning.trace.certificate import (
    PROFILE_PER_COMMAND,
    certificate_precision,
    certified_axis_angle,
    certified_deviation,
)
from armpath.planning.trace.family import AxisRule, CurveFamily
from armpath.planning.trace.reachability import (
    CurveArc,
    CurveReachability,
    UnreachableArc,
    common_mm,
    curve_reachability,
    merged_arcs,
)
from armpath.planning.trace.reference import (
    CommandUnits,
    Piece,
    _joint_change,
    reference_pieces,
)
from armpath.planning.trace.tracer import (
    _BODY_BUFFER_MM,
    BAND_SHARE,
    END_CHAIN_SHARE,
    FALLBACK_BAND_SHARE,
    GOAL_REACHED_MM,
    Tracer,
)
from armpath.tolerances import TRACE_TOLERANCE_MM, check_trace_tolerance

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Share of the tolerance to which the final clearance check resolves a trace's clearances, at
#: most :data:`~armpath.planning.motion_check.CERTIFY_RESOLUTION_MM`: below the twentieth of it
#: the tracer keeps the tip off a surface it follows at the instants it checks.
_CERTIFY_SHARE = 0.02


@dataclass(frozen=True)
class TraceOptions:
    """How to trace.

    ``tolerance_mm``: the largest distance of the continuous tool path from the curve during a
    pass. ``layer_step_mm``: spacing of the reference path's layers. ``scan_step_mm``: spacing of
    the reachability scan (see :func:`~armpath.planning.trace.curve_reachability`).
    ``motion``: options of the transits onto the curve and between passes. ``axis_rule``:
    where the tool's approach axis may point on the curve (:class:`AxisRule`: near the surface
    normal, or a fixed direction); None: any direction from outside the surface. ``bound``:
    compute the lower bound of the commands (:func:`~armpath.planning.bounds.trace_bound`),
    its search holding up to ``bound_samples`` live samples (None:
    :data:`~armpath.planning.bounds.search.MAX_SAMPLES`; more: a tighter bound, later).
    """

    tolerance_mm: float = TRACE_TOLERANCE_MM
    layer_step_mm: float = 5.0
    scan_step_mm: float = 4.0
    motion: MotionOptions = field(default_factory=MotionOptions)
    axis_rule: AxisRule | None = None
    bound: bool = True
    bound_samples: int | None = None

    def __post_init__(self) -> None:
        check_trace_tolerance(self.tolerance_mm)
        if not self.layer_step_mm > 0:
            raise InvalidInputError("layer step must be > 0 mm")
        check_max_samples(self.bound_samples)


@dataclass(frozen=True)
class TracePass:
    """One continuous pass: the tip follows the curve from state ``first`` to state ``last``
    (state 0 is the start, state k the state after command k), covering arc lengths
    ``start_mm``..``end_mm``, from ``end_mm`` toward ``start_mm`` when ``backward``."""

    first: int
    last: int
    start_mm: float
    end_mm: float
    max_deviation_mm: float
    max_deviation_bound_mm: float
    #: With a tool-axis rule: the largest angle (rad) of the tool axis from the rule's axis
    #: over the continuous motion of the pass, and its proven bound (a fixed direction; None
    #: for the surface normal, whose largest angle is found by refined sampling).
    max_axis_angle_rad: float | None = None
    max_axis_angle_bound_rad: float | None = None
    backward: bool = False
    #: Why the pass ends short of the end of the arc it was traced toward, in words ("" where
    #: it reaches it): the tracer found no command on, or the reference path lifts off there.
    ends_because: str = ""

    @property
    def covered_mm(self) -> float:
        return self.end_mm - self.start_mm


@dataclass(frozen=True)
class Transit:
    """A move off the curve (to the first pass, or lifting off between passes)."""

    first: int
    last: int
    method: str


@dataclass(frozen=True, eq=False)
class TraceResult:
    """A traced curve: the command sequence, its passes and what they cover."""

    sequence: CommandSequence
    curve: Curve
    reachability: CurveReachability
    passes: tuple[TracePass, ...]
    transits: tuple[Transit, ...]
    tolerance_mm: float
    clearance: MotionClearance
    metrics: PlanMetrics
    deviation_s_mm: FloatArray
    deviation_mm: FloatArray
    axis_rule: AxisRule | None = None
    #: Reachable pieces no pass could be moved onto (with why): reachable but not traced.
    not_traced: tuple[tuple[CurveArc, str], ...] = ()
    #: The fewest commands any plan that traces what this one traces needs (see
    #: :func:`~armpath.planning.bounds.trace_bound`), None when it was not computed.
    lower_bound: CommandBound | None = None

    @property
    def n_commands(self) -> int:
        return self.sequence.n_commands

    @property
    def covered_mm(self) -> float:
        """Length of the curve covered by the passes (mm; overlaps counted once)."""
        return sum(b - a for a, b in self._covered())

    @property
    def covered_reachable_mm(self) -> float:
        """Length of the reachable arcs covered by the passes (mm): a pass may run a hair past
        an arc's end, found to its resolution."""
        curve = self.curve
        reachable = merged_arcs(self.reachability.reachable, curve.length, curve.closed)
        return common_mm(self._covered(), reachable)

    def _covered(self) -> list[tuple[float, float]]:
        """The passes' union (:func:`merged_arcs`)."""
        arcs = [CurveArc(p.start_mm, p.end_mm) for p in self.passes]
        return merged_arcs(arcs, self.curve.length, self.curve.closed)

    @property
    def max_deviation_mm(self) -> float:
        return max((p.max_deviation_mm for p in self.passes), default=0.0)

    @property
    def max_axis_angle_rad(self) -> float | None:
        """The largest angle of the tool axis from its rule over every pass (None: no rule)."""
        angles = [p.max_axis_angle_rad for p in self.passes if p.max_axis_angle_rad is not None]
        return max(angles) if angles else None

    @property
    def max_axis_angle_bound_rad(self) -> float | None:
        bounds = [p.max_axis_angle_bound_rad for p in self.passes]
        if not bounds or any(b is None for b in bounds):
            return None
        return max(b for b in bounds if b is not None)

    @property
    def max_deviation_bound_mm(self) -> float:
        return max((p.max_deviation_bound_mm for p in self.passes), default=0.0)


#: Under a time limit, the arcs are traced a second time (see :func:`plan_trace`) only while
#: more than this many times what the first tracing took remains (the plan's certificate and
#: bound come after it).
_RETRACE_TIME_SHARE = 2.0


#: Points along a curve no part of which is reachable where :func:`_near_miss` looks for the
#: nearest tool point.
_NEAR_MISS_POINTS = 9


def _near_miss(
    arm: SerialArm, curve: Curve, unreachable: Sequence[UnreachableArc], tolerance_mm: float
) -> str:
    """Where every arc of ``curve`` is out of reach: a clause naming how near the tool point
    comes to it (at :data:`_NEAR_MISS_POINTS` points along it, the orientation rule ignored)
    when that lies within ``tolerance_mm``; else empty. A trace follows members that put the
    tool point on the curve, so an arm whose tool point moves in fewer than three directions
    (one joint; two in a plane) or a curve just beyond full stretch has none, although states
    within the tolerance exist."""
    from armpath.ik.family import EXACT_FRACTION
    from armpath.ik.target import ToolTarget
    from armpath.planning.reach_generic import nearest_reachable

    if any(a.blocked_by != ("out of reach",) for a in unreachable):
        return ""
    rng = np.random.default_rng(0)
    s = np.linspace(0.0, curve.length, _NEAR_MISS_POINTS)
    points = curve.at_arc_length(s)
    near = [nearest_reachable(arm, ToolTarget(p), rng)[0] for p in points]
    k = int(np.argmin(near))
    if near[k] > tolerance_mm:
        return ""
    exact = EXACT_FRACTION * arm.size * arm.mm_per_unit
    return (
        f"; the tool point comes within {near[k]:.3g} mm of it ({s[k]:.1f} mm along it), "
        f"inside the {tolerance_mm:g} mm tolerance, but a trace follows configurations that "
        f"put the tool point on the curve (to {exact:.1g} mm) and none does: the curve lies "
        "beside what the tool point sweeps (an arm moving it in fewer than three directions, "
        "one joint or joints that all move it in a plane, sweeps only a circle or a surface; "
        "or the curve lies just beyond full stretch); armpath reach takes the nearest point "
        "reached, one point at a time"
    )


def plan_trace(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: IntArray,
    curve: Curve,
    options: TraceOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
) -> TraceResult:
    """Trace every reachable part of ``curve`` from ``start_ticks``, fewest passes first.

    A pass may follow a reference path begun nearer the arm, its approach charged
    (:func:`~armpath.planning.trace.reference.reference_pieces`); where one does, the arcs are
    traced again along references between fixed ends and the plan with fewer commands kept
    (the one covering more where they differ by more than the tolerance); under a time limit,
    only while :data:`_RETRACE_TIME_SHARE` times what the first tracing took remains, and the
    first plan stands if the limit runs out in the second."""
    opts = options or TraceOptions()
    say = on_progress or (lambda _m: None)
    start = np.asarray(start_ticks, dtype=np.int64)
    check_state_clear(arm, world, arm.lattice.to_joint(start))  # before any scan
    reach = curve_reachability(
        arm,
        world,
        curve,
        scan_step_mm=opts.scan_step_mm,
        on_progress=say,
        rule=opts.axis_rule,
        start_q=arm.lattice.to_joint(start),
    )
    if not reach.reachable:
        raise PlanningError(
            f"no part of curve {curve.name!r} is reachable: "
            + "; ".join(a.reason for a in reach.unreachable)
            + _near_miss(arm, curve, reach.unreachable, opts.tolerance_mm)
        )
    fam = reach.family
    arcs = list(reach.reachable)
    overlap = 0.0
    all_round = _all_round(curve, arcs)
    if all_round:
        # all around: begun where the family comes nearest the arm, run on a little past the
        # start so that the covered ends meet
        a0 = _nearest_loop_start(fam, arm.lattice.to_joint(start), curve.length, arcs[0].start_mm)
        arcs = [CurveArc(a0, a0 + curve.length)]
        overlap = min(2.0 * opts.tolerance_mm, LOOP_OVERLAP_MM)
    began = time.monotonic()
    run = _trace_arcs(arm, world, reach, start, arcs, overlap, opts, say, charge_approach=True)
    deadline = current_deadline()
    if run.approach_charged and (
        deadline is None or deadline.remaining > _RETRACE_TIME_SHARE * (time.monotonic() - began)
    ):
        # a pass followed a reference begun nearer the arm, its approach charged; what that
        # foretells (see reference_pieces) does not always hold once traced on the lattice, so
        # the arcs are traced again between the references' fixed ends and the better kept
        say("tracing again along references between fixed ends, to keep the fewer commands")
        try:
            fixed = _trace_arcs(arm, world, reach, start, arcs, overlap, opts, say)
        except TimeLimitError:  # the first plan stands (its certificate still to come)
            fixed = run
        if not run.better_than(fixed, opts.tolerance_mm, curve):
            run = fixed
    broken = all_round and len(run.passes) > 1 and not any(p.backward for p in run.passes)
    left = _gaps_between_passes(arcs, run.passes, run.not_traced, curve.length) if broken else []
    if left:
        # the pass once round broke off and the next began past the break; begun where the
        # longest stretch left ends, the last pass runs on to that stretch instead of a pass
        # of its own covering what lay before the first one's beginning
        deadline = current_deadline()
        if deadline is None or deadline.remaining > _RETRACE_TIME_SHARE * (
            time.monotonic() - began
        ):
            longest = max(left, key=lambda gap: gap[0].length_mm)[0]
            a1 = float(curve.wrap(longest.end_mm))
            say(f"tracing again once round from {a1:.1f} mm, where the longest stretch left ends")
            try:
                again = _trace_arcs(
                    arm, world, reach, start, [CurveArc(a1, a1 + curve.length)], overlap, opts, say
                ).without_idle_last_pass(curve)
            except (TimeLimitError, PlanningError):
                again = run
            say(
                f"traced from there: {len(again.states) - 1} commands in {len(again.passes)} "
                f"passes over {again.covered_mm(curve):.2f} mm, against "
                f"{len(run.states) - 1} in {len(run.passes)} over {run.covered_mm(curve):.2f} mm"
            )
            if again.better_than(run, opts.tolerance_mm, curve):
                run = again
    states, passes, transits, not_traced = run.states, run.passes, run.transits, run.not_traced
    prof_s, prof_d = run.profile_s, run.profile_d
    not_traced += _with_lattice_reason(
        reach.family,
        opts.tolerance_mm,
        _gaps_between_passes(arcs, passes, not_traced, curve.length if curve.closed else None),
    )
    if not passes:
        if not_traced:
            why = "; ".join(f"{a.start_mm:.1f}..{a.end_mm:.1f} mm: {why}" for a, why in not_traced)
        else:
            why = "no pass stayed within the tolerance along the reachable arcs " + ", ".join(
                f"{a.start_mm:.1f}..{a.end_mm:.1f} mm" for a in arcs
            )
        raise PlanningError(f"no reachable part of curve {curve.name!r} could be traced: {why}")
    all_states = np.array(states)
    sequence = CommandSequence.from_states(all_states, arm.lattice)
    say("certifying the clearance of the whole motion")
    # proven to a fiftieth of the tolerance at most: the tracer keeps the tip a twentieth of
    # it off a surface it follows at the instants it checks (at 0.005 mm, 0.0005 mm off it
    # where the default 0.01 mm left it unproven; the UR5 cell's seam at 0.1 mm came 0.005 mm
    # near between them, unproven at a tenth of the tolerance)
    resolution = min(CERTIFY_RESOLUTION_MM, _CERTIFY_SHARE * opts.tolerance_mm)
    clearance = plan_clearance(arm, world, sequence, tolerance=resolution)
    if not clearance.certified_ok:  # a plan is delivered only with its motion proven clear
        if clearance.violated:
            why = "a sampled instant breaks it"
        elif clearance.evaluations >= WHOLE_PLAN_EVALUATIONS:
            why = "not proven in its budget"
        else:
            why = f"not proven to {resolution:g} mm, the finest it resolves"
        raise PlanningError(
            f"the trace failed its final clearance check, {why} ({clearance.limiting_pair} "
            f"{clearance.limiting_slack:+.4f} mm at a sampled instant of command "
            f"{clearance.limiting_command}; proven no less than "
            f"{clearance.lower_bound_slack:+.4f} mm): it is not written"
        )
    result = TraceResult(
        sequence,
        curve,
        reach,
        tuple(passes),
        tuple(transits),
        opts.tolerance_mm,
        clearance,
        plan_metrics(arm, sequence),
        np.concatenate(prof_s) if prof_s else np.zeros(0),
        np.concatenate(prof_d) if prof_d else np.zeros(0),
        opts.axis_rule,
        tuple(not_traced),
        None,
    )
    if not opts.bound:
        return result
    say("bounding the fewest commands of this trace")
    bound = trace_plan_bound(result, on_progress=say, max_samples=opts.bound_samples)
    if bound is not None:
        bound = bound.against_plan(sequence.n_commands)
    return replace(result, lower_bound=bound)


def _all_round(curve: Curve, arcs: Sequence[CurveArc]) -> bool:
    """Whether ``curve`` is closed and its reachable ``arcs`` are the whole of it: it is then
    traced in one pass all round, begun anywhere."""
    return curve.closed and len(arcs) == 1 and arcs[0].length_mm >= curve.length - 1e-9


def trace_plan_bound(
    result: TraceResult,
    rounds: int | None = None,
    on_progress: Callable[[str], None] | None = None,
    max_samples: int | None = None,
    with_errors: bool = True,
) -> CommandBound | None:
    """The lower bound of the commands of any plan that traces what ``result``'s passes cover
    (what :func:`plan_trace` reports): one pass per span (overlapping spans merged; on a closed
    curve reachable all round each pass's own span, and a pass once round the whole of it may
    begin anywhere and comes back to where it began), the family's points placed
    where the plan's joint path turns or evenly (:func:`~armpath.planning.bounds.trace_bound`),
    searched ``rounds`` rounds at most (None: as many as the budget allows) and until it holds
    ``max_samples`` live samples. None where the family has no member within the limits on a
    span. ``with_errors=False``: the estimate without the samples' sampling errors (not a
    bound; see the search). For an arm on a track the larger of that and its carriage's
    travel (:func:`~armpath.planning.bounds.carriage.carriage_travel_bound`), which is proven
    where the family's bound of a redundant arm is an estimate."""
    fam = result.reachability.family
    reachable = result.reachability.reachable
    around = _all_round(result.curve, reachable)
    spans: list[list[float]] = []
    for p in sorted(result.passes, key=lambda p: p.start_mm):
        if spans and p.start_mm <= spans[-1][1] and not around:
            spans[-1][1] = max(spans[-1][1], p.end_mm)
        else:
            spans.append([p.start_mm, p.end_mm])
    if not around:
        # what a pass covers beyond the reachable arcs (its tool point within the tolerance
        # of a point no configuration reaches) is left out: the bound holds for any plan that
        # covers the rest, and the family has no member there
        spans = [
            [max(a, arc.start_mm), min(b, arc.end_mm)]
            for a, b in spans
            for arc in reachable
            if min(b, arc.end_mm) > max(a, arc.start_mm)
        ]
        if not spans:
            return None
    # one pass once round a closed curve: it visits every point in order and comes back to
    # where it began, the move from its last point to its first counted too (passes round it
    # are bounded each on its own span; a pass that stops short, on its arc alone)
    loop = around and len(spans) == 1 and spans[0][1] - spans[0][0] >= result.curve.length
    sequence = result.sequence
    q_all = sequence.states_joint()
    path_mm, path_q = [], []
    for p in result.passes:
        q = q_all[p.first : p.last + 1]
        path_mm.append(_pass_arc_lengths(fam, q, p))
        path_q.append(q)
    # a span of a fraction of a mm at the edge of the reach (a pass's last command there) is
    # bounded at its middle (a span shorter than twice LAYER_INSET_MM), where the family's
    # sampled tool directions may all miss the few that reach: bounded without it (a bound
    # over fewer spans is still a bound) if it has no member
    short = [(a, b) for a, b in spans if b - a < 2 * LAYER_INSET_MM]
    tries = [[(a, b) for a, b in spans]]
    if short and len(short) < len(spans):
        tries.append([(a, b) for a, b in spans if b - a >= 2 * LAYER_INSET_MM])
    found = None
    forecast = [-np.inf]
    start = sequence.grid.to_joint(sequence.start_ticks)

    def along_band(first: CommandBound) -> float:
        # a circle, or a curve near one in windows: what its band bound (bounds/band_trace.py)
        # comes to, foretold once the family's first round is known; the family's search
        # stops once it cannot pass that, and the band bound is computed after it where the
        # forecast passes the family's (round the UR5 cell's seam it does not: about 170 s saved)
        forecast[0] = -np.inf
        if with_errors and first.proven:
            forecast[0] = band_forecast(fam, start, these, result.tolerance_mm, loop, first)
        return forecast[0]

    for these in tries:
        try:
            found = trace_bound(
                fam,
                start,
                these,
                result.tolerance_mm,
                loop=loop,
                rounds=rounds,
                on_progress=on_progress,
                upper_commands=float(sequence.n_commands),
                path_mm=np.concatenate(path_mm),
                path_q=np.vstack(path_q),
                max_samples=max_samples,
                with_errors=with_errors,
                after_first=along_band,
            )
            break
        except PlanningError:
            continue
    if not with_errors:
        return found
    if found is not None and forecast[0] > found.value:
        band = band_trace_bound(
            fam, start, these, result.tolerance_mm, loop, found, on_progress=on_progress
        )
        found = with_band(found, band)
    carriage = carriage_travel_bound(
        fam.arm,
        result.curve,
        [(a, b) for a, b in spans],
        start,
        result.tolerance_mm,
    )
    return with_carriage(found, carriage, float(sequence.n_commands))


def _pass_arc_lengths(fam: CurveFamily, q: FloatArray, p: TracePass) -> FloatArray:
    """Arc lengths (mm) of the curve points nearest the tool point at a pass's states ``q``
    (rad), on a closed curve unwrapped along the pass from where it begins, as its
    ``start_mm``..``end_mm`` count them."""
    _, s = fam.curve.closest(tool_position(fam.arm, q))
    s = np.asarray(s, dtype=np.float64)
    if not fam.curve.closed:
        return s
    return unwrapped_along(s, fam.curve.length, p.end_mm if p.backward else p.start_mm)


def unwrapped_along(s_mm: FloatArray, length_mm: float, begin_mm: float) -> FloatArray:
    """Arc lengths ``s_mm`` (mm, each in ``[0, length_mm)``) of consecutive points along a
    closed curve of that length, unwrapped: the first taken nearest ``begin_mm``, each next
    one nearest the one before (consecutive points are less than half the curve apart)."""
    step = np.diff(s_mm)
    step -= length_mm * np.round(step / length_mm)
    first = s_mm[0] + length_mm * np.round((begin_mm - s_mm[0]) / length_mm)
    return np.asarray(first + np.r_[0.0, np.cumsum(step)], dtype=np.float64)


#: A stretch of a reachable arc between two passes longer than this (mm, the resolution the
#: ends of the reachable arcs are found to) is reported as not traced: the coverage counts
#: it (0.5 mm hid a closed curve's 0.38 and 0.16 mm untraced between its two passes).
GAP_REPORTED_MM = 0.05
#: How far a pass once round a closed curve runs on past where it began (mm; at most twice the
#: tolerance): its ends then meet though each is reached within GOAL_REACHED_MM. Twice a wide
#: tolerance ran on further than that for nothing: the seed's 25 mm free circle took 53
#: commands with 10 mm, one more than with 3 mm.
LOOP_OVERLAP_MM = 0.2


#: Points of an untraced stretch at which the lattice is searched for a state within the
#: tolerance (at most; a tolerance apart on shorter stretches).
HOLE_PROBES = 48


def _lattice_holes(fam: CurveFamily, tolerance_mm: float, arc: CurveArc) -> FloatArray:
    """Arc lengths (mm) of points evenly inside ``arc`` near which no lattice state puts the
    tool point within ``tolerance_mm``, each proven by listing every state of the joints that
    move it over their ranges (:func:`~armpath.planning.bounds.lattice_goals.lattice_state_exists`,
    obstacles left out). Up to :data:`HOLE_PROBES` points, a tolerance apart where the arc is
    shorter; the search stops at the first point it cannot decide (its budget spent)."""
    count = int(min(HOLE_PROBES, max(1.0, np.ceil(arc.length_mm / tolerance_mm))))
    s = arc.start_mm + (np.arange(count) + 0.5) * arc.length_mm / count
    points = fam.curve.at_arc_length(fam.curve.wrap(s)) / fam.arm.mm_per_unit
    holes = []
    for s_mm, point in zip(s, points, strict=True):
        check_time("describing the untraced arcs")
        exists = lattice_state_exists(
            fam.arm, point, tolerance_mm / fam.arm.mm_per_unit, fam.tip_joints
        )
        if exists is None:
            break
        if not exists:
            holes.append(s_mm)
    return np.asarray(fam.curve.wrap(np.array(holes)), dtype=np.float64)


def _with_lattice_reason(
    fam: CurveFamily, tolerance_mm: float, gaps: list[tuple[CurveArc, str]]
) -> list[tuple[CurveArc, str]]:
    """The gaps between passes, each with what the lattice says of it: the points of it near
    which no lattice state puts the tool point within the tolerance (:func:`_lattice_holes`,
    a proof), where no command of a pass can end; else, where three joints or fewer move the
    tool point (a SCARA's two arm joints and its quill), how far one tick moves it there: with
    no joint left to take up the error, few lattice states lie within the tolerance of the
    curve."""
    tip = fam.tip_joints
    out = []
    for arc, why in gaps:
        check_time("describing the untraced arcs")
        holes = _lattice_holes(fam, tolerance_mm, arc)
        if holes.size:
            where = (
                f"at {holes[0]:.2f} mm"
                if holes.size == 1
                else f"at {holes.size} points from {holes[0]:.2f} to {holes[-1]:.2f} mm"
            )
            out.append(
                (
                    arc,
                    f"{why}; no lattice state at all puts the tool point within "
                    f"{tolerance_mm:g} mm of the curve {where} (every state of the "
                    f"{int(tip.sum())} joints that move it listed over their ranges, "
                    "obstacles left out), so no command can end near them: the lattice is "
                    "coarse for this tolerance there",
                )
            )
            continue
        if int(tip.sum()) > 3:
            out.append((arc, why))
            continue
        v = fam.best(float(fam.curve.wrap(0.5 * (arc.start_mm + arc.end_mm))))
        if v.out_of_reach:
            out.append((arc, why))
            continue
        tick_mm = float(np.linalg.norm(tick_jacobian(fam.arm, v.q), axis=0)[tip].max())
        if tick_mm <= tolerance_mm:
            out.append((arc, why))
            continue
        out.append(
            (
                arc,
                f"{why} (only {int(tip.sum())} joints move the tool point, up to "
                f"{tick_mm:.2g} mm a tick here: few lattice states lie within "
                f"{tolerance_mm:g} mm of the curve)",
            )
        )
    return out


def _gaps_between_passes(
    arcs: list[CurveArc],
    passes: list[TracePass],
    already: list[tuple[CurveArc, str]],
    closed_mm: float | None = None,
) -> list[tuple[CurveArc, str]]:
    """The stretches of the reachable ``arcs`` that no pass covers and that are not reported
    yet (``already``): where a pass found no command continuing it within the tolerance and
    the next pass began farther on. ``closed_mm``: the length of a closed curve, on which an
    arc all round it has no ends: the stretch after its last pass and the one before its
    first are one, running on past where the arc begins."""
    between = (
        "the tracer found no lattice command continuing the pass within the tolerance here; "
        "the next pass starts past it"
    )
    out: list[tuple[CurveArc, str]] = []
    for arc in arcs:
        spans = _spans_on(arc, [(p.start_mm, p.end_mm) for p in passes], closed_mm, 1e-9)
        spans += _spans_on(arc, [(a.start_mm, a.end_mm) for a, _ in already], closed_mm, 0.0)
        spans.sort()
        if not spans:
            continue
        all_round = closed_mm is not None and arc.length_mm >= closed_mm - 1e-9
        reached = arc.start_mm
        for k, (a, b) in enumerate(spans):
            if a - reached > GAP_REPORTED_MM and not (all_round and k == 0):
                out.append((CurveArc(reached, a), between))
            reached = max(reached, b)
        if all_round:
            assert closed_mm is not None
            # from the last pass's end round to the first's start
            head = max(spans[0][0] - arc.start_mm, 0.0)
            if arc.end_mm - reached + head > GAP_REPORTED_MM:
                shift = closed_mm if reached >= closed_mm else 0.0
                out.append((CurveArc(reached - shift, spans[0][0] + closed_mm - shift), between))
        elif arc.end_mm - reached > GAP_REPORTED_MM:
            out.append(
                (
                    CurveArc(reached, arc.end_mm),
                    "the tracer found no lattice command continuing the last pass within "
                    "the tolerance to the end of the reachable arc",
                )
            )
    return out


def _spans_on(
    arc: CurveArc, spans: list[tuple[float, float]], closed_mm: float | None, slack: float
) -> list[tuple[float, float]]:
    """The parts of ``spans`` (arc lengths, mm) that lie on ``arc``, in its terms: on a closed
    curve of length ``closed_mm`` a span is taken a whole number of turns on or back too (a
    pass once round from where a re-trace began runs past the curve's length, and an arc
    round it may begin anywhere), each part clipped to the arc; ``slack`` (mm): how near its
    ends a span may end and still count."""
    turns = [0.0]
    if closed_mm is not None:
        turns = [k * closed_mm for k in range(-2, 3)]
    out = []
    for a, b in spans:
        for shift in turns:
            lo, hi = a + shift, b + shift
            if hi > arc.start_mm - slack and lo < arc.end_mm + slack:
                out.append((max(lo, arc.start_mm), min(hi, arc.end_mm)))
    return out


def _search_need(arm: SerialArm, world: CollisionWorld, opts: TraceOptions) -> FloatArray:
    """Each pair's clearance the motion planner's search needs of its states (mm)."""
    return np.asarray(
        world.required(arm)
        + search_clearance_extra(arm, world, opts.motion.buffer_mm, opts.motion.sample_spacing_mm),
        dtype=np.float64,
    )


def _search_slack(
    arm: SerialArm, world: CollisionWorld, q_ticks: IntArray, need: FloatArray
) -> FloatArray:
    """Of lattice states ``q_ticks`` ``(..., n)``, the smallest slack over the pairs against
    ``need`` (:func:`_search_need`; mm): the state has the search's room where it is >= 0
    (infinite where no pair is checked: an arm with no obstacle and no link pair apart)."""
    values, _ = world.pair_clearances(arm, arm.lattice.to_joint(q_ticks))
    return np.asarray(np.min(values - need, axis=-1, initial=np.inf), dtype=np.float64)


def _lift_off(
    arm: SerialArm,
    world: CollisionWorld,
    q_ticks: IntArray,
    opts: TraceOptions,
    toward: IntArray | None = None,
) -> CommandSequence:
    """Commands that take the arm from the end of a pass (tool on the surface, links possibly in
    a tight spot) to a state with the room the motion planner's search needs.

    Greedy escape: from each state, random full-size commands (seeded) are scored by their end
    state's smallest slack against the search's clearance needs, and the best one whose continuous
    motion is certified clear is taken; at most 12 commands. ``toward`` (a lattice state the
    lift-off will be run backward from, see :func:`_enter_backward`): the commands that bring
    the arm a whole command nearer it (every joint within one command fewer of it) are tried
    first, and the best certified one is taken where it gains slack, so the transit through
    the lift-off needs no more commands than the straight motion (the seed crack: 70 -> 69).
    """
    need = _search_need(arm, world, opts)
    active = active_joints(arm)
    grid = arm.lattice
    rng = np.random.default_rng([opts.motion.seed, 7])
    rng_nearer = np.random.default_rng([opts.motion.seed, 8])
    states = [np.asarray(q_ticks, dtype=np.int64)]

    def slack(q: IntArray) -> FloatArray:
        return _search_slack(arm, world, q, need)

    def best_certified(here: IntArray, cand: IntArray, floor: float) -> IntArray | None:
        """Of ``cand`` (within the limits), the one of most slack above ``floor`` among the 16
        of most slack whose straight motion from ``here`` is certified clear."""
        cand = cand[arm.within_limits(arm.lattice.to_joint(cand))]
        if cand.shape[0] == 0:
            return None
        sc = slack(cand)
        for k in np.argsort(-sc)[:16]:
            if sc[k] <= floor:
                break
            seq = CommandSequence.straight(here, cand[k], lattice=grid)
            if motion_clearance(arm, world, seq).certified_ok:
                return np.asarray(cand[k], dtype=np.int64)
        return None

    for _ in range(12):
        check_time("lifting off the curve")
        here = states[-1]
        here_slack = float(slack(here[None])[0])
        if here_slack >= 0.0:
            break
        found = None
        if toward is not None and np.any(toward != here):
            # each joint ends within one command fewer of ``toward`` (and moves one at most)
            gap = np.asarray(toward, dtype=np.int64) - here
            fewer = int(grid.commands_needed(gap)) - 1
            lo = np.maximum(-grid.max_ticks, gap - fewer * grid.max_ticks) * active
            hi = np.minimum(grid.max_ticks, gap + fewer * grid.max_ticks) * active
            if np.all(lo <= hi):
                nearer = here + rng_nearer.integers(lo, hi + 1, (4000, here.size))
                found = best_certified(here, nearer, here_slack)
        if found is None:
            # random commands of every size up to each joint's largest (in twentieths of it)
            size = rng.uniform(1.0, 20.0, (4000, 1)) / 20.0 * grid.max_ticks
            steps = np.round(rng.uniform(-1.0, 1.0, (4000, here.size)) * size).astype(np.int64)
            found = best_certified(here, here + steps * active, -np.inf)
        if found is None:
            break
        states.append(found)
    return CommandSequence.from_states(np.array(states, dtype=np.int64), grid)


@dataclass(frozen=True)
class _Tracing:
    """What tracing the arcs made (see :func:`_trace_arcs`): states, passes, transits, arcs
    not traced and the deviation profile; ``approach_charged``: whether a pass followed a
    reference shortened with its approach charged."""

    states: list[IntArray]
    passes: list[TracePass]
    transits: list[Transit]
    not_traced: list[tuple[CurveArc, str]]
    profile_s: list[FloatArray]
    profile_d: list[FloatArray]
    approach_charged: bool = False

    def covered_mm(self, curve: Curve) -> float:
        """How much of ``curve`` its passes cover (mm; an overlap counted once: a pass that
        ran over another's end made a tracing look as if it covered more)."""
        return _covered_mm(curve, [CurveArc(p.start_mm, p.end_mm) for p in self.passes])

    def without_idle_last_pass(self, curve: Curve) -> _Tracing:
        """This tracing without its last pass (and the transit onto it) where that pass covers
        less than :data:`GAP_REPORTED_MM` of the curve that the others leave (a pass begun just
        short of where the first one began, in a stretch a break left before it)."""
        if len(self.passes) < 2 or len(self.transits) < len(self.passes):
            return self
        last = self.passes[-1]
        if _new_coverage_mm(curve, self.passes[:-1], last.start_mm, last.end_mm) >= (
            GAP_REPORTED_MM
        ):
            return self
        onto = self.transits[-1]
        return replace(
            self,
            states=self.states[: onto.first + 1],
            passes=self.passes[:-1],
            transits=self.transits[:-1],
            profile_s=self.profile_s[:-1],
            profile_d=self.profile_d[:-1],
        )

    def better_than(self, other: _Tracing, slack_mm: float, curve: Curve) -> bool:
        """Whether this tracing of the same arcs of ``curve`` is the one to keep: fewer
        commands (then fewer passes) where it covers no less than ``other`` less ``slack_mm``,
        else more covered."""
        mine, theirs = self.covered_mm(curve), other.covered_mm(curve)
        if abs(mine - theirs) > slack_mm:
            return mine > theirs
        return (len(self.states), len(self.passes)) < (len(other.states), len(other.passes))


def _new_coverage_mm(
    curve: Curve, passes: list[TracePass], start_mm: float, end_mm: float
) -> float:
    """How much of ``curve`` (mm) the arc ``start_mm`` .. ``end_mm`` covers that ``passes``
    do not."""
    before = [CurveArc(p.start_mm, p.end_mm) for p in passes]
    return _covered_mm(curve, [*before, CurveArc(start_mm, end_mm)]) - _covered_mm(curve, before)


def _covered_mm(curve: Curve, arcs: list[CurveArc]) -> float:
    """The length of ``curve`` the union of ``arcs`` covers (mm)."""
    return float(sum(b - a for a, b in merged_arcs(arcs, curve.length, curve.closed)))


#: Points along a closed curve where :func:`_nearest_loop_start` looks for the member nearest
#: the arm, and the slack (mm or deg) such a member keeps: begun there, the UR5 cell's 40 mm
#: circle took 103 commands rather than 108 (102 since the tracer's endgame looks ahead), its
#: 80 mm circle 114 rather than 122, the seam 182 either way.
_LOOP_STARTS = 24
_LOOP_START_SLACK = 0.3


def _span_text(curve: Curve, arc: CurveArc) -> str:
    """Where an arc lies on the curve, for progress lines: ``23.8..121.0 mm``; on a closed
    curve ``once round from 23.8 mm``, or ``560.0..10.2 mm (through 0)`` where it runs past the
    curve's start (:func:`~armpath.geometry.curves.arc_within_round`)."""
    if not curve.closed:
        return f"{arc.start_mm:.1f}..{arc.end_mm:.1f} mm"
    start, end, whole, through = arc_within_round(arc.start_mm, arc.end_mm, curve.length)
    if whole:
        return f"once round from {start:.1f} mm"
    return f"{start:.1f}..{end:.1f} mm{' (through 0)' if through else ''}"


def _followed_end_chain(
    tracer: Tracer, goal: float, left_mm: float, hold: IntArray, listed: bool = True
) -> list[IntArray]:
    """The end chain (:meth:`Tracer.end_chain`) over :data:`END_CHAIN_SHARE` of the
    ``left_mm`` from where the pass stands to ``goal``, now followed by ``tracer``."""
    chain = tracer.end_chain(goal, END_CHAIN_SHARE * left_mm, hold=hold, listed=listed)
    tracer.follow(chain)
    return chain


def _trace_arcs(
    arm: SerialArm,
    world: CollisionWorld,
    reach: CurveReachability,
    start: IntArray,
    arcs: list[CurveArc],
    overlap: float,
    opts: TraceOptions,
    say: Callable[[str], None],
    charge_approach: bool = False,
) -> _Tracing:
    """Trace ``arcs`` in turn from ``start`` (the last one running on by ``overlap`` mm), each
    piece the way its reference DP chose (``charge_approach``: a piece's reference may be
    shortened with the approach onto it charged, see :func:`reference_pieces`). An arc whose
    pass gets stuck is put back shorter by 1 mm or more, so the loop ends."""
    fam = reach.family
    curve = reach.curve
    states: list[IntArray] = [start]
    passes: list[TracePass] = []
    transits: list[Transit] = []
    not_traced: list[tuple[CurveArc, str]] = []
    prof_s: list[FloatArray] = []
    prof_d: list[FloatArray] = []
    queue: list[tuple[CurveArc, float]] = [(arc, 0.0) for arc in arcs]
    pieces_charged: list[bool] = []
    queue[-1] = (queue[-1][0], overlap)

    def certify(
        pass_states: list[IntArray], begin: float
    ) -> tuple[float, float, FloatArray, FloatArray]:
        """The pass's certified deviation (:func:`certified_deviation`) at the precision its
        tolerance asks."""
        precision = certificate_precision(opts.tolerance_mm)
        return certified_deviation(arm, curve, np.array(pass_states), begin, precision)

    while queue:
        check_time("tracing the curve")
        arc, run_on = queue.pop(0)
        say(f"choosing the reference path along {_span_text(curve, arc)} of the curve")
        try:
            pieces = reference_pieces(
                fam,
                arc,
                opts.layer_step_mm,
                arm.lattice.to_joint(states[-1]),
                charge_approach=charge_approach,
            )
        except PlanningError as exc:
            # no clear member on the reference's layers (a short rest of an arc in a tight
            # spot): reported with the arcs not traced; the passes made so far stand
            not_traced.append((arc, str(exc)))
            continue
        for k, piece in enumerate(pieces):
            pieces_charged.append(piece.approach_charged)
            last_piece = k == len(pieces) - 1
            say(f"tracing pass {len(passes) + 1}: {_span_text(curve, piece.arc)} of the curve")
            tracer = Tracer(fam, piece, opts.tolerance_mm, band_share=BAND_SHARE)
            tracer.align(arm.lattice.to_joint(states[-1]))
            here = len(states) - 1
            if passes:  # lift off first, to where the transit's search has room
                states.extend(list(_lift_off(arm, world, states[-1], opts).states()[1:]))
            try:
                motion, q_entry, s_entry = _enter(tracer, reach, states[-1], opts, say)
            except PlanningError as exc:
                # this piece is reachable but cannot be entered from here: report it, go on
                not_traced.append((piece.arc, str(exc)))
                continue
            sign, begin, finish = piece.sign, piece.begin_mm, piece.finish_mm
            goal = finish + sign * (run_on if last_piece else 0.0)
            entered = len(states)
            for again, share in enumerate((BAND_SHARE, FALLBACK_BAND_SHARE)):
                if again:
                    # the pass's certified deviation exceeded the tolerance: traced again from
                    # the same entry, its tool point kept nearer the curve
                    del states[entered:]
                    transits.pop()
                    tracer = Tracer(fam, piece, opts.tolerance_mm, band_share=share)
                    tracer.align(arm.lattice.to_joint(states[here]))
                pass_states, s_at = [q_entry], s_entry
                if sign * (s_at - begin) > GOAL_REACHED_MM:  # back to where the piece begins
                    pass_states, s_at = tracer.run(q_entry, s_at, begin)
                entry, pass_states = _entry_merged(arm, world, motion, pass_states)
                states.extend(list(entry.sequence.states()[1:]))
                transits.append(Transit(here, len(states) - 1, entry.method))
                first = len(states) - 1
                # onto an arc's end (not a loop's run on past where it began): also traced
                # from there back, followed and finished along where that takes fewer commands
                chain = None
                unchained = tracer.reference
                if goal == finish:
                    chain = _followed_end_chain(tracer, goal, abs(finish - s_at), pass_states[-1])
                elif curve.closed and abs(finish - begin) >= curve.length - 1e-6:
                    # once round a closed curve: the pass may end on the state it begins from
                    # (where it began, it is within the tolerance and clear)
                    chain = [pass_states[-1]]
                # traced with the lattice states the band holds listed past the farthest near
                # the reference and, onto an arc's end where that took any, without; where the
                # end chain's listing took any, also without along a chain traced without (the
                # pass follows its chain). The farthest commands can leave the tip where the
                # next ones get less far (the seed crack: 141 commands with, 139 without; a
                # 600 mm line before the UR5: 62 along with, 62 without along the chain traced
                # with, 56 along the chain traced without; the SO-100's circle the other way
                # round). A loop is traced once, with them: none took more (the seed's and the
                # UR5 cell's circles, the cell's seam), and tracing the UR5's circle twice
                # took 32 s rather than 15 s
                runs = [tracer.run(pass_states[-1], s_at, goal, chain)]
                if goal == finish and tracer.listed_taken:
                    runs.append(tracer.run(pass_states[-1], s_at, goal, chain, listed=False))
                if goal == finish and tracer.chain_listed_taken:
                    # (a chain whose listing took none is the one traced without it)
                    tracer.reference = unchained
                    chain = _followed_end_chain(
                        tracer, goal, abs(finish - s_at), pass_states[-1], listed=False
                    )
                    runs.append(tracer.run(pass_states[-1], s_at, goal, chain, listed=False))
                at_goal = sign * goal - GOAL_REACHED_MM
                ahead, s_reached = min(runs, key=lambda r: (-min(sign * r[1], at_goal), len(r[0])))
                pass_states += ahead[1:]
                states.extend(pass_states[1:])
                if len(pass_states) == 1:
                    break
                dev, dev_bound, ps, pd = certify(pass_states, begin)
                if dev_bound <= opts.tolerance_mm:
                    break
            cut = False
            if len(pass_states) > 1 and dev_bound > opts.tolerance_mm:
                # traced again, still not proven within the tolerance: the pass ends before
                # its first command that is not, and the rest of the arc gets new passes
                kept = _commands_within(certify, pass_states, begin, opts.tolerance_mm)
                del states[first + kept + 1 :]
                s_reached = float(ps[PROFILE_PER_COMMAND * kept])
                pass_states = pass_states[: kept + 1]
                cut = True
                if kept:
                    dev, dev_bound, ps, pd = certify(pass_states, begin)
            if len(pass_states) == 1 or (
                _new_coverage_mm(curve, passes, float(ps.min()), float(ps.max())) < GAP_REPORTED_MM
                and abs(finish - begin) > GAP_REPORTED_MM
            ):
                # entered but no command along the curve, or commands that add less to what
                # the passes cover than a stretch left untraced is reported for (the SO-100's
                # circle: entered where a break lay ahead, 0.06 mm in two commands, all but
                # 0.01 mm covered already): not a pass, nor is the way there kept: the next
                # try starts from where this one did
                del states[here + 1 :]
                transits.pop()
                rest = _rest_of_arc(arc, piece, s_reached, made_pass=False)
                if rest is not None:
                    queue.insert(0, (rest, run_on))
                break
            prof_s.append(ps)
            prof_d.append(pd)
            angle, angle_bound = None, None
            if opts.axis_rule is not None:
                angle, angle_bound = certified_axis_angle(
                    arm, fam.axis_angles, np.array(pass_states), not opts.axis_rule.normal
                )
            stuck = cut or sign * (finish - s_reached) > 0.5
            if cut:
                ends = (
                    "the next command's continuous path was not proven within the tolerance "
                    f"(at {curve.wrap(s_reached):.1f} mm)"
                )
            elif stuck:
                ends = (
                    "no lattice command went on from its last state within the tolerance and "
                    "clear "
                    f"(at {curve.wrap(s_reached):.1f} mm)"
                )
            elif not last_piece:
                ends = (
                    "its reference path lifts off here: the solution family cannot be "
                    "followed on continuously (the members ahead lie a lift-off away: "
                    "a joint limit, a change of branch or an obstacle)"
                )
            else:
                ends = ""
            passes.append(
                TracePass(
                    first,
                    len(states) - 1,
                    float(ps.min()),
                    float(ps.max()),
                    dev,
                    dev_bound,
                    angle,
                    angle_bound,
                    piece.backward,
                    ends,
                )
            )
            if stuck:
                # stuck: the rest of the arc gets new passes (see _rest_of_arc)
                rest = _rest_of_arc(arc, piece, s_reached, made_pass=True)
                if rest is not None:
                    queue.insert(0, (rest, run_on))
                break
    charged = any(pieces_charged)
    return _Tracing(states, passes, transits, not_traced, prof_s, prof_d, charged)


def _commands_within(
    certify: Callable[[list[IntArray], float], tuple[float, float, FloatArray, FloatArray]],
    pass_states: list[IntArray],
    begin: float,
    tolerance_mm: float,
) -> int:
    """How many of a pass's first commands are each proven to keep the tool point within
    ``tolerance_mm`` of the curve (``certify``, the pass's certificate, of each alone)."""
    for k in range(len(pass_states) - 1):
        if certify(pass_states[k : k + 2], begin)[1] > tolerance_mm:
            return k
    return len(pass_states) - 1


def _entry_merged(
    arm: SerialArm, world: CollisionWorld, motion: MotionPlan, back: list[IntArray]
) -> tuple[MotionPlan, list[IntArray]]:
    """The transit onto a pass (``motion``) and the commands that run the pass back from where
    it was entered to where it begins (``back``: its states, the entry first), merged where
    certified straight motions need fewer commands (:func:`merged_certified`); with the states
    the pass then begins from. The run back covers nothing the pass does not cover again on its
    way on, so the transit may end where it ends (an entry where there is room, traced back to
    the end of the arc; the seed crack, before :func:`_enter` moved its tight entry on to where
    the run back ends, saved its one command back this way: 145 -> 144)."""
    if motion.sequence.n_commands + len(back) - 1 < 2:
        return motion, back
    joined = motion.sequence.then(CommandSequence.from_states(np.array(back), arm.lattice))
    merged = merged_certified(arm, world, replace(motion, sequence=joined))
    if merged.sequence is joined:  # nothing fewer: the transit and the run back as they were
        return motion, back
    return merged, [back[-1]]


def _nearest_loop_start(
    fam: CurveFamily, q_from: FloatArray, length_mm: float, s_first: float
) -> float:
    """Where to begin a closed curve reachable all around (arc length, mm): of
    :data:`_LOOP_STARTS` points spread along it from ``s_first``, the one with a family member
    nearest ``q_from`` (rad; largest joint change of the joints that move the tool point, whole
    turns of unlimited joints the shorter way) among those with :data:`_LOOP_START_SLACK` of
    slack; ``s_first`` when none has."""
    tip, units = fam.tip_joints, CommandUnits.of_family(fam)
    best, pick = np.inf, s_first
    for s0 in s_first + np.arange(_LOOP_STARTS) * length_mm / _LOOP_STARTS:
        check_time("choosing where to begin the curve")
        q = fam.configs(float(s0), fam.coarse_dirs)
        if q.shape[0] == 0:
            continue
        q = q[fam.score(q, ceiling=_LOOP_START_SLACK) >= _LOOP_START_SLACK]
        turn = _joint_change(units.units(q[:, tip]), units.units(q_from[tip]), units.period)
        if turn.size and float(turn.min()) < best:
            best, pick = float(turn.min()), float(s0)
    return pick


def _rest_of_arc(arc: CurveArc, piece: Piece, s_reached: float, made_pass: bool) -> CurveArc | None:
    """What is left of ``arc`` to trace after a pass on ``piece`` stopped at ``s_reached`` (mm)
    short of the piece's far end, or None when less than 0.5 mm is left. The rest resumes where
    the pass stopped, or 2 mm past where the piece begins when the pass made no progress (or
    no pass was made): so every arc put back is shorter by 1 mm or more and the loop ends."""
    begin = piece.begin_mm
    if piece.backward:
        moved = made_pass and s_reached < begin - 1.0
        resume = s_reached if moved else min(s_reached, begin) - 2.0
        return CurveArc(arc.start_mm, resume) if resume > arc.start_mm + 0.5 else None
    moved = made_pass and s_reached > begin + 1.0
    resume = s_reached if moved else max(s_reached, begin) + 2.0
    return CurveArc(resume, arc.end_mm) if resume < arc.end_mm - 0.5 else None


def _enter_backward(
    tracer: Tracer, q_from: IntArray, q_start: IntArray, opts: TraceOptions
) -> MotionPlan:
    """A transit from ``q_from`` into the tight state ``q_start`` at the start of an arc: the
    arm lifts off from ``q_start`` (:func:`_lift_off`) to a state with room for the search, the
    search plans the way there, and the lift-off is run backward (a command's continuous
    motion is the same path either way, so its clearance holds backward too). The whole transit
    is certified again."""
    arm, world = tracer.arm, tracer.world
    lift = _lift_off(arm, world, q_start, opts, toward=q_from).states()
    if lift.shape[0] < 2 and _search_slack(arm, world, q_start, _search_need(arm, world, opts)) < 0:
        raise PlanningError("no lift-off from there gives the search room")
    # (a state with the room already is searched to as it is: no lift-off is needed; a seam
    # 1 mm above a table was left untraced there, "no lift-off gives the search room")
    search = plan_motion(arm, world, q_from, lift[-1][None, :], opts.motion)
    states = np.concatenate([search.sequence.states(), lift[-2::-1]])
    seq = CommandSequence.from_states(states, tracer.grid)
    mc = motion_clearance(arm, world, seq)
    if not mc.certified_ok:  # the search's own leg is certified; this is the safety net
        raise PlanningError("the lift-off run backward is not certified clear")
    direct = tracer.grid.commands_needed(q_start - q_from)
    return MotionPlan(
        seq,
        0,
        mc,
        plan_metrics(arm, seq),
        direct,
        f"{search.method} + lift-off run backward",
        search.searched_samples,
    )


def _enter(
    tracer: Tracer,
    reach: CurveReachability,
    q_from: IntArray,
    opts: TraceOptions,
    say: Callable[[str], None],
) -> tuple[MotionPlan, IntArray, float]:
    """Move from ``q_from`` onto the curve near where the tracer's piece begins (its start, or
    its end for a piece traced backward).

    The end of an arc is usually a tight spot (that is why the arc ends there): it is entered
    by a straight motion, or by a search to a roomier state the arm can lift off to from there
    and that lift-off run backward (:func:`_enter_backward`). Otherwise the entry is one of the
    first scan points along the piece whose best configuration keeps the transit search's buffer
    plus half its sample spacing plus 0.5 mm of slack; the pass then runs back to where the
    piece begins before tracing on.
    """
    arc = tracer.arc
    L = reach.curve.length
    scan_s = reach.scan_s_mm

    def at(s: float) -> str:  # where on the curve, for the messages (a closed one's wrapped)
        return f"{float(reach.curve.wrap(s)):.1f} mm"

    if reach.curve.closed:
        scan_s = np.concatenate([scan_s, scan_s + L, scan_s + 2 * L])
        scores = np.tile(reach.scan_score, 3)
    else:
        scores = reach.scan_score
    inside = (scan_s >= arc.start_mm) & (scan_s <= arc.end_mm)
    need = opts.motion.buffer_mm + opts.motion.sample_spacing_mm / 2 + 0.5
    roomy = scan_s[inside & (scores >= need)]
    candidates = [tracer.piece.begin_mm, *tracer.piece.in_order(roomy)[:3].tolist()]
    failures = []
    for i, s_try in enumerate(candidates):
        try:
            q, s = tracer.start_state(s_try, need if i else _BODY_BUFFER_MM, hold=q_from)
        except PlanningError as exc:
            failures.append(str(exc))  # it names the point
            continue
        if i == 0 and tracer.piece.sign * (s - tracer.piece.begin_mm) > GOAL_REACHED_MM:
            # entered a little past where the piece begins: the transit goes on to where the
            # tracer gets back to it, which the pass is then traced from (the seed crack: its
            # one command back, 0.06 mm)
            back, s_back = tracer.run(q, s, tracer.piece.begin_mm)
            if tracer.piece.sign * (s_back - tracer.piece.begin_mm) <= GOAL_REACHED_MM:
                q, s = back[-1], s_back
        say(f"moving onto the curve at {at(s)}")
        if i == 0:  # the tight start of the arc: a straight motion, else a lift-off reversed
            seq = CommandSequence.straight(q_from, q, lattice=tracer.grid)
            mc = motion_clearance(tracer.arm, tracer.world, seq)
            if mc.certified_ok:
                m = plan_metrics(tracer.arm, seq)
                return MotionPlan(seq, 0, mc, m, seq.n_commands, "direct", 0), q, s
            try:
                return _enter_backward(tracer, q_from, q, opts), q, s
            except PlanningError as exc:
                failures.append(f"{at(s)}: the straight motion there is blocked; {exc}")
            continue
        # one search per entry point but the last: another entry often works where one fails
        motion_opts = opts.motion if i == len(candidates) - 1 else replace(opts.motion, attempts=1)
        try:
            return plan_motion(tracer.arm, tracer.world, q_from, q[None, :], motion_opts), q, s
        except PlanningError as exc:
            failures.append(f"{at(s)}: {exc}")
    # no room for a searched transit anywhere: straight motions onto the first scan points of
    # the piece where the links keep the tracer's small buffer
    tight = tracer.piece.in_order(scan_s[inside & (scores >= _BODY_BUFFER_MM)])[:8]
    blocked = stateless = 0
    for s_try in tight.tolist():
        check_time("moving onto the curve")
        try:
            q, s = tracer.start_state(s_try, _BODY_BUFFER_MM, hold=q_from)
        except PlanningError:
            stateless += 1
            continue
        seq = CommandSequence.straight(q_from, q, lattice=tracer.grid)
        mc = motion_clearance(tracer.arm, tracer.world, seq)
        if mc.certified_ok:
            say(f"moving onto the curve at {at(s)} (straight)")
            m = plan_metrics(tracer.arm, seq)
            return MotionPlan(seq, 0, mc, m, seq.n_commands, "direct", 0), q, s
        blocked += 1
    if blocked:
        failures.append(f"straight motions onto {blocked} more points of the arc are blocked too")
    if stateless:
        failures.append(f"{stateless} more points of the arc have no lattice state to start from")
    # each reason once (the arc's start and its first roomy scan point may be one point)
    raise PlanningError("could not move onto the curve: " + "; ".join(dict.fromkeys(failures)))
