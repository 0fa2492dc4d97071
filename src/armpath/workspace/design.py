"""Design study of the seed arm (seed 000 section 6.2): link lengths and joint ranges against
reach and blind zones.

**Objective** (stated, after seed 000's equation 37): at a fixed total length
``AB + BC + CD + DE`` (the material of the arm), maximise the volume the fingertip reaches above
the table (z >= 0, turned about the vertical axis; the central blind zone is not counted, being
unreachable); ties go to the smaller blind volume. Every candidate is evaluated by
:func:`evaluate_design` from a seeded meridian map, so results do not depend on where they run.

:func:`sweep` runs the candidates in parallel on this machine (joblib) or, given the address of
a Dask scheduler, on that cluster: the same function on the same inputs either way.

Bounds (:mod:`armpath.budget`): at most ``MAX_DESIGNS`` candidates, ``MAX_JOBS`` local jobs,
``MAX_SAMPLES`` joint samples over the whole sweep and ``MAX_GRID_CELLS`` pixels a map, all
checked before any work. Under a time limit the candidates go out in batches of one per worker;
each worker runs under what is left of the limit, and the caller checks it between batches, so
the sweep ends with the caller's :class:`~armpath.errors.TimeLimitError` soon after the limit.
"""

from __future__ import annotations

import math
import multiprocessing
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from itertools import product
from typing import Any

import numpy as np

from armpath.budget import (
    MAX_DESIGNS,
    MAX_JOBS,
    MAX_SAMPLES,
    RAISE_TIME_LIMIT,
    check_size,
    check_time,
    current_deadline,
    time_limit,
)
from armpath.errors import InvalidInputError, TimeLimitError
from armpath.model.seed_arm import SeedArmGeometry, seed_arm
from armpath.workspace.blindzones import map_shape, meridian_map
from armpath.workspace.sampling import check_count, random_generator


@dataclass(frozen=True)
class DesignMetrics:
    """One candidate's numbers (mm, mm^3)."""

    geometry: SeedArmGeometry
    reach_volume_mm3: float
    blind_volume_mm3: float
    farthest_mm: float
    nearest_to_b_mm: float
    #: whether its meridian map's blind zone had settled (see
    #: :attr:`~armpath.workspace.blindzones.PlaneMap.settled`): False, too few samples
    settled: bool = True

    def row(self) -> dict[str, float]:
        g = self.geometry
        return {
            "AB_mm": g.ab_mm,
            "BC_mm": g.bc_mm,
            "CD_mm": g.cd_mm,
            "DE_mm": g.de_mm,
            "theta2_deg": g.range_deg[1],
            "theta3_deg": g.range_deg[2],
            "theta5_deg": g.range_deg[4],
            "reach_volume_m3": self.reach_volume_mm3 / 1e9,
            "blind_volume_l": self.blind_volume_mm3 / 1e6,
            "farthest_mm": self.farthest_mm,
            "nearest_to_B_mm": self.nearest_to_b_mm,
        }


def evaluate_design(
    geometry: SeedArmGeometry, pixel_mm: float = 10.0, samples: int = 1_000_000, seed: int = 0
) -> DesignMetrics:
    """Reach volume above the table, blind volume, farthest reach from B and nearest reachable
    distance to B (mm) of one candidate, from a seeded meridian map."""
    arm = seed_arm(geometry)
    m = meridian_map(arm, pixel_mm, samples, seed=seed)
    u, v = m.centers()
    above = np.broadcast_to(v[None, :] >= 0.0, m.reach.shape)
    dist_b = np.hypot(u[:, None], v[None, :] - geometry.ab_mm)
    reach_dist = dist_b[m.reach]
    return DesignMetrics(
        geometry,
        m.revolved_volume(m.reach & above),
        m.revolved_blind_volume(),
        float(reach_dist.max()),
        float(reach_dist.min()),
        m.settled,
    )


def design_grid(
    total_mm: float = 715.0,
    ab_mm: Sequence[float] = (100.0, 140.0, 180.0, 220.0, 250.0),
    de_mm: Sequence[float] = (45.0, 65.0, 100.0, 147.0),
    theta3_deg: Sequence[float] = (138.0, 165.0),
    base: SeedArmGeometry | None = None,
) -> list[SeedArmGeometry]:
    """Candidates with ``AB + BC + CD + DE = total_mm`` and ``BC = CD``; the other ranges as in
    ``base`` (default: the seed arm's). At most ``MAX_DESIGNS`` combinations (refused before
    any is built)."""
    if not (math.isfinite(total_mm) and total_mm > 0):
        raise InvalidInputError(f"the total length must be a positive length in mm, got {total_mm}")
    for name, values in (("AB", ab_mm), ("DE", de_mm), ("joint 3 range", theta3_deg)):
        if not all(math.isfinite(v) and v > 0 for v in values):
            raise InvalidInputError(f"every {name} of the grid must be > 0, got {list(values)}")
    check_size(
        len(ab_mm) * len(de_mm) * len(theta3_deg),
        MAX_DESIGNS,
        "candidate designs (AB x DE x joint 3 values)",
        "the grid's values",
    )
    base = base or SeedArmGeometry()
    out = []
    for ab, de, t3 in product(ab_mm, de_mm, theta3_deg):
        mid = 0.5 * (total_mm - ab - de)
        if mid <= 0:
            continue
        ranges = list(base.range_deg)
        ranges[2] = t3
        out.append(
            replace(base, ab_mm=ab, bc_mm=mid, cd_mm=mid, de_mm=de, range_deg=tuple(ranges))  # type: ignore[arg-type]
        )
    if not out:
        raise InvalidInputError(f"no candidate fits a total length of {total_mm} mm")
    return out


def check_jobs(n_jobs: int, option: str = "n_jobs") -> int:
    """``n_jobs`` if it is -1 (every core) or a number of processes from 1 to ``MAX_JOBS``;
    refused otherwise, naming ``option``."""
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, int | np.integer):
        raise InvalidInputError(f"{option} must be a whole number, got {n_jobs!r}")
    if n_jobs == -1:
        return -1
    if n_jobs < 1:
        raise InvalidInputError(
            f"{option} must be -1 (every core) or a number of processes from 1 to {MAX_JOBS}, "
            f"got {n_jobs}"
        )
    check_size(int(n_jobs), MAX_JOBS, "parallel jobs", option)
    return int(n_jobs)


def check_sweep_size(
    candidates: Sequence[SeedArmGeometry],
    pixel_mm: float,
    samples: int,
    seed: int,
    *,
    extra: int = 0,
    options: tuple[str, str] = ("pixel_mm", "samples"),
) -> None:
    """Refuse a sweep before any work: more than ``MAX_DESIGNS`` candidates, a map of more than
    ``MAX_GRID_CELLS`` pixels for some candidate, more than ``MAX_SAMPLES`` joint samples over
    the candidates and ``extra`` further evaluations, or a bad seed. ``options`` name the pixel
    and samples options in the messages."""
    check_size(len(candidates), MAX_DESIGNS, "candidate designs", "the candidates")
    random_generator(seed)
    samples = check_count(samples, options[1], MAX_SAMPLES, "joint samples a design")
    check_size(
        float(samples) * (len(candidates) + extra),
        MAX_SAMPLES,
        f"joint samples of the sweep ({samples:,} for each of {len(candidates) + extra} designs)",
        options[1],
    )
    for g in candidates:
        map_shape(seed_arm(g), pixel_mm, options[0])


def _evaluate_within(
    ends_at: float | None, geometry: SeedArmGeometry, pixel_mm: float, samples: int, seed: int
) -> DesignMetrics:
    """:func:`evaluate_design` under a time limit that ends at ``ends_at`` (``time.time()``,
    which every process and host share, unlike the monotonic clock); run by the workers, so
    their start-up counts too."""
    if ends_at is None:
        return evaluate_design(geometry, pixel_mm, samples, seed)
    with time_limit(max(ends_at - time.time(), 1e-3)):
        check_time("starting a design evaluation")
        return evaluate_design(geometry, pixel_mm, samples, seed)


def _ends_at() -> float | None:
    """When the time limit in force runs out, in ``time.time()`` (``None``: no limit)."""
    deadline = current_deadline()
    return None if deadline is None else time.time() + deadline.remaining


def _in_batches(
    candidates: list[SeedArmGeometry],
    workers: int,
    run: Callable[[list[SeedArmGeometry], float | None], list[DesignMetrics]],
) -> list[DesignMetrics]:
    """``run(batch, ends_at)`` on batches of ``workers`` candidates (all of them at once
    without a time limit), checking the time limit between batches. A worker that ran out of
    time, or a wait for the workers that timed out (a ``TimeoutError``), ends the sweep with the
    caller's own time-limit error."""
    size = max(len(candidates) if current_deadline() is None else workers, 1)
    out: list[DesignMetrics] = []
    try:
        for start in range(0, len(candidates), size):
            check_time(f"evaluating designs ({start} of {len(candidates)} done)")
            out += run(candidates[start : start + size], _ends_at())
    except (TimeLimitError, TimeoutError, multiprocessing.TimeoutError) as exc:
        check_time(f"evaluating designs ({len(out)} of {len(candidates)} done)")
        if isinstance(exc, TimeLimitError):
            raise
        raise TimeLimitError(
            "the time limit ran out while waiting for the design evaluations; " + RAISE_TIME_LIMIT
        ) from None
    check_time(f"evaluating designs ({len(out)} of {len(candidates)} done)")
    return out


def _wait_limit() -> float | None:
    """How long to wait for a batch of workers (s): what is left of the time limit in force."""
    deadline = current_deadline()
    return None if deadline is None else max(deadline.remaining, 1e-3)


def sweep(
    candidates: Sequence[SeedArmGeometry],
    *,
    pixel_mm: float = 10.0,
    samples: int = 1_000_000,
    seed: int = 0,
    scheduler: str | None = None,
    n_jobs: int = -1,
) -> list[DesignMetrics]:
    """:func:`evaluate_design` of every candidate, in the candidates' order: on the Dask
    scheduler at ``scheduler`` (e.g. ``tcp://host:8786``) or with joblib on ``n_jobs`` local
    processes (-1: every core; at most ``MAX_JOBS``, and no more than the machine's cores or
    the candidates). Sizes are checked first
    (:func:`check_sweep_size`). Under a time limit the candidates go out one batch per round
    of workers, with the limit checked between batches; the workers run under the same limit,
    and waiting for them stops when it runs out (joblib's ``timeout``, Dask's ``wait``)."""
    candidates = list(candidates)
    n_jobs = check_jobs(n_jobs)
    check_sweep_size(candidates, pixel_mm, samples, seed)
    if scheduler is not None:
        try:
            from distributed import Client, wait
        except ImportError:
            raise InvalidInputError("--scheduler needs Dask: pip install 'armpath[dask]'") from None
        try:
            client = Client(scheduler, timeout="5s")  # type: ignore[no-untyped-call]
        except (OSError, ValueError) as exc:  # ValueError: not an address ("bogus")
            raise InvalidInputError(
                f"cannot reach the Dask scheduler at {scheduler}: {exc}"
            ) from None
        with client:
            threads = sum(client.nthreads().values())  # type: ignore[no-untyped-call]

            def on_dask(batch: list[SeedArmGeometry], ends_at: float | None) -> list[Any]:
                futures = client.map(
                    _evaluate_within,
                    [ends_at] * len(batch),
                    batch,
                    pixel_mm=pixel_mm,
                    samples=samples,
                    seed=seed,
                    pure=True,
                )
                try:
                    wait(futures, timeout=_wait_limit())  # type: ignore[no-untyped-call]
                    return list(client.gather(futures))  # type: ignore[no-untyped-call]
                finally:
                    client.cancel(futures)  # type: ignore[no-untyped-call]

            return _in_batches(candidates, threads, on_dask)
    from joblib import Parallel, cpu_count, delayed

    # more processes than cores or candidates only hold memory (about 35 MB each): 256 asked
    # on a 2-core machine started 259 processes and 9 GB
    cores = max(int(cpu_count()), 1)
    n_jobs = max(min(cores if n_jobs == -1 else n_jobs, cores, len(candidates)), 1)

    def on_joblib(batch: list[SeedArmGeometry], ends_at: float | None) -> list[Any]:
        # one Parallel per batch, not a shared ``with Parallel(...)``: on a timeout a shared
        # (managed) one kills its workers and at once sets up a new executor for the next
        # call, which the error exit then left alive; loky reuses the workers between batches
        # either way, and each batch waits only for what is left of the limit (the worker
        # tracker's warnings at such an exit: armpath.cli.workspace.quiet_worker_tracker)
        jobs = (delayed(_evaluate_within)(ends_at, g, pixel_mm, samples, seed) for g in batch)
        return list(Parallel(n_jobs=n_jobs, timeout=_wait_limit())(jobs))

    return _in_batches(candidates, n_jobs, on_joblib)


def ranked(results: Sequence[DesignMetrics], tie: float = 0.005) -> list[DesignMetrics]:
    """Best first by the objective: reach volume above the table, volumes within ``tie``
    (relative, about the sampling noise) counting as equal; then the smaller blind volume."""
    if not results:
        return []
    step = tie * max(r.reach_volume_mm3 for r in results)
    return sorted(results, key=lambda r: (-round(r.reach_volume_mm3 / step), r.blind_volume_mm3))
