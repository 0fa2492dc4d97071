"""Every lattice state that puts the tool point within a tolerance of a point: a complete,
exact enumeration by branch and bound over boxes of ticks.

A plan reaches a target at a *lattice state* (whole ticks of every joint) whose tool point lies
within the tolerance of it. Those states are finite and, unlike the family's continuous members
(:mod:`.sampling`), carry no sampling error: a tour's relaxation over them (:mod:`.tour`) is
exact, and each leg between two of them takes at least their largest joint change in whole
commands.

The search keeps boxes of ticks of the joints that move the tool point (the others stay at the
start's values: the caller makes sure they move no part of the arm). A box is dropped when no
configuration in it can bring the tool point within the tolerance of the target. Anywhere in
the box the tool point lies within ``sum_k B_k r_k`` of the centre's (``B`` the joints'
:func:`~armpath.kinematics.displacement_bounds`, ``r`` the box's half-widths, rad): the test
of wide boxes. For a narrower one with centre ``c`` (tool point ``p``, position Jacobian
``J``), every configuration ``c + d`` of the box has its tool point at ``p + J d + e`` with
``|e| <= 1/2 sum_ij M_ij r_i r_j``, where ``M_ij`` bounds the second derivative of the tool
point in joints ``i`` and ``j``: for revolute joints the distance from the later joint's axis
to the tool point, at most ``B`` of that joint; so for every unit vector ``u``,
``|u . (target - p)| <= sum_k |u . J_k| r_k + |e| + tolerance`` holds if the box holds such a
state. The test takes ``u`` toward the target and along the normals of the linearised image's
faces (``J_i x J_j``), which bound it exactly; a box that fails one is dropped, another is
halved along the joint that may move the tool point most across it. Single states are checked
by their exact tool point. States that break the clearance rule can be left out on the way
(see :func:`lattice_goal_states`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.jit import njit
from armpath.kinematics import displacement_bounds, z_axis_chain
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Boxes one enumeration may look at (about a quarter of a microsecond each, so some 50 s): past
#: it the enumeration gives up, and a caller falls back on the family's sampled members.
MAX_GOAL_BOXES = 200_000_000
#: Lattice states one enumeration may return (48 bytes each for six joints).
MAX_GOAL_STATES = 2_000_000
#: Boxes the kernel looks at between two looks at the clock (about a quarter of a second).
CHUNK_BOXES = 1_000_000
#: How a run of the kernel ended: every box looked at; its chunk of boxes spent (the boxes not
#: looked at yet returned, to resume from); a budget of states or the stack's depth spent.
_DONE, _CHUNK_SPENT, _GAVE_UP = 0, 1, 2
#: Widest span of half-ticks (per joint) whose sines and cosines the kernel tabulates; a finer
#: lattice's joints are turned with ``sin`` and ``cos`` at each box (8 bytes a value, two a
#: half-tick: 2 MiB a joint at most).
MAX_TABLE = 1 << 17
#: Depth of the search's stack: each halving adds one box, and a box of ``2**k`` ticks is halved
#: at most ``k`` times along that joint.
_STACK = 4096
#: Widths (ticks), widest first, at which the search stops to look at the clearance of the boxes
#: it keeps, before it searches on inside those that may hold a state keeping the rule. The looks
#: end after one that dropped less than :data:`MIN_DROPPED_SHARE` of its boxes (a look costs
#: about twenty of the kernel's boxes). One thread (``benchmarks/bench_lattice_goals.py``,
#: 2026-12-05), the UR5 cell's four welds: 58 s at 8 ticks alone, 34 s at 32, 16 and 8 (32
#: drops about 70 %, 16 a fifth, 8 a seventh), 32 s on this schedule; the seed's Task 3: 19 s
#: at 8 alone, 27 s at all three (32 and 16 drop at most 7 %, 8 half to three quarters), 16.5 s
#: on this schedule (32 alone).
COARSE_TICKS = (32, 16, 8)
MIN_DROPPED_SHARE = 0.25


@dataclass(frozen=True)
class GoalStates:
    """The lattice states (ticks ``(K, n)``) within the tolerance of a target, the boxes looked
    at, and whether the enumeration is complete (False: a budget ran out)."""

    ticks: IntArray
    boxes: int
    complete: bool


def second_derivative_bounds(arm: SerialArm) -> FloatArray:
    """``(n, n)`` bounds on the tool point's second derivatives (model units per rad^2, or
    per unit of a prismatic joint): that of joints ``i`` and ``j`` is at most the later joint's
    :func:`~armpath.kinematics.displacement_bounds` (a revolute joint's distance to the tool
    point; 1 for a prismatic one, whose mixed derivatives are unit vectors or zero)."""
    reach = displacement_bounds(arm)
    n = reach.size
    index = np.maximum.outer(np.arange(n), np.arange(n))
    return np.asarray(np.maximum(reach[index], 1.0), dtype=np.float64)


def tip_chain(
    arm: SerialArm, tip_index: IntArray, q_fixed: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """The arm as rigid transforms between the joints ``tip_index`` (ascending), the others
    held at their values in ``q_fixed`` (rad, or model units for a prismatic joint): ``P``
    ``(m + 1, 3, 4)`` (rotation | translation rows) with the tool pose
    ``P_0 Z_0 P_1 Z_1 ... Z_(m-1) P_m``, ``Z_k`` a turn about (or a shift along) z by tip joint
    ``k``'s value, and whether each tip joint is prismatic. Frame ``P_0 Z_0 ... P_k`` has tip
    joint ``k``'s axis as its z axis, its origin on that axis (:func:`z_axis_chain`)."""
    C = z_axis_chain(arm)
    prismatic = np.array([j.kind is JointKind.PRISMATIC for j in arm.joints])
    tip = set(int(i) for i in tip_index)
    parts: list[FloatArray] = []
    current = C[0].copy()
    for i in range(arm.n_joints):
        if i in tip:
            parts.append(current)
            current = C[i + 1].copy()
            continue
        Z = np.eye(4)
        if prismatic[i]:
            Z[2, 3] = q_fixed[i]
        else:
            c, s = np.cos(q_fixed[i]), np.sin(q_fixed[i])
            Z[:2, :2] = [[c, -s], [s, c]]
        current = current @ Z @ C[i + 1]
    parts.append(current)
    P = np.ascontiguousarray(np.stack(parts)[:, :3, :], dtype=np.float64)
    return P, np.ascontiguousarray(prismatic[np.asarray(tip_index, dtype=np.int64)])


def kernel_constants(
    arm: SerialArm,
    target: FloatArray,
    tolerance: float,
    tip: NDArray[np.bool_],
    fixed_ticks: IntArray,
) -> tuple[FloatArray, FloatArray, float, FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """The arguments of :func:`_enumerate` between the boxes and the budgets, for the joints
    ``tip`` listed about ``target`` (model units) within ``tolerance``, the others held at
    ``fixed_ticks``: the listed joints' ticks, the target, the tolerance, the second-derivative
    and displacement bounds, and :func:`tip_chain`'s transforms and prismatic flags."""
    tick = np.asarray(arm.lattice.tick, dtype=np.float64)
    tip_index = np.flatnonzero(tip).astype(np.int64)
    q_fixed = np.asarray(fixed_ticks, dtype=np.float64) * tick
    M = second_derivative_bounds(arm)[np.ix_(tip_index, tip_index)]
    reach_bound = np.ascontiguousarray(displacement_bounds(arm)[tip_index], dtype=np.float64)
    chain, tip_prismatic = tip_chain(arm, tip_index, q_fixed)
    return (
        np.ascontiguousarray(tick[tip_index]),
        np.asarray(target, dtype=np.float64),
        float(tolerance),
        np.ascontiguousarray(M),
        reach_bound,
        chain,
        tip_prismatic,
    )


def lattice_goal_states(
    arm: SerialArm,
    target: FloatArray,
    tolerance: float,
    tip: NDArray[np.bool_],
    fixed_ticks: IntArray,
    lower_ticks: IntArray,
    upper_ticks: IntArray,
    may_be_clear: Callable[[FloatArray, FloatArray], NDArray[np.bool_]] | None = None,
    max_boxes: int = MAX_GOAL_BOXES,
    max_states: int = MAX_GOAL_STATES,
) -> GoalStates:
    """Every lattice state with the tool point within ``tolerance`` (model units) of
    ``target`` (model units) whose joints in ``tip`` lie within ``lower_ticks`` ..
    ``upper_ticks`` (inclusive, one per tip joint) and whose other joints are ``fixed_ticks``
    (ticks ``(n,)``; the tip joints' entries are ignored). Complete unless a budget ran out.

    ``may_be_clear`` (configurations ``(N, n)`` rad and how far any point of the arm may move
    from each, model units -> whether a configuration so near may keep the clearance rule, as
    :meth:`~armpath.geometry.world.CollisionWorld.may_be_clear_within`): the states that break
    the rule are not wanted, so the search keeps boxes :data:`COARSE_TICKS` wide in turn and
    drops those whose centre says no for the farthest any point of the arm moves within the
    box; every state of such a box breaks the rule. It stops looking after a width whose look
    dropped less than :data:`MIN_DROPPED_SHARE` of the boxes."""
    grid = arm.lattice
    tick = np.asarray(grid.tick, dtype=np.float64)
    tip_index = np.flatnonzero(tip).astype(np.int64)
    q_fixed = np.asarray(fixed_ticks, dtype=np.float64) * tick
    reach_bound = np.ascontiguousarray(displacement_bounds(arm)[tip_index], dtype=np.float64)
    fixed = kernel_constants(arm, target, tolerance, tip, fixed_ticks)

    def run(
        lo: IntArray, hi: IntArray, coarse: int, boxes_left: int
    ) -> tuple[IntArray, IntArray, int, bool]:
        """The boxes kept (``coarse`` > 1) or the states found from the boxes ``lo`` ..
        ``hi``, the boxes looked at, and whether complete: the kernel runs
        :data:`CHUNK_BOXES` boxes at a time, resumed from the boxes it has not looked at
        yet, so that a time limit is heard between chunks."""
        found_lo: list[IntArray] = []
        found_hi: list[IntArray] = []
        kept = looked = 0
        while True:
            check_time("listing the lattice goal states")
            chunk = min(CHUNK_BOXES, boxes_left - looked)
            out, out_hi, count, used, status, lo, hi = _enumerate(
                np.ascontiguousarray(lo, dtype=np.int64),
                np.ascontiguousarray(hi, dtype=np.int64),
                *fixed,
                int(max(chunk, 0)),
                int(max_states - kept),
                int(coarse),
            )
            found_lo.append(out[:count])
            found_hi.append(out_hi[:count])
            kept += count
            looked += used
            if status != _CHUNK_SPENT or looked >= boxes_left or kept >= max_states:
                return (
                    np.concatenate(found_lo),
                    np.concatenate(found_hi),
                    looked,
                    status == _DONE,
                )

    lo = np.asarray(lower_ticks, dtype=np.int64).reshape(1, -1)
    hi = np.asarray(upper_ticks, dtype=np.int64).reshape(1, -1)
    boxes = 0
    looks = COARSE_TICKS if may_be_clear is not None else ()
    for coarse in looks:
        assert may_be_clear is not None
        lo, hi, more, complete = run(lo, hi, coarse, max_boxes - boxes)
        boxes += more
        count = lo.shape[0]
        if not complete:
            return GoalStates(np.zeros((0, tip.size), dtype=np.int64), boxes, False)
        if count:
            centre = np.broadcast_to(q_fixed, (count, tip.size)).copy()
            centre[:, tip_index] = 0.5 * (lo + hi) * tick[tip_index]
            keep = may_be_clear(centre, (0.5 * (hi - lo) * tick[tip_index]) @ reach_bound)
            lo, hi = lo[keep], hi[keep]
        if lo.shape[0] > (1.0 - MIN_DROPPED_SHARE) * count:
            break  # the narrower looks would pay less than they cost
    out, _, more, complete = run(lo, hi, 0, max_boxes - boxes)
    ticks = np.broadcast_to(np.asarray(fixed_ticks, dtype=np.int64), (out.shape[0], tip.size))
    ticks = ticks.copy()
    ticks[:, tip_index] = out
    return GoalStates(ticks, int(boxes + more), bool(complete))


#: Boxes :func:`lattice_state_exists` may look at for one point (about half a second): a point
#: near which no state lies is only known so once every box is dropped.
EXISTS_BOXES = 2_000_000


def whole_range_ticks(arm: SerialArm, tip: NDArray[np.bool_]) -> tuple[IntArray, IntArray] | None:
    """The lowest and highest ticks of each joint in ``tip`` over which every tool point the
    lattice can reach is reached: each joint's limits, a revolute joint without limits or
    with more than a turn between them over one turn (its states repeat every turn when a turn
    is a whole number of ticks); None where that cannot be said (such a joint whose turn is
    not, or a sliding joint without limits)."""
    grid = arm.lattice
    index = np.flatnonzero(tip)
    tick = np.asarray(grid.tick, dtype=np.float64)[index]
    revolute = np.array([arm.joints[int(i)].kind is JointKind.REVOLUTE for i in index])
    lower_limit, upper_limit = arm.lower[index], arm.upper[index]
    bounded = np.isfinite(lower_limit) & np.isfinite(upper_limit)
    turn = 2.0 * np.pi / tick
    whole = np.abs(turn - np.round(turn)) <= 1e-6
    if np.any(~bounded & ~(revolute & whole)):
        return None
    lowest, highest = (ticks[index] for ticks in arm.tick_limits)
    lower = np.where(bounded, lowest, np.ceil(-np.pi / tick - 1e-9)).astype(np.int64)
    upper = np.where(bounded, highest, np.floor(np.pi / tick + 1e-9)).astype(np.int64)
    turns = revolute & whole
    upper = np.where(
        turns, np.minimum(upper, lower + np.round(turn).astype(np.int64) - 1), upper
    ).astype(np.int64)
    return lower, upper


def lattice_state_exists(
    arm: SerialArm,
    target: FloatArray,
    tolerance: float,
    tip: NDArray[np.bool_],
    max_boxes: int = EXISTS_BOXES,
) -> bool | None:
    """Whether any lattice state within the joint limits puts the tool point within
    ``tolerance`` (model units) of ``target`` (model units), obstacles left out: the listing of
    :func:`lattice_goal_states` over :func:`whole_range_ticks`, stopped at the first state
    (the joints outside ``tip``, which move no tool point, held at a tick within their limits).
    False is a proof that none does; None where it cannot be said (a budget of ``max_boxes``
    spent, or a joint's range that cannot be listed)."""
    ranges = whole_range_ticks(arm, tip)
    if ranges is None:
        return None
    fixed = np.clip(0.0, *arm.tick_limits).astype(np.int64)  # the tick nearest 0 within them
    found = lattice_goal_states(
        arm,
        np.asarray(target, dtype=np.float64),
        tolerance * (1.0 + 1e-9) + 1e-12,  # a superset of the exact test's states
        np.asarray(tip, dtype=bool),
        fixed,
        ranges[0],
        ranges[1],
        max_boxes=max_boxes,
        max_states=1,
    )
    if found.ticks.shape[0]:
        return True
    return False if found.complete else None


@njit(cache=True, nogil=True)
def _enumerate(
    lower: np.ndarray,
    upper: np.ndarray,
    tick: np.ndarray,
    target: np.ndarray,
    tolerance: float,
    M: np.ndarray,
    reach_bound: np.ndarray,
    chain: np.ndarray,
    prismatic: np.ndarray,
    max_boxes: int,
    max_states: int,
    coarse: int,
) -> tuple[
    np.ndarray, np.ndarray, int, int, int, np.ndarray, np.ndarray
]:  # pragma: no cover - compiled
    """The branch and bound of :func:`lattice_goal_states` (see the module) over the boxes
    ``lower`` .. ``upper`` of the tip joints (``tick`` theirs; ``chain`` and ``prismatic``
    from :func:`tip_chain`), at most ``max_boxes`` of them: the states found (``lo`` of
    ``(count, m)`` boxes of one state) and, with ``coarse`` > 1, the boxes kept whose widest
    joint spans at most ``coarse`` ticks (their ``lo`` and ``hi``), not split; the boxes looked
    at; how it ended (:data:`_DONE`, :data:`_CHUNK_SPENT`, :data:`_GAVE_UP`); and the boxes not
    looked at yet, to resume from (none unless the chunk was spent).

    A box's centre lies on whole or half ticks (``lo + hi`` half-ticks): the joints' sines and
    cosines there are tabulated once over the boxes' span (at most :data:`MAX_TABLE`
    half-ticks a joint, else taken at each box)."""
    m = tick.shape[0]
    lo = np.empty((_STACK, m), dtype=np.int64)
    hi = np.empty((_STACK, m), dtype=np.int64)
    out = np.empty((1024, m), dtype=np.int64)
    out_hi = np.empty((1024, m), dtype=np.int64)
    count = 0
    boxes = 0
    G = np.zeros((3, 4))
    axis = np.zeros((m, 3))
    origin = np.zeros((m, 3))
    J = np.zeros((3, m))
    r = np.zeros(m)
    none = np.empty((0, m), dtype=np.int64)
    first = np.zeros(m, dtype=np.int64)
    span = 0
    for k in range(m):
        for start in range(lower.shape[0]):
            if start == 0 or lower[start, k] < first[k] // 2:
                first[k] = 2 * lower[start, k]
        for start in range(lower.shape[0]):
            span = max(span, 2 * upper[start, k] - first[k] + 1)
    tabulated = span <= MAX_TABLE
    sine = np.zeros((m, span if tabulated else 0))
    cosine = np.zeros((m, span if tabulated else 0))
    if tabulated:
        for k in range(m):
            for i in range(span):
                v = 0.5 * (first[k] + i) * tick[k]
                sine[k, i], cosine[k, i] = np.sin(v), np.cos(v)
    for start in range(lower.shape[0]):
        empty = False
        for k in range(m):
            empty = empty or lower[start, k] > upper[start, k]
            lo[0, k] = lower[start, k]
            hi[0, k] = upper[start, k]
        top = 0 if empty else 1
        while top > 0:
            if boxes == max_boxes:  # the stack and the starts not begun, to resume from
                rest = top + lower.shape[0] - start - 1
                rest_lo = np.empty((rest, m), dtype=np.int64)
                rest_hi = np.empty((rest, m), dtype=np.int64)
                for i in range(rest):
                    for k in range(m):
                        if i < top:
                            rest_lo[i, k], rest_hi[i, k] = lo[i, k], hi[i, k]
                        else:
                            at = start + 1 + i - top
                            rest_lo[i, k], rest_hi[i, k] = lower[at, k], upper[at, k]
                return out, out_hi, count, boxes, _CHUNK_SPENT, rest_lo, rest_hi
            top -= 1
            boxes += 1
            single = True
            # the tool point at the centre: the chain's product, each tip joint's axis (its
            # frame's z) and a point of it (the origin) taken before the joint's own motion
            for i in range(3):
                for j in range(4):
                    G[i, j] = chain[0, i, j]
            for k in range(m):
                r[k] = 0.5 * (hi[top, k] - lo[top, k]) * tick[k]
                if hi[top, k] > lo[top, k]:
                    single = False
                for i in range(3):
                    axis[k, i] = G[i, 2]
                    origin[k, i] = G[i, 3]
                half_ticks = lo[top, k] + hi[top, k]
                v = 0.5 * half_ticks * tick[k]
                if prismatic[k]:
                    for i in range(3):
                        G[i, 3] += v * G[i, 2]
                else:
                    if tabulated:
                        s, c = sine[k, half_ticks - first[k]], cosine[k, half_ticks - first[k]]
                    else:
                        s, c = np.sin(v), np.cos(v)
                    for i in range(3):
                        g0, g1 = G[i, 0], G[i, 1]
                        G[i, 0] = c * g0 + s * g1
                        G[i, 1] = c * g1 - s * g0
                P = chain[k + 1]
                for i in range(3):
                    g0, g1, g2, t = G[i, 0], G[i, 1], G[i, 2], G[i, 3]
                    for j in range(4):
                        G[i, j] = g0 * P[0, j] + g1 * P[1, j] + g2 * P[2, j]
                    G[i, 3] += t
            px, py, pz = G[0, 3], G[1, 3], G[2, 3]
            vx, vy, vz = target[0] - px, target[1] - py, target[2] - pz
            dist = np.sqrt(vx * vx + vy * vy + vz * vz)
            if single:  # a state: its exact tool point decides
                if dist <= tolerance:
                    if count == out.shape[0] and count >= max_states:
                        return out, out_hi, count, boxes, _GAVE_UP, none, none
                    out, out_hi, count = _kept(out, out_hi, count, lo[top], hi[top])
                continue
            for k in range(m):
                z0, z1, z2 = axis[k, 0], axis[k, 1], axis[k, 2]
                if prismatic[k]:
                    J[0, k], J[1, k], J[2, k] = z0, z1, z2
                else:
                    r0, r1, r2 = px - origin[k, 0], py - origin[k, 1], pz - origin[k, 2]
                    J[0, k] = z1 * r2 - z2 * r1
                    J[1, k] = z2 * r0 - z0 * r2
                    J[2, k] = z0 * r1 - z1 * r0
            second = 0.0
            lipschitz = 0.0
            for a in range(m):
                lipschitz += reach_bound[a] * r[a]
                for b in range(m):
                    second += 0.5 * M[a, b] * r[a] * r[b]
            # anywhere in the box the tool point lies within lipschitz of the centre's
            if dist > lipschitz + tolerance:
                continue
            slack = tolerance + second
            # the linearisation's tests (useless where its remainder exceeds lipschitz)
            dropped = False
            if second < lipschitz and dist > 0.0:
                # toward the target
                reach = 0.0
                for k in range(m):
                    reach += abs(J[0, k] * vx + J[1, k] * vy + J[2, k] * vz) * r[k]
                dropped = dist > reach / dist + slack
            # along the normals of the linearised image's faces
            a = 0
            while second < lipschitz and not dropped and a < m:
                b = a + 1
                while not dropped and b < m:
                    ux = J[1, a] * J[2, b] - J[2, a] * J[1, b]
                    uy = J[2, a] * J[0, b] - J[0, a] * J[2, b]
                    uz = J[0, a] * J[1, b] - J[1, a] * J[0, b]
                    norm = np.sqrt(ux * ux + uy * uy + uz * uz)
                    if norm > 1e-12:  # (the test scaled by the normal's length)
                        reach = 0.0
                        for k in range(m):
                            reach += abs(J[0, k] * ux + J[1, k] * uy + J[2, k] * uz) * r[k]
                        dropped = abs(ux * vx + uy * vy + uz * vz) > reach + slack * norm
                    b += 1
                a += 1
            if dropped:
                continue
            widest = 0
            for k in range(m):
                widest = max(widest, hi[top, k] - lo[top, k] + 1)
            if widest <= coarse:  # kept whole for the caller's clearance test
                if count == out.shape[0] and count >= max_states:
                    return out, out_hi, count, boxes, _GAVE_UP, none, none
                out, out_hi, count = _kept(out, out_hi, count, lo[top], hi[top])
                continue
            # halve along the joint that may move the tool point most across the box: its
            # linear and second-order share, or its Lipschitz share where that is less
            best, best_k = -1.0, 0
            for k in range(m):
                if hi[top, k] > lo[top, k]:
                    moves = np.sqrt(J[0, k] ** 2 + J[1, k] ** 2 + J[2, k] ** 2) * r[k]
                    for b in range(m):
                        moves += M[k, b] * r[k] * r[b]
                    moves = min(moves, reach_bound[k] * r[k])
                    if moves > best:
                        best, best_k = moves, k
            if top + 2 > _STACK:
                return out, out_hi, count, boxes, _GAVE_UP, none, none
            mid = (lo[top, best_k] + hi[top, best_k]) // 2
            for k in range(m):
                lo[top + 1, k] = lo[top, k]
                hi[top + 1, k] = hi[top, k]
            hi[top, best_k] = mid
            lo[top + 1, best_k] = mid + 1
            top += 2
    return out, out_hi, count, boxes, _DONE, none, none


@njit(cache=True, nogil=True)
def _kept(
    out: np.ndarray, out_hi: np.ndarray, count: int, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray, int]:  # pragma: no cover - compiled
    """``out`` and ``out_hi`` with the box ``lo`` .. ``hi`` added as row ``count`` (both
    doubled when full), and the new count. The caller checks its budget of rows before."""
    m = lo.shape[0]
    if count == out.shape[0]:
        bigger = np.empty((2 * count, m), dtype=np.int64)
        bigger_hi = np.empty((2 * count, m), dtype=np.int64)
        for i in range(count):
            for k in range(m):
                bigger[i, k] = out[i, k]
                bigger_hi[i, k] = out_hi[i, k]
        out, out_hi = bigger, bigger_hi
    for k in range(m):
        out[count, k] = lo[k]
        out_hi[count, k] = hi[k]
    return out, out_hi, count + 1
