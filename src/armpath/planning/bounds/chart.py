"""A chart of the tool directions with the family's singular directions blown up.

The bounds sample the family at a point along tool directions (:mod:`.sampling`), and each
sample's error box spans what the members of its neighbouring directions differ by. At some
directions the members form a whole curve: a six-joint arm whose wrist is straight (the axes
of joints 4 and 6 in line, the tool along them) keeps its tool where it is while joints 2-4
turn together, so the single direction along that line has a curve of members, and the
members of directions near it lie near a point of that curve that depends on the side from
which the direction comes (its azimuth about the singular direction). A cell that touches such
a direction spans the whole curve however small it is, and the bound can pick any corner of
that box (issue 21: the UR5 cell's welds held at 64 commands, joint 4's errors 20-28 commands).

The chart here blows such a direction ``center`` up into a circle, one point per azimuth: a
virtual direction at angle ``rho`` from the centre, ``inner <= rho <= outer``, stands for the
real direction at angle :func:`real_radius` ``(rho)`` from it with the same azimuth, from
:data:`RING_RADIUS` on the circle ``rho = inner`` out to ``outer``; beyond ``outer`` the chart
is the identity; within ``inner`` (the hole) nothing is sampled. A cell on the circle spans a
short arc of azimuth, whose members lie close together on the curve, so splitting it shrinks
its errors as anywhere else. The chart covers every real direction: the directions beyond
:data:`RING_RADIUS` once, those closer to the centre by the circle's cells (their members lie
within the azimuths' boxes as the radius goes to zero).

The singular directions are found where the family's differential loses rank
(:func:`singular_directions`): the smallest singular value of the tool point's and the tool
direction's joint Jacobian, minimised on a shrinking grid of directions from the members of
600 coarse directions where it is least among their branch's neighbours (one start per
spacing), and kept where the members about the minimum turn a long way within a tiny circle
(a blow-down: a curve of members at one direction), not where two branches merely meet.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.angles import wrap_to_pi
from armpath.geometry.primitives import orthonormal_frame
from armpath.kinematics import displacement_bounds, forward_frames, jacobian_from_frames
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Angle (rad) from a singular direction of the real directions the circle's samples stand
#: for: far above the error of the singular direction found (below ``1e-9``), far below any
#: spacing of the samples.
RING_RADIUS = 1e-5
#: Virtual radius (rad) of the circle a singular direction is blown up to, at most; beyond
#: twice it the chart is the identity.
INNER_RADIUS = 0.1
#: Samples on each circle to begin with (the search splits them further where the bound runs).
RING_SAMPLES = 48
#: Tolerance (rad) within which a virtual direction lies on a circle.
_ON_RING = 1e-9
#: The search for a singular direction: a grid of ``_GRID`` x ``_GRID`` directions about the
#: best so far, ``_SHRINK`` times narrower each round, until it is ``_LOCATE_TO`` rad wide.
_GRID = 7
_SHRINK = 3.0
_LOCATE_TO = 1e-9
#: Smallest singular value (the tool point's rows divided by the arm's longest lever) below
#: which a sample starts a search, and below which its minimum is singular.
_START_SIGMA = 0.2
_SINGULAR_SIGMA = 1e-7
#: Members of neighbouring directions this close (rad, any joint) are on one branch.
_SAME_BRANCH = 0.5
#: Two singular directions closer than this (rad) are one.
_SAME_CENTER = 1e-4
#: A singular direction is blown up when the members :data:`RING_RADIUS` about it, followed
#: round ``_WALK_STEPS`` directions each no farther than ``_WALK_STEP`` (rad, any joint) from
#: the last, go this far (rad) from the singular member: a curve of members, not a fold.
_BLOW_DOWN_SPREAD = 0.05
_WALK_STEPS = 24
_WALK_STEP = 0.6


@dataclass(frozen=True, eq=False)
class BlowUp:
    """A singular direction ``center`` (unit, real) and the virtual radii of its circle
    (``inner``) and of the edge of the chart about it (``outer``), rad."""

    center: FloatArray
    inner: float
    outer: float


def _polar(v: FloatArray, c: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Angles ``rho (M,)`` of unit vectors ``v (M, 3)`` from ``c`` and their azimuth vectors
    (unit, across ``c``; any where ``v`` is ``c``)."""
    along = v @ c
    across = v - along[:, None] * c
    norm = np.linalg.norm(across, axis=1)
    rho = np.arctan2(norm, along)
    e1, _ = orthonormal_frame(c)
    w = np.where(norm[:, None] > 0.0, across / np.where(norm > 0.0, norm, 1.0)[:, None], e1)
    return rho, w


def real_radius(rho: FloatArray, cap: BlowUp) -> FloatArray:
    """The real angle from the centre of virtual angles ``rho`` within ``cap``'s chart: from
    :data:`RING_RADIUS` on the circle (and in the hole) to ``outer`` at the chart's edge."""
    t = np.clip((rho - cap.inner) / (cap.outer - cap.inner), 0.0, 1.0)
    return np.asarray(RING_RADIUS + t * (cap.outer - RING_RADIUS), dtype=np.float64)


def to_real(v: FloatArray, caps: tuple[BlowUp, ...]) -> FloatArray:
    """The real directions ``(M, 3)`` of virtual directions ``v (M, 3)``."""
    out = np.array(v, dtype=np.float64, copy=True)
    for cap in caps:
        rho, w = _polar(out, cap.center)
        near = rho < cap.outer
        if np.any(near):
            r = real_radius(rho[near], cap)
            out[near] = np.cos(r)[:, None] * cap.center + np.sin(r)[:, None] * w[near]
    return out


def ring(cap: BlowUp, count: int = RING_SAMPLES) -> FloatArray:
    """``count`` virtual directions evenly spaced on ``cap``'s circle."""
    e1, e2 = orthonormal_frame(cap.center)
    a = 2.0 * np.pi * np.arange(count) / count
    w = np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2
    return np.asarray(np.cos(cap.inner) * cap.center + np.sin(cap.inner) * w, dtype=np.float64)


def ring_of(v: FloatArray, caps: tuple[BlowUp, ...]) -> IntArray:
    """Per virtual direction, the index of the circle it lies on, or -1."""
    out = np.full(v.shape[0], -1, dtype=np.int64)
    for k, cap in enumerate(caps):
        rho, _ = _polar(v, cap.center)
        out[np.abs(rho - cap.inner) <= _ON_RING] = k
    return out


def real_within(v: FloatArray, caps: tuple[BlowUp, ...], angle: FloatArray) -> BoolArray:
    """Virtual directions ``v (M, 3)`` about which the chart is the identity out to ``angle``
    ``(M,)`` rad: every direction within that angle of one lies beyond every cap's ``outer``,
    so its real and virtual angles to ``v`` are one."""
    ok = np.ones(v.shape[0], dtype=bool)
    for cap in caps:
        ok &= _polar(v, cap.center)[0] >= cap.outer + angle
    return ok


def outside_holes(v: FloatArray, caps: tuple[BlowUp, ...]) -> BoolArray:
    """Virtual directions on or outside every circle (the chart's domain)."""
    ok = np.ones(v.shape[0], dtype=bool)
    for cap in caps:
        ok &= _polar(v, cap.center)[0] >= cap.inner - _ON_RING
    return ok


def snapped(v: FloatArray, caps: tuple[BlowUp, ...]) -> FloatArray:
    """Virtual directions ``v`` with those in a hole moved out onto its circle (same azimuth):
    the midpoint of two points of a circle lies inside it."""
    out = np.array(v, dtype=np.float64, copy=True)
    for cap in caps:
        rho, w = _polar(out, cap.center)
        inside = rho < cap.inner
        out[inside] = np.cos(cap.inner) * cap.center + np.sin(cap.inner) * w[inside]
    return out


def _sigma_min(arm: SerialArm, q: FloatArray, tip: BoolArray, lever: float) -> FloatArray:
    """Smallest singular value of the joint Jacobian of the tool point (divided by ``lever``)
    and of the tool direction across itself, over the ``tip`` joints, per configuration."""
    frames = forward_frames(arm, q)  # the last is the tool's
    J = jacobian_from_frames(arm, frames)[:, :, tip]
    a = frames[:, -1, :3, :3] @ np.asarray(arm.approach_axis)
    e1, e2 = orthonormal_frame(a)
    da = np.cross(np.swapaxes(J[:, 3:, :], 1, 2), a[:, None, :])  # (M, J, 3)
    M = np.concatenate(
        [
            J[:, :3, :] / lever,
            np.einsum("mk,mjk->mj", e1, da)[:, None, :],
            np.einsum("mk,mjk->mj", e2, da)[:, None, :],
        ],
        axis=1,
    )
    return np.asarray(np.linalg.svd(M, compute_uv=False)[:, -1], dtype=np.float64)


def singular_directions(
    arm: SerialArm,
    tip: BoolArray,
    members: Callable[[FloatArray], tuple[FloatArray, IntArray]],
    dirs: FloatArray,
    spacing: float,
) -> list[FloatArray]:
    """The blown-down directions of a family whose tip joints are five (the tool point and its
    direction fix them up to finitely many: the family is two-dimensional, a chart of
    directions can cover it), found from the directions ``dirs (D, 3)`` about ``spacing`` rad
    apart: each a unit direction. ``members(d (K, 3))`` gives
    the members ``(m, n)`` at directions ``d`` and the index into ``d`` of each."""
    if int(tip.sum()) != 5 or dirs.shape[0] == 0:
        return []
    lever = float(max(displacement_bounds(arm)[tip].max(), 1e-9))
    q, index = members(dirs)
    if q.shape[0] == 0:
        return []
    sigma = _sigma_min(arm, q, tip, lever)
    # starts: members whose value is least among the members of the same branch (within
    # _SAME_BRANCH) at the directions within 1.5 spacings
    i, j = _neighbour_members(dirs, index, 1.5 * spacing)
    same = _apart(q[i], q[j], tip) < _SAME_BRANCH
    low = sigma.copy()
    np.minimum.at(low, i[same], sigma[j[same]])
    starts = np.flatnonzero((sigma <= low) & (sigma < _START_SIGMA))
    # one start per spacing (the least): a blow-down's whole curve of members lies at one
    # direction, and its members each start a search that ends there
    kept: list[int] = []
    for k in starts[np.argsort(sigma[starts], kind="stable")]:
        if all(float(dirs[index[k]] @ dirs[index[j]]) < np.cos(spacing) for j in kept):
            kept.append(int(k))
    starts = np.array(kept, dtype=np.int64)
    if starts.size == 0:
        return []
    centers, ref = dirs[index[starts]].copy(), q[starts].copy()
    g = np.linspace(-1.0, 1.0, _GRID)
    offsets = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)  # (G, 2)
    h = spacing
    while h > _LOCATE_TO:
        frames = np.stack(orthonormal_frame(centers), axis=1)  # (S, 2, 3)
        cand = centers[:, None, :] + h * np.einsum("gk,skj->sgj", offsets, frames)
        cand = (cand / np.linalg.norm(cand, axis=-1, keepdims=True)).reshape(-1, 3)
        value, at = _tracked(arm, tip, lever, members, cand, np.repeat(ref, offsets.shape[0], 0))
        count = centers.shape[0]
        pick = np.argmin(value.reshape(count, -1), axis=1) + offsets.shape[0] * np.arange(count)
        centers, ref = cand[pick], at[pick]
        if h < spacing / 3.0:
            # starts that met (a blow-down's whole curve of members leads to one direction)
            best = value[pick]
            keep: list[int] = []
            for k in np.argsort(best, kind="stable"):
                if all(float(centers[k] @ centers[j]) < np.cos(2.0 * h) for j in keep):
                    keep.append(int(k))
            centers, ref = centers[keep], ref[keep]
        h /= _SHRINK
    value, ref = _tracked(arm, tip, lever, members, centers, ref)
    found: list[FloatArray] = []
    for k in np.argsort(value):
        if value[k] > _SINGULAR_SIGMA:
            break
        if any(float(centers[k] @ c) > np.cos(_SAME_CENTER) for c in found):
            continue
        if _blown_down(tip, members, centers[k], ref[k]):
            found.append(centers[k])
    return found


def _neighbour_members(
    dirs: FloatArray, index: IntArray, angle: float
) -> tuple[IntArray, IntArray]:
    """Pairs ``(i, j)`` of members (``index``: each member's direction) whose directions
    differ, within ``angle`` rad of each other, both ways round."""
    from scipy.spatial import cKDTree

    chord = 2.0 * np.sin(min(angle, np.pi) / 2.0)
    pairs = cKDTree(dirs).query_pairs(chord, output_type="ndarray").astype(np.int64)
    pairs = np.vstack([pairs, pairs[:, ::-1]])
    order = np.argsort(index, kind="stable")
    ptr = np.searchsorted(index[order], np.arange(dirs.shape[0] + 1))
    count = np.diff(ptr)
    a, b = pairs[:, 0], pairs[:, 1]
    size = count[a] * count[b]
    which = np.repeat(np.arange(a.size), size)
    k = np.arange(int(size.sum())) - np.repeat(np.cumsum(size) - size, size)
    i = order[ptr[a[which]] + k // count[b[which]]]
    j = order[ptr[b[which]] + k % count[b[which]]]
    return i, j


def _apart(x: FloatArray, y: FloatArray, tip: BoolArray) -> FloatArray:
    """Largest difference (rad, whole turns aside) of the tip joints of ``x`` and ``y``."""
    return np.asarray(np.abs(wrap_to_pi(x[..., tip] - y[..., tip])).max(axis=-1))


def _tracked(
    arm: SerialArm,
    tip: BoolArray,
    lever: float,
    members: Callable[[FloatArray], tuple[FloatArray, IntArray]],
    d: FloatArray,
    ref: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """Per direction of ``d (K, 3)``, the least singular value of the member nearest
    ``ref[k]`` (inf without one) and that member (``ref[k]`` without one)."""
    q, index = members(d)
    value, at = np.full(d.shape[0], np.inf), ref.copy()
    if q.shape[0] == 0:
        return value, at
    gap = _apart(q, ref[index], tip)
    nearest = np.full(d.shape[0], np.inf)
    np.minimum.at(nearest, index, gap)
    take = np.flatnonzero(gap <= nearest[index])
    take = take[np.unique(index[take], return_index=True)[1]]
    value[index[take]] = _sigma_min(arm, q[take], tip, lever)
    at[index[take]] = q[take]
    return value, at


def _blown_down(
    tip: BoolArray,
    members: Callable[[FloatArray], tuple[FloatArray, IntArray]],
    center: FloatArray,
    q: FloatArray,
) -> bool:
    """Whether the members at directions :data:`RING_RADIUS` about ``center``, followed once
    round from the one nearest the singular member ``q``, each near the last, go far from
    ``q``: a curve of members at the centre. Not where two branches meet (a fold: on one
    side no member near, the walk jumps to another branch)."""
    e1, e2 = orthonormal_frame(center)
    a = np.linspace(0.0, 2.0 * np.pi, _WALK_STEPS, endpoint=False)
    d = center + RING_RADIUS * (np.cos(a)[:, None] * e1 + np.sin(a)[:, None] * e2)
    m, index = members(d / np.linalg.norm(d, axis=1, keepdims=True))
    if m.shape[0] == 0:
        return False

    first = np.argmin(_apart(m, q, tip))
    at, start = m[first], int(index[first])
    farthest = 0.0
    for k in range(1, _WALK_STEPS + 1):
        here = m[index == (start + k) % _WALK_STEPS]
        if here.shape[0] == 0:
            return False
        step = _apart(here, at, tip)
        if step.min() > _WALK_STEP:
            return False
        at = here[np.argmin(step)]
        farthest = max(farthest, float(_apart(at, q, tip)))
    return farthest > _BLOW_DOWN_SPREAD


def caps_about(centers: list[FloatArray]) -> tuple[BlowUp, ...]:
    """The blow-ups of ``centers``: each circle :data:`INNER_RADIUS` at most and a fifth of the
    way to the nearest other centre, so that the charts about them do not overlap."""
    caps = []
    for k, c in enumerate(centers):
        gaps = [float(np.arccos(np.clip(c @ o, -1.0, 1.0))) for o in centers[:k] + centers[k + 1 :]]
        inner = min([INNER_RADIUS, *(g / 5.0 for g in gaps)])
        caps.append(BlowUp(np.asarray(c, dtype=np.float64), inner, 2.0 * inner))
    return tuple(caps)
