"""The seed arm of SPEC section 1: the one place where its numbers live.

Six revolute joints; points A (base, on the table), B, C, D, E (fingertip). Joints 1, 4, 6 turn
about their link's own axis, joints 2, 3, 5 bend the next link::

    R2 = Rz(t1) Rx(t2)    R3 = R2 Rx(t3)    R5 = R3 Rz(t4) Rx(t5)    R6 = R5 Rz(t6)
    B = (0, 0, AB)   C = B + BC R2 ez   D = C + CD R3 ez   E = D + DE R5 ez

Lengths are mm. Joint 6 turns the tool and does not move E.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from armpath.errors import InvalidInputError
from armpath.model.serial_arm import Joint, Landmark, Link, SerialArm

#: Initial pose Theta0 of SPEC section 1, degrees.
SEED_HOME_DEG: tuple[float, ...] = (0.0, -90.0, 0.0, 0.0, -90.0, 0.0)


@dataclass(frozen=True)
class SeedArmGeometry:
    """Link lengths (mm), joint ranges (deg, symmetric; ``inf`` = unlimited) and link radius (mm).

    The defaults are the seed papers' arm. Every number is a parameter so that design studies can
    vary it.
    """

    ab_mm: float = 140.0
    bc_mm: float = 255.0
    cd_mm: float = 255.0
    de_mm: float = 65.0
    range_deg: tuple[float, float, float, float, float, float] = (
        np.inf,
        125.0,
        138.0,
        np.inf,
        133.5,
        np.inf,
    )
    link_radius_mm: float = 0.0

    def __post_init__(self) -> None:
        for name in ("ab_mm", "bc_mm", "cd_mm", "de_mm"):
            value = float(getattr(self, name))
            if not (np.isfinite(value) and value > 0):
                raise InvalidInputError(f"seed arm: {name} must be a positive length, got {value}")
        if len(self.range_deg) != 6 or any(not (r > 0) for r in self.range_deg):
            raise InvalidInputError("seed arm: range_deg needs 6 positive half-ranges (inf = free)")
        if not (np.isfinite(self.link_radius_mm) and self.link_radius_mm >= 0):
            raise InvalidInputError("seed arm: link_radius_mm must be >= 0")


def _tz(length: float) -> np.ndarray:
    T = np.eye(4)
    T[2, 3] = length
    return T


def seed_arm(geometry: SeedArmGeometry | None = None) -> SerialArm:
    """Build the seed arm (SPEC section 1) as a :class:`SerialArm`.

    Frames: 1 = joint 1 at A, 2 = joint 2 at B, 3 = joint 3 at C, 4 = joint 4 at C,
    5 = joint 5 at D, 6 = joint 6 at D, 7 = tool at E. The home pose is SPEC's initial pose,
    clipped into the joint ranges when a design study narrows them.
    """
    g = geometry or SeedArmGeometry()
    ex, ez = (1.0, 0.0, 0.0), (0.0, 0.0, 1.0)
    placement = [
        (np.eye(4), ez),
        (_tz(g.ab_mm), ex),
        (_tz(g.bc_mm), ex),
        (np.eye(4), ez),
        (_tz(g.cd_mm), ex),
        (np.eye(4), ez),
    ]
    joints = tuple(
        Joint(
            name=f"theta{i + 1}",
            T_parent_joint=T,
            axis=np.array(axis),
            limits=(-np.radians(r), np.radians(r)) if np.isfinite(r) else (-np.inf, np.inf),
        )
        for i, ((T, axis), r) in enumerate(zip(placement, g.range_deg, strict=True))
    )
    landmarks = (
        Landmark("A", 1),
        Landmark("B", 2),
        Landmark("C", 3),
        Landmark("D", 5),
        Landmark("E", 7),
    )
    r = g.link_radius_mm
    links = (
        Link("AB", 0, 1, r, checked=False),
        Link("BC", 1, 2, r),
        Link("CD", 2, 3, r),
        Link("DE", 3, 4, r),
    )
    return SerialArm(
        name="seed",
        joints=joints,
        T_flange_tool=_tz(g.de_mm),
        landmarks=landmarks,
        links=links,
        home=np.clip(
            np.radians(SEED_HOME_DEG),
            [j.limits[0] for j in joints],
            [j.limits[1] for j in joints],
        ),
        length_unit="mm",
        parameters=(
            ("AB_mm", g.ab_mm),
            ("BC_mm", g.bc_mm),
            ("CD_mm", g.cd_mm),
            ("DE_mm", g.de_mm),
            ("link_radius_mm", g.link_radius_mm),
        ),
    )


def seed_geometry_from(
    parameters: Mapping[str, float], range_deg: Sequence[float]
) -> SeedArmGeometry:
    """The geometry named by a seed arm's ``parameters`` (``AB_mm`` ... ``DE_mm``, optional
    ``link_radius_mm``; a missing link raises ``KeyError``) and its six joint ranges (deg)."""
    return SeedArmGeometry(
        ab_mm=float(parameters["AB_mm"]),
        bc_mm=float(parameters["BC_mm"]),
        cd_mm=float(parameters["CD_mm"]),
        de_mm=float(parameters["DE_mm"]),
        range_deg=tuple(float(r) for r in range_deg),  # type: ignore[arg-type]
        link_radius_mm=float(parameters.get("link_radius_mm", 0.0)),
    )


def seed_geometry_of(arm: SerialArm) -> SeedArmGeometry:
    """Recover the :class:`SeedArmGeometry` of an arm built by :func:`seed_arm`.

    Raises :class:`InvalidInputError` for any other arm, so seed-specific solvers refuse models
    they do not understand instead of silently computing nonsense.
    """
    params = dict(arm.parameters)
    keys = ("AB_mm", "BC_mm", "CD_mm", "DE_mm")
    if arm.name != "seed" or any(k not in params for k in keys) or arm.n_joints != 6:
        raise InvalidInputError(
            f"model {arm.name!r} is not a seed-type arm (6R with links AB, BC, CD, DE)"
        )
    ranges = tuple(
        round(float(np.degrees(j.limits[1])), 9) if j.is_limited else float("inf")
        for j in arm.joints
    )
    geometry = seed_geometry_from(params, ranges)
    rebuilt = seed_arm(geometry)
    if not all(a.same_as(b) for a, b in zip(rebuilt.joints, arm.joints, strict=True)) or not (
        np.allclose(rebuilt.T_flange_tool, arm.T_flange_tool)
        and np.allclose(arm.T_world_base, np.eye(4))
    ):
        raise InvalidInputError(
            f"model {arm.name!r} does not match the seed-arm geometry (joints, tool at E, base "
            "at the origin)"
        )
    return geometry
