"""The reference path of a trace: dynamic programming through the solution family along an arc.

The tool point has a family of solutions at every curve point. A reference path through the
family is chosen by dynamic programming over layers of the family every few mm: nodes keep a
clearance and joint-limit slack, transitions cost the largest joint change of the joints that
move the tool point (what commands cost) less a small reward for slack; where the family cannot
be followed continuously the path pays for a lift-off, which splits the arc into *pieces*
(passes), as few as possible. Configurations with the same links (the seed arm's wrist flip) are
chosen per piece to suit the state the arm comes from.

The DP's layers hold a coarse sample of the family, so its path zigzags from sample to sample
(on the seed crack its joint changes add up to 112 commands' worth where the family's shortest
path is about 64). Each piece's path is then *straightened* within the family: every layer in
turn moves to the member nearest the midpoint of its neighbours (the tip kept on its curve point),
where that keeps its slack, its joint limits and the tool-axis rule, first on every 2**k-th
layer, then on finer levels (:func:`straightened`; 72.5 commands' worth on the seed crack).
That pulls it straight in the squared joint changes; commands cost the largest one, so the path
is then *shortened* in that measure (plus a charge for bends in the joints) by sequential
linear programming over the family linearised at every layer (:func:`shortened`; 65.3 on the
seed crack, which is then traced along in 75 commands instead of 82).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import PlanningError
from armpath.geometry.world import into_windows
from armpath.jit import njit
from armpath.kinematics import position_jacobian, tool_position
from armpath.planning.trace.family import CurveFamily
from armpath.planning.trace.reachability import CurveArc

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Largest joint change between reference layers 5 mm apart that still counts as following the
#: solution family continuously (commands: 12 deg where a command moves a joint 2 deg).
_MAX_LAYER_STEP = 6.0
#: What a lift-off (a new pass) costs in the reference DP, as a joint change (commands).
_LIFT_OFF = 60.0
#: What a lift-off costs besides, per command of the joints' mean change: among members the
#: largest change reaches alike (joint 1 turning 146 deg to the other side of a KUKA-like
#: arm), the one whose other joints move least (its wrist unflipped: the flipped one could
#: not be entered where its pass began, and 1.4 mm of the seam were left untraced).
_LIFT_SPREAD = 0.05
#: Slack (mm or deg) beyond which a reference node earns no more reward, and the reward per
#: unit of slack (commands).
_SLACK_COUNTED = 3.0
_SLACK_REWARD = 0.15
#: Rounds of :func:`straightened` on each level (each round moves every layer of the level
#: once, odd then even ones). Coarse to fine, the seed crack's reference goes from 112 to 72.5
#: commands' worth (20 rounds are as short; one level of 150 rounds on every layer: 74.6), the
#: UR5 cell's seam from 100.6 to 59.7 (one level of 150: 60.9).
_STRAIGHTEN_ROUNDS = 80
#: Fewest layers of the coarsest level of :func:`straightened`.
_COARSEST_LAYERS = 4
#: A straightened layer keeps at least this much slack (mm or deg), or its own if less (0.1
#: traced the UR5 cell's seam in 182 commands, 0.3 in 186, 1.0 in 191; the seed crack 165-167).
_STRAIGHTEN_SLACK = 0.1
#: Rounds of :func:`shortened` at most, and its trust region: how far (command units, in the
#: family's linearised coordinates) a layer may move in a round, at first, at most, and when it
#: has shrunk so far that the rounds stop.
_SHORTEN_ROUNDS = 30
_SHORTEN_REGION = 2.0
_SHORTEN_REGION_MAX = 20.0
_SHORTEN_REGION_MIN = 1e-3
#: Least gain (commands) the linear program must promise for another round.
_SHORTEN_GAIN = 1e-3
#: Linear programs of more variables than this are solved by HiGHS's interior point method
#: (with crossover), smaller ones by its simplex: on a 7-joint arm's 1.7 m seam (3,400
#: variables, 12,000 rows) 0.5 s rather than 2.7 s, the same optimum; the small ones of 6-joint
#: arms keep the simplex's vertex (where the optimum is not unique, another vertex is another
#: reference path).
_SHORTEN_IPM_VARIABLES = 2000
#: What :func:`shortened` charges per command unit of the path's second differences, beside
#: its largest joint changes.
_BEND_WEIGHT = 1.0
#: Newton steps that bring a moved layer's tip back onto its curve point, and how close (mm).
_PROJECT_STEPS = 6
_ON_POINT_MM = 1e-6
#: How much cheaper (commands of the reference DP's cost) tracing an arc from its
#: end must be to be chosen: the DP sees the approach but not how hard a tight end is to
#: finish in. The seed crack's end is nearer by 7 commands: traced from there 145 commands (70
#: onto the crack, 75 along) against 156 forward (83 + 73).
BACKWARD_MARGIN = 5.0
#: How much less (commands) a piece's reference shortened with its approach charged must cost,
#: its approach included, than the one shortened between fixed ends to be kept
#: (:func:`reference_pieces`). The two costs foretold the traces' commands on the cases
#: measured: a 600 mm line before the bare UR5 132.0 against 122.9 (traced 134 against 122),
#: the UR5 cell's 80 mm circle 83.6 against 82.9 (111 against 108), the seed crack 138.3
#: against 143.5 (139 against 144); the track cell's seam, 303.9 against 303.5, was traced
#: 245 against 302, which this margin leaves as it was.
APPROACH_CHARGE_MARGIN = 0.5
#: Most family members kept on one layer (evenly over the tool directions).
MAX_LAYER_NODES = 1500
#: A layer with fewer members near its best slack than this at the DP's tool directions is
#: sampled again at more (every coarse direction, then the fine ones; the try with the most
#: kept): a KUKA-like arm tracing a seam 1 mm above a table (its 4 mm tool kept near upright
#: by the clearance rule) found none over 20 mm about a corner at a third of the free curve's
#: directions, and its DP cut the seam there (3 passes; 2 with 16 or 32, 3 with 8; with 32 an
#: iiwa14's free line resampled every layer, its reference 1.8 -> 4.6 s; with 16: 1.7 s).
_FEW_LAYER_NODES = 16


@dataclass(frozen=True)
class CommandUnits:
    """The tip joints of a family in command units: ``step`` what one command moves each (rad,
    or model units for a prismatic joint), ``period`` a whole turn in commands for an unlimited
    revolute joint (0 for the others). The reference DP measures joint changes so, which is
    what commands cost whatever the joint's kind and lattice."""

    step: FloatArray
    period: FloatArray

    @staticmethod
    def of_family(fam: CurveFamily) -> CommandUnits:
        grid, tip = fam.arm.lattice, fam.tip_joints
        step = (np.asarray(grid.tick, dtype=np.float64) * grid.max_ticks)[tip]
        return CommandUnits(step, np.where(fam.turns_freely[tip], 2.0 * np.pi / step, 0.0))

    def units(self, q_tip: FloatArray) -> FloatArray:
        """Tip-joint values (rad, model units) in commands."""
        return np.asarray(q_tip, dtype=np.float64) / self.step

    def flipped(self, fam: CurveFamily, u: FloatArray) -> FloatArray | None:
        """:meth:`CurveFamily.flipped` of tip-joint values in commands."""
        other = fam.flipped(np.degrees(u * self.step))
        return None if other is None else np.radians(other) / self.step


def _joint_change(u: FloatArray, here: FloatArray, period: FloatArray) -> FloatArray:
    """Largest joint change (commands) from ``here`` to each row of ``u`` (both in commands;
    joints with a ``period`` by the shorter way round)."""
    d = u - here
    turn = np.where(period > 0, period, 1.0)
    d = d - np.where(period > 0, turn * np.floor(d / turn + 0.5), 0.0)
    return np.asarray(np.abs(d).max(axis=-1), dtype=np.float64)


#: Joints the DP's predecessor grid is keyed on (those that spread its nodes over most cells).
_GRID_KEYS = 3


@njit(cache=True)
def _cell_index(
    x: float, low: float, width: float, cells: int, period: float
) -> int:  # pragma: no cover - compiled
    """The grid cell of joint value ``x`` (commands) along one key."""
    if period > 0.0:
        x -= period * np.floor(x / period + 0.5)
    return min(max(int(np.floor((x - low) / width)), 0), cells - 1)


@njit(cache=True)
def _dp_layer(
    prev_q: FloatArray,
    prev_cost: FloatArray,
    q: FloatArray,
    bonus: FloatArray,
    period: FloatArray,
    max_step: float,
    lift_cost: float,
) -> tuple[FloatArray, NDArray[np.int64], NDArray[np.bool_]]:  # pragma: no cover - compiled
    """One DP layer: for each node of ``q`` (commands) the best predecessor in ``prev_q``, either
    traced (largest joint change <= ``max_step``, costing that change) or after a lift-off
    (costing ``lift_cost`` plus the change and :data:`_LIFT_SPREAD` of the mean change: a new
    pass, and the move between the passes takes
    at least that many commands; half the change let a 7-axis arm on a slow track leave the
    carriage's schedule for a pass that ran out of reach, then drive the track 285 mm back).

    Traced predecessors are looked for in a grid over the :data:`_GRID_KEYS` joints that spread
    the predecessors over most cells (cells at least ``max_step`` wide, so only a node's cell
    and its neighbours can hold one; joints with a ``period`` wrap round); lift-offs only where the
    cheapest conceivable one could beat the best traced transition, predecessors cheapest
    first, each measured only until it cannot win."""
    m, j = q.shape[0], q.shape[1]
    cost = np.full(m, np.inf)
    arg = np.full(m, -1, dtype=np.int64)
    lifted = np.zeros(m, dtype=np.bool_)
    live = np.flatnonzero(np.isfinite(prev_cost))
    if live.size == 0:
        return cost, arg, lifted
    by_cost = live[np.argsort(prev_cost[live], kind="mergesort")]
    # each joint's grid: lowest value, cell width and count, and how many cells it fills
    low = np.zeros(j)
    width = np.ones(j)
    cells = np.ones(j, dtype=np.int64)
    filled = np.zeros(j, dtype=np.int64)
    for k in range(j):
        if period[k] > 0.0:
            cells[k] = max(int(period[k] / max_step), 1)
            low[k], width[k] = -0.5 * period[k], period[k] / cells[k]
        else:
            low[k] = np.min(prev_q[live, k])
            spread = np.max(prev_q[live, k]) - low[k]
            width[k] = max(max_step, spread / 64.0)
            cells[k] = int(spread / width[k]) + 1
        seen = np.zeros(cells[k], dtype=np.bool_)
        for a in live:
            seen[_cell_index(prev_q[a, k], low[k], width[k], cells[k], period[k])] = True
        filled[k] = np.sum(seen)
    keys = np.argsort(-filled, kind="mergesort")[: min(_GRID_KEYS, j)]
    n_keys = keys.size
    stride = np.ones(n_keys, dtype=np.int64)
    for g in range(n_keys - 2, -1, -1):
        stride[g] = stride[g + 1] * cells[keys[g + 1]]
    n_cells = stride[0] * cells[keys[0]]
    cell_of = np.zeros(live.size, dtype=np.int64)
    for i in range(live.size):
        for g in range(n_keys):
            k = keys[g]
            cell_of[i] += stride[g] * _cell_index(
                prev_q[live[i], k], low[k], width[k], cells[k], period[k]
            )
    order = np.argsort(cell_of, kind="mergesort")
    first = np.searchsorted(cell_of[order], np.arange(n_cells + 1))
    at = np.zeros(n_keys, dtype=np.int64)
    span = np.zeros(n_keys, dtype=np.int64)
    step = np.zeros(n_keys, dtype=np.int64)
    for b in range(m):
        for g in range(n_keys):
            k = keys[g]
            at[g] = _cell_index(q[b, k], low[k], width[k], cells[k], period[k])
            span[g] = min(cells[k], 3)  # the cell and its neighbours (all, when fewer)
        step[:] = 0
        while True:  # every combination of neighbouring cells along the keys
            cell = 0
            inside = True
            for g in range(n_keys):
                k = keys[g]
                c = at[g] + step[g] - 1 if span[g] == 3 else step[g]
                if period[k] > 0.0:
                    c %= cells[k]
                elif c < 0 or c >= cells[k]:
                    inside = False
                cell += stride[g] * c
            if inside:
                for i in range(first[cell], first[cell + 1]):
                    a = live[order[i]]
                    worst = 0.0
                    for k in range(j):
                        d = q[b, k] - prev_q[a, k]
                        if period[k] > 0.0:
                            d -= period[k] * np.floor(d / period[k] + 0.5)
                        d = abs(d)
                        if d > worst:
                            worst = d
                            if worst > max_step:
                                break
                    if worst <= max_step:
                        c = prev_cost[a] + worst - bonus[b]
                        if c < cost[b]:
                            cost[b] = c
                            arg[b] = a
            g = n_keys - 1
            while g >= 0:
                step[g] += 1
                if step[g] < span[g]:
                    break
                step[g] = 0
                g -= 1
            if g < 0:
                break
        for a in by_cost:
            base = prev_cost[a] + lift_cost - bonus[b]
            if base >= cost[b]:
                break  # this lift-off, and every later (costlier) one, cannot win
            worst = 0.0
            spread = 0.0
            for k in range(j):
                d = q[b, k] - prev_q[a, k]
                if period[k] > 0.0:
                    d -= period[k] * np.floor(d / period[k] + 0.5)
                d = abs(d)
                spread += d
                if d > worst:
                    worst = d
                    if base + worst >= cost[b]:
                        break
            c = base + worst + _LIFT_SPREAD * spread / j
            if c < cost[b]:
                cost[b] = c
                arg[b] = a
                lifted[b] = True
    return cost, arg, lifted


@dataclass(frozen=True)
class Piece:
    """A piece of a reachable arc traced in one pass, with its reference path (layers, rad;
    both in increasing arc length), traced from its end toward its start when ``backward``."""

    arc: CurveArc
    layers: FloatArray
    ref: FloatArray
    backward: bool = False
    #: whether ``ref`` was shortened with the approach onto it charged (its first layer moved
    #: nearer where the arm comes from; see :func:`reference_pieces`)
    approach_charged: bool = False

    @property
    def sign(self) -> float:
        """+1 traced toward growing arc length, -1 backward."""
        return -1.0 if self.backward else 1.0

    @property
    def begin_mm(self) -> float:
        """Where the piece is traced from (its start, or its end backward)."""
        return self.arc.end_mm if self.backward else self.arc.start_mm

    @property
    def finish_mm(self) -> float:
        """Where the piece is traced to."""
        return self.arc.start_mm if self.backward else self.arc.end_mm

    def in_order(self, s_mm: FloatArray) -> FloatArray:
        """Arc lengths (ascending) in the order the piece is traced."""
        return s_mm[::-1] if self.backward else s_mm


def straightened(fam: CurveFamily, layers: FloatArray, ref: FloatArray) -> FloatArray:
    """The reference ``ref`` (rad, one row per layer at arc lengths ``layers`` mm) pulled
    straight within the family, its end layers kept.

    Each round moves the odd, then the even interior layers to the midpoint of their neighbours'
    tip joints, brought back into the family by minimum-norm Newton steps (the tip on the layer's
    curve point); a layer moves only where it lands on the point, within the joint limits and
    the tool-axis rule, with at least :data:`_STRAIGHTEN_SLACK` of slack (or its own, if less).
    Coarse to fine: the rounds run first on every ``2**k``-th layer (neighbours
    ``2**k`` layers apart, so a detour as long as the arc straightens in a few rounds), then on
    every ``2**(k-1)``-th, down to every layer. A fixed number of rounds per level
    (:data:`_STRAIGHTEN_ROUNDS`): it ends by design."""
    tip = fam.tip_joints
    ref = np.array(ref, dtype=np.float64)
    if ref.shape[0] < 3:
        return ref
    points = np.array([fam.frame(float(s))[0] for s in layers])
    floor = np.minimum(fam.score(ref, ceiling=_STRAIGHTEN_SLACK), _STRAIGHTEN_SLACK)
    last = ref.shape[0] - 1
    stride = 1
    while 2 * stride * _COARSEST_LAYERS <= last:
        stride *= 2
    while stride >= 1:
        # the layers of this level: every stride-th, and the last
        idx = np.unique(np.r_[np.arange(0, last, stride), last])
        for _ in range(_STRAIGHTEN_ROUNDS):
            check_time("straightening the reference path along the curve")
            for parity in (1, 2):
                pos = np.arange(parity, idx.size - 1, 2)
                if pos.size == 0:
                    continue
                k, before, after = idx[pos], idx[pos - 1], idx[pos + 1]
                w = ((k - before) / (after - before))[:, None]
                q = ref[k].copy()
                q[:, tip] = (1.0 - w) * ref[before][:, tip] + w * ref[after][:, tip]
                q = _onto_points(fam, q, points[k])
                ok = _may_move(fam, q, points[k], floor[k])
                ref[k[ok]] = q[ok]
        stride //= 2
    return ref


def _onto_points(fam: CurveFamily, q: FloatArray, points: FloatArray) -> FloatArray:
    """Configurations ``q`` ``(L, n)`` rad with their tips brought onto ``points`` ``(L, 3)`` by
    :data:`_PROJECT_STEPS` minimum-norm Newton steps of the tip joints."""
    arm, tip = fam.arm, fam.tip_joints
    q = np.array(q, dtype=np.float64, copy=True)
    for _ in range(_PROJECT_STEPS):
        J = position_jacobian(arm, q)[..., tip]
        miss = points - tool_position(arm, q)
        q[:, tip] += np.einsum("mij,mj->mi", np.linalg.pinv(J), miss)
    return q


def _may_move(fam: CurveFamily, q: FloatArray, points: FloatArray, floor: FloatArray) -> BoolArray:
    """Which layers may move to ``q``: the tip on its point, within the joint limits and the
    tool-axis rule, and more slack than ``floor`` (capped at twice :data:`_STRAIGHTEN_SLACK`)."""
    ok: BoolArray = np.linalg.norm(points - tool_position(fam.arm, q), axis=-1) <= _ON_POINT_MM
    ok &= fam.arm.within_limits(q) & fam.axis_ok(q)
    slack = fam.score(q[ok], floor=floor[ok], ceiling=2 * _STRAIGHTEN_SLACK)
    ok[ok] = slack > floor[ok]
    return ok


def _commands_worth(u: FloatArray) -> float:
    """The largest joint changes of a path ``(L, J)`` in command units, layer to layer, summed
    (what the commands along it cost at least), plus :data:`_BEND_WEIGHT` times its second
    differences' size (how far it is from straight in the joints)."""
    worth = float(np.abs(np.diff(u, axis=0)).max(axis=1, initial=0.0).sum())
    return worth + _BEND_WEIGHT * float(np.abs(np.diff(u, 2, axis=0)).sum())


def shortened(
    fam: CurveFamily,
    layers: FloatArray,
    ref: FloatArray,
    comes_from: FloatArray | None = None,
    begins_last: bool = False,
) -> FloatArray:
    """The reference ``ref`` (rad, one row per layer at arc lengths ``layers`` mm, already
    :func:`straightened`) shortened in what commands cost, its end layers kept (but see
    ``comes_from``).

    :func:`straightened` pulls the path straight in the squared joint changes; commands cost the
    *largest* joint change, in which other joints move for free while one moves most. Here the
    path's largest joint changes (command units), plus :data:`_BEND_WEIGHT` times its second
    differences (a path straight in the joints is one a straight command can follow along the
    curve), are minimised by sequential linear programming: each round, every interior layer may
    move within the family linearised at it (the null space of the tip's Jacobian) inside a
    trust region, its joint limits as linear constraints; the linear program's answer is brought
    back onto the curve points (Newton), each layer checked as in :func:`straightened`, and the
    new path kept only if it costs less (the region then grows, else shrinks). At most
    :data:`_SHORTEN_ROUNDS` rounds, fewer once the linear program promises less than
    :data:`_SHORTEN_GAIN`: it ends by design.

    ``comes_from`` (the tip joints where the arm is before the pass, rad): the layer the pass
    begins from (the last with ``begins_last``) may move too, and the largest joint change from
    there onto it is charged as well (the commands of the approach, what the dynamic program's
    first layer costs): where the family is wide, the pass then begins at the member nearest the
    arm rather than at a sampled one. Which of the two paths a pass follows,
    :func:`reference_pieces` decides."""
    from scipy.optimize import linprog  # imported when first needed
    from scipy.sparse import coo_matrix

    arm, tip = fam.arm, fam.tip_joints
    ref = np.array(ref, dtype=np.float64)
    n_layers, m = ref.shape[0], int(np.count_nonzero(tip))
    r = m - 3  # the family's dimension at a point, linearised
    if n_layers < 3 or r <= 0:
        return ref
    units = CommandUnits.of_family(fam)
    step = units.step
    lo, hi = units.units(arm.lower[tip]), units.units(arm.upper[tip])
    points = np.array([fam.frame(float(s))[0] for s in layers])
    floor = np.minimum(fam.score(ref, ceiling=_STRAIGHTEN_SLACK), _STRAIGHTEN_SLACK)
    first = n_layers - 1 if begins_last else 0
    here = None if comes_from is None else units.units(comes_from)

    def worth(u: FloatArray) -> float:
        approach = 0.0 if here is None else _joint_change(u[first], here, units.period)
        return _commands_worth(u) + float(approach)

    cost_now, region = worth(units.units(ref[:, tip])), _SHORTEN_REGION
    n_z, n_seg, n_bend = n_layers * r, n_layers - 1, (n_layers - 2) * m
    # variables: z (the move of each layer in its null space), t (each step's largest joint
    # change), b (each second difference's size per joint), a (the approach's largest joint
    # change, when it is charged)
    c = np.r_[np.zeros(n_z), np.ones(n_seg), np.full(n_bend, _BEND_WEIGHT)]
    moving = np.ones(n_layers, dtype=bool)
    moving[[0, -1]] = False
    if here is not None:
        c = np.r_[c, 1.0]
        moving[first] = True
    fixed = np.repeat(~moving[:, None], r, axis=1)
    for _ in range(_SHORTEN_ROUNDS):
        check_time("shortening the reference path along the curve")
        u = units.units(ref[:, tip])
        J = position_jacobian(arm, ref)[..., tip] * step
        N = np.transpose(np.linalg.svd(J)[2][:, 3:, :], (0, 2, 1))  # (L, m, r)
        start = None
        if here is not None:  # the approach from where the arm is, whole turns the nearer way
            turn = np.where(units.period > 0, units.period, 1.0)
            near = here + np.where(units.period > 0, turn * np.round((u[first] - here) / turn), 0.0)
            start = (first, near)
        A, b = _shorten_constraints(u, N, lo, hi, n_z, n_seg, moving, start)
        bounds = np.column_stack([np.full(c.size, 0.0), np.full(c.size, np.inf)])
        bounds[:n_z] = np.where(fixed, 0.0, region).reshape(-1, 1) * [-1.0, 1.0]
        method = "highs-ipm" if c.size > _SHORTEN_IPM_VARIABLES else "highs"
        res = linprog(c, A_ub=coo_matrix(A, shape=(b.size, c.size)), b_ub=b, bounds=bounds,
                      method=method)  # fmt: skip
        if res.status != 0 or res.fun > cost_now - _SHORTEN_GAIN:
            break  # no answer, or the linearised path cannot get shorter: done
        z = res.x[:n_z].reshape(n_layers, r)
        q = ref.copy()
        q[:, tip] = (u + np.einsum("lmr,lr->lm", N, z)) * step
        q = _onto_points(fam, q, points)
        ok = _may_move(fam, q, points, floor)
        ok &= moving
        trial = np.where(ok[:, None], q, ref)
        cost = worth(units.units(trial[:, tip]))
        if cost < cost_now - 1e-9:
            ref, cost_now, region = trial, cost, min(region * 1.5, _SHORTEN_REGION_MAX)
        else:
            region *= 0.4
            if region < _SHORTEN_REGION_MIN:
                break
    return ref


def _shorten_constraints(
    u: FloatArray,
    N: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    n_z: int,
    n_seg: int,
    moving: BoolArray,
    start: tuple[int, FloatArray] | None = None,
) -> tuple[tuple[FloatArray, tuple[IntArray, IntArray]], FloatArray]:
    """The linear program of one :func:`shortened` round in sparse form ``((values, (rows,
    cols)), b)``: ``A x <= b`` for x = (z, t, b[, a]), the path ``u + N z`` (command units), the
    layers that may move ``moving`` kept within the joint limits; ``start = (layer, here)``:
    ``a`` bounds the largest joint change from ``here`` onto that layer."""
    n_layers, m, r = N.shape
    vals: list[FloatArray] = []
    rows: list[IntArray] = []
    cols: list[IntArray] = []
    rhs: list[FloatArray] = []
    count = 0

    def add(coef: FloatArray, col: IntArray, b: FloatArray) -> None:
        """Rows ``sum coef * x[col] <= b``: ``coef`` and ``col`` ``(R, E)``, ``b`` ``(R,)``."""
        nonlocal count
        R = b.size
        rows.append(np.repeat(np.arange(count, count + R), coef.shape[1]))
        vals.append(coef.ravel())
        cols.append(col.ravel())
        rhs.append(b)
        count += R

    zc = np.arange(n_layers * r).reshape(n_layers, r)
    a_col = n_z + n_seg + (n_layers - 2) * m  # the approach's variable, after z, t and b
    for sign in (1.0, -1.0):
        # sign * (u[k+1] + N[k+1] z[k+1] - u[k] - N[k] z[k])_j <= t_k
        k = np.repeat(np.arange(n_layers - 1), m)
        j = np.tile(np.arange(m), n_layers - 1)
        coef = np.hstack([sign * N[k + 1, j], -sign * N[k, j], -np.ones((k.size, 1))])
        col = np.hstack([zc[k + 1], zc[k], (n_z + k)[:, None]])
        add(coef, col, -sign * (u[k + 1, j] - u[k, j]))
        # sign * (second difference at k)_j <= b_(k, j), interior layers
        k = np.repeat(np.arange(1, n_layers - 1), m)
        j = np.tile(np.arange(m), n_layers - 2)
        coef = np.hstack(
            [sign * N[k + 1, j], -2.0 * sign * N[k, j], sign * N[k - 1, j], -np.ones((k.size, 1))]
        )
        col = np.hstack([zc[k + 1], zc[k], zc[k - 1], (n_z + n_seg + (k - 1) * m + j)[:, None]])
        add(coef, col, -sign * (u[k + 1, j] - 2.0 * u[k, j] + u[k - 1, j]))
        if start is not None:
            # sign * (u[f] + N[f] z[f] - here)_j <= a
            f, near = start
            coef = np.hstack([sign * N[f], -np.ones((m, 1))])
            col = np.hstack([np.repeat(zc[f][None, :], m, axis=0), np.full((m, 1), a_col)])
            add(coef, col, -sign * (u[f] - near))
    # the joint limits of the layers that move (the fixed ends do not: a value there a
    # rounding outside its limit would make the program infeasible; a moving end's limit is
    # kept no tighter than where it is)
    k = np.repeat(np.flatnonzero(moving), m)
    j = np.tile(np.arange(m), int(np.count_nonzero(moving)))
    upper, lower = np.isfinite(hi[j]), np.isfinite(lo[j])
    add(N[k, j][upper], zc[k][upper], np.maximum(hi[j] - u[k, j], 0.0)[upper])
    add(-N[k, j][lower], zc[k][lower], np.maximum(u[k, j] - lo[j], 0.0)[lower])
    A = (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols)))
    return A, np.concatenate(rhs)


def _layer_members(
    fam: CurveFamily, s: float, dirs: FloatArray
) -> tuple[FloatArray, FloatArray, float] | None:
    """The family's members at arc length ``s`` for the reference DP, their slack scores (up to
    :data:`_SLACK_COUNTED`) and the best score; None when none is clear. Where fewer than
    :data:`_FEW_LAYER_NODES` are near the best at ``dirs``, the layer is sampled again at every
    coarse direction, then at the fine ones, and the try with the most such members kept."""
    tries = [dirs] + [d for d in (fam.coarse_dirs, fam.fine_dirs) if d.shape[0] > dirs.shape[0]]
    found: tuple[FloatArray, FloatArray, float] | None = None
    most = -1
    for layer_dirs in tries:
        q = fam.configs(s, layer_dirs)
        if q.shape[0] == 0:
            continue
        # scores above 3 count as 3 (the bonus below), so no distance beyond is measured
        sc = fam.score(q, ceiling=_SLACK_COUNTED)
        best = float(np.max(sc))
        if best < 0:
            continue
        near_best = int(np.count_nonzero(sc >= min(0.3, 0.5 * best)))
        if near_best > most:
            found, most = (q, sc, best), near_best
        if near_best >= _FEW_LAYER_NODES:
            break
    return found


def reference_pieces(
    fam: CurveFamily,
    arc: CurveArc,
    step: float,
    q_from: FloatArray,
    directions: tuple[bool, ...] = (False, True),
    charge_approach: bool = False,
) -> list[Piece]:
    """Reference paths through the solution family along ``arc``, as few pieces (passes) as
    possible.

    Dynamic programming over layers of the family every ``step`` mm: nodes keep a slack, a traced
    transition costs the largest joint change in commands (:class:`CommandUnits`; at most
    :data:`_MAX_LAYER_STEP`: the family must be followed continuously), a lift-off costs
    :data:`_LIFT_OFF` more (a new pass). The
    first layer's cost is the largest joint change from ``q_from``, and the DP runs each way of
    ``directions`` along the arc (False: forward, True: backward): backward is traced where it
    is cheaper by more than :data:`BACKWARD_MARGIN` and needs no lift-off (the pieces come
    in the order traced, each ``backward`` when traced from its end; a backward second pass
    was seen to find no way in where the forward one did, a 25 mm clamp on the seed crack). The
    wrist flip (joint 4 + 180 deg, joint 5 negated) moves no link, so it is chosen per piece
    afterwards. Each piece is then :func:`straightened` and :func:`shortened` between its fixed
    end layers; with ``charge_approach`` also shortened with the approach from where the arm
    comes from charged (its first layer moving too, :func:`shortened`), and that path kept,
    ``approach_charged``, where it costs, its approach included, less by
    :data:`APPROACH_CHARGE_MARGIN`.
    """
    a, b = arc.start_mm, arc.end_mm
    tip = fam.tip_joints
    units = CommandUnits.of_family(fam)
    inset = min(1.0, 0.1 * (b - a))
    n = max(int(np.ceil((b - a - 2 * inset) / step)), 1)
    nodes: list[tuple[float, FloatArray, FloatArray]] = []
    # the same tool directions on every layer; a curve in free space (every direction allowed,
    # not half of them) takes every third, which keeps the DP's work alike
    dirs = fam.coarse_dirs if fam.surface is not None else fam.coarse_dirs[::3]
    windows = fam.world.joint_windows(fam.arm, q_from)
    for s in np.linspace(a + inset, b - inset, n + 1):
        check_time("choosing the reference path along the curve")
        layer = _layer_members(fam, float(s), dirs)
        if layer is None:
            continue
        q, sc, best = layer
        # a joint with self-collision ranges at its values on the start's side of them (the
        # only ones the arm reaches from there; it does not turn freely, see the family)
        q = into_windows(q, windows)[0]
        keep = np.flatnonzero(sc >= min(0.3, 0.5 * best))
        if keep.size > MAX_LAYER_NODES:  # evenly over the tool directions
            keep = keep[np.linspace(0, keep.size - 1, MAX_LAYER_NODES).astype(np.int64)]
        nodes.append((float(s), np.ascontiguousarray(units.units(q[keep][:, tip])), sc[keep]))
    if not nodes:
        raise PlanningError(f"no clear configuration found on the arc {a:.3f}..{b:.3f} mm")
    wrap = fam.turns_freely[tip]
    here = units.units(q_from[tip])
    # either way along the arc: backward in one pass where the DP finds it cheaper by a margin
    # (its first layer costs the approach, so an arc whose end is nearer is traced from there)
    routes = {back: _route(fam, nodes[::-1] if back else nodes, here, units) for back in directions}
    # the DP measures a joint that turns a whole turn within its limits the shorter way round;
    # where a pass turns it nearly a whole turn, the limits may put the pass's start a turn
    # away, and the approach costs what it then takes (a UR5's circle round its base, begun
    # beside the start but traced the way that ran joint 1 into its limit: 177 commands onto it)
    cost = {
        back: total + _limits_extra(fam, units, nodes[::-1] if back else nodes, path, lifts, here)
        for back, (total, path, lifts) in routes.items()
    }
    backward = (
        True in routes
        and not routes[True][2]
        and (False not in routes or cost[True] < cost[False] - BACKWARD_MARGIN)
    )
    _, path, lifts = routes[backward]
    seq = nodes[::-1] if backward else nodes
    ref = np.array([seq[k][1][path[k]] for k in range(len(seq))])
    s_seq = np.array([x[0] for x in seq])
    cuts = [0, *sorted(lifts), len(seq)]
    pieces = []
    prev = here
    comes_from = here * units.step  # where the arm is before each piece, as turned (rad)
    for i in range(len(cuts) - 1):
        lo, hi = cuts[i], cuts[i + 1]
        part = ref[lo:hi]
        flipped = units.flipped(fam, part)
        if (
            flipped is not None
            and _joint_change(flipped[:1], prev, units.period)[0]
            < _joint_change(part[:1], prev, units.period)[0]
        ):
            part = flipped
        prev = part[-1]
        layers = s_seq[lo:hi]
        # where the piece begins: the arc's end, else the layer before it (the lift-off)
        begin = (b if backward else a) if i == 0 else float(s_seq[lo - 1])
        finish = (a if backward else b) if i == len(cuts) - 2 else float(s_seq[hi - 1])
        if backward:  # stored along the curve, traced the other way
            part, layers, begin, finish = part[::-1], layers[::-1], finish, begin
        rad = part * units.step
        rad[:, wrap] = np.unwrap(rad[:, wrap], axis=0)
        rad = _turned_into_limits(fam, rad, comes_from, backward)
        origin, comes_from = comes_from, rad[0] if backward else rad[-1]  # where it ends
        # the joints that do not move the tool point are left to the tracer (it keeps them)
        full = np.zeros((rad.shape[0], fam.arm.n_joints))
        full[:, tip] = rad
        full = straightened(fam, layers, full)
        fixed_ends = shortened(fam, layers, full)
        full, charged = fixed_ends, False
        if charge_approach and layers.size > 1:
            # the approach charged too, the pass may begin nearer the arm (see shortened):
            # kept where, its approach included, it costs less by the margin
            nearer = shortened(fam, layers, full, origin, backward)
            with_approach = [
                _commands_worth(units.units(x[:, tip]))
                + _joint_change(
                    units.units(x[-1 if backward else 0, tip])[None],
                    units.units(origin),
                    units.period,
                )[0]
                for x in (fixed_ends, nearer)
            ]
            if with_approach[1] < with_approach[0] - APPROACH_CHARGE_MARGIN:
                full, charged = nearer, True
        if layers.size == 1:  # a one-layer piece: a constant reference
            layers = np.array([layers[0], layers[0] + 1e-9])
            full = np.vstack([full, full])
        pieces.append(Piece(CurveArc(begin, finish), layers, full, backward, charged))
    return pieces


def _limits_extra(
    fam: CurveFamily,
    units: CommandUnits,
    seq: list[tuple[float, FloatArray, FloatArray]],
    path: list[int],
    lifts: list[int],
    here: FloatArray,
) -> float:
    """What the approach to a route's first pass (layers ``seq`` in the order traced, members
    ``path``) costs beyond what the DP counted, once its joints are turned into their limits
    (:func:`_turned_into_limits`): commands."""
    part = np.array([seq[k][1][path[k]] for k in range(min(lifts, default=len(seq)))])
    wrap = fam.turns_freely[fam.tip_joints]
    rad = part * units.step
    rad[:, wrap] = np.unwrap(rad[:, wrap], axis=0)
    start = _turned_into_limits(fam, rad, here * units.step, False)[0] / units.step
    unlimited = np.where(fam.unlimited[fam.tip_joints], units.period, 0.0)
    counted = _joint_change(part[:1], here, units.period)[0]
    return float(max(_joint_change(start[None], here, unlimited)[0] - counted, 0.0))


def _turned_into_limits(
    fam: CurveFamily, rad: FloatArray, comes_from: FloatArray, backward: bool
) -> FloatArray:
    """A piece's tip joints ``rad`` (rows along the curve), each limited joint that turns a
    whole turn within its limits turned by whole turns so that the piece lies within them,
    starting (where it is traced from) nearest ``comes_from``; where no turn fits, the one that
    leaves it least outside."""
    tip = fam.tip_joints
    lo, hi = fam.arm.lower[tip], fam.arm.upper[tip]
    out = rad.copy()
    first = out[-1] if backward else out[0]
    for j in np.flatnonzero(fam.turns_freely[tip] & np.isfinite(lo) & np.isfinite(hi)):
        turns = np.round((comes_from[j] - first[j]) / (2 * np.pi)) + np.arange(-2, 3)
        low, high = out[:, j].min(), out[:, j].max()
        outside = np.maximum(lo[j] - (low + 2 * np.pi * turns), 0.0) + np.maximum(
            high + 2 * np.pi * turns - hi[j], 0.0
        )
        away = np.abs(first[j] + 2 * np.pi * turns - comes_from[j])
        k = turns[np.lexsort((away, np.round(outside, 9)))[0]]
        out[:, j] += 2 * np.pi * k
    return out


def _route(
    fam: CurveFamily,
    nodes: list[tuple[float, FloatArray, FloatArray]],
    here: FloatArray,
    units: CommandUnits,
) -> tuple[float, list[int], list[int]]:
    """The DP through ``nodes`` (layers in the order traced: arc length, members' tip joints
    in commands, slack) from the tip joints ``here`` (commands): its cost, the member picked
    on each layer and the layers where a new pass starts."""
    first = [nodes[0][1]]
    flip0 = units.flipped(fam, nodes[0][1])
    if flip0 is not None:
        first.append(flip0)
    cost = np.min([_joint_change(q, here, units.period) for q in first], axis=0)
    back = []
    for k in range(1, len(nodes)):
        gap = abs(nodes[k][0] - nodes[k - 1][0])
        bonus = _SLACK_REWARD * nodes[k][2]
        max_step = _MAX_LAYER_STEP * max(gap / 5.0, 1.0)
        cost, arg, lifted = _dp_layer(
            nodes[k - 1][1], cost, nodes[k][1], bonus, units.period, max_step, _LIFT_OFF
        )
        back.append((arg, lifted))
    j = int(np.argmin(cost))
    total = float(cost[j])
    path, lifts = [j], []
    for k in range(len(back) - 1, -1, -1):
        arg, lifted = back[k]
        if lifted[j]:
            lifts.append(k + 1)  # a new pass starts at layer k + 1
        j = int(arg[j])
        path.append(j)
    path.reverse()
    return total, path, lifts
