"""How much of a tight curve one command can follow within the tolerance band (issue 21).

The trace bound's along part counts the joints' travel through the solution family; it does
not see that a command moves the joints *linearly*: its tool path bends only as far as the
arm's second derivatives allow, so along a tight curve it stays within the band only a few
millimetres (the seed arm's 25 mm circle: about 7 mm a command, while the family's
largest-joint length would allow 25). This module proves, for one configuration, how long an
arc of a circle any command can cover whose tool point lies within the tolerance at its start,
its middle and its end, the middle configuration being that one
(:func:`command_arc_limit`), and the largest over a family's samples
(:func:`sampled_arc_limit`).

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

from armpath.jit import njit
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
#: tenth of the last) and Newton steps in each at most (a round stops when converged).
_BARRIER_ROUNDS = 7
_NEWTON_STEPS = 30
#: Rounds of :func:`command_arc_limit`: each takes the chord the last one proved as a bound on
#: any command's (it tightens how far the chord may lean off the tangent); it stops earlier
#: when a round proves no shorter chord.
_CHORD_ROUNDS = 4
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
    frames = forward_frames(arm, np.asarray(q, dtype=np.float64)[None])[0]
    return _hessian_from(arm, frames, jacobian_from_frames(arm, frames[None])[0][:3])


def _hessian_from(arm: SerialArm, frames: FloatArray, J: FloatArray) -> FloatArray:
    """:func:`tool_point_hessian` from the configuration's frames ``(n + 2, 4, 4)`` and the
    tool point's Jacobian ``J (3, n)``, already computed."""
    n = arm.n_joints
    H = np.zeros((3, n, n))
    for i, joint in enumerate(arm.joints):
        if joint.kind is JointKind.PRISMATIC:
            continue
        z = frames[i + 1, :3, :3] @ joint.axis
        for j in range(i, n):
            H[:, i, j] = np.cross(z, J[:, j])
            H[:, j, i] = H[:, i, j]
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
    :data:`_BARRIER_ROUNDS` times; compiled) from the box's own (with the others nil, the bound
    is the box's corner), raised until ``P`` is positive definite. Any multipliers give a
    bound: the value returned is ``f`` of those the steps reached, or the corner's where that
    is less."""
    k = g.size
    eye = np.eye(k)
    quads = np.ascontiguousarray(np.concatenate([mats, eye[:, None, :] * eye[:, :, None]]))
    lins = np.ascontiguousarray(
        np.concatenate([np.zeros((mats.shape[0], k)), -(lo + hi)[:, None] * eye])
    )
    consts = np.concatenate([caps, -lo * hi])
    corner = np.where(g > 0, hi, lo)
    widest = float(g @ corner)
    half = np.maximum(hi - lo, 1e-12) / 2.0
    box = np.abs(g) / (2.0 * half)
    floor = 1e-2 * max(float(box.mean()), 1e-12)
    scale = [1e-2 * floor / max(float(np.abs(B).max()), 1e-300) for B in mats]
    for _ in range(60):  # the box's multipliers raised until P is positive definite
        mult = np.concatenate([scale, box + floor])
        ok, value, D = _box_dual_kernel(
            np.asarray(g, np.float64), quads, lins, consts, mult, _BARRIER_ROUNDS, _NEWTON_STEPS
        )
        if ok:
            break
        floor *= 4.0
    else:
        return widest, corner
    if not value < widest:
        return widest, corner
    return float(value), np.clip(np.asarray(D), lo, hi)


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


def command_arc_limit(
    arm: SerialArm,
    q_mid: FloatArray,
    circle: Circle,
    tolerance_mm: float,
    taylor: TaylorBounds | None = None,
    moves: BoolArray | None = None,
    nodes: int = 200,
    anywhere: bool = False,
) -> float:
    """The longest arc (mm) of ``circle`` between the points nearest the start and the end of
    any command whose middle configuration is ``q_mid`` (rad / mm) and whose tool point lies
    within ``tolerance_mm`` of the circle at its start, middle and end (see the module); 0
    where ``q_mid``'s own tool point lies farther than that from the circle; inf where the
    circle is too tight for the lemma (its radius within the path's bend and the tolerance)
    or too small for the arc to be told from the chord, and for an arm whose lengths are not
    in mm. ``nodes``: boxes of joint changes the branch and bound of each round may bound
    (:func:`_dual_bound`). ``anywhere``: the middle's tool point may lie anywhere within the
    tolerance of the circle (taken at the band's inner edge, which leaves the chord the most
    room), the joints' derivatives those at ``q_mid``: for a sample of the family that stands
    for the members about it."""
    if arm.length_unit != "mm":
        return math.inf
    tip = tool_point_joints(arm) if moves is None else moves
    tb = taylor_bounds(arm, tip) if taylor is None else taylor
    R, tol = float(circle.radius_mm), float(tolerance_mm)
    if tol + tb.bend >= R or math.pi * (R - tol) <= tb.chord:
        return math.inf
    b = np.asarray(circle.normal, dtype=np.float64)
    b = b / np.linalg.norm(b)
    frames = forward_frames(arm, np.asarray(q_mid, dtype=np.float64)[None])[0]
    a = frames[-1, :3, 3] - circle.centre
    a_plane = a - (a @ b) * b
    radius_a = float(np.linalg.norm(a_plane))  # the middle tool point's distance from the axis
    if radius_a < 1e-9:
        return math.inf
    r = a_plane / radius_a
    if anywhere:  # the middle at the band's inner edge: the most room for the chord
        radius_a = R - tol
    elif math.hypot(radius_a - R, float(a @ b)) > tol:
        return 0.0  # no command through q_mid has its middle within the tolerance
    slack = R + tol - radius_a  # how far inside the outer circle it lies, 0 to 2 tol
    t = np.cross(b, r)
    J_all = jacobian_from_frames(arm, frames[None])[0][:3]
    J = J_all[:, tip]
    H = _hessian_from(arm, frames, J_all)[:, tip][:, :, tip]
    steps = arm.lattice.max_step[tip]
    g, jr, jb = J.T @ t, J.T @ r, J.T @ b
    A = np.outer(g, g) + radius_a * np.einsum("k,kab->ab", r, H)
    e_c, e_w = tb.chord_error, tb.bend_error
    # this configuration's own bounds on |c| and |w| (each term of J D and D'HD at its
    # largest), where less than the arm's
    chord = min(tb.chord, float(np.linalg.norm(J, axis=0) @ steps) + e_c)
    bend = min(tb.bend, float(steps @ np.linalg.norm(H, axis=0) @ steps) / 8.0 + e_w)
    binormal = 2.0 * tol + e_c
    blocks = [A, np.outer(jr, jr), np.outer(jb, jb)]
    for _ in range(_CHORD_ROUNDS):
        # (t.c)^2 + 8 |a| (r.w) <= 8 |a| slack + 4 slack^2, and (g'D)^2 <= (t.c)^2 + 2 |t.c|
        # e_c + e_c^2 with |t.c| <= chord, |a| D'H_r D <= 8 |a| (r.w) + 8 |a| e_w
        cap = (
            8.0 * radius_a * slack
            + 4.0 * slack**2
            + 8.0 * radius_a * e_w
            + 2.0 * chord * e_c
            + e_c**2
        )
        radial = (2.0 * R * tol + bend * chord) / radius_a
        limits = np.array([cap, (radial + e_c) ** 2, binormal**2])
        along = _dual_bound(g, blocks, limits, steps, nodes) + e_c
        # every command through q_mid has |c| at most this: the next round may use it
        tighter = math.sqrt(along**2 + radial**2 + (2.0 * tol) ** 2)
        if tighter >= chord:
            break
        chord = tighter
    if chord + 2.0 * tol >= 2.0 * R:
        return math.inf
    return 2.0 * R * math.asin((chord + 2.0 * tol) / (2.0 * R))


@dataclass(frozen=True)
class SampledLimit:
    """The longest arc (mm) one command can follow at any of a family's samples
    (:func:`sampled_arc_limit`), and where: the sample's configuration (rad / mm) and the arc
    length (mm) of its curve point; ``samples`` how many were bounded."""

    arc_mm: float
    q: FloatArray
    s_mm: float
    samples: int


def sampled_arc_limit(
    arm: SerialArm,
    layers: list[tuple[float, FloatArray]],
    circle: Circle,
    tolerance_mm: float,
    nodes: int = 200,
) -> SampledLimit:
    """The largest :func:`command_arc_limit` (its middle anywhere within the tolerance) over
    the configurations of ``layers`` (each the arc length, mm, of a curve point and the
    family's samples there, ``(M, n)``): each sample first bounded by one box's dual, then, from
    the highest down, again with the branch and bound of ``nodes`` boxes until the highest
    refined one is at least the next unrefined one (each value is a bound on its sample's
    limit, so the unrefined ones below it need no refining). Proven per sample; between
    samples the family is as far sampled as it is."""
    tip = tool_point_joints(arm)
    tb = taylor_bounds(arm, tip)
    where = [(s, q) for s, qs in layers for q in qs]
    if not where:
        return SampledLimit(0.0, np.zeros(arm.n_joints), math.nan, 0)
    coarse = np.array(
        [
            command_arc_limit(arm, q, circle, tolerance_mm, tb, tip, nodes=1, anywhere=True)
            for _, q in where
        ]
    )
    order = np.argsort(-coarse, kind="stable")
    best, best_k = -math.inf, int(order[0])
    for k in order:
        if coarse[k] <= best:
            break
        fine = command_arc_limit(
            arm, where[k][1], circle, tolerance_mm, tb, tip, nodes=nodes, anywhere=True
        )
        if fine > best:
            best, best_k = fine, int(k)
    return SampledLimit(float(best), where[best_k][1], float(where[best_k][0]), len(where))
