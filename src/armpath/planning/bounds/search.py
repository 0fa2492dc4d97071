"""Branch and bound over the family's direction cells for the relaxations the bounds solve.

A bound's *relaxation* is a shortest path from the start through the family at a few *sites*
(curve points, targets), in the largest-joint metric in commands, obstacles ignored between
the sites. Two kinds:

* a *chain* (:class:`Chain`, a trace): the sites in one sequence; between two, a *join* says
  what a plan does there: :attr:`Join.MOVE` moves from a member of one to a member of the
  next (the distance); :attr:`Join.FREE` counts nothing (between the spans of a trace, traced
  in any order), and the approach may be charged there. The approach is charged exactly once:
  at the first site, at the last (the chain traced backward) or at a FREE join.
* a *loop* (:class:`Loop`, a closed curve traced whole in one pass that may begin anywhere):
  the sites in their order round the curve, a move between each two neighbours, the last and
  the first included; the pass begins between two neighbours (that move dropped), visits
  every site once round the curve either way, and the approach is charged at the first it
  visits.
* *orders* (:class:`Orders`, a tour): the sites in any of several orders from the start, each
  leg a whole number of commands, back to the start or not; or in every order at once
  (:class:`Subsets`, for more sites than their orders one by one allow).

A forward dynamic programme gives every sample the least cost of reaching it, a backward one
the least cost from it to the end; their sum is the least cost of any path through the
sample's cell, each distance less both samples' sampling errors, so it bounds every path
through the cell's members from below. The same programme through the samples that are
themselves clear, taken as exact, gives a path the relaxation allows: its cost is an upper
bound of the relaxation's optimum (the *incumbent*; a caller may give a lower one, the
commands of a plan). A cell whose least cost is above the incumbent holds no optimal path, so
its direction is dropped from the search (*pruned*); the cells whose least cost is within
:data:`SPLIT_WINDOW` of the bound and whose sampling error or clearance is unsure are split
(the triangles of directions about them split in four), cheapest first. Rounds repeat until the
bound is within :data:`GAP_GOAL` of the incumbent, nothing is left to split, the bound has not
risen for :data:`STALL_ROUNDS` rounds, or a budget is spent (the live samples:
:data:`MAX_SAMPLES` unless the caller gives more; the rounds: :func:`search_rounds` of that;
:data:`TOTAL_DIRECTIONS`). Every round's value bounds the relaxation (as far as the sampling
errors hold, see the package); the largest is kept. A dropped cell holds no path cheaper than
the incumbent it was dropped against, as far as that round's errors hold, and is not looked at
again (its error can still change as its neighbours split: the test checks instead that no
exact path through the sampled members, dropped ones included, is cheaper than the bound).
"""

from __future__ import annotations

import enum
import itertools
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from scipy.sparse.csgraph import minimum_spanning_tree

from armpath.budget import check_time
from armpath.errors import InvalidInputError
from armpath.planning.bounds.passage import PassageSamples
from armpath.planning.bounds.sampling import (
    AUDIT_REFINE_CELLS,
    MAX_LAYER_DIRECTIONS,
    MIN_SPACING,
    FamilySampler,
    Layer,
    _Samples,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]
#: Where :class:`Subsets`' programme came from to each sample, by set of sites visited and the
#: last one: the site and the sample before.
_Came = dict[tuple[int, int], tuple[NDArray[np.int8], NDArray[np.int32]]]

#: Rounds of the search at most with the default budget of live samples (each round samples,
#: bounds, prunes and splits once); a larger budget allows more (:func:`search_rounds`).
SEARCH_ROUNDS = 16
#: The search stops once its bound is this close to the incumbent (commands).
GAP_GOAL = 0.25
#: Sampling error (commands) a cell that may hold an optimal path is split down to.
SEARCH_ERROR_GOAL = 0.02
#: Cells whose least cost is within this much of the bound (commands) are split (cheapest
#: first): the bound rises where the paths that hold it down run.
SPLIT_WINDOW = 1.0
#: Directions one site splits about in one round at most (cheapest cells first; each split
#: adds about three).
SPLITS_PER_ROUND = 2000
#: Rounds in a row without a higher bound after which the search stops (the cells left to
#: split lie where the family itself changes fast: near a fold of the family a joint turns a
#: long way within one cell). Before the sites' singular directions were blown up
#: (:mod:`.chart`) the UR5 cell's welds stalled at 64 after 5 rounds, the path's largest error
#: 23 commands at the wrist's singular cells; now they rise to 87 in 13 rounds and stop at the
#: sample budget.
STALL_ROUNDS = 2
#: Live samples of all sites together past which the search splits no more: each round's
#: dynamic programmes take longer than in proportion to a site's samples (each step searches
#: the samples before for each sample after: :func:`~.metric.advance`). A
#: caller may give more (:func:`check_max_samples`: up to :data:`MAX_SAMPLES_LIMIT`) for a
#: tighter bound (``benchmarks/results/bounds.md``, a 2-core machine, 2026-12-06): the seed's
#: Task 3 109 -> 111 commands with 200,000 (its sampled bound 29 s -> 52 s), the UR5 cell's
#: welds 103 either way (34 s -> 43 s) and its seam 102.9 -> 104.9 (34 s -> 91 s, 20 rounds;
#: while 16 rounds ended every search, the seam stayed where 16 rounds took it whatever the
#: budget: :func:`search_rounds`).
#: What counts is what a round leaves alive: a round over the budget goes on if the samples of
#: the cells that may hold a path cheaper than the incumbent fit (six welds in free space,
#: whose first sampling holds 52,944: 65 after that round alone, 68 after three in 43 s).
MAX_SAMPLES = 50_000
#: Range of the samples a caller may give the search (memory: a few hundred bytes each).
MIN_SAMPLES_LIMIT = 1_000
MAX_SAMPLES_LIMIT = 2_000_000
#: Directions of all sites together at most (memory: a few hundred bytes each).
TOTAL_DIRECTIONS = 1_000_000
#: Cost (commands) above the incumbent that a cell's least cost may reach and still be kept:
#: rounding only.
_PRUNE_SLACK = 1e-6


class Join(enum.Enum):
    """What happens between two consecutive sites of a chain (see the module)."""

    MOVE = "move"
    FREE = "free"


@dataclass(frozen=True)
class Solution:
    """A relaxation solved on given samples: the least ``total`` (commands; inf when no path
    reaches the end), per site the least cost of a path through each sample (``through``), the
    path attaining the total (the sample it takes at each site), the approach's part of it, and
    the order of the sites it visits (a tour's; the sites' own order for a chain); a tour's
    least total of each order, rounded up."""

    total: float
    through: list[FloatArray]
    samples: list[int]
    approach: float
    order: tuple[int, ...]
    per_order: dict[tuple[int, ...], int] = field(default_factory=dict)
    #: a loop's least total of each site the pass may visit first (see :class:`Loop`)
    per_start: dict[int, float] = field(default_factory=dict)
    #: a tour over every order (:class:`Subsets`): per set of sites still to visit and the
    #: one it begins at, the least cost at each of its samples of visiting them all
    to_go: dict[tuple[int, int], FloatArray] | None = None


def _flip(
    prev0: FloatArray, app_prev: FloatArray, app_next: FloatArray
) -> tuple[FloatArray, IntArray]:
    """Costs at the next site with the approach charged at the join (at the member before it,
    from which the chain was traced backward, or at the member after it), from the costs
    ``prev0`` before it with the approach not yet charged; the predecessor of each."""
    m = app_next.shape[0]
    if prev0.size == 0 or not np.any(np.isfinite(prev0)):
        return np.full(m, np.inf), np.full(m, -1, dtype=np.int64)
    before = prev0 + app_prev
    i_before = int(np.argmin(before))
    i_free = int(np.argmin(prev0))
    after = prev0[i_free] + app_next
    take_after = after < before[i_before]
    cost = np.where(take_after, after, before[i_before])
    arg = np.where(take_after, i_free, i_before).astype(np.int64)
    return np.asarray(cost, dtype=np.float64), arg


@dataclass(frozen=True)
class Chain:
    """A trace's relaxation: the sites in sequence, ``joins[k]`` between sites ``k`` and
    ``k + 1`` (see the module)."""

    joins: list[Join]
    #: moves in fractional commands (a trace's passes run on between the points)
    whole = False

    def narrowed(self, found: Solution, incumbent: float) -> Chain:
        """The same chain (only a tour's orders can be dropped)."""
        return self

    def solve(
        self,
        sampler: FamilySampler,
        layers: list[Layer],
        app: list[FloatArray],
        find_through: bool = True,
        upper: float = np.inf,
        to_go: dict[tuple[int, int], FloatArray] | None = None,
    ) -> Solution:
        """Both programmes over each sample and a flag (0: the approach not charged yet, 1:
        charged), and the path attaining the least total; ``find_through=False``: the forward
        programme alone (the total and its path; the least cost through each sample left
        infinite, as for a sample no path reaches). ``upper`` (the incumbent) and ``to_go``
        are not used here: the relaxations solved site by site keep every cost."""
        K = len(layers)
        fwd = [np.stack([np.zeros(layers[0].size), app[0]], axis=1)]
        ptr = [np.full((layers[0].size, 2), -1, dtype=np.int64)]  # predecessor * 2 + its flag
        for k in range(1, K):
            check_time("bounding the commands")
            prev, cur, join = layers[k - 1], layers[k], self.joins[k - 1]
            cost = np.full((cur.size, 2), np.inf)
            arg = np.full((cur.size, 2), -1, dtype=np.int64)
            for f in (0, 1):
                if join is Join.FREE:
                    if prev.size and np.any(np.isfinite(fwd[-1][:, f])):
                        i = int(np.argmin(fwd[-1][:, f]))
                        cost[:, f], arg[:, f] = fwd[-1][i, f], 2 * i + f
                else:
                    c, a = sampler.advance(prev, fwd[-1][:, f], cur)
                    cost[:, f], arg[:, f] = c, np.where(a >= 0, 2 * a + f, -1)
            if join is Join.FREE:
                c, a = _flip(fwd[-1][:, 0], app[k - 1], app[k])
                better = c < cost[:, 1]
                cost[better, 1], arg[better, 1] = c[better], 2 * a[better]
            fwd.append(cost)
            ptr.append(arg)
        bwd = [np.stack([app[-1], np.zeros(layers[-1].size)], axis=1)]
        for k in range(K - 2, -1, -1) if find_through else ():
            check_time("bounding the commands")
            nxt, cur, join = layers[k + 1], layers[k], self.joins[k]
            cost = np.full((cur.size, 2), np.inf)
            for f in (0, 1):
                if join is Join.FREE:
                    cost[:, f] = float(np.min(bwd[0][:, f], initial=np.inf))
                else:
                    cost[:, f] = sampler.advance(nxt, bwd[0][:, f], cur)[0]
            if join is Join.FREE:
                cost[:, 0] = np.minimum(cost[:, 0], _flip(bwd[0][:, 1], app[k + 1], app[k])[0])
            bwd.insert(0, cost)
        through = [np.full(lay.size, np.inf) for lay in layers]
        if find_through:
            through = [np.asarray((f + b).min(axis=1)) for f, b in zip(fwd, bwd, strict=True)]
        charged = fwd[-1][:, 1]
        uncharged = fwd[-1][:, 0] + app[-1]
        total = float(min(np.min(charged, initial=np.inf), np.min(uncharged, initial=np.inf)))
        order = tuple(range(K))
        if not np.isfinite(total):
            return Solution(total, through, [], np.nan, order)
        # the path, back from the end
        if np.min(charged) <= np.min(uncharged):
            i, f, approach = int(np.argmin(charged)), 1, np.nan
        else:
            i, f = int(np.argmin(uncharged)), 0
            approach = float(app[-1][i])
        samples = [i]
        for k in range(K - 1, 0, -1):
            pi, pf = divmod(int(ptr[k][i, f]), 2)
            if f == 1 and pf == 0:  # the approach was charged at this join: on which side?
                gap = fwd[k][i, 1] - fwd[k - 1][pi, 0]
                near_after = abs(gap - app[k][i]) <= abs(gap - app[k - 1][pi])
                approach = float(app[k][i] if near_after else app[k - 1][pi])
            i, f = pi, pf
            samples.append(i)
        if f == 1:  # charged at the first site
            approach = float(app[0][i])
        return Solution(total, through, samples[::-1], approach, order)


@dataclass(frozen=True)
class Loop:
    """A closed curve's relaxation: the sites in their order round the curve, traced whole in
    one pass that may begin between any two neighbours (see the module). ``starts``: the sites
    the chains of its rotations begin at (None: every site)."""

    starts: tuple[int, ...] | None = None
    #: moves in fractional commands (the pass runs on between the points)
    whole = False

    def narrowed(self, found: Solution, incumbent: float) -> Loop:
        """Without the rotations whose every path costs more than ``incumbent`` (by ``found``,
        solved on these samples), which hold no optimal pass: each round then solves fewer."""
        keep = tuple(k for k, c in found.per_start.items() if c <= incumbent + 1e-9)
        return Loop(keep or self.starts)

    def solve(
        self,
        sampler: FamilySampler,
        layers: list[Layer],
        app: list[FloatArray],
        find_through: bool = True,
        upper: float = np.inf,
        to_go: dict[tuple[int, int], FloatArray] | None = None,
    ) -> Solution:
        """The chain of each rotation of the sites, from each of :attr:`starts` round the
        curve (the pass begun just before that site and traced forward, the approach charged
        there, or begun just after the site before it and traced backward, the approach charged
        there): the least total over them, per site the least cost through each sample
        (``find_through=False``: left infinite, see :meth:`Chain.solve`), each rotation's least
        total (``per_start``), and the path attaining the total, its ``order`` the sites in the
        order its chain lists them."""
        K = len(layers)
        chain = Chain([Join.MOVE] * (K - 1))
        through = [np.full(lay.size, np.inf) for lay in layers]
        best: tuple[Solution, list[int]] | None = None
        per_start = {}
        for k in range(K) if self.starts is None else self.starts:
            check_time("bounding the commands")
            rot = [(k + i) % K for i in range(K)]
            found = chain.solve(
                sampler, [layers[i] for i in rot], [app[i] for i in rot], find_through
            )
            per_start[k] = found.total
            for site, cost in zip(rot, found.through, strict=True):
                through[site] = np.minimum(through[site], cost)
            if best is None or found.total < best[0].total:
                best = found, rot
        assert best is not None
        found, rot = best
        samples = [-1] * K  # by site (none when no path reaches the end)
        for site, i in zip(rot, found.samples, strict=False):
            samples[site] = i
        return Solution(found.total, through, samples, found.approach, tuple(rot), {}, per_start)


@dataclass(frozen=True)
class Orders:
    """A tour's relaxation: the sites visited in each of ``orders`` from the start (legs whole
    commands), ``back`` to the start."""

    orders: list[tuple[int, ...]]
    back: bool
    #: every leg a whole number of commands (it ends at its target)
    whole = True

    def narrowed(self, found: Solution, incumbent: float) -> Orders:
        """Without the orders whose every path costs more than ``incumbent`` (by ``found``,
        solved on these samples: no cell dropped later can make them cheaper), which hold no
        optimal tour; each round then solves fewer."""
        keep = [o for o in self.orders if found.per_order.get(o, 0) <= incumbent + 1e-9]
        return Orders(keep or self.orders, self.back)

    def solve(
        self,
        sampler: FamilySampler,
        layers: list[Layer],
        app: list[FloatArray],
        find_through: bool = True,
        upper: float = np.inf,
        to_go: dict[tuple[int, int], FloatArray] | None = None,
    ) -> Solution:
        """Every order's prefixes forward and suffixes backward: the least total, each order's
        (rounded up), per site the least cost through each sample (``find_through=False``:
        the suffixes not followed, these left infinite; see :meth:`Chain.solve`), and the path
        of the best order."""
        K = len(layers)
        prefix: dict[tuple[int, ...], tuple[FloatArray, IntArray | None]] = {}
        suffix: dict[tuple[int, ...], FloatArray] = {}

        def forward(o: tuple[int, ...]) -> FloatArray:
            if o not in prefix:
                if len(o) == 1:
                    prefix[o] = (app[o[0]], None)
                else:
                    check_time("bounding the tour's commands")
                    before = forward(o[:-1])
                    prefix[o] = sampler.advance(layers[o[-2]], before, layers[o[-1]], self.whole)
            return prefix[o][0]

        def backward(o: tuple[int, ...]) -> FloatArray:
            if o not in suffix:
                if len(o) == 1:
                    suffix[o] = app[o[0]] if self.back else np.zeros(layers[o[0]].size)
                else:
                    check_time("bounding the tour's commands")
                    after = backward(o[1:])
                    suffix[o] = sampler.advance(layers[o[1]], after, layers[o[0]], self.whole)[0]
            return suffix[o]

        through = [np.full(lay.size, np.inf) for lay in layers]
        best, best_order = np.inf, self.orders[0]
        per_order = {}
        for o in self.orders:
            end = forward(o) + backward(o[-1:])
            value = float(np.min(end, initial=np.inf))
            if np.isfinite(value):
                per_order[o] = int(np.ceil(value - 1e-9))
            if value < best:
                best, best_order = value, o
            for i in range(len(o)) if find_through else ():
                t = o[i]
                through[t] = np.minimum(through[t], forward(o[: i + 1]) + backward(o[i:]))
        if not np.isfinite(best):
            return Solution(best, through, [], np.nan, best_order, per_order)
        # the path of the best order, back from its last site
        o = best_order
        i = int(np.argmin(forward(o) + backward(o[-1:])))
        picks = [i]
        for n in range(len(o), 1, -1):
            arg = prefix[o[:n]][1]
            assert arg is not None
            i = int(arg[i])
            picks.append(i)
        picks = picks[::-1]
        samples = [-1] * K
        for t, p in zip(o, picks, strict=True):
            samples[t] = p
        return Solution(best, through, samples, float(app[o[0]][picks[0]]), o, per_order)


class OutOfPairsError(Exception):
    """:class:`Subsets`' programme would measure more pairs of samples than its budget
    (``max_pairs``)."""


class _Costs(dict[tuple[int, int], FloatArray]):
    """:class:`Subsets`' costs by set of sites visited (a bit mask) and the last one, kept only
    where one is finite (most sets have none under a tight cap); a key left out reads as its
    site's samples all infinite (one shared array per site, never written to)."""

    def __init__(self, sizes: list[int]) -> None:
        super().__init__()
        self.none = [np.full(m, np.inf) for m in sizes]

    def __missing__(self, key: tuple[int, int]) -> FloatArray:
        return self.none[key[1]]

    def keep(self, key: tuple[int, int], c: FloatArray) -> bool:
        """Keeps ``c`` at ``key`` where any of it is finite; whether it did."""
        if not np.any(np.isfinite(c)):
            return False
        self[key] = c
        return True


class NearestToGo(Mapping[tuple[int, int], FloatArray]):
    """Costs still to go of :class:`Subsets`' programme that no path beats, from the nearest
    samples of the other sites: at each sample ``x`` of site ``j``, with the sites ``R`` still
    to visit after it (the key is ``(R | {j}`` as a bit mask``, j)``, as :attr:`Solution.to_go`'s),
    a path on through every site of ``R`` (and back with the tour's ``ends``) takes at least

    * ``min over r in R of d(x, r)`` plus the least spanning tree of ``R`` (each edge the
      least distance between two sites' samples): its first leg reaches one site of ``R``,
      the legs after it join every site of ``R``, a tree through them, and
    * where every sample is exact (no sampling error), ``max over r in R of d(x, r)``: the
      distances then obey the triangle inequality, so the legs from ``x`` to any site of
      ``R`` are no shorter than the direct one (between error boxes they need not be: a wide
      box touching two others joins them at no cost),

    the larger, plus the least of the ``ends`` at the sites of ``R`` (the path ends at one of
    them); with ``R`` empty the ends at ``x`` themselves. ``d(x, r)`` is the distance from
    ``x`` to the nearest sample of ``r``, a whole number of commands with ``whole`` (every leg
    is), less the samples' errors. These hold whichever samples the path takes. Each key's
    costs are computed when asked (``n 2**(n-1)`` keys; the nearest distances, ``n (n - 1)``
    of them, once)."""

    def __init__(
        self, sampler: FamilySampler, layers: list[Layer], ends: list[FloatArray], whole: bool
    ) -> None:
        n = len(layers)
        self._n = n
        self._ends = ends
        self._nearest: dict[tuple[int, int], FloatArray] = {}
        for r, lay in enumerate(layers):
            check_time("bounding the tour's commands")
            zero = np.zeros(lay.size)
            tree = sampler.predecessor_tree(lay, zero) if lay.size else None
            for j in range(n):
                if j != r:
                    self._nearest[j, r] = (
                        sampler.advance(lay, zero, layers[j], whole, tree)[0]
                        if lay.size
                        else np.full(layers[j].size, np.inf)
                    )
        self._between = np.zeros((n, n))
        for (j, r), d in self._nearest.items():
            self._between[j, r] = float(np.min(d, initial=np.inf))
        self._between = np.minimum(self._between, self._between.T)
        self._home = [float(np.min(e, initial=np.inf)) for e in ends]
        self._exact = not any(np.any(lay.err) for lay in layers)
        self._trees: dict[int, float] = {}

    def _tree(self, left: int) -> float:
        """The least spanning tree of the sites of the bit mask ``left`` (scipy leaves out an
        edge of length 0, which joins its sites at no cost either way)."""
        if left not in self._trees:
            sites = [r for r in range(self._n) if left >> r & 1]
            sub = self._between[np.ix_(sites, sites)]
            self._trees[left] = float(minimum_spanning_tree(sub).sum()) if len(sites) > 1 else 0.0
        return self._trees[left]

    def __getitem__(self, key: tuple[int, int]) -> FloatArray:
        mask, j = key
        left = mask & ~(1 << j)
        if left == 0:
            return self._ends[j]
        sites = [r for r in range(self._n) if left >> r & 1]
        out: FloatArray = np.min([self._nearest[j, r] for r in sites], axis=0) + self._tree(left)
        if self._exact:
            out = np.maximum(out, np.max([self._nearest[j, r] for r in sites], axis=0))
        return out + min(self._home[r] for r in sites)

    def __iter__(self) -> Iterator[tuple[int, int]]:
        full = (1 << self._n) - 1
        keys = ((mask, j) for mask in range(1, full + 1) for j in range(self._n))
        return iter((mask, j) for mask, j in keys if mask >> j & 1)

    def __len__(self) -> int:
        return self._n << (self._n - 1)


def next_cap(cap: float, least: float, step: float, growth: float) -> tuple[float, float]:
    """The cap of :class:`Subsets`' next deepening run, and its step above ``cap`` (that of
    the run before was ``step``): at least the least total a path left out could come to
    (``least``) and a command more; beyond that, steps that double the work a run does, as
    far as the work grew by ``growth`` times a command from one run to the next (the pairs
    offered; 0 where unknown), at most twice the step before. Eight welds of the seed arm in
    free space do two to six times the work a command, and rise a command a run; eight of
    its scene, four inside the workpiece, a tenth to a half, and rise by up to six."""
    rise = 1.0
    if growth > 1.0:
        rise = max(1.0, float(np.floor(np.log(2.0) / np.log(growth) + 1e-9)))
    elif growth > 0.0:
        rise = 2.0 * step  # no more work a command: as far again
    rise = min(rise, 2.0 * step)
    cap_next = max(cap + rise, float(np.ceil(least - 1e-9)))
    return cap_next, cap_next - cap


@dataclass(frozen=True)
class Subsets:
    """A tour's relaxation over every visiting order at once: Held and Karp's dynamic
    programme over the sets of sites visited, forward from the start and backward from the
    end (``back``: to the start), each leg a whole number of commands. ``n 2**(n-1)`` legs each
    way, each measured from the samples of every site that may come before (or after) together;
    no order's own total (``per_order`` stays empty). ``max_pairs``: most pairs of samples
    a solve offers its legs' steps (the samples before times those after, every step of every
    programme it runs; each step's search measures fewer); past it the solve raises
    :class:`OutOfPairsError`."""

    back: bool
    max_pairs: float = np.inf
    whole = True

    def narrowed(self, found: Solution, incumbent: float) -> Subsets:
        """The same relaxation (no order is dropped: they are not solved one by one)."""
        return self

    def _programme(
        self,
        sampler: FamilySampler,
        layers: list[Layer],
        first: list[FloatArray],
        upper: float = np.inf,
        to_go: Mapping[tuple[int, int], FloatArray] | None = None,
        spent: list[float] | None = None,
    ) -> tuple[_Costs, _Came, float]:
        """For each set of sites (a bit mask) and its last one: the least cost at each sample
        of the last one's layer of a path through every site of the set, beginning with
        ``first`` at its first site, and where each came from (site, sample); and the least
        total a path left out could come to (inf where none was). Costs above ``upper`` are
        left infinite (a path that dear is no better than one known), and so are those whose
        least cost still to go (``to_go``, by the set of sites not yet visited and the last
        one) takes them above it; the samples so left are not measured from. A path left out
        was left at its first sample whose cost, or least cost before it, plus its cost still
        to go passed ``upper``: that sum, no more than the path's total, is what the least
        left out is taken over. ``spent``: the pairs offered so far (one number, added to;
        :attr:`max_pairs`)."""
        n = len(layers)
        full = (1 << n) - 1
        spent = [0.0] if spent is None else spent
        beyond = np.inf  # the least total a path left out could come to

        def kept(c: FloatArray, h: FloatArray | None) -> FloatArray:
            nonlocal beyond
            f = c if h is None else c + h
            over = f > upper
            beyond = min(beyond, float(np.min(f[over], initial=np.inf)))
            return np.where(over, np.inf, c)

        def still_to_go(mask: int, j: int) -> FloatArray | None:
            if to_go is None:
                return None
            h = to_go.get(((full & ~mask) | (1 << j), j))
            return cost.none[j] if h is None else h  # no key: nothing within reach

        cost = _Costs([lay.size for lay in layers])
        for j in range(n):
            cost.keep((1 << j, j), kept(first[j], still_to_go(1 << j, j)))
        came: _Came = {}
        for size in range(2, n + 1):
            for combo in itertools.combinations(range(n), size):
                mask = sum(1 << i for i in combo)
                for j in combo:
                    check_time("bounding the tour's commands")
                    rest = mask & ~(1 << j)
                    before = [i for i in combo if i != j and (rest, i) in cost]
                    if not before:
                        continue  # no path through the set ends at j within the cap
                    live = {i: np.flatnonzero(np.isfinite(cost[rest, i])) for i in before}
                    # only the samples of j that the cost still to go leaves within reach; a
                    # path to another costs at least the least cost before it
                    h = still_to_go(mask, j)
                    to = np.arange(layers[j].size) if h is None else np.flatnonzero(h <= upper)
                    if h is not None and to.size < layers[j].size:
                        low = min(float(np.min(cost[rest, i][live[i]])) for i in before)
                        beyond = min(beyond, low + float(np.min(h[h > upper])))
                    if not to.size:
                        continue
                    spent[0] += float(sum(live[i].size for i in before)) * to.size
                    if spent[0] > self.max_pairs:
                        raise OutOfPairsError
                    c = np.full(layers[j].size, np.inf)
                    arg = np.full(layers[j].size, -1, dtype=np.int64)
                    c[to], arg[to] = sampler.advance(
                        Layer.joined([layers[i].subset(live[i]) for i in before]),
                        np.concatenate([cost[rest, i][live[i]] for i in before]),
                        layers[j].subset(to),
                        self.whole,
                    )
                    if cost.keep((mask, j), kept(c, h)):
                        # (site, sample) compactly: a path is traced back through finite costs
                        # only (arg is -1 where c is inf)
                        owner = np.repeat(before, [live[i].size for i in before]).astype(np.int8)
                        local = np.concatenate([live[i] for i in before]).astype(np.int32)
                        came[mask, j] = (owner[arg], local[arg])
        return cost, came, beyond

    def _deepened(
        self,
        sampler: FamilySampler,
        layers: list[Layer],
        app: list[FloatArray],
        ends: list[FloatArray],
        upper: float,
        to_go: Mapping[tuple[int, int], FloatArray] | None,
    ) -> tuple[_Costs, _Came]:
        """The forward programme for the least total alone, run with a rising cap on the
        costs kept (iterative deepening): from the least the costs still to go allow
        (``to_go``; None: from the other sites' nearest samples, :class:`NearestToGo`), each
        run's cap raised by :func:`next_cap` (at least to the least total the run before left
        out; further where the work grows slowly with the cap), until a path within the cap is
        found (no path within it was left out, so its total is the least), none was left out,
        or the cap reaches ``upper``. Every run raises the cap by a command or more. A cap far
        below the least total leaves out nearly every partial path, so the runs below it cost
        little: five welds of the seed arm in free space over their 640,796 lattice goal
        states, 38 s for one run capped by a greedy order's total, 1.3 s for the one run it
        takes. Raised a command at a time, eight welds of the seed scene, four inside its
        workpiece, ran 26 times from 112 to 137 commands before the pairs' budget ran out,
        each run a tenth dearer than the one before."""
        n = len(layers)
        full = (1 << n) - 1
        if to_go is None:
            to_go = NearestToGo(sampler, layers, ends, self.whole)
        least = min(
            (
                float(np.min(app[j] + h, initial=np.inf))
                for j in range(n)
                if (h := to_go.get((full, j))) is not None
            ),  # no key: nothing within reach
            default=np.inf,
        )
        spent = [0.0]
        cap = min(upper, np.ceil(least - 1e-9) if self.whole else least)
        step, work = 1.0, 0.0  # the last rise of the cap, the pairs the run before offered
        while True:
            before = spent[0]
            forward, came, beyond = self._programme(sampler, layers, app, cap, to_go, spent)
            found = any(np.any(np.isfinite(forward[full, j] + ends[j])) for j in range(n))
            if found or not np.isfinite(beyond) or cap >= upper:
                return forward, came
            growth = ((spent[0] - before) / work) ** (1.0 / step) if work > 0 else 0.0
            work = spent[0] - before
            cap, step = next_cap(cap, beyond, step, growth)
            cap = min(upper, cap)

    def solve(
        self,
        sampler: FamilySampler,
        layers: list[Layer],
        app: list[FloatArray],
        find_through: bool = True,
        upper: float = np.inf,
        to_go: Mapping[tuple[int, int], FloatArray] | None = None,
    ) -> Solution:
        """The least total over every order, per site the least cost through each sample
        (``find_through=False``: left infinite) and the best path, as :meth:`Orders.solve`.
        ``upper``: a cost no optimal path exceeds (the incumbent): partial paths dearer than
        it are left out, and so are the costs through the samples they reach. ``to_go``: costs
        still to go at these samples that no path from them is cheaper than (by the set of
        sites left and the one it begins at: the :attr:`Solution.to_go` of a solution on
        samples these are some of, with their errors): partial paths they take above
        ``upper`` are left out too. The total alone (``find_through=False``) runs the forward
        programme with a rising cap (:meth:`_deepened`; ``to_go`` None: from the nearest
        samples, :class:`NearestToGo`). The solution's own :attr:`Solution.to_go` is its
        backward programme's costs (None without ``find_through``)."""
        n = len(layers)
        full = (1 << n) - 1
        ends = [np.asarray(app[j]) if self.back else np.zeros(layers[j].size) for j in range(n)]
        backward = None
        if find_through:
            # forward from the start first (the approach is charged there, so the incumbent
            # leaves out most partial paths: six welds in free space keep a third of the
            # costs, backward from the end five in six), then backward keeping only the
            # partial paths whose least cost from the start leaves them within it (the first
            # round's two programmes 10.9 -> 5.5 s)
            spent = [0.0]
            forward, came, _ = self._programme(sampler, layers, app, upper, to_go, spent)
            backward = self._programme(sampler, layers, ends, upper, forward, spent)[0]
        else:
            forward, came = self._deepened(sampler, layers, app, ends, upper, to_go)
        totals = [forward[full, j] + ends[j] for j in range(n)]
        least = [float(np.min(t, initial=np.inf)) for t in totals]
        through = [np.full(lay.size, np.inf) for lay in layers]
        best = min(least, default=np.inf)
        if not np.isfinite(best):
            return Solution(best, through, [], np.nan, tuple(range(n)), to_go=backward)
        if backward is not None:
            # a path through a sample of site j: the sites of some set before it (forward)
            # and the others after it (backward from the end)
            for (mask, j), reach in forward.items():
                after = (full & ~mask) | (1 << j)
                through[j] = np.minimum(through[j], reach + backward[after, j])
        last = int(np.argmin(least))
        picks, order, mask = [int(np.argmin(totals[last]))], [last], full
        while mask != 1 << order[-1]:
            owner, local = came[mask, order[-1]]
            mask &= ~(1 << order[-1])
            order.append(int(owner[picks[-1]]))
            picks.append(int(local[picks[-1]]))
        samples = [-1] * n
        for t, i in zip(order, picks, strict=True):
            samples[t] = i
        return Solution(
            best,
            through,
            samples,
            float(app[order[-1]][picks[-1]]),
            tuple(reversed(order)),
            to_go=backward,
        )


@dataclass
class _Site:
    """The search's state at one site: the tool point, which directions the family allows
    there, every member sampled so far, which directions may still hold an optimal path,
    and the layer filtered from the members (recomputed when new directions come)."""

    point: FloatArray
    allowed: Callable[[FloatArray], BoolArray] | None
    acc: _Samples
    alive: BoolArray
    layer: Layer
    triangles: IntArray
    spacing: FloatArray
    unsure: BoolArray

    def live(self) -> Layer:
        """The samples of directions still alive."""
        assert self.layer.direction is not None
        return self.layer.subset(self.alive[self.layer.direction])


@dataclass(frozen=True)
class SearchResult:
    """What the search found: the bound (``value``, commands) and the approach's part of its
    path, the order its path visits the sites in; the least cost of a path through clear
    samples (``clear_path``: an upper bound of the relaxation's optimum; inf when none was
    found), its configurations (one per site in site order, rad; None without one) and the
    order it visits the sites in; the bound's path's configurations; the rounds run, the
    samples and directions of the last, and the largest sampling error on the bound's path
    (commands)."""

    value: float
    approach: float
    order: tuple[int, ...]
    clear_path: float
    clear_q: FloatArray | None
    clear_order: tuple[int, ...]
    bound_q: FloatArray
    rounds: int
    samples: int
    directions: int
    largest_error: float


@dataclass(frozen=True)
class _Resume:
    """Where a call of :meth:`CellSearch.run` that ended on its rounds stopped: its last
    round's live samples and solution, the incumbent, the best result so far (with the last
    round's samples and directions and the clear path) and the rounds it has not risen for."""

    live: list[Layer]
    found: Solution
    incumbent: float
    best: SearchResult
    stalled: int


def check_max_samples(samples: int | None) -> int:
    """``samples`` as the search's budget of live samples (None: :data:`MAX_SAMPLES`), or
    :class:`InvalidInputError` naming the range (:data:`MIN_SAMPLES_LIMIT` ..
    :data:`MAX_SAMPLES_LIMIT`)."""
    if samples is None:
        return MAX_SAMPLES
    if isinstance(samples, bool) or int(samples) != samples:
        raise InvalidInputError(f"bound samples must be a whole number, got {samples!r}")
    if not MIN_SAMPLES_LIMIT <= samples <= MAX_SAMPLES_LIMIT:
        raise InvalidInputError(
            f"bound samples must be between {MIN_SAMPLES_LIMIT:,} and {MAX_SAMPLES_LIMIT:,}, "
            f"got {samples:,}"
        )
    return int(samples)


def search_rounds(max_samples: int | None = None) -> int:
    """Rounds a search may run with a budget of ``max_samples`` live samples (None: the
    default, :data:`MAX_SAMPLES`; see :func:`check_max_samples`): :data:`SEARCH_ROUNDS` at the
    default budget and in proportion to a larger one, so that a larger budget is spent rather
    than cut short by the rounds (each round splits only the cells near the bound's paths: the
    UR5 cell's seam holds 45,324 samples after its 16 rounds and its bound still rises)."""
    return SEARCH_ROUNDS * max(1, check_max_samples(max_samples) // MAX_SAMPLES)


def _held(layer: Layer, through: FloatArray, incumbent: float) -> tuple[BoolArray, IntArray]:
    """The pruning rule: the samples of ``layer`` that may lie on a path no costlier than
    ``incumbent`` (``through``: each sample's least cost of a path through it), and the
    directions that keep one (the cells :meth:`CellSearch._prune_and_split` keeps alive)."""
    assert layer.direction is not None
    keep = through <= incumbent + _PRUNE_SLACK
    return keep, np.unique(layer.direction[keep])


def _kept_samples(layer: Layer, through: FloatArray, incumbent: float) -> int:
    """The samples of ``layer`` that pruning against ``incumbent`` leaves alive: those of the
    directions that keep one (:func:`_held`)."""
    assert layer.direction is not None
    _, held = _held(layer, through, incumbent)
    return int(np.count_nonzero(np.isin(layer.direction, held)))


class CellSearch:
    """Branch and bound over the direction cells of a relaxation's sites (see the module).

    ``levels``: before the search, the cells kept only for what their neighbours allow are
    split that many times at every site, as :meth:`FamilySampler.layer` does.
    ``max_samples``: the live samples past which the search splits no more, counted after a
    round's pruning (:data:`MAX_SAMPLES`; see :func:`check_max_samples`)."""

    def __init__(
        self,
        sampler: FamilySampler,
        relaxation: Chain | Loop | Orders | Subsets,
        points: list[FloatArray],
        allowed: list[Callable[[FloatArray], BoolArray] | None],
        q_start: FloatArray,
        *,
        with_errors: bool = True,
        levels: int = 0,
        max_samples: int | None = None,
        passages: Sequence[PassageSamples] = (),
    ) -> None:
        self.sampler = sampler
        self.max_samples = check_max_samples(max_samples)
        self.relaxation = relaxation
        #: per order of a tour, the most commands any round proves for it: a round's least
        #: total of the order, or the incumbent its cells were dropped against if less (a
        #: dropped cell holds no path of any order cheaper than that)
        self.per_order: dict[tuple[int, ...], int] = {}
        self.q_start = q_start
        self.with_errors = with_errors
        self.sites = [self._site(p, a, levels) for p, a in zip(points, allowed, strict=True)]
        if with_errors:  # the samples' claim to cover the family, tested (an estimate: none)
            sampler.audit_sites(points, [s.layer for s in self.sites], allowed, self._refined)
        #: the passages a leg from the start takes, each with the sites it takes them to
        sites = np.array(points).reshape(-1, 3)
        entered = [p.passage.entered(sites, sampler.tol) for p in passages]
        self.passages = [(p, e) for p, e in zip(passages, entered, strict=True) if np.any(e)]
        #: where a call of :meth:`run` that ended on its rounds alone stopped: the next call
        #: goes on from it (see :class:`_Resume`); None when the search may not go on (it
        #: ended otherwise) or has not run
        self._resume: _Resume | None = None
        self._ended = False

    def _site(
        self, point: FloatArray, allowed: Callable[[FloatArray], BoolArray] | None, levels: int
    ) -> _Site:
        acc, filtered = self.sampler.sampled(point, self.sampler.base, allowed, levels=levels)
        layer, _, spacing, triangles = filtered
        alive = np.ones(acc.dirs.shape[0], dtype=bool)
        site = _Site(point, allowed, acc, alive, layer, triangles, spacing, alive)
        self._set(site, filtered)
        return site

    def _set(self, site: _Site, filtered: tuple[Layer, IntArray, FloatArray, IntArray]) -> None:
        """Take what :meth:`FamilySampler._filtered` made of the site's members."""
        layer, unsure, spacing, triangles = filtered
        site.layer = layer if self.with_errors else layer.without_errors()
        site.spacing, site.triangles = spacing, triangles
        site.unsure = np.zeros(site.acc.dirs.shape[0], dtype=bool)
        site.unsure[unsure] = True

    def _refined(self, k: int, missed: FloatArray) -> Layer | None:
        """Site ``k``'s layer with the cells split whose samples' boxes lie nearest the
        members ``missed`` (command units) that an audit found outside every box (those of the
        farthest out first, at most :data:`AUDIT_REFINE_CELLS`); None where none could be
        split (see :meth:`FamilySampler.audit_sites`)."""
        site = self.sites[k]
        assert site.layer.direction is not None
        beyond, nearest = self.sampler.nearest_boxes(site.layer, missed)
        nearest = nearest[np.argsort(-beyond, kind="stable")]  # the farthest out first
        nearest = nearest[nearest >= 0]
        if nearest.size == 0:
            return None
        cells = site.layer.direction[nearest]
        _, first = np.unique(cells, return_index=True)
        refine = np.zeros(site.acc.dirs.shape[0], dtype=bool)
        refine[cells[np.sort(first)][:AUDIT_REFINE_CELLS]] = True
        return site.layer if self._split(site, refine) else None

    def _split(self, site: _Site, refine: BoolArray) -> int:
        """Split the triangles of directions about ``refine``; the count of new directions."""
        before = site.acc.dirs.shape[0]
        site.acc = self.sampler.split(site.acc, site.point, refine, site.triangles, site.allowed)
        added = int(site.acc.dirs.shape[0] - before)
        if added:
            site.alive = np.concatenate([site.alive, np.ones(added, dtype=bool)])
            self._set(site, self.sampler._filtered(site.acc))
        return added

    def _approach(self, layers: list[Layer], exact: bool = False) -> list[FloatArray]:
        """The least commands from the start to each sample of each site's layer: directly,
        or through a passage the leg must take where that is more (``exact``: through the
        passage's samples that are clear themselves, taken as exact)."""
        whole = self.relaxation.whole
        out = []
        for k, lay in enumerate(layers):
            cost = self.sampler.distance_from(self.q_start, lay, whole)
            for p, entered in self.passages:
                if entered[k]:
                    cost = np.maximum(cost, p.to(self.sampler, lay, whole, exact))
            out.append(cost)
        return out

    def run(
        self,
        rounds: int | None = None,
        say: Callable[[str], None] | None = None,
        upper: float = np.inf,
        enough: float = -np.inf,
    ) -> SearchResult | None:
        """Search ``rounds`` more rounds at most (None: :func:`search_rounds` of the budget),
        from the incumbent ``upper`` (commands; a plan's) if lower than any found, and only
        while the path through clear samples costs more than ``enough`` (commands; another
        bound's: the relaxation's optimum is at most that path's); None when
        no path reaches the end (a site without a sample in the first round) or an earlier
        call ended the search. A call after one that ended on its rounds alone goes on from
        where that one stopped (its last round's cells pruned and split, not solved again):
        its result is the best of every call's rounds, and counts them all
        (:attr:`SearchResult.rounds`)."""
        say = say or (lambda _m: None)
        rounds = search_rounds(self.max_samples) if rounds is None else rounds
        best: SearchResult | None = None
        clear_total, clear_q, clear_order = np.inf, None, tuple(range(len(self.sites)))
        pruned_against = np.inf
        stalled = 0
        if self._ended:
            return None
        first = 1
        if self._resume is not None:
            was, self._resume = self._resume, None
            best, stalled, first = was.best, was.stalled, was.best.rounds + 1
            clear_total, clear_q = was.best.clear_path, was.best.clear_q
            clear_order = was.best.clear_order
            pruned_against = min(float(upper), was.incumbent)
            # the resumed round's samples all counted as left (its pruning was not measured)
            if not self._go_on(
                was.live, was.found, pruned_against, best.directions, best.samples, best.samples
            ):
                return best
        for r in range(first, first + rounds):
            live = [site.live() for site in self.sites]
            clear_index = [np.flatnonzero(np.asarray(lay.clear)) for lay in live]
            exact = [
                lay.subset(k).without_errors() for lay, k in zip(live, clear_index, strict=True)
            ]
            incumbent = min(float(upper), clear_total)
            # the relaxation first where an incumbent is known (a plan's commands or an earlier
            # round's clear path), then the path through the clear samples, its path and total
            # only (no cell is pruned or split by it): no optimal path costs more, so a
            # programme may leave costlier partial paths out. Only a clear path cheaper than
            # the incumbent is of use (with whole legs: at least one command cheaper than one
            # found before), and the relaxation's least costs still to go bound a clear path's
            # from below (a tour over every order prunes with them: six welds in free space,
            # 150,000 samples, the last round's clear path 47 -> 0.2 s; the whole tour, with
            # the order of :meth:`Subsets.solve`'s programmes, 205 -> 98 s, 71 either way)
            found = None
            if np.isfinite(incumbent):
                found = self.relaxation.solve(
                    self.sampler, live, self._approach(live), upper=incumbent + 1e-9
                )
            cheaper = min(
                clear_total - (1.0 - 1e-9 if self.relaxation.whole else 0.0), incumbent + 1e-9
            )
            to_go = None
            if found is not None and found.to_go is not None:
                to_go = {key: c[clear_index[key[1]]] for key, c in found.to_go.items()}
            clear = self.relaxation.solve(
                self.sampler, exact, self._approach(exact, True), False, cheaper, to_go
            )
            if clear.total < clear_total:
                clear_total = clear.total
                clear_q = np.array([lay.q[i] for lay, i in zip(exact, clear.samples, strict=True)])
                clear_order = clear.order
            incumbent = min(float(upper), clear_total)
            if found is None:
                found = self.relaxation.solve(
                    self.sampler, live, self._approach(live), upper=incumbent + 1e-9
                )
            cap = np.ceil(pruned_against - 1e-9) if np.isfinite(pruned_against) else np.inf
            for o, c in found.per_order.items():
                self.per_order[o] = max(self.per_order.get(o, 0), int(min(c, cap)))
            if not np.isfinite(found.total):
                self._ended = True
                break
            samples = sum(lay.size for lay in live)
            directions = sum(site.acc.dirs.shape[0] for site in self.sites)
            stalled = 0 if best is None or found.total > best.value + 1e-9 else stalled + 1
            if best is None or found.total > best.value:
                on_path = [(lay, i) for lay, i in zip(live, found.samples, strict=True) if i >= 0]
                best = SearchResult(
                    found.total, found.approach, found.order, clear_total, clear_q, clear_order,
                    np.array([lay.q[i] for lay, i in on_path]), r, samples, directions,
                    max(float(lay.err[i].max()) for lay, i in on_path),
                )  # fmt: skip
            else:
                best = replace(
                    best, clear_path=clear_total, clear_q=clear_q, clear_order=clear_order,
                    rounds=r, samples=samples,
                    directions=directions,
                )  # fmt: skip
            say(
                f"bounding the commands: round {r}: at least {best.value:.2f}, a clear path "
                f"{clear_total:.2f}, {samples} samples of {directions} directions"
            )
            # over the budget, the search goes on only if the samples of the cells that may
            # hold a path cheaper than the incumbent fit in it (the others are dropped next)
            kept = sum(
                _kept_samples(lay, through, incumbent)
                for lay, through in zip(live, found.through, strict=True)
            )
            if (
                incumbent - best.value <= GAP_GOAL
                or kept > self.max_samples
                or stalled >= STALL_ROUNDS
                or clear_total <= enough
            ):
                self._ended = True
                break
            if r == first + rounds - 1:
                self._resume = _Resume(live, found, incumbent, best, stalled)
                break
            pruned_against = incumbent
            if not self._go_on(live, found, incumbent, directions, samples, kept):
                break
        return best

    def _go_on(
        self,
        live: list[Layer],
        found: Solution,
        incumbent: float,
        directions: int,
        samples: int,
        kept: int,
    ) -> bool:
        """After a round (its ``live`` samples and ``found`` solution): narrow the relaxation
        and prune and split the cells against ``incumbent`` (``kept``: the samples the split
        budget counts as left after pruning); False, and the search ended, when nothing was
        split."""
        self.relaxation = self.relaxation.narrowed(found, incumbent)
        if self._prune_and_split(live, found, incumbent, directions, samples, kept):
            return True
        self._ended = True
        return False

    def _prune_and_split(
        self,
        live: list[Layer],
        found: Solution,
        incumbent: float,
        directions: int,
        samples: int,
        kept: int,
    ) -> bool:
        """Drop the directions whose every live sample costs more than the incumbent; split,
        cheapest first, the cells within :data:`SPLIT_WINDOW` of the bound whose error or
        clearance is unsure, no more at a site than the samples left to :attr:`max_samples`
        allow (a split adds up to six directions). False when nothing was split."""
        split_any = False
        window = found.total + SPLIT_WINDOW
        per_direction = samples / max(directions, 1)
        share = (self.max_samples - kept) / (6.0 * max(per_direction, 1.0) * len(self.sites))
        cap = int(max(min(SPLITS_PER_ROUND, share), 0))
        for site, lay, through in zip(self.sites, live, found.through, strict=True):
            assert lay.direction is not None
            keep, held = _held(lay, through, incumbent)
            sampled = np.zeros(site.alive.shape[0], dtype=bool)
            sampled[lay.direction] = True
            hold = np.zeros(site.alive.shape[0], dtype=bool)
            hold[held] = True
            site.alive &= hold | ~sampled
            wants = keep & (through <= window)
            wants &= (lay.err.max(axis=1) > SEARCH_ERROR_GOAL) | site.unsure[lay.direction]
            wants &= site.spacing[lay.direction] / 2.0 >= MIN_SPACING
            room = min(MAX_LAYER_DIRECTIONS - site.acc.dirs.shape[0], TOTAL_DIRECTIONS - directions)
            if not np.any(wants) or room <= 0 or cap == 0:
                continue
            order = np.argsort(through[wants], kind="stable")
            pick = np.unique(lay.direction[wants][order][: min(cap, room // 3)])
            refine = np.zeros(site.alive.shape[0], dtype=bool)
            refine[pick] = True
            added = self._split(site, refine)
            directions += added
            split_any |= added > 0
        return split_any
