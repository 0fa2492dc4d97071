"""What the trace bound loses to its sampling errors (issue 21), on the seed scene's Task 2.

Run with ``python benchmarks/bench_bound_sampling.py``. Task 2 is planned once (its commands
along the crack, and the largest joint change they add up to), then the bound's shortest path
through the family is computed at 5, 20 and 60 points of the traced arc, with the samples'
sampling errors (the proven bound) and without them (the shortest path through the samples
themselves: an estimate of what the bound tends to as the sampling gets finer, not a bound).
Writes ``benchmarks/results/bound_sampling.md`` and prints it.
"""

from __future__ import annotations

import datetime as dt
import time

import numpy as np
import report
from report import table

from armpath.planning.bounds import trace_bound
from armpath.scenes import seed_scene
from armpath.tasks import trace_task

POINTS = (5, 20, 60)


def main() -> int:
    scene = seed_scene()
    t0 = time.perf_counter()
    res = trace_task(scene)
    plan_s = time.perf_counter() - t0
    (pas,) = res.passes
    states = res.sequence.states()[pas.first : pas.last + 1]
    steps = np.abs(np.diff(states, axis=0)) / res.sequence.grid.max_ticks
    change = float(steps.max(axis=1).sum())
    fam = res.reachability.family
    q0 = res.sequence.grid.to_joint(res.sequence.start_ticks)
    span = [(pas.start_mm, pas.end_mm)]
    rows = []
    for points in POINTS:
        for errors in (True, False):
            t = time.perf_counter()
            b = trace_bound(fam, q0, span, res.tolerance_mm, layers_per_span=points,
                            with_errors=errors)  # fmt: skip
            rows.append(
                [
                    str(points),
                    "yes (the bound)" if errors else "no (estimate)",
                    f"{b.parts['along']:.1f}",
                    f"{b.parts['approach']:.1f}",
                    f"{b.value:.1f}",
                    f"{time.perf_counter() - t:.1f}",
                ]
            )
    v = report.versions(("numpy", "numba"))
    when = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Trace bound: what the sampling errors cost",
        "",
        f"`python benchmarks/bench_bound_sampling.py` — armpath at {v['armpath']}; Python "
        f"{v['python']}, numpy {v['numpy']}, numba {v['numba']}; {when}.",
        "",
        f"Task 2 on the seed scene: {res.n_commands} commands, {pas.last - pas.first} of them "
        f"along the crack ({pas.start_mm:.1f}..{pas.end_mm:.1f} mm), whose largest joint "
        f"changes add up to {change:.1f} commands' worth (planned in {plan_s:.0f} s).",
        "",
        table(
            ["points of the arc", "sampling errors", "along", "approach", "total", "wall [s]"],
            rows,
        ),
        "",
        "Commands. Without the errors the value is the shortest path through the samples, not a "
        "bound; with them it is the proven bound, which loses more to the errors (they add up "
        "over the points) than it gains from more points.",
        "",
    ]
    return report.write(report.ROOT / "benchmarks" / "results" / "bound_sampling.md", lines)


if __name__ == "__main__":
    raise SystemExit(main())
