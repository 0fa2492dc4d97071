"""How much of a curved curve one command can follow within the tolerance band (issue 21).

The trace bound's along part counts the joints' travel through the solution family; it does
not see that a command moves the joints *linearly*: its tool path bends only as far as the
arm's second derivatives allow, so along a tight curve it stays within the band only a few
millimetres (the seed arm's 25 mm circle: about 7 mm a command, while the family's
largest-joint length would allow 25). This module proves, for one configuration, how long an
arc of a circle any command can cover whose tool point lies within the tolerance at its start,
its middle and its end, the middle configuration being that one.

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

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.kinematics import (
    forward_frames,
    jacobian_from_frames,
    lengths_after,
    tool_point_joints,
)
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: The multipliers' minimisation (:func:`_dual_bound`): rounds of the barrier's weight (each a
#: tenth of the last) and Newton steps in each at most (a round stops when converged).
_BARRIER_ROUNDS = 10
_NEWTON_STEPS = 30
#: Rounds of :func:`command_arc_limit`: each takes the chord the last one proved as a bound on
#: any command's (it tightens how far the chord may lean off the tangent); it stops earlier
#: when a round proves no shorter chord.
_CHORD_ROUNDS = 4


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
    J = jacobian_from_frames(arm, frames[None])[0][:3]
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


def _dual_bound(
    g: FloatArray, blocks: list[FloatArray], limits: FloatArray, steps: FloatArray
) -> float:
    """An upper bound on ``g'D`` over ``|D_i| <= steps_i`` and ``D'B_l D <= limits_l`` (each
    ``B_l`` symmetric), by weak duality (see the module): ``f = g' P^-1 g / 4 + mult . caps``
    for nonnegative multipliers ``mult`` of every constraint (the box's as ``D_i^2 <=
    steps_i^2``), ``P`` the constraints' matrices summed with them, positive definite. ``f``
    is convex in the multipliers; they are found by Newton steps on ``f`` less logarithmic
    barriers of ``mult`` and ``det P`` (an interior-point method, its weight shrunk
    :data:`_BARRIER_ROUNDS` times), from the box's own multipliers (with the others nil the
    bound is ``sum |g_i| steps_i``). Any multipliers give a bound: the one returned is ``f`` of
    those the steps reached (or the box's, where that is less)."""
    k = g.size
    mats = np.asarray([*blocks, *(np.diag(e) for e in np.eye(k))])
    caps = np.concatenate([limits, steps**2])
    widest = float(np.sum(np.abs(g) * steps))

    def factor(mult: FloatArray) -> FloatArray | None:
        try:
            return np.asarray(np.linalg.cholesky(np.einsum("l,lab->ab", mult, mats)))
        except np.linalg.LinAlgError:
            return None

    def bound(mult: FloatArray, L: FloatArray) -> float:
        y = np.linalg.solve(L, g)
        return float(y @ y) / 4.0 + float(mult @ caps)

    box = np.maximum(np.abs(g), 1e-12 * max(float(np.abs(g).max()), 1.0)) / (2.0 * steps)
    scale = [1e-2 * float(box.mean()) / max(float(np.abs(B).max()), 1e-300) for B in blocks]
    mult = np.concatenate([scale, box])
    L = factor(mult)
    if L is None:
        return widest
    weight = 1e-2 * bound(mult, L) / mult.size
    for _ in range(_BARRIER_ROUNDS):
        for _ in range(_NEWTON_STEPS):
            assert L is not None
            y = np.linalg.solve(L.T, np.linalg.solve(L, g))
            By = np.einsum("lab,b->la", mats, y)
            Linv = np.linalg.inv(L)
            Pinv = Linv.T @ Linv
            PB = np.einsum("ab,lbc->lac", Pinv, mats)  # P^-1 B_l
            grad = caps - By @ y / 4.0 - weight * (np.einsum("laa->l", PB) + 1.0 / mult)
            hess = 0.5 * By @ Pinv @ By.T + weight * (
                np.einsum("lab,mba->lm", PB, PB) + np.diag(1.0 / mult**2)
            )
            try:
                step = -np.linalg.solve(hess, grad)
            except np.linalg.LinAlgError:
                break
            decrement = -float(step @ grad)
            if decrement < 1e-12 * (abs(weight) + 1.0):
                break
            # the longest step that keeps every multiplier positive, then backtracking
            shrink = step < 0
            t = (
                min(1.0, 0.99 * float(np.min(-mult[shrink] / step[shrink])))
                if shrink.any()
                else 1.0
            )

            def merit(m: FloatArray, Lm: FloatArray, weight: float = weight) -> float:
                return bound(m, Lm) - weight * (
                    2.0 * float(np.sum(np.log(np.diag(Lm)))) + float(np.sum(np.log(m)))
                )

            here = merit(mult, L)
            for _ in range(50):
                trial = mult + t * step
                L_trial = factor(trial)
                if L_trial is not None and merit(trial, L_trial) <= here - 0.25 * t * decrement:
                    break
                t *= 0.5
            else:
                break
            mult, L = trial, L_trial
        weight *= 0.1
    assert L is not None
    return min(bound(mult, L), widest)


def command_arc_limit(
    arm: SerialArm,
    q_mid: FloatArray,
    circle: Circle,
    tolerance_mm: float,
    taylor: TaylorBounds | None = None,
    moves: BoolArray | None = None,
) -> float:
    """The longest arc (mm) of ``circle`` between the points nearest the start and the end of
    any command whose middle configuration is ``q_mid`` (rad / mm) and whose tool point lies
    within ``tolerance_mm`` of the circle at its start, middle and end (see the module); 0
    where ``q_mid``'s own tool point lies farther than that from the circle; inf where the
    circle is too tight for the lemma (its radius within the path's bend and the tolerance)
    or too small for the arc to be told from the chord, and for an arm whose lengths are not
    in mm."""
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
    if math.hypot(radius_a - R, float(a @ b)) > tol:
        return 0.0  # no command through q_mid has its middle within the tolerance
    slack = R + tol - radius_a  # how far inside the outer circle it lies, 0 to 2 tol
    r = a_plane / radius_a
    t = np.cross(b, r)
    J = jacobian_from_frames(arm, frames[None])[0][:3][:, tip]
    H = tool_point_hessian(arm, q_mid)[:, tip][:, :, tip]
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
        along = _dual_bound(g, blocks, limits, steps) + e_c
        # every command through q_mid has |c| at most this: the next round may use it
        tighter = math.sqrt(along**2 + radial**2 + (2.0 * tol) ** 2)
        if tighter >= chord:
            break
        chord = tighter
    if chord + 2.0 * tol >= 2.0 * R:
        return math.inf
    return 2.0 * R * math.asin((chord + 2.0 * tol) / (2.0 * R))
