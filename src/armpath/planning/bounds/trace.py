"""The lower bound of a trace's commands (see the package): the chain of the family at points
along each traced span, searched by branch and bound (:mod:`armpath.planning.bounds.search`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from armpath.errors import PlanningError
from armpath.planning.bounds.sampling import FamilySampler, _allowed_at
from armpath.planning.bounds.search import SEARCH_ROUNDS, CellSearch, Chain, Join
from armpath.planning.bounds.value import CommandBound
from armpath.planning.trace.family import CurveFamily

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Layers of a trace bound per span (curve points, evenly spaced). More points make the path
#: follow more of the curve but add up more sampling error (seed crack, shortest path through
#: the samples: 5 points 58.6 commands, 20 points 62.5, 60 points 64.0).
LAYERS_PER_SPAN = 5
#: Tool directions the family is first sampled along at each layer (about 4.5 deg apart).
SEARCH_DIRECTIONS = 2000
#: Layers are placed this far inside each span's ends (mm).
_INSET_MM = 0.5


def _layer_positions(spans_mm: list[tuple[float, float]], per_span: int) -> list[FloatArray]:
    """Arc lengths (mm) of each span's ``per_span`` layers, evenly from just inside its start to
    just inside its end (one in the middle of a span shorter than the insets)."""
    out = []
    for a, b in spans_mm:
        if b - a <= 2 * _INSET_MM:
            out.append(np.array([0.5 * (a + b)]))
        else:
            out.append(np.linspace(a + _INSET_MM, b - _INSET_MM, max(per_span, 2)))
    return out


def trace_bound(
    fam: CurveFamily,
    q_start: FloatArray,
    spans_mm: list[tuple[float, float]],
    tolerance_mm: float,
    loop: bool = False,
    layers_per_span: int = LAYERS_PER_SPAN,
    rounds: int = SEARCH_ROUNDS,
    on_progress: Callable[[str], None] | None = None,
    directions: int = SEARCH_DIRECTIONS,
    with_errors: bool = True,
    upper_commands: float = np.inf,
) -> CommandBound:
    """Fewest commands of any plan that passes the tool point along each span of the curve
    (arc lengths mm, ``a < b``) within ``tolerance_mm`` from ``q_start`` (rad).

    Each span is followed by one pass, in either direction, the spans in any order; the bound is
    the approach from the start to the pass it begins with plus every pass's shortest path
    through the family at ``layers_per_span`` points of the span (the moves between spans
    counted as zero). ``loop``: one span that
    is the whole closed curve, which a pass may begin anywhere on. The family is sampled along
    ``directions`` tool directions at first and searched by branch and bound for ``rounds``
    rounds at most (:class:`~armpath.planning.bounds.search.CellSearch`).
    ``upper_commands``: the commands of a plan that traces the spans, if known (the search
    drops the cells that cannot hold a path cheaper than it).
    ``with_errors=False`` (a diagnostic, not a bound): the samples' sampling errors are left
    out, which gives the shortest path through the samples themselves, what the bound tends to
    as the sampling gets finer.
    """
    sampler = FamilySampler(fam, tolerance_mm, directions, q_start)
    s_layers = _layer_positions(spans_mm, layers_per_span)
    s_all = np.concatenate(s_layers)
    joins: list[Join] = []
    for i, s in enumerate(s_layers):
        if i:
            joins.append(Join.FREE)
        joins += [Join.LOOP if loop else Join.MOVE] * (s.size - 1)
    search = CellSearch(
        sampler,
        Chain(joins),
        [fam.frame(float(s))[0] for s in s_all],
        [_allowed_at(fam, float(s)) for s in s_all],
        q_start,
        with_errors=with_errors,
    )
    found = search.run(rounds, on_progress, upper=upper_commands)
    if found is None:
        raise PlanningError("a traced span has no family member within the joint limits")
    return CommandBound(
        commands=max(int(np.ceil(found.value - 1e-9)), 0),
        value=found.value,
        method=(
            "approach plus shortest path in the largest-joint metric through the solution "
            f"family at {s_all.size} points of the traced spans (the members that may be clear "
            "there; obstacles ignored between them, but not a joint's own self-collision ranges; "
            "tool directions sampled, each distance less the samples' sampling errors, and "
            "searched by branch and bound: cells that cannot hold a path shorter than the plan "
            "or than one through clear members dropped, the others split); one pass per span, "
            "either direction"
            + ("; the pass may begin anywhere on the closed curve" if loop else "")
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
        | ({"clear_path_commands": found.clear_path} if np.isfinite(found.clear_path) else {}),
        guide_q=found.clear_q if found.clear_q is not None else found.bound_q,
        guide_s_mm=s_all,
    )
