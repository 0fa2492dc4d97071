"""The lower bound of a trace's commands (see the package)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.errors import PlanningError
from armpath.planning.bounds.sampling import (
    BASE_DIRECTIONS,
    REFINE_ROUNDS,
    FamilySampler,
    Layer,
    _allowed_at,
    _path,
    _Refiner,
)
from armpath.planning.bounds.value import CommandBound
from armpath.planning.trace.family import CurveFamily

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

#: Layers of a trace bound per span (curve points, evenly spaced).
LAYERS_PER_SPAN = 5
#: The same for a trace's layers: none (seed Task 2: one level raises the bound by less than a
#: command at ten times the time; the curve's points are where most directions are clear).
TRACE_CLEAR_LEVELS = 0


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
