"""Clearance along the continuous motion of a command sequence, with a certified bound.

During a command the joints move linearly and together, so between two sampled instants every
point of the arm moves at most ``delta = sum_i |dq_i| * R_i`` (see
:func:`armpath.kinematics.displacement_bounds`). Signed distance is 1-Lipschitz, hence the
clearance anywhere in a sampled interval is at least ``min(c_a, c_b) - delta / 2``. Intervals
whose bound could still hide a smaller clearance are bisected until the smallest clearance is
known to within ``tolerance`` (branch and bound), so the reported minimum is the true minimum of
the continuous motion up to ``tolerance`` and ``certified_ok`` is a proof, not a sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.commands import CommandSequence, ticks_to_rad
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import displacement_bounds
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class MotionClearance:
    """Clearances (length unit, capsule radii subtracted) over a whole continuous motion.

    ``min_clearance`` is the smallest clearance found (any part, tool tip included), a value the
    motion really attains; ``min_clearance_lower_bound`` is a proven lower bound of the true
    minimum, so the true minimum lies between the two. ``min_body_clearance`` excludes the tool
    tip (it must stay >= the margin); ``min_tip_clearance`` is the tool tip's (>= 0 required).
    ``certified_ok`` is True when the clearance rule provably holds everywhere along the motion;
    ``violated`` when a sampled instant breaks it. ``worst_*`` locate the smallest clearance:
    part, obstacle and the command during which it happens (0 = the start state).
    """

    min_clearance: float
    min_clearance_lower_bound: float
    min_body_clearance: float
    min_tip_clearance: float
    lower_bound_slack: float
    certified_ok: bool
    violated: bool
    worst_part: str
    worst_obstacle: str
    worst_command: int
    evaluations: int


def motion_clearance(
    arm: SerialArm,
    world: CollisionWorld,
    sequence: CommandSequence,
    tolerance: float = 0.01,
    initial_substeps: int = 4,
    max_evaluations: int = 20_000,
    precision_evaluations: int = 1_000,
) -> MotionClearance:
    """Smallest clearance over the continuous motion of ``sequence`` (start state included).

    Intervals whose bound does not yet prove the clearance rule are bisected, lowest bound
    first, until the rule is certified, a sampled instant violates it, or ``max_evaluations``
    configurations have been evaluated. Then up to ``precision_evaluations`` more narrow the gap
    between the smallest clearance found and its proven lower bound toward ``tolerance``. A
    violated motion is not refined further.
    """
    parts = world.parts(arm)
    is_tip = np.array([p.is_tip for p in parts])
    R = displacement_bounds(arm)
    states = sequence.states().astype(np.float64)
    n = sequence.n_commands
    rate = np.abs(sequence.commands).astype(np.float64) @ R * ticks_to_rad(1.0)

    def config(u: FloatArray) -> FloatArray:
        if n == 0:
            return ticks_to_rad(np.broadcast_to(states[0], (u.size, states.shape[1])))
        k = np.clip(np.floor(u).astype(np.int64), 0, n - 1)
        return ticks_to_rad(states[k] + (u - k)[:, None] * sequence.commands[k])

    def metrics(c: FloatArray) -> FloatArray:
        body = np.where(is_tip[None, :, None], np.inf, c).min(axis=(1, 2))
        tip = np.where(~is_tip[None, :, None], np.inf, c).min(axis=(1, 2))
        return np.stack([body, tip], axis=1)  # (M, 2)

    required = np.array([world.margin, 0.0])
    tighten = required.copy()  # per metric: tighten lower bounds that fall below this

    def evaluate(u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        per_part = np.where(is_tip, tighten[1], tighten[0])
        values, lowers = world.clearance_bounds(arm, config(u), tighten_below=per_part)
        return values, metrics(values), metrics(lowers)

    u_nodes = np.unique(
        np.concatenate(
            [np.arange(n + 1, dtype=np.float64)]
            + [np.arange(n) + j / initial_substeps for j in range(1, initial_substeps)]
        )
    )
    C, M, L = evaluate(u_nodes)  # values (M, P, O); value and lower-bound metrics (M, 2)

    def bounds() -> tuple[FloatArray, FloatArray]:
        k = np.minimum(np.floor(u_nodes[:-1]).astype(np.int64), max(n - 1, 0))
        half_delta = 0.5 * rate[k] * np.diff(u_nodes) if n else np.zeros(0)
        return np.minimum(L[:-1], L[1:]) - half_delta[:, None], half_delta

    certified_at: int | None = None
    while n > 0:
        lb, half_delta = bounds()
        if np.min(M - required) < 0:
            break  # a sampled instant violates the rule: the motion is rejected
        slack_lb = (lb - required).min(axis=1)
        need = (slack_lb < 0) & (half_delta > tolerance / 2)
        budget = max_evaluations - u_nodes.size
        if not np.any(need):  # certified: spend a little on the precision of the minimum
            best = M.min(axis=0)
            if certified_at is None:
                certified_at = u_nodes.size
                # tighten the bounds of the instants that could hide a smaller minimum
                tighten = np.maximum(required, best - tolerance)
                loose = np.flatnonzero(np.any(tighten > L, axis=1))[:precision_evaluations]
                if loose.size:
                    C[loose], M[loose], L[loose] = evaluate(u_nodes[loose])
                continue
            need = np.any(lb < best - tolerance, axis=1) & (half_delta > tolerance / 2)
            budget = min(budget, certified_at + precision_evaluations - u_nodes.size)
        if not np.any(need) or budget <= 0:
            break
        idx = np.flatnonzero(need)
        idx = idx[np.argsort(slack_lb[idx])[: min(budget, 4096)]]
        mid = 0.5 * (u_nodes[idx] + u_nodes[idx + 1])
        C_mid, M_mid, L_mid = evaluate(mid)
        order = np.argsort(np.concatenate([u_nodes, mid]), kind="stable")
        u_nodes = np.concatenate([u_nodes, mid])[order]
        C = np.concatenate([C, C_mid])[order]
        M = np.concatenate([M, M_mid])[order]
        L = np.concatenate([L, L_mid])[order]

    lb, _ = bounds()
    lower = lb if n else L
    lb_slack = float((lower - required).min())
    flat = C.reshape(C.shape[0], -1)
    idx_min = int(np.argmin(flat.min(axis=1)))
    p_idx, o_idx = np.unravel_index(int(np.argmin(C[idx_min])), C.shape[1:])
    u_worst = float(u_nodes[idx_min])
    violated = bool(np.min(M - required) < 0)
    return MotionClearance(
        min_clearance=float(flat.min()),
        min_clearance_lower_bound=float(lower.min()),
        min_body_clearance=float(M[:, 0].min()),
        min_tip_clearance=float(M[:, 1].min()),
        lower_bound_slack=lb_slack,
        certified_ok=lb_slack >= 0.0 and not violated,
        violated=violated,
        worst_part=parts[p_idx].name,
        worst_obstacle=world.obstacles[o_idx].name,
        worst_command=0 if u_worst == 0.0 else int(np.ceil(u_worst)),
        evaluations=int(u_nodes.size),
    )
