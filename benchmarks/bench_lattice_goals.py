"""Listing the lattice goal states of a tour's welds (issue 21): when the clearance is looked at.

Run with ``python benchmarks/bench_lattice_goals.py``. For each weld of the seed scene's Task 3
and of the UR5 cell (``examples/ur5_cell.toml``), the lattice states within the tolerance that
keep the clearance rule are listed (:func:`armpath.planning.bounds.lattice_goals.
lattice_goal_states`, one thread, as the tour's bound lists them) three ways: with the clearance
looked at in boxes 8 ticks wide only; at each of
:data:`~armpath.planning.bounds.lattice_goals.COARSE_TICKS` (32, 16 and 8 ticks); and on the
default schedule, the same widths until a look drops less than
:data:`~armpath.planning.bounds.lattice_goals.MIN_DROPPED_SHARE` of its boxes. All must list the
same clear states (checked); the table gives the boxes looked at, the states kept before the
exact clearance check, the clear states and the seconds. No peer library lists lattice goal
states; the comparison is between the schedules, in one run. Writes
``benchmarks/results/lattice_goals.md`` and prints it.
"""

from __future__ import annotations

import datetime as dt
import time
from pathlib import Path

import report
from report import table

from armpath.api import arm_and_scene
from armpath.planning.bounds import lattice_goals
from armpath.planning.bounds.sampling import FamilySampler
from armpath.planning.bounds.tour import listing_ranges
from armpath.planning.tour import _targets_family

UR5_CELL = Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml"
#: Task 3's tolerance and the UR5 cell's welds' (mm).
TOLERANCE_MM = 0.05
#: Boxes and states the listings may take here: ten and twenty times the defaults, so the 8-tick
#: schedule ends too (on the UR5 cell it keeps 2.5 million boxes 8 ticks wide at a weld, past
#: the default 2,000,000).
LARGER_BUDGET = (10 * lattice_goals.MAX_GOAL_BOXES, 20 * lattice_goals.MAX_GOAL_STATES)
#: Widths looked at, and the least share of its boxes a look must drop for the next to be looked at.
DEFAULT = "32, 16, 8 until a look drops under a quarter (default)"
SCHEDULES = {
    "8 ticks only": ((8,), 0.0),
    "32, 16, 8, every one": (lattice_goals.COARSE_TICKS, 0.0),
    DEFAULT: (lattice_goals.COARSE_TICKS, lattice_goals.MIN_DROPPED_SHARE),
}


def _case(name: str, scene_source: Path | None) -> list[list[str]]:
    arm, scene = arm_and_scene(None, scene_source)
    world = scene.world
    welds = scene.spotweld_targets_mm()
    q0 = arm.lattice.to_joint(arm.lattice.to_ticks(arm.home, "initial pose"))  # the tour's start
    sampler = FamilySampler(_targets_family(arm, world, welds), TOLERANCE_MM, q_start=q0)
    ranges = listing_ranges(sampler, q0)
    assert ranges is not None, f"{name}: its states cannot be listed"
    start, lower, upper = ranges
    rows = []
    for k, weld in enumerate(welds):
        found = {}
        for label, schedule in SCHEDULES.items():
            lattice_goals.COARSE_TICKS, lattice_goals.MIN_DROPPED_SHARE = schedule
            t = time.perf_counter()
            listed = lattice_goals.lattice_goal_states(
                arm,
                weld,
                TOLERANCE_MM,
                sampler.tip,
                start,
                lower,
                upper,
                may_be_clear=lambda q, moved: world.may_be_clear_within(arm, q, moved),
                max_boxes=LARGER_BUDGET[0],
                max_states=LARGER_BUDGET[1],
            )
            q = arm.lattice.to_joint(listed.ticks)
            clear = listed.ticks[world.satisfied(arm, q)]
            seconds = time.perf_counter() - t
            assert listed.complete
            found[label] = {tuple(s) for s in clear}
            rows.append(
                [
                    f"{name}, weld {k + 1}",
                    label,
                    f"{listed.boxes:,}",
                    f"{listed.ticks.shape[0]:,}",
                    f"{clear.shape[0]:,}",
                    f"{seconds:.1f}",
                ]
            )
        first, *others = found.values()
        assert all(other == first for other in others), f"{name} weld {k + 1}: lists differ"
    lattice_goals.COARSE_TICKS, lattice_goals.MIN_DROPPED_SHARE = SCHEDULES[DEFAULT]
    return rows


def main() -> int:
    rows = _case("seed Task 3", None) + _case("UR5 cell", UR5_CELL)
    totals = []
    for label in SCHEDULES:
        for case in ("seed Task 3", "UR5 cell"):
            mine = [r for r in rows if r[1] == label and r[0].startswith(case)]
            seconds = sum(float(r[5]) for r in mine)
            totals.append([f"{case}, all welds", label, "", "", "", f"{seconds:.1f}"])
    v = report.versions(("numpy", "numba"))
    lines = [
        "# Lattice goal states of the welds: when the clearance is looked at",
        "",
        f"`python benchmarks/bench_lattice_goals.py` — armpath at {v['armpath']}; Python "
        f"{v['python']}, numpy {v['numpy']}, numba {v['numba']}; "
        f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC; one thread.",
        "",
        table(
            ["weld", "clearance looked at", "boxes", "states kept", "clear states", "seconds"],
            rows + totals,
        ),
        "",
        "States kept: within the tolerance, in boxes whose clearance did not rule them out, "
        "before each state's exact clearance check. The schedules list the same clear states "
        "(checked), here with ten times the default budget of boxes and twenty times that of "
        "states: with the defaults, the 8-tick schedule gives up at the UR5 cell's welds (2.5 "
        "million boxes 8 ticks wide kept at a weld). The tour's bound lists two welds at a time "
        "on two threads.",
    ]
    return report.write(report.ROOT / "benchmarks" / "results" / "lattice_goals.md", lines)


if __name__ == "__main__":
    raise SystemExit(main())
