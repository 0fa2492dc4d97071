"""Motion planning: our ``plan_motion`` against OMPL's RRT-Connect on the same collision model.

Run with ``python benchmarks/bench_planning.py`` (``--help`` for the knobs). Problems:

* the four Task-3 legs of the seed scene, each on its own from the start pose (home) to the
  lattice goal states of one spot-weld target (``goal_states``, nearest first);
* harder scenes built with ``scene_from_dict`` (the seed scene plus obstacles) whose straight
  motion to the goal is blocked: a box wall across the sweep of joint 1 (joint-space goal) and a
  shelf around a point goal near the base (point goal); opt-in (``--problems all``, it makes
  the run longer than 10 minutes): a ceiling slab over the base on the way to Task 1's tool-box
  point (point goal).

For each problem and seed 0..4 it measures, in the same run,

* ours: ``plan_motion(arm, world, start, goals, MotionOptions(seed=s))`` (direct motion if it is
  certified, else RRT-Connect + shortcuts + lattice conversion + merge + certification);
* OMPL (the PyPI wheel) ``og.RRTConnect`` in a ``RealVectorStateSpace`` over the five joints that
  move the arm (joint 6 moves no point of the arm: it stays at the start value and reaches the
  goal value on the last segment, as ours does). Bounds: the joint limits, unlimited joints
  +-180 deg around the start (widened to contain every goal). The state validity checker and a
  Python ``ob.MotionValidator`` both call our ``edge_checker`` (the same certified straight
  segment test, same buffer and sample spacing, that our RRT uses; a state is the segment
  ``q -> q``), so both planners see exactly the same free space and the same segment resolution.
  Goal: ``ob.GoalStates`` with every goal state. ``simplifySolution()`` (OMPL's full simplifier),
  time limit 30 s, then the path is put on the command lattice the way ours is
  (``path_to_sequence``, then ``merge_commands`` with the same edge test) and the command sequence
  is certified with ``motion_clearance``.

OMPL's global random seed can be set only once per process (``RNG.setSeed`` before any RNG
exists; later calls are ignored, and 0 becomes 1), so every OMPL run happens in a child process
forked from this one after the warm-up, with ``RNG.setSeed(seed + 1)``: the same warm numba
kernels and scene objects, and a reproducible run per seed.

Writes ``benchmarks/results/planning.md`` and prints it. Absolute times drift on this machine
(other work runs on its two cores); the ratios measured in one run hold better.
"""

from __future__ import annotations

import argparse
import copy
import datetime as dt
import multiprocessing as mp
import os
import platform
import statistics
import sys
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import report
from report import table

try:
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou
except ImportError:  # pragma: no cover - the benchmark needs its peer
    sys.exit("bench_planning needs ompl: pip install ompl  (or the 'bench' extra)")

from armpath.commands import (
    TICK_RAD,
    CommandSequence,
    commands_needed,
    deg_to_ticks,
    ticks_to_rad,
)
from armpath.errors import ArmpathError
from armpath.geometry.world import CollisionWorld
from armpath.model import seed_arm
from armpath.model.serial_arm import SerialArm
from armpath.planning.motion import (
    MotionOptions,
    active_joints,
    edge_checker,
    merge_commands,
    path_to_sequence,
    plan_motion,
    retracted_pre_goal,
)
from armpath.planning.motion_check import motion_clearance
from armpath.planning.reach import goal_states
from armpath.planning.rrt import RrtOptions
from armpath.scenes import scene_from_dict, seed_scene

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "planning.md"
IntArray = np.ndarray


# --- problems -------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Problem:
    """Start state and goal states ``(G, 6)`` in ticks, in one world."""

    name: str
    world: CollisionWorld
    start: IntArray
    goals: IntArray
    goal_kind: str
    note: str = ""

    @property
    def lower_bound(self) -> int:
        """Fewest commands of a straight motion to any goal (obstacles ignored)."""
        return min(commands_needed(g - self.start) for g in self.goals)


def _seed_dict() -> dict[str, Any]:
    text = resources.files("armpath.scenes").joinpath("seed.toml").read_text("utf-8")
    return tomllib.loads(text)


def _scene_with(name: str, extra: list[dict[str, Any]], drop_tasks: bool = True) -> Any:
    """The seed scene plus ``extra`` obstacles (schema of ``armpath.scenes``)."""
    data = copy.deepcopy(_seed_dict())
    data["name"] = name
    data["description"] = f"seed scene + {', '.join(o['name'] for o in extra)}"
    data["obstacles"] = list(data["obstacles"]) + extra
    if drop_tasks:
        data.pop("tasks", None)
    return scene_from_dict(data, f"<bench {name}>")


#: Extra obstacles of the harder scenes (mm, deg), and their goals.
#: A wall across the sweep of joint 1 (a plate along the 135 deg direction, 150..600 mm from the
#: base axis, 320 mm tall): the arm must lift over it on its way to the joint-space goal.
WALL = [
    {
        "type": "box",
        "name": "wall",
        "center": [-265.0, 265.0, 160.0],
        "size": [40.0, 450.0, 320.0],
        "rotation_deg": [0.0, 0.0, 45.0],
    }
]
WALL_GOAL_DEG = (90.0, -90.0, 0.0, 0.0, -90.0, 0.0)
#: A ceiling slab above the base: Task 1's point (the tool box) is reached over the top of the
#: base in the straight motion; with the slab the arm must go around.
CEILING = [
    {"type": "box", "name": "ceiling", "center": [0.0, 0.0, 440.0], "size": [300.0, 500.0, 20.0]}
]
CEILING_TARGET_MM = (20.0, -200.0, 120.0)  # Task 1's tool-box point
#: A shelf around a point goal near the base: board at z 150-170, back and side walls.
SHELF = [
    {
        "type": "box",
        "name": "board",
        "center": [-30.0, -330.0, 160.0],
        "size": [260.0, 200.0, 20.0],
    },
    {"type": "box", "name": "back", "center": [-30.0, -440.0, 85.0], "size": [260.0, 20.0, 170.0]},
    {"type": "box", "name": "side", "center": [-170.0, -330.0, 85.0], "size": [20.0, 200.0, 170.0]},
]
SHELF_TARGET_MM = (0.0, -300.0, 100.0)


def build_problems(arm: SerialArm, which: set[str]) -> list[Problem]:
    start = deg_to_ticks(np.degrees(arm.home))
    out: list[Problem] = []
    seed = seed_scene()
    for i, p in enumerate(seed.spotweld_targets_mm()):
        name = f"task3 leg {i + 1}"
        if not _wanted(name, which):
            continue
        goals, _ = goal_states(arm, seed.world, start, p)
        xyz = ", ".join(f"{v:.1f}" for v in p)
        out.append(
            Problem(name, seed.world, start, goals, f"point ({xyz}) mm, {len(goals)} states")
        )
    if _wanted("wall", which):
        scene = _scene_with("wall", WALL)
        goal = deg_to_ticks(WALL_GOAL_DEG)[None, :]
        out.append(
            Problem(
                "wall",
                scene.world,
                start,
                goal,
                "joint goal (90, -90, 0, 0, -90, 0) deg",
                "box wall 40 x 450 x 320 mm across the sweep of joint 1",
            )
        )
    if _wanted("ceiling", which):
        scene = _scene_with("ceiling", CEILING)
        goals, _ = goal_states(arm, scene.world, start, CEILING_TARGET_MM)
        out.append(
            Problem(
                "ceiling",
                scene.world,
                start,
                goals,
                f"point (20, -200, 120) mm (Task 1), {len(goals)} states",
                "box slab 300 x 500 x 20 mm at z 430-450 over the base",
            )
        )
    if _wanted("shelf", which):
        scene = _scene_with("shelf", SHELF)
        goals, _ = goal_states(arm, scene.world, start, SHELF_TARGET_MM)
        out.append(
            Problem(
                "shelf",
                scene.world,
                start,
                goals,
                f"point (0, -300, 100) mm, {len(goals)} states",
                "a shelf (board at z 150-170, back and side walls) around the target",
            )
        )
    return out


#: Problems left out of the default run (it must stay under 10 minutes on 2 cores): our planner
#: fails every seed of "ceiling", each failure costing all its searches (~30 s).
OPT_IN = ("ceiling",)


def _wanted(name: str, which: set[str]) -> bool:
    """``which``: substrings of problem names; empty = the default set; ``{"all"}`` = every one."""
    if "all" in which:
        return True
    if not which:
        return name not in OPT_IN
    return any(w in name for w in which)


# --- ours -----------------------------------------------------------------------------------


@dataclass
class Run:
    """One planner run on one problem with one seed."""

    seed: int
    success: bool
    seconds: float
    commands: int | None = None
    certified: bool = False
    samples: int | None = None
    method: str = ""
    error: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


def run_ours(arm: SerialArm, prob: Problem, seed: int, step_deg: float = 0.0) -> Run:
    opts = MotionOptions(seed=seed)
    if step_deg > 0:
        opts = MotionOptions(seed=seed, rrt=RrtOptions(step=float(np.radians(step_deg))))
    t0 = time.perf_counter()
    try:
        plan = plan_motion(arm, prob.world, prob.start, prob.goals, opts)
    except ArmpathError as exc:
        return Run(seed, False, time.perf_counter() - t0, error=str(exc)[:160])
    return Run(
        seed,
        True,
        time.perf_counter() - t0,
        commands=plan.sequence.n_commands,
        certified=plan.clearance.certified_ok,
        samples=plan.searched_samples,
        method=plan.method,
    )


# --- OMPL -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class OmplSettings:
    time_limit: float = 30.0
    range_rad: float = 0.0  # 0: OMPL's default (0.2 x the space's maximum extent)
    simplify: bool = True


def _ompl_bounds(arm: SerialArm, prob: Problem, active: np.ndarray) -> tuple[np.ndarray, ...]:
    s = ticks_to_rad(prob.start)
    g = ticks_to_rad(prob.goals)
    lo = np.array([j.limits[0] for j in arm.joints])
    hi = np.array([j.limits[1] for j in arm.joints])
    lo = np.where(np.isfinite(lo), lo, np.minimum(s - np.pi, g.min(axis=0)))
    hi = np.where(np.isfinite(hi), hi, np.maximum(s + np.pi, g.max(axis=0)))
    return lo[active], hi[active]


def ompl_solve(arm: SerialArm, prob: Problem, seed: int, cfg: OmplSettings) -> Run:
    """One OMPL RRT-Connect run (call in a fresh process: it sets OMPL's global seed)."""
    ou.setLogLevel(ou.LOG_ERROR)
    ou.RNG.setSeed(seed + 1)  # OMPL turns seed 0 into 1
    opts = MotionOptions()
    check = edge_checker(arm, prob.world, opts.buffer_mm, opts.sample_spacing_mm)
    active = active_joints(arm)
    idx = np.flatnonzero(active)
    dim = idx.size
    s_rad = ticks_to_rad(prob.start)
    g_rad = ticks_to_rad(prob.goals)
    lo, hi = _ompl_bounds(arm, prob, active)
    # like ours: a goal whose tool tip touches a surface is searched for at its pre-goal (tip
    # backed off along the surface normal), then reached by one straight approach motion
    pre = np.array(
        [retracted_pre_goal(arm, prob.world, g, active, opts.approach_mm) for g in g_rad]
    )

    space = ob.RealVectorStateSpace(dim)
    bounds = ob.RealVectorBounds(dim)
    for k in range(dim):
        bounds.setLow(k, float(lo[k]))
        bounds.setHigh(k, float(hi[k]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    stats = {"state_calls": 0, "motion_calls": 0, "callback_s": 0.0}

    def full(st: Any) -> np.ndarray:
        q = s_rad.copy()
        q[idx] = [st[k] for k in range(dim)]
        return q

    def state_ok(st: Any) -> bool:
        t = time.perf_counter()
        q = full(st)[None, :]
        ok = bool(check(q, q)[0])
        stats["state_calls"] += 1
        stats["callback_s"] += time.perf_counter() - t
        return ok

    class EdgeValidator(ob.MotionValidator):  # type: ignore[misc]
        """Our certified straight-segment test as OMPL's motion validator."""

        def checkMotion(self, a: Any, b: Any, *_rest: Any) -> bool:  # noqa: N802
            t = time.perf_counter()
            ok = bool(check(full(a)[None, :], full(b)[None, :])[0])
            stats["motion_calls"] += 1
            stats["callback_s"] += time.perf_counter() - t
            return ok

    si.setStateValidityChecker(state_ok)
    validator = EdgeValidator(si)
    si.setMotionValidator(validator)
    si.setup()

    ss = og.SimpleSetup(si)
    start = si.allocState()
    for k in range(dim):
        start[k] = float(s_rad[idx[k]])
    ss.setStartState(start)
    goal = ob.GoalStates(si)
    for g in pre:
        st = si.allocState()
        for k in range(dim):
            st[k] = float(g[idx[k]])
        goal.addState(st)
    ss.setGoal(goal)
    planner = og.RRTConnect(si)
    if cfg.range_rad > 0:
        planner.setRange(cfg.range_rad)
    ss.setPlanner(planner)
    ss.setup()
    range_used = planner.getRange()

    t0 = time.perf_counter()
    status = ss.solve(cfg.time_limit)
    t_solve = time.perf_counter() - t0
    extra: dict[str, Any] = {"range_rad": range_used, "solve_s": t_solve}
    if not ss.haveExactSolutionPath():
        stats_out = {**stats, **extra}
        return Run(seed, False, time.perf_counter() - t0, error=str(status), extra=stats_out)
    t1 = time.perf_counter()
    if cfg.simplify:
        ss.simplifySolution()
    extra["simplify_s"] = time.perf_counter() - t1
    path = ss.getSolutionPath()
    states = np.array(
        [[path.getState(i)[k] for k in range(dim)] for i in range(path.getStateCount())]
    )
    extra["path_states"] = len(states)
    search_s = time.perf_counter() - t0
    gi = int(np.argmin(np.abs(pre[:, idx] - states[-1]).max(axis=1)))
    extra["goal_gap_rad"] = float(np.abs(pre[gi, idx] - states[-1]).max())
    # onto the lattice exactly as plan_motion does: inactive joints at the start value, the
    # goal's value at the end; full speed along the path, then merge runs of commands; the
    # approach from a pre-goal is its own straight motion
    path_rad = np.broadcast_to(s_rad, (len(states), s_rad.size)).copy()
    path_rad[:, idx] = states
    path_rad[-1] = np.where(active, pre[gi], g_rad[gi])
    if np.array_equal(pre[gi], g_rad[gi]):
        seq_raw = path_to_sequence(path_rad / TICK_RAD, prob.start, prob.goals[gi], arm.lattice)
        seq = merge_commands(seq_raw, check)
    else:
        pre_ticks = np.round(path_rad[-1] / TICK_RAD).astype(np.int64)
        last = CommandSequence.straight(pre_ticks, prob.goals[gi]).commands
        raw = path_to_sequence(path_rad / TICK_RAD, prob.start, pre_ticks, arm.lattice)
        merged = merge_commands(raw, check)
        seq_raw = CommandSequence(prob.start, np.vstack([raw.commands, last]))
        seq = CommandSequence(prob.start, np.vstack([merged.commands, last]))
    mc = motion_clearance(arm, prob.world, seq)
    total = time.perf_counter() - t0
    extra["lattice_s"] = total - search_s
    same = np.array_equal(seq_raw.commands, seq.commands)
    certified_raw = (
        mc.certified_ok if same else motion_clearance(arm, prob.world, seq_raw).certified_ok
    )
    extra.update(
        stats,
        search_s=search_s,
        commands_raw=seq_raw.n_commands,
        certified_raw=certified_raw,
        goal_index=gi,
        limiting=(
            ""
            if mc.certified_ok
            else f"{mc.limiting_pair} {mc.limiting_slack:+.3f} mm at command "
            f"{mc.limiting_command}"
            + (", violated" if mc.violated else f", proven bound {mc.lower_bound_slack:+.4f}")
        ),
    )
    return Run(
        seed,
        True,
        total,
        commands=seq.n_commands,
        certified=mc.certified_ok,
        method="rrt-connect + simplifySolution + lattice merge",
        extra=extra,
    )


def _child(conn: Any, arm: SerialArm, prob: Problem, seed: int, cfg: OmplSettings) -> None:
    try:
        q = ticks_to_rad(prob.start)[None, :]
        prob.world.slack(arm, q)  # touch the (inherited, compiled) kernels before timing
        run = ompl_solve(arm, prob, seed, cfg)
    except Exception as exc:  # report, never hang the parent
        run = Run(seed, False, float("nan"), error=f"{type(exc).__name__}: {exc}"[:200])
    conn.send(run)
    conn.close()


def run_ompl(arm: SerialArm, prob: Problem, seed: int, cfg: OmplSettings) -> Run:
    """``ompl_solve`` in a forked child (fresh OMPL seed), killed if it overruns badly."""
    ctx = mp.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, arm, prob, seed, cfg))
    t0 = time.perf_counter()
    proc.start()
    send.close()
    deadline = cfg.time_limit * 4 + 120.0
    run = None
    if recv.poll(deadline):
        try:
            run = recv.recv()
        except EOFError:
            run = None
    proc.join(10.0)
    if proc.is_alive():
        proc.kill()
        proc.join()
    if run is None:
        why = f"child exit code {proc.exitcode}" if proc.exitcode else "timed out"
        run = Run(seed, False, time.perf_counter() - t0, error=why)
    return run


# --- report ---------------------------------------------------------------------------------


def _median(values: list[float] | list[int | None]) -> float | None:
    """Median of the values that are not None (None when there are none)."""
    present = [float(v) for v in values if v is not None]
    return statistics.median(present) if present else None


def _fmt(x: float | None, spec: str = ".2f") -> str:
    return "-" if x is None else format(x, spec)


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.machine()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5, help="seeds 0 .. N-1 for both planners")
    ap.add_argument("--time-limit", type=float, default=30.0, help="OMPL solve limit [s]")
    ap.add_argument(
        "--ompl-range-deg",
        type=float,
        default=0.0,
        help="RRT-Connect range (L2 over 5 joints, deg); 0 = OMPL's default",
    )
    ap.add_argument(
        "--ours-step-deg",
        type=float,
        default=0.0,
        help="our RRT step (largest joint change, deg); 0 = MotionOptions' default",
    )
    ap.add_argument(
        "--problems",
        nargs="*",
        default=[],
        help="substrings of problem names to run; 'all' adds the opt-in ones "
        f"({', '.join(OPT_IN)}); default: every other problem",
    )
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)

    t_start = time.perf_counter()
    arm = seed_arm()
    say: Callable[[str], None] = lambda m: print(m, flush=True)  # noqa: E731
    say("building problems (goal states) ...")
    problems = build_problems(arm, set(args.problems))
    # warm-up: compile / load every numba kernel the planners use, outside the timings
    say("warm-up ...")
    warm = problems[0]
    plan_motion(arm, warm.world, warm.start, warm.start[None, :] + 20, MotionOptions(seed=0))
    edge_checker(arm, warm.world, 0.4, 2.0)(
        ticks_to_rad(warm.start)[None, :], ticks_to_rad(warm.goals[:1])
    )
    motion_clearance(arm, warm.world, CommandSequence.straight(warm.start, warm.goals[0]))
    cfg = OmplSettings(args.time_limit, np.radians(args.ompl_range_deg))
    seeds = range(args.seeds)

    results: dict[str, tuple[list[Run], list[Run]]] = {}
    direct_clear: dict[str, str] = {}
    for prob in problems:
        clear = [
            motion_clearance(arm, prob.world, CommandSequence.straight(prob.start, g)).certified_ok
            for g in prob.goals[:8]
        ]
        direct_ok = f"{sum(clear)} of {len(clear)}"
        direct_clear[prob.name] = direct_ok
        say(f"[{prob.name}] {prob.goal_kind}; straight motions clear: {direct_ok}")
        ours: list[Run] = []
        omp: list[Run] = []
        for s in seeds:
            r = run_ours(arm, prob, s, args.ours_step_deg)
            ours.append(r)
            say(
                f"  ours seed {s}: {'ok' if r.success else 'FAIL'} {r.seconds:.2f} s "
                f"{r.commands} commands {r.samples} samples {r.method}{r.error}"
            )
            o = run_ompl(arm, prob, s, cfg)
            omp.append(o)
            say(
                f"  ompl seed {s}: {'ok' if o.success else 'FAIL'} {o.seconds:.2f} s "
                f"{o.commands} commands (raw {o.extra.get('commands_raw')}) certified "
                f"{o.certified} calls {o.extra.get('state_calls')}/{o.extra.get('motion_calls')} "
                f"{o.error}"
            )
        results[prob.name] = (ours, omp)
    elapsed = time.perf_counter() - t_start

    # --- tables
    main_rows, detail_rows, prob_rows = [], [], []
    for prob in problems:
        ours, omp = results[prob.name]
        t_ours = _median([r.seconds for r in ours])
        t_ompl = _median([r.seconds for r in omp if np.isfinite(r.seconds)])
        ok_ours = [r for r in ours if r.success]
        ok_ompl = [r for r in omp if r.success]
        cert_ompl = [r for r in ok_ompl if r.certified]
        ratio = t_ompl / t_ours if t_ours and t_ompl else None
        main_rows.append(
            [
                prob.name,
                _fmt(t_ours),
                _fmt(t_ompl),
                _fmt(ratio, ".2f"),
                f"{len(ok_ours)}/{len(ours)}",
                f"{len(ok_ompl)}/{len(omp)} ({len(cert_ompl)} cert.)",
                _fmt(_median([r.commands for r in ok_ours]), ".0f"),
                _fmt(_median([r.commands for r in ok_ompl]), ".0f"),
                _fmt(_median([r.extra["commands_raw"] for r in ok_ompl]), ".0f"),
                str(prob.lower_bound),
            ]
        )
        n_direct = sum(r.method == "direct" for r in ok_ours)
        methods = f"{n_direct} direct, {len(ok_ours) - n_direct} searched"
        cb = [
            r.extra["callback_s"] / r.extra["search_s"] for r in ok_ompl if r.extra.get("search_s")
        ]
        detail_rows.append(
            [
                prob.name,
                methods,
                _fmt(_median([r.samples for r in ok_ours]), ".0f"),
                _fmt(_median([r.seconds for r in ok_ours])),
                _fmt(_median([r.extra["solve_s"] for r in ok_ompl])),
                _fmt(_median([r.extra["simplify_s"] for r in ok_ompl])),
                _fmt(_median([r.extra["lattice_s"] for r in ok_ompl])),
                _fmt(_median([r.seconds for r in ok_ompl])),
                _fmt(_median([r.extra["state_calls"] for r in ok_ompl]), ".0f")
                + " / "
                + _fmt(_median([r.extra["motion_calls"] for r in ok_ompl]), ".0f"),
                _fmt(_median([100 * c for c in cb]), ".0f"),
                _fmt(_median([r.extra["path_states"] for r in ok_ompl]), ".0f"),
            ]
        )
        prob_rows.append(
            [
                prob.name,
                prob.goal_kind,
                prob.note or "seed scene",
                direct_clear[prob.name],
            ]
        )
    per_run = []
    for prob in problems:
        ours, omp = results[prob.name]
        for r, o in zip(ours, omp, strict=True):
            per_run.append(
                [
                    prob.name,
                    str(r.seed),
                    f"{r.seconds:.2f}" if r.success else f"fail ({r.seconds:.1f})",
                    str(r.commands) if r.success else "-",
                    f"{o.seconds:.2f}" if o.success else f"fail ({o.seconds:.1f})",
                    (
                        f"{o.commands} / {o.extra.get('commands_raw')}"
                        f"{'' if o.certified else ' (not certified: ' + o.extra['limiting'] + ')'}"
                    )
                    if o.success
                    else "-",
                ]
            )
    failures = []
    for prob in problems:
        ours, omp = results[prob.name]
        for label, runs in (("ours", ours), ("OMPL", omp)):
            for r in runs:
                if not r.success:
                    failures.append(f"- {prob.name}, {label}, seed {r.seed}: {r.error}")

    versions = report.versions(("numpy", "numba", "scipy", "ompl"))
    now = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    try:
        load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        load = "?"
    range_note = f"{args.ompl_range_deg:g} deg" if args.ompl_range_deg > 0 else "OMPL's default"
    ranges = sorted(
        {
            round(r.extra["range_rad"], 4)
            for _, o in results.values()
            for r in o
            if "range_rad" in r.extra
        }
    )
    ompl_range = (
        ", ".join(f"{r:.3g} rad = {np.degrees(r):.0f} deg" for r in ranges) if ranges else "?"
    )
    defaults = MotionOptions()
    searches = int(getattr(defaults, "searches", 1))
    opt_in = [n for n in OPT_IN if not any(p.name == n for p in problems)]
    step_note = (
        f"{args.ours_step_deg:g} deg"
        if args.ours_step_deg > 0
        else f"{np.degrees(RrtOptions().step):g} deg (default)"
    )
    md = [
        "# Motion planning: ours (`plan_motion`) vs OMPL RRT-Connect, same collision model",
        "",
        f"Generated by `python benchmarks/bench_planning.py` on {now} in {elapsed:.0f} s. "
        f"Machine: {_cpu()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, "
        f"load average at the end {load} (shared machine: absolute times drift, ratios hold "
        "better). Versions: " + ", ".join(f"{k} {v}" for k, v in versions.items()) + ".",
        "",
        f"Seeds 0..{args.seeds - 1} for both planners; OMPL time limit {args.time_limit:g} s, "
        f"range {range_note}; our RRT step {step_note}. Times are wall-clock seconds per "
        "run, medians over all seeds (failed runs count with the time they took); command "
        "counts are medians over the successful runs. Ratio = OMPL / ours (> 1: ours is faster).",
        "",
        "## Problems",
        "",
        "Start: the home pose (0, -90, 0, 0, -90, 0) deg. Point goals are the lattice goal "
        "states of `goal_states` (fingertip within 0.05 mm, clear, nearest first); both "
        "planners get all of them.",
        "",
        table(
            ["problem", "goal", "obstacles beyond the seed scene", "straight motions clear"],
            prob_rows,
        ),
        "",
        "## Results",
        "",
        table(
            [
                "problem",
                "ours [s]",
                "OMPL [s]",
                "OMPL / ours",
                "ours success",
                "OMPL success (certified)",
                "ours commands",
                "OMPL commands (merged)",
                "OMPL commands (raw)",
                "direct lower bound",
            ],
            main_rows,
        ),
        "",
        "OMPL commands: the simplified path put on the lattice with our `path_to_sequence` "
        "(raw), then `merge_commands` with the same edge test (merged; the OMPL time includes "
        "both and the certification). Certified = `motion_clearance(...).certified_ok` of the "
        "merged sequence. Direct lower bound: `commands_needed(goal - start)`, smallest over the "
        "goal states, obstacles ignored.",
        "",
        "## Where the time goes",
        "",
        table(
            [
                "problem",
                "ours: method",
                "ours: RRT samples (kept plan)",
                "ours [s] (successes)",
                "OMPL solve [s]",
                "OMPL simplify [s]",
                "OMPL lattice + merge + certify [s]",
                "OMPL total [s] (successes)",
                "OMPL state / motion checks",
                "OMPL time in Python checks [%]",
                "OMPL path states",
            ],
            detail_rows,
        ),
        "",
        "OMPL's checks are Python callbacks into our batched numpy/numba code, one segment per "
        "call; the share is callback time / (solve + simplify). Ours calls the same edge test "
        "(batched where it can: direct goals, shortcuts, merges).",
        "",
        "## Per run",
        "",
        table(
            [
                "problem",
                "seed",
                "ours [s]",
                "ours commands",
                "OMPL [s]",
                "OMPL commands merged / raw",
            ],
            per_run,
        ),
        "",
    ]
    if failures:
        md += ["Failures:", "", *failures, ""]
    if opt_in:
        md += [
            f"Not in this run: {', '.join(opt_in)} (`--problems all` adds it; see `OPT_IN`).",
            "",
        ]
    md += [
        "## What is comparable",
        "",
        "- Same free space: OMPL's state checker and motion validator are our `edge_checker` "
        "(margin + 0.4 mm buffer + half the 2 mm sample spacing at samples no arm point is more "
        "than 2 mm apart), the test our RRT, shortcuts and merges use; same goal states; same "
        "search box except for unlimited joints (ours: from the lowest start/goal value - 180 deg "
        "to the highest + 180; OMPL: start +- 180 deg, widened to the goals); same conversion to "
        "commands and the same certification.",
        "- Not the same: ours tries the straight motions first, searches with a step of "
        f"{np.degrees(defaults.rrt.step):g} deg (largest joint change) and a "
        f"{defaults.rrt.goal_bias:.0%} goal bias, and post-processes with largest-change "
        "(command-count) shortcuts and elastic-band tightening; if the lattice path fails "
        "certification it searches again with 1.5 x the buffer and half the spacing. "
        f"It keeps the best of {searches} successful search(es) and tolerates "
        f"{defaults.attempts} failed one(s) (`MotionOptions` defaults; at most "
        f"{defaults.rrt.max_samples} samples each), so a plan costs about {searches} searches "
        f"and a failure {defaults.attempts + searches - 1}; OMPL makes one search per run. "
        f"OMPL's range is {ompl_range} (L2 over the 5 joints; OMPL's default is 0.2 x the box "
        "diagonal), its simplifier (`simplifySolution()` = reduce vertices, shortcuts, "
        "collapse, B-spline smoothing, better goal) shortens Euclidean joint-space length, and "
        "there is no retry: an OMPL path that fails certification is counted as a success of "
        "the search and marked not certified. OMPL stops at its time limit (never reached "
        "here unless a run says so); ours at its sample budget.",
        "- OMPL's time starts at `solve()` (building the state space and `SimpleSetup` is not "
        "timed, a few ms) and includes the simplification, the lattice conversion, the merge "
        "and the certification; ours is the whole `plan_motion` call. Every OMPL run is a "
        "forked child of this process (warm kernels, its own seed).",
        "",
        "## Notes on the ompl 2.0.1 wheel met while building this",
        "",
        "- `ompl.util.RNG.setSeed` works once per process, before the first RNG exists; later "
        "calls are ignored with an error message, and seed 0 is replaced by 1 (so seeds 0 and 1 "
        "would coincide: the runs use seed + 1). Hence one forked child per OMPL run.",
        "- A Python subclass of `ob.MotionValidator` overriding `checkMotion(s1, s2)` is "
        "accepted by `SpaceInformation.setMotionValidator` and used by RRT-Connect and the "
        "simplifier; `si.setStateValidityChecker` takes a plain Python callable.",
        "- States are indexed `state[i]` (open slices do not work); a process that exits with "
        "OMPL objects alive prints nanobind leak warnings (harmless; the children here exit "
        "without them).",
        "",
    ]
    return report.write(args.out, md)


if __name__ == "__main__":
    raise SystemExit(main())
