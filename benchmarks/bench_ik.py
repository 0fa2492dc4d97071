"""All-solutions inverse kinematics: ours (``complete_solver``) against peer libraries.

Run with ``python benchmarks/bench_ik.py`` (``--quick`` for a cheap subset, ``--help`` for the
knobs) in an environment with the peers installed (``pip install -e ".[bench-ik]"``; the
versions of the committed results are pinned in ``PIP_PINNED``).

A peer that is not installed is skipped (a row says so). In one run, on the same arms (PUMA 560,
UR5 and random general 6R arms, standard D-H in mm) and the same poses (FK of random joint
vectors), it measures each library's set-up time per arm, single-call wall and thread-CPU time,
batched time where the library has a batch call, completeness (is the generating joint vector
among the solutions?), the number of solutions and their FK residuals by one shared FK
(``ik_peers.fk``), and writes ``benchmarks/results/ik.md``. The adapters are in ``ik_peers.py``.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import ik_peers as peers
import numpy as np
import report
from report import table

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "ik.md"
LIBS = tuple(peers.ADAPTERS)
PIP_EXTRA = 'pip install -e ".[bench-ik]"'
PIP_PINNED = (
    'pip install -e . ssik==8.2.0 "roboticstoolbox-python[ik]==1.5.0" EAIK==1.2.2 ik-geo==1.0.3 '
    "py-ikgeo-kinematics==0.0.2 ikdh==1.2.0"
)
PACKAGES = (
    "numpy",
    "numba",
    "scipy",
    "sympy",
    "ssik",
    "roboticstoolbox-python",
    "eaik",
    "ik-geo",
    "py-ikgeo-kinematics",
    "ikdh",
)


# --- the plan: which library runs on which arms --------------------------------------------------


def plan(args: argparse.Namespace, arms: list[tuple[str, dict]]) -> list[dict[str, Any]]:
    """One job per (library, arm): ``isolated`` jobs run in a child process with a time limit."""
    Q = peers.test_joints(args.poses)
    fixed = [a for a in arms if not a[0].startswith("rand")]
    rand = [a for a in arms if a[0].startswith("rand")]
    take = {
        "ours": arms,
        "eaik": arms,  # declines general arms: recorded as unsupported
        "ikgeo": fixed,  # gen_six_dof on general arms is a 2-D search (~0.1 % complete)
        "pyikgeo": arms,
        "ikdh": arms,
        "ssik": fixed + rand[: args.ssik_random],
        "rtb_analytic": fixed + rand[: args.rtb_random],
        "rtb_lm": fixed + rand[: args.lm_random],
    }
    jobs = []
    for lib in args.peers:
        for name, dh in take[lib]:
            general = name.startswith("rand")
            job = {"lib": lib, "arm": name, "dh": dh, "Q": Q, "isolated": False}
            if lib == "rtb_lm":
                job["Q"] = Q[: args.lm_poses]
            if lib in ("ssik", "rtb_analytic") and general:
                job.update(isolated=True, timeout=args.ssik_timeout)
                if lib == "rtb_analytic":
                    job["timeout"] = args.rtb_timeout
            jobs.append(job)
    return jobs


def run_job(job: dict[str, Any], opts: dict[str, Any], args: argparse.Namespace) -> dict:
    lib, name, dh, Q = job["lib"], job["arm"], job["dh"], job["Q"]
    if not job["isolated"]:
        return peers.measure(lib, name, dh, Q, opts)
    env = {}
    if lib == "ssik":
        cold = Path(opts["ssik_dir"]) / f"derivations_{name}"
        env["SSIK_DERIVATION_CACHE"] = str(cold) if not args.ssik_warm else args.ssik_cache
    rec = peers.measure_isolated(lib, name, dh, Q, opts, job["timeout"], env)
    if lib != "ssik":
        return rec
    rec["cache"] = "warm" if args.ssik_warm else "cold"
    if "timeout" in rec and not args.ssik_warm:
        print(f"  ssik {name}: cold set-up exceeded {job['timeout']:.0f} s; warm cache", flush=True)
        env["SSIK_DERIVATION_CACHE"] = args.ssik_cache
        warm = peers.measure_isolated(lib, name, dh, Q, opts, job["timeout"], env)
        warm["cache"] = f"warm (a cold set-up did not finish in {job['timeout']:.0f} s)"
        rec = warm
    return rec


# --- scoring and formatting ----------------------------------------------------------------------


def score(dh: dict, Q: np.ndarray, sols: list[np.ndarray]) -> dict[str, Any]:
    found, nsol, pos, rot = [], [], 0.0, 0.0
    for q, S in zip(Q, sols, strict=False):
        T = peers.fk(dh, q)
        found.append(peers.contains(S, q))
        nsol.append(len(S))
        for s in S:
            p, r = peers.residual(dh, s, T)
            pos, rot = max(pos, p), max(rot, r)
    return {"found": found, "nsol": nsol, "pos": pos, "rot": rot}


def _us(x: float) -> str:
    return f"{x * 1e6:.1f}" if x < 1e-5 else f"{x * 1e6:.0f}"


def _s(x: float) -> str:
    return f"{x:.0f}" if x >= 100 else f"{x:.1f}" if x >= 1 else f"{x:.2g}"


def _found(found: list[bool]) -> str:
    h, n = int(np.sum(found)), len(found)
    pct = "100%" if h == n else f"{100 * h / n:.1f}%"
    return f"{pct} ({h}/{n})"


def _arms_label(names: list[str]) -> str:
    if len(names) == 1:
        return names[0]
    return f"{len(names)} random ({names[0]}–{names[-1]})"


def summary_row(lib: str, recs: list[dict], arms: dict[str, dict]) -> list[str]:
    label = peers.ADAPTERS[lib].label
    names = [r["arm"] for r in recs]
    ok = [r for r in recs if "sols" in r]
    bad = [r for r in recs if "sols" not in r]
    if not ok:
        r = bad[0]
        why = (
            f"unsupported: {r['unsupported']}"
            if "unsupported" in r
            else f"not finished in {r['timeout']:.0f} s (set-up + solves)"
            if "timeout" in r
            else r.get("skipped") or r.get("error", "?")
        )
        return [_arms_label(names), label, why, *[""] * 10]
    found, nsol, wall, cpu, batch, pos, rot = [], [], [], [], [], 0.0, 0.0
    for r in ok:
        sc = r["score"]
        found += sc["found"]
        nsol += sc["nsol"]
        wall += r["wall"]
        cpu += r["cpu"]
        pos, rot = max(pos, sc["pos"]), max(rot, sc["rot"])
        if "batch_s" in r:
            batch.append(r["batch_s"] / r["batch_n"])
    infos = sorted({str(r.get("info", "")) for r in ok})
    solver = "; ".join(infos) if len(infos) <= 2 else f"{infos[0]}; … ({len(infos)} kinds)"
    caches = sorted({r["cache"] for r in ok if "cache" in r and r["arm"].startswith("rand")})
    if caches:
        solver += f" ({', '.join(caches)} derivation cache)" if lib == "ssik" else ""
    if bad:
        solver += f"; {len(bad)} arm(s) not run: " + "; ".join(
            str(b.get("unsupported") or b.get("error") or b.get("timeout")) for b in bad
        )
    setups = [r["setup_s"] for r in ok]
    setup = _s(setups[0]) if len(setups) == 1 else f"{_s(np.mean(setups))} (max {_s(max(setups))})"
    if max(setups) >= 1:
        cpus = [r["setup_cpu_s"] for r in ok]
        setup += f", CPU {_s(max(cpus))}" if len(cpus) > 1 else f", CPU {_s(cpus[0])}"
    budget = [r for r in ok if "budget_stop" in r]
    poses = f"{len(found) // len(ok)}" + (" (budget cut)" if budget else "")
    return [
        _arms_label([r["arm"] for r in ok]),
        label,
        solver,
        poses,
        _found(found),
        f"{np.mean(nsol):.2f}",
        f"{pos:.1e}",
        f"{rot:.1e}",
        _us(float(np.median(wall))),
        _us(float(np.median(cpu))),
        _us(float(np.mean(cpu))),
        _us(float(np.mean(batch))) if batch else "",
        setup,
    ]


def random_arm_rows(recs: list[dict], libs: list[str], rand_names: list[str]) -> list[list[str]]:
    rows = []
    for name in rand_names:
        row = [name]
        for lib in libs:
            r = next((x for x in recs if x["lib"] == lib and x["arm"] == name), None)
            if r is None:
                row.append("")
            elif "sols" not in r:
                row.append("unsupported" if "unsupported" in r else "not run")
            else:
                sc = r["score"]
                h, n = int(np.sum(sc["found"])), len(sc["found"])
                row.append(f"{h}/{n} · {np.mean(sc['nsol']):.2f} · {_us(np.median(r['cpu']))}")
        rows.append(row)
    return rows


def misses(recs: list[dict], Qs: dict) -> list[str]:
    """Every pose where ours missed the generating q, and batch/single disagreements."""
    out = []
    for r in recs:
        if "sols" not in r:
            continue
        Q = Qs[(r["lib"], r["arm"])]
        if r["lib"] == "ours":
            for i, (q, S, hit) in enumerate(zip(Q, r["sols"], r["score"]["found"], strict=False)):
                if hit:
                    continue
                near = np.abs(peers.wrap(S - q)).max(axis=1).min() if len(S) else float("nan")
                why = f" — {r['notes'][i]}" if r["notes"][i] else f"; nearest {near:.1e} rad"
                qs = ", ".join(f"{x:.4f}" for x in q)
                out.append(
                    f"- ours, {r['arm']}, pose {i}: q = ({qs}) rad; {len(S)} solutions "
                    f"returned{why}."
                )
        if "batch_sols" in r:
            bfound = [peers.contains(S, q) for q, S in zip(Q, r["batch_sols"], strict=False)]
            if sum(bfound) != sum(r["score"]["found"][: len(bfound)]):
                out.append(
                    f"- {r['lib']}, {r['arm']}: the batched call finds the generating q in "
                    f"{sum(bfound)}/{len(bfound)} poses, single calls in "
                    f"{sum(r['score']['found'])}/{len(r['score']['found'])}."
                )
    return out


# --- first-ever call of our solver (numba compilation) -------------------------------------------

_COMPILE_PROBE = """
import json, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
import ik_peers as peers
from armpath.ik import complete_solver
from armpath.model.dh import DHRow, dh_arm
out = {}
Q = peers.test_joints(300, seed=99)
for label, dh in (("spherical wrist (PUMA 560)", peers.puma560()),
                  ("three parallel axes (UR5)", peers.ur5()),
                  ("Raghavan-Roth (rand00)", peers.random_arms(1)[0])):
    rows = [DHRow(a=dh["a"][i], alpha=dh["alpha"][i], d=dh["d"][i], offset=dh["offset"][i])
            for i in range(6)]
    Ts = np.array([peers.fk(dh, q) for q in Q])
    t = time.perf_counter()
    s = complete_solver(dh_arm(rows, "standard", name="probe"))
    s.solve(Ts[0])
    out[label + ": set-up + first solve"] = time.perf_counter() - t
    t = time.perf_counter()
    s.solve_batch(Ts)
    out[label + ": first solve_batch (300 poses, parallel kernel)"] = time.perf_counter() - t
print(json.dumps(out))
"""


def compile_probe() -> dict[str, float] | str:
    """Time our solver's first calls with an empty numba cache (a child process whose
    ``NUMBA_CACHE_DIR`` is a fresh directory: the disk cache of the checkout is not touched)."""
    with tempfile.TemporaryDirectory(prefix="numba_cold_") as tmp:
        proc = subprocess.run(
            [sys.executable, "-c", _COMPILE_PROBE, str(Path(__file__).resolve().parent)],
            env={**os.environ, "NUMBA_CACHE_DIR": tmp},
            capture_output=True,
            text=True,
        )
    if proc.returncode != 0:
        return f"failed: {(proc.stderr.strip().splitlines() or ['?'])[-1]}"
    return json.loads(proc.stdout.strip().splitlines()[-1])


# --- main ----------------------------------------------------------------------------------------


def parse(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--random", type=int, default=5, help="random general arms (seed 1)")
    ap.add_argument("--poses", type=int, default=200, help="poses per arm (joints: seed 2)")
    ap.add_argument(
        "--peers",
        default=",".join(LIBS),
        help=f"comma list of libraries to run, from {','.join(LIBS)} (ours is always run)",
    )
    ap.add_argument("--ssik-random", type=int, default=1, help="random arms for ssik")
    ap.add_argument(
        "--ssik-timeout", type=float, default=600.0, help="s for ssik's set-up of a general arm"
    )
    ap.add_argument(
        "--ssik-warm",
        action="store_true",
        help="use the ssik derivation cache (--ssik-cache) instead of a cold set-up",
    )
    ap.add_argument(
        "--ssik-cache",
        default=str(Path.home() / ".cache" / "ssik" / "rr-derivations"),
        help="the warm derivation cache (used with --ssik-warm or when the cold set-up times out)",
    )
    ap.add_argument("--rtb-random", type=int, default=1, help="random arms for rtb General6RIK")
    ap.add_argument("--rtb-timeout", type=float, default=600.0, help="s for rtb on a general arm")
    ap.add_argument("--rtb-split", type=int, default=2, help="General6RIK(k=...) split")
    ap.add_argument("--lm-random", type=int, default=2, help="random arms for rtb ikine_LM")
    ap.add_argument("--lm-poses", type=int, default=50, help="poses per arm for rtb ikine_LM")
    ap.add_argument("--lm-starts", type=int, default=16, help="random starts per pose for LM")
    ap.add_argument("--budget", type=float, default=300.0, help="s per (library, arm) solve loop")
    ap.add_argument("--batch-repeats", type=int, default=3, help="batched calls (median)")
    ap.add_argument(
        "--quick",
        action="store_true",
        help="2 random arms, 50 poses, no rtb analytic_ik (minutes of symbolic set-up), no ssik "
        "or rtb on general arms, LM on PUMA/UR5 with 10 poses, no compile probe",
    )
    ap.add_argument("--no-compile-probe", action="store_true", help="skip the cold-numba probe")
    ap.add_argument("--json", type=Path, default=None, help="also write the scores as JSON")
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    peers = [p for p in args.peers.split(",") if p]
    unknown = sorted(set(peers) - set(LIBS))
    if unknown:
        ap.error(f"unknown peers {unknown}; choose from {LIBS}")
    if args.quick:
        args.random, args.poses = min(args.random, 2), min(args.poses, 50)
        args.ssik_random = args.rtb_random = args.lm_random = 0
        args.lm_poses = min(args.lm_poses, 10)
        peers = [p for p in peers if p != "rtb_analytic"]
        args.no_compile_probe = True
    args.peers = ["ours", *(p for p in LIBS if p in peers and p != "ours")]
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    t_run = time.perf_counter()
    load0 = os.getloadavg()
    versions = report.versions(PACKAGES)  # the code measured is the code at the start
    arms = peers.test_arms(args.random)
    arm_dh = dict(arms)
    installed = {lib: peers.ADAPTERS[lib].installed() for lib in args.peers}
    probe = None if args.no_compile_probe or not installed["ours"] else compile_probe()
    recs: list[dict] = []
    Qs: dict[tuple[str, str], np.ndarray] = {}
    with tempfile.TemporaryDirectory(prefix="bench_ik_ssik_") as ssik_dir:
        opts = {
            "budget": args.budget,
            "batch_repeats": args.batch_repeats,
            "lm_starts": args.lm_starts,
            "rtb_split": args.rtb_split,
            "ssik_dir": ssik_dir,
        }
        for job in plan(args, arms):
            lib, name = job["lib"], job["arm"]
            Qs[(lib, name)] = job["Q"]
            if not installed[lib]:
                recs.append({"lib": lib, "arm": name, "skipped": "not installed"})
                continue
            t = time.perf_counter()
            print(f"{lib:13s} {name:8s} ...", end=" ", flush=True)
            rec = run_job(job, opts, args)
            if "sols" in rec:
                rec["score"] = score(job["dh"], job["Q"][: len(rec["sols"])], rec["sols"])
                sc = rec["score"]
                print(
                    f"found {sum(sc['found'])}/{len(sc['found'])}, "
                    f"#sol {np.mean(sc['nsol']):.2f}, cpu {_us(np.median(rec['cpu']))} us, "
                    f"setup {rec['setup_s']:.3g} s",
                    end=" ",
                )
            else:
                print(
                    {k: v for k, v in rec.items() if k not in ("lib", "arm", "load", "load_s")},
                    end=" ",
                )
            print(f"[{time.perf_counter() - t:.1f} s]", flush=True)
            recs.append(rec)
    elapsed = time.perf_counter() - t_run

    # --- the report
    order = {lib: i for i, lib in enumerate(args.peers)}
    rand_names = [n for n, _ in arms if n.startswith("rand")]
    rows = []
    for group in ("puma560", "ur5", "random"):
        for lib in sorted({r["lib"] for r in recs}, key=order.get):
            rs = [
                r
                for r in recs
                if r["lib"] == lib
                and (r["arm"] == group or (group == "random" and r["arm"] in rand_names))
            ]
            if rs:
                rows.append(summary_row(lib, rs, arm_dh))
    rand_libs = [
        lib
        for lib in args.peers
        if any(r["lib"] == lib and r["arm"] in rand_names and "sols" in r for r in recs)
    ]
    loads = [x for r in recs for x in r.get("load", [])]
    now = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    cpu = platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        import numba

        nthreads = str(numba.get_num_threads())
    except ImportError:
        nthreads = "?"
    cmd = " ".join(["python benchmarks/bench_ik.py", *(argv if argv is not None else sys.argv[1:])])
    n_lm = min(args.lm_poses, args.poses)
    md = [
        "# Inverse kinematics: ours (`complete_solver`) vs peer all-solutions IK libraries",
        "",
        f"Reproduce: `{PIP_EXTRA}` (this run's versions: `{PIP_PINNED}`), then "
        "`python benchmarks/bench_ik.py` (about 15 min on this machine, most of it the symbolic "
        "set-up of ssik and rtb on one general arm; `--quick` takes about 2 min, "
        "`--help` lists the knobs). Peers that are not installed are skipped.",
        "",
        f"Generated by `{cmd.strip()}` on {now} in {elapsed:.0f} s. Machine: {cpu}, "
        f"{os.cpu_count()} cores, {platform.system()} {platform.release()}; load average "
        f"{load0[0]:.2f} at the start, between {min(loads, default=0):.2f} and "
        f"{max(loads, default=0):.2f} during the measurements (the machine is shared: wall times "
        "drift, thread-CPU times of single calls hold better). numba threads "
        f"{nthreads}. Versions: " + ", ".join(f"{k} {v}" for k, v in versions.items()) + ".",
        "",
        "## Setup",
        "",
        f"Arms (standard D-H, mm, rad): PUMA 560, UR5 and {args.random} random general 6R arms "
        "(a, d uniform in ±500 mm, α uniform in ±π; seed 1; rand00, rand01, …). Poses: "
        f"FK of {args.poses} joint vectors uniform in [-π, π)⁶ (seed 2), the same for every arm "
        "and library. Every adapter (`benchmarks/ik_peers.py`) converts the D-H table to its "
        "library's model and units (metres for ssik, rtb and ikdh, whose tolerances are absolute; "
        "product of exponentials for ik-geo and py-ikgeo-kinematics; theta offsets folded in) "
        "and maps the answers back; one FK scores them all. No joint limits anywhere.",
        "",
        "- **ours**: `armpath.ik.complete_solver(dh_arm(rows, 'standard'))` — the closed forms "
        "for a spherical wrist (PUMA) and for three parallel axes (UR5), the Raghavan–Roth "
        "elimination for the random arms. Warm-up calls first load every numba kernel from the "
        "disk cache; the compile time of a first-ever call is below. `solve_batch` runs numba's "
        "parallel kernel (all numba threads) for N ≥ 64 poses (Raghavan–Roth) or N ≥ 128 (closed "
        "forms) and returns padded arrays (`IKBatch`); the adapter's per-pose views of them are "
        "inside the timing.",
        "- **EAIK**: `DhRobot(...).IK`, batched `IK_batched(num_worker_threads=2)`; "
        "least-squares answers dropped. It declines arms outside its known families.",
        "- **ik-geo**: the family factory chosen by py-ikgeo-kinematics' detector; PUMA and UR5 "
        "only (its `gen_six_dof` 2-D search found the generating q in ~0.1 % of poses on "
        "random arms in the prototype runs, at 2–180 ms a pose).",
        "- **py-ikgeo-kinematics**: `Robot.inverse` (through scipy's `RigidTransform`), batched "
        "`Robot.reach(threads=2)`; random arms go to its `general` family (a search).",
        "- **ikdh**: `Solver.solve` (Husty–Pfurner), limits ±360°.",
        "- **ssik**: `Manipulator.from_dh` + `prepare()` + the native artifact (`emit_artifact`, "
        "and for a general arm the baked Raghavan–Roth tensor), all counted as set-up; solved "
        "through the artifact's native `solve(respect_limits=False)`. PUMA, UR5 and "
        f"{args.ssik_random} random arm(s); the general arm's set-up (symbolic derivation of "
        "three Raghavan–Roth splits, minutes) runs in a child process with "
        + (
            f"the warm derivation cache `{args.ssik_cache}`"
            if args.ssik_warm
            else f"an empty derivation cache (cold) and a limit of {args.ssik_timeout:.0f} s, "
            f"falling back to the warm cache `{args.ssik_cache}`"
        )
        + ".",
        "- **rtb analytic_ik**: `DHRobot.analytic_ik()` on PUMA and UR5 (symbolic derivation "
        "plus its own 100-pose validation, all counted as set-up); on "
        f"{args.rtb_random} random arm(s) `General6RIK(robot, k={args.rtb_split})` directly "
        "(one split, no validation: `analytic_ik()` itself derives three splits and did not "
        f"finish in 13.5 min on this machine), in a child process limited to "
        f"{args.rtb_timeout:.0f} s.",
        f"- **rtb ikine_LM**: numerical, one solution a call; every solution emulated by "
        f"{args.lm_starts} random starts per pose (ilimit 30, slimit 1, tol 1e-14), distinct "
        f"results kept; PUMA, UR5 and {args.lm_random} random arm(s), first {n_lm} poses.",
        "",
        "Columns: **generating q found** = poses whose generating joint vector is among the "
        "returned solutions (max |Δq| mod 2π < 1e-4 rad); **mean #sol** = solutions returned "
        "per pose; **max pos / rot res** = largest FK residual over every returned solution "
        "(mm; rad, from the chord); **wall / CPU median** = per single `solve` call, wall clock "
        "and CPU time of the calling thread (`time.thread_time`: robust to other load; all "
        "single calls are single-threaded), median over poses (and arms); **CPU mean** = mean "
        "thread-CPU per call; **batched** = wall time of one batched call on all poses divided "
        f"by their number (median of {args.batch_repeats} calls; wall, not CPU, since it may use "
        "several threads); **set-up** = wall seconds per arm to build the solver (mean and max "
        "over arms; the process CPU seconds too when ≥ 1 s). Times in microseconds. One untimed "
        f"warm-up call per arm. Solve loops stop after {args.budget:.0f} s (marked).",
        "",
        "## Results",
        "",
        table(
            [
                "arms",
                "library",
                "solver picked",
                "poses / arm",
                "generating q found",
                "mean #sol",
                "max pos res [mm]",
                "max rot res [rad]",
                "wall median [us]",
                "CPU median [us]",
                "CPU mean [us]",
                "batched [us/pose]",
                "set-up [s]",
            ],
            rows,
        ),
        "",
    ]
    if rand_names and rand_libs:
        md += [
            "### Random arms one by one",
            "",
            "Cells: generating q found / poses · mean #sol · CPU median per call [us].",
            "",
            table(
                ["arm", *(peers.ADAPTERS[lib].label for lib in rand_libs)],
                random_arm_rows(recs, rand_libs, rand_names),
            ),
            "",
        ]
    md += ["## Notes", ""]
    if isinstance(probe, dict):
        md.append(
            "- First-ever calls of ours (a child process with an empty numba cache, i.e. "
            "compilation): " + "; ".join(f"{k} {v:.1f} s" for k, v in probe.items()) + "."
        )
    ours_load = next((r["load_s"] for r in recs if r["lib"] == "ours" and "load_s" in r), None)
    if ours_load is not None:
        md.append(
            f"- Ours' warm-up at the start of this run (import, then every kernel from the numba "
            f"disk cache, recompiling what changed in src/ since the cache was written): "
            f"{ours_load:.1f} s; not counted in any column."
        )
    elif probe:
        md.append(f"- Compile probe {probe}.")
    missed = misses(recs, Qs)
    if missed:
        md += ["- Poses where ours missed the generating q (reproducible):", *missed]
    else:
        md.append("- Ours found the generating q in every pose.")
    for r in recs:
        if "first_error" in r:
            md.append(
                f"- {r['lib']}, {r['arm']}: {r['errors']} call(s) raised, first {r['first_error']}"
            )
        if "timeout" in r:
            md.append(
                f"- {r['lib']}, {r['arm']}: not finished within {r['timeout']:.0f} s in its child "
                "process (set-up plus solves); skipped."
            )
        if r.get("budget_stop"):
            md.append(f"- {r['lib']}, {r['arm']}: budget cut after {r['budget_stop']} poses.")
    md.append("")
    if args.json:
        out = [
            {k: v for k, v in r.items() if k not in ("sols", "batch_sols", "wall", "cpu", "notes")}
            | (
                {
                    "found": int(np.sum(r["score"]["found"])),
                    "poses": len(r["score"]["found"]),
                    "nsol_mean": float(np.mean(r["score"]["nsol"])),
                    "max_pos_res_mm": r["score"]["pos"],
                    "max_rot_res_rad": r["score"]["rot"],
                    "wall_median_s": float(np.median(r["wall"])),
                    "cpu_median_s": float(np.median(r["cpu"])),
                    "cpu_mean_s": float(np.mean(r["cpu"])),
                    "score": None,
                }
                if "score" in r
                else {}
            )
            for r in recs
        ]
        args.json.write_text(json.dumps(out, indent=1, default=str))
    return report.write(args.out, md)


if __name__ == "__main__":
    sys.exit(main())
