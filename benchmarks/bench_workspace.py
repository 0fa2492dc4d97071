"""Workspace sampling rate: ours against roboticstoolbox-python's batched forward kinematics.

Run with ``python benchmarks/bench_workspace.py`` (needs roboticstoolbox-python, e.g. the
``bench-ik`` extra; ``--help`` for the knobs). For PUMA 560 and UR5, from the same D-H tables
(``ik_peers``), in the same run:

* ours: ``sample_workspace`` end to end (random joints, forward kinematics of the tool point in a
  compiled kernel, voxel marking), and ``tool_position`` (numpy, batched) for the FK alone;
* roboticstoolbox-python: ``ETS.fkine`` (batched, the fast path) and ``DHRobot.fkine`` on the same
  joint samples, each followed by the same numpy voxel marking for the whole pipeline.

It reports samples per second and the ratio to ours, checks that both compute the same tool
points (max difference, mm), writes ``benchmarks/results/workspace.md`` and prints it.
"""

from __future__ import annotations

import argparse
import datetime as dt
import importlib.util
import os
import sys
import time
from pathlib import Path

import numpy as np
import report
from report import table

if importlib.util.find_spec("roboticstoolbox") is None:  # pragma: no cover - needs its peer
    sys.exit("bench_workspace needs roboticstoolbox-python: pip install '.[bench-ik]'")
import ik_peers as peers
import numba

from armpath.kinematics import tool_position
from armpath.model.dh import DHRow, dh_arm
from armpath.workspace import GridSpec, joint_ranges, sample_workspace
from armpath.workspace.sampling import joint_samples

ROOT = Path(__file__).resolve().parents[1]
RESULT = ROOT / "benchmarks" / "results" / "workspace.md"


def _mark_numpy(points_mm: np.ndarray, spec: GridSpec, occupied: np.ndarray) -> None:
    idx = np.floor((points_mm - spec.origin) / spec.voxel).astype(np.int64)
    occupied[idx[:, 0], idx[:, 1], idx[:, 2]] = True


def _best(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def run_arm(name: str, dh: dict[str, np.ndarray], args: argparse.Namespace) -> list[list[str]]:
    rows = [
        DHRow(
            a=dh["a"][i],
            alpha=dh["alpha"][i],
            d=dh["d"][i],
            offset=dh["offset"][i],
            limits=(-np.pi, np.pi),
        )
        for i in range(6)
    ]
    arm = dh_arm(rows, "standard", name=name)
    robot = peers._rtb_robot(name, dh)
    ets = robot.ets()
    spec = GridSpec.for_arm(arm, args.voxel)
    ranges = joint_ranges(arm)
    q_small = joint_samples(ranges, args.rtb_samples, np.random.default_rng(1), "uniform")
    q_dh = q_small[: args.dh_samples]

    # agreement of the tool points (rtb works in metres)
    ours_p = tool_position(arm, q_small)
    rtb_p = np.asarray(ets.fkine(q_small).t) * 1000.0
    diff = float(np.max(np.abs(ours_p - rtb_p)))

    sample_workspace(arm, 1000, args.voxel)  # load the compiled kernel
    t_ours = _best(lambda: sample_workspace(arm, args.samples, args.voxel, seed=2), args.repeats)
    t_np = _best(lambda: tool_position(arm, q_small), args.repeats)

    def rtb_pipeline(fk, q):
        occ = np.zeros(spec.shape, dtype=bool)
        _mark_numpy(np.asarray(fk(q).t).reshape(-1, 3) * 1000.0, spec, occ)

    t_ets_fk = _best(lambda: ets.fkine(q_small), args.repeats)
    t_ets = _best(lambda: rtb_pipeline(ets.fkine, q_small), args.repeats)
    t_dh = _best(lambda: rtb_pipeline(robot.fkine, q_dh), 1)
    rate_ours = args.samples / t_ours
    out = []
    for lib, what, n, seconds in (
        ("armpath (ours)", "`sample_workspace`: joints, FK, voxels", args.samples, t_ours),
        ("armpath (ours)", "`tool_position` (numpy FK only)", len(q_small), t_np),
        ("roboticstoolbox", "`ETS.fkine` (FK only)", len(q_small), t_ets_fk),
        ("roboticstoolbox", "`ETS.fkine` + numpy voxels", len(q_small), t_ets),
        ("roboticstoolbox", "`DHRobot.fkine` + numpy voxels", len(q_dh), t_dh),
    ):
        rate = n / seconds
        out.append(
            [
                name,
                lib,
                what,
                f"{n:,}",
                f"{seconds:.3f}",
                f"{rate / 1e6:.3f}",
                f"{rate_ours / rate:.1f}",
            ]
        )
    out[0].append(f"{diff:.1e}")
    for r in out[1:]:
        r.append("")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=20_000_000, help="our end-to-end samples")
    ap.add_argument("--rtb-samples", type=int, default=200_000, help="samples for ETS.fkine")
    ap.add_argument("--dh-samples", type=int, default=20_000, help="samples for DHRobot.fkine")
    ap.add_argument("--voxel", type=float, default=10.0, help="voxel edge, mm")
    ap.add_argument("--repeats", type=int, default=3, help="timed repeats (best taken)")
    ap.add_argument("--out", type=Path, default=RESULT)
    args = ap.parse_args(argv)
    started = time.perf_counter()
    load = os.getloadavg()[0]
    rows: list[list[str]] = []
    for name, dh in (("puma560", peers.puma560()), ("ur5", peers.ur5())):
        rows += run_arm(name, dh, args)
        print(f"{name} done", flush=True)
    v = report.versions(("numpy", "numba", "roboticstoolbox-python", "spatialmath-python"))
    header = [
        "arm",
        "library",
        "what is timed",
        "samples",
        "seconds",
        "million samples/s",
        "ours / this (rate)",
        "max |Δp| ours vs rtb [mm]",
    ]
    lines = [
        "# Workspace sampling: ours vs roboticstoolbox-python's batched forward kinematics",
        "",
        'Reproduce: `pip install -e ".[bench-ik]"`, then `python benchmarks/bench_workspace.py`.',
        "",
        f"Generated on {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC in "
        f"{time.perf_counter() - started:.0f} s; load average {load:.2f} at the start (the "
        f"machine is shared); numba threads {numba.get_num_threads()}. Versions: "
        + ", ".join(f"{k} {val}" for k, val in v.items())
        + ".",
        "",
        f"Same D-H tables (ik_peers), joints uniform in [-π, π), {args.voxel:g} mm voxels over "
        "the reach. Best of "
        f"{args.repeats} runs (one for `DHRobot.fkine`). Ours end to end includes drawing the "
        "joint samples; the rtb rows get theirs for free. rtb works in metres; its tool points "
        "are scaled to mm for the voxels and the comparison.",
        "",
        table(header, rows),
        "",
    ]
    return report.write(args.out, lines)


if __name__ == "__main__":
    raise SystemExit(main())
