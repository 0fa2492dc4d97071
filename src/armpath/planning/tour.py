"""Visiting several target points in the best order (Task 3, the spot welds).

For each target, :func:`~armpath.planning.reach.goal_states` gives a few clear lattice states
that put the fingertip on it. Every visiting order is ranked by a lower bound of its commands:
a shortest path through the layers start -> goals of the 1st target -> goals of the 2nd ...,
each step costing the commands of the direct motion (obstacles ignored, so no order can do
better). The best-ranked orders are then planned leg by leg with
:func:`~armpath.planning.motion.plan_motion` (direct where clear, else searched), and the order
with the fewest planned commands wins.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.commands import CommandSequence, ticks_to_rad
from armpath.errors import InvalidInputError, PlanningError
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import tool_position
from armpath.model.serial_arm import SerialArm
from armpath.planning.motion import (
    MotionOptions,
    MotionPlan,
    PlanMetrics,
    plan_metrics,
    plan_motion,
)
from armpath.planning.motion_check import MotionClearance, motion_clearance
from armpath.planning.reach import goal_states

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class Visit:
    """Target ``target_index`` reached after command ``after_command`` (1-based) with
    fingertip error ``error_mm``."""

    target_index: int
    target_mm: tuple[float, float, float]
    after_command: int
    error_mm: float


@dataclass(frozen=True, eq=False)
class TourResult:
    """A planned tour: the whole command sequence and where each target is reached."""

    sequence: CommandSequence
    order: tuple[int, ...]
    visits: tuple[Visit, ...]
    legs: tuple[MotionPlan, ...]
    returns_to_start: bool
    clearance: MotionClearance
    metrics: PlanMetrics
    order_lower_bounds: dict[tuple[int, ...], int]
    orders_planned: dict[tuple[int, ...], int]
    tolerance_mm: float

    @property
    def n_commands(self) -> int:
        return self.sequence.n_commands

    @property
    def max_error_mm(self) -> float:
        return max(v.error_mm for v in self.visits)


def _order_bound(start: IntArray, goals: list[IntArray], order: tuple[int, ...], back: bool) -> int:
    """Fewest direct-motion commands through one goal state per target in ``order``."""
    # cost[k] = best commands to be at goal k of the current layer
    cost = np.array([0.0])
    prev = start[None, :]
    for t in order:
        g = goals[t]
        step = np.ceil(np.max(np.abs(g[None, :, :] - prev[:, None, :]), axis=-1) / 20.0)
        cost = np.min(cost[:, None] + step, axis=0)
        prev = g
    if back:
        cost = cost + np.ceil(np.max(np.abs(prev - start), axis=-1) / 20.0)
    return int(np.min(cost))


def plan_tour(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: ArrayLike,
    targets_mm: ArrayLike,
    order: str = "auto",
    return_to_start: bool = False,
    tolerance_mm: float = 0.05,
    goals_per_target: int = 16,
    orders_to_plan: int = 2,
    options: MotionOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
) -> TourResult:
    """Plan a clear tour from ``start_ticks`` through every target (mm), optionally back.

    ``order`` is ``"auto"`` (every order ranked by its lower bound, the ``orders_to_plan`` best
    planned) or ``"given"`` (the targets' order). Raises :class:`PlanningError` when a target
    cannot be reached clear of the obstacles.
    """
    if order not in ("auto", "given"):
        raise InvalidInputError(f"order must be 'auto' or 'given', got {order!r}")
    pts = np.asarray(targets_mm, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] == 0 or not np.all(np.isfinite(pts)):
        raise InvalidInputError(f"targets must be a list of finite (x, y, z) mm, got {pts.shape}")
    start = np.asarray(start_ticks, dtype=np.int64)
    say = on_progress or (lambda _msg: None)
    opts = options or MotionOptions()
    goals: list[IntArray] = []
    for i, p in enumerate(pts):
        say(f"goal states for target {i + 1} ({', '.join(f'{v:.2f}' for v in p)}) mm")
        g, _ = goal_states(arm, world, start, p, tolerance_mm, goals_per_target)
        goals.append(g)
    orders = (
        [tuple(range(len(pts)))]
        if order == "given"
        else list(itertools.permutations(range(len(pts))))
    )
    bounds = {o: _order_bound(start, goals, o, return_to_start) for o in orders}
    ranked = sorted(orders, key=lambda o: (bounds[o], o))[: max(1, orders_to_plan)]
    best: tuple[int, list[MotionPlan], tuple[int, ...]] | None = None
    planned: dict[tuple[int, ...], int] = {}
    failures: list[str] = []
    for o in ranked:
        say(f"planning order {[i + 1 for i in o]} (lower bound {bounds[o]} commands)")
        legs: list[MotionPlan] = []
        state = start
        try:
            for t in o:
                leg = plan_motion(arm, world, state, goals[t], opts)
                legs.append(leg)
                state = leg.sequence.final_ticks
            if return_to_start:
                leg = plan_motion(arm, world, state, start[None, :], opts)
                legs.append(leg)
        except PlanningError as exc:
            failures.append(f"order {[i + 1 for i in o]}: {exc}")
            continue
        total = sum(leg.sequence.n_commands for leg in legs)
        planned[o] = total
        if best is None or total < best[0]:
            best = (total, legs, o)
    if best is None:
        raise PlanningError("no order could be planned: " + "; ".join(failures))
    _, legs, chosen = best
    commands = np.vstack([leg.sequence.commands for leg in legs])
    sequence = CommandSequence(start, commands)
    visits = []
    k = 0
    for t, leg in zip(chosen, legs, strict=False):
        k += leg.sequence.n_commands
        tip = tool_position(arm, ticks_to_rad(leg.sequence.final_ticks))
        visits.append(
            Visit(t, tuple(float(v) for v in pts[t]), k, float(np.linalg.norm(tip - pts[t])))  # type: ignore[arg-type]
        )
    say("certifying the whole tour's continuous motion")
    clearance = motion_clearance(arm, world, sequence)
    if not clearance.certified_ok:
        raise PlanningError(
            f"tour failed its final clearance check ({clearance.limiting_pair} "
            f"{clearance.limiting_slack:+.3f} mm at command {clearance.limiting_command})"
        )
    return TourResult(
        sequence=sequence,
        order=chosen,
        visits=tuple(visits),
        legs=tuple(legs),
        returns_to_start=return_to_start,
        clearance=clearance,
        metrics=plan_metrics(arm, sequence, opts.energy_weights),
        order_lower_bounds=bounds,
        orders_planned=planned,
        tolerance_mm=tolerance_mm,
    )
