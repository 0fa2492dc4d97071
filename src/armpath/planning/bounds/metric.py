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

#: Most predecessors in a leaf of the shortest-path step's k-d tree.
TREE_LEAF = 32
#: Targets of the shortest-path step searched in turn, each from the predecessor the one
#: before chose (the first of a run from none); runs are what numba's threads share out.
TARGET_RUN = 64
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
def _tree(
    u: FloatArray, e: FloatArray, live: IntArray, cost: FloatArray, period: FloatArray
) -> tuple[
    IntArray, FloatArray, FloatArray, FloatArray, IntArray, IntArray, IntArray
]:  # pragma: no cover - compiled
    """A k-d tree over the samples ``live`` of ``u`` (errors ``e``): the samples in tree order
    (each leaf's cheapest first by ``cost``) and per node the box (``lo``, ``hi`` per joint)
    that holds its samples' error boxes, its cheapest cost, where its samples start and stop
    in that order, and its first child (-1: a leaf; the second child follows the first).
    A node of more than :data:`TREE_LEAF` samples is halved at the median of the joint along
    which its samples spread most (each joint's order presorted once and kept by stable
    partitions: ``n log n`` work, the same tree on any machine). Periodic joints are taken on
    their first turn, so a box is at most a turn wide plus the errors (:func:`_gap` measures
    such boxes the shorter way)."""
    n, j = live.size, u.shape[1]
    x = np.empty((n, j))
    for t in range(n):
        for c in range(j):
            v = u[live[t], c]
            if period[c] > 0.0:
                v -= period[c] * np.floor(v / period[c])
            x[t, c] = v
    # each joint's samples in its order, within every node's range
    order = np.empty((j, n), dtype=np.int64)
    for c in range(j):
        order[c] = np.argsort(x[:, c], kind="mergesort")
    left = np.zeros(n, dtype=np.bool_)
    spare = np.empty(n, dtype=np.int64)
    idx = np.empty(n, dtype=np.int64)
    most = 4 * (n // TREE_LEAF + 1) + 1  # leaves hold at least TREE_LEAF / 2 samples each
    lo = np.empty((most, j))
    hi = np.empty((most, j))
    cheapest = np.empty(most)
    start = np.zeros(most, dtype=np.int64)
    stop = np.zeros(most, dtype=np.int64)
    first = np.full(most, -1, dtype=np.int64)
    todo = np.empty(most, dtype=np.int64)
    todo[0], stop[0] = 0, n
    count = pending = 1 if n > 0 else 0  # no samples: no node
    while pending > 0:
        pending -= 1
        k = todo[pending]
        a, b = start[k], stop[k]
        if b - a <= TREE_LEAF:  # a leaf: its box and cheapest from its members
            part = order[0, a:b].copy()
            idx[a:b] = part[np.argsort(cost[live[part]], kind="mergesort")]
            cheapest[k] = cost[live[idx[a]]]
            for c in range(j):
                low, high = np.inf, -np.inf
                for t in range(a, b):
                    i = idx[t]
                    low = min(low, x[i, c] - e[live[i], c])
                    high = max(high, x[i, c] + e[live[i], c])
                lo[k, c], hi[k, c] = low, high
            continue
        widest, along = -1.0, 0
        for c in range(j):
            spread = x[order[c, b - 1], c] - x[order[c, a], c]
            if spread > widest:
                widest, along = spread, c
        middle = (a + b) // 2
        for t in range(a, b):
            left[order[along, t]] = t < middle
        for c in range(j):
            if c == along:
                continue
            at_left, at_right = a, middle
            for t in range(a, b):
                i = order[c, t]
                if left[i]:
                    spare[at_left] = i
                    at_left += 1
                else:
                    spare[at_right] = i
                    at_right += 1
            for t in range(a, b):
                order[c, t] = spare[t]
        first[k] = count
        start[count], stop[count] = a, middle
        start[count + 1], stop[count + 1] = middle, b
        todo[pending], todo[pending + 1] = count, count + 1
        count += 2
        pending += 2
    for k in range(count - 1, -1, -1):  # children come after their parent
        if first[k] >= 0:
            a, b = first[k], first[k] + 1
            cheapest[k] = min(cheapest[a], cheapest[b])
            for c in range(j):
                lo[k, c] = min(lo[a, c], lo[b, c])
                hi[k, c] = max(hi[a, c], hi[b, c])
    return (
        live[idx], lo[:count], hi[:count], cheapest[:count], start[:count], stop[:count],
        first[:count],
    )  # fmt: skip


@njit(cache=True)
def _node_gap(
    k: int,
    lo: FloatArray,
    hi: FloatArray,
    ub: FloatArray,
    eb: FloatArray,
    period: FloatArray,
    whole: bool,
) -> float:  # pragma: no cover - compiled
    """Least distance from any sample of node ``k`` to the sample ``ub`` (error ``eb``)."""
    worst = 0.0
    for c in range(ub.size):
        x = _gap(lo[k, c], hi[k, c], ub[c] - eb[c], ub[c] + eb[c], period[c])
        if x > worst:
            worst = x
    if whole:
        worst = np.ceil(worst - 1e-9)
    return worst


@njit(cache=True)
def _advance_run(
    r: int,
    targets: IntArray,
    pu: FloatArray,
    pe: FloatArray,
    pc: FloatArray,
    u: FloatArray,
    e: FloatArray,
    period: FloatArray,
    whole: bool,
    members: IntArray,
    lo: FloatArray,
    hi: FloatArray,
    cheapest: FloatArray,
    start: IntArray,
    stop: IntArray,
    first: IntArray,
    cost: FloatArray,
    arg: IntArray,
) -> None:  # pragma: no cover - compiled
    """The costs and predecessors of run ``r`` of ``targets`` (see :func:`_advance_serial`)."""
    stack = np.empty(2 * 64, dtype=np.int64)  # two nodes a level; the tree is < 64 deep
    bounds = np.empty(2 * 64)
    before = -1
    for tb in range(r * TARGET_RUN, min((r + 1) * TARGET_RUN, targets.size)):
        b = targets[tb]
        best, barg = np.inf, -1
        if before >= 0:  # the predecessor the target before chose: a cost to beat
            x = _edge(pu[before], pe[before], u[b], e[b], period, np.inf)
            if whole:
                x = np.ceil(x - 1e-9)
            best, barg = pc[before] + x, before
        stack[0] = 0
        bounds[0] = cheapest[0] + _node_gap(0, lo, hi, u[b], e[b], period, whole)
        depth = 1
        while depth > 0:
            depth -= 1
            k = stack[depth]
            if bounds[depth] >= best:
                continue
            if first[k] < 0:  # a leaf, cheapest first: the gap bounds every member's edge
                gap = _node_gap(k, lo, hi, u[b], e[b], period, whole)
                for t in range(start[k], stop[k]):
                    i = members[t]
                    if pc[i] + gap >= best:
                        break
                    x = _edge(pu[i], pe[i], u[b], e[b], period, best - pc[i])
                    if whole:
                        x = np.ceil(x - 1e-9)
                    if pc[i] + x < best:
                        best, barg = pc[i] + x, i
                continue
            near, far = first[k], first[k] + 1
            b_near = cheapest[near] + _node_gap(near, lo, hi, u[b], e[b], period, whole)
            b_far = cheapest[far] + _node_gap(far, lo, hi, u[b], e[b], period, whole)
            if b_far < b_near:
                near, far, b_near, b_far = far, near, b_far, b_near
            if b_far < best:  # the nearer child is searched first
                stack[depth], bounds[depth] = far, b_far
                depth += 1
            if b_near < best:
                stack[depth], bounds[depth] = near, b_near
                depth += 1
        cost[b], arg[b] = best, barg
        before = barg


#: The k-d tree of a layer's samples with a finite cost (:func:`_tree`), the samples and costs
#: it was made from: several steps from the same layer and costs share it
#: (:func:`predecessor_tree`).
PredecessorTree = tuple[
    FloatArray, FloatArray, FloatArray, IntArray, FloatArray, FloatArray, FloatArray, IntArray,
    IntArray, IntArray,
]  # fmt: skip


def predecessor_tree(
    pu: FloatArray, pe: FloatArray, pc: FloatArray, period: FloatArray
) -> PredecessorTree:
    """The k-d tree the shortest-path step searches for the samples ``pu`` (errors ``pe``)
    with a finite cost ``pc`` (:func:`_tree`), to give :func:`advance` for every step from
    them."""
    live = np.flatnonzero(np.isfinite(pc))
    return (pu, pe, pc, *_tree(pu, pe, live, pc, period))


@njit(cache=True)
def _advance_serial(
    targets: IntArray,
    u: FloatArray,
    e: FloatArray,
    period: FloatArray,
    whole: bool,
    pu: FloatArray,
    pe: FloatArray,
    pc: FloatArray,
    members: IntArray,
    lo: FloatArray,
    hi: FloatArray,
    cheapest: FloatArray,
    start: IntArray,
    stop: IntArray,
    first: IntArray,
) -> tuple[FloatArray, IntArray]:  # pragma: no cover - compiled
    """One step of the shortest path: for each sample of ``u`` the least ``pc[i]`` plus the
    distance from sample ``i`` of the layer before (less both errors; rounded up to whole
    commands when ``whole``), and which ``i`` (where several attain it, the first found).

    Branch and bound over the k-d tree of the predecessors with a finite cost (:func:`_tree`,
    the arguments from ``pu`` on): a node's cheapest cost plus the gap between its box and
    the target's error box bounds every pair through it from below, so the search goes down
    the nearer child first, and passes over a node, or the rest of a leaf's members (cheapest
    first), whose bound reaches the best found. The targets are taken in the order
    ``targets`` (that of their own k-d tree), in runs of :data:`TARGET_RUN`, each target
    first measured from the predecessor its neighbour chose."""
    cost = np.full(u.shape[0], np.inf)
    arg = np.full(u.shape[0], -1, dtype=np.int64)
    for r in range((targets.size + TARGET_RUN - 1) // TARGET_RUN):
        _advance_run(
            r, targets, pu, pe, pc, u, e, period, whole, members, lo, hi, cheapest, start,
            stop, first, cost, arg,
        )  # fmt: skip
    return cost, arg


@njit(cache=True, parallel=True)
def _advance_parallel(
    targets: IntArray,
    u: FloatArray,
    e: FloatArray,
    period: FloatArray,
    whole: bool,
    pu: FloatArray,
    pe: FloatArray,
    pc: FloatArray,
    members: IntArray,
    lo: FloatArray,
    hi: FloatArray,
    cheapest: FloatArray,
    start: IntArray,
    stop: IntArray,
    first: IntArray,
) -> tuple[FloatArray, IntArray]:  # pragma: no cover - compiled
    """:func:`_advance_serial` with its runs of targets on numba's threads (the same runs,
    so the same costs and predecessors)."""
    cost = np.full(u.shape[0], np.inf)
    arg = np.full(u.shape[0], -1, dtype=np.int64)
    for r in prange((targets.size + TARGET_RUN - 1) // TARGET_RUN):
        _advance_run(
            r, targets, pu, pe, pc, u, e, period, whole, members, lo, hi, cheapest, start,
            stop, first, cost, arg,
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
    tree: PredecessorTree | None = None,
    threads: bool | None = None,
) -> tuple[FloatArray, IntArray]:
    """Shortest-path costs at the samples ``u`` (errors ``e``) from the costs ``pc`` of the
    samples ``pu`` (errors ``pe``) and the predecessor of each (:func:`_advance_serial`), on
    numba's threads when the pairs are many enough to pay for them (``threads``: True or
    False to choose). ``tree``: :func:`predecessor_tree` of ``pu``, ``pe`` and ``pc``, made
    here when not given."""
    if pu.shape[0] == 0 or u.shape[0] == 0 or not np.any(np.isfinite(pc)):
        return np.full(u.shape[0], np.inf), np.full(u.shape[0], -1, dtype=np.int64)
    if tree is None:
        tree = predecessor_tree(pu, pe, pc, period)
    targets = _tree(u, e, np.arange(u.shape[0]), np.zeros(u.shape[0]), period)[0]
    args = (targets, u, e, period, whole, *tree)
    if threads is None:
        threads = threads_pay_off(pu.shape[0] * u.shape[0], _PARALLEL_PAIRS)
    if not threads:
        return _advance_serial(*args)
    with parallel_kernel_lock:
        return _advance_parallel(*args)
