"""Built-in robot models, by name, and the resolver the CLI's ``--model NAME|FILE`` uses.

Every length is mm and every angle rad. Sources:

* ``seed``: the seed arm of SPEC section 1 (:mod:`armpath.model.seed_arm`).
* ``welder003``: seed 003's welding arm, RRP positioning plus a spherical wrist, modified D-H
  exactly as the report's table (``a1 = 500 mm``, prismatic ``d3`` in [0, 700] mm, ``d6 = 200``
  mm to the tool tip).
* ``painter004``: seed 004's painting robot, standard D-H with the paper's lengths (``d1 = 842,
  a1 = 400, a2 = 800, a3 = 130, d4 = 774, d5 = 98, d6 = 63`` mm), twists ``-90, 0, -90, -50,
  +50, 0`` deg and joint offsets ``0, -90, 0, -90, 0, 180`` deg: the one model found that
  reproduces the paper's pose and its table 1 (``docs/seed004.md``).
* ``puma560``: Corke's standard D-H PUMA 560 (lengths in mm) with its joint limits.
* ``ur5``: Universal Robots UR5, the maker's standard D-H parameters, joints +-360 deg.
* ``iiwa14``: KUKA LBR iiwa 14 R820, a 7-axis arm (standard D-H, the maker's joint limits).

Collision links are each model's physical skeleton (:mod:`armpath.model.skeleton`) with the
capsule radii below (mm; the fixed base first, then the link each joint moves; zero-length
links have none): round numbers of the order of each machine's link thickness, to keep the
links' bodies apart, not measured envelopes. A robot file sets its own (``link_radii_mm``); the
seed arm keeps its zero radius (SPEC).
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

#: Capsule radii (mm): the fixed base, then the link each joint moves (see the module docstring).
#: welder003: the 500 mm arm, the boom, the 200 mm torch.
WELDER003_LINK_RADII_MM = (0.0, 60.0, 50.0, 0.0, 0.0, 25.0, 0.0)
#: painter004: the 842 mm column, the 400 mm shoulder, the 800 mm arm, the forearm, the wrist.
PAINTER004_LINK_RADII_MM = (150.0, 120.0, 100.0, 80.0, 60.0, 50.0, 0.0)
#: puma560: the trunk, the upper arm (with the elbow's 150 mm offset), the forearm (with the
#: spherical wrist at its end: links 4-6 have zero length).
PUMA560_LINK_RADII_MM = (100.0, 0.0, 80.0, 55.0, 0.0, 0.0, 0.0)
#: The PUMA 560's trunk: its D-H base frame is at the shoulder, 26.45 in above the mounting
#: surface (the height Corke's Python Robotics Toolbox gives).
PUMA560_PEDESTAL_MM = 26.45 * 25.4
#: iiwa14: the base, then the seven links (shoulder, upper arm, elbow, forearm, wrist, flange).
IIWA14_LINK_RADII_MM = (80.0, 70.0, 70.0, 65.0, 65.0, 55.0, 50.0, 40.0)
#: ur5: the base column, the upper arm, the forearm (with wrist 1's 109 mm housing), wrists 2, 3.
UR5_LINK_RADII_MM = (75.0, 0.0, 60.0, 50.0, 45.0, 45.0, 0.0)


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


def welder003(d3_max_mm: float = 700.0) -> SerialArm:
    """Seed 003's RRP + spherical-wrist welding arm (modified D-H, mm); the report also uses
    ``d3_max_mm = 300`` to show its torus-shaped dexterous workspace."""
    rows = [
        DHRow(a=0.0, alpha=0.0, d=0.0),
        DHRow(a=500.0, alpha=-90 * _D, d=0.0),
        DHRow(a=0.0, alpha=90 * _D, d=0.0, kind=JointKind.PRISMATIC, limits=(0.0, d3_max_mm)),
        DHRow(a=0.0, alpha=0.0, d=0.0),
        DHRow(a=0.0, alpha=-90 * _D, d=0.0),
        DHRow(a=0.0, alpha=90 * _D, d=200.0),
    ]
    return dh_arm(
        rows,
        "modified",
        name="welder003",
        home=[0.0, 0.0, 0.5 * d3_max_mm, 0.0, 0.0, 0.0],
        link_radii_mm=WELDER003_LINK_RADII_MM,
    )


def painter004() -> SerialArm:
    """Seed 004's painting robot (standard D-H, mm): the model that reproduces the paper.

    Lengths as printed; twists -90, 0, -90, -50, +50, 0 deg (the printed alpha5 = 50 deg and an
    opposite alpha4 = -50 deg, the oblique wrist of the paper's figure); joint offsets 0, -90, 0,
    -90, 0, 180 deg between the paper's angles q and the D-H angles theta = q + offset; the
    paper's joint ranges. With these, (20, 30, 20, 25, 80, 0) deg gives the printed pose and
    table 1's four real solutions (``docs/seed004.md``).
    """
    D = _D
    lengths = [(400.0, 842.0), (800.0, 0.0), (130.0, 0.0), (0.0, 774.0), (0.0, 98.0), (0.0, 63.0)]
    twists = [-90.0, 0.0, -90.0, -50.0, 50.0, 0.0]
    offsets = [0.0, -90.0, 0.0, -90.0, 0.0, 180.0]
    ranges = [(-90, 90), (-30, 90), (-70, 70), (-300, 300), (-180, 180), (-460, 460)]
    rows = [
        DHRow(a=a, alpha=al * D, d=d, offset=off * D, limits=(lo * D, hi * D))
        for (a, d), al, off, (lo, hi) in zip(lengths, twists, offsets, ranges, strict=True)
    ]
    return dh_arm(rows, "standard", name="painter004", link_radii_mm=PAINTER004_LINK_RADII_MM)


def puma560() -> SerialArm:
    """PUMA 560, standard D-H as in Corke's Robotics Toolbox (mm), with its joint limits."""
    rows = _rows(
        a=[0.0, 431.8, 20.32, 0.0, 0.0, 0.0],
        alpha_deg=[90.0, 0.0, -90.0, 90.0, -90.0, 0.0],
        d=[0.0, 0.0, 150.05, 431.8, 0.0, 0.0],
        limits_deg=[(-160, 160), (-45, 225), (-225, 45), (-110, 170), (-100, 100), (-266, 266)],
    )
    return dh_arm(
        rows,
        "standard",
        name="puma560",
        link_radii_mm=PUMA560_LINK_RADII_MM,
        pedestal_mm=PUMA560_PEDESTAL_MM,
    )


def ur5() -> SerialArm:
    """Universal Robots UR5, standard D-H (mm); three parallel axes (2, 3, 4)."""
    rows = _rows(
        a=[0.0, -425.0, -392.25, 0.0, 0.0, 0.0],
        alpha_deg=[90.0, 0.0, 0.0, 90.0, -90.0, 0.0],
        d=[89.159, 0.0, 0.0, 109.15, 94.65, 82.3],
        limits_deg=[(-360, 360)] * 6,
    )
    return dh_arm(rows, "standard", name="ur5", link_radii_mm=UR5_LINK_RADII_MM)


def iiwa14() -> SerialArm:
    """KUKA LBR iiwa 14 R820, a 7-axis arm: standard D-H (mm) with the maker's joint limits
    (a redundant arm: every tool pose has a one-dimensional family of solutions)."""
    rows = _rows(
        a=[0.0] * 7,
        alpha_deg=[-90.0, 90.0, 90.0, -90.0, -90.0, 90.0, 0.0],
        d=[360.0, 0.0, 420.0, 0.0, 400.0, 0.0, 126.0],
        limits_deg=[(-170, 170), (-120, 120), (-170, 170), (-120, 120), (-170, 170), (-120, 120),
                    (-175, 175)],
    )  # fmt: skip
    return dh_arm(
        rows,
        "standard",
        name="iiwa14",
        home=np.radians([0.0, 30.0, 0.0, -60.0, 0.0, 30.0, 0.0]),
        link_radii_mm=IIWA14_LINK_RADII_MM,
    )


BUILTIN_MODELS: dict[str, Callable[[], SerialArm]] = {
    "seed": seed_arm,
    "welder003": welder003,
    "painter004": painter004,
    "puma560": puma560,
    "ur5": ur5,
    "iiwa14": iiwa14,
}


def resolve_model(spec: str, tip_link: str | None = None) -> SerialArm:
    """A built-in model by name, or a robot file (``.json`` D-H table or ``.urdf``, up to
    ``tip_link``) by path."""
    if spec in BUILTIN_MODELS:
        if tip_link is not None:
            raise InvalidInputError(
                f"a tip link (--tip-link, tip_link=) names a link of a URDF; {spec!r} is built in"
            )
        return BUILTIN_MODELS[spec]()
    if spec.strip() and (Path(spec).suffix.lower() in (".json", ".urdf") or Path(spec).is_file()):
        return load_robot_file(spec, tip_link)
    raise InvalidInputError(
        f"unknown model {spec!r}: use one of {sorted(BUILTIN_MODELS)} or a .json / .urdf file"
    )
