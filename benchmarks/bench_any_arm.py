"""Any arm (issue 18): how long a UR5 reach and a UR5 trace take, and the seed tasks beside them.

Run with ``python benchmarks/bench_any_arm.py`` (``--help`` for the knobs). In one process, after a
warm-up that compiles the kernels:

* **UR5 reach** (the arm alone, from its home, fewest commands, 0.05 mm) to targets across its
  workspace: wall time of each ``plan_reach`` call, and ``armpath reach ... --model ur5`` from
  the shell (interpreter start-up and imports included);
* **UR5 traces** in ``examples/ur5_cell.toml``: the scene's 572 mm seam round the workpiece, and
  an 80 mm-radius circle (503 mm) above the table, each planned alone (``bound=False``: what
  the 30 s goal is about) and with its lower bound;
* **the seed tasks** (reach, trace, spot welds) with their command counts, which must stay
  63 / 139 / 121 or fewer (this machine; the tours differ between machines, see the README),
  and their bounds;
* **a UR5 on a track** (``examples/track_cell.toml``): its trace and its tour, the proven
  bound (the carriage's travel), the plan's gap to it and the family's estimate.

Goals (issue 18, on 2 cores): a UR5 reach <= 2 s, a 500 mm trace <= 30 s. Writes
``benchmarks/results/any_arm.md`` and prints it.
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import report
from report import table

from armpath.geometry.world import CollisionWorld
from armpath.model.catalog import resolve_model
from armpath.model.seed_arm import seed_arm
from armpath.planning.reach import plan_reach
from armpath.planning.trace import TraceOptions
from armpath.scenes import load_scene, seed_scene
from armpath.scenes.arm import scene_arm
from armpath.tasks import reach_task, spotweld_task, trace_task

ROOT = Path(__file__).resolve().parents[1]
CELL = ROOT / "examples" / "ur5_cell.toml"
TRACK = ROOT / "examples" / "track_cell.toml"
OUT = ROOT / "benchmarks" / "results" / "any_arm.md"

#: UR5 reach targets (mm, in the base frame) across its workspace: front, side, high, low, far.
UR5_TARGETS = (
    (300.0, 200.0, 300.0),
    (-400.0, 100.0, 200.0),
    (100.0, -450.0, 500.0),
    (500.0, 0.0, -100.0),
    (0.0, 600.0, 100.0),
)
CIRCLE_RADIUS_MM = 80.0


def _timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def ur5_reach(repeats: int) -> tuple[list[list[str]], float]:
    arm = resolve_model("ur5")
    world = CollisionWorld(())
    start = arm.lattice.to_ticks(arm.home, "home")
    plan_reach(arm, world, start, np.array(UR5_TARGETS[0]))  # warm-up: compile
    rows, worst = [], 0.0
    for target in UR5_TARGETS:
        times = []
        for _ in range(repeats):
            res, s = _timed(plan_reach, arm, world, start, np.array(target))
            times.append(s)
        med = statistics.median(times)
        worst = max(worst, med)
        rows.append(
            [
                "reach ({:g}, {:g}, {:g}) mm".format(*target),
                str(res.n_commands),
                str(res.lower_bound.commands),
                f"{res.error_mm:.4f}",
                f"{med:.2f}",
            ]
        )
    return rows, worst


def ur5_reach_cli(repeats: int) -> float:
    cmd = [sys.executable, "-m", "armpath", "reach", "300", "200", "300", "--model", "ur5"]
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def _circle_scene(folder: Path) -> Path:
    c, r = (330.0, -200.0, 150.0), CIRCLE_RADIUS_MM
    text = CELL.read_text(encoding="utf-8").split("[tasks.reach]")[0]
    path = folder / "circle.toml"
    path.write_text(
        text
        + '[tasks.trace.curve]\ntype = "parametric"\nname = "circle"\n'
        + f'x = "{c[0]} + {r} * cos(t)"\ny = "{c[1]} + {r} * sin(t)"\nz = "{c[2]}"\n'
        + f"t = [0, {2 * math.pi!r}]\n",
        encoding="utf-8",
    )
    return path


#: Columns of the UR5 traces' table.
TRACE_COLUMNS = [
    "curve",
    "commands",
    "bound",
    "passes",
    "deviation [mm]",
    "plan alone [s]",
    "with its bound [s]",
]


def ur5_traces() -> tuple[list[list[str]], float]:
    """Each trace planned alone (``bound=False``) and with its lower bound; the rows and the
    slowest plan alone (s)."""
    rows = []
    slowest = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for label, path in (("seam", CELL), ("circle", _circle_scene(Path(tmp)))):
            scene = load_scene(path)
            arm = scene_arm(scene)
            alone, s_alone = _timed(trace_task, scene, arm, TraceOptions(bound=False))
            res, s = _timed(trace_task, scene, arm)
            assert alone.n_commands == res.n_commands  # the bound does not change the plan
            slowest = max(slowest, s_alone)
            rows.append(
                [
                    f"trace: {label} ({res.curve.length:.0f} mm)",
                    str(res.n_commands),
                    "-" if res.lower_bound is None else str(res.lower_bound.commands),
                    f"{len(res.passes)} pass(es)",
                    f"{res.max_deviation_mm:.4f}",
                    f"{s_alone:.1f}",
                    f"{s:.1f}",
                ]
            )
    return rows, slowest


def seed_tasks() -> list[list[str]]:
    scene, arm = seed_scene(), seed_arm()
    rows = []
    res, s = _timed(reach_task, scene, arm)
    rows.append(["1 reach", str(res.n_commands), str(res.lower_bound.commands), f"{s:.1f}"])
    res, s = _timed(trace_task, scene, arm)
    rows.append(["2 trace", str(res.n_commands), _bound(res.lower_bound), f"{s:.1f}"])
    res, s = _timed(spotweld_task, scene, arm)
    rows.append(["3 spot welds", str(res.n_commands), _bound(res.lower_bound), f"{s:.1f}"])
    return rows


def _bound(bound) -> str:
    """A result's lower bound for a table: its commands, "(estimate)" where not proven."""
    if bound is None:
        return "-"
    return str(bound.commands) + ("" if bound.proven else " (estimate)")


def track_tasks() -> list[list[str]]:
    """``examples/track_cell.toml`` (a UR5 on a 2 m track): its trace and its tour, each with
    its proven bound (the carriage's travel) and the family's estimate named in it."""
    scene = load_scene(TRACK)
    arm = scene_arm(scene)
    rows = []
    for label, task in (("trace (1.7 m seam)", trace_task), ("spot welds (3)", spotweld_task)):
        res, s = _timed(task, scene, arm)
        bound = res.lower_bound
        estimate = (bound.sampling or {}).get("family_estimate_commands") if bound else None
        rows.append(
            [
                label,
                str(res.n_commands),
                _bound(bound),
                "-" if bound is None else f"{100 * (res.n_commands / bound.commands - 1):.1f}",
                "-" if estimate is None else f"{math.ceil(estimate - 1e-9)}",
                f"{s:.1f}",
            ]
        )
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per reach (default 3)")
    ap.add_argument("--out", type=Path, default=OUT, help=f"report file (default {OUT})")
    args = ap.parse_args()
    if not 1 <= args.repeats <= 100:
        sys.exit("error: --repeats must be in 1..100")
    started = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    reach_rows, worst = ur5_reach(args.repeats)
    cli = ur5_reach_cli(args.repeats)
    trace_rows, slowest_trace = ur5_traces()
    seed_rows = seed_tasks()
    track_rows = track_tasks()
    v = report.versions(("numpy", "numba"))
    lines = [
        "# Any arm: UR5 reach and trace, seed tasks",
        "",
        f"`python benchmarks/bench_any_arm.py --repeats {args.repeats}` — armpath at "
        f"{v['armpath']}; Python {v['python']}, numpy {v['numpy']}, numba {v['numba']}; "
        f"{started}. Wall times after a warm-up that compiles the kernels (one process).",
        "",
        "## UR5 alone, from home, 0.05 mm (goal: <= 2 s a reach)",
        "",
        table(
            ["target", "commands", "bound", "error [mm]", "median wall [s]"],
            reach_rows,
        ),
        "",
        f"Slowest reach: {worst:.2f} s (goal 2 s: {'met' if worst <= 2.0 else 'NOT met'}). "
        f"`armpath reach 300 200 300 --model ur5` from the shell: {cli:.2f} s median "
        "(start-up and imports included).",
        "",
        "## UR5 in examples/ur5_cell.toml, 0.1 mm (goal: <= 30 s a 500 mm trace)",
        "",
        table(TRACE_COLUMNS, trace_rows),
        "",
        f"Slowest plan alone: {slowest_trace:.1f} s (goal 30 s: "
        f"{'met' if slowest_trace <= 30.0 else 'NOT met'}); the lower bound's search comes on "
        "top (`--no-bound` leaves it out).",
        "",
        "## Seed tasks (commands must stay 63 / 139 / 121 or fewer)",
        "",
        table(["task", "commands", "bound", "wall [s]"], seed_rows),
        "",
        "## A UR5 on a 2 m track, examples/track_cell.toml",
        "",
        table(
            [
                "task",
                "commands",
                "proven bound",
                "plan above it [%]",
                "family's estimate (not proven)",
                "wall [s]",
            ],
            track_rows,
        ),
        "",
        "The proven bound is the carriage's travel to where the arm reaches every point "
        "(`armpath.planning.bounds.carriage`).",
        "",
    ]
    return report.write(args.out, lines)


if __name__ == "__main__":
    sys.exit(main())
