"""RRT-Connect in joint space with shortcutting (deterministic for a given generator).

The planner is generic: it sees the configuration space only through an :class:`EdgeChecker`
(is a straight joint-space segment clear?) and a box of joint bounds. Distances between
configurations are the largest joint change (the L-infinity norm): the number of commands a
straight motion needs is proportional to it, so shortcuts that shorten it save commands.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import InvalidInputError

FloatArray = NDArray[np.float64]

#: ``edges_clear(a (M, n), b (M, n)) -> (M,) bool``: are straight segments a -> b clear?
EdgeChecker = Callable[[FloatArray, FloatArray], NDArray[np.bool_]]


@dataclass(frozen=True)
class RrtOptions:
    """Settings of :func:`rrt_connect` (angles in rad).

    ``step`` is the largest joint change of one tree extension; ``max_samples`` bounds the work;
    ``goal_bias`` is the probability of sampling a goal instead of a random configuration.
    """

    step: float = np.radians(20.0)
    max_samples: int = 5000
    goal_bias: float = 0.05

    def __post_init__(self) -> None:
        if not (np.isfinite(self.step) and 1e-3 <= self.step <= 2 * np.pi):
            raise InvalidInputError(f"RRT step must be in [0.001, 2 pi] rad, got {self.step}")
        if not 1 <= self.max_samples <= 1_000_000:
            raise InvalidInputError(f"RRT samples must be in [1, 1000000], got {self.max_samples}")
        if not 0.0 <= self.goal_bias <= 1.0:
            raise InvalidInputError(f"RRT goal bias must be in [0, 1], got {self.goal_bias}")


@dataclass(frozen=True)
class RrtResult:
    """A joint-space path ``(K, n)`` rad from the start to ``goal_index``'s goal, or failure."""

    success: bool
    path: FloatArray
    goal_index: int
    samples: int
    tree_sizes: tuple[int, int]
    reason: str = ""


class _Tree:
    def __init__(self, roots: FloatArray, capacity: int) -> None:
        n = roots.shape[1]
        self.q = np.empty((capacity + roots.shape[0], n))
        self.parent = np.full(capacity + roots.shape[0], -1, dtype=np.int64)
        self.root = np.empty(capacity + roots.shape[0], dtype=np.int64)
        self.size = roots.shape[0]
        self.q[: self.size] = roots
        self.root[: self.size] = np.arange(self.size)

    def nearest(self, x: FloatArray) -> int:
        return int(np.argmin(np.max(np.abs(self.q[: self.size] - x), axis=1)))

    def add(self, x: FloatArray, parent: int) -> int:
        if self.size == self.q.shape[0]:
            grow = self.q.shape[0]
            self.q = np.vstack([self.q, np.empty((grow, self.q.shape[1]))])
            self.parent = np.r_[self.parent, np.full(grow, -1, dtype=np.int64)]
            self.root = np.r_[self.root, np.empty(grow, dtype=np.int64)]
        i = int(self.size)
        self.q[i] = x
        self.parent[i] = parent
        self.root[i] = self.root[parent]
        self.size += 1
        return i

    def branch(self, i: int) -> FloatArray:
        """Configurations from node ``i`` back to its root."""
        out = []
        while i >= 0:
            out.append(self.q[i])
            i = int(self.parent[i])
        return np.array(out)


def _steer(a: FloatArray, b: FloatArray, step: float) -> FloatArray:
    d = b - a
    m = float(np.max(np.abs(d)))
    return b if m <= step else a + d * (step / m)


def rrt_connect(
    start: FloatArray,
    goals: FloatArray,
    lower: FloatArray,
    upper: FloatArray,
    edges_clear: EdgeChecker,
    rng: np.random.Generator,
    options: RrtOptions | None = None,
) -> RrtResult:
    """Bidirectional RRT (RRT-Connect) from ``start`` ``(n,)`` to any of ``goals`` ``(G, n)``.

    Random configurations are drawn uniformly in the box ``[lower, upper]``; the start tree
    extends one step toward each, the goal tree (rooted at every goal) then tries to connect to
    the new node greedily, and the trees swap roles. Returns the first connecting path.
    """
    opts = options or RrtOptions()
    trees = [_Tree(start[None, :], opts.max_samples), _Tree(goals, opts.max_samples)]
    # the direct connections first (cheap and often enough)
    direct = edges_clear(np.broadcast_to(start, goals.shape), goals)
    if np.any(direct):
        g = int(np.argmax(direct))
        return RrtResult(True, np.vstack([start, goals[g]]), g, 0, (1, goals.shape[0]))
    for it in range(opts.max_samples):
        check_time("searching for a collision-free path")
        a, b = trees[it % 2], trees[(it + 1) % 2]
        if rng.random() < opts.goal_bias:
            target = (goals if it % 2 == 0 else start[None, :])[
                int(rng.integers(goals.shape[0] if it % 2 == 0 else 1))
            ]
        else:
            target = rng.uniform(lower, upper)
        i_near = a.nearest(target)
        new = _steer(a.q[i_near], target, opts.step)
        if not edges_clear(a.q[i_near][None], new[None])[0]:
            continue
        i_new = a.add(new, i_near)
        # connect: b extends greedily toward the new node until blocked or joined; each step
        # brings it one step closer (largest joint change), so this ends
        j = b.nearest(new)
        while True:
            nxt = _steer(b.q[j], new, opts.step)
            if not edges_clear(b.q[j][None], nxt[None])[0]:
                break
            j = b.add(nxt, j)
            if np.array_equal(nxt, new):
                from_start, from_goal = (a, b) if it % 2 == 0 else (b, a)
                i_s, i_g = (i_new, j) if it % 2 == 0 else (j, i_new)
                path = np.vstack([from_start.branch(i_s)[::-1], from_goal.branch(i_g)[1:]])
                goal_index = int(from_goal.root[i_g])
                return RrtResult(True, path, goal_index, it + 1, (trees[0].size, trees[1].size))
    return RrtResult(
        False,
        start[None, :],
        -1,
        opts.max_samples,
        (trees[0].size, trees[1].size),
        f"no connection after {opts.max_samples} samples",
    )


def path_cost(path: FloatArray, weights: FloatArray | None = None) -> float:
    """Sum over segments of the largest (weighted) joint change."""
    d = np.abs(np.diff(path, axis=0))
    if weights is not None:
        d = d * weights
    return float(d.max(axis=1).sum()) if d.size else 0.0


def shortcut(
    path: FloatArray,
    edges_clear: EdgeChecker,
    rng: np.random.Generator,
    cost: Callable[[FloatArray], float] = path_cost,
    rounds: int = 200,
) -> FloatArray:
    """Shorten ``path`` by straight shortcuts between points on it (kept only when clear and
    cheaper by ``cost``), then by per-joint partial shortcuts: one joint's motion between two
    points replaced by a linear one, the others kept (effective for largest-change costs).
    """
    p = np.asarray(path, dtype=np.float64)
    # greedy pass: from each vertex, jump to the farthest vertex visible
    out = [p[0]]
    i = 0
    while i < len(p) - 1:
        far = np.arange(len(p) - 1, i, -1)
        ok = edges_clear(np.broadcast_to(p[i], (far.size, p.shape[1])), p[far])
        j = int(far[int(np.argmax(ok))]) if np.any(ok) else i + 1
        out.append(p[j])
        i = j
    p = _densify(np.array(out), 16)
    for _ in range(rounds):
        check_time("shortening the path")
        if len(p) < 3:
            break
        i, j = sorted(rng.choice(len(p), size=2, replace=False))
        if j - i < 2:
            continue
        if rng.random() < 0.5:  # straight shortcut: one new segment p[i] -> p[j]
            cand = np.vstack([p[: i + 1], p[j:]])
            a, b = p[i][None], p[j][None]
        else:  # partial shortcut of one joint: segments i .. j change
            joint = int(rng.integers(p.shape[1]))
            cand = p.copy()
            frac = (np.arange(i, j + 1) - i) / (j - i)
            cand[i : j + 1, joint] = p[i, joint] + frac * (p[j, joint] - p[i, joint])
            a, b = cand[i:j], cand[i + 1 : j + 1]
        if cost(cand) >= cost(p) - 1e-12:
            continue
        if np.all(edges_clear(a, b)):
            p = _drop_collinear(cand)
    return _tighten(p, edges_clear, cost)


def _tighten(
    path: FloatArray,
    edges_clear: EdgeChecker,
    cost: Callable[[FloatArray], float],
    sweeps: int = 6,
) -> FloatArray:
    """Elastic-band tightening: pull each interior vertex toward the midpoint of its
    neighbours (full, half or quarter way) while that lowers the cost and both new edges stay
    clear. Candidates of all vertices are tested in one batch per sweep.
    """
    p = _densify(path, max(len(path), 24))
    for _ in range(sweeps):
        improved = False
        for alpha in (1.0, 0.5, 0.25):
            if len(p) < 3:
                return p
            k = np.arange(1, len(p) - 1)
            cand = p[k] + alpha * (0.5 * (p[k - 1] + p[k + 1]) - p[k])
            ok = edges_clear(p[k - 1], cand) & edges_clear(cand, p[k + 1])
            # apply non-adjacent moves (every other vertex) so each test stays valid
            for parity in (0, 1):
                sel = [i for i in np.flatnonzero(ok) if (k[i] % 2) == parity]
                if not sel:
                    continue
                trial = p.copy()
                trial[k[sel]] = cand[sel]
                if cost(trial) < cost(p) - 1e-12:
                    p = trial
                    improved = True
                    break
        if not improved:
            break
    return _drop_collinear(p)
    return p


def _densify(p: FloatArray, count: int) -> FloatArray:
    """Insert midpoints into the longest segments until ``p`` has ``count`` vertices."""
    while len(p) < count:
        k = int(np.argmax(np.max(np.abs(np.diff(p, axis=0)), axis=1)))
        p = np.insert(p, k + 1, 0.5 * (p[k] + p[k + 1]), axis=0)
    return p


def _drop_collinear(p: FloatArray) -> FloatArray:
    """Remove vertices that lie on the straight segment between their neighbours."""
    keep = [0]
    for k in range(1, len(p) - 1):
        ab, bc = p[k] - p[keep[-1]], p[k + 1] - p[k]
        na, nb = np.linalg.norm(ab), np.linalg.norm(bc)
        if na < 1e-12 or nb < 1e-12:
            continue
        if abs(float(ab @ bc) / (na * nb) - 1.0) > 1e-12:
            keep.append(k)
    keep.append(len(p) - 1)
    return p[keep]
