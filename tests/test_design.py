"""The design sweep: the same numbers locally (joblib) and on a Dask cluster, and a reach volume
that agrees with the voxel workspace."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from armpath.model import seed_arm
from armpath.model.seed_arm import SeedArmGeometry
from armpath.workspace import sample_workspace
from armpath.workspace.design import design_grid, evaluate_design, ranked, sweep

ARMPATH = [sys.executable, "-m", "armpath"]


def test_local_and_dask_sweeps_agree():
    distributed = pytest.importorskip("distributed")
    candidates = design_grid(715.0, ab_mm=(100.0, 140.0), de_mm=(65.0,), theta3_deg=(138.0,))
    assert [c.ab_mm + c.bc_mm + c.cd_mm + c.de_mm for c in candidates] == [715.0, 715.0]
    local = sweep(candidates, pixel_mm=15.0, samples=100_000, seed=3, n_jobs=2)
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
    ) as cluster:
        remote = sweep(
            candidates, pixel_mm=15.0, samples=100_000, seed=3, scheduler=cluster.scheduler_address
        )
    assert [r.row() for r in local] == [r.row() for r in remote]
    # shorter AB at the same total length reaches more (seed 000's conclusion)
    assert ranked(local)[0].geometry.ab_mm == 100.0


def test_reach_volume_matches_the_voxel_workspace():
    """The revolved meridian map and the 3-D voxel grid, two different samplers, give the same
    volume above the table for the seed arm."""
    metrics = evaluate_design(SeedArmGeometry(), pixel_mm=10.0, samples=1_000_000, seed=1)
    grid = sample_workspace(seed_arm(), 6_000_000, 15.0, seed=1)
    centres = grid.centers()
    above = centres[centres[:, 2] >= 0.0]
    voxel_volume = len(above) * grid.voxel**3
    assert metrics.reach_volume_mm3 == pytest.approx(voxel_volume, rel=0.06)
    assert metrics.blind_volume_mm3 > 1e6  # the seed arm has a central blind zone (litres)
    wide = evaluate_design(
        SeedArmGeometry(range_deg=(np.inf, 125.0, 165.0, np.inf, 133.5, np.inf)),
        pixel_mm=10.0,
        samples=1_000_000,
        seed=1,
    )
    assert wide.blind_volume_mm3 < 0.05 * metrics.blind_volume_mm3  # joint 3 closes it


def test_cli_design_sweep(tmp_path):
    out = tmp_path / "ds"
    proc = subprocess.run(
        [
            *ARMPATH,
            "design-sweep",
            "--samples",
            "20000",
            "--pixel",
            "20",
            "--jobs",
            "1",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    assert "recommendation: AB" in proc.stdout
    lines = (out / "design_sweep.csv").read_text().splitlines()
    assert lines[0].startswith("rank,AB_mm") and len(lines) == 1 + len(design_grid())
    bad = subprocess.run(
        [*ARMPATH, "design-sweep", "--total", "100", "--out", str(tmp_path / "x")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert bad.returncode == 1 and "no candidate fits" in bad.stderr
    assert not (tmp_path / "x").exists()


# --- bounds on the work (issue 17, item 4) ----------------------------------------------------


def test_job_counts():
    from armpath.errors import InvalidInputError
    from armpath.workspace.design import check_jobs

    assert [check_jobs(n) for n in (-1, 1, 2, 256)] == [-1, 1, 2, 256]
    for bad, message in ((0, "-1 .every core."), (-2, "-1 .every core."), (257, "256")):
        with pytest.raises(InvalidInputError, match=message):
            check_jobs(bad, "--jobs")
    with pytest.raises(InvalidInputError, match="n_jobs must be -1"):
        sweep(design_grid()[:1], samples=100, n_jobs=0)  # joblib's own error was a traceback


def test_a_sweep_starts_no_more_processes_than_cores_or_candidates(monkeypatch):
    """256 jobs asked for 3 candidates start at most min(cores, 3) workers (on a 2-core
    machine 256 started 259 processes holding 9 GB); the numbers are those of one process."""
    import joblib

    started = []

    class Recording(joblib.Parallel):
        def __init__(self, n_jobs=None, **kw):
            started.append(n_jobs)
            super().__init__(n_jobs=n_jobs, **kw)

    monkeypatch.setattr(joblib, "Parallel", Recording)
    candidates = design_grid()[:3]
    wide = sweep(candidates, pixel_mm=15.0, samples=2_000, seed=1, n_jobs=256)
    assert started == [min(joblib.cpu_count(), 3)]
    one = sweep(candidates, pixel_mm=15.0, samples=2_000, seed=1, n_jobs=1)
    assert [m.reach_volume_mm3 for m in wide] == [m.reach_volume_mm3 for m in one]
    assert started[-1] == 1


def test_sweep_sizes_are_refused_before_any_work():
    """101 x 100 x 1 = 10,100 grid points is more than MAX_DESIGNS (refused before building
    them); a sweep whose samples or maps are too large is refused before any worker starts."""
    from armpath.errors import InvalidInputError

    many = [100.0 + k for k in range(101)], [45.0 + k / 10 for k in range(100)]
    with pytest.raises(InvalidInputError, match=r"candidate designs.*10,100.*10,000"):
        design_grid(715.0, ab_mm=many[0], de_mm=many[1], theta3_deg=(138.0,))
    with pytest.raises(InvalidInputError, match="total length"):
        design_grid(float("nan"))
    candidates = design_grid()  # 40
    with pytest.raises(InvalidInputError, match=r"joint samples of the sweep.*200,000,040"):
        sweep(candidates, samples=5_000_001, n_jobs=1)  # 40 x 5,000,001 > 200,000,000
    with pytest.raises(InvalidInputError, match=r"pixels of a 0\.01 mm map"):
        sweep(candidates, pixel_mm=0.01, samples=100, n_jobs=1)
    with pytest.raises(InvalidInputError, match="random seed"):
        sweep(candidates, samples=100, seed=-1, n_jobs=1)


def test_sweep_in_batches_under_a_time_limit_gives_the_same_numbers():
    """Under a generous time limit the designs go out one batch per round of workers, each
    worker under the deadline; the numbers are those of the sweep without a limit."""
    from armpath.budget import time_limit

    candidates = design_grid(715.0, ab_mm=(100.0, 180.0, 250.0), de_mm=(65.0,), theta3_deg=(165.0,))
    free = sweep(candidates, pixel_mm=20.0, samples=20_000, seed=2, n_jobs=2)
    with time_limit(600.0):
        limited = sweep(candidates, pixel_mm=20.0, samples=20_000, seed=2, n_jobs=2)
    assert [r.row() for r in limited] == [r.row() for r in free]
    assert [r.geometry.ab_mm for r in limited] == [100.0, 180.0, 250.0]


def test_time_limit_ends_a_local_sweep():
    """4 million samples a design on 2 processes would take minutes; the parent stops waiting
    at the limit (the workers' start-up included) and raises its own time-limit error."""
    from armpath.budget import time_limit
    from armpath.errors import TimeLimitError

    with (
        time_limit(1.5),
        pytest.raises(TimeLimitError, match=r"time limit of 1\.5 s ran out while evaluating"),
    ):
        sweep(design_grid()[:4], pixel_mm=10.0, samples=4_000_000, n_jobs=2)


def test_time_limit_ends_a_dask_sweep():
    distributed = pytest.importorskip("distributed")
    from armpath.budget import time_limit
    from armpath.errors import TimeLimitError

    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
        ) as cluster,
        time_limit(1.5),
        pytest.raises(TimeLimitError, match=r"time limit of 1\.5 s ran out"),
    ):
        sweep(
            design_grid()[:4],
            pixel_mm=10.0,
            samples=4_000_000,
            scheduler=cluster.scheduler_address,
        )
