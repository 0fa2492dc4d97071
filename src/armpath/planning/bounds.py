"""Lower bounds on the commands of traces and tours, over the arm's whole solution family.

A command moves joint ``j`` by at most its largest step ``m_j``, so a motion from ``q`` to
``q'`` takes at least ``max_j |q'_j - q_j| / m_j`` commands: the largest-joint (Chebyshev)
distance in *command units* ``u_j = q_j / m_j`` (revolute joints whose range spans a whole
turn the shorter way round). Only
the joints that move the tool point count (the others turn the tool about it).

A trace's pass brings the tool point within the tolerance of every point of the curve, in
order; a tour puts it within the tolerance of every target. Every configuration that does so
belongs to the solution family there (:class:`~armpath.planning.trace.family.CurveFamily`), and
a plan's must also be clear of the obstacles. So the commands are at least the length of a
shortest path from the start through the family at the layers (curve points every few mm;
targets), in the Chebyshev metric, through the members that may be clear; the moves between
layers ignore the obstacles (a relaxation, so the bound holds whatever the scene).

The family is sampled over tool directions; each sample stands for the members of the
directions around it and carries a per-joint *sampling error*: the largest difference to the
nearest member of each neighbouring direction (Delaunay neighbours on the sphere of
directions), plus the joint change that moves the tool point by the tolerance (pseudo-inverse
of the position Jacobian). Distances between samples are taken less both samples' errors, so
the shortest path through the samples is, up to that error estimate, no longer than any path
through the family. A sample is dropped only when no member of its cell can be clear: its
slack is worse than the arm's points move to its neighbours. Where a sample is kept only for
that allowance (it is not clear itself), its direction cells are split (clearance levels),
which shrinks the allowance and drops the cells that collide whole. Rounds refine the
directions around the best path (caps of finer directions), which shrinks the errors where they
count. The error estimate assumes the family varies no faster inside a direction cell than
between neighbouring samples; the tests check the bounds against differently computed ones
(SLSQP over the exact family; the exactly clear members of a fine sampling) and the plans.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import PlanningError
from armpath.geometry.primitives import orthonormal_frame
from armpath.geometry.world import into_windows
from armpath.jit import njit, parallel_kernel_lock, prange, threads_pay_off
from armpath.kinematics import displacement_bounds, landmark_positions, position_jacobian
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.planning.trace.family import CurveFamily, fibonacci_directions

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Largest joint change (commands) between members of neighbouring directions that are taken
#: for one branch of the family (farther: the branch ends between them).
BRANCH_GAP = 30.0
#: Width (commands) of the cells that group predecessors in the shortest-path step.
GROUP_CELL = 12.0
#: Pairs of samples of two layers from which the shortest-path step runs on numba's threads.
_PARALLEL_PAIRS = 1_000_000
#: Slack (model units) a sample may lack beyond what its error box allows and still be kept.
CLEAR_MARGIN = 1e-6
#: Sampling error (commands) below which a sample on the best path is not refined further.
ERROR_GOAL = 0.05
#: Finest direction spacing of a refinement (rad, about 0.05 deg).
MIN_SPACING = float(np.radians(0.05))
#: Refinement rounds after the first sampling.
REFINE_ROUNDS = 1
#: Layers of a trace bound per span (curve points, evenly spaced).
LAYERS_PER_SPAN = 5
#: Tool directions the family is first sampled along (about 2.3 deg apart).
BASE_DIRECTIONS = 8000
#: Times the directions about samples kept only for what their neighbours allow (not clear
#: themselves) are refined, twice as fine each time, at a tour's targets (seed Task 3: 0 levels
#: bound 86 commands, 1 level 94, 2 levels 102 at about three times the time).
TOUR_CLEAR_LEVELS = 1
#: The same for a trace's layers: none (seed Task 2: one level raises the bound by less than a
#: command at ten times the time; the curve's points are where most directions are clear).
TRACE_CLEAR_LEVELS = 0
#: Most directions of one layer (refinement stops before it would pass this).
MAX_LAYER_DIRECTIONS = 200_000
#: Sampling error standing for "no neighbour has a member" (commands).
_MISSING = 1e6


@dataclass(frozen=True)
class CommandBound:
    """A lower bound on commands: ``commands`` (the value rounded up), the ``value`` in
    fractional commands, its parts (a trace's ``approach`` and ``along``), how it was
    computed, and the joint path that attains it (the *guide*: configurations rad, one per
    layer, with the arc length of each layer for a trace)."""

    commands: int
    value: float
    method: str
    parts: dict[str, float] = field(default_factory=dict)
    sampling: dict[str, float] = field(default_factory=dict)
    guide_q: FloatArray | None = None
    guide_s_mm: FloatArray | None = None

    def describe(self) -> dict[str, object]:
        return {
            "commands": self.commands,
            "value_commands": round(self.value, 4),
            "method": self.method,
            "parts_commands": {k: round(v, 4) for k, v in self.parts.items()},
            "sampling": {k: round(v, 6) for k, v in self.sampling.items()},
        }


@dataclass(frozen=True)
class Layer:
    """Samples of the family at one point: command units ``u (M, J)`` of the tip joints, their
    errors ``err (M, J)`` (commands), the configurations ``q (M, n)`` rad and the tool
    direction of each ``dirs (M, 3)``."""

    u: FloatArray
    err: FloatArray
    q: FloatArray
    dirs: FloatArray

    @property
    def size(self) -> int:
        return int(self.u.shape[0])

    def without_errors(self) -> Layer:
        """The same samples taken as exact (no sampling error): not a bound any more, the
        shortest path through the samples themselves."""
        return Layer(self.u, np.zeros_like(self.err), self.q, self.dirs)


def _cap(center: FloatArray, radius: float, spacing: float) -> FloatArray:
    """Directions on a hexagonal grid of ``spacing`` rad within ``radius`` rad of ``center``."""
    e1, e2 = orthonormal_frame(center[None])
    k = int(np.ceil(radius / spacing)) + 1
    i, j = np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij")
    x = spacing * (i + 0.5 * j).ravel()
    y = spacing * (np.sqrt(3.0) / 2.0 * j).ravel()
    keep = x * x + y * y <= radius * radius
    t = np.tan(np.hypot(x[keep], y[keep]))
    r = np.hypot(x[keep], y[keep])
    scale = np.where(r > 0, t / np.where(r > 0, r, 1.0), 1.0)
    d = center + (x[keep] * scale)[:, None] * e1 + (y[keep] * scale)[:, None] * e2
    return np.asarray(d / np.linalg.norm(d, axis=-1, keepdims=True), dtype=np.float64)


def _delaunay_neighbours(dirs: FloatArray) -> tuple[IntArray, IntArray, IntArray]:
    """Neighbours of each direction in the spherical Delaunay triangulation (the convex hull of
    the unit vectors), as CSR ``(pointer, index)``, and the triangles ``(T, 3)``."""
    from scipy.spatial import ConvexHull

    tri = ConvexHull(dirs).simplices
    a = np.concatenate([tri[:, 0], tri[:, 1], tri[:, 2], tri[:, 1], tri[:, 2], tri[:, 0]])
    b = np.concatenate([tri[:, 1], tri[:, 2], tri[:, 0], tri[:, 0], tri[:, 1], tri[:, 2]])
    a, b = a.astype(np.int64), b.astype(np.int64)  # n * n overflows qhull's int32
    pairs = np.unique(a * dirs.shape[0] + b)
    src, dst = pairs // dirs.shape[0], pairs % dirs.shape[0]
    ptr = np.searchsorted(src, np.arange(dirs.shape[0] + 1))
    return ptr.astype(np.int64), dst.astype(np.int64), tri.astype(np.int64)


@dataclass(frozen=True)
class _Samples:
    """A layer's samples before the clearance filter: every direction tried ``dirs (D, 3)``
    and, per member, its configuration, direction index, command units, the arm's points,
    the tolerance's joint change (commands) and its slack (model units; 0 where it is
    not negative, the only values the filter needs)."""

    dirs: FloatArray
    q: FloatArray
    index: IntArray
    u: FloatArray
    points: FloatArray
    tol_err: FloatArray
    slack: FloatArray

    @staticmethod
    def empty(arm: SerialArm, n_tip: int) -> _Samples:
        none = np.zeros((0, arm.n_joints))
        return _Samples(
            dirs=np.zeros((0, 3)),
            q=none,
            index=np.zeros(0, dtype=np.int64),
            u=np.zeros((0, n_tip)),
            points=landmark_positions(arm, none),
            tol_err=np.zeros((0, n_tip)),
            slack=np.zeros(0),
        )


def _midpoints(dirs: FloatArray, triangles: IntArray, refine: BoolArray) -> FloatArray:
    """The midpoints (on the sphere) of the edges of every triangle with a vertex to
    ``refine``: each such triangle is split in four, which halves its directions' cells."""
    tri = triangles[np.any(refine[triangles], axis=1)]
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    mid = dirs[edges[:, 0]] + dirs[edges[:, 1]]
    return np.asarray(mid / np.linalg.norm(mid, axis=-1, keepdims=True), dtype=np.float64)


def _distinct(new: FloatArray, old: FloatArray) -> FloatArray:
    """The directions of ``new`` not already in ``old`` or earlier in ``new`` (qhull needs
    distinct points)."""
    key = np.round(np.vstack([old, new]) * 1e9).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    first = np.sort(first[first >= old.shape[0]])
    return np.asarray(new[first - old.shape[0]], dtype=np.float64)


@njit(cache=True)
def _wrapped(d: float, period: float) -> float:  # pragma: no cover - compiled
    if period > 0.0:
        d -= period * np.floor(d / period + 0.5)
    return abs(d)


@njit(cache=True)
def _sampling_errors(
    u: FloatArray,
    points: FloatArray,
    node_dir: IntArray,
    dir_ptr: IntArray,
    nb_ptr: IntArray,
    nb: IntArray,
    period: FloatArray,
    missing: float,
    branch_gap: float,
    own: bool,
) -> tuple[FloatArray, FloatArray]:  # pragma: no cover - compiled
    """Per sample and joint, the largest difference to the nearest sample (Chebyshev) of each
    neighbouring direction that has one within ``branch_gap`` commands (a member farther is on
    another branch; ``missing`` where no neighbour has one); and per
    sample the farthest any of the arm's ``points`` ``(M, P, 3)`` moves to those neighbours
    (inf where none). Samples are sorted by direction; ``dir_ptr`` points at each
    direction's first. ``own``: the other samples of a sample's own direction are neighbours
    too (a family sampled at several turns about each direction)."""
    m, j = u.shape
    err = np.zeros((m, j))
    moved = np.zeros(m)
    for i in range(m):
        d = node_dir[i]
        found = False
        for p in range(nb_ptr[d] - (1 if own else 0), nb_ptr[d + 1]):
            e = nb[p] if p >= nb_ptr[d] else d
            best, arg = np.inf, -1
            for k in range(dir_ptr[e], dir_ptr[e + 1]):
                if k == i:
                    continue
                worst = 0.0
                for c in range(j):
                    x = _wrapped(u[k, c] - u[i, c], period[c])
                    if x > worst:
                        worst = x
                        if worst >= best:
                            break
                if worst < best:
                    best, arg = worst, k
            if arg >= 0 and best <= branch_gap:  # farther: another branch, not a neighbour
                found = True
                for c in range(j):
                    x = _wrapped(u[arg, c] - u[i, c], period[c])
                    if x > err[i, c]:
                        err[i, c] = x
                for t in range(points.shape[1]):
                    x = 0.0
                    for c in range(3):
                        x += (points[arg, t, c] - points[i, t, c]) ** 2
                    moved[i] = max(moved[i], np.sqrt(x))
        if not found:
            err[i, :] = missing
            moved[i] = np.inf
    return err, moved


@njit(cache=True)
def _edge(
    a: FloatArray, ea: FloatArray, b: FloatArray, eb: FloatArray, period: FloatArray, stop: float
) -> float:  # pragma: no cover - compiled
    """Least Chebyshev distance between the error boxes of two samples (commands), or a value
    >= ``stop`` as soon as it reaches it."""
    worst = 0.0
    for c in range(a.size):
        x: float = _wrapped(b[c] - a[c], period[c]) - ea[c] - eb[c]
        if x > worst:
            worst = x
            if worst >= stop:
                return worst
    return worst


@njit(cache=True)
def _gap(lo: float, hi: float, a: float, b: float, period: float) -> float:  # pragma: no cover
    """Distance between the intervals ``[lo, hi]`` and ``[a, b]`` (on a circle of ``period``
    when it is > 0)."""
    if period > 0.0:
        shift = period * np.floor(((a + b) - (lo + hi)) / (2.0 * period) + 0.5)
        lo += shift
        hi += shift
    if b < lo:
        return lo - b
    if a > hi:
        return a - hi
    return 0.0


@njit(cache=True)
def _groups(
    u: FloatArray, e: FloatArray, live: IntArray, period: FloatArray, cell: float
) -> tuple[IntArray, IntArray, FloatArray, FloatArray]:  # pragma: no cover - compiled
    """The samples ``live`` of ``u`` grouped by cells ``cell`` commands wide: the members in
    group order, where each group starts, and each group's box (``lo``, ``hi`` per joint) that
    holds its members' error boxes (periodic joints on the turn of the group's first)."""
    j = u.shape[1]
    keys = np.zeros(live.size, dtype=np.int64)
    for t in range(live.size):
        k = 0
        for c in range(j):
            x = u[live[t], c]
            if period[c] > 0.0:
                x -= period[c] * np.floor(x / period[c])
            k = k * 1_000_003 + int(np.floor(x / cell))
        keys[t] = k
    order = np.argsort(keys, kind="mergesort")
    members = live[order]
    flags = np.ones(live.size, dtype=np.bool_)
    for t in range(1, live.size):
        flags[t] = keys[order[t]] != keys[order[t - 1]]
    starts = np.append(np.flatnonzero(flags), live.size).astype(np.int64)
    g = starts.size - 1
    lo = np.full((g, j), np.inf)
    hi = np.full((g, j), -np.inf)
    for q in range(g):
        for t in range(starts[q], starts[q + 1]):
            i = members[t]
            for c in range(j):
                x = u[i, c]
                if period[c] > 0.0:
                    x0 = u[members[starts[q]], c]
                    x -= period[c] * np.floor((x - x0) / period[c] + 0.5)
                lo[q, c] = min(lo[q, c], x - e[i, c])
                hi[q, c] = max(hi[q, c], x + e[i, c])
    return members, starts, lo, hi


@njit(cache=True)
def _advance_groups(
    pu: FloatArray,
    pe: FloatArray,
    pc: FloatArray,
    u: FloatArray,
    e: FloatArray,
    period: FloatArray,
    cell: float,
) -> tuple[
    IntArray,
    IntArray,
    FloatArray,
    FloatArray,
    FloatArray,
    IntArray,
    IntArray,
    FloatArray,
    FloatArray,
]:  # pragma: no cover - compiled
    """The groups of :func:`_advance_serial`: the predecessors with a finite cost (members in
    group order, each group cheapest first, where each group starts, its box, its cheapest
    cost) and the targets (members, starts, boxes)."""
    live = np.flatnonzero(np.isfinite(pc))
    members, starts, lo, hi = _groups(pu, pe, live, period, cell)
    targets, tstarts, tlo, thi = _groups(u, e, np.arange(u.shape[0]), period, cell)
    g = starts.size - 1
    cheapest = np.full(g, np.inf)
    for q in range(g):
        # each group's members cheapest first: a scan ends at the first too costly
        seg = members[starts[q] : starts[q + 1]]
        members[starts[q] : starts[q + 1]] = seg[np.argsort(pc[seg], kind="mergesort")]
        cheapest[q] = pc[members[starts[q]]]
    return members, starts, lo, hi, cheapest, targets, tstarts, tlo, thi


@njit(cache=True)
def _advance_target_group(
    r: int,
    pu: FloatArray,
    pe: FloatArray,
    pc: FloatArray,
    u: FloatArray,
    e: FloatArray,
    period: FloatArray,
    whole: bool,
    members: IntArray,
    starts: IntArray,
    lo: FloatArray,
    hi: FloatArray,
    cheapest: FloatArray,
    targets: IntArray,
    tstarts: IntArray,
    tlo: FloatArray,
    thi: FloatArray,
    cost: FloatArray,
    arg: IntArray,
) -> None:  # pragma: no cover - compiled
    """The costs and predecessors of the targets of group ``r`` (see :func:`_advance_serial`)."""
    g = starts.size - 1
    bound = np.empty(g)
    gap = np.empty(g)
    for q in range(g):
        worst = 0.0
        for c in range(pu.shape[1]):
            x = _gap(lo[q, c], hi[q, c], tlo[r, c], thi[r, c], period[c])
            if x > worst:
                worst = x
        if whole:
            worst = np.ceil(worst - 1e-9)
        gap[q] = worst
        bound[q] = cheapest[q] + worst
    ranked = np.argsort(bound)
    for tb in range(tstarts[r], tstarts[r + 1]):
        b = targets[tb]
        best, barg = np.inf, -1
        for q in ranked:
            if bound[q] >= best:
                break
            for t in range(starts[q], starts[q + 1]):
                i = members[t]
                if pc[i] + gap[q] >= best:
                    break
                x = _edge(pu[i], pe[i], u[b], e[b], period, best - pc[i])
                if whole:
                    x = np.ceil(x - 1e-9)
                if pc[i] + x < best:
                    best, barg = pc[i] + x, i
        cost[b], arg[b] = best, barg


@njit(cache=True)
def _advance_serial(
    pu: FloatArray,
    pe: FloatArray,
    pc: FloatArray,
    u: FloatArray,
    e: FloatArray,
    period: FloatArray,
    whole: bool,
    cell: float,
) -> tuple[FloatArray, IntArray]:  # pragma: no cover - compiled
    """One step of the shortest path: for each sample of ``u`` the least ``pc[i]`` plus the
    distance from sample ``i`` of the layer before (less both errors; rounded up to whole
    commands when ``whole``), and which ``i``.

    Branch and bound: both layers' samples are grouped by cells ``cell`` commands wide; the gap
    between two groups' boxes plus the cheapest cost of the predecessor group bounds every
    pair from below, so for each group of samples the predecessor groups are taken in the
    order of that bound, and a sample's search ends when the bound reaches the best found."""
    cost = np.full(u.shape[0], np.inf)
    arg = np.full(u.shape[0], -1, dtype=np.int64)
    if not np.any(np.isfinite(pc)) or u.shape[0] == 0:
        return cost, arg
    members, starts, lo, hi, cheapest, targets, tstarts, tlo, thi = _advance_groups(
        pu, pe, pc, u, e, period, cell
    )
    for r in range(tstarts.size - 1):
        _advance_target_group(
            r, pu, pe, pc, u, e, period, whole, members, starts, lo, hi, cheapest,
            targets, tstarts, tlo, thi, cost, arg,
        )  # fmt: skip
    return cost, arg


@njit(cache=True, parallel=True)
def _advance_parallel(
    pu: FloatArray,
    pe: FloatArray,
    pc: FloatArray,
    u: FloatArray,
    e: FloatArray,
    period: FloatArray,
    whole: bool,
    cell: float,
) -> tuple[FloatArray, IntArray]:  # pragma: no cover - compiled
    """:func:`_advance_serial` with each group of targets on numba's threads."""
    cost = np.full(u.shape[0], np.inf)
    arg = np.full(u.shape[0], -1, dtype=np.int64)
    if not np.any(np.isfinite(pc)) or u.shape[0] == 0:
        return cost, arg
    members, starts, lo, hi, cheapest, targets, tstarts, tlo, thi = _advance_groups(
        pu, pe, pc, u, e, period, cell
    )
    for r in prange(tstarts.size - 1):
        _advance_target_group(
            r, pu, pe, pc, u, e, period, whole, members, starts, lo, hi, cheapest,
            targets, tstarts, tlo, thi, cost, arg,
        )  # fmt: skip
    return cost, arg


class FamilySampler:
    """Samples the family of one arm at points, with sampling errors (see the module)."""

    def __init__(
        self,
        fam: CurveFamily,
        tolerance_mm: float,
        directions: int | None = None,
        q_start: FloatArray | None = None,
    ) -> None:
        arm = fam.arm
        self.fam = fam
        self.tip = np.asarray(fam.tip_joints, dtype=bool)
        grid = arm.lattice
        step = (np.asarray(grid.tick, dtype=np.float64) * grid.max_ticks)[self.tip]
        self.step = step
        # a revolute joint whose range spans a whole turn is measured the shorter way round:
        # the family's samples take one of its turns, a plan may take the other
        span = (arm.upper - arm.lower)[self.tip]
        revolute = np.array([j.kind is JointKind.REVOLUTE for j in arm.joints])[self.tip]
        turns = revolute & ~(span < 2.0 * np.pi)
        self.period = np.where(turns, 2.0 * np.pi / step, 0.0)
        #: the tip joints that a self-collision range they cannot cross confines
        #: (:meth:`CollisionWorld.joint_windows` from ``q_start``): rad, by joint index; such a
        #: joint is measured within its range, not round the turn
        self.joint_windows = tuple(
            w
            for w in (fam.world.joint_windows(arm, q_start) if q_start is not None else ())
            if self.tip[w[0]]
        )
        #: the same ranges in command units, by index among the tip joints
        self.windows: list[tuple[int, float, float]] = []
        tip_index = np.cumsum(self.tip) - 1
        for k, lo, hi in self.joint_windows:
            j = int(tip_index[k])
            self.windows.append((j, lo / step[j], hi / step[j]))
            self.period[j] = 0.0
        self.tol = tolerance_mm / arm.mm_per_unit
        base = fam.coarse_dirs if directions is None else fibonacci_directions(directions)
        self.base = np.asarray(base, dtype=np.float64)
        self.base_spacing = float(np.sqrt(4.0 * np.pi / self.base.shape[0]))
        #: how far any point of the arm moves per unit of each tip joint (model units per rad)
        self.reach = displacement_bounds(arm)[self.tip]
        #: tool frames sampled about each direction (several: the family has a third dimension)
        self.turns = fam.turns_per_direction
        self.required = fam.world.required(arm)

    def units(self, q: FloatArray) -> FloatArray:
        """Command units of the tip joints of configurations ``(..., n)`` rad; a joint with a
        range to keep (:attr:`joint_windows`) takes the copy of its value (whole turns) nearest
        it (:func:`into_windows`)."""
        q = np.asarray(q, dtype=np.float64)
        if self.joint_windows:
            flat = into_windows(q.reshape(-1, q.shape[-1]), self.joint_windows)[0]
            q = flat.reshape(q.shape)
        return np.asarray(q[..., self.tip] / self.step, dtype=np.float64)

    def outside_windows(self, u: FloatArray, err: FloatArray) -> BoolArray:
        """Samples (command units ``(M, J)``, errors ``(M, J)``) whose every nearby member lies
        outside a joint's range to keep: farther out than the sample's error."""
        out = np.zeros(u.shape[0], dtype=bool)
        for j, lo, hi in self.windows:
            gap = np.maximum(np.maximum(lo - u[:, j], u[:, j] - hi), 0.0)
            out |= gap > err[:, j] + 1e-9
        return out

    def directions(self, caps: list[tuple[FloatArray, float, float]]) -> FloatArray:
        """The base directions with finer caps ``(center, radius, spacing)`` rad: a coarser
        direction is dropped only where its whole cell lies inside a finer cap, and each cap
        reaches one coarser spacing beyond its radius, so the union covers every direction."""
        dirs = [self.base]
        spacing = [np.full(self.base.shape[0], self.base_spacing)]
        for center, radius, h in sorted(caps, key=lambda c: -c[2]):
            all_d, all_s = np.vstack(dirs), np.concatenate(spacing)
            angle = np.arccos(np.clip(all_d @ center, -1.0, 1.0))
            keep = ~((all_s > h) & (angle < radius - all_s))
            reach = radius + float(all_s[angle < radius + all_s].max(initial=h))
            new = _cap(center, reach, h)
            dirs, spacing = [all_d[keep], new], [all_s[keep], np.full(new.shape[0], h)]
        return _distinct(np.vstack(dirs), np.zeros((0, 3)))

    def layer(
        self,
        E: FloatArray,
        dirs: FloatArray,
        allowed: Callable[[FloatArray], BoolArray] | None = None,
        *,
        levels: int,
    ) -> Layer:
        """The family at tool point ``E`` sampled along ``dirs`` (those ``allowed``: a mask of
        any directions). A sample that is not clear itself is kept when a member near it may be
        (see :meth:`_filtered`); ``levels`` times, the triangles of directions about such
        samples are split in four, which shrinks what their neighbours allow and so drops the
        samples whose whole cell collides."""
        acc = _Samples.empty(self.fam.arm, int(self.tip.sum()))
        new = np.asarray(dirs, dtype=np.float64)
        for level in range(levels + 1):
            check_time("bounding the commands")
            acc = self._grown(acc, E, new, allowed)
            lay, unsure, spacing, triangles = self._filtered(acc)
            refine = np.zeros(acc.dirs.shape[0], dtype=bool)
            refine[unsure] = spacing[unsure] / 2.0 >= MIN_SPACING
            if level == levels or not np.any(refine):
                break
            new = _distinct(_midpoints(acc.dirs, triangles, refine), acc.dirs)
            if acc.dirs.shape[0] + new.shape[0] > MAX_LAYER_DIRECTIONS:
                break
        return lay

    def _grown(
        self,
        acc: _Samples,
        E: FloatArray,
        dirs: FloatArray,
        allowed: Callable[[FloatArray], BoolArray] | None,
    ) -> _Samples:
        """``acc`` with the members along ``dirs`` added (configurations, command units, the
        arm's points, the tolerance's joint change, the slack)."""
        pick = np.flatnonzero(allowed(dirs)) if allowed is not None else np.arange(dirs.shape[0])
        q, index = self.fam.members(E, dirs[pick])
        index = pick[index] + acc.dirs.shape[0]
        tol_err = np.zeros((q.shape[0], acc.u.shape[1]))
        slack = np.zeros(q.shape[0])
        if q.shape[0]:
            J = position_jacobian(self.fam.arm, q)[:, :, self.tip]
            with np.errstate(all="ignore"):
                pinv = np.linalg.pinv(J, rcond=1e-9)
            tol_err = self.tol * np.abs(pinv).sum(axis=-1) / self.step
            tol_err = np.where(np.isfinite(tol_err), tol_err, _MISSING)
            # only a negative slack matters (see _filtered): the broad phase skips the pairs
            # that cannot be below zero, and every sample at or above it reads 0
            slack = self.fam.world.slack(self.fam.arm, q, ceiling=0.0)
        return _Samples(
            dirs=np.vstack([acc.dirs, dirs]),
            q=np.vstack([acc.q, q]),
            index=np.concatenate([acc.index, index]),
            u=np.vstack([acc.u, self.units(q)]),
            points=np.concatenate([acc.points, landmark_positions(self.fam.arm, q)]),
            tol_err=np.vstack([acc.tol_err, tol_err]),
            slack=np.concatenate([acc.slack, slack]),
        )

    def _filtered(self, acc: _Samples) -> tuple[Layer, IntArray, FloatArray, IntArray]:
        """The layer of the samples in ``acc`` with their errors; the samples kept only for
        what their neighbours allow (indices into ``acc.dirs``); each direction's spacing (the
        widest angle to its Delaunay neighbours, rad); the Delaunay triangles.

        A sample is kept when its slack is no worse than the arm's points move to its
        neighbours (and within the tolerance): a member nearby may then be clear where the
        sample is not. Links are straight between those points, so none moves farther."""
        order = np.argsort(acc.index, kind="stable")
        q, index, u = acc.q[order], acc.index[order], acc.u[order]
        n_dirs = acc.dirs.shape[0]
        nb_ptr, nb, triangles = _delaunay_neighbours(acc.dirs)
        src = np.repeat(np.arange(n_dirs), np.diff(nb_ptr))
        cosines = np.einsum("ij,ij->i", acc.dirs[src], acc.dirs[nb])
        spacing = np.zeros(n_dirs)
        np.maximum.at(spacing, src, np.arccos(np.clip(cosines, -1.0, 1.0)))
        dir_ptr = np.searchsorted(index, np.arange(n_dirs + 1)).astype(np.int64)
        err, moved = _sampling_errors(
            u, acc.points[order], index, dir_ptr, nb_ptr, nb, self.period, _MISSING,
            BRANCH_GAP, self.turns > 1,
        )  # fmt: skip
        alone = err[:, 0] >= _MISSING
        if np.any(alone) and not np.all(alone):
            # no neighbouring direction has a member (a sliver of the family inside the joint
            # limits): the layer's median error stands in for the unknown one
            err[alone] = np.median(err[~alone], axis=0)
            moved[alone] = np.median(moved[~alone])
        tol_err, slack = acc.tol_err[order], acc.slack[order]
        err = err + tol_err
        allowance = moved + (tol_err * self.step) @ self.reach + CLEAR_MARGIN
        keep = (slack >= -allowance) & ~self.outside_windows(u, err)
        unsure = np.unique(index[keep & (slack < 0.0)])
        layer = Layer(u[keep], err[keep], q[keep], acc.dirs[index[keep]])
        return layer, unsure, spacing, triangles

    def distance_from(self, q_start: FloatArray, layer: Layer, whole: bool = False) -> FloatArray:
        """Least commands from ``q_start`` (rad) to each sample's error box (rounded up to
        whole commands when ``whole``)."""
        d = self.units(q_start)[None, :] - layer.u
        period = np.where(self.period > 0, self.period, 1.0)
        d = np.where(self.period > 0, d - period * np.floor(d / period + 0.5), d)
        out = np.maximum(np.abs(d) - layer.err, 0.0).max(axis=-1, initial=0.0)
        return np.asarray(np.ceil(out - 1e-9) if whole else out, dtype=np.float64)

    def advance(
        self, prev: Layer, cost: FloatArray, nxt: Layer, whole: bool = False
    ) -> tuple[FloatArray, IntArray]:
        """Shortest-path costs at ``nxt`` from ``cost`` at ``prev`` (and the predecessors);
        ``whole``: each step a whole number of commands (a leg between targets)."""
        if prev.size == 0 or nxt.size == 0:
            return np.full(nxt.size, np.inf), np.full(nxt.size, -1, dtype=np.int64)
        args = (prev.u, prev.err, cost, nxt.u, nxt.err, self.period, whole, GROUP_CELL)
        if not threads_pay_off(prev.size * nxt.size, _PARALLEL_PAIRS):
            return _advance_serial(*args)
        with parallel_kernel_lock:
            return _advance_parallel(*args)


def _allowed_at(fam: CurveFamily, s: float) -> Callable[[FloatArray], BoolArray]:
    """The tool directions the family allows at arc length ``s`` mm."""
    return lambda dirs: fam.allowed_mask(s, dirs)


def _path(
    layers: list[Layer], init: FloatArray, sampler: FamilySampler
) -> tuple[float, list[int], list[FloatArray]]:
    """Shortest path through ``layers`` from costs ``init`` at the first: its cost, the sample
    it takes on each layer, and the least cost of reaching each sample of each layer."""
    costs = [init]
    args = []
    for k in range(1, len(layers)):
        check_time("bounding the commands")
        cost, arg = sampler.advance(layers[k - 1], costs[-1], layers[k])
        costs.append(cost)
        args.append(arg)
    cost = costs[-1]
    if cost.size == 0 or not np.any(np.isfinite(cost)):
        return np.inf, [], costs
    j = int(np.argmin(cost))
    best = float(cost[j])
    path = [j]
    for arg in reversed(args):
        j = int(arg[j])
        path.append(j)
    return best, path[::-1], costs


class _Refiner:
    """The directions of each layer and their refinement: after each round, caps of directions
    three times finer go round the samples on the best path whose error is above
    :data:`ERROR_GOAL`."""

    def __init__(self, sampler: FamilySampler, count: int) -> None:
        self.sampler = sampler
        self.caps: list[list[tuple[FloatArray, float, float]]] = [[] for _ in range(count)]

    def directions(self, k: int) -> FloatArray:
        return self.sampler.directions(self.caps[k])

    def refine(self, k: int, layer: Layer, sample: int) -> bool:
        """Refine layer ``k`` round its ``sample``; False when it needs none."""
        if float(layer.err[sample].max()) <= ERROR_GOAL:
            return False
        d = layer.dirs[sample]
        h = self.sampler.base_spacing
        for center, radius, spacing in self.caps[k]:
            if np.arccos(np.clip(center @ d, -1.0, 1.0)) < radius:
                h = min(h, spacing)
        if h / 3.0 < MIN_SPACING:
            return False
        self.caps[k].append((d, 3.0 * h, h / 3.0))
        return True


def trace_bound(
    fam: CurveFamily,
    q_start: FloatArray,
    spans_mm: list[tuple[float, float]],
    tolerance_mm: float,
    loop: bool = False,
    layers_per_span: int = LAYERS_PER_SPAN,
    rounds: int = REFINE_ROUNDS,
    on_progress: Callable[[str], None] | None = None,
    directions: int = BASE_DIRECTIONS,
    clear_levels: int = TRACE_CLEAR_LEVELS,
    with_errors: bool = True,
) -> CommandBound:
    """Fewest commands of any plan that passes the tool point along each span of the curve
    (arc lengths mm, ``a < b``) within ``tolerance_mm`` from ``q_start`` (rad).

    Each span is followed by one pass, in either direction, the spans in any order; the bound is
    the approach from the start to the pass it begins with plus every pass's shortest path
    through the family at ``layers_per_span`` points (the moves between spans counted as zero).
    ``loop``: one span that is the whole closed curve, which a pass may begin anywhere on.
    ``with_errors=False`` (a diagnostic, not a bound): the samples' sampling errors are left
    out, which gives the shortest path through the samples themselves, what the bound tends to
    as the sampling gets finer.
    """
    say = on_progress or (lambda _m: None)
    sampler = FamilySampler(fam, tolerance_mm, directions, q_start)
    inset = 0.5
    s_layers = []
    for a, b in spans_mm:
        if b - a <= 2 * inset:
            s_layers.append(np.array([0.5 * (a + b)]))
        else:
            s_layers.append(np.linspace(a + inset, b - inset, max(layers_per_span, 2)))
    s_all = np.concatenate(s_layers)
    refiner = _Refiner(sampler, s_all.size)
    points = [fam.frame(float(s))[0] for s in s_all]
    first = np.cumsum([0] + [s.size for s in s_layers])
    value, parts = -np.inf, {}
    guide_q = np.zeros((0, fam.arm.n_joints))
    largest_err, n_samples = 0.0, 0
    for r in range(rounds + 1):
        say(f"bounding the commands: round {r + 1} of {rounds + 1}")
        flat = []
        for k, s in enumerate(s_all):
            check_time("bounding the commands")
            dirs = refiner.directions(k)
            lay = sampler.layer(points[k], dirs, _allowed_at(fam, float(s)), levels=clear_levels)
            flat.append(lay if with_errors else lay.without_errors())
        n_samples = sum(lay.size for lay in flat)
        rows = [flat[first[i] : first[i + 1]] for i in range(len(s_layers))]
        free, approach, path = [], [], []
        for row in rows:
            f, p, free_costs = _path(row, np.zeros(row[0].size), sampler)
            if not p:
                raise PlanningError("a traced span has no family member within the joint limits")
            free.append(f)
            path += p
            if loop:
                approach.append(_loop_with_approach(row, sampler, q_start, free_costs))
            else:
                fwd, _, _ = _path(row, sampler.distance_from(q_start, row[0]), sampler)
                # the pass run backward: the approach to a sample of the last layer, then the
                # free path from it back to the first layer, which is as long as the free
                # path found to it from the first (every step's distance is symmetric)
                bwd = float(np.min(free_costs[-1] + sampler.distance_from(q_start, row[-1])))
                approach.append(min(fwd, bwd))
        extra = [a - f for a, f in zip(approach, free, strict=True)]
        if float(sum(free) + min(extra)) > value:  # every round bounds: the most of them holds
            value = float(sum(free) + min(extra))
            parts = {"along": float(sum(free)), "approach": float(min(extra))}
            guide_q = np.array([lay.q[p] for lay, p in zip(flat, path, strict=True)])
            largest_err = max(float(lay.err[p].max()) for lay, p in zip(flat, path, strict=True))
        if r == rounds or not any(
            [refiner.refine(k, lay, p) for k, (lay, p) in enumerate(zip(flat, path, strict=True))]
        ):
            break
    return CommandBound(
        commands=max(int(np.ceil(value - 1e-9)), 0),
        value=value,
        method=(
            "approach plus shortest path in the largest-joint metric through the solution "
            f"family at {layers_per_span} points of each span (the members that may be clear "
            "there; obstacles ignored between them, but not a joint's own self-collision ranges; "
            "tool directions sampled and refined about "
            "the path, each distance less the samples' sampling errors); one pass per span, "
            "either direction"
            + ("; the pass may begin anywhere on the closed curve" if loop else "")
            + ("" if with_errors else "; WITHOUT the sampling errors: an estimate, not a bound")
        ),
        parts=parts,
        sampling={
            "layers": float(s_all.size),
            "samples": float(n_samples),
            "largest_error_on_path_commands": largest_err,
        },
        guide_q=guide_q,
        guide_s_mm=s_all,
    )


def tour_bound(
    fam: CurveFamily,
    q_start: FloatArray,
    targets: FloatArray,
    tolerance_mm: float,
    orders: list[tuple[int, ...]],
    back: bool = False,
    rounds: int = REFINE_ROUNDS,
    on_progress: Callable[[str], None] | None = None,
    clear_levels: int = TOUR_CLEAR_LEVELS,
) -> tuple[CommandBound, dict[tuple[int, ...], int]]:
    """Fewest commands of a tour from ``q_start`` (rad) through ``targets`` ``(K, 3)`` (model
    units) within ``tolerance_mm``: for each of ``orders``, a shortest path through the family
    at each target (every goal configuration that may be clear, its cells split
    ``clear_levels`` times where unsure; obstacles ignored between targets), each leg a whole
    number of commands; ``back`` returns to the start. Returns the least over the orders and each
    order's bound."""
    say = on_progress or (lambda _m: None)
    sampler = FamilySampler(fam, tolerance_mm, q_start=q_start)
    refiner = _Refiner(sampler, targets.shape[0])
    per_order: dict[tuple[int, ...], int] = {}
    best_value, best_order = -np.inf, orders[0]
    path: list[int] = []
    layers: list[Layer] = []
    for r in range(rounds + 1):
        say(f"bounding the tour's commands: round {r + 1} of {rounds + 1}")
        now = []
        for k, p in enumerate(targets):
            check_time("bounding the commands")
            now.append(sampler.layer(p, refiner.directions(k), levels=clear_levels))
        round_orders: dict[tuple[int, ...], int] = {}
        value, order, nodes = _orders_through(sampler, now, q_start, orders, back, round_orders)
        # every round's samples bound every plan: the most of them holds (finer directions
        # can lower a round's value where they bring new members closer)
        for o, c in round_orders.items():
            per_order[o] = max(per_order.get(o, c), c)
        if value > best_value:
            best_value, best_order, path, layers = value, order, nodes, now
        if r == rounds or not any(
            [refiner.refine(t, now[t], p) for t, p in zip(order, nodes, strict=True)]
        ):
            break
    largest = max(float(layers[t].err[p].max()) for t, p in zip(best_order, path, strict=True))
    bound = CommandBound(
        commands=int(np.ceil(best_value - 1e-9)),
        value=best_value,
        method=(
            "least over every visiting order of a shortest path from the start through the "
            "solution family at each target (every goal configuration within the tolerance "
            "that may be clear; obstacles ignored between the targets, but not a joint's own "
            "self-collision ranges; tool directions "
            "sampled, refined where clearance is unsure and about the path, each distance less "
            "the samples' sampling errors), each leg rounded up to whole commands"
        ),
        sampling={
            "orders": float(len(orders)),
            "samples": float(sum(lay.size for lay in layers)),
            "largest_error_on_path_commands": largest,
        },
        guide_q=np.array([layers[t].q[p] for t, p in zip(best_order, path, strict=True)]),
    )
    return bound, per_order


def tour_bound_any_order(
    fam: CurveFamily,
    q_start: FloatArray,
    targets: FloatArray,
    tolerance_mm: float,
    back: bool = False,
    on_progress: Callable[[str], None] | None = None,
    clear_levels: int = TOUR_CLEAR_LEVELS,
) -> CommandBound:
    """A cheaper bound of the best order for many targets: every target is entered once, from
    the start or from another target, so the commands are at least the sum over the targets of
    the shortest such leg (whole commands each), plus the shortest way back with ``back``."""
    say = on_progress or (lambda _m: None)
    say(f"bounding the tour's commands ({targets.shape[0]} targets, any order)")
    sampler = FamilySampler(fam, tolerance_mm, q_start=q_start)
    layers = []
    for p in targets:
        check_time("bounding the commands")
        layers.append(sampler.layer(p, sampler.directions([]), levels=clear_levels))
    if any(lay.size == 0 for lay in layers):
        raise PlanningError("a target has no family member within the joint limits")
    from_start = [float(sampler.distance_from(q_start, lay, whole=True).min()) for lay in layers]
    total = 0.0
    for t, lay in enumerate(layers):
        best = from_start[t]
        for s, other in enumerate(layers):
            if s != t:
                check_time("bounding the tour's commands")
                cost, _ = sampler.advance(other, np.zeros(other.size), lay, whole=True)
                best = min(best, float(cost.min()))
        total += best
    if back:
        total += min(from_start)
    return CommandBound(
        commands=int(np.ceil(total - 1e-9)),
        value=total,
        method=(
            "every target entered once: the sum over the targets of the shortest leg into its "
            "solution family (every goal configuration within the tolerance that may be "
            "clear; obstacles ignored between the targets, but not a joint's own self-collision "
            "ranges; from the start or another target, "
            "whole commands, each distance less the samples' sampling errors)"
            + ("; plus the shortest way back" if back else "")
        ),
        sampling={
            "targets": float(targets.shape[0]),
            "samples": float(sum(lay.size for lay in layers)),
        },
    )


def _orders_through(
    sampler: FamilySampler,
    layers: list[Layer],
    q_start: FloatArray,
    orders: list[tuple[int, ...]],
    back: bool,
    per_order: dict[tuple[int, ...], int],
) -> tuple[float, tuple[int, ...], list[int]]:
    """Each order's shortest path from the start through the targets' layers (into
    ``per_order``, rounded up), legs in whole commands, orders sharing their prefixes; the
    least, its order and the sample it takes at each target.

    Paths already as long as the least total found are dropped (legs cost no less than 0, so
    none of them can beat it); an order whose every path was dropped is bounded by that total.
    Orders that are likely best should come first."""
    if any(lay.size == 0 for lay in layers):
        raise PlanningError("a target has no family member within the joint limits")
    first = [sampler.distance_from(q_start, lay, whole=True) for lay in layers]
    memo: dict[tuple[int, ...], tuple[FloatArray, list[IntArray]]] = {}
    best_value, best_order, path = np.inf, orders[0], []

    def prefix(o: tuple[int, ...]) -> tuple[FloatArray, list[IntArray]]:
        if o not in memo:
            if len(o) == 1:
                memo[o] = (first[o[0]], [])
            else:
                cost, args = prefix(o[:-1])
                check_time("bounding the tour's commands")
                live = np.where(cost < best_value, cost, np.inf)
                nxt, arg = sampler.advance(layers[o[-2]], live, layers[o[-1]], whole=True)
                memo[o] = (nxt, [*args, arg])
        return memo[o]

    for o in orders:
        cost, args = prefix(o)
        if back:
            cost = cost + sampler.distance_from(q_start, layers[o[-1]], whole=True)
        j = int(np.argmin(cost))
        per_order[o] = int(np.ceil(min(float(cost[j]), best_value) - 1e-9))
        if cost[j] < best_value:
            nodes = [j]
            for arg in reversed(args):
                nodes.append(int(arg[nodes[-1]]))
            best_value, best_order, path = float(cost[j]), o, nodes[::-1]
    return best_value, best_order, path


def _loop_with_approach(
    row: list[Layer], sampler: FamilySampler, q_start: FloatArray, free_costs: list[FloatArray]
) -> float:
    """A closed curve traced from anywhere on it, either way round: the path through the layers
    in order with one free cut (the move from the last layer back to the first is dropped, a
    relaxation); the approach is charged at the sample where the pass begins, on either side of
    the cut. ``free_costs``: the least cost of each sample from anywhere on the first layer
    (what :func:`_path` gives from zero costs)."""
    app = [sampler.distance_from(q_start, lay) for lay in row]
    before = free_costs[0]  # the piece before the cut, begun at the first layer
    after = app[0].copy()  # the piece after the cut (the pass began at the first layer)
    for k in range(1, len(row)):
        check_time("bounding the commands")
        b_next = free_costs[k]
        a_next, _ = sampler.advance(row[k - 1], after, row[k])
        # the cut between layers k - 1 and k: the pass begins at k (going forward), or at
        # k - 1 (going backward) and then resumes anywhere at k
        a_next = np.minimum(a_next, float(np.min(before)) + app[k])
        a_next = np.minimum(a_next, float(np.min(before + app[k - 1])))
        before, after = b_next, a_next
    return float(min(np.min(after), np.min(before + app[-1])))
