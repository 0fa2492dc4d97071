"""Design study of the seed arm (seed 000 section 6.2): link lengths and joint ranges against
reach and blind zones.

**Objective** (stated, after seed 000's equation 37): at a fixed total length
``AB + BC + CD + DE`` (the material of the arm), maximise the volume the fingertip reaches above
the table (z >= 0, turned about the vertical axis; the central blind zone is not counted, being
unreachable); ties go to the smaller blind volume. Every candidate is evaluated by
:func:`evaluate_design` from a seeded meridian map, so results do not depend on where they run.

:func:`sweep` runs the candidates in parallel on this machine (joblib) or, given the address of
a Dask scheduler, on that cluster: the same function on the same inputs either way.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from itertools import product

import numpy as np

from armpath.errors import InvalidInputError
from armpath.model.seed_arm import SeedArmGeometry, seed_arm
from armpath.workspace.blindzones import meridian_map


@dataclass(frozen=True)
class DesignMetrics:
    """One candidate's numbers (mm, mm^3)."""

    geometry: SeedArmGeometry
    reach_volume_mm3: float
    blind_volume_mm3: float
    farthest_mm: float
    nearest_to_b_mm: float

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
    )


def design_grid(
    total_mm: float = 715.0,
    ab_mm: Sequence[float] = (100.0, 140.0, 180.0, 220.0, 250.0),
    de_mm: Sequence[float] = (45.0, 65.0, 100.0, 147.0),
    theta3_deg: Sequence[float] = (138.0, 165.0),
    base: SeedArmGeometry | None = None,
) -> list[SeedArmGeometry]:
    """Candidates with ``AB + BC + CD + DE = total_mm`` and ``BC = CD``; the other ranges as in
    ``base`` (default: the seed arm's)."""
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
    processes."""
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise InvalidInputError("--scheduler needs Dask: pip install 'armpath[dask]'") from None
        try:
            client = Client(scheduler, timeout="5s")  # type: ignore[no-untyped-call]
        except OSError as exc:
            raise InvalidInputError(
                f"cannot reach the Dask scheduler at {scheduler}: {exc}"
            ) from None
        with client:
            futures = client.map(
                evaluate_design,
                list(candidates),
                pixel_mm=pixel_mm,
                samples=samples,
                seed=seed,
                pure=True,
            )
            return list(client.gather(futures))  # type: ignore[no-untyped-call]
    from joblib import Parallel, delayed

    return list(
        Parallel(n_jobs=n_jobs)(
            delayed(evaluate_design)(g, pixel_mm, samples, seed) for g in candidates
        )
    )


def ranked(results: Sequence[DesignMetrics], tie: float = 0.005) -> list[DesignMetrics]:
    """Best first by the objective: reach volume above the table, volumes within ``tie``
    (relative, about the sampling noise) counting as equal; then the smaller blind volume."""
    if not results:
        return []
    step = tie * max(r.reach_volume_mm3 for r in results)
    return sorted(results, key=lambda r: (-round(r.reach_volume_mm3 / step), r.blind_volume_mm3))
