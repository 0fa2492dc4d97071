"""The largest-joint metric in command units, and the compiled shortest-path step between two
layers of samples (:func:`advance`): for each sample of the next layer the least cost of the
layer before plus the distance between their error boxes."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.jit import njit, parallel_kernel_lock, prange, threads_pay_off

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Width (commands) of the cells that group predecessors in the shortest-path step.
GROUP_CELL = 12.0
#: Pairs of samples of two layers from which the shortest-path step runs on numba's threads.
_PARALLEL_PAIRS = 1_000_000


@njit(cache=True)
def _wrapped(d: float, period: float) -> float:  # pragma: no cover - compiled
    if period > 0.0:
        d -= period * np.floor(d / period + 0.5)
    return abs(d)


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


def advance(
    pu: FloatArray,
    pe: FloatArray,
    pc: FloatArray,
    u: FloatArray,
    e: FloatArray,
    period: FloatArray,
    whole: bool = False,
) -> tuple[FloatArray, IntArray]:
    """Shortest-path costs at the samples ``u`` (errors ``e``) from the costs ``pc`` of the
    samples ``pu`` (errors ``pe``) and the predecessor of each (:func:`_advance_serial`), on
    numba's threads when the pairs are many enough to pay for them."""
    if pu.shape[0] == 0 or u.shape[0] == 0:
        return np.full(u.shape[0], np.inf), np.full(u.shape[0], -1, dtype=np.int64)
    args = (pu, pe, pc, u, e, period, whole, GROUP_CELL)
    if not threads_pay_off(pu.shape[0] * u.shape[0], _PARALLEL_PAIRS):
        return _advance_serial(*args)
    with parallel_kernel_lock:
        return _advance_parallel(*args)
