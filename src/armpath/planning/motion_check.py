"""Clearance along the continuous motion of a command sequence, with a certified bound.

During a command the joints move linearly and together, so between two sampled instants every
point of the arm moves at most ``delta = sum_i |dq_i| * R_i`` (see
:func:`armpath.kinematics.displacement_bounds`). Signed distance is 1-Lipschitz, hence the
clearance anywhere in a sampled interval is at least ``min(c_a, c_b) - delta / 2`` (``- delta``
for the distance between two links, which can both move). Intervals
whose bound could still hide a smaller clearance are bisected until the smallest clearance is
known to within ``tolerance`` (branch and bound), so the reported minimum is the true minimum of
the continuous motion up to ``tolerance`` and ``certified_ok`` is a proof, not a sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.commands import CommandSequence
from armpath.errors import CollisionError
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import displacement_bounds
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class MotionClearance:
    """Clearances (length unit, capsule radii subtracted) over a whole continuous motion.

    ``min_clearance`` is the smallest clearance to an obstacle found (any part, tool tip
    included), a value the motion really attains; ``min_clearance_lower_bound`` is a proven lower
    bound of the true minimum, so the true minimum lies between the two. ``min_body_clearance``
    excludes the tool tip (it must stay >= the margin); ``min_tip_clearance`` is the tool tip's
    (>= 0 required); ``min_self_clearance`` the smallest distance between non-adjacent links
    (inf when none are checked). ``lower_bound_slack`` is the proven lower bound of the smallest
    ``clearance - required`` over every constrained pair: ``certified_ok`` (slack >= 0) proves the
    clearance rule everywhere along the motion; ``violated`` means a sampled instant breaks it.
    ``worst_*`` locate the smallest obstacle clearance: part, obstacle and the command during
    which it happens (0 = the start state); ``limiting_*`` the smallest slack found (the pair
    closest to breaking the rule, obstacle or link pair), its value and command.
    """

    min_clearance: float
    min_clearance_lower_bound: float
    min_body_clearance: float
    min_tip_clearance: float
    min_self_clearance: float
    lower_bound_slack: float
    certified_ok: bool
    violated: bool
    worst_part: str
    worst_obstacle: str
    worst_command: int
    limiting_pair: str
    limiting_slack: float
    limiting_command: int
    evaluations: int


#: Instants whose clearances :func:`motion_clearance` evaluates at once.
_EVALUATION_CHUNK = 50_000
#: Most instants a motion's first round evaluates (``initial_substeps`` a command, else one).
_MAX_INITIAL_INSTANTS = 1_000_000
#: The evaluations a whole plan's final check may take (a trace's passes and transits, a
#: tour's legs), each part having been certified within the default 20,000: together they
#: may need more. A Kinova's tour of the UR5 cell's four welds, its tool tip onto each, took
#: 20,458 and was refused after five minutes of planning. The bisection refines only the
#: intervals not yet proven, so the cap costs time only where a plan needs it; where it runs
#: out, :func:`plan_clearance` checks each half with it again.
WHOLE_PLAN_EVALUATIONS = 400_000


#: How finely :func:`motion_clearance` resolves a clearance by default (length unit): an
#: interval over which no point moves more than this is not split further.
CERTIFY_RESOLUTION_MM = 0.01


def motion_clearance(
    arm: SerialArm,
    world: CollisionWorld,
    sequence: CommandSequence,
    tolerance: float = CERTIFY_RESOLUTION_MM,
    initial_substeps: int = 4,
    max_evaluations: int = 20_000,
    precision_evaluations: int = 1_000,
) -> MotionClearance:
    """Smallest clearances over the continuous motion of ``sequence`` (start state included).

    Intervals whose bound does not yet prove the clearance rule are bisected, lowest bound
    first, until the rule is certified, a sampled instant violates it, ``max_evaluations``
    configurations have been evaluated, or no point moves more than ``tolerance`` (length
    unit) over an interval left unproven (a clearance nearer the rule than that is not
    proven). Then up to ``precision_evaluations`` more narrow the gap between the smallest
    obstacle clearance found and its proven lower bound toward ``tolerance``. A violated
    motion is not refined further.
    """
    pairs = world.pairs(arm)
    required = np.array([p.required for p in pairs])
    is_self = np.array([p.is_self for p in pairs], dtype=bool)
    is_tip = np.array([p.is_tip for p in pairs], dtype=bool)
    R = displacement_bounds(arm)
    states = sequence.states().astype(np.float64)
    n = sequence.n_commands
    # every point moves at most rate[k] per unit of u during command k; a link-link distance
    # can change by twice that
    grid = sequence.grid
    rate = (np.abs(sequence.commands).astype(np.float64) * grid.tick) @ R
    speed = np.where(is_self, 2.0, 1.0)

    def config(u: FloatArray) -> FloatArray:
        if n == 0:
            return grid.to_joint(np.broadcast_to(states[0], (u.size, states.shape[1])))
        k = np.clip(np.floor(u).astype(np.int64), 0, n - 1)
        return grid.to_joint(states[k] + (u - k)[:, None] * sequence.commands[k])

    def evaluate(u: FloatArray) -> tuple[FloatArray, FloatArray]:
        # a chunk at a time: the link frames of a million instants at once held 1.5 GB
        parts = [
            world.pair_clearances(arm, config(u[i : i + _EVALUATION_CHUNK]))
            for i in range(0, max(u.size, 1), _EVALUATION_CHUNK)
        ]
        return np.concatenate([v for v, _ in parts]), np.concatenate([lo for _, lo in parts])

    # a very long sequence starts from its states alone (its instants' clearances are kept)
    substeps = initial_substeps if n * initial_substeps <= _MAX_INITIAL_INSTANTS else 1
    u_nodes = np.unique(
        np.concatenate(
            [np.arange(n + 1, dtype=np.float64)]
            + [np.arange(n) + j / substeps for j in range(1, substeps)]
        )
    )
    V, L = evaluate(u_nodes)  # values and proven lower bounds, (M, K)

    def bounds() -> tuple[FloatArray, FloatArray]:
        """Lower bound of every pair's clearance on each interval ``(M - 1, K)``: a clearance
        that changes at most ``c`` per unit of u and is at least ``a`` and ``b`` at the ends
        of an interval of width ``h`` is at least ``(a + b - c h) / 2`` inside it (where the
        two slopes from its ends meet) and never below ``min(a, b) - c h / 2``; a motion
        that ends touching a surface head-on (0 at its end) is proven clear up to rounding."""
        k = np.minimum(np.floor(u_nodes[:-1]).astype(np.int64), max(n - 1, 0))
        half_delta = 0.5 * rate[k] * np.diff(u_nodes) if n else np.zeros(0)
        drop = half_delta[:, None] * speed[None, :]
        lb = np.minimum(np.minimum(L[:-1], L[1:]), 0.5 * (L[:-1] + L[1:]) - drop)
        return lb, half_delta

    certified = False
    obstacle_cols = ~is_self
    while n > 0 and pairs:  # ends: every round evaluates new instants within the budget
        check_time("certifying the clearance of a motion")
        lb, half_delta = bounds()
        if np.min(V - required) < 0:
            break  # a sampled instant violates the rule: the motion is rejected
        slack_lb = (lb - required).min(axis=1)
        need = (slack_lb < 0) & (half_delta > tolerance / 2)
        budget = max_evaluations - u_nodes.size
        if not np.any(need):  # certified: spend a little on the precision of the minimum
            if not certified:
                certified = True
                start_count = u_nodes.size
            if not np.any(obstacle_cols):
                break
            best = V[:, obstacle_cols].min()
            need = (lb[:, obstacle_cols].min(axis=1) < best - tolerance) & (
                half_delta > tolerance / 2
            )
            budget = min(budget, start_count + precision_evaluations - u_nodes.size)
        if not np.any(need) or budget <= 0:
            break
        idx = np.flatnonzero(need)
        idx = idx[np.argsort(slack_lb[idx])[: min(budget, 4096)]]
        mid = 0.5 * (u_nodes[idx] + u_nodes[idx + 1])
        V_mid, L_mid = evaluate(mid)
        order = np.argsort(np.concatenate([u_nodes, mid]), kind="stable")
        u_nodes = np.concatenate([u_nodes, mid])[order]
        V = np.concatenate([V, V_mid])[order]
        L = np.concatenate([L, L_mid])[order]

    lower = bounds()[0] if n else L
    if not pairs:
        inf = float("inf")
        return MotionClearance(
            inf, inf, inf, inf, inf, inf, True, False, "", "", 0, "", inf, 0, int(u_nodes.size)
        )
    slack_all = V - required
    lb_slack = float((lower - required).min())
    violated = bool(slack_all.min() < 0)

    def command_of(i: int) -> int:
        return 0 if u_nodes[i] == 0.0 else int(np.ceil(u_nodes[i]))

    def col_min(mask: NDArray[np.bool_], arr: FloatArray) -> float:
        return float(arr[:, mask].min()) if np.any(mask) else float("inf")

    i_lim, c_lim = np.unravel_index(int(np.argmin(slack_all)), slack_all.shape)
    obs_cols = np.flatnonzero(obstacle_cols)
    if obs_cols.size:
        i_w, c_w = np.unravel_index(int(np.argmin(V[:, obs_cols])), (V.shape[0], obs_cols.size))
        worst = (pairs[obs_cols[c_w]].part, pairs[obs_cols[c_w]].other, command_of(int(i_w)))
    else:
        worst = ("", "", 0)
    body = obstacle_cols & ~is_tip
    tip = obstacle_cols & is_tip
    return MotionClearance(
        min_clearance=col_min(obstacle_cols, V),
        min_clearance_lower_bound=col_min(obstacle_cols, lower),
        min_body_clearance=col_min(body, V),
        min_tip_clearance=col_min(tip, V),
        min_self_clearance=col_min(is_self, V),
        lower_bound_slack=lb_slack,
        certified_ok=lb_slack >= 0.0 and not violated,
        violated=violated,
        worst_part=worst[0],
        worst_obstacle=worst[1],
        worst_command=worst[2],
        limiting_pair=pairs[c_lim].label,
        limiting_slack=float(slack_all[i_lim, c_lim]),
        limiting_command=command_of(int(i_lim)),
        evaluations=int(u_nodes.size),
    )


def plan_clearance(
    arm: SerialArm,
    world: CollisionWorld,
    sequence: CommandSequence,
    tolerance: float = CERTIFY_RESOLUTION_MM,
) -> MotionClearance:
    """The final check of a whole plan: :func:`motion_clearance` with
    :data:`WHOLE_PLAN_EVALUATIONS`; where that runs out with no sampled instant breaking the
    rule and the motion not yet proven, each half is checked with that budget again, and so on
    down to single commands where needed. A motion whose stretches are each proven clear is
    proven clear; the result is the stretches' combined (the least of each clearance, their
    commands counted from the plan's start). At most ``2 n - 1`` checks of ``n`` commands, so
    it ends; a tool tip kept a few ten-thousandths of a millimetre off the surface it follows
    along hundreds of commands (a trace with a 0.01 mm tolerance) needs more than one budget
    and was refused after the whole trace was planned."""
    parts: list[tuple[int, MotionClearance]] = []
    states = sequence.states()
    grid = sequence.grid
    stack = [(0, sequence.n_commands)]
    while stack:  # depth first, in command order: the first violated stretch stops it
        check_time("certifying the clearance of the whole plan")
        lo, hi = stack.pop()
        part = CommandSequence(states[lo], sequence.commands[lo:hi], grid)
        mc = motion_clearance(
            arm, world, part, tolerance=tolerance, max_evaluations=WHOLE_PLAN_EVALUATIONS
        )
        spent = mc.evaluations >= WHOLE_PLAN_EVALUATIONS
        if not mc.certified_ok and not mc.violated and spent and hi - lo > 1:
            mid = (lo + hi) // 2
            stack += [(mid, hi), (lo, mid)]
            continue
        parts.append((lo, mc))
        if mc.violated:
            break
    if len(parts) == 1 and parts[0][0] == 0:
        return parts[0][1]
    return _combined(parts)


def _combined(parts: list[tuple[int, MotionClearance]]) -> MotionClearance:
    """One :class:`MotionClearance` of consecutive stretches ``(first command, clearance)``:
    the least of each value, the worst and limiting pairs where they are least, commands
    counted from the whole motion's start."""
    lo_w, worst = min(parts, key=lambda p: p[1].min_clearance)
    lo_l, limit = min(parts, key=lambda p: p[1].limiting_slack)
    slack = min(mc.lower_bound_slack for _, mc in parts)
    violated = any(mc.violated for _, mc in parts)
    return MotionClearance(
        min_clearance=worst.min_clearance,
        min_clearance_lower_bound=min(mc.min_clearance_lower_bound for _, mc in parts),
        min_body_clearance=min(mc.min_body_clearance for _, mc in parts),
        min_tip_clearance=min(mc.min_tip_clearance for _, mc in parts),
        min_self_clearance=min(mc.min_self_clearance for _, mc in parts),
        lower_bound_slack=slack,
        certified_ok=slack >= 0.0 and not violated,
        violated=violated,
        worst_part=worst.worst_part,
        worst_obstacle=worst.worst_obstacle,
        worst_command=lo_w + worst.worst_command,
        limiting_pair=limit.limiting_pair,
        limiting_slack=limit.limiting_slack,
        limiting_command=lo_l + limit.limiting_command,
        evaluations=sum(mc.evaluations for _, mc in parts),
    )


#: Random configurations within the joint limits at which :func:`check_state_clear` tries a
#: pair that breaks the rule, to tell a pose in collision from a base placed too near an
#: obstacle (the pair then breaks it at every pose tried).
POSES_TRIED = 64


def _poses_within_limits(arm: SerialArm, n: int) -> FloatArray:
    """``n`` configurations drawn evenly within the joint limits (fixed seed; an unlimited
    side as :meth:`~armpath.model.serial_arm.SerialArm.sampling_box` has it)."""
    lower, upper = arm.sampling_box()
    poses: FloatArray = np.random.default_rng(0).uniform(lower, upper, (n, arm.n_joints))
    return poses


def check_state_clear(
    arm: SerialArm, world: CollisionWorld, q: FloatArray, what: str = "start state"
) -> None:
    """Raise :class:`CollisionError` naming the worst pair when ``q`` breaks the clearance rule.

    Where that pair breaks the rule at every one of :data:`POSES_TRIED` random poses within the
    joint limits too, no pose can help and the message says to move the arm's base or the
    obstacle; else, where ``q`` is the arm's home, it says how to start elsewhere."""
    values, _ = world.pair_clearances(arm, q)
    pairs = world.pairs(arm)
    if not pairs:
        return
    required = world.required(arm)
    slack = values - required
    k = int(np.argmin(slack))
    if slack[k] < 0:
        pair = pairs[k]
        home = what == "start state" and np.allclose(q, arm.home, rtol=0.0, atol=1e-9)
        elsewhere, _ = world.pair_clearances(arm, _poses_within_limits(arm, POSES_TRIED))
        if np.all(elsewhere[:, k] < required[k]):
            # a capsule thicker than the distance it lacks at the best pose: its radius is
            # what no pose helps (a --link-radius of 1e6 mm blamed the base)
            radius = max(
                (lk.radius for lk in arm.links if lk.name in (pair.part, pair.other)), default=0.0
            )
            lacking = float(required[k] - elsewhere[:, k].max())
            cause = (
                f"none can be while {pair.part} is {radius:g} {arm.length_unit} thick in "
                "radius, more than it lacks at the best of them (thinner links: "
                "--link-radius, or the radius in the robot file)"
                if radius > 0.0 and lacking < radius
                else "the arm's base stands too near it (move the base, [arm] base in a scene "
                "file, or the obstacle)"
            )
            hint = (
                f"; so is every one of {POSES_TRIED} random poses within the joint limits: " + cause
            )
        elif home:
            hint = (
                "; it is the arm's home pose: start elsewhere (--from of reach, plan, trace "
                "and spotweld; start_deg= in Python) or move the home ([arm] home_deg; run "
                "starts every task there)"
            )
        else:
            hint = ""
        raise CollisionError(
            f"{what} is in collision: {pair.part} is {values[k]:.3f} mm from {pair.other} "
            f"(needs >= {pair.required:g} mm)" + hint
        )


def check_target_clear_of_fixed_links(
    arm: SerialArm, world: CollisionWorld, target: NDArray[np.float64], tolerance: float
) -> None:
    """Raise :class:`CollisionError` where no configuration putting the tool point within
    ``tolerance`` of ``target`` can keep the links apart because ``target`` lies in or by a
    link no joint moves (:meth:`CollisionWorld.fixed_link_blocker`): a target inside the
    base column is refused at once, with the reason, rather than after a search."""
    why = world.fixed_link_blocker(arm, target, tolerance)
    if why is not None:
        where = ", ".join(f"{v:g}" for v in target)
        raise CollisionError(
            f"no configuration reaching ({where}) {arm.length_unit} keeps the links apart: {why}"
        )
