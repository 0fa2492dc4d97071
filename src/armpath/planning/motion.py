"""Collision-free motion on the command lattice: from a start state to one of several goal states.

Pipeline (:func:`plan_motion`):

1. **Direct**: the straight motion to each goal (fewest commands: ``ceil(largest change / 2 deg)``)
   is certified by :func:`~armpath.planning.motion_check.motion_clearance`; the first clear one
   wins, unless a nearer goal (one needing fewer direct commands) is blocked: then the search
   runs too and the shorter of the two is kept. Where none is clear, two straight motions
   through a waypoint (given ones, and ones drawn where the two need no more commands than the
   straight one: :func:`fewest_command_waypoints`) compete with the search.
2. **Search**: RRT-Connect in joint space (:mod:`armpath.planning.rrt`) with an edge test that
   samples each straight segment so densely that no arm point moves more than
   ``sample_spacing_mm`` between samples and demands the margin plus ``buffer_mm`` plus half that
   spacing at every sample (so the segment is provably clear of the body rule), then shortcuts.
3. **Onto the lattice**: the path is followed at full speed (states at equal largest-change
   steps of at most 2 deg, rounded to ticks), then state-level shortcuts merge runs of commands
   whenever a straight motion needs fewer commands and passes the edge test.
4. **Certify**: the final command sequence is checked on its continuous motion; if it fails
   (rounding near an obstacle), the search is repeated with 1.5 times the buffer and half the
   sample spacing. With ``searches`` > 1, several successful searches (different seeds) are
   made and the best by the objective is kept.

Objectives (seed 000 section 5.2.5): ``commands`` (default: largest-change path length),
``path`` (fingertip path length) and ``energy`` (weighted joint travel) steer the shortcuts and the
choice among goals; every plan reports all three (:class:`PlanMetrics`).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import MAX_COMMANDS, MAX_SEARCHES, check_size, check_time
from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError, PlanningError
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import (
    displacement_bounds,
    joints_that_move,
    landmark_positions,
    position_jacobian,
    tool_position,
)
from armpath.model.lattice import Lattice
from armpath.model.serial_arm import SerialArm
from armpath.planning.choices import Objective, objective_of
from armpath.planning.motion_check import MotionClearance, check_state_clear, motion_clearance
from armpath.planning.rrt import EdgeChecker, RrtOptions, rrt_connect, shortcut
from armpath.planning.tighten import tightened

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class PlanMetrics:
    """How a command sequence scores on every objective.

    ``tip_path_mm`` is the length of the fingertip's continuous path; ``energy_deg`` the joint
    travel ``sum_i w_i sum_k |d_ik|`` (deg, weights ``w``); ``joint_travel_deg`` the unweighted
    travel per joint.
    """

    commands: int
    tip_path_mm: float
    energy_deg: float
    joint_travel_deg: tuple[float, ...]


#: Largest energy weight of a joint (only the weights' ratios matter; a larger one makes the
#: weighted travel overflow).
MAX_ENERGY_WEIGHT = 1e6


@dataclass(frozen=True)
class MotionOptions:
    """Settings of :func:`plan_motion` (lengths mm, angles deg).

    Attributes
    ----------
    objective:
        What to minimise (see :class:`Objective`).
    energy_weights:
        Per-joint weights of the energy objective (default all 1).
    buffer_mm:
        Extra clearance the search keeps beyond the rule, so that rounding the path to the
        lattice does not break it (times 1.5 on each retry, while the spacing halves). Goal
        states must keep the margin plus this buffer plus half the spacing for the body.
    sample_spacing_mm:
        Largest displacement of any arm point between two samples of a searched segment.
    rrt:
        RRT-Connect settings.
    shortcut_rounds:
        Random shortcut attempts on the searched path.
    attempts:
        Failed searches tolerated (each retry with a new seed, 1.5 times the buffer and half
        the spacing) before giving up.
    searches:
        Successful searches (different seeds) whose best plan by the objective is kept (more
        searches: often fewer commands, proportionally more time).
    approach_mm:
        A goal whose tool tip is closer than this to a surface is searched for at a pre-goal
        with the tip backed off this far along the surface normal; the last motion goes
        straight from there to the goal (the tip meets the surface head-on).
    seed:
        Seed of the random generator: the same seed gives the same plan.
    """

    objective: Objective = Objective.COMMANDS
    energy_weights: tuple[float, ...] | None = None
    buffer_mm: float = 0.4
    sample_spacing_mm: float = 2.0
    rrt: RrtOptions = field(default_factory=RrtOptions)
    shortcut_rounds: int = 300
    attempts: int = 3
    searches: int = 1
    approach_mm: float = 3.0
    seed: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "objective", objective_of(self.objective))
        if not (np.isfinite(self.buffer_mm) and self.buffer_mm >= 0):
            raise InvalidInputError(f"buffer must be >= 0 mm, got {self.buffer_mm}")
        if not (np.isfinite(self.sample_spacing_mm) and 0.01 <= self.sample_spacing_mm <= 100):
            raise InvalidInputError(
                f"sample spacing must be in [0.01, 100] mm, got {self.sample_spacing_mm}"
            )
        if not (1 <= self.searches <= MAX_SEARCHES and 1 <= self.attempts <= MAX_SEARCHES):
            raise InvalidInputError(
                f"searches and attempts must be in [1, {MAX_SEARCHES}], got {self.searches} and "
                f"{self.attempts}"
            )
        if not 0 <= self.shortcut_rounds <= 100_000:
            raise InvalidInputError(
                f"shortcut rounds must be in [0, 100000], got {self.shortcut_rounds}"
            )
        if self.energy_weights is not None and self.objective is not Objective.ENERGY:
            raise InvalidInputError(
                "energy weights go with the energy objective (--objective energy; "
                f"objective='energy' in Python), not {self.objective.value!r}"
            )
        if self.energy_weights is not None and any(
            not (np.isfinite(w) and 0 <= w <= MAX_ENERGY_WEIGHT) for w in self.energy_weights
        ):
            raise InvalidInputError(
                f"energy weights must be in [0, {MAX_ENERGY_WEIGHT:g}] (only their ratios "
                f"matter), got {self.energy_weights}"
            )
        if self.energy_weights is not None and not any(w > 0 for w in self.energy_weights):
            raise InvalidInputError(
                "energy weights must not all be 0 (only their ratios matter: every motion "
                f"would cost nothing), got {self.energy_weights}"
            )


@dataclass(frozen=True, eq=False)
class MotionPlan:
    """A certified command sequence from the start to ``goal_index``'s goal state."""

    sequence: CommandSequence
    goal_index: int
    clearance: MotionClearance
    metrics: PlanMetrics
    direct_commands: int
    method: str
    searched_samples: int


#: Commands whose tool point path :func:`plan_metrics` samples at once.
_METRIC_CHUNK = 20_000


def plan_metrics(
    arm: SerialArm, sequence: CommandSequence, weights: ArrayLike | None = None
) -> PlanMetrics:
    """Commands, fingertip path length (mm, continuous motion) and weighted joint travel (deg
    for revolute joints, mm for prismatic ones)."""
    travel = np.round(np.abs(sequence.commands).sum(axis=0) * sequence.grid.tick_display, 10)
    w = np.ones(arm.n_joints) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (arm.n_joints,):
        raise InvalidInputError(f"energy weights need {arm.n_joints} values, got {w.size}")
    # the tip path within one command is smooth: 8 chords per command are within ~1e-4; summed
    # :data:`_METRIC_CHUNK` commands at a time (a million commands sampled at once held 2 GB)
    length = 0.0
    states = sequence.states()
    for lo in range(0, sequence.n_commands, _METRIC_CHUNK):
        part = CommandSequence(
            states[lo], sequence.commands[lo : lo + _METRIC_CHUNK], sequence.grid
        )
        tip = tool_position(arm, part.sample_motion(8))
        length += float(np.linalg.norm(np.diff(tip, axis=0), axis=-1).sum())
    return PlanMetrics(
        commands=sequence.n_commands,
        tip_path_mm=length,
        energy_deg=float(travel @ w),
        joint_travel_deg=tuple(float(v) for v in travel),
    )


def active_joints(arm: SerialArm, rng: np.random.Generator | None = None) -> NDArray[np.bool_]:
    """Joints whose motion moves some landmark of the arm (the seed arm's joint 6 does not)."""
    gen = rng or np.random.default_rng(0)
    return joints_that_move(arm, landmark_positions, gen.uniform(-np.pi, np.pi, (8, arm.n_joints)))


def search_clearance_extra(
    arm: SerialArm, world: CollisionWorld, buffer_mm: float, spacing_mm: float
) -> FloatArray:
    """Per pair, what the search's samples must keep beyond the clearance rule (mm): the tool
    tip ``spacing_mm / 2``, other obstacle pairs ``buffer_mm + spacing_mm / 2``, link pairs
    ``buffer_mm + spacing_mm`` (see :func:`edge_checker`)."""
    pairs = world.pairs(arm)
    is_tip = np.array([p.is_tip for p in pairs], dtype=bool)
    is_self = np.array([p.is_self for p in pairs], dtype=bool)
    return np.asarray(
        np.where(is_tip, spacing_mm / 2, buffer_mm + np.where(is_self, spacing_mm, spacing_mm / 2)),
        dtype=np.float64,
    )


#: Sample strides of :func:`edge_checker`'s coarse-to-fine passes along each segment.
EDGE_STRIDES = (16, 1)


def edge_checker(
    arm: SerialArm, world: CollisionWorld, buffer_mm: float, spacing_mm: float
) -> EdgeChecker:
    """Straight joint-space segments ``a -> b`` (rad) that provably keep the clearance rule.

    Each segment is sampled so that no arm point moves more than ``spacing_mm`` between samples;
    every non-tip pair must keep ``required + buffer_mm + spacing_mm / 2`` at the samples (link
    pairs ``+ spacing_mm``), which by the Lipschitz bound proves ``required + buffer_mm`` along
    the whole segment. The tool tip keeps ``spacing_mm / 2``, which proves it never penetrates
    (a goal where it touches a surface is searched for at a retracted pre-goal).
    """
    extra = search_clearance_extra(arm, world, buffer_mm, spacing_mm)
    R = displacement_bounds(arm)
    segments = world.segment_checker(arm, extra, EDGE_STRIDES)

    def check(a: FloatArray, b: FloatArray) -> NDArray[np.bool_]:
        a2 = np.atleast_2d(a)
        b2 = np.atleast_2d(b)
        reach = np.abs(b2 - a2) @ R
        counts = np.maximum(np.ceil(reach / spacing_mm).astype(np.int64), 1) + 1
        # coarse to fine: every EDGE_STRIDES[0]-th sample of each segment (and its end) first,
        # then the samples between, only for segments not yet blocked
        return segments(
            np.ascontiguousarray(a2, dtype=np.float64),
            np.ascontiguousarray(b2, dtype=np.float64),
            counts,
        )

    return check


def path_to_sequence(
    path_ticks: FloatArray, start: IntArray, goal: IntArray, lattice: Lattice
) -> CommandSequence:
    """Follow a joint-space path (ticks, float) at full speed on the lattice.

    States are taken at equal steps along the path in the command metric (the largest
    ``|change_i| / max_ticks_i``) of at most one command, and rounded to ticks; the first is
    ``start`` and the last ``goal`` exactly. A float step strictly below ``max_ticks_i`` ticks
    rounds to at most ``max_ticks_i``, so at most one count past the fewest is tried.
    """
    p = np.asarray(path_ticks, dtype=np.float64).copy()
    p[0], p[-1] = start, goal
    m = lattice.max_ticks.astype(np.float64)
    seg = np.max(np.abs(np.diff(p, axis=0)) / m, axis=1)
    arc = np.r_[0.0, np.cumsum(seg)]
    total = float(arc[-1])
    fewest = max(int(np.ceil(total - 1e-9)), 1)
    for n in range(fewest, max(int(np.floor(total)) + 1, fewest) + 1):
        s = np.linspace(0.0, total, n + 1)
        states = np.empty((n + 1, p.shape[1]))
        for j in range(p.shape[1]):
            states[:, j] = np.interp(s, arc, p[:, j])
        ticks = np.round(states).astype(np.int64)
        ticks[0], ticks[-1] = start, goal
        cmds = np.diff(ticks, axis=0)
        if np.all(lattice.legal(cmds)):
            return CommandSequence(start, cmds, lattice)
    raise AssertionError("unreachable: steps below max_ticks always round to legal commands")


def merge_commands(
    sequence: CommandSequence,
    edges_clear: EdgeChecker,
    max_checks: int = 400,
    batch: int = 24,
) -> CommandSequence:
    """Replace runs of commands by fewer straight commands where the straight motion is clear.

    Greedy from the start: from each state, the farthest later state that a straight motion
    reaches in fewer commands and that passes ``edges_clear`` is jumped to (``batch`` of them
    asked at a time, farthest first; ``max_checks`` in all).
    """
    grid = sequence.grid
    states = sequence.states()
    out = [states[0]]
    i = 0
    checks = 0
    while i < len(states) - 1:
        later = np.arange(len(states) - 1, i + 1, -1)
        need = grid.commands_needed_many(states[later] - states[i])
        saving = later[need < later - i]
        jump = i + 1
        if saving.size and checks < max_checks:
            take = saving[: max(1, min(saving.size, batch))]
            checks += take.size
            ok = edges_clear(
                grid.to_joint(np.broadcast_to(states[i], (take.size, states.shape[1]))),
                grid.to_joint(states[take]),
            )
            if np.any(ok):
                jump = int(take[int(np.argmax(ok))])
        if jump > i + 1:
            straight = CommandSequence.straight(states[i], states[jump], lattice=grid).states()
            out.extend(straight[1:])
        else:
            out.append(states[i + 1])
        i = jump
    return CommandSequence.from_states(np.array(out), grid)


#: Earlier states :func:`fewest_through_states` looks back over from each state (its work grows
#: with the states times this).
_FEWEST_WINDOW = 400


def fewest_through_states(
    sequence: CommandSequence, edges_clear: EdgeChecker, max_checks: int = 200
) -> CommandSequence:
    """``sequence`` through the fewest commands that keep its states as the only corners: a
    shortest path over its states, from each state to any later one by a straight motion in
    as many commands as its largest joint change, where ``edges_clear`` passes that motion
    (consecutive states always). Dynamic programme in state order; to each state, the straight
    motions from earlier ones are asked cheapest first and only while they would need fewer
    commands than the best way known there (the first that passes is the best), at most
    ``max_checks`` in all and from at most :data:`_FEWEST_WINDOW` states back: it ends by
    design, and a sequence whose pairs are all asked gets the optimum over its states. Greedy
    merging (:func:`merge_commands`) jumps as far as it can from each state and can miss a
    shorter way past its jumps."""
    grid = sequence.grid
    states = sequence.states()
    n = states.shape[0]
    best = np.zeros(n, dtype=np.int64)
    back = np.arange(-1, n - 1)
    checks = 0
    for j in range(1, n):
        best[j] = best[j - 1] + int(grid.commands_needed(states[j] - states[j - 1]))
        if j < 2 or checks >= max_checks:
            continue
        first = max(0, j - _FEWEST_WINDOW)
        cost = best[first : j - 1] + grid.commands_needed_many(states[j] - states[first : j - 1])
        for k in np.argsort(cost, kind="stable"):
            if cost[k] >= best[j] or checks >= max_checks:
                break
            checks += 1
            i = first + int(k)
            if edges_clear(grid.to_joint(states[i])[None], grid.to_joint(states[j])[None])[0]:
                best[j], back[j] = int(cost[k]), i
                break
    corners = [n - 1]
    while corners[-1] > 0:
        corners.append(int(back[corners[-1]]))
    corners.reverse()
    out = [states[0]]
    for i, j in itertools.pairwise(corners):
        out.extend(CommandSequence.straight(states[i], states[j], lattice=grid).states()[1:])
    return CommandSequence.from_states(np.array(out), grid)


def certified_edges(arm: SerialArm, world: CollisionWorld, grid: Lattice) -> EdgeChecker:
    """Straight motions between lattice states ``a -> b`` (rad) whose continuous motion
    :func:`~armpath.planning.motion_check.motion_clearance` certifies (the tool tip may touch a
    surface, never enter it), asked in order: True for the first certified one, False for the
    others (those after it are not checked; :func:`merge_commands` takes the first)."""

    def check(a: FloatArray, b: FloatArray) -> NDArray[np.bool_]:
        a_ticks, b_ticks = (
            grid.nearest_ticks(np.atleast_2d(a)),
            grid.nearest_ticks(np.atleast_2d(b)),
        )
        ok = np.zeros(a_ticks.shape[0], dtype=bool)
        for k in range(a_ticks.shape[0]):
            straight = CommandSequence.straight(a_ticks[k], b_ticks[k], lattice=grid)
            if motion_clearance(arm, world, straight).certified_ok:
                ok[k] = True
                break
        return ok

    return check


#: Straight motions certified on their continuous motion (:func:`certified_edges`) that
#: :func:`merged_certified` tries at most, in all and from one state at a time, merging
#: greedily; then at most :data:`CERTIFIED_FEWEST_CHECKS` more for the fewest commands through
#: the merged states (:func:`fewest_through_states`; about 5 ms each: the UR5 cell's welds
#: 119 -> 115, 71 checks).
CERTIFIED_MERGE_CHECKS = 64
CERTIFIED_MERGE_BATCH = 8
CERTIFIED_FEWEST_CHECKS = 200


def merged_certified(
    arm: SerialArm,
    world: CollisionWorld,
    plan: MotionPlan,
    energy_weights: ArrayLike | None = None,
) -> MotionPlan:
    """``plan`` with runs of its commands replaced by fewer straight ones whose continuous
    motion is certified (:func:`merge_commands` with :func:`certified_edges`): a searched
    motion's retreat from a surface, its path and its approach to a surface are merged apart,
    each held off the surfaces by the search's edge test, so commands across them can often
    go. Costs about 5 ms a check (at most :data:`CERTIFIED_MERGE_CHECKS`): the UR5 cell's
    welds 118 -> 115 commands, the seed's Task 3 127 -> 126 (its first leg 70 -> 69, a direct
    motion's count). Then the fewest commands through the merged states
    (:func:`fewest_through_states`), and last the states themselves moved where fewer
    commands between the same ends are certified (:func:`~armpath.planning.tighten.tightened`,
    a few seconds for each count tried: the UR5 cell's welds without the pools 114 -> 109).
    ``energy_weights``: what the merged plan's energy is weighted by (as the plan's own)."""
    seq = plan.sequence
    if seq.n_commands < 2:
        return plan
    grid = seq.grid
    certified = certified_edges(arm, world, grid)
    merged = merge_commands(seq, certified, CERTIFIED_MERGE_CHECKS, CERTIFIED_MERGE_BATCH)
    merged = fewest_through_states(merged, certified, CERTIFIED_FEWEST_CHECKS)
    method = plan.method + " + certified merge"
    if merged.n_commands >= seq.n_commands:
        merged, method = seq, plan.method
    placed = tightened(arm, world, merged)
    if placed.n_commands < merged.n_commands:
        merged, method = placed, method + " + states placed"
    if merged.n_commands >= seq.n_commands:
        return plan
    mc = motion_clearance(arm, world, merged)
    if not mc.certified_ok:  # each straight piece is certified; the whole is checked again
        return plan
    return replace(
        plan,
        sequence=merged,
        clearance=mc,
        metrics=plan_metrics(arm, merged, energy_weights),
        method=method,
    )


def plan_motion(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: ArrayLike,
    goal_ticks: ArrayLike,
    options: MotionOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
    turn_copies: bool = False,
    certified_merge: bool = True,
    waypoints: Callable[[], IntArray] | None = None,
) -> MotionPlan:
    """Plan a clear command sequence from ``start_ticks`` to one of ``goal_ticks`` ``(G, n)``.

    ``turn_copies``: the goals stand for a tool target rather than exact joint values, so their
    whole-turn copies (:func:`with_turn_copies`) are goals too. ``certified_merge``: with the
    commands objective, the plan kept is merged further where certified straight motions need
    fewer commands (:func:`merged_certified`; a planner that makes many motions and keeps few,
    a tour, leaves it to the ones it keeps). With the commands objective, where no direct
    motion is clear, two straight motions through a waypoint compete with the search
    (:func:`via_waypoint`): through waypoints drawn on fewest-command ways to the nearest goal
    (:func:`fewest_command_waypoints`) and through the given ``waypoints`` (lattice states;
    :func:`~armpath.planning.passages.passage_waypoints` gives those in the openings of hollow
    obstacles; a function that gives them, asked only then).

    Raises :class:`PlanningError` when neither a direct motion nor the search finds a motion
    that keeps the clearance rule (the message says what was tried).
    """
    opts = options or MotionOptions()
    start = np.asarray(start_ticks)
    goals = np.atleast_2d(np.asarray(goal_ticks))
    n = arm.n_joints
    if start.shape != (n,) or goals.ndim != 2 or goals.shape[1] != n or goals.shape[0] == 0:
        raise InvalidInputError(
            f"start must have {n} joint values and goals shape (G, {n}); "
            f"got {start.shape} and {goals.shape}"
        )
    grid = arm.lattice
    none = np.zeros((0, n), np.int64)
    start = CommandSequence(start, none, grid).start_ticks
    goals = np.array([CommandSequence(g, none, grid).start_ticks for g in goals])
    arm.check_limits(grid.to_joint(start), what="start state")
    for g in goals:
        arm.check_limits(grid.to_joint(g), what="goal state")
    check_size(
        min(grid.commands_needed(g - start) for g in goals),
        MAX_COMMANDS,
        "commands of the motion to the nearest goal",
        "the goal, or the arm's lattice (its ticks and largest steps)",
    )
    check_state_clear(arm, world, grid.to_joint(start))
    if goals.shape[0] == 1:
        check_state_clear(arm, world, grid.to_joint(goals[0]), what="goal state")
    if turn_copies:
        goals = with_turn_copies(arm, goals, start)
    weights = None if opts.energy_weights is None else np.asarray(opts.energy_weights)
    say = on_progress or (lambda _msg: None)

    def score(seq: CommandSequence) -> tuple[float, ...]:
        m = plan_metrics(arm, seq, weights)
        if opts.objective is Objective.PATH:
            return (m.tip_path_mm, m.commands)
        if opts.objective is Objective.ENERGY:
            return (m.energy_deg, m.commands)
        return (m.commands, m.tip_path_mm)

    direct_counts = grid.commands_needed_many(goals - start)
    # 1. direct motions, fewest commands first
    best: MotionPlan | None = None
    for gi in np.argsort(direct_counts, kind="stable")[:8]:
        seq = CommandSequence.straight(start, goals[gi], lattice=grid)
        mc = motion_clearance(arm, world, seq)
        if mc.certified_ok:
            plan = MotionPlan(
                seq,
                int(gi),
                mc,
                plan_metrics(arm, seq, weights),
                int(direct_counts[gi]),
                "direct",
                0,
            )
            if best is None or score(plan.sequence) < score(best.sequence):
                best = plan
            if opts.objective is Objective.COMMANDS:
                break
    if best is None and opts.objective is Objective.COMMANDS:
        # two straight motions through a waypoint: first through ones drawn where both need
        # no more commands together than the straight one to the nearest goal (the fewest
        # there are), then through the given ones
        near = int(np.argmin(direct_counts))
        rng = np.random.default_rng([opts.seed, 11])
        drawn = fewest_command_waypoints(arm, start, goals[near], _DRAWN_WAYPOINTS, rng)
        best = via_waypoint(arm, world, start, goals, drawn, weights, opts.seed)
        if best is None and waypoints is not None:
            best = via_waypoint(arm, world, start, goals, waypoints(), weights, opts.seed)
    if best is not None and (
        opts.objective is not Objective.COMMANDS or best.sequence.n_commands <= direct_counts.min()
    ):
        return best
    # a direct motion to a farther goal (a whole-turn copy, say) is kept only if the search
    # finds nothing shorter to the nearer goals it could not reach directly
    direct_best = best

    # 2.-4. search, onto the lattice, certify
    active = active_joints(arm)
    lo = np.array([j.limits[0] for j in arm.joints])
    hi = np.array([j.limits[1] for j in arm.joints])
    s_rad = grid.to_joint(start)
    g_rad = grid.to_joint(goals)
    span_lo = np.minimum(s_rad, g_rad.min(axis=0)) - np.pi
    span_hi = np.maximum(s_rad, g_rad.max(axis=0)) + np.pi
    lower = np.where(np.isfinite(lo), np.maximum(lo, span_lo), span_lo)
    upper = np.where(np.isfinite(hi), np.minimum(hi, span_hi), span_hi)
    lower = np.where(active, lower, s_rad)
    upper = np.where(active, upper, s_rad)
    # goals whose tool tip touches a surface are approached from a retracted pre-goal; a start
    # whose tool tip touches one (the end of a weld) first backs away from it the same way
    pre = np.array([retracted_pre_goal(arm, world, g, active, opts.approach_mm) for g in g_rad])
    # after a farther back-off (below): the lattice states from the pre-goal to each goal
    chains: list[list[IntArray] | None] = [None] * len(g_rad)
    original_start = start
    lead = _retreat(arm, world, start, active, opts.approach_mm)
    if lead.n_commands:
        start = lead.final_ticks
        s_rad = grid.to_joint(start)
    # inactive joints move straight from start to goal; plan with them at the start value
    goals_search = np.where(active, pre, s_rad)
    # the search works in joint coordinates scaled by each joint's largest step in one command
    # (relative to the largest), where the largest-change distance counts commands; for the
    # seed controller (2 deg on every joint) the scale is exactly 1
    scale = grid.max_step / grid.max_step.max()

    def cost_fn(w: FloatArray | None) -> Callable[[FloatArray], float]:
        """The objective of a path in scaled coordinates."""
        if opts.objective is Objective.PATH:

            def tip_len(path: FloatArray) -> float:
                dense = _densify_path(path * scale, np.radians(1.0))
                tip = tool_position(arm, dense)
                return float(np.linalg.norm(np.diff(tip, axis=0), axis=-1).sum())

            return tip_len
        if opts.objective is Objective.ENERGY:
            ww = np.ones(n) if w is None else w
            return lambda path: float((np.abs(np.diff(path * scale, axis=0)) @ ww).sum())
        return lambda path: float(np.abs(np.diff(path, axis=0)).max(axis=1).sum())

    failures: list[str] = []
    found: list[MotionPlan] = []
    buffer, spacing = opts.buffer_mm, opts.sample_spacing_mm
    approach = opts.approach_mm
    for attempt in range(opts.attempts + opts.searches - 1):
        if len(found) >= opts.searches:
            break
        check_time("planning a collision-free motion")
        rng = np.random.default_rng([opts.seed, attempt])
        check = edge_checker(arm, world, buffer, spacing)

        def check_scaled(
            a: FloatArray, b: FloatArray, check: EdgeChecker = check
        ) -> NDArray[np.bool_]:
            return check(a * scale, b * scale)

        say(f"searching (search {attempt + 1}, buffer {buffer:g} mm)")
        # the first search looks only for the goals within half a turn of the nearest one: a
        # whole-turn copy is a goal for a joint that cannot get round the near way (an elbow
        # folding through its upper arm), and a tree that happens to reach it first would
        # turn the joint all the way round
        turning = grid.max_step[~grid.prismatic]  # only revolute joints have turn copies
        far = FAR_GOAL_TURNS * 2.0 * np.pi / turning.max() if turning.size else np.inf
        pick = np.flatnonzero(
            direct_counts <= direct_counts.min() + far
            if attempt == 0
            else np.ones(goals.shape[0], dtype=bool)
        )
        res = rrt_connect(
            s_rad / scale,
            goals_search[pick] / scale,
            lower / scale,
            upper / scale,
            check_scaled,
            rng,
            opts.rrt,
        )
        if not res.success:
            failures.append(f"search {attempt + 1}: {res.reason}")
            touching = any(not np.array_equal(p_, g_) for p_, g_ in zip(pre, g_rad, strict=True))
            if (touching or lead.n_commands) and approach < MAX_APPROACH_MM:
                # the goals (or the start) sit in a narrow spot, a tool just off the surface it
                # works on: back off farther for the next search; the motions from there are
                # straight and certified like every other.
                approach = min(approach * 5.0, MAX_APPROACH_MM)
            if touching:
                backed = [_approach_chain(arm, world, g, active, approach, grid) for g in g_rad]
                pre = np.array([g if not chain else grid.to_joint(chain[0]) for g, chain in zip(
                    g_rad, backed, strict=True)])  # fmt: skip
                chains = [chain or None for chain in backed]
                failures[-1] += f" (the goals boxed in: backing off {approach:g} mm)"
            if lead.n_commands:
                # a start just off its surface (the end of a weld): back it off farther too
                chain = _approach_chain(
                    arm, world, grid.to_joint(original_start), active, approach, grid
                )
                if chain:
                    lead = _straight_through(np.array([original_start, *chain[::-1]]), grid)
                    start = lead.final_ticks
                    s_rad = grid.to_joint(start)
                    lower = np.where(active, lower, s_rad)
                    upper = np.where(active, upper, s_rad)
            goals_search = np.where(active, pre, s_rad)
            continue
        gi = int(pick[res.goal_index])
        path = res.path.copy()
        # inactive joints: goal value at the end
        path[-1] = np.where(active, pre[gi], g_rad[gi]) / scale
        path = shortcut(path, check_scaled, rng, cost_fn(weights), opts.shortcut_rounds)
        path_ticks = grid.to_ticks_float(path * scale)
        approach_states = chains[gi]
        if approach_states is not None:  # from the far pre-goal down the certified approach
            main = merge_commands(
                path_to_sequence(path_ticks, start, approach_states[0], grid), check
            )
            seq = main
            for a_, b_ in itertools.pairwise([*approach_states, goals[gi]]):
                seq = seq.then(CommandSequence.straight(a_, b_, lattice=grid))
        elif np.array_equal(pre[gi], g_rad[gi]):
            seq = merge_commands(path_to_sequence(path_ticks, start, goals[gi], grid), check)
        else:  # the final approach from the pre-goal is its own straight motion
            pre_ticks = np.round(path_ticks[-1]).astype(np.int64)
            main = merge_commands(path_to_sequence(path_ticks, start, pre_ticks, grid), check)
            seq = main.then(CommandSequence.straight(pre_ticks, goals[gi], lattice=grid))
        if lead.n_commands:
            seq = lead.then(seq)
        mc = motion_clearance(arm, world, seq)
        if mc.certified_ok:
            found.append(
                MotionPlan(
                    seq,
                    gi,
                    mc,
                    plan_metrics(arm, seq, weights),
                    int(direct_counts[gi]),
                    "rrt-connect + shortcuts + lattice merge",
                    res.samples,
                )
            )
            continue
        what = (
            f"{mc.limiting_pair} {mc.limiting_slack:+.3f} mm off its clearance at command "
            f"{mc.limiting_command}"
            if mc.violated
            else f"clearance not provable: lower bound {mc.lower_bound_slack:+.4f} mm"
        )
        failures.append(f"search {attempt + 1}: lattice path fails the final check ({what})")
        buffer *= 1.5
        spacing *= 0.5
    if direct_best is not None:
        found.append(direct_best)
    if found:
        kept = min(found, key=lambda plan: score(plan.sequence))
        if certified_merge and opts.objective is Objective.COMMANDS:
            kept = merged_certified(arm, world, kept, weights)
        return kept
    raise PlanningError("no collision-free motion found: " + "; ".join(failures))


#: Motions through a waypoint (the fewest commands first) that :func:`via_waypoint` screens
#: at :data:`_VIA_SAMPLES` instants of each part, and most of those it then certifies.
_VIA_SCREENED = 2_000
_VIA_SAMPLES = 24
#: The screen looks at every this many instants first (see :func:`_via_screen`).
_VIA_FIRST_EVERY = 4
VIA_CHECKS = 16
#: Waypoints whose commands from the start and to the goals are counted at once.
_VIA_CHUNK = 8192
#: The descent from the screened waypoints: rounds, waypoints kept, children of each per
#: round, and the largest moves of a child per joint (fractions of a command's largest step).
#: Into the seed workpiece (plan --to-xyz 190 -125 81.98): 67 commands through the sampled
#: waypoints, 65 after one round, 64 after three (the direct motion to its goal state, blocked,
#: needs 58 or 59 by the goal state taken).
_DESCENT_ROUNDS = 4
_DESCENT_KEPT = 100
_DESCENT_CHILDREN = 40
_DESCENT_MOVES = (0.5, 0.2)


def via_waypoint(
    arm: SerialArm,
    world: CollisionWorld,
    start: IntArray,
    goals: IntArray,
    waypoints: IntArray,
    weights: FloatArray | None = None,
    seed: int = 0,
) -> MotionPlan | None:
    """The fewest-command motion of two straight parts found from ``start`` through a waypoint
    to one of ``goals`` (lattice states), certified clear; None when none is found.

    Each part needs as many commands as its largest joint change, so through the right waypoint
    the motion needs no more than the straight one that a link's collision blocks. The
    ``waypoints`` are taken in order of the commands through them (each to its nearest goal),
    at most :data:`_VIA_SCREENED` of them screened at sampled instants of both parts; the best
    screened ones then descend (:data:`_DESCENT_ROUNDS` rounds of random lattice moves about
    them, a child kept when it screens clear and needs fewer commands, ``seed`` for the
    moves), and the motions through the best are certified, at most :data:`VIA_CHECKS`: it
    ends by design."""
    grid = arm.lattice
    waypoints = np.asarray(waypoints, dtype=np.int64)
    if waypoints.shape[0] == 0:
        return None
    cost, goal_of = _via_costs(grid, start, goals, waypoints)
    order = np.argsort(cost, kind="stable")[:_VIA_SCREENED]
    order = order[_via_screen(arm, world, start, goals[goal_of[order]], waypoints[order])]
    if order.size == 0:
        return None
    # the screened waypoints, fewest commands first, with their commands and goals
    order = order[:_DESCENT_KEPT]
    kept, kept_cost, kept_goal = waypoints[order], cost[order], goal_of[order]
    rng = np.random.default_rng(seed)
    for _ in range(_DESCENT_ROUNDS):
        for move in _DESCENT_MOVES:
            check_time("planning a motion through a waypoint")
            reach_ticks = np.maximum(np.round(move * grid.max_ticks), 1).astype(np.int64)
            children = np.repeat(kept, _DESCENT_CHILDREN, axis=0) + rng.integers(
                -reach_ticks,
                reach_ticks + 1,
                size=(kept.shape[0] * _DESCENT_CHILDREN, kept.shape[1]),
            )
            children = children[arm.within_limits(grid.to_joint(children))]
            c_cost, c_goal = _via_costs(grid, start, goals, children)
            better = c_cost < kept_cost.max()
            children, c_cost, c_goal = children[better], c_cost[better], c_goal[better]
            clear = _via_screen(arm, world, start, goals[c_goal], children)
            pool = np.concatenate([kept, children[clear]])
            pool_cost = np.concatenate([kept_cost, c_cost[clear]])
            pool_goal = np.concatenate([kept_goal, c_goal[clear]])
            best = np.argsort(pool_cost, kind="stable")[:_DESCENT_KEPT]
            kept, kept_cost, kept_goal = pool[best], pool_cost[best], pool_goal[best]
    for w, gi in zip(kept[:VIA_CHECKS], kept_goal[:VIA_CHECKS], strict=True):
        check_time("planning a motion through a waypoint")
        first = CommandSequence.straight(start, w, lattice=grid)
        seq = first.then(CommandSequence.straight(w, goals[gi], lattice=grid))
        mc = motion_clearance(arm, world, seq)
        if mc.certified_ok:
            direct = int(grid.commands_needed(goals[gi] - start))
            metrics = plan_metrics(arm, seq, weights)
            return MotionPlan(seq, int(gi), mc, metrics, direct, "direct through a waypoint", 0)
    return None


#: Waypoints :func:`plan_motion` draws between the start and the nearest goal
#: (:func:`fewest_command_waypoints`) where no direct motion is clear, screened before the
#: given ones: the seed crack's entry, whose straight motion dips the tool 67 mm into the table
#: halfway, 70 -> 69 commands with seeds 0, 1 and 2 alike (200 did as well); 2,000 cost the
#: seed's Task 3, whose blocked legs find no such motion, 5 s more (300: none measurable).
_DRAWN_WAYPOINTS = 300


def fewest_command_waypoints(
    arm: SerialArm, start: IntArray, goal: IntArray, count: int, rng: np.random.Generator
) -> IntArray:
    """``count`` lattice states (fewer where some lie outside the joint limits) through which
    two straight motions from ``start`` to ``goal`` need no more commands together than the
    straight one, ``N``: each ``k`` commands of the way along (``k`` drawn evenly from 1 to
    ``N - 1``), every joint drawn evenly from the ticks within ``k`` commands of the start and
    ``N - k`` of the goal (a joint that moves nothing else, see :func:`active_joints`, on the
    straight line). None (an empty array) when ``N < 2``."""
    grid = arm.lattice
    start = np.asarray(start, dtype=np.int64)
    goal = np.asarray(goal, dtype=np.int64)
    n_cmd = int(grid.commands_needed(goal - start))
    if n_cmd < 2 or count <= 0:
        return np.zeros((0, start.size), dtype=np.int64)
    k = rng.integers(1, n_cmd, count)[:, None]
    step = np.asarray(grid.max_ticks, dtype=np.int64)
    lo = np.maximum(start - k * step, goal - (n_cmd - k) * step)
    hi = np.minimum(start + k * step, goal + (n_cmd - k) * step)
    drawn = lo + np.floor(rng.uniform(0.0, 1.0, lo.shape) * (hi - lo + 1)).astype(np.int64)
    on_line = np.clip(np.round(start + k / n_cmd * (goal - start)).astype(np.int64), lo, hi)
    out = np.where(active_joints(arm), drawn, on_line)
    return np.asarray(out[arm.within_limits(grid.to_joint(out))], dtype=np.int64)


def _via_costs(
    grid: Lattice, start: IntArray, goals: IntArray, waypoints: IntArray
) -> tuple[IntArray, IntArray]:
    """Per waypoint, the commands of the two straight motions from ``start`` through it to its
    nearest goal, and that goal's index."""
    cost = grid.commands_needed_many(waypoints - start)
    goal_of = np.empty(waypoints.shape[0], dtype=np.int64)
    for k in range(0, waypoints.shape[0], _VIA_CHUNK):
        check_time("planning a motion through a waypoint")
        part = grid.commands_needed_many(goals[None, :, :] - waypoints[k : k + _VIA_CHUNK, None])
        goal_of[k : k + _VIA_CHUNK] = np.argmin(part, axis=1)
        cost[k : k + _VIA_CHUNK] += part.min(axis=1)
    return cost, goal_of


def _via_screen(
    arm: SerialArm, world: CollisionWorld, start: IntArray, goals: IntArray, waypoints: IntArray
) -> NDArray[np.bool_]:
    """Per waypoint, whether the arm keeps the clearance rule at :data:`_VIA_SAMPLES`
    instants of each straight motion, from ``start`` to it and from it to its goal (``goals``,
    one per waypoint): a screen, the motions kept are certified after. Every
    :data:`_VIA_FIRST_EVERY`-th instant is looked at first, and the others only for the
    waypoints that pass there (most blocked motions fail at the first ones; the verdict is
    the same)."""
    grid = arm.lattice
    t = np.linspace(0.0, 1.0, _VIA_SAMPLES)[1:-1, None]
    s_rad, w_rad, g_rad = grid.to_joint(start), grid.to_joint(waypoints), grid.to_joint(goals)
    instants = np.concatenate(
        [
            s_rad + t * (w_rad - s_rad)[:, None],
            w_rad[:, None],
            w_rad[:, None] + t * (g_rad - w_rad)[:, None],
        ],
        axis=1,
    )
    first = np.zeros(instants.shape[1], dtype=bool)
    first[::_VIA_FIRST_EVERY] = True
    ok = np.asarray(world.satisfied(arm, instants[:, first]).all(axis=1), dtype=bool)
    live = np.flatnonzero(ok)
    if live.size:
        ok[live] = world.satisfied(arm, instants[live][:, ~first]).all(axis=1)
    return ok


#: Most goal states one motion search takes: the given ones and their whole-turn copies.
MAX_SEARCH_GOALS = 64
#: Goals farther than this beyond the nearest one (turns of the revolute joint that moves
#: farthest in a command: 90 commands at 2 deg a command) are left out of a motion's first
#: search.
FAR_GOAL_TURNS = 0.5


def whole_turn_ticks(arm: SerialArm) -> IntArray:
    """Ticks in a whole turn of each revolute joint whose (finite) limits span more than a turn
    and whose turn is a whole number of ticks (its whole-turn copies are goals too:
    :func:`with_turn_copies`); 0 for the other joints."""
    grid = arm.lattice
    turn = 2.0 * np.pi / grid.tick
    wide = np.isfinite(arm.lower) & np.isfinite(arm.upper) & (arm.upper - arm.lower > 2 * np.pi)
    exact = (~grid.prismatic) & wide & (np.abs(turn - np.round(turn)) < 1e-6)
    return np.asarray(np.round(np.where(exact, turn, 0.0)), dtype=np.int64)


def with_turn_copies(arm: SerialArm, goals: IntArray, start: IntArray) -> IntArray:
    """``goals`` followed by their whole-turn copies: each goal with one revolute joint, whose
    (finite) limits span more than a turn, a whole turn up or down (inside the limits, on the
    lattice).
    A copy has the same links but is reached the other way round: an elbow at 222.8 deg is
    also at -137.2 deg, and only one of them may be reachable without folding the arm through
    itself. Copies nearest ``start`` in commands first, up to :data:`MAX_SEARCH_GOALS` goals."""
    grid = arm.lattice
    turn_ticks = whole_turn_ticks(arm)
    exact = turn_ticks > 0
    if not np.any(exact) or goals.shape[0] >= MAX_SEARCH_GOALS:
        return goals
    seen = {g.tobytes() for g in goals}
    copies: list[IntArray] = []
    for g in goals:
        for i in np.flatnonzero(exact):
            for sign in (1, -1):
                c = g.copy()
                c[i] += sign * turn_ticks[i]
                q_i = float(grid.to_joint(c)[i])
                if q_i < arm.lower[i] - 1e-12 or q_i > arm.upper[i] + 1e-12:
                    continue
                if c.tobytes() not in seen:
                    seen.add(c.tobytes())
                    copies.append(c)
    if not copies:
        return goals
    extra = np.array(copies)
    extra = extra[np.argsort(grid.commands_needed_many(extra - start), kind="stable")]
    return np.vstack([goals, extra[: MAX_SEARCH_GOALS - goals.shape[0]]])


#: The farthest a goal is backed off its surface for the search (mm).
MAX_APPROACH_MM = 75.0


def _approach_chain(
    arm: SerialArm,
    world: CollisionWorld,
    q: FloatArray,
    active: NDArray[np.bool_],
    distance_mm: float,
    grid: Lattice,
) -> list[IntArray]:
    """Lattice states backing the tool off its surface from goal ``q`` along the surface
    normal: at ``distance_mm``, then a fifth of it, and so on down to 3 mm, farthest first,
    with every straight motion between them (and the last one to the goal) certified clear.
    Empty when the goal touches nothing or a motion is not clear."""
    goal = grid.nearest_ticks(q)
    steps: list[IntArray] = []
    d = distance_mm
    while True:
        back = retracted_pre_goal(arm, world, q, active, d)
        if np.array_equal(back, q):
            return []
        steps.append(grid.nearest_ticks(back))
        if d <= 3.0:
            break
        d = max(d / 5.0, 3.0)
    for a, b in itertools.pairwise([*steps, goal]):
        seq = CommandSequence.straight(a, b, lattice=grid)
        if not motion_clearance(arm, world, seq).certified_ok:
            return []
    return steps


def _straight_through(states: IntArray, grid: Lattice) -> CommandSequence:
    """Straight moves through lattice ``states`` (each split into legal commands)."""
    seq = CommandSequence(states[0], np.zeros((0, states.shape[1]), dtype=np.int64), grid)
    for a, b in itertools.pairwise(states):
        seq = seq.then(CommandSequence.straight(a, b, lattice=grid))
    return seq


def _retreat(
    arm: SerialArm,
    world: CollisionWorld,
    start: IntArray,
    active: NDArray[np.bool_],
    distance_mm: float,
) -> CommandSequence:
    """Commands that back the tool tip straight away from the surface it touches at ``start``
    (:func:`retracted_pre_goal` on the lattice), or none when it touches nothing or the retreat
    is not certified clear. A search from a touching start could not prove its first edge."""
    grid = arm.lattice
    none = CommandSequence(start, np.zeros((0, start.size), dtype=np.int64), grid)
    q = grid.to_joint(start)
    back = retracted_pre_goal(arm, world, q, active, distance_mm)
    if np.array_equal(back, q):
        return none
    back_ticks = grid.nearest_ticks(back)
    if not arm.within_limits(grid.to_joint(back_ticks)):
        return none
    seq = CommandSequence.straight(start, back_ticks, lattice=grid)
    return seq if motion_clearance(arm, world, seq).certified_ok else none


def retracted_pre_goal(
    arm: SerialArm,
    world: CollisionWorld,
    q: FloatArray,
    active: NDArray[np.bool_],
    distance_mm: float,
) -> FloatArray:
    """``q`` moved so the tool tip backs ``distance_mm`` away from the surface it touches.

    When the tip is within ``distance_mm`` of an obstacle, the joints move (least squares,
    active joints only, two Newton steps) so the tip goes along that obstacle's outward normal;
    otherwise ``q`` is returned unchanged. A straight motion from the result to ``q`` then
    approaches the surface head-on instead of grazing it.
    """
    if distance_mm <= 0 or not world.obstacles:
        return q
    tip = tool_position(arm, q)
    d = np.array([float(o.signed_distance(tip)) for o in world.obstacles])
    k = int(np.argmin(d))
    if d[k] >= distance_mm:
        return q
    normal = world.obstacles[k].outward_normal(tip)
    if not np.all(np.isfinite(normal)):
        return q
    goal = tip + (distance_mm - d[k]) * normal
    out = q.copy()
    for k in range(8):  # Newton; a few mm converge in two steps, a larger retreat in more
        miss = goal - tool_position(arm, out)
        if k >= 2 and float(np.linalg.norm(miss)) < 1e-9:
            break
        J = position_jacobian(arm, out)[:, active]
        step, *_ = np.linalg.lstsq(J, miss, rcond=None)
        out[active] += step
    lo = np.array([j.limits[0] for j in arm.joints])
    hi = np.array([j.limits[1] for j in arm.joints])
    if (
        not np.all((out >= lo) & (out <= hi))
        or np.linalg.norm(tool_position(arm, out) - goal) > 0.5
    ):
        return q
    return out


def _densify_path(path: FloatArray, step: float) -> FloatArray:
    out = [path[:1]]
    for a, b in itertools.pairwise(path):
        k = max(int(np.ceil(np.max(np.abs(b - a)) / step)), 1)
        t = np.linspace(0.0, 1.0, k + 1)[1:, None]
        out.append(a + t * (b - a))
    return np.vstack(out)
