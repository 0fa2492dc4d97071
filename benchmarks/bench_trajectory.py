"""Trajectory solve times: minimum snap in closed form vs QP solvers, and retiming peers.

Run with ``python benchmarks/bench_trajectory.py`` (cvxpy for the modelling-layer peer:
``pip install -e ".[bench]"``; ``--help`` for the knobs). One problem, in the same run: 6 joints
through 101 waypoints (100 segments, a seeded random walk in deg), segment times from the
trapezoid allocation at 60 deg/s and 120 deg/s^2, stretched by ``--stretch`` so that the limits
bind but can be met.

* Minimum snap without limits: ours (one sparse KKT factorisation for all joints), the same
  equality-only QP through OSQP and Clarabel (qpsolvers, one per joint), and through cvxpy.
* Minimum snap with |velocity| <= 60, |acceleration| <= 120, |jerk| <= 600: ours with Clarabel and
  with OSQP (limits at local extremes, re-solved until they hold everywhere), and cvxpy+Clarabel
  with the limits at 16 fixed points a segment (no refinement: it may exceed them in between).
* Retiming under the same limits: uniform scaling, the shortest bounded QP, toppra (velocity and
  acceleration only, on the same path) and ruckig (jerk-limited, between the waypoints).

Each row gives the median time, the cost (sum over joints of the integral of squared snap) over
the unbounded optimum's, and the largest limit ratio measured on 20,001 samples. Writes
``benchmarks/results/trajectory.md`` and prints it.
"""

from __future__ import annotations

import argparse
import datetime as dt
import importlib.util
import os
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import report
from report import table
from scipy import sparse

from armpath.trajectory import MotionLimits, allocate_times, compare_retimings, minimum_snap
from armpath.trajectory import minsnap as ms

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "trajectory.md"
LIMITS = {"velocity": 60.0, "acceleration": 120.0, "jerk": 600.0}


def _median(fn: Callable[[], object], repeats: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times)), out


def _coefficients_to_traj(x: np.ndarray, t: np.ndarray, n: int) -> ms.PiecewisePolynomial:
    """Per-joint solution vectors ``(J, n_seg * n)`` as a trajectory."""
    n_seg = len(t) - 1
    return ms.PiecewisePolynomial(t, np.stack([xj.reshape(n_seg, n) for xj in x], axis=2), 4)


def _limit_ratio(traj: ms.PiecewisePolynomial) -> float:
    tt = np.linspace(traj.times[0], traj.times[-1], 20001)
    return max(
        float(np.abs(traj.evaluate(tt, d)).max() / LIMITS[name])
        for d, name in ((1, "velocity"), (2, "acceleration"), (3, "jerk"))
    )


def _qp_equality_only(problem: ms._Problem, solver: str, t: np.ndarray) -> ms.PiecewisePolynomial:
    from qpsolvers import solve_qp

    xs = []
    for j in range(problem.B.shape[1]):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            x = solve_qp(
                2.0 * problem.Q,
                np.zeros(problem.Q.shape[0]),
                A=problem.A,
                b=problem.B[:, j],
                solver=solver,
                **(
                    {"eps_abs": 1e-8, "eps_rel": 1e-8, "max_iter": 200000}
                    if solver == "osqp"
                    else {}
                ),
            )
        xs.append(np.full(problem.Q.shape[0], np.nan) if x is None else x)
    return _coefficients_to_traj(np.array(xs), t, problem.n)


def _cvxpy_solve(
    problem: ms._Problem, t: np.ndarray, limits: dict[str, np.ndarray] | None
) -> ms.PiecewisePolynomial:
    import cvxpy as cp

    n_seg, n = problem.n_seg, problem.n
    Q = sparse.csc_matrix(problem.Q)
    seg = np.repeat(np.arange(n_seg), 16)
    s = np.tile(np.linspace(0.0, 1.0, 16), n_seg)
    xs = []
    for j in range(problem.B.shape[1]):
        x = cp.Variable(problem.Q.shape[0])
        cons = [problem.A @ x == problem.B[:, j]]
        if limits is not None:
            G, h = ms._limit_rows(problem, t, limits, j, seg, s)
            cons.append(G @ x <= h)
        cp.Problem(cp.Minimize(cp.quad_form(x, Q, assume_PSD=True)), cons).solve(solver=cp.CLARABEL)
        xs.append(np.asarray(x.value))
    return _coefficients_to_traj(np.array(xs), t, n)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--waypoints", type=int, default=101, help="waypoints (segments + 1)")
    parser.add_argument("--stretch", type=float, default=1.2, help="times over the trapezoids")
    parser.add_argument("--repeats", type=int, default=7, help="runs per timing (median)")
    args = parser.parse_args()
    started = time.perf_counter()
    load = os.getloadavg()[0]
    rng = np.random.default_rng(3)
    W = np.cumsum(rng.uniform(-30.0, 30.0, (args.waypoints, 6)), axis=0)
    t = args.stretch * allocate_times(W, LIMITS["velocity"], LIMITS["acceleration"])
    limits = MotionLimits(**LIMITS)
    bounds = [np.zeros((3, 6)), np.zeros((3, 6))]
    problem = ms._equality_problem(W, t, 4, 3, bounds)
    per_joint = limits.per_joint(6)
    have_cvxpy = importlib.util.find_spec("cvxpy") is not None

    rows: list[list[str]] = []
    base_s, free = _median(lambda: minimum_snap(W, t), args.repeats)
    assert isinstance(free, ms.PiecewisePolynomial)
    free_cost = float(free.cost().sum())

    def row(
        group: str, who: str, what: str, seconds: float, traj: ms.PiecewisePolynomial, ref: float
    ) -> None:
        cost = float(traj.cost().sum())
        rows.append(
            [
                group,
                who,
                what,
                f"{1e3 * seconds:.1f}",
                f"{seconds / ref:.1f}",
                f"{cost / free_cost:.6f}" if np.isfinite(cost) else "failed",
                f"{_limit_ratio(traj):.5f}" if np.isfinite(cost) else "",
            ]
        )

    solve_s, solved = _median(lambda: ms._kkt_solve(problem), args.repeats)
    assert isinstance(solved, np.ndarray)
    solved_traj = ms.PiecewisePolynomial(t, solved, 4)
    row(
        "no limits",
        "armpath (ours)",
        "sparse KKT, one LU for 6 joints",
        solve_s,
        solved_traj,
        solve_s,
    )
    row("no limits", "armpath (ours)", "`minimum_snap`: assembly + KKT", base_s, free, solve_s)
    for solver in ("osqp", "clarabel"):
        sec, traj = _median(lambda s=solver: _qp_equality_only(problem, s, t), args.repeats)
        assert isinstance(traj, ms.PiecewisePolynomial)
        row(
            "no limits", f"qpsolvers + {solver}", "same QP, one solve per joint", sec, traj, solve_s
        )
    if have_cvxpy:
        sec, traj = _median(lambda: _cvxpy_solve(problem, t, None), max(1, args.repeats // 3))
        assert isinstance(traj, ms.PiecewisePolynomial)
        row("no limits", "cvxpy + Clarabel", "same QP modelled in cvxpy", sec, traj, solve_s)

    bounded_ref = None
    for solver in ("clarabel", "osqp"):
        sec, traj = _median(
            lambda s=solver: minimum_snap(W, t, limits=limits, solver=s), max(1, args.repeats // 2)
        )
        assert isinstance(traj, ms.PiecewisePolynomial)
        bounded_ref = bounded_ref or sec
        row(
            "v, a, j limits",
            f"armpath (ours) + {solver}",
            "limits at local extremes, re-solved until met",
            sec,
            traj,
            bounded_ref,
        )
    if have_cvxpy:
        sec, traj = _median(lambda: _cvxpy_solve(problem, t, per_joint), 1)
        assert isinstance(traj, ms.PiecewisePolynomial) and bounded_ref is not None
        row(
            "v, a, j limits",
            "cvxpy + Clarabel",
            "limits at 16 fixed points a segment",
            sec,
            traj,
            bounded_ref,
        )

    retimed = compare_retimings(W, t / args.stretch, limits)
    retime_rows = []
    for r in retimed:
        peaks = [r.peak_velocity.max(), r.peak_acceleration.max(), r.peak_jerk.max()]
        retime_rows.append(
            [
                r.method,
                f"{r.duration_s:.2f}",
                *(f"{v:.2f}" for v in peaks),
                r.verdict(limits),
                f"{1e3 * r.compute_s:.0f}",
            ]
        )

    versions = report.versions(
        ("numpy", "scipy", "qpsolvers", "clarabel", "osqp", "cvxpy", "toppra", "ruckig")
    )
    lines = [
        "# Trajectories: minimum snap in closed form vs QP solvers; retiming peers",
        "",
        'Reproduce: `pip install -e ".[bench]"`, then `python benchmarks/bench_trajectory.py`.',
        "",
        f"Generated on {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC in "
        f"{time.perf_counter() - started:.0f} s; load average {load:.2f} at the start (the "
        "machine is shared). Versions: " + ", ".join(f"{k} {v}" for k, v in versions.items()) + ".",
        "",
        f"Problem: 6 joints through {args.waypoints} waypoints (seeded random walk, deg), "
        f"rest to rest, segment times {args.stretch:g} x the trapezoid allocation at 60 deg/s "
        f"and 120 deg/s^2 (total {t[-1]:.1f} s). Limits: |v| <= 60 deg/s, |a| <= 120 deg/s^2, "
        "|j| <= 600 deg/s^3. Cost: sum over joints of the integral of squared snap, over the "
        "unbounded optimum's. Limit ratio: largest |v|/60, |a|/120, |j|/600 on 20,001 samples "
        "(> 1: a limit is exceeded). Times: median of the runs, wall clock. Without limits the "
        "peers get the assembled problem (our `_equality_problem`) for free, so the ratio is to "
        "our solve alone; with limits every row includes building its inequality rows.",
        "",
        "## Minimum snap",
        "",
        table(
            ["problem", "solver", "how", "ms", "× ours", "cost / unbounded", "limit ratio"],
            rows,
        ),
        "",
        "## Retiming under the same limits (the allocated times unstretched)",
        "",
        "`scaled`: the unbounded optimum slowed uniformly until the tightest limit is met. "
        "`bounded`: the bounded QP on the same relative times, compressed by bisection to the "
        "shortest feasible duration. `toppra`: time-optimal along the same path under velocity "
        "and acceleration (no jerk limit). `ruckig`: jerk-limited time-optimal motion between "
        "consecutive waypoints, through them with the `scaled` trajectory's velocity and "
        "acceleration (its own path in between).",
        "",
        table(
            [
                "method",
                "duration [s]",
                "peak speed [deg/s]",
                "peak accel. [deg/s^2]",
                "peak jerk [deg/s^3]",
                "limits",
                "compute [ms]",
            ],
            retime_rows,
        ),
        "",
    ]
    return report.write(RESULT, lines)


if __name__ == "__main__":
    raise SystemExit(main())
