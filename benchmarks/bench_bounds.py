"""Lower bounds of traces and tours against their plans (issue 21): where the gaps lie.

Run with ``python benchmarks/bench_bounds.py``. For the seed scene's Tasks 2 and 3 and the UR5
cell's seam and welds (``examples/ur5_cell.toml``), each task is planned once (a trace without
its bound; a tour plans with it, its time included), then its lower bound is computed three
ways over the same relaxation (the family at points of the traced spans or at the welds;
obstacles ignored between them):

* the first sampling alone (one round of the search: the tool directions sampled once, each
  distance less the samples' sampling errors): a bound;
* the branch and bound (the default, what ``armpath trace`` and ``spotweld`` report): a bound;
* the same allowed four times the live samples and rounds (``--bound-samples 200000``): a
  bound, later;
* the same search with the samples taken as exact (``with_errors=False``): the shortest path
  through the samples themselves, an estimate of the relaxation's optimum (neither a bound nor
  a path the relaxation surely allows: samples kept because a member near them may be clear
  count too), which the bound and it approach together as the sampling gets finer;
* the least cost of a path through samples that are themselves clear, taken as exact: a path
  the relaxation allows, so the relaxation's optimum is at most this (not a bound on plans).

The bound's distance to the estimate is roughly what the sampling leaves open; the estimate's
distance to the plan, what the relaxation leaves out (the obstacles between the points, the
command lattice, the tolerance band) or what the planner loses, which finer sampling does not
close.
Writes ``benchmarks/results/bounds.md`` and prints it.
"""

from __future__ import annotations

import datetime as dt
import itertools
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import report
from report import table

from armpath.model.seed_arm import seed_arm
from armpath.planning.bounds import CommandBound, tour_bound
from armpath.planning.bounds.search import MAX_SAMPLES, SEARCH_ROUNDS, search_rounds
from armpath.planning.tour import _targets_family
from armpath.planning.trace.plan import TraceOptions, trace_plan_bound
from armpath.scenes import load_scene, seed_scene
from armpath.scenes.arm import scene_arm
from armpath.tasks import spotweld_task, trace_task

UR5_CELL = Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml"
#: The larger budget of live samples the last bound column allows (``--bound-samples``).
MORE_SAMPLES = 200_000


def _timed(run: Callable[[], CommandBound]) -> tuple[CommandBound, float]:
    t = time.perf_counter()
    b = run()
    return b, time.perf_counter() - t


def _trace_case(name: str, scene, arm) -> list[str]:
    t = time.perf_counter()
    res = trace_task(scene, arm, TraceOptions(bound=False))
    plan_s = time.perf_counter() - t

    def bound(rounds: int | None = None, max_samples: int | None = None) -> CommandBound:
        # what the trace reports with its bound
        found = trace_plan_bound(res, rounds=rounds, max_samples=max_samples)
        assert found is not None
        return found

    first, first_s = _timed(lambda: bound(rounds=1))
    full, full_s = _timed(bound)
    more, more_s = _timed(lambda: bound(max_samples=MORE_SAMPLES))
    exact = trace_plan_bound(res, with_errors=False)
    assert exact is not None
    return _row(name, res.n_commands, plan_s, first, first_s, full, full_s, more, more_s, exact)


def _tour_case(name: str, scene, arm) -> list[str]:
    t = time.perf_counter()
    res = spotweld_task(scene, arm)  # a tour plans with its bound
    plan_s = time.perf_counter() - t
    pts = scene.spotweld_targets_mm()
    fam = _targets_family(arm or seed_arm(), scene.world, pts)
    q0 = res.sequence.grid.to_joint(res.sequence.start_ticks)
    orders = list(itertools.permutations(range(pts.shape[0])))

    def bound(**kw: object) -> CommandBound:
        return tour_bound(fam, q0, pts, res.tolerance_mm, orders, **kw)[0]  # type: ignore[arg-type]

    first, first_s = _timed(lambda: bound(rounds=1))
    full, full_s = _timed(bound)
    more, more_s = _timed(lambda: bound(max_samples=MORE_SAMPLES))
    exact = bound(with_errors=False)
    return _row(name, res.n_commands, plan_s, first, first_s, full, full_s, more, more_s, exact)


def _row(
    name: str,
    plan: int,
    plan_s: float,
    first: CommandBound,
    first_s: float,
    full: CommandBound,
    full_s: float,
    more: CommandBound,
    more_s: float,
    exact: CommandBound,
) -> list[str]:
    clear = full.sampling.get("clear_path_commands", np.inf)
    return [
        name,
        f"{plan} ({plan_s:.0f} s)",
        f"{first.value:.1f} ({first_s:.1f} s)",
        f"**{full.value:.1f}** ({full_s:.1f} s, {full.sampling['rounds']:.0f} rounds, "
        f"{full.sampling['samples']:,.0f} samples)",
        f"{more.value:.1f} ({more_s:.1f} s, {more.sampling['rounds']:.0f} rounds)",
        f"{exact.value:.1f}",
        f"{100.0 * (plan - exact.value) / max(exact.value, 1e-9):.0f} %",
        "none found" if not np.isfinite(clear) else f"{clear:.1f}",
        f"{100.0 * (plan - full.commands) / max(full.commands, 1):.0f} %",
    ]


def main() -> int:
    seed = seed_scene()
    cell = load_scene(UR5_CELL)
    ur5 = scene_arm(cell)
    rows = [
        _trace_case("seed Task 2 (crack, 1 pass)", seed, None),
        _tour_case("seed Task 3 (4 welds, every order)", seed, None),
        _trace_case("UR5 cell seam (closed, 1 pass)", cell, ur5),
        _tour_case("UR5 cell welds (every order)", cell, ur5),
    ]
    v = report.versions(("numpy", "numba"))
    when = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Lower bounds of traces and tours against their plans",
        "",
        f"`python benchmarks/bench_bounds.py` — armpath at {v['armpath']}; Python "
        f"{v['python']}, numpy {v['numpy']}, numba {v['numba']}; {when}.",
        "",
        table(
            [
                "task",
                "plan [commands]",
                "bound, first sampling",
                "bound, branch and bound",
                f"the same with {MORE_SAMPLES:,} samples",
                "samples taken exact (estimate)",
                "plan above the estimate",
                "a clear path of the relaxation",
                "plan above the bound",
            ],
            rows,
        ),
        "",
        "Commands (fractional: a bound's value before it is rounded up). The first sampling is "
        "the search's first round alone (tool directions sampled once, each distance less the "
        "samples' sampling errors). The branch and bound drops the direction cells that cannot "
        "hold a path cheaper than the incumbent (the plan's commands, or a path through clear "
        "samples if cheaper) and splits the others where the bound runs, until it stalls or "
        f"its budget is spent (by default {MAX_SAMPLES:,} live samples and {SEARCH_ROUNDS} "
        f"rounds; the next column allows {MORE_SAMPLES:,} and {search_rounds(MORE_SAMPLES)}, "
        f"`--bound-samples {MORE_SAMPLES}`). The estimate is the same "
        "search with the samples taken as exact, no sampling error subtracted: the shortest path "
        "through the samples themselves, an estimate of the relaxation's optimum (neither a "
        "bound nor surely a path the relaxation allows: samples kept because a member near "
        "them may be clear count too; the bound and it approach each other as the sampling "
        "gets finer). A plan far above it is held up by what the relaxation leaves out or by "
        "the planner, which finer sampling does not close. The clear path is the "
        "relaxation's own: samples that are clear "
        "themselves, taken as exact, so the relaxation's optimum is at most that; between it "
        "and the plan lie the obstacles between the points, the command lattice and the "
        "tolerance band, which the relaxation leaves out (none found: no sampled member at an "
        "end of the seed crack's reachable arc is clear itself, the family narrows to a point "
        "there).",
        "",
    ]
    return report.write(report.ROOT / "benchmarks" / "results" / "bounds.md", lines)


if __name__ == "__main__":
    raise SystemExit(main())
