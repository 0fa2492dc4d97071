"""The clearance rule in compiled loops: along joint-space segments (the planners' edge test)
and the smallest slacks of configurations (:func:`configurations_slacks`, behind
:meth:`CollisionWorld.smallest_slacks`).

A planner asks thousands of times whether a straight joint-space segment keeps the clearance
rule at samples along it. :func:`segments_satisfied` answers a batch of segments in one call of
:func:`_segments_clear`: per segment, the samples coarse to fine, per sample the landmarks, the
parts' capsules, each obstacle's broad phase (enclosing ball) and exact distance, then the link
pairs, stopping at the first sample that breaks the rule; samples that a neighbour's room
already proves (the Lipschitz bound of :func:`armpath.kinematics.displacement_bounds`) are
skipped. The verdict equals :meth:`CollisionWorld.satisfied` at every sample (the same kernels
on the same numbers).

Obstacles with a closed-form distance (half-spaces, spheres, capsules, boxes, solids of
revolution) are packed into flat tables (:class:`ObstacleTable`); a world with any other kind (a
mesh) has no table, and its callers use :meth:`CollisionWorld.satisfied` per batch of samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.geometry.kernels import (
    point_segments_distance,
    segment_box,
    segment_point,
    segment_revolution,
    segment_segment,
)
from armpath.geometry.primitives import (
    Box,
    Capsule,
    HalfSpace,
    Obstacle,
    SolidOfRevolution,
    Sphere,
)
from armpath.jit import njit
from armpath.kinematics import landmark_scratch, landmarks_into

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_HALF_SPACE, _SPHERE, _CAPSULE, _BOX, _REVOLUTION = range(5)
#: Room (length unit) kept back from a sample's proof of its neighbours, for rounding.
_ROUNDING = 1e-9


@dataclass(frozen=True)
class ObstacleTable:
    """Obstacles as flat arrays for the compiled loop.

    ``kinds`` one code per obstacle; ``params (O, 15)``: half-space point and normal, sphere
    centre and radius, capsule ends and radius, box centre, half extents and rotation (row
    major), solid of revolution origin and axis; ``balls (O, 4)`` enclosing ball centre and
    radius (radius inf: none); ``profiles (O, V, 2)``, ``boundary (O, V)`` and ``n_vertices``
    the solids of revolution's profiles, padded to the longest.
    """

    kinds: IntArray
    params: FloatArray
    balls: FloatArray
    profiles: FloatArray
    boundary: NDArray[np.bool_]
    n_vertices: IntArray


def obstacle_table(obstacles: tuple[Obstacle, ...]) -> ObstacleTable | None:
    """:class:`ObstacleTable` of ``obstacles``, or None when one has no closed form here."""
    count = len(obstacles)
    kinds = np.zeros(count, dtype=np.int64)
    params = np.zeros((count, 15))
    balls = np.zeros((count, 4))
    balls[:, 3] = np.inf
    longest = max(
        [o.profile.shape[0] for o in obstacles if isinstance(o, SolidOfRevolution)] or [1]
    )
    profiles = np.zeros((count, longest, 2))
    boundary = np.zeros((count, longest), dtype=bool)
    n_vertices = np.zeros(count, dtype=np.int64)
    for i, o in enumerate(obstacles):
        if isinstance(o, HalfSpace):
            kinds[i] = _HALF_SPACE
            params[i, :6] = np.r_[o.point, o.normal]
        elif isinstance(o, Sphere):
            kinds[i] = _SPHERE
            params[i, :4] = np.r_[o.center, o.radius]
        elif isinstance(o, Capsule):
            kinds[i] = _CAPSULE
            params[i, :7] = np.r_[o.start, o.end, o.radius]
        elif isinstance(o, Box):
            kinds[i] = _BOX
            params[i] = np.r_[o.center, o.half_extents, o.rotation.reshape(-1)]
        elif isinstance(o, SolidOfRevolution):
            kinds[i] = _REVOLUTION
            params[i, :6] = np.r_[o.origin, o.axis]
            n = o.profile.shape[0]
            profiles[i, :n] = o.profile
            boundary[i, :n] = o.boundary_edges
            n_vertices[i] = n
        else:
            return None
        ball = o.enclosing_ball()
        if ball is not None:
            balls[i] = np.r_[ball[0], ball[1]]
    return ObstacleTable(kinds, params, balls, profiles, boundary, n_vertices)


@njit(cache=True)
def _obstacle_distance(
    o: int,
    kinds: np.ndarray,
    params: np.ndarray,
    profiles: np.ndarray,
    boundary: np.ndarray,
    n_vertices: np.ndarray,
    p0: np.ndarray,
    p1: np.ndarray,
    seg: np.ndarray,
    k: int,
    work: np.ndarray,
    cands: np.ndarray,
) -> float:  # pragma: no cover - compiled
    """Smallest signed distance of part ``k`` (``p0[k] -> p1[k]``, also in ``seg[k]`` as six
    numbers) to obstacle ``o``: the value its class's ``segment_distance_bounds`` gives."""
    kind = kinds[o]
    c = params[o]
    if kind == _HALF_SPACE:
        d0 = (p0[k, 0] - c[0]) * c[3] + (p0[k, 1] - c[1]) * c[4] + (p0[k, 2] - c[2]) * c[5]
        d1 = (p1[k, 0] - c[0]) * c[3] + (p1[k, 1] - c[1]) * c[4] + (p1[k, 2] - c[2]) * c[5]
        return float(min(d0, d1))
    if kind == _SPHERE:
        return float(segment_point(p0, p1, k, c[0], c[1], c[2]) - c[3])
    if kind == _CAPSULE:
        a0, a1, a2 = p0[k, 0], p0[k, 1], p0[k, 2]
        b0, b1, b2 = p1[k, 0], p1[k, 1], p1[k, 2]
        return float(
            segment_segment(a0, a1, a2, b0, b1, b2, c[0], c[1], c[2], c[3], c[4], c[5]) - c[6]
        )
    if kind == _BOX:
        return float(segment_box(p0, p1, k, c[0:3], c[6:15].reshape(3, 3), c[3:6], work))
    n = n_vertices[o]
    return float(
        segment_revolution(seg, k, c[0:3], c[3:6], profiles[o, :n], boundary[o, :n], cands)
    )


@njit(cache=True)
def _parts_into(
    pts: np.ndarray,
    link_start: np.ndarray,
    link_end: np.ndarray,
    tip_exempt: float,
    tip_split: bool,
    p0: np.ndarray,
    p1: np.ndarray,
    seg: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """The parts' segments ``p0[p] -> p1[p]`` (also ``seg[p]`` as six numbers) from the
    landmarks ``pts``: the links, the last one cut ``tip_exempt`` before its end when
    ``tip_split`` (the bare tip is the extra last part), as :meth:`CollisionWorld._segments`."""
    n_links = link_start.shape[0]
    for p in range(n_links):
        for t in range(3):
            p0[p, t] = pts[link_start[p], t]
            p1[p, t] = pts[link_end[p], t]
    if tip_split:
        # the last link: its body up to the cut, then the bare tip from the cut
        last = n_links - 1
        d0 = p1[last, 0] - p0[last, 0]
        d1 = p1[last, 1] - p0[last, 1]
        d2 = p1[last, 2] - p0[last, 2]
        length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        cut = min(max(tip_exempt / (length if length > 0 else 1.0), 0.0), 1.0)
        for t in range(3):
            end = p1[last, t]
            at = end - cut * (end - p0[last, t])
            p1[n_links, t] = end
            p0[n_links, t] = at
            p1[last, t] = at
    for p in range(p0.shape[0] if tip_split else n_links):
        for t in range(3):
            seg[p, t] = p0[p, t]
            seg[p, 3 + t] = p1[p, t]


@njit(cache=True)
def _box_gap(
    p0: np.ndarray, p1: np.ndarray, k: int, c: np.ndarray
) -> float:  # pragma: no cover - compiled
    """A lower bound of the distance from segment ``p0[k] -> p1[k]`` to the box of parameters
    ``c`` (centre, half extents, rotation row major; see :class:`ObstacleTable`), as
    :meth:`armpath.geometry.primitives.Box.broad_phase`."""
    gap = -np.inf
    for axis in range(3):
        e0 = 0.0
        e1 = 0.0
        for t in range(3):
            r = c[6 + 3 * t + axis]  # rotation[t, axis]: the box axis in world coordinates
            e0 += (p0[k, t] - c[t]) * r
            e1 += (p1[k, t] - c[t]) * r
        h = c[3 + axis]
        gap = max(gap, min(e0, e1) - h, -h - max(e0, e1), -h)
    return gap


@njit(cache=True, nogil=True)
def configurations_slacks(
    q: np.ndarray,
    columns: np.ndarray,
    ceilings: np.ndarray,
    floors: np.ndarray,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
    frames: np.ndarray,
    offsets: np.ndarray,
    link_start: np.ndarray,
    link_end: np.ndarray,
    tip_exempt: float,
    tip_split: bool,
    part_radius: np.ndarray,
    need: np.ndarray,
    kinds: np.ndarray,
    params: np.ndarray,
    balls: np.ndarray,
    profiles: np.ndarray,
    boundary: np.ndarray,
    n_vertices: np.ndarray,
    self_a0: np.ndarray,
    self_a1: np.ndarray,
    self_b0: np.ndarray,
    self_b1: np.ndarray,
    self_radii: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """:meth:`CollisionWorld.smallest_slacks` in one loop: per group ``g`` (pairs
    ``columns[g]``) and configuration ``q[m]``, ``min(ceilings[g, m], smallest clearance less
    need over the group's pairs)``, exact above ``floors[g, m]``; ``(G, M)``.

    Exact above the floors, as the batched version (the same kernels on the same numbers);
    below, the two may stop at different values. The group's link pairs first, then its
    obstacle pair of lowest broad-phase bound (:func:`_broad_phase`), then the others in
    order, each measured only where its bound is below the value so far, until the value is
    at its floor. A distance is measured once per configuration whichever groups ask for it."""
    n_obs = kinds.shape[0]
    n_links = link_start.shape[0]
    n_parts = n_links + (1 if tip_split else 0)
    n_obs_cols = n_parts * n_obs
    n_self = self_radii.shape[0]
    n_groups = columns.shape[0]
    out = np.empty((n_groups, q.shape[0]))
    pts = np.empty((frames.shape[0], 3))
    scratch = landmark_scratch(q.shape[1])
    p0 = np.empty((max(n_parts, 1), 3))
    p1 = np.empty((max(n_parts, 1), 3))
    seg = np.empty((max(n_parts, 1), 6))
    work = np.empty(3)
    cands = np.empty(8 + profiles.shape[1] * 32)
    lower = np.empty(n_obs_cols)
    exact = np.empty(n_obs_cols)
    measured = np.zeros(n_obs_cols, dtype=np.bool_)
    self_slack = np.empty(n_self)
    any_self = False
    for g in range(n_groups):
        for s in range(n_self):
            any_self = any_self or columns[g, n_obs_cols + s]
    for m in range(q.shape[0]):
        landmarks_into(
            q[m], T_world_base, T_parent_joint, axes, prismatic, T_flange_tool, frames,
            offsets, scratch, pts,
        )  # fmt: skip
        _parts_into(pts, link_start, link_end, tip_exempt, tip_split, p0, p1, seg)
        for p in range(n_parts):
            for o in range(n_obs):
                k = p * n_obs + o
                measured[k] = False
                # (as the batched version rounds it; less an allowance, so a bound never
                # passes the exact value it bounds)
                lower[k] = _broad_phase(o, kinds, params, balls, p0, p1, p) - (
                    (part_radius[p] + need[k]) + _ROUNDING
                )
        if any_self:
            for s in range(n_self):
                d = point_segments_distance(pts, self_a0[s], self_a1[s], self_b0[s], self_b1[s])
                self_slack[s] = d - self_radii[s] - need[n_obs_cols + s]
        for g in range(n_groups):
            low = ceilings[g, m]
            for s in range(n_self):
                if columns[g, n_obs_cols + s]:
                    low = min(low, self_slack[s])
            first = -1
            for k in range(n_obs_cols):
                if columns[g, k] and (first < 0 or lower[k] < lower[first]):
                    first = k
            # the pair of lowest bound first, then the others in order, each measured where
            # its bound is below the value so far, until the value is at its floor
            for step in range(n_obs_cols + 1):
                k = first if step == 0 else step - 1
                if k < 0 or (step > 0 and k == first) or not columns[g, k]:
                    continue
                if low <= floors[g, m]:
                    break
                if lower[k] >= low:
                    continue
                if not measured[k]:
                    p, o = k // n_obs, k % n_obs
                    d = _obstacle_distance(
                        o, kinds, params, profiles, boundary, n_vertices, p0, p1, seg, p, work,
                        cands,
                    )  # fmt: skip
                    exact[k] = d - part_radius[p] - need[k]
                    measured[k] = True
                low = min(low, exact[k])
            out[g, m] = low
    return out


@njit(cache=True)
def _broad_phase(
    o: int,
    kinds: np.ndarray,
    params: np.ndarray,
    balls: np.ndarray,
    p0: np.ndarray,
    p1: np.ndarray,
    k: int,
) -> float:  # pragma: no cover - compiled
    """A lower bound of the signed distance of part ``k`` to obstacle ``o``, as
    :meth:`armpath.geometry.primitives.Obstacle.broad_phase` gives it: the distance to its
    enclosing ball, for a box the larger of that and the gap along its axes (-inf: none)."""
    low = -np.inf
    if balls[o, 3] < np.inf:
        low = segment_point(p0, p1, k, balls[o, 0], balls[o, 1], balls[o, 2]) - balls[o, 3]
    if kinds[o] == _BOX:
        low = max(low, _box_gap(p0, p1, k, params[o]))
    return float(low)


@njit(cache=True)
def segments_clear(
    a: np.ndarray,
    b: np.ndarray,
    counts: np.ndarray,
    strides: np.ndarray,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
    frames: np.ndarray,
    offsets: np.ndarray,
    link_start: np.ndarray,
    link_end: np.ndarray,
    tip_exempt: float,
    tip_split: bool,
    part_radius: np.ndarray,
    need: np.ndarray,
    kinds: np.ndarray,
    params: np.ndarray,
    balls: np.ndarray,
    profiles: np.ndarray,
    boundary: np.ndarray,
    n_vertices: np.ndarray,
    self_a0: np.ndarray,
    self_a1: np.ndarray,
    self_b0: np.ndarray,
    self_b1: np.ndarray,
    self_radii: np.ndarray,
    reach: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """Per segment ``a[e] -> b[e]`` sampled at ``counts[e]`` evenly spaced configurations,
    whether every sample keeps every pair's ``need`` (pairs in :meth:`CollisionWorld.pairs`
    order). Samples on the coarsest stride first (and the last), then finer; a segment stops at
    its first failing sample.

    A sample that passes with room to spare proves its neighbours pass too: ``reach`` bounds
    how far any arm point moves per unit of each joint (:func:`displacement_bounds`), so a
    pair's clearance changes by at most that much between samples (twice for two links), and
    the samples within the smallest room are not evaluated. The verdict is the same."""
    n_edges, n_j = a.shape
    n_obs = kinds.shape[0]
    n_links = link_start.shape[0]
    n_parts = n_links + (1 if tip_split else 0)
    n_self = self_radii.shape[0]
    ok = np.ones(n_edges, dtype=np.bool_)
    q = np.empty(n_j)
    pts = np.empty((frames.shape[0], 3))
    scratch = landmark_scratch(n_j)
    p0 = np.empty((max(n_parts, 1), 3))
    p1 = np.empty((max(n_parts, 1), 3))
    seg = np.empty((max(n_parts, 1), 6))
    work = np.empty(3)
    cands = np.empty(8 + profiles.shape[1] * 32)
    n_levels = strides.shape[0]
    for e in range(n_edges):
        count = counts[e]
        # how far any arm point can move from one sample to the next
        step = 0.0
        for j in range(n_j):
            step += abs(b[e, j] - a[e, j]) * reach[j]
        step /= count - 1
        proven = np.zeros(count, dtype=np.bool_)
        for level in range(n_levels):
            for i in range(count):
                if proven[i]:
                    continue
                # the coarsest level whose stride the sample is on (the last is on every one)
                own = n_levels - 1
                for s in range(n_levels):
                    if i % strides[s] == 0 or i == count - 1:
                        own = s
                        break
                if own != level:
                    continue
                frac = i / (count - 1)
                for j in range(n_j):
                    q[j] = a[e, j] + frac * (b[e, j] - a[e, j])
                landmarks_into(
                    q,
                    T_world_base,
                    T_parent_joint,
                    axes,
                    prismatic,
                    T_flange_tool,
                    frames,
                    offsets,
                    scratch,
                    pts,
                )
                _parts_into(pts, link_start, link_end, tip_exempt, tip_split, p0, p1, seg)
                # the smallest room any pair has beyond its need (a lower bound: the broad
                # phase's where it decided); a point moves at most ``step`` per sample
                room = np.inf
                clear = True
                for o in range(n_obs):
                    for p in range(n_parts):
                        wanted = need[p * n_obs + o] + part_radius[p]
                        if wanted == -np.inf:
                            continue  # nothing asked of this pair
                        if balls[o, 3] < np.inf:
                            near = segment_point(p0, p1, p, balls[o, 0], balls[o, 1], balls[o, 2])
                            if near - balls[o, 3] >= wanted:
                                room = min(room, near - balls[o, 3] - wanted)
                                continue
                        d = _obstacle_distance(
                            o, kinds, params, profiles, boundary, n_vertices,
                            p0, p1, seg, p, work, cands,
                        )  # fmt: skip
                        if d < wanted:
                            clear = False
                            break
                        room = min(room, d - wanted)
                    if not clear:
                        break
                if clear:
                    for s in range(n_self):
                        d = point_segments_distance(
                            pts, self_a0[s], self_a1[s], self_b0[s], self_b1[s]
                        )
                        wanted = need[n_parts * n_obs + s]
                        if d - self_radii[s] < wanted:
                            clear = False
                            break
                        room = min(room, 0.5 * (d - self_radii[s] - wanted))  # both links move
                if not clear:
                    ok[e] = False
                    break
                # the samples whose every pair keeps its need by this one's room pass too
                if step > 0.0:
                    spare = (room - _ROUNDING) / step
                    spread = int(min(spare, count)) if spare > 0.0 else 0
                else:
                    spread = count
                for j in range(max(i - spread, 0), min(i + spread, count - 1) + 1):
                    proven[j] = True
            if not ok[e]:
                break
    return ok
