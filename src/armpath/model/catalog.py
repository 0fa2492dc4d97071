"""Built-in robot models, by name, and the resolver the CLI's ``--model NAME|FILE`` uses.

Every length is mm and every angle rad. Sources:

* ``seed``: the seed arm of SPEC section 1 (:mod:`armpath.model.seed_arm`).
* ``welder003``: seed 003's welding arm, RRP positioning plus a spherical wrist, modified D-H
  exactly as the report's table (``a1 = 500 mm``, prismatic ``d3`` in [0, 700] mm, ``d6 = 200``
  mm to the tool tip).
* ``painter004``: seed 004's painting robot, standard D-H with the paper's lengths (``d1 = 842,
  a1 = 400, a2 = 800, a3 = 130, d4 = 774, d5 = 98, d6 = 63`` mm) and its oblique wrist twist
  ``alpha5 = 50 deg``; the other twists are ``alpha1 = -90, alpha2 = 0, alpha3 = -90,
  alpha4 = 90, alpha6 = 0`` deg (see ``docs/seed004.md`` for why and what the paper's table
  gives).
* ``puma560``: Corke's standard D-H PUMA 560 (lengths in mm) with its joint limits.
* ``ur5``: Universal Robots UR5, the maker's standard D-H parameters, joints +-360 deg.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from armpath.errors import InvalidInputError
from armpath.model.dh import DHRow, dh_arm, load_robot_file
from armpath.model.seed_arm import seed_arm
from armpath.model.serial_arm import JointKind, SerialArm

_D = np.pi / 180.0


def _rows(
    a: list[float],
    alpha_deg: list[float],
    d: list[float],
    limits_deg: list[tuple[float, float]] | None = None,
) -> list[DHRow]:
    lim = limits_deg or [(-np.inf, np.inf)] * len(a)
    return [
        DHRow(a=ai, alpha=al * _D, d=di, limits=(lo * _D, hi * _D))
        for ai, al, di, (lo, hi) in zip(a, alpha_deg, d, lim, strict=True)
    ]


def welder003() -> SerialArm:
    """Seed 003's RRP + spherical-wrist welding arm (modified D-H, mm)."""
    rows = [
        DHRow(a=0.0, alpha=0.0, d=0.0),
        DHRow(a=500.0, alpha=-90 * _D, d=0.0),
        DHRow(a=0.0, alpha=90 * _D, d=0.0, kind=JointKind.PRISMATIC, limits=(0.0, 700.0)),
        DHRow(a=0.0, alpha=0.0, d=0.0),
        DHRow(a=0.0, alpha=-90 * _D, d=0.0),
        DHRow(a=0.0, alpha=90 * _D, d=200.0),
    ]
    return dh_arm(rows, "modified", name="welder003", home=[0.0, 0.0, 350.0, 0.0, 0.0, 0.0])


def painter004() -> SerialArm:
    """Seed 004's painting robot (standard D-H, mm) with the oblique 50 deg wrist twist."""
    rows = _rows(
        a=[400.0, 800.0, 130.0, 0.0, 0.0, 0.0],
        alpha_deg=[-90.0, 0.0, -90.0, 90.0, 50.0, 0.0],
        d=[842.0, 0.0, 0.0, 774.0, 98.0, 63.0],
    )
    return dh_arm(rows, "standard", name="painter004")


def puma560() -> SerialArm:
    """PUMA 560, standard D-H as in Corke's Robotics Toolbox (mm), with its joint limits."""
    rows = _rows(
        a=[0.0, 431.8, 20.32, 0.0, 0.0, 0.0],
        alpha_deg=[90.0, 0.0, -90.0, 90.0, -90.0, 0.0],
        d=[0.0, 0.0, 150.05, 431.8, 0.0, 0.0],
        limits_deg=[(-160, 160), (-45, 225), (-225, 45), (-110, 170), (-100, 100), (-266, 266)],
    )
    return dh_arm(rows, "standard", name="puma560")


def ur5() -> SerialArm:
    """Universal Robots UR5, standard D-H (mm); three parallel axes (2, 3, 4)."""
    rows = _rows(
        a=[0.0, -425.0, -392.25, 0.0, 0.0, 0.0],
        alpha_deg=[90.0, 0.0, 0.0, 90.0, -90.0, 0.0],
        d=[89.159, 0.0, 0.0, 109.15, 94.65, 82.3],
        limits_deg=[(-360, 360)] * 6,
    )
    return dh_arm(rows, "standard", name="ur5")


BUILTIN_MODELS: dict[str, Callable[[], SerialArm]] = {
    "seed": seed_arm,
    "welder003": welder003,
    "painter004": painter004,
    "puma560": puma560,
    "ur5": ur5,
}


def resolve_model(spec: str) -> SerialArm:
    """A built-in model by name, or a robot file (``.json`` D-H table or ``.urdf``) by path."""
    if spec in BUILTIN_MODELS:
        return BUILTIN_MODELS[spec]()
    if Path(spec).suffix.lower() in (".json", ".urdf") or Path(spec).exists():
        return load_robot_file(spec)
    raise InvalidInputError(
        f"unknown model {spec!r}: use one of {sorted(BUILTIN_MODELS)} or a .json / .urdf file"
    )
