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

    ``min_clearance`` covers every checked part including the tool tip; ``min_body_clearance``
    excludes the tool tip (it must stay >= the margin); ``min_tip_clearance`` is the tool tip's
    (it must stay >= 0). Each is exact to within ``tolerance``. ``certified_ok`` is True when the
    clearance rule provably holds everywhere along the motion. ``worst_*`` locate the smallest
    clearance: part, obstacle and the command during which it happens (0 = the start state).
    """

    min_clearance: float
    min_body_clearance: float
    min_tip_clearance: float
    lower_bound_slack: float
    certified_ok: bool
    worst_part: str
    worst_obstacle: str
    worst_command: int
    tolerance: float
    evaluations: int


def motion_clearance(
    arm: SerialArm,
    world: CollisionWorld,
    sequence: CommandSequence,
    tolerance: float = 1e-3,
    initial_substeps: int = 4,
    max_rounds: int = 60,
) -> MotionClearance:
    """Smallest clearance over the continuous motion of ``sequence`` (start state included)."""
    parts = world.parts(arm)
    is_tip = np.array([p.is_tip for p in parts])
    R = displacement_bounds(arm)
    states = sequence.states().astype(np.float64)
    n = sequence.n_commands
    cmd_rate = np.abs(sequence.commands).astype(np.float64) @ R * ticks_to_rad(1.0) if n else None

    def config(u: FloatArray) -> FloatArray:
        k = np.clip(np.floor(u).astype(np.int64), 0, max(n - 1, 0))
        frac = u - k
        if n == 0:
            return ticks_to_rad(np.broadcast_to(states[0], (u.size, states.shape[1])))
        return ticks_to_rad(states[k] + frac[:, None] * sequence.commands[k])

    def evaluate(u: FloatArray) -> FloatArray:
        return world.clearances(arm, config(u))  # (M, P, O)

    if n == 0:
        u_nodes = np.zeros(1)
    else:
        u_nodes = np.unique(
            np.concatenate(
                [np.arange(n + 1, dtype=np.float64)]
                + [np.arange(n) + j / initial_substeps for j in range(initial_substeps)]
            )
        )
    C = evaluate(u_nodes)
    evaluations = u_nodes.size

    def metrics(c: FloatArray) -> FloatArray:
        body = np.where(is_tip[None, :, None], np.inf, c).min(axis=(1, 2))
        tip = np.where(~is_tip[None, :, None], np.inf, c).min(axis=(1, 2))
        return np.stack([body, tip], axis=1)  # (M, 2)

    M = metrics(C)
    if n > 0:
        for _ in range(max_rounds):
            order = np.argsort(u_nodes)
            u_nodes, C, M = u_nodes[order], C[order], M[order]
            ua, ub = u_nodes[:-1], u_nodes[1:]
            k = np.minimum(np.floor(ua).astype(np.int64), n - 1)
            assert cmd_rate is not None
            half_delta = 0.5 * cmd_rate[k] * (ub - ua)
            lb = np.minimum(M[:-1], M[1:]) - half_delta[:, None]
            best = M.min(axis=0)
            refine = np.any(lb < best[None, :] - tolerance, axis=1) & (half_delta > tolerance)
            if not np.any(refine):
                break
            mid = 0.5 * (ua[refine] + ub[refine])
            C_mid = evaluate(mid)
            evaluations += mid.size
            u_nodes = np.concatenate([u_nodes, mid])
            C = np.concatenate([C, C_mid])
            M = np.concatenate([M, metrics(C_mid)])
        order = np.argsort(u_nodes)
        u_nodes, C, M = u_nodes[order], C[order], M[order]
        k = np.minimum(np.floor(u_nodes[:-1]).astype(np.int64), n - 1)
        assert cmd_rate is not None
        half_delta = 0.5 * cmd_rate[k] * np.diff(u_nodes)
        lb = np.minimum(M[:-1], M[1:]) - half_delta[:, None]
        lb_slack = float(np.min(np.minimum(lb[:, 0] - world.margin, lb[:, 1])))
    else:
        lb_slack = float(min(M[0, 0] - world.margin, M[0, 1]))
    flat = C.reshape(C.shape[0], -1)
    idx = int(np.argmin(flat.min(axis=1)))
    p_idx, o_idx = np.unravel_index(int(np.argmin(C[idx])), C.shape[1:])
    u_worst = float(u_nodes[idx])
    worst_command = 0 if u_worst == 0.0 else int(np.ceil(u_worst))
    return MotionClearance(
        min_clearance=float(flat.min()),
        min_body_clearance=float(M[:, 0].min()),
        min_tip_clearance=float(M[:, 1].min()),
        lower_bound_slack=lb_slack,
        certified_ok=lb_slack >= 0.0,
        worst_part=parts[p_idx].name,
        worst_obstacle=world.obstacles[o_idx].name,
        worst_command=worst_command,
        tolerance=tolerance,
        evaluations=evaluations,
    )
