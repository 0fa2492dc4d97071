"""How much of a tight curve one command can follow within the tolerance band (issue 21).

The trace bound's along part counts the joints' travel through the solution family; it does
not see that a command moves the joints *linearly*: its tool path bends only as far as the
arm's second derivatives allow, so along a tight curve it stays within the band only a few
millimetres (the seed arm's 25 mm circle: about 7 mm a command, while the family's
largest-joint length would allow 25). This module proves, for one configuration, how long an
arc of a circle any command can cover whose tool point lies within the tolerance at its start,
its middle and its end, the middle configuration being that one
(:func:`command_arc_limit`; a batch at once, :func:`arc_limits`).
:mod:`~armpath.planning.bounds.band_trace` takes the largest over the family's members near
each part of a circle and bounds a trace along it with those.

**The lemma.** A command from ``q0`` changes the joints by ``D`` (each within its largest step);
its middle configuration is ``m = q0 + D/2`` and its tool points at start, middle and end are
``p0, a, p1``. With ``c = p1 - p0`` (the chord) and ``w = (p0 + p1)/2 - a`` (how far the
chord's middle lies from the tool path's), Taylor's theorem along the joint line gives

* ``c = J D + e_c``, ``|e_c| <= M3 / 24``, and ``w = D'HD / 8 + e_w``, ``|e_w| <= M4 / 384``,

``J`` and ``H`` the tool point's Jacobian and Hessian at ``m``, ``Mk`` bounds on the k-th
derivative of the tool point along any joint line within the steps (:func:`taylor_bounds`,
from the lengths of the chain after each joint). Let the three points lie within ``tol`` of a
circle of radius ``R`` (centre ``o``, plane normal ``b``), ``a``'s part in the circle's plane
at ``|a| = R + tol - slack`` from ``o`` (``0 <= slack <= 2 tol``), and take at ``a`` the
outward direction ``r`` in that plane and the tangent ``t = b x r``. The in-plane parts of
``p0`` and ``p1`` lie at most ``R + tol`` from ``o``, so

* ``(t.c)^2 + 8 |a| (r.w) <= 8 |a| slack + 4 slack^2`` (the chord's middle, pushed outward by
  the path's bend, lies at least ``|a| + r.w`` from ``o``, and a chord of that length fits
  within the outer circle only so far from its middle),
* ``|b.c| <= 2 tol`` (both ends within ``tol`` of the plane), and
* ``|r.c| <= (2 R tol + |w| |c|) / |a|`` (the ends' distances from ``o`` differ by at most
  ``2 tol``), with ``|c|`` and ``|w|`` bounded at ``m`` term by term, and ``|c|`` then by what
  the last round proved (:data:`_CHORD_ROUNDS`).

**The half band.** Where the tool point must also stay out of a solid whose face the circle
lies on, it lies at most ``inner <= tol`` inside the circle (in its plane): then ``0 <= slack
<= tol + inner`` and the ends' squared distances from the axis differ by at most ``(R +
tol)^2 - (R - inner)^2``, which replaces ``4 R tol`` above (``inner_mm``; the band bound
works out ``inner`` from the face, :mod:`~armpath.planning.bounds.band_trace`).

These are quadratic and linear in ``D``; with ``|D_i| <= s_i`` they bound ``t.c``. Maximising
a linear function under quadratic constraints is not convex, but every choice of nonnegative
multipliers ``lam, mu, nu`` with ``P = lam A + mu_r jr jr' + mu_b jb jb' + diag(nu)`` positive
definite bounds it (weak duality): ``max g'D <= g' P^-1 g / 4 + lam k + mu_r er^2 + mu_b eb^2 +
nu's^2``. The multipliers are chosen by minimising that (a convex function of them); whatever
the minimiser returns, the value computed from them is a bound. At configurations on the seed
arm's 25 mm circle it lies 8-9 % above the longest command SLSQP finds through them, the UR5's
on an 80 mm circle 4-11 % (``tests/test_band.py``). The arc of the circle between the points
nearest ``p0`` and ``p1`` is then at most ``2 R asin((|c| + 2 tol) / 2R)``.

The arc of the curve a command *covers* (the points within ``tol`` of its whole tool path)
is decided by two instants of its motion; the motion between them is a command too, its
joint change within the steps, so the longest arc over every middle configuration bounds it
(up to ``2 tol`` at either end, where the covered points lie beyond the nearest ones).
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.jit import njit, parallel_kernel_lock, prange, threads_pay_off
from armpath.kinematics import (
    forward_frames,
    jacobian_from_frames,
    lengths_after,
    tool_point_joints,
)
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: The multipliers' minimisation (:func:`_box_dual`): rounds of the barrier's weight (each a
#: tenth of the last) and Newton steps in each at most (a round stops when converged). Seed arm,
#: 12 configurations on its 25 mm circle: 7 rounds and 5 give the same limits to 1e-5 (2.5 and
#: 0.9 ms a configuration with the chord rounds below), 4 to 5e-5 (0.76 ms).
_BARRIER_ROUNDS = 5
_NEWTON_STEPS = 30
#: Rounds of :func:`command_arc_limit`: each takes the chord the last one proved as a bound on
#: any command's (it tightens how far the chord may lean off the tangent); it stops earlier
#: when a round proves no shorter chord. The same 12 configurations: 2 rounds give limits 0.04 %
#: above 4 rounds' (3: 0.0003 %) in half the time.
_CHORD_ROUNDS = 2
#: Configurations of a batch (:func:`arc_limits`) from which numba's threads pay off.
_PARALLEL_MIDDLES = 16
#: The branch and bound of :func:`_dual_bound` stops where the highest box's bound lies within
#: this share of the best joint change found.
_BRANCH_GAP = 0.02


@dataclass(frozen=True)
class Circle:
    """A circle: centre (mm), unit normal of its plane and radius (mm)."""

    centre: FloatArray
    normal: FloatArray
    radius_mm: float


@dataclass(frozen=True)
class TaylorBounds:
    """Bounds on a command's tool path (see the module) for joint changes within ``steps``:
    ``chord`` on ``|c|`` (mm), ``bend`` on ``|w|`` (mm), ``chord_error`` on ``|c - J D|`` and
    ``bend_error`` on ``|w - D'HD/8|`` (mm)."""

    chord: float
    bend: float
    chord_error: float
    bend_error: float


def tool_point_hessian(arm: SerialArm, q: FloatArray) -> FloatArray:
    """Second derivatives of the tool point in the joints at ``q (n,)``, ``(3, n, n)`` (mm per
    rad^2, or per rad mm / mm^2 for prismatic joints). For joints ``i <= j`` along the chain
    it is ``z_i x J_j`` (``J_j`` the tool point's velocity per unit of joint ``j``) where ``i``
    turns, and zero where it slides: turning an earlier joint turns the later joint's velocity
    with it; sliding one leaves it as it is."""
    frames = forward_frames(arm, np.asarray(q, dtype=np.float64)[None])
    return np.asarray(_hessians(arm, frames, jacobian_from_frames(arm, frames)[:, :3])[0])


def _hessians(arm: SerialArm, frames: FloatArray, J: FloatArray) -> FloatArray:
    """:func:`tool_point_hessian` of a batch, ``(M, 3, n, n)``, from its frames ``(M, n + 2,
    4, 4)`` and the tool point's Jacobians ``J (M, 3, n)``, already computed."""
    n = arm.n_joints
    H = np.zeros((J.shape[0], 3, n, n))
    for i, joint in enumerate(arm.joints):
        if joint.kind is JointKind.PRISMATIC:
            continue
        z = frames[:, i + 1, :3, :3] @ joint.axis  # (M, 3)
        turned = np.cross(z[:, :, None], J[:, :, i:], axis=1)  # (M, 3, n - i)
        H[:, :, i, i:] = turned
        H[:, :, i:, i] = turned
    return H


def _derivative_bound(order: int, steps: FloatArray, reach: FloatArray, turns: BoolArray) -> float:
    """A bound on the ``order``-th derivative of the tool point along a joint line whose joint
    changes are at most ``steps``: each term of the chain rule with joint ``j`` last (the
    others before it, and turning: a slide's velocity does not change with a slide) is at most
    ``reach[j]`` (the distance from joint ``j`` to the tool point, or 1 for a slide) times the
    product of the changes."""
    total, before = 0.0, 0.0
    for j in range(steps.size):
        if turns[j]:
            total += reach[j] * ((before + steps[j]) ** order - before**order)
            before += steps[j]
        else:
            total += order * before ** (order - 1) * steps[j]
    return total


def taylor_bounds(arm: SerialArm, moves: BoolArray | None = None) -> TaylorBounds:
    """:class:`TaylorBounds` for any command of ``arm`` (its largest steps), over the joints
    ``moves`` (default those that move the tool point: the others leave it where it is)."""
    tip = tool_point_joints(arm) if moves is None else moves
    steps = np.where(tip, arm.lattice.max_step, 0.0)
    turns = np.array([j.kind is not JointKind.PRISMATIC for j in arm.joints])
    reach = np.array([lengths_after(arm, i) if turns[i] else 1.0 for i in range(arm.n_joints)])
    m1, m2, m3, m4 = (_derivative_bound(k, steps, reach, turns) for k in (1, 2, 3, 4))
    bend_error = m4 / 384.0
    return TaylorBounds(m1, m2 / 8.0 + bend_error, m3 / 24.0, bend_error)


@njit(cache=True)
def _cholesky(P: np.ndarray, L: np.ndarray) -> bool:  # pragma: no cover - compiled
    """``L`` lower triangular with ``L L' = P``; False where ``P`` is not positive definite."""
    k = P.shape[0]
    for j in range(k):
        total = P[j, j]
        for m in range(j):
            total -= L[j, m] * L[j, m]
        if not total > 0.0 or not np.isfinite(total):
            return False
        L[j, j] = np.sqrt(total)
        for i in range(j + 1, k):
            total = P[i, j]
            for m in range(j):
                total -= L[i, m] * L[j, m]
            L[i, j] = total / L[j, j]
        for i in range(j):
            L[i, j] = 0.0
    return True


@njit(cache=True)
def _lower_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """``y`` with ``L y = b``."""
    k = b.size
    y = np.empty(k)
    for i in range(k):
        total = b[i]
        for m in range(i):
            total -= L[i, m] * y[m]
        y[i] = total / L[i, i]
    return y


@njit(cache=True)
def _upper_solve(L: np.ndarray, y: np.ndarray) -> np.ndarray:  # pragma: no cover - compiled
    """``x`` with ``L' x = y``."""
    k = y.size
    x = np.empty(k)
    for i in range(k - 1, -1, -1):
        total = y[i]
        for m in range(i + 1, k):
            total -= L[m, i] * x[m]
        x[i] = total / L[i, i]
    return x


@njit(cache=True)
def _dual_value(
    g: np.ndarray,
    quads: np.ndarray,
    lins: np.ndarray,
    consts: np.ndarray,
    mult: np.ndarray,
    L: np.ndarray,
) -> tuple[bool, float, np.ndarray]:  # pragma: no cover - compiled
    """Whether ``P = sum mult B`` is positive definite (its factor into ``L``), the dual's
    value ``h' P^-1 h / 4 + mult . c`` and the Lagrangian's maximiser ``P^-1 h / 2``."""
    k, n_c = g.size, mult.size
    P = np.zeros((k, k))
    h = g.copy()
    for c in range(n_c):
        for a in range(k):
            h[a] -= mult[c] * lins[c, a]
            for b in range(k):
                P[a, b] += mult[c] * quads[c, a, b]
    if not _cholesky(P, L):
        return False, np.inf, h
    y = _lower_solve(L, h)
    value = 0.25 * (y @ y) + mult @ consts
    return True, value, 0.5 * _upper_solve(L, y)


@njit(cache=True)
def _box_dual_kernel(
    g: np.ndarray,
    quads: np.ndarray,
    lins: np.ndarray,
    consts: np.ndarray,
    mult: np.ndarray,
    rounds: int,
    steps: int,
) -> tuple[bool, float, np.ndarray]:  # pragma: no cover - compiled
    """The interior-point minimisation of :func:`_box_dual` from the multipliers ``mult``
    (changed in place): whether they were valid, the dual's value at the last ones and the
    Lagrangian's maximiser there."""
    k, n_c = g.size, mult.size
    L = np.zeros((k, k))
    ok, value, D = _dual_value(g, quads, lins, consts, mult, L)
    if not ok:
        return False, np.inf, D
    weight = 1e-2 * abs(value) / n_c + 1e-12
    Lt = np.zeros((k, k))
    Hf = np.zeros((n_c, n_c))
    for _ in range(rounds):
        for _ in range(steps):
            # P^-1 from the factor, then the gradient and Hessian of the barrier's merit
            Linv = np.zeros((k, k))
            for col in range(k):
                e = np.zeros(k)
                e[col] = 1.0
                Linv[:, col] = _lower_solve(L, e)
            Pinv = Linv.T @ Linv
            v = np.empty((n_c, k))
            PB = np.empty((n_c, k, k))
            grad = np.empty(n_c)
            for c in range(n_c):
                v[c] = quads[c] @ D + 0.5 * lins[c]
                PB[c] = Pinv @ quads[c]
                trace = 0.0
                for a in range(k):
                    trace += PB[c, a, a]
                grad[c] = consts[c] - (v[c] + 0.5 * lins[c]) @ D - weight * (trace + 1.0 / mult[c])
            Pv = v @ Pinv
            hess = 2.0 * (Pv @ v.T)
            for c in range(n_c):
                for d in range(c, n_c):
                    tr = 0.0
                    for a in range(k):
                        for b in range(k):
                            tr += PB[c, a, b] * PB[d, b, a]
                    hess[c, d] += weight * tr
                    if d != c:
                        hess[d, c] += weight * tr
                hess[c, c] += weight / (mult[c] * mult[c])
            if not _cholesky(hess, Hf):
                break
            step = -_upper_solve(Hf, _lower_solve(Hf, grad))
            decrement = -(step @ grad)
            if not decrement > 1e-12 * (abs(weight) + 1.0):
                break
            t = 1.0  # the longest step that keeps every multiplier positive
            for c in range(n_c):
                if step[c] < 0.0:
                    t = min(t, -0.99 * mult[c] / step[c])
            logdet = 0.0
            for a in range(k):
                logdet += 2.0 * np.log(L[a, a])
            here = value - weight * (logdet + np.sum(np.log(mult)))
            moved = False
            for _ in range(50):
                trial = mult + t * step
                ok, v_trial, D_trial = _dual_value(g, quads, lins, consts, trial, Lt)
                if ok:
                    logdet = 0.0
                    for a in range(k):
                        logdet += 2.0 * np.log(Lt[a, a])
                    merit = v_trial - weight * (logdet + np.sum(np.log(trial)))
                    if merit <= here - 0.25 * t * decrement:
                        moved = True
                        break
                t *= 0.5
            if not moved:
                break
            mult[:] = trial
            value, D = v_trial, D_trial
            for a in range(k):
                for b in range(k):
                    L[a, b] = Lt[a, b]
        weight *= 0.1
    return True, value, D


@njit(cache=True)
def _one_box(
    g: np.ndarray, mats: np.ndarray, caps: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> tuple[float, np.ndarray]:  # pragma: no cover - compiled
    """:func:`_box_dual`, compiled (what a batch of configurations runs)."""
    k, nq = g.size, mats.shape[0]
    n_c = nq + k
    quads = np.zeros((n_c, k, k))
    lins = np.zeros((n_c, k))
    consts = np.zeros(n_c)
    for m in range(nq):
        consts[m] = caps[m]
        for a in range(k):
            for b in range(k):
                quads[m, a, b] = mats[m, a, b]
    corner = np.empty(k)
    widest = 0.0
    box = np.empty(k)
    for i in range(k):
        quads[nq + i, i, i] = 1.0
        lins[nq + i, i] = -(lo[i] + hi[i])
        consts[nq + i] = -lo[i] * hi[i]
        corner[i] = hi[i] if g[i] > 0 else lo[i]
        widest += g[i] * corner[i]
        box[i] = abs(g[i]) / max(hi[i] - lo[i], 1e-12)
    floor = 1e-2 * max(box.mean(), 1e-12)
    mult = np.empty(n_c)
    valid = False
    value, D = np.inf, corner
    for _ in range(60):  # the box's multipliers raised until P is positive definite
        for m in range(nq):
            mult[m] = 1e-2 * floor / max(np.abs(mats[m]).max(), 1e-300)
        for i in range(k):
            mult[nq + i] = box[i] + floor
        valid, value, D = _box_dual_kernel(
            g, quads, lins, consts, mult, _BARRIER_ROUNDS, _NEWTON_STEPS
        )
        if valid:
            break
        floor *= 4.0
    if not valid or not value < widest:
        return widest, corner
    out = np.empty(k)
    for i in range(k):
        out[i] = min(max(D[i], lo[i]), hi[i])
    return value, out


def _box_dual(
    g: FloatArray, mats: FloatArray, caps: FloatArray, lo: FloatArray, hi: FloatArray
) -> tuple[float, FloatArray]:
    """An upper bound on ``g'D`` over ``lo <= D <= hi`` and ``D'B_l D <= caps_l`` (``mats``
    the symmetric ``B_l``), by weak duality, and the joint change that maximises the
    Lagrangian at the multipliers found (a candidate for the largest ``g'D``).

    With the box written ``(D_i - lo_i)(D_i - hi_i) <= 0``, every constraint is ``D'B D + b'D
    <= c``; for nonnegative multipliers ``mult`` whose ``P = sum mult B`` is positive definite,
    ``f = h' P^-1 h / 4 + mult . c`` (``h = g - sum mult b``) bounds ``g'D`` from above. ``f``
    is convex in the multipliers; they are found by Newton steps on ``f`` less logarithmic
    barriers of ``mult`` and ``det P`` (an interior-point method, its weight shrunk
    :data:`_BARRIER_ROUNDS` times; compiled, :func:`_one_box`) from the box's own (with the
    others nil, the bound is the box's corner), raised until ``P`` is positive definite. Any
    multipliers give a bound: the value returned is ``f`` of those the steps reached, or the
    corner's where that is less."""
    value, D = _one_box(
        np.ascontiguousarray(g, dtype=np.float64),
        np.ascontiguousarray(np.asarray(mats, dtype=np.float64).reshape(-1, g.size, g.size)),
        np.ascontiguousarray(caps, dtype=np.float64),
        np.ascontiguousarray(lo, dtype=np.float64),
        np.ascontiguousarray(hi, dtype=np.float64),
    )
    return float(value), np.asarray(D)


def _dual_bound(
    g: FloatArray,
    blocks: list[FloatArray],
    limits: FloatArray,
    steps: FloatArray,
    nodes: int = 1,
) -> float:
    """An upper bound on ``g'D`` over ``|D_i| <= steps_i`` and ``D'B_l D <= limits_l`` (each
    ``B_l`` symmetric): :func:`_box_dual` of the whole box, or with ``nodes`` above one a
    branch and bound over boxes: the box whose bound is highest is split in two at its middle
    across the joint whose squared share of the box, times how far it takes part in the
    constraints' negative curvature, is largest, until its bound lies within
    :data:`_BRANCH_GAP` of the best feasible ``g'D`` found (the dual's maximisers of the
    boxes that satisfy every constraint) or ``nodes`` boxes were bounded. The bound is the
    highest of the boxes left. A safety net: where the constraints are far from convex (an
    arm's null space bending the path both ways) one box's dual may lie well above the largest
    ``g'D``, and split boxes bring it down; at the configurations the tests check, a singular
    wrist's included, one box's dual already lies within 10 % of SLSQP's longest command."""
    mats = np.asarray(blocks, dtype=np.float64).reshape(-1, g.size, g.size)
    caps = np.asarray(limits, dtype=np.float64)
    if nodes <= 1:
        return _box_dual(g, mats, caps, -steps, steps)[0]

    def feasible(D: FloatArray) -> bool:
        return bool(np.all(np.einsum("a,lab,b->l", D, mats, D) <= caps))

    # how far each joint takes part in the constraints' negative curvature (their concave
    # parts: what a box's dual must pay for with the box's multipliers)
    concave = np.zeros(g.size)
    for B in mats:
        w, V = np.linalg.eigh(B)
        concave += np.abs(np.einsum("ak,k,ak->a", V, np.minimum(w, 0.0), V)) / max(
            float(np.abs(w).max()), 1e-300
        )
    value, D = _box_dual(g, mats, caps, -steps, steps)
    best = float(g @ D) if feasible(D) else -math.inf
    heap = [(-value, 0, -steps, steps)]
    count = 1
    while count < nodes:
        top, _, lo, hi = heap[0]
        if math.isfinite(best) and -top - best <= _BRANCH_GAP * max(abs(best), 1e-9):
            break
        heapq.heappop(heap)
        j = int(np.argmax(((hi - lo) / (2.0 * steps)) ** 2 * (concave + 1e-3)))
        middle = 0.5 * (lo[j] + hi[j])
        for a, b in ((lo[j], middle), (middle, hi[j])):
            lo2, hi2 = lo.copy(), hi.copy()
            lo2[j], hi2[j] = a, b
            value, D = _box_dual(g, mats, caps, lo2, hi2)
            count += 1
            if feasible(D):
                best = max(best, float(g @ D))
            heapq.heappush(heap, (-value, count, lo2, hi2))
    return -heap[0][0]


@dataclass(frozen=True)
class _Middles:
    """What the lemma takes from each of a batch of middle configurations (see the module):
    ``g = J't``, ``A = g g' + |a| H_r``, ``jr = J'r``, ``jb = J'b`` (per joint that moves the
    tool point), ``|a|`` and its ``slack`` (mm), this configuration's own bounds on ``|c|``
    and ``|w|`` (mm), and ``fixed``: NaN where the dual is to bound the chord, else the limit
    itself (0 where the middle's tool point lies out of the band, inf where the circle is
    degenerate at it: its axis through the tool point)."""

    g: FloatArray
    A: FloatArray
    jr: FloatArray
    jb: FloatArray
    radius_a: FloatArray
    slack: FloatArray
    chord: FloatArray
    bend: FloatArray
    fixed: FloatArray


def _middles(
    arm: SerialArm,
    qs: FloatArray,
    circle: Circle,
    tol: float,
    tb: TaylorBounds,
    tip: BoolArray,
    anywhere: bool,
    inner: float,
) -> _Middles:
    """:class:`_Middles` of configurations ``qs (M, n)`` (see :func:`command_arc_limit`)."""
    qs = np.asarray(qs, dtype=np.float64).reshape(-1, arm.n_joints)
    R = float(circle.radius_mm)
    b = np.asarray(circle.normal, dtype=np.float64)
    b = b / np.linalg.norm(b)
    frames = forward_frames(arm, qs)
    a = frames[:, -1, :3, 3] - circle.centre
    a_plane = a - (a @ b)[:, None] * b
    radius_a = np.linalg.norm(a_plane, axis=-1)  # the middle tool point's distance from the axis
    fixed = np.full(qs.shape[0], np.nan)
    fixed[radius_a < 1e-9] = math.inf
    r = a_plane / np.maximum(radius_a, 1e-9)[:, None]
    if anywhere:  # the middle at the band's inner edge: the most room for the chord
        radius_a = np.full(qs.shape[0], R - inner)
    else:  # no command has its middle within the tolerance where this lies outside
        fixed[np.isnan(fixed) & (np.hypot(radius_a - R, a @ b) > tol)] = 0.0
        fixed[np.isnan(fixed) & (radius_a < R - inner)] = 0.0
    slack = R + tol - radius_a  # how far inside the outer circle it lies, 0 to tol + inner
    t = np.cross(b, r)
    J_all = jacobian_from_frames(arm, frames)[:, :3]
    J = J_all[:, :, tip]
    H = _hessians(arm, frames, J_all)[:, :, tip][:, :, :, tip]
    steps = arm.lattice.max_step[tip]
    g = np.einsum("mkj,mk->mj", J, t)
    H_r = np.einsum("mk,mkab->mab", r, H)
    A = g[:, :, None] * g[:, None, :] + radius_a[:, None, None] * H_r
    # this configuration's own bounds on |c| and |w| (each term of J D and D'HD at its
    # largest), where less than the arm's
    chord = np.minimum(tb.chord, np.linalg.norm(J, axis=1) @ steps + tb.chord_error)
    H_norm = np.linalg.norm(H, axis=1)
    bend = np.minimum(tb.bend, np.einsum("a,mab,b->m", steps, H_norm, steps) / 8.0 + tb.bend_error)
    return _Middles(
        g=np.ascontiguousarray(g),
        A=np.ascontiguousarray(A),
        jr=np.ascontiguousarray(np.einsum("mkj,mk->mj", J, r)),
        jb=np.ascontiguousarray(J.transpose(0, 2, 1) @ b),
        radius_a=radius_a,
        slack=slack,
        chord=chord,
        bend=bend,
        fixed=fixed,
    )


@njit(cache=True)
def _round_limits(
    radius_a: float,
    slack: float,
    R: float,
    tol: float,
    inner: float,
    e_c: float,
    e_w: float,
    chord: float,
    bend: float,
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """One round's right-hand sides of the three constraints on ``D`` (see the module), the
    chord and bend bounds ``chord``, ``bend`` known so far; and the radial allowance. With
    ``(t.c)^2 + 8 |a| (r.w) <= 8 |a| slack + 4 slack^2``, ``(g'D)^2 <= (t.c)^2 + 2 |t.c| e_c +
    e_c^2`` (``|t.c| <= chord``) and ``|a| D'H_r D <= 8 |a| (r.w) + 8 |a| e_w``."""
    cap = 8.0 * radius_a * slack + 4.0 * slack**2 + 8.0 * radius_a * e_w + 2.0 * chord * e_c
    cap += e_c**2
    radial = (R * (tol + inner) + 0.5 * (tol * tol - inner * inner) + bend * chord) / radius_a
    return cap, (radial + e_c) ** 2, radial


@njit(cache=True)
def _chord_one_box(
    g: np.ndarray,
    A: np.ndarray,
    jr: np.ndarray,
    jb: np.ndarray,
    steps: np.ndarray,
    radius_a: float,
    slack: float,
    R: float,
    tol: float,
    inner: float,
    e_c: float,
    e_w: float,
    chord: float,
    bend: float,
) -> float:  # pragma: no cover - compiled
    """The bound on any command's chord through one middle configuration (its
    :class:`_Middles` row), each round by one box's dual (:func:`_one_box`)."""
    k = g.size
    mats = np.empty((3, k, k))
    for a in range(k):
        for b in range(k):
            mats[0, a, b] = A[a, b]
            mats[1, a, b] = jr[a] * jr[b]
            mats[2, a, b] = jb[a] * jb[b]
    limits = np.empty(3)
    limits[2] = (2.0 * tol + e_c) ** 2
    for _ in range(_CHORD_ROUNDS):
        limits[0], limits[1], radial = _round_limits(
            radius_a, slack, R, tol, inner, e_c, e_w, chord, bend
        )
        along = _one_box(g, mats, limits, -steps, steps)[0] + e_c
        # every command through this configuration has |c| at most this: the next round
        # may use it
        tighter = np.sqrt(along**2 + radial**2 + (2.0 * tol) ** 2)
        if tighter >= chord:
            break
        chord = tighter
    return chord


@njit(cache=True)
def _chords_one_box(
    g: np.ndarray,
    A: np.ndarray,
    jr: np.ndarray,
    jb: np.ndarray,
    steps: np.ndarray,
    radius_a: np.ndarray,
    slack: np.ndarray,
    R: float,
    tol: float,
    inner: float,
    e_c: float,
    e_w: float,
    chord: np.ndarray,
    bend: np.ndarray,
    todo: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`_chord_one_box` of each configuration ``todo`` of a batch (the others' chords
    left as they are)."""
    out = chord.copy()
    for i in range(todo.size):
        m = todo[i]
        out[m] = _chord_one_box(
            g[m], A[m], jr[m], jb[m], steps, radius_a[m], slack[m], R, tol, inner, e_c, e_w,
            chord[m], bend[m],
        )  # fmt: skip
    return out


@njit(cache=True, parallel=True)
def _chords_one_box_parallel(
    g: np.ndarray,
    A: np.ndarray,
    jr: np.ndarray,
    jb: np.ndarray,
    steps: np.ndarray,
    radius_a: np.ndarray,
    slack: np.ndarray,
    R: float,
    tol: float,
    inner: float,
    e_c: float,
    e_w: float,
    chord: np.ndarray,
    bend: np.ndarray,
    todo: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`_chords_one_box` on numba's threads."""
    out = chord.copy()
    for i in prange(todo.size):
        m = todo[i]
        out[m] = _chord_one_box(
            g[m], A[m], jr[m], jb[m], steps, radius_a[m], slack[m], R, tol, inner, e_c, e_w,
            chord[m], bend[m],
        )  # fmt: skip
    return out


def _chord_branching(
    mid: _Middles,
    steps: FloatArray,
    R: float,
    tol: float,
    inner: float,
    tb: TaylorBounds,
    nodes: int,
) -> float:
    """:func:`_chord_one_box` of the one configuration of ``mid`` with each round's dual by
    the branch and bound of :func:`_dual_bound` over ``nodes`` boxes."""
    blocks = [mid.A[0], np.outer(mid.jr[0], mid.jr[0]), np.outer(mid.jb[0], mid.jb[0])]
    chord, e_c = float(mid.chord[0]), tb.chord_error
    for _ in range(_CHORD_ROUNDS):
        cap, radial_cap, radial = _round_limits(
            float(mid.radius_a[0]), float(mid.slack[0]), R, tol, inner, e_c, tb.bend_error, chord,
            float(mid.bend[0]),
        )  # fmt: skip
        limits = np.array([cap, radial_cap, (2.0 * tol + e_c) ** 2])
        along = _dual_bound(mid.g[0], blocks, limits, steps, nodes) + e_c
        tighter = math.sqrt(along**2 + radial**2 + (2.0 * tol) ** 2)
        if tighter >= chord:
            break
        chord = tighter
    return chord


def _arcs(chord: FloatArray, R: float, tol: float) -> FloatArray:
    """The longest arc (mm) between the points of the circle nearest two points within
    ``tol`` of it whose chord is at most ``chord`` (inf where it may span the circle)."""
    x = (np.asarray(chord, dtype=np.float64) + 2.0 * tol) / (2.0 * R)
    with np.errstate(invalid="ignore"):
        return np.where(x < 1.0, 2.0 * R * np.arcsin(np.minimum(x, 1.0)), math.inf)


def _inner(tol: float, inner_mm: float | None) -> float:
    """The band's inner half-width (mm): ``inner_mm`` within 0 and the tolerance ``tol`` (a
    wider inner half only loosens the bound), the tolerance where not given."""
    return tol if inner_mm is None else min(max(float(inner_mm), 0.0), tol)


def lemma_applies(arm: SerialArm, circle: Circle, tol: float, tb: TaylorBounds) -> bool:
    """Whether the lemma can bound commands along ``circle``: an arm measured in mm and a
    circle wider than the path's bend and the tolerance, long enough for the arc to be told
    from the chord."""
    R = float(circle.radius_mm)
    return arm.length_unit == "mm" and tol + tb.bend < R and math.pi * (R - tol) > tb.chord


def arc_limits(
    arm: SerialArm,
    qs: FloatArray,
    circle: Circle,
    tolerance_mm: float,
    taylor: TaylorBounds | None = None,
    moves: BoolArray | None = None,
    anywhere: bool = True,
    inner_mm: float | None = None,
) -> FloatArray:
    """:func:`command_arc_limit` of each configuration ``qs (M, n)`` by one box's dual each
    round (compiled over the batch): an upper bound on the limit :func:`command_arc_limit`
    refines by branch and bound."""
    tip = tool_point_joints(arm) if moves is None else moves
    tb = taylor_bounds(arm, tip) if taylor is None else taylor
    qs = np.asarray(qs, dtype=np.float64).reshape(-1, arm.n_joints)
    tol = float(tolerance_mm)
    if not lemma_applies(arm, circle, tol, tb):
        return np.full(qs.shape[0], math.inf)
    if qs.shape[0] == 0:
        return np.zeros(0)
    inner = _inner(tol, inner_mm)
    mid = _middles(arm, qs, circle, tol, tb, tip, anywhere, inner)
    R = float(circle.radius_mm)
    args = (
        mid.g, mid.A, mid.jr, mid.jb, np.ascontiguousarray(arm.lattice.max_step[tip]),
        mid.radius_a, mid.slack, R, tol, inner, tb.chord_error, tb.bend_error, mid.chord,
        mid.bend, np.flatnonzero(np.isnan(mid.fixed)),
    )  # fmt: skip
    if threads_pay_off(qs.shape[0], _PARALLEL_MIDDLES):
        with parallel_kernel_lock:
            chords = _chords_one_box_parallel(*args)
    else:
        chords = _chords_one_box(*args)
    return np.asarray(np.where(np.isnan(mid.fixed), _arcs(chords, R, tol), mid.fixed))


def command_arc_limit(
    arm: SerialArm,
    q_mid: FloatArray,
    circle: Circle,
    tolerance_mm: float,
    taylor: TaylorBounds | None = None,
    moves: BoolArray | None = None,
    nodes: int = 200,
    anywhere: bool = False,
    inner_mm: float | None = None,
) -> float:
    """The longest arc (mm) of ``circle`` between the points nearest the start and the end of
    any command whose middle configuration is ``q_mid`` (rad / mm) and whose tool point lies
    within ``tolerance_mm`` of the circle at its start, middle and end (see the module); 0
    where ``q_mid``'s own tool point lies farther than that from the circle; inf where the
    circle is too tight for the lemma (its radius within the path's bend and the tolerance)
    or too small for the arc to be told from the chord, and for an arm whose lengths are not
    in mm. ``nodes``: boxes of joint changes the branch and bound of each round may bound
    (:func:`_dual_bound`; 1: one box, :func:`arc_limits`). ``anywhere``: the middle's tool
    point may lie anywhere within the tolerance of the circle (taken at the band's inner
    edge, which leaves the chord the most room), the joints' derivatives those at ``q_mid``:
    for a sample of the family that stands for the members about it. ``inner_mm``: how far
    inside the circle (towards its axis, in its plane) the tool point may lie at most (mm;
    default the tolerance, a band on both sides; less where it must stay out of a solid whose
    face the circle lies on: the half band, see the module)."""
    tip = tool_point_joints(arm) if moves is None else moves
    tb = taylor_bounds(arm, tip) if taylor is None else taylor
    tol = float(tolerance_mm)
    if nodes <= 1 or not lemma_applies(arm, circle, tol, tb):
        return float(arc_limits(arm, q_mid, circle, tol, tb, tip, anywhere, inner_mm)[0])
    inner = _inner(tol, inner_mm)
    mid = _middles(arm, q_mid, circle, tol, tb, tip, anywhere, inner)
    if not np.isnan(mid.fixed[0]):
        return float(mid.fixed[0])
    R = float(circle.radius_mm)
    chord = _chord_branching(mid, arm.lattice.max_step[tip], R, tol, inner, tb, nodes)
    return float(_arcs(np.array([chord]), R, tol)[0])
