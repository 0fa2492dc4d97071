"""How far the tool point can get from a point of an arm's own frame: a proven largest distance.

The carriage bound (:mod:`armpath.planning.bounds.carriage`) needs a ball, fixed to the
carriage, that holds every tool point the arm on it can take. The lengths of the chain summed
give one (every revolute joint keeps the lengths of the transforms after it), but offsets at
right angles add up there as if in a line: a UR5 with a 120 mm torch, 1218 mm summed, reaches
about 1130 mm. This module finds the largest distance itself, proven, by branch and bound over
the joints after the carriage.

Over a box of joint values (centre ``c``, half widths ``h``) the squared distance
``G(q) = |p(q) - o|^2`` from the centre ``o`` to the tool point ``p`` is at most

    G(c) + sum_i |dG/dq_i (c)| h_i + 0.5 * B,
    B = 2 * ((sum_i r_i h_i)^2 + D * sum_ij r_max(i,j) h_i h_j),

from Taylor's theorem: each first derivative of the tool point is a joint's twist applied to it,
at most ``r_i`` long in the box (the distance from the tool point to joint ``i``'s axis: at the
centre, plus how far the later joints can move the point in the box, and never more than
:func:`~armpath.kinematics.displacement_bounds`; 1 for a prismatic joint), each second
derivative ``d2p/dq_i dq_j`` is the earlier joint's rotation applied to the later one's
twist, at most ``r_max(i,j)`` (the later joint's bound) long, and ``D`` is an upper bound of
``|p - o|`` in the box (its centre's plus the first order, at most the summed lengths). A
second bound takes Taylor one order further: ``G``'s Hessian at the centre (exact: the point's
second derivatives are the earlier joint's axis across the later one's column), its largest
value over the box bounded (concave near a farthest point, where it is at most the
unconstrained maximum), and the third derivatives bounded as the second were; each box takes
the lower of the two (for up to :data:`HESSIAN_JOINTS` free joints). Boxes whose bound is
within :data:`DISTANCE_SLACK` of the largest distance found at a centre are dropped, the
others split across the joint that contributes most; the largest bound of all the boxes,
dropped or left, is the proven distance. A budget of boxes ends the search: its result
stays a proof, only less tight.

The centre is put on the axis of the first revolute joint after the carriage (that joint then
leaves every distance as it is and drops out), where the largest sampled distance is least.

A ball about one centre overstates how far the tool point gets at a height well above or below
it. :func:`farthest_from_axis` bounds, by the same search, the distance from that axis itself
(the part of ``p - o`` square to it) of the tool points between two heights along it: a box
whose heights (bounded as the distance is) miss them is dropped, and the largest distance met
is taken at box centres stepped onto the heights. Between the heights ``G`` is at most
``G - lam (height - middle) + |lam| (half the band)`` whatever ``lam``; each box bounds that
sum too, with ``lam`` the multiplier at its centre (``G``'s gradient along the height's), so
a box need not be thin across the heights to be dropped (the track cell's table height:
51,000 boxes in 0.3 s, not 1.5 million in 5 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.kinematics import (
    displacement_bounds,
    forward_frames,
    jacobian_from_frames,
    lengths_after,
    tool_point_joints,
    tool_position,
)
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]

#: The search stops when its proven distance is within this of the largest distance found
#: (model length units; mm for the arms the carriage bound takes).
DISTANCE_SLACK = 0.5
#: Most boxes evaluated in all (each one forward pass and Jacobian of the arm).
MAX_BOXES = 2_000_000
#: Boxes evaluated in one batch at most, and the numbers (8 bytes each) a batch may hold in
#: its largest arrays (every frame, the Jacobian, the point's second derivatives): fewer boxes
#: for a longer arm, about 160 MB a batch whatever its joints.
_BATCH = 100_000
_BATCH_FLOATS = 20_000_000
#: Free joints up to which each box is also bounded by Taylor to second order (its Hessian
#: grows with their square; beyond, the first-order bound alone).
HESSIAN_JOINTS = 8
#: Joint configurations sampled to place the centre along the axis.
_CENTRE_SAMPLES = 4000


@dataclass(frozen=True)
class FarthestReach:
    """The proven largest distance ``radius`` from ``centre`` to the tool point, over every
    value of the joints after joint ``after`` within their limits (model units). ``centre`` is
    a point fixed to joint ``after``'s moving frame, given in the world with that joint and
    those before it at zero; ``found`` the largest distance met at a configuration
    (``radius - found`` is what the search left open), ``boxes`` how many boxes it took,
    ``complete`` whether it ran to its slack (False: the budget of boxes ended it, and the
    distance is proven but less tight)."""

    after: int
    centre: FloatArray
    radius: float
    found: float
    boxes: int
    complete: bool


def _search_ranges(arm: SerialArm, first: int) -> tuple[FloatArray, FloatArray]:
    """Per joint from ``first`` on, the values the search covers: the limits, a revolute
    joint's no wider than one turn."""
    lo = arm.lower[first:].astype(np.float64).copy()
    hi = arm.upper[first:].astype(np.float64).copy()
    for k, joint in enumerate(arm.joints[first:]):
        if joint.kind is JointKind.REVOLUTE and (
            not (np.isfinite(lo[k]) and np.isfinite(hi[k])) or hi[k] - lo[k] >= 2 * np.pi
        ):
            lo[k], hi[k] = -np.pi, np.pi
    return lo, hi


def _tool_points(arm: SerialArm, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Tool points ``(M, 3)`` and their geometric Jacobians ``(M, 6, n)`` (rows 3-5: each
    revolute joint's axis, zero for a prismatic one) at configurations ``(M, n)``."""
    frames = forward_frames(arm, q)
    return frames[:, -1, :3, 3], jacobian_from_frames(arm, frames)


def farthest_tool_point(
    arm: SerialArm, after: int = 0, max_boxes: int = MAX_BOXES
) -> FarthestReach | None:
    """The proven largest distance from a point of joint ``after``'s moving frame to the tool
    point, over the values of the joints after it (see the module). None where a later
    prismatic joint is unlimited (the tool point has no farthest place). Computed once per
    arm (a second of search or more; cached on the arm)."""
    cache: dict[tuple[int, int], FarthestReach | None] = arm.__dict__.setdefault(
        "_farthest_tool_point", {}
    )
    key = (int(after), int(max_boxes))
    if key not in cache:
        cache[key] = _search(arm, after, max_boxes)
    return cache[key]


def _search(arm: SerialArm, after: int, max_boxes: int) -> FarthestReach | None:
    """:func:`farthest_tool_point`, searched."""
    setup = _setup(arm, after)
    if setup is None:
        return None
    rng = np.random.default_rng(0)
    sample = np.tile(setup.q_fixed, (_CENTRE_SAMPLES, 1))
    sample[:, setup.first :] = rng.uniform(
        setup.lo, setup.hi, (_CENTRE_SAMPLES, arm.n_joints - setup.first)
    )
    P = _tool_points(arm, sample)[0]
    centre_world = setup.origin.copy()
    if setup.axis is not None:
        # on the next revolute axis: that joint then keeps every distance
        a_point, a_dir = setup.axis
        d = P - a_point
        along, sq = d @ a_dir, np.einsum("ij,ij->i", d, d)
        # largest squared distance from a_point + t a_dir: max(sq - 2 t along + t^2), convex in t
        lo_t, hi_t = float(along.min()), float(along.max())
        for _ in range(80):
            m1, m2 = lo_t + (hi_t - lo_t) / 3, hi_t - (hi_t - lo_t) / 3
            f1 = np.max(sq - 2 * m1 * along) + m1 * m1
            f2 = np.max(sq - 2 * m2 * along) + m2 * m2
            lo_t, hi_t = (lo_t, m2) if f1 <= f2 else (m1, hi_t)
        centre_world = a_point + 0.5 * (lo_t + hi_t) * a_dir
    found = float(np.sqrt(np.max(np.einsum("ij,ij->i", P - centre_world, P - centre_world))))
    proven_sq, best_sq, boxes, complete = _branch_and_bound(
        arm, setup, centre_world, None, None, found * found, max_boxes
    )
    return FarthestReach(
        after=after,
        centre=centre_world,
        radius=float(np.sqrt(proven_sq)),
        found=float(np.sqrt(best_sq)),
        boxes=boxes,
        complete=complete,
    )


@dataclass(frozen=True)
class AxisReach:
    """The proven largest distance ``radius`` from the axis of joint ``after + 1`` (revolute)
    to the tool point, over every value of the joints after joint ``after`` within their
    limits that puts the tool point between ``heights`` along that axis (model units). The
    axis passes through ``axis_point`` along ``axis_dir`` (unit), given in the world with joint
    ``after`` and those before it at zero; heights are measured from ``axis_point``.
    ``radius`` is ``-inf`` where no tool point lies between the heights. ``found`` is the
    largest distance met at a configuration whose tool point lies between them (nan: none
    met), ``boxes`` how many boxes the search took, ``complete`` as in
    :class:`FarthestReach`."""

    after: int
    axis_point: FloatArray
    axis_dir: FloatArray
    heights: tuple[float, float]
    radius: float
    found: float
    boxes: int
    complete: bool


def farthest_from_axis(
    arm: SerialArm,
    after: int,
    height_lo: float,
    height_hi: float,
    max_boxes: int = MAX_BOXES,
) -> AxisReach | None:
    """The proven largest distance from the axis of joint ``after + 1`` to the tool point
    among the tool points between ``height_lo`` and ``height_hi`` along that axis (see
    :class:`AxisReach`): a ring, not a ball, for the tool points at a target's height, by the
    branch and bound of :func:`farthest_tool_point` with the distance taken square to the axis
    and every box dropped whose tool points provably miss the heights. None where joint
    ``after + 1`` is not revolute or a later prismatic joint is unlimited. Cached on the arm
    per heights (widened outward to whole millionths)."""
    cache: dict[tuple[int, float, float, int], AxisReach | None] = arm.__dict__.setdefault(
        "_farthest_from_axis", {}
    )
    lo = math.floor(float(height_lo) * 1e6) / 1e6
    hi = math.ceil(float(height_hi) * 1e6) / 1e6
    key = (int(after), lo, hi, int(max_boxes))
    if key not in cache:
        cache[key] = _search_ring(arm, after, key[1], key[2], max_boxes)
    return cache[key]


def _search_ring(
    arm: SerialArm, after: int, height_lo: float, height_hi: float, max_boxes: int
) -> AxisReach | None:
    """:func:`farthest_from_axis`, searched."""
    setup = _setup(arm, after)
    if setup is None or setup.axis is None:
        return None
    a_point, a_dir = setup.axis
    proven_sq, best_sq, boxes, complete = _branch_and_bound(
        arm, setup, a_point, a_dir, (height_lo, height_hi), -np.inf, max_boxes
    )
    return AxisReach(
        after=after,
        axis_point=a_point,
        axis_dir=a_dir,
        heights=(height_lo, height_hi),
        radius=float(np.sqrt(proven_sq)) if proven_sq >= 0 else -np.inf,
        found=float(np.sqrt(best_sq)) if best_sq >= 0 else float("nan"),
        boxes=boxes,
        complete=complete,
    )


@dataclass(frozen=True)
class _Setup:
    """What both searches start from: the joints searched (``first`` on, ranges ``lo, hi``),
    the configuration they vary (``q_fixed``: zero), the world origin of joint ``after``'s
    moving frame there, the free joints (those that move the tool point; the next revolute
    one left out) and the next revolute joint's axis (point, unit direction) or None."""

    first: int
    lo: FloatArray
    hi: FloatArray
    q_fixed: FloatArray
    origin: FloatArray
    free: NDArray[np.intp]
    axis: tuple[FloatArray, FloatArray] | None


def next_axis(arm: SerialArm, after: int) -> tuple[FloatArray, FloatArray] | None:
    """The axis of joint ``after + 1`` where it is revolute (a point on it and its unit
    direction, in the world with joint ``after`` and those before it at zero), the axis
    :func:`farthest_from_axis` measures from; None where it is not revolute or a searched
    range is unbounded."""
    setup = _setup(arm, after)
    return None if setup is None else setup.axis


def _setup(arm: SerialArm, after: int) -> _Setup | None:
    """The searches' start (:class:`_Setup`); None where a searched range is unbounded."""
    n = arm.n_joints
    first = after + 1
    lo, hi = _search_ranges(arm, first)
    if not np.all(np.isfinite(lo) & np.isfinite(hi)):
        return None
    # configurations with joint ``after`` (and those before it) at zero: the frame it moves
    # stays where it is at zero, and distances in it are the same at any of its values
    q_fixed = np.zeros(n)
    frames0 = forward_frames(arm, q_fixed[None])[0]
    T_after = frames0[after + 1]  # the world frame of joint ``after`` after its motion, at zero
    moving = np.zeros(n, dtype=bool)
    moving[first:] = True
    moving &= tool_point_joints(arm)
    axis = None
    if first < n and arm.joints[first].kind is JointKind.REVOLUTE:
        axis_frame = frames0[first + 1]  # its frame turns about its own axis
        a_dir = axis_frame[:3, :3] @ arm.joints[first].axis
        axis = (axis_frame[:3, 3].copy(), a_dir / np.linalg.norm(a_dir))
        moving[first] = False  # it keeps every distance from (and height along) its axis
    return _Setup(first, lo, hi, q_fixed, T_after[:3, 3].copy(), np.flatnonzero(moving), axis)


def _branch_and_bound(
    arm: SerialArm,
    setup: _Setup,
    centre: FloatArray,
    axis_dir: FloatArray | None,
    heights: tuple[float, float] | None,
    found_sq: float,
    max_boxes: int,
) -> tuple[float, float, int, bool]:
    """The search of the module over the free joints' boxes: (the proven largest squared
    distance, at most that of ``D``, the summed lengths from the centre, which holds where the
    budget allowed no box; the largest met; boxes taken; whether every box was dropped: False
    where the budget ended the search). The distance is from ``centre``, or with
    ``axis_dir`` from the axis through ``centre`` along it (the part square to it); with
    ``heights`` only tool points whose height along the axis from ``centre`` lies between
    them count: a box is dropped where its heights, bounded as the distance is, miss them,
    and each box's centre is also stepped onto the middle height (one Newton step) for a
    tool point that counts. ``found_sq`` is the largest squared distance already met
    (``-inf``: none)."""
    lo, hi = setup.lo, setup.hi
    first, free = setup.first, setup.free
    r = displacement_bounds(arm)[free]
    D = float(np.linalg.norm(centre - setup.origin)) + lengths_after(arm, setup.first - 1)
    box_lo = lo[free - first][None, :].copy()
    box_hi = hi[free - first][None, :].copy()
    second_order = free.size <= HESSIAN_JOINTS
    n = arm.n_joints
    per_box = 16 * (n + 2) + 6 * n + (3 * free.size**2 if second_order else 0)
    batch = int(max(1000, min(_BATCH, _BATCH_FLOATS // per_box)))
    best_sq = found_sq
    boxes = 0
    dropped_sq = found_sq  # the largest bound of a box dropped (the found distance's own)
    open_sq = np.inf  # the largest bound of the boxes not yet dropped (none evaluated: inf)
    while box_lo.shape[0]:
        if boxes + box_lo.shape[0] > max_boxes:
            break
        boxes += box_lo.shape[0]
        upper = np.empty(box_lo.shape[0])
        grad_part = np.empty_like(box_lo)
        for start in range(0, box_lo.shape[0], batch):
            sl = slice(start, start + batch)
            c, h = 0.5 * (box_lo[sl] + box_hi[sl]), 0.5 * (box_hi[sl] - box_lo[sl])
            q = np.tile(setup.q_fixed, (c.shape[0], 1))
            q[:, free] = c
            p, J6 = _tool_points(arm, q)
            e, Jf = p - centre, J6[:, :3, free]
            # each column's length: the tool point's distance from that joint's axis
            R, first_order, second, pair_share = _box_derivative_bounds(
                np.linalg.norm(Jf, axis=1), r, h
            )
            # second derivatives of the tool point: the earlier joint's axis across the later
            # one's column (zero where the earlier joint slides)
            Hp = _point_hessians(J6[:, 3:, free], Jf) if second_order else None
            if axis_dir is not None:
                height = e @ axis_dir
                height_grad = np.einsum("j,mjk->mk", axis_dir, Jf)
                e = e - height[:, None] * axis_dir
                Jf = Jf - axis_dir[None, :, None] * height_grad[:, None, :]
            G = np.einsum("ij,ij->i", e, e)
            grad = 2.0 * np.einsum("ij,ijk->ik", e, Jf)
            lin = np.abs(grad) * h
            # the distance anywhere in the box: at most its centre's plus the first order
            far = np.minimum(D, np.sqrt(G) + first_order)
            # Taylor to first order with the second bounded, and to second order (the
            # centre's Hessian, concave near a farthest point) with the third bounded
            bound = G + lin.sum(axis=1) + (first_order**2 + far * second)
            if Hp is not None:
                hessian = 2.0 * (
                    np.einsum("mki,mkj->mij", Jf, Jf) + np.einsum("mk,mkij->mij", e, Hp)
                )
                third = _third_order(R, h)
                bound = np.minimum(
                    bound,
                    G
                    + _quadratic_max(grad, hessian, h)
                    + (second * first_order + far * third / 3.0),
                )
            if heights is not None and axis_dir is not None:
                # on the heights, G is at most G - lam (height - middle) + |lam| (half the
                # band), whatever lam: with each box's multiplier at its centre the bound
                # of that sum is flat across the heights (a box need not be thin in them)
                middle, half_band = 0.5 * (heights[0] + heights[1]), 0.5 * (heights[1] - heights[0])
                g2 = np.einsum("mi,mi->m", height_grad, height_grad)
                lam = np.where(
                    g2 > 1e-12,
                    np.einsum("mi,mi->m", grad, height_grad) / np.maximum(g2, 1e-12),
                    0.0,
                )
                grad_l = grad - lam[:, None] * height_grad
                at_centre = G - lam * (height - middle) + np.abs(lam) * half_band
                relaxed = at_centre + (
                    (np.abs(grad_l) * h).sum(axis=1)
                    + (first_order**2 + far * second + 0.5 * np.abs(lam) * second)
                )
                if Hp is not None:
                    hessian_l = hessian - lam[:, None, None] * np.einsum(
                        "k,mkij->mij", axis_dir, Hp
                    )
                    relaxed = np.minimum(
                        relaxed,
                        at_centre
                        + _quadratic_max(grad_l, hessian_l, h)
                        + (second * first_order + far * third / 3.0 + np.abs(lam) * third / 6.0),
                    )
                bound = np.minimum(bound, relaxed)
            # what each joint adds: its linear part and its share of the quadratic one
            grad_part[sl] = lin + h * (R * first_order[:, None] + far[:, None] * pair_share)
            if heights is None or axis_dir is None:
                best_sq = max(best_sq, float(G.max()))
            else:
                h_lo, h_hi = heights
                spread = (np.abs(height_grad) * h).sum(axis=1) + 0.5 * second
                possible = (height + spread >= h_lo) & (height - spread <= h_hi)
                bound[~possible] = -np.inf
                inside = possible & (height >= h_lo) & (height <= h_hi)
                if np.any(inside):
                    best_sq = max(best_sq, float(G[inside].max()))
                best_sq = max(
                    best_sq,
                    _stepped_onto(
                        arm,
                        setup,
                        q,
                        centre,
                        axis_dir,
                        heights,
                        # only where the box may still hold a farther tool point
                        possible & (bound > best_sq + _slack_sq(best_sq)),
                        height,
                        height_grad,
                        g2,
                    ),
                )
            upper[sl] = bound
        keep = upper > best_sq + _slack_sq(best_sq)
        if np.any(~keep):
            dropped_sq = max(dropped_sq, float(upper[~keep].max()))
        if not np.any(keep):
            open_sq = -np.inf
            box_lo = box_lo[:0]
            break
        # the kept boxes' halves are within their bounds, whether split again or not
        open_sq = float(upper[keep].max())
        box_lo, box_hi, grad_part = box_lo[keep], box_hi[keep], grad_part[keep]
        # split each box in two across the joint that adds most
        k = np.argmax(grad_part, axis=1)
        rows = np.arange(box_lo.shape[0])
        mid = 0.5 * (box_lo[rows, k] + box_hi[rows, k])
        lo_a, hi_a = box_lo.copy(), box_hi.copy()
        hi_a[rows, k] = mid
        lo_b, hi_b = box_lo.copy(), box_hi.copy()
        lo_b[rows, k] = mid
        box_lo, box_hi = np.concatenate([lo_a, lo_b]), np.concatenate([hi_a, hi_b])
    # every box is dropped or open (the budget ran out): the largest of their bounds
    return min(max(dropped_sq, open_sq), D * D), best_sq, boxes, open_sq == -np.inf


def _box_derivative_bounds(
    column: FloatArray, r: FloatArray, h: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Bounds of the tool point's derivatives over boxes of the free joints (in chain order),
    from each joint's Jacobian column's length at the box's centre ``column (M, F)`` (the
    tool point's distance from a revolute joint's axis; 1 for a prismatic one), the arm's
    bounds ``r (F,)`` and the half widths ``h (M, F)``:

    * ``R (M, F)``: the longest first derivative ``|dp/dq_i|`` in the box. The distance from
      joint ``i``'s axis changes only with the joints after it (those before move the axis
      and the point together), each moving the point at most its own bound, so it is at
      most the centre's plus ``sum_{k > i} R_k h_k`` (and at most ``r_i``);
    * ``first (M,)``: ``sum_i R_i h_i``, how far the tool point moves in the box;
    * ``second (M,)``: ``sum_ij R_max(i,j) h_i h_j``: a second derivative ``d2p/dq_i dq_j``
      is the earlier joint's turn of the later one's first derivative, no longer than it;
    * ``share (M, F)``: ``sum_j R_max(i,j) h_j`` per joint ``i`` (its part of ``second``)."""
    R = np.empty_like(column)
    tail = np.zeros(column.shape[0])  # sum over the later joints of R_k h_k
    for k in range(column.shape[1] - 1, -1, -1):
        R[:, k] = np.minimum(r[k], column[:, k] + tail)
        tail = tail + R[:, k] * h[:, k]
    first = tail
    before = np.cumsum(h, axis=1) - h  # sum of h_j over the earlier joints
    second = np.einsum("mk,mk->m", R * h, h + 2.0 * before)
    later = np.cumsum((R * h)[:, ::-1], axis=1)[:, ::-1] - R * h  # sum of R_j h_j, j later
    share = R * (before + h) + later
    return R, first, second, share


def _point_hessians(axes: FloatArray, columns: FloatArray) -> FloatArray:
    """Second derivatives ``d2p/dq_i dq_j (M, 3, F, F)`` of the tool point from the joints'
    axes ``(M, 3, F)`` (zero for a prismatic joint) and Jacobian columns ``(M, 3, F)``, in
    chain order: the earlier joint's axis across the later one's column (a turn of the earlier
    joint turns the later column with the rest of the chain)."""
    crossed = np.cross(axes[:, :, :, None], columns[:, :, None, :], axis=1)  # axis_i x col_j
    F = axes.shape[2]
    later = np.arange(F)[None, :] >= np.arange(F)[:, None]  # j >= i
    return np.where(later, crossed, np.swapaxes(crossed, 2, 3))


def _quadratic_max(grad: FloatArray, hessian: FloatArray, h: FloatArray) -> FloatArray:
    """Upper bounds ``(M,)`` of ``g . d + d' H d / 2`` over each box ``|d_i| <= h_i``: the
    least of the term by term bound, the gradient's bound with the largest eigenvalue's
    curvature, and where ``H`` is negative definite its unconstrained largest value."""
    lin = (np.abs(grad) * h).sum(axis=1)
    off = np.abs(hessian)
    diag = np.einsum("mii->mi", hessian)
    idx = np.arange(h.shape[1])
    off[:, idx, idx] = np.maximum(diag, 0.0)
    termwise = lin + 0.5 * np.einsum("mi,mij,mj->m", h, off, h)
    eig = np.linalg.eigvalsh(hessian)
    top = eig[:, -1]
    curved = lin + 0.5 * np.maximum(top, 0.0) * np.einsum("mi,mi->m", h, h)
    out = np.minimum(termwise, curved)
    concave = top < -1e-9 * np.maximum(1.0, np.abs(eig[:, 0]))  # and not near singular
    if np.any(concave):
        x = np.linalg.solve(-hessian[concave], grad[concave][:, :, None])[:, :, 0]
        out[concave] = np.minimum(out[concave], 0.5 * np.einsum("mi,mi->m", grad[concave], x))
    return np.asarray(out, dtype=np.float64)


def _third_order(R: FloatArray, h: FloatArray) -> FloatArray:
    """``sum_ijk R_max(i,j,k) h_i h_j h_k (M,)`` (the latest joint's bound per triple): the
    triples whose latest joint is ``k`` sum to the cube of the half widths up to ``k`` less
    the cube of those before it."""
    upto = np.cumsum(h, axis=1)
    return np.asarray(np.einsum("mk,mk->m", R, upto**3 - (upto - h) ** 3), dtype=np.float64)


def _slack_sq(best_sq: float) -> float:
    """What a box's squared bound may exceed ``best_sq`` by and still be dropped: the
    search's slack (:data:`DISTANCE_SLACK`) in distance."""
    best = max(best_sq, 0.0)
    return float((np.sqrt(best) + DISTANCE_SLACK) ** 2 - best)


def _stepped_onto(
    arm: SerialArm,
    setup: _Setup,
    q: FloatArray,
    centre: FloatArray,
    axis_dir: FloatArray,
    heights: tuple[float, float],
    rows: NDArray[np.bool_],
    height: FloatArray,
    height_grad: FloatArray,
    g2: FloatArray,
) -> float:
    """The largest squared distance from the axis of a tool point between ``heights``, met
    after one Newton step of the ``rows`` of ``q`` onto the middle height (``height_grad``
    the heights' gradients in the free joints, ``g2`` their squared lengths; within the
    joints' ranges); ``-inf`` where none is."""
    free = setup.free
    rows = rows & (g2 > 1e-12)
    if not np.any(rows):
        return -np.inf
    step = (height[rows] - 0.5 * (heights[0] + heights[1])) / g2[rows]
    q2 = q[rows].copy()
    q2[:, free] -= step[:, None] * height_grad[rows]
    lo, hi = setup.lo[free - setup.first], setup.hi[free - setup.first]
    q2 = q2[np.all((q2[:, free] >= lo) & (q2[:, free] <= hi), axis=1)]
    if q2.shape[0] == 0:
        return -np.inf
    e = tool_position(arm, q2) - centre
    height2 = e @ axis_dir
    ok = (height2 >= heights[0]) & (height2 <= heights[1])
    if not np.any(ok):
        return -np.inf
    e = e[ok] - height2[ok, None] * axis_dir
    return float(np.einsum("ij,ij->i", e, e).max())


__all__ = [
    "DISTANCE_SLACK",
    "MAX_BOXES",
    "AxisReach",
    "FarthestReach",
    "farthest_from_axis",
    "farthest_tool_point",
    "next_axis",
]
