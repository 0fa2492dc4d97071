"""Trace a curve with the fingertip: command sequences whose continuous tip path stays on it.

1. **Reachability** (:mod:`armpath.planning.curve_reach`) splits the curve into reachable arcs.
2. **Redundancy resolution.** The fingertip has a two-dimensional family of solutions at every
   curve point. A reference path through the family is chosen by dynamic programming over layers
   of the family every few mm: nodes keep a clearance and joint-limit slack, transitions cost the
   largest joint change (what commands cost) less a small reward for slack; where the family
   cannot be followed continuously the path pays for a lift-off, which splits the arc into
   *passes* (as few as possible).
3. **Commands.** From the current lattice state, the planner looks for the command that carries
   the tip farthest along the curve: for each candidate advance it follows the reference (pulled
   gently toward it), projects onto the curve point (offset outward by half the tolerance when the
   curve lies on a surface, so the tip neither leaves the band nor enters the surface), and
   searches the lattice around it. Candidates are pre-filtered by the linearized offset in the
   curve's normal plane, then checked exactly: end point within the band, the continuous motion
   sampled within the band and outside the surface, the clearance rule with a small buffer.
4. **Passes and transits.** The arm moves from the start to each pass, and between passes (lifting
   off the surface), with the collision-free planner (:func:`~armpath.planning.motion.plan_motion`).
5. **Certification.** The whole sequence's clearance is certified along the continuous motion
   (:func:`~armpath.planning.motion_check.motion_clearance`); the tip's deviation from the curve
   during every pass is bounded by branch and bound with the tip's largest speed, so the reported
   largest deviation is the true maximum of the continuous path to within ``2 um``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numba
import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.commands import MAX_INCREMENT_TICKS, TICK_RAD, CommandSequence, ticks_to_rad
from armpath.errors import InvalidInputError, PlanningError
from armpath.geometry.curves import Curve
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import displacement_bounds, position_jacobian, tool_position
from armpath.model.serial_arm import SerialArm
from armpath.planning.curve_reach import (
    CurveArc,
    CurveFamily,
    CurveReachability,
    curve_reachability,
)
from armpath.planning.motion import (
    MotionOptions,
    MotionPlan,
    PlanMetrics,
    active_joints,
    plan_metrics,
    plan_motion,
    search_clearance_extra,
)
from armpath.planning.motion_check import MotionClearance, motion_clearance

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Joints that move the fingertip of a seed-type arm (joint 6 turns the tool only).
_TIP_JOINTS = 5
#: Lattice offsets searched around a projected configuration, per tip joint (ticks).
_BOX = 4
#: Instants per command at which a candidate's continuous motion is checked while searching.
_PATH_SAMPLES = 16
#: Extra clearance the links keep while tracing, so the certification of the continuous motion
#: (bound from sampling) succeeds (mm).
_BODY_BUFFER_MM = 0.02
#: Largest joint change between reference layers 5 mm apart that still counts as following the
#: solution family continuously (deg).
_MAX_LAYER_STEP_DEG = 12.0
#: What a lift-off (a new pass) costs in the reference DP, as a joint change (deg).
_LIFT_OFF_DEG = 120.0
#: Least advance of the tip along the curve that one tracing command must make (mm): the
#: progress measure that makes every pass end.
_MIN_ADVANCE_MM = 0.05
#: Candidate advances along the curve per command (mm), tried largest first.
_ADVANCES_MM = (20.0, 17.0, 14.0, 12.0, 10.0, 8.5, 7.0, 6.0, 5.0, 4.0, 3.0, 2.0, 1.5, 1.0, 0.5)


@dataclass(frozen=True)
class TraceOptions:
    """How to trace.

    ``tolerance_mm``: the largest distance of the continuous tip path from the curve during a
    pass. ``layer_step_mm``: spacing of the reference path's layers. ``scan_step_mm``: spacing of
    the reachability scan (see :func:`~armpath.planning.curve_reach.curve_reachability`).
    ``motion``: options of the transits onto the curve and between passes.
    """

    tolerance_mm: float = 0.1
    layer_step_mm: float = 5.0
    scan_step_mm: float = 4.0
    motion: MotionOptions = field(default_factory=MotionOptions)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.tolerance_mm) and 0.005 <= self.tolerance_mm <= 10.0):
            raise InvalidInputError(
                f"tracing tolerance must be between 0.005 and 10 mm, got {self.tolerance_mm}"
            )
        if not self.layer_step_mm > 0:
            raise InvalidInputError("layer step must be > 0 mm")


@dataclass(frozen=True)
class TracePass:
    """One continuous pass: the tip follows the curve from state ``first`` to state ``last``
    (state 0 is the start, state k the state after command k), covering arc lengths
    ``start_mm``..``end_mm``."""

    first: int
    last: int
    start_mm: float
    end_mm: float
    max_deviation_mm: float
    max_deviation_bound_mm: float

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

    @property
    def n_commands(self) -> int:
        return self.sequence.n_commands

    @property
    def covered_mm(self) -> float:
        """Length of the curve covered by the passes (mm; overlaps counted once)."""
        return min(float(sum(p.covered_mm for p in self.passes)), self.curve.length)

    @property
    def max_deviation_mm(self) -> float:
        return max((p.max_deviation_mm for p in self.passes), default=0.0)

    @property
    def max_deviation_bound_mm(self) -> float:
        return max((p.max_deviation_bound_mm for p in self.passes), default=0.0)


def _joint_change(q_deg: FloatArray, here_deg: FloatArray, wrap: NDArray[np.bool_]) -> FloatArray:
    """Largest joint change (deg) from ``here_deg`` to each row of ``q_deg`` (unlimited joints
    by the shorter way round)."""
    d = q_deg - here_deg
    d = np.where(wrap, (d + 180.0) % 360.0 - 180.0, d)
    return np.asarray(np.abs(d).max(axis=-1), dtype=np.float64)


def _same_links(q: FloatArray, half_turn: float) -> FloatArray:
    """Configurations of a seed-type arm ``(..., >= 5)`` and the others with the same links,
    stacked ``(4, ..., n)``: itself, its wrist flip (joint 4 + half a turn, joint 5 negated), its
    arm-side flip (joint 1 + half a turn, joints 2 and 3 negated, joint 4 - half a turn) and
    both. ``half_turn`` is 180 for degrees, pi for radians."""
    wrist = q.copy()
    wrist[..., 3] += half_turn
    wrist[..., 4] *= -1.0
    side = q.copy()
    side[..., 0] += half_turn
    side[..., 1:3] *= -1.0
    side[..., 3] -= half_turn
    both = side.copy()
    both[..., 3] += half_turn
    both[..., 4] *= -1.0
    return np.stack([q, wrist, side, both])


def _flips(q_deg: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Configurations of a seed-type arm (joints 1-5, deg) and their wrist flips (joint 4 in
    ``[-180, 180)``)."""
    other = _same_links(q_deg, 180.0)[1]
    other[..., 3] = (other[..., 3] + 180.0) % 360.0 - 180.0
    return q_deg, other


@numba.njit(cache=True)
def _dp_layer(
    prev_q: FloatArray,
    prev_cost: FloatArray,
    q: FloatArray,
    bonus: FloatArray,
    wrap: NDArray[np.bool_],
    max_step: float,
    lift_cost: float,
) -> tuple[FloatArray, NDArray[np.int64], NDArray[np.bool_]]:  # pragma: no cover - compiled
    """One DP layer: for each node of ``q`` (deg) the best predecessor in ``prev_q``, either
    traced (largest joint change <= ``max_step``, costing that change) or after a lift-off
    (costing ``lift_cost`` plus half the change: a new pass)."""
    n, m, j = prev_q.shape[0], q.shape[0], q.shape[1]
    cost = np.full(m, np.inf)
    arg = np.full(m, -1, dtype=np.int64)
    lifted = np.zeros(m, dtype=np.bool_)
    for b in range(m):
        for a in range(n):
            if not np.isfinite(prev_cost[a]):
                continue
            worst = 0.0
            for k in range(j):
                d = q[b, k] - prev_q[a, k]
                if wrap[k]:
                    d = (d + 180.0) % 360.0 - 180.0
                d = abs(d)
                if d > worst:
                    worst = d
            if worst <= max_step:
                c = prev_cost[a] + worst - bonus[b]
                if c < cost[b]:
                    cost[b] = c
                    arg[b] = a
                    lifted[b] = False
            c = prev_cost[a] + lift_cost + 0.5 * worst - bonus[b]
            if c < cost[b]:
                cost[b] = c
                arg[b] = a
                lifted[b] = True
    return cost, arg, lifted


@dataclass(frozen=True)
class _Piece:
    """A piece of a reachable arc traced in one pass, with its reference path (layers, rad)."""

    arc: CurveArc
    layers: FloatArray
    ref: FloatArray


def _reference_pieces(
    fam: CurveFamily, arc: CurveArc, step: float, q_from: FloatArray
) -> list[_Piece]:
    """Reference paths through the solution family along ``arc``, as few pieces (passes) as
    possible.

    Dynamic programming over layers of the family every ``step`` mm: nodes keep a slack, a traced
    transition costs the largest joint change (at most :data:`_MAX_LAYER_STEP_DEG`: the family
    must be followed continuously), a lift-off costs :data:`_LIFT_OFF_DEG` more (a new pass). The
    first layer's cost is the largest joint change from ``q_from``. The wrist flip (joint 4 + 180
    deg, joint 5 negated) moves no link, so it is chosen per piece afterwards.
    """
    a, b = arc.start_mm, arc.end_mm
    inset = min(1.0, 0.1 * (b - a))
    n = max(int(np.ceil((b - a - 2 * inset) / step)), 1)
    nodes: list[tuple[float, FloatArray, FloatArray]] = []
    # the same tool directions on every layer; a curve in free space (every direction allowed,
    # not half of them) takes every third, which keeps the DP's work alike
    dirs = fam.coarse_dirs if fam.surface is not None else fam.coarse_dirs[::3]
    for s in np.linspace(a + inset, b - inset, n + 1):
        check_time("choosing the reference path along the curve")
        q = fam.configs(float(s), dirs)
        if q.shape[0] == 0:
            continue
        sc = fam.score(q)
        best = float(np.max(sc))
        if best < 0:
            continue
        keep = sc >= min(0.3, 0.5 * best)
        nodes.append((float(s), np.degrees(q[keep, :_TIP_JOINTS]), sc[keep]))
    if not nodes:
        raise PlanningError(f"no clear configuration found on the arc {a:.3f}..{b:.3f} mm")
    wrap = fam.unlimited[:_TIP_JOINTS]
    here = np.degrees(q_from[:_TIP_JOINTS])
    cost = np.min([_joint_change(q, here, wrap) for q in _flips(nodes[0][1])], axis=0)
    back = []
    for k in range(1, len(nodes)):
        gap = nodes[k][0] - nodes[k - 1][0]
        bonus = 0.3 * np.minimum(nodes[k][2], 3.0)
        max_step = _MAX_LAYER_STEP_DEG * max(gap / 5.0, 1.0)
        cost, arg, lifted = _dp_layer(
            nodes[k - 1][1], cost, nodes[k][1], bonus, wrap, max_step, _LIFT_OFF_DEG
        )
        back.append((arg, lifted))
    j = int(np.argmin(cost))
    path, lifts = [j], []
    for k in range(len(back) - 1, -1, -1):
        arg, lifted = back[k]
        if lifted[j]:
            lifts.append(k + 1)  # a new pass starts at layer k + 1
        j = int(arg[j])
        path.append(j)
    path.reverse()
    ref = np.array([nodes[k][1][path[k]] for k in range(len(nodes))])
    s_nodes = np.array([x[0] for x in nodes])
    cuts = [0, *sorted(lifts), len(nodes)]
    pieces = []
    prev = here
    for i in range(len(cuts) - 1):
        lo, hi = cuts[i], cuts[i + 1]
        part = ref[lo:hi]
        flipped = _flips(part)[1]
        if _joint_change(flipped[:1], prev, wrap)[0] < _joint_change(part[:1], prev, wrap)[0]:
            part = flipped
        prev = part[-1]
        rad = np.radians(part)
        rad[:, wrap] = np.unwrap(rad[:, wrap], axis=0)
        full = np.concatenate([rad, np.zeros((rad.shape[0], 1))], axis=1)
        start = a if i == 0 else float(s_nodes[lo - 1])
        end = b if i == len(cuts) - 2 else float(s_nodes[hi - 1])
        layers = s_nodes[lo:hi]
        if layers.size == 1:  # a one-layer piece: a constant reference
            layers = np.array([layers[0], layers[0] + 1e-9])
            full = np.vstack([full, full])
        pieces.append(_Piece(CurveArc(start, end), layers, full))
    return pieces


class _Tracer:
    """Greedy lattice tracing of one arc along a reference path through the family."""

    def __init__(self, fam: CurveFamily, piece: _Piece, tolerance: float) -> None:
        self.fam = fam
        self.arm = fam.arm
        self.world = fam.world
        self.arc = piece.arc
        self.tol = tolerance
        self.offset = tolerance / 2 if fam.surface is not None else 0.0
        self.wrap = fam.unlimited
        pairs = self.world.pairs(self.arm)
        self.extra = np.array([0.0 if p.is_tip else _BODY_BUFFER_MM for p in pairs])
        self.layers, self.ref = piece.layers, piece.ref
        box = np.arange(-_BOX, _BOX + 1)
        self.offsets = np.stack(np.meshgrid(*[box] * _TIP_JOINTS, indexing="ij"), -1).reshape(
            -1, _TIP_JOINTS
        )
        self.offsets_f = self.offsets.astype(np.float64)

    def q_ref(self, s: float | FloatArray) -> FloatArray:
        s_arr = np.asarray(s, dtype=np.float64)
        return np.stack(
            [np.interp(s_arr, self.layers, self.ref[:, j]) for j in range(self.ref.shape[1])],
            axis=-1,
        )

    def align(self, q_start: FloatArray) -> None:
        """Shift unlimited joints of the reference by whole turns to start near ``q_start``."""
        first = self.q_ref(self.layers[0])
        turns = np.round((q_start - first) / (2 * np.pi)) * self.wrap
        self.ref = self.ref + turns * 2 * np.pi

    def matched(self, q: FloatArray, like: FloatArray) -> FloatArray:
        """The representation of each configuration's links (``q`` ``(6,)`` or ``(M, 6)``)
        nearest ``like`` among :func:`_same_links`, unlimited joints turned by whole turns;
        representations outside the joint limits are not used."""
        q2 = np.atleast_2d(q)
        reps = _same_links(q2, np.pi)  # (4, M, 6)
        reps = reps + np.round((like - reps) / (2 * np.pi)) * 2 * np.pi * self.wrap
        gap = np.abs(reps - like).max(axis=-1)
        gap = np.where(self.arm.within_limits(reps), gap, np.inf)
        gap[0] = np.where(np.isfinite(gap).any(axis=0), gap[0], 0.0)  # keep q if none fits
        pick = np.argmin(gap, axis=0)
        out = reps[pick, np.arange(q2.shape[0])]
        return np.asarray(out if q.ndim == 2 else out[0], dtype=np.float64)

    # -- curve geometry -------------------------------------------------------------------------
    def target(self, s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Target tip point at ``s`` and two unit vectors spanning the curve's normal plane."""
        c, t, n = self.fam.frame(s)
        if not np.any(n):
            helper = np.array([0.0, 0.0, 1.0]) if abs(t[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            n = helper - (helper @ t) * t
            n /= np.linalg.norm(n)
        return c + self.offset * n if self.fam.surface is not None else c, n, np.cross(t, n)

    def unwrap_s(self, s: FloatArray, near: float) -> FloatArray:
        if not self.fam.curve.closed:
            return s
        L = self.fam.curve.length
        return np.asarray(s + L * np.round((near - s) / L))

    def tip_checks(self, P: FloatArray, near: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Distance to the curve, arc length of the closest point (unwrapped near ``near``) and
        signed distance to the surface (inf without one) of tip points ``(..., 3)``."""
        d, s = self.fam.curve.closest(P)
        if self.fam.surface is not None:
            sd = self.fam.surface.signed_distance(P)
        else:
            sd = np.full(d.shape, np.inf)
        return d, self.unwrap_s(s, near), sd

    def in_band(self, d: FloatArray, sd: FloatArray, off_surface: float) -> NDArray[np.bool_]:
        """Tip points within 0.9 of the tolerance from the curve and, on a surface, at least
        ``off_surface`` times the tolerance outside it (``d``, ``sd`` from :meth:`tip_checks`)."""
        return np.asarray((d <= 0.9 * self.tol) & (sd >= off_surface * self.tol), dtype=bool)

    # -- lattice ---------------------------------------------------------------------------
    def project(self, q: FloatArray, E: FloatArray) -> FloatArray:
        """Nearest family member to ``q`` (minimum-norm Newton steps) with the tip at ``E``."""
        q = q.copy()
        for _ in range(5):
            e = E - tool_position(self.arm, q)
            if np.linalg.norm(e) < 1e-9:
                break
            J = position_jacobian(self.arm, q)[:, :_TIP_JOINTS]
            q[:_TIP_JOINTS] += np.linalg.pinv(J) @ e
        return q

    def lattice_near(self, base: FloatArray, n: FloatArray, b: FloatArray, q6: int) -> IntArray:
        """Lattice states around ``base`` (rad) whose tip, linearized, is within half the
        tolerance of the base's tip in the normal plane."""
        J = position_jacobian(self.arm, base)[:, :_TIP_JOINTS]
        A_t = (np.stack([n, b]) @ J).T * TICK_RAD  # mm per tick
        exact = base[:_TIP_JOINTS] / TICK_RAD
        rounded = np.round(exact).astype(np.int64)
        lin = self.offsets_f @ A_t + (rounded - exact) @ A_t
        keep = np.einsum("ij,ij->i", lin, lin) <= (self.tol / 2) ** 2
        cand = rounded + self.offsets[keep]
        return np.concatenate([cand, np.full((cand.shape[0], 1), q6)], axis=1)

    def valid_ends(
        self, qk: IntArray, sk: float, cand: IntArray, goal: float
    ) -> tuple[IntArray, FloatArray]:
        """Candidates whose command from ``qk`` keeps the tip in the band and the arm clear while
        it moves toward arc length ``goal``; returned with the arc length their end state
        reaches."""
        sign = 1.0 if goal >= sk else -1.0
        if cand.shape[0] == 0:
            return cand, np.zeros(0)
        cand = cand[np.abs(cand - qk).max(axis=1) <= MAX_INCREMENT_TICKS]
        cand = cand[self.arm.within_limits(ticks_to_rad(cand))]
        if cand.shape[0] == 0:
            return cand, np.zeros(0)
        d, s, sd = self.tip_checks(tool_position(self.arm, ticks_to_rad(cand)), sk)
        ok = self.in_band(d, sd, 0.1) & (sign * (s - sk) > _MIN_ADVANCE_MM)
        ok &= sign * (s - goal) <= self.tol
        cand, s = cand[ok], s[ok]
        if cand.shape[0] == 0:
            return cand, s
        t = np.linspace(0.0, 1.0, _PATH_SAMPLES + 1)[1:-1]
        Q = qk[None, None, :] + t[None, :, None] * (cand - qk)[:, None, :]
        d2, _, sd2 = self.tip_checks(tool_position(self.arm, ticks_to_rad(Q)), sk)
        ok = np.all(self.in_band(d2, sd2, 0.05), axis=1)
        cand, s, Q = cand[ok], s[ok], Q[ok]
        if cand.shape[0] == 0:
            return cand, s
        checked = np.concatenate([Q[:, 1::2], cand[:, None, :]], axis=1)
        clear = self.world.satisfied(self.arm, ticks_to_rad(checked), self.extra).all(axis=1)
        return cand[clear], s[clear]

    def step(self, qk: IntArray, sk: float, goal: float) -> tuple[IntArray, float] | None:
        """The command from ``qk`` that carries the tip farthest along the curve toward arc
        length ``goal``."""
        qk_rad = ticks_to_rad(qk)
        sign = 1.0 if goal >= sk else -1.0
        last = None
        for adv in _ADVANCES_MM:
            s1 = sk + sign * min(adv, abs(goal - sk))
            if abs(s1 - sk) <= _MIN_ADVANCE_MM or s1 == last:
                continue
            last = s1
            drift = self.q_ref(s1) - self.q_ref(sk)
            pull = np.clip(0.3 * (self.q_ref(sk) - qk_rad), -np.radians(0.5), np.radians(0.5))
            cand, s = self._commands_toward(qk, sk, s1, goal, [drift + pull, drift])
            if cand.shape[0]:
                ref_gap = np.degrees(np.abs(ticks_to_rad(cand) - self.q_ref(s))).max(axis=1)
                k = int(np.argmax(sign * s - 0.05 * ref_gap))
                return cand[k], float(s[k])
        if abs(goal - sk) <= 15.0:
            return self._toward_best(qk, sk, goal)
        return None

    def _commands_toward(
        self, qk: IntArray, sk: float, s1: float, goal: float, moves: list[FloatArray]
    ) -> tuple[IntArray, FloatArray]:
        """Valid next states (see :meth:`valid_ends`) near the tip target at ``s1``: each joint
        move (rad) from ``qk`` is projected onto the target and the lattice searched around it
        (moves that end up more than 2.3 deg from ``qk`` are dropped)."""
        qk_rad = ticks_to_rad(qk)
        E, n, b = self.target(s1)
        found = []
        for move in moves:
            base = self.project(qk_rad + move, E)
            if np.degrees(np.abs(base - qk_rad)).max() <= 2.3:
                found.append(self.lattice_near(base, n, b, int(qk[-1])))
        if not found:
            return np.zeros((0, qk.size), dtype=np.int64), np.zeros(0)
        return self.valid_ends(qk, sk, np.unique(np.concatenate(found), axis=0), goal)

    def _toward_best(self, qk: IntArray, sk: float, goal: float) -> tuple[IntArray, float] | None:
        """Near the end of an arc (a tight spot): small advances, the joints turned toward the
        family member with the most slack there rather than along the reference."""
        qk_rad = ticks_to_rad(qk)
        sign = 1.0 if goal >= sk else -1.0
        for adv in (3.0, 1.5, 0.8, 0.4, 0.2, 0.1):
            s1 = sk + sign * min(adv, abs(goal - sk))
            v = self.fam.best(s1, fine=True)
            if not v.reachable:
                continue
            turn = self.matched(v.q, qk_rad) - qk_rad
            moves = [np.clip(turn, -np.radians(t), np.radians(t)) for t in (1.9, 1.0, 0.5, 0.25)]
            cand, s = self._commands_toward(qk, sk, s1, goal, moves)
            if cand.shape[0]:
                # the most slack first (a tight spot), then the farthest
                score = self.fam.score(ticks_to_rad(cand))
                k = int(np.lexsort((-sign * s, -np.round(score, 2)))[0])
                return cand[k], float(s[k])
        return None

    def start_state(
        self, s_from: float, body_buffer_mm: float = _BODY_BUFFER_MM
    ) -> tuple[IntArray, float]:
        """A lattice state with the tip in the band as close after ``s_from`` as found, whose
        links keep ``body_buffer_mm`` beyond the clearance rule."""
        extra = np.where(self.extra > 0, body_buffer_mm, 0.0)
        for gap in (0.02, 0.05, 0.1, 0.2, 0.4, 0.8, 1.6, 3.2, 6.4):
            s0 = s_from + gap
            E, n, b = self.target(s0)
            ref = self.q_ref(s0)
            bases = [ref]
            q = self.fam.configs(s0, self.fam.fine_dirs)
            if q.shape[0]:
                q = self.matched(q, ref)
                turn = np.degrees(np.abs(q - ref).max(axis=1))
                score = np.where(turn <= 30.0, self.fam.score(q), -np.inf)
                roomy = score >= body_buffer_mm
                pick = (
                    np.argmin(np.where(roomy, turn, np.inf)) if np.any(roomy) else np.argmax(score)
                )
                if np.isfinite(score[pick]):
                    bases.insert(0, q[pick])
            for base in bases:
                cand = self.lattice_near(self.project(base, E), n, b, 0)
                cand = cand[self.arm.within_limits(ticks_to_rad(cand))]
                if cand.shape[0] == 0:
                    continue
                d, s, sd = self.tip_checks(tool_position(self.arm, ticks_to_rad(cand)), s0)
                ok = self.in_band(d, sd, 0.1) & (s >= self.arc.start_mm - self.tol)
                ok &= self.world.satisfied(self.arm, ticks_to_rad(cand), extra)
                if np.any(ok):
                    k = int(np.argmin(np.where(ok, s, np.inf)))
                    return cand[k], float(s[k])
        raise PlanningError(
            f"no clear lattice state with the tip within {self.tol:g} mm of the curve near "
            f"{s_from:.1f} mm"
        )

    def run(self, q_start: IntArray, s_start: float, goal: float) -> tuple[list[IntArray], float]:
        """Trace from ``q_start`` toward arc length ``goal`` (as far as it goes).

        Terminates by design: the direction is fixed at the start, every accepted command
        advances the tip by more than :data:`_MIN_ADVANCE_MM` in that direction (see
        :meth:`valid_ends`), and the pass ends once the tip is within that distance of the goal
        or past it. So the distance left decreases strictly and the number of commands is at
        most ``(|goal - s_start| + tolerance) / _MIN_ADVANCE_MM``.
        """
        direction = 1.0 if goal >= s_start else -1.0
        states, sk, qk = [q_start], s_start, q_start
        budget = int(np.ceil((abs(goal - s_start) + self.tol) / _MIN_ADVANCE_MM)) + 1
        for _ in range(budget):
            if direction * (goal - sk) <= _MIN_ADVANCE_MM:
                break
            check_time(f"tracing {self.arc.start_mm:.1f}..{self.arc.end_mm:.1f} mm of the curve")
            nxt = self.step(qk, sk, goal)
            if nxt is None:
                break
            q_next, s_next = nxt
            if direction * (s_next - sk) <= _MIN_ADVANCE_MM:  # cannot happen: valid_ends
                raise AssertionError("tracer made no progress: step rule broken")
            qk, sk = q_next, s_next
            states.append(qk)
        return states, sk


def certified_deviation(
    arm: SerialArm, curve: Curve, states: IntArray, s_near: float, precision: float = 0.002
) -> tuple[float, float, FloatArray, FloatArray]:
    """Largest distance (mm) of the continuous tip path through lattice ``states`` (ticks) from
    ``curve``, a proven upper bound (branch and bound: the tip moves at most ``rate * dt`` between
    instants, distance is 1-Lipschitz), and a profile ``(s, deviation)`` sampled 32 times per
    command."""
    states = np.asarray(states, dtype=np.int64)
    if states.shape[0] < 2:
        P = tool_position(arm, ticks_to_rad(states))
        d, s = curve.closest(P)
        return float(d.max()), float(d.max()), s, d
    steps = np.diff(states, axis=0).astype(np.float64)
    rate = np.abs(steps) @ (displacement_bounds(arm) * TICK_RAD)  # mm per unit of u
    n = steps.shape[0]

    def tip(u: FloatArray) -> FloatArray:
        k = np.clip(np.floor(u).astype(np.int64), 0, n - 1)
        return tool_position(arm, ticks_to_rad(states[k] + (u - k)[:, None] * steps[k]))

    u = np.linspace(0.0, n, 32 * n + 1)
    d, s = curve.closest(tip(u))
    profile_s = s.copy()
    if curve.closed:
        L = curve.length
        profile_s = np.asarray(np.unwrap(s / L * 2 * np.pi) * L / (2 * np.pi))
        profile_s += L * np.round((s_near - profile_s[0]) / L)
    profile_d = d.copy()
    for _ in range(40):
        k = np.minimum(np.floor(u[:-1]).astype(np.int64), n - 1)
        h = np.diff(u)
        bound = 0.5 * (d[:-1] + d[1:] + rate[k] * h)
        best = float(d.max())
        need = bound > best + precision
        if not np.any(need):
            break
        mid = 0.5 * (u[:-1][need] + u[1:][need])
        d_mid, _ = curve.closest(tip(mid))
        order = np.argsort(np.concatenate([u, mid]), kind="stable")
        u = np.concatenate([u, mid])[order]
        d = np.concatenate([d, d_mid])[order]
    k = np.minimum(np.floor(u[:-1]).astype(np.int64), n - 1)
    bound = float(np.max(0.5 * (d[:-1] + d[1:] + rate[k] * np.diff(u))))
    return float(d.max()), max(bound, float(d.max())), profile_s, profile_d


def plan_trace(
    arm: SerialArm,
    world: CollisionWorld,
    start_ticks: IntArray,
    curve: Curve,
    options: TraceOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
) -> TraceResult:
    """Trace every reachable part of ``curve`` from ``start_ticks``, fewest passes first."""
    opts = options or TraceOptions()
    say = on_progress or (lambda _m: None)
    reach = curve_reachability(arm, world, curve, scan_step_mm=opts.scan_step_mm, on_progress=say)
    if not reach.reachable:
        raise PlanningError(
            f"no part of curve {curve.name!r} is reachable: "
            + "; ".join(a.reason for a in reach.unreachable)
        )
    fam = reach.family
    start = np.asarray(start_ticks, dtype=np.int64)
    states: list[IntArray] = [start]
    passes: list[TracePass] = []
    transits: list[Transit] = []
    prof_s: list[FloatArray] = []
    prof_d: list[FloatArray] = []
    arcs = list(reach.reachable)
    overlap = 0.0
    if curve.closed and len(arcs) == 1 and arcs[0].length_mm >= curve.length - 1e-9:
        # all around: run on a little past the start so the covered ends meet
        arcs = [CurveArc(arcs[0].start_mm, arcs[0].start_mm + curve.length)]
        overlap = 2.0 * opts.tolerance_mm
    queue: list[tuple[CurveArc, float]] = [(arc, 0.0) for arc in arcs]
    queue[-1] = (queue[-1][0], overlap)
    while queue:
        check_time("tracing the curve")
        arc, run_on = queue.pop(0)
        pieces = _reference_pieces(fam, arc, opts.layer_step_mm, ticks_to_rad(states[-1]))
        for k, piece in enumerate(pieces):
            last_piece = k == len(pieces) - 1
            say(
                f"tracing pass {len(passes) + 1}: {piece.arc.start_mm:.1f}.."
                f"{piece.arc.end_mm:.1f} mm of the curve"
            )
            tracer = _Tracer(fam, piece, opts.tolerance_mm)
            tracer.align(ticks_to_rad(states[-1]))
            here = len(states) - 1
            if passes:  # lift off first, to where the transit's search has room
                states.extend(list(_lift_off(arm, world, states[-1], opts).states()[1:]))
            motion, q_entry, s_entry = _enter(tracer, reach, states[-1], opts, say)
            states.extend(list(motion.sequence.states()[1:]))
            transits.append(Transit(here, len(states) - 1, motion.method))
            first = len(states) - 1
            pass_states = [q_entry]
            if s_entry > piece.arc.start_mm + 0.05:  # back to the start of the piece first
                pass_states, s_entry = tracer.run(q_entry, s_entry, piece.arc.start_mm)
            goal = piece.arc.end_mm + (run_on if last_piece else 0.0)
            ahead, s_reached = tracer.run(pass_states[-1], s_entry, goal)
            pass_states += ahead[1:]
            states.extend(pass_states[1:])
            dev, dev_bound, ps, pd = certified_deviation(
                arm, curve, np.array(pass_states), piece.arc.start_mm
            )
            prof_s.append(ps)
            prof_d.append(pd)
            passes.append(
                TracePass(first, len(states) - 1, float(ps.min()), float(ps.max()), dev, dev_bound)
            )
            if s_reached < piece.arc.end_mm - 0.5:
                # stuck: the rest of the arc gets new passes. The rest starts at least 1 mm past
                # this piece's start (skipping 2 mm if this pass made no progress), so every
                # arc put back is shorter by 1 mm or more and the loop ends.
                resume = (
                    s_reached
                    if s_reached > piece.arc.start_mm + 1.0
                    else max(s_reached, piece.arc.start_mm) + 2.0
                )
                if resume < arc.end_mm - 0.5:
                    queue.insert(0, (CurveArc(resume, arc.end_mm), run_on))
                break
    all_states = np.array(states)
    sequence = CommandSequence(all_states[0], np.diff(all_states, axis=0))
    say("certifying the clearance of the whole motion")
    clearance = motion_clearance(arm, world, sequence, max_evaluations=400_000)
    return TraceResult(
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
    )


def _lift_off(
    arm: SerialArm, world: CollisionWorld, q_ticks: IntArray, opts: TraceOptions
) -> CommandSequence:
    """Commands that take the arm from the end of a pass (tool on the surface, links possibly in
    a tight spot) to a state with the room the motion planner's search needs.

    Greedy escape: from each state, random full-size commands (seeded) are scored by their end
    state's smallest slack against the search's clearance needs, and the best one whose continuous
    motion is certified clear is taken; at most 12 commands.
    """
    need = world.required(arm) + search_clearance_extra(
        arm, world, opts.motion.buffer_mm, opts.motion.sample_spacing_mm
    )
    active = active_joints(arm)
    rng = np.random.default_rng([opts.motion.seed, 7])
    states = [np.asarray(q_ticks, dtype=np.int64)]

    def slack(q: IntArray) -> FloatArray:
        values, _ = world.pair_clearances(arm, ticks_to_rad(q))
        return np.asarray((values - need).min(axis=-1), dtype=np.float64)

    for _ in range(12):
        check_time("lifting off the curve")
        here = states[-1]
        if float(slack(here[None])[0]) >= 0.0:
            break
        size = rng.uniform(1.0, MAX_INCREMENT_TICKS, (4000, 1))
        steps = np.round(rng.uniform(-1.0, 1.0, (4000, here.size)) * size).astype(np.int64)
        cand = here + steps * active
        cand = cand[arm.within_limits(ticks_to_rad(cand))]
        if cand.shape[0] == 0:
            break
        sc = slack(cand)
        for k in np.argsort(-sc)[:16]:
            seq = CommandSequence.straight(here, cand[k])
            if motion_clearance(arm, world, seq).certified_ok:
                states.append(cand[k])
                break
        else:
            break
    return CommandSequence(
        states[0], np.diff(np.array(states, dtype=np.int64), axis=0).astype(np.int64)
    )


def _enter(
    tracer: _Tracer,
    reach: CurveReachability,
    q_from: IntArray,
    opts: TraceOptions,
    say: Callable[[str], None],
) -> tuple[MotionPlan, IntArray, float]:
    """Move from ``q_from`` onto the curve near the start of the tracer's arc.

    The start of an arc is usually a tight spot (that is why the arc ends there): it is entered
    only by a straight motion. Otherwise the entry is one of the first scan points along the arc
    whose best configuration keeps the transit search's buffer plus half its sample spacing plus
    0.5 mm of slack; the pass then runs back to the start of the arc before tracing forward.
    """
    arc = tracer.arc
    L = reach.curve.length
    scan_s = reach.scan_s_mm
    if reach.curve.closed:
        scan_s = np.concatenate([scan_s, scan_s + L, scan_s + 2 * L])
        scores = np.tile(reach.scan_score, 3)
    else:
        scores = reach.scan_score
    inside = (scan_s >= arc.start_mm) & (scan_s <= arc.end_mm)
    need = opts.motion.buffer_mm + opts.motion.sample_spacing_mm / 2 + 0.5
    roomy = scan_s[inside & (scores >= need)]
    candidates = [arc.start_mm, *roomy[:3].tolist()]
    failures = []
    for i, s_try in enumerate(candidates):
        try:
            q, s = tracer.start_state(s_try, need if i else _BODY_BUFFER_MM)
        except PlanningError as exc:
            failures.append(f"{s_try:.1f} mm: {exc}")
            continue
        say(f"moving onto the curve at {float(reach.curve.wrap(s)):.1f} mm")
        if i == 0:  # the tight start of the arc: only a straight motion can end there
            seq = CommandSequence.straight(q_from, q)
            mc = motion_clearance(tracer.arm, tracer.world, seq)
            if mc.certified_ok:
                m = plan_metrics(tracer.arm, seq)
                return MotionPlan(seq, 0, mc, m, seq.n_commands, "direct", 0), q, s
            failures.append(f"{s:.1f} mm: the straight motion there is blocked")
            continue
        # one search per entry point but the last: another entry often works where one fails
        motion_opts = opts.motion if i == len(candidates) - 1 else replace(opts.motion, attempts=1)
        try:
            return plan_motion(tracer.arm, tracer.world, q_from, q[None, :], motion_opts), q, s
        except PlanningError as exc:
            failures.append(f"{s:.1f} mm: {exc}")
    raise PlanningError("could not move onto the curve: " + "; ".join(failures))
