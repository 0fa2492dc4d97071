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
