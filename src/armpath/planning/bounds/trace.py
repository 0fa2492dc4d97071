"""The lower bound of a trace's commands (see the package): the chain of the family at points
along each traced span, searched by branch and bound (:mod:`armpath.planning.bounds.search`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from armpath.errors import PlanningError
from armpath.planning.bounds.passage import passage_method, passage_sampling, sampled_passages
from armpath.planning.bounds.sampling import FamilySampler, _allowed_at
from armpath.planning.bounds.search import (
    CellSearch,
    Chain,
    Join,
    Loop,
    SearchResult,
    search_rounds,
)
from armpath.planning.bounds.value import CommandBound
from armpath.planning.trace.family import CurveFamily

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Layers of a trace bound per span (curve points, evenly spaced) when no path is given to
#: place them. More points make the path follow more of the curve but add up more sampling
#: error (seed crack, shortest path through the samples: 5 points 58.6 commands, 20 points
#: 62.5, 60 points 64.0).
LAYERS_PER_SPAN = 5
#: Layers per span at most where a joint path places them (:func:`turning_layers`), and the
#: least a further layer must add to the path's largest-joint length through the layers to be
#: placed (commands: about what its sampling errors take away again). Seed crack, layers where
#: the plan's joint path turns: 3 layers bound 126.2, 4 129.3, 5 128.8, 7 128.4 (5 evenly
#: spaced 126.1); the plan's path through them gains 3.0, 2.3, 0.3, 0.3 commands a layer.
MAX_TURNING_LAYERS = 8
LAYER_GAIN = 1.0
#: Least spacing of layers placed along a path, as a share of the span (one command can turn
#: in place: two layers at one curve point add error and no length).
_LAYER_GAP_SHARE = 0.02
#: Tool directions the family is first sampled along at each layer (about 4.5 deg apart).
SEARCH_DIRECTIONS = 2000
#: Layers are placed this far inside each span's ends (mm).
LAYER_INSET_MM = 0.5


def _layer_positions(spans_mm: list[tuple[float, float]], per_span: int) -> list[FloatArray]:
    """Arc lengths (mm) of each span's ``per_span`` layers, evenly from just inside its start to
    just inside its end (one in the middle of a span shorter than the insets)."""
    out = []
    for a, b in spans_mm:
        if b - a <= 2 * LAYER_INSET_MM:
            out.append(np.array([0.5 * (a + b)]))
        else:
            out.append(np.linspace(a + LAYER_INSET_MM, b - LAYER_INSET_MM, max(per_span, 2)))
    return out


def turning_layers(
    spans_mm: list[tuple[float, float]],
    path_mm: FloatArray,
    path_u: FloatArray,
    max_layers: int = MAX_TURNING_LAYERS,
    gain: float = LAYER_GAIN,
) -> list[FloatArray]:
    """Layer positions (arc lengths, mm) on each span where a joint path along the curve turns:
    of the path's points in the span (arc lengths ``path_mm (P,)`` of its tool point, joint
    values ``path_u (P, J)`` in command units; those up to :data:`LAYER_INSET_MM` past an end
    taken at it), the layers whose polyline through the path's
    values is longest in the largest-joint metric, the span's first and last points among
    them, no two closer than a share of the span; a further layer (up to ``max_layers``) while
    it lengthens the polyline by ``gain`` commands or more. A span with fewer than two of the
    path's points gets :data:`LAYERS_PER_SPAN` evenly spaced. Any positions give a bound; these
    keep the corners of the path the plan takes, which evenly spaced layers cut."""
    out = []
    for (a, b), even in zip(spans_mm, _layer_positions(spans_mm, LAYERS_PER_SPAN), strict=True):
        lo, hi = a + min(LAYER_INSET_MM, 0.5 * (b - a)), b - min(LAYER_INSET_MM, 0.5 * (b - a))
        # the path's points a little past the span's ends count as at its ends (a pass that
        # runs on past the end of a reachable arc: the seed crack's first state 0.03 mm on)
        near = (path_mm >= a - LAYER_INSET_MM) & (path_mm <= b + LAYER_INSET_MM)
        inside = np.flatnonzero(near)
        if inside.size < 2:
            out.append(even)
            continue
        order = inside[np.argsort(path_mm[inside], kind="stable")]
        s, u = np.clip(path_mm[order], lo, hi), path_u[order]
        polylines = _longest_polylines(s, u, max(max_layers, 2), _LAYER_GAP_SHARE * (b - a))
        picks, length = polylines[2]
        if not picks:  # no two of the path's points far enough apart: a very short span
            out.append(even)
            continue
        for more, longer in polylines[3:]:
            if not more or longer < length + gain:
                break
            picks, length = more, longer
        out.append(s[picks])
    return out


def _longest_polylines(
    s: FloatArray, u: FloatArray, k_max: int, gap: float
) -> list[tuple[list[int], float]]:
    """For each ``k`` up to ``k_max`` (the list's index; 0 and 1 unused), the ``k`` points of a
    path (arc lengths ``s`` ascending, values ``u``), its first and last among them and
    consecutive ones at least ``gap`` apart in ``s``, whose polyline is longest in the
    largest-joint metric: their indices and that length ([] and -inf when no ``k`` points are
    so far apart). One dynamic programme: the best ``j``-point polyline to each point."""
    n = s.size
    d = np.abs(u[:, None, :] - u[None, :, :]).max(axis=-1)  # (n, n)
    far = (s[None, :] - s[:, None]) >= gap  # far[m, i]: i may follow m
    best = np.full((k_max, n), -np.inf)
    back = np.zeros((k_max, n), dtype=np.int64)
    best[0, 0] = 0.0
    for j in range(1, k_max):
        through = np.where(far, best[j - 1][:, None] + d, -np.inf)  # (from m, to i)
        back[j] = np.argmax(through, axis=0)
        best[j] = through[back[j], np.arange(n)]
    out: list[tuple[list[int], float]] = [([], -np.inf), ([], -np.inf)]
    for k in range(2, k_max + 1):
        if not np.isfinite(best[k - 1, n - 1]):
            out.append(([], -np.inf))
            continue
        picks = [n - 1]
        for j in range(k - 1, 0, -1):
            picks.append(int(back[j, picks[-1]]))
        out.append((picks[::-1], float(best[k - 1, n - 1])))
    return out


def _once_round(s_mm: FloatArray, length_mm: float) -> FloatArray:
    """Arc lengths ``s_mm`` (mm, ascending, along a pass once round a closed curve of
    ``length_mm``, perhaps a little more) brought onto the curve and sorted, without those
    closer than :data:`_LAYER_GAP_SHARE` of the curve to one kept before (the pass's first and
    last points are one point of the curve)."""
    gap = _LAYER_GAP_SHARE * length_mm
    kept: list[float] = []
    for s in np.mod(s_mm, length_mm):
        apart = [min(abs(s - k), length_mm - abs(s - k)) for k in kept]
        if all(d >= gap for d in apart):
            kept.append(float(s))
    return np.sort(np.array(kept))


def trace_bound(
    fam: CurveFamily,
    q_start: FloatArray,
    spans_mm: list[tuple[float, float]],
    tolerance_mm: float,
    loop: bool = False,
    layers_per_span: int = LAYERS_PER_SPAN,
    rounds: int | None = None,
    on_progress: Callable[[str], None] | None = None,
    directions: int = SEARCH_DIRECTIONS,
    with_errors: bool = True,
    upper_commands: float = np.inf,
    path_mm: FloatArray | None = None,
    path_q: FloatArray | None = None,
    max_samples: int | None = None,
    through_openings: bool = True,
    after_first: Callable[[CommandBound], float] | None = None,
) -> CommandBound:
    """Fewest commands of any plan that passes the tool point along each span of the curve
    (arc lengths mm, ``a < b``) within ``tolerance_mm`` from ``q_start`` (rad).

    Each span is followed by one pass, in either direction, the spans in any order; the bound is
    the approach from the start to the pass it begins with plus every pass's shortest path
    through the family at a few points of the span (the moves between spans counted as zero):
    ``layers_per_span`` evenly spaced; given a joint path along the spans (a plan's states
    ``path_q (P, n)`` rad with their tool point's arc lengths ``path_mm (P,)``), also where that
    path turns (:func:`turning_layers`), and the placement whose first round of the search
    bounds higher is searched on. ``loop``: one span that is the whole closed curve, which a
    pass may begin anywhere on (the points taken once round the curve, the move from the last
    to the first counted too: :class:`~armpath.planning.bounds.search.Loop`). The family is
    sampled along ``directions`` tool directions at first and searched by branch and bound
    for ``rounds`` rounds at most (None: as many as the budget allows,
    :func:`~armpath.planning.bounds.search.search_rounds`) and until it holds ``max_samples``
    live samples (:class:`~armpath.planning.bounds.search.CellSearch`).
    ``upper_commands``: the commands of a plan that traces the spans, if known (the search
    drops the cells that cannot hold a path cheaper than it).
    ``with_errors=False`` (a diagnostic, not a bound): the samples' sampling errors are left
    out, which gives the shortest path through the samples themselves, what the bound tends to
    as the sampling gets finer. ``through_openings``: the approach to a point inside a hollow
    obstacle takes at least its way through one of the obstacle's openings
    (:mod:`~armpath.planning.bounds.passage`); False: the direct approach only.
    ``after_first``: called with the bound after the first round; what it returns (commands:
    another bound, or what one is foretold to come to) ends the search once the path through
    clear samples costs no more (the family's bound cannot then pass it).
    """
    sampler = FamilySampler(fam, tolerance_mm, directions, q_start)
    rounds = search_rounds(max_samples) if rounds is None else rounds
    if loop:  # evenly over one turn of the curve from where the pass begins
        count = max(layers_per_span, 2)
        even = [spans_mm[0][0] + fam.curve.length * np.arange(count) / count]
    else:
        even = _layer_positions(spans_mm, layers_per_span)
    placements = [("evenly spaced", even)]
    # the openings a leg from the start to a point of the spans must pass, sampled once
    every = np.linspace(0.0, 1.0, 64)
    near = np.array([fam.frame(a + (b - a) * f)[0] for a, b in spans_mm for f in every])
    ways = sampled_passages(sampler, q_start, near, with_errors, through_openings)
    if path_mm is not None and path_q is not None:
        path_u = np.asarray(path_q, dtype=np.float64)[:, sampler.tip] / sampler.step
        turning = turning_layers(spans_mm, np.asarray(path_mm, dtype=np.float64), path_u)
        placements.append(("where the plan's joint path turns", turning))

    def said(placed: str) -> Callable[[str], None] | None:
        """Progress of the search of one placement, named where there are two."""
        if on_progress is None or len(placements) == 1:
            return on_progress
        report = on_progress
        head = "bounding the commands:"
        return lambda msg: report(msg.replace(head, f"{head[:-1]}, layers {placed}:", 1))

    started = []
    for placed, s_layers in placements:
        relaxation: Chain | Loop
        if loop:  # the points once round the curve, in order; the pass may begin between any
            s_all = _once_round(np.concatenate(s_layers), fam.curve.length)
            relaxation = Loop()
        else:
            s_all = np.concatenate(s_layers)
            joins: list[Join] = []
            for i, s in enumerate(s_layers):
                if i:
                    joins.append(Join.FREE)
                joins += [Join.MOVE] * (s.size - 1)
            relaxation = Chain(joins)
        points = np.array([fam.frame(float(s))[0] for s in s_all])
        search = CellSearch(
            sampler,
            relaxation,
            list(points),
            [_allowed_at(fam, float(s)) for s in s_all],
            q_start,
            with_errors=with_errors,
            max_samples=max_samples,
            passages=ways,
        )
        first = search.run(1, said(placed), upper=upper_commands)
        if first is None:
            raise PlanningError("a traced span has no family member within the joint limits")
        started.append((first, search, placed, s_all))
    # the placement whose first round bounds higher is searched on (the seed crack: 126.1
    # against 123.1 evenly, then 133.8; the UR5 cell's seam, a loop: 80.8 evenly against
    # 56.2, then 103.3)
    found, search, placed, s_all = max(started, key=lambda x: x[0].value)
    say = said(placed)
    if len(placements) > 1:
        placed += (
            ": of the points evenly spaced and where the plan's joint path turns, those whose "
            "first round bounds higher"
        )
    enough = -np.inf
    if after_first is not None:
        enough = after_first(_bound(found, search, placed, s_all, with_errors, loop))
    if rounds > 1 and found.clear_path > enough:
        # on from the first round's cells (pruned and split, not solved again); its result is
        # the best of every round, the first's included
        found = search.run(rounds - 1, say, upper=upper_commands, enough=enough) or found
    return _bound(found, search, placed, s_all, with_errors, loop)


def _bound(
    found: SearchResult,
    search: CellSearch,
    placed: str,
    s_all: FloatArray,
    with_errors: bool = True,
    loop: bool = False,
) -> CommandBound:
    """The trace bound of a search's result (see :func:`trace_bound`)."""
    sampler = search.sampler
    return CommandBound(
        unproven_because=sampler.unproven_because(with_errors),
        commands=max(int(np.ceil(found.value - 1e-9)), 0),
        value=found.value,
        method=(
            "approach plus shortest path in the largest-joint metric through the solution "
            f"family at {s_all.size} points of the traced spans ({placed}; the members that may "
            "be clear "
            "there; obstacles ignored between them, but not a joint's own self-collision ranges; "
            "tool directions sampled, each distance less the samples' sampling errors, and "
            "searched by branch and bound: cells that cannot hold a path shorter than the plan "
            "or than one through clear members dropped, the others split); one pass per span, "
            "either direction"
            + ("; the pass may begin anywhere on the closed curve" if loop else "")
            + passage_method([p for p, _ in search.passages], "the approach")
            + ("" if with_errors else "; WITHOUT the sampling errors: an estimate, not a bound")
        ),
        parts={"along": found.value - found.approach, "approach": found.approach},
        sampling={
            "layers": float(s_all.size),
            "rounds": float(found.rounds),
            "samples": float(found.samples),
            "directions": float(found.directions),
            "largest_error_on_path_commands": found.largest_error,
        }
        | ({"clear_path_commands": found.clear_path} if np.isfinite(found.clear_path) else {})
        | passage_sampling([p for p, _ in search.passages]),
        guide_q=found.clear_q if found.clear_q is not None else found.bound_q,
        guide_s_mm=s_all,
    )
