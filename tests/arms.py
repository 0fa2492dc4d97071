"""Arms the tests build from D-H tables (beside the built-in models)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from armpath.model.dh import DHRow
from armpath.model.serial_arm import JointKind


def scara_rows(elbow_limit_rad: float = 2.4) -> list[DHRow]:
    """A SCARA's standard D-H table (mm, rad): arms of 300 and 250 mm at 400 mm, each turning
    within +-``elbow_limit_rad``, a quill sliding 0..200 mm down (prismatic), the tool 50 mm
    below on the last axis."""
    limits = (-elbow_limit_rad, elbow_limit_rad)
    return [
        DHRow(300.0, 0.0, 400.0, limits=limits),
        DHRow(250.0, np.pi, 0.0, limits=limits),
        DHRow(0.0, 0.0, 0.0, kind=JointKind.PRISMATIC, limits=(0.0, 200.0)),
        DHRow(0.0, 0.0, 50.0, limits=(-3.0, 3.0)),
    ]


def scara_robot_file(path: Path, elbow_limit_deg: float) -> Path:
    """Write ``scara_rows``' SCARA as a D-H robot file in mm and deg at ``path`` (joints 1
    and 2 within +-``elbow_limit_deg``, the quill 0..200 mm, joint 4 within +-170 deg)."""
    limits = [-elbow_limit_deg, elbow_limit_deg]
    path.write_text(
        json.dumps(
            {
                "name": "scara", "convention": "standard",
                "units": {"length": "mm", "angle": "deg"},
                "links": [
                    {"a": 300, "alpha": 0, "d": 400, "limits": limits},
                    {"a": 250, "alpha": 180, "d": 0, "limits": limits},
                    {"a": 0, "alpha": 0, "d": 0, "type": "prismatic", "limits": [0, 200]},
                    {"a": 0, "alpha": 0, "d": 50, "limits": [-170, 170]},
                ],
            }
        )
    )  # fmt: skip
    return path


def planar_two_link_file(path: Path) -> Path:
    """Write a planar two-link arm as a D-H robot file in mm and deg at ``path``: two
    revolute joints about parallel z axes (within +-180 deg), links 300 and 200 mm, the tool
    point in the plane z = 0."""
    links = [{"a": a, "alpha": 0, "d": 0, "offset": 0, "limits": [-180, 180]} for a in (300, 200)]
    units = {"length": "mm", "angle": "deg"}
    doc = {"name": "planar2", "convention": "standard", "units": units, "links": links}
    path.write_text(json.dumps(doc))
    return path


#: The UR5's standard D-H table, from its maker's published parameters: (a mm, alpha rad,
#: d mm) of each joint.
UR5_DH = (
    [0.0, -425.0, -392.25, 0.0, 0.0, 0.0],
    [np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0],
    [89.159, 0.0, 0.0, 109.15, 94.65, 82.3],
)
