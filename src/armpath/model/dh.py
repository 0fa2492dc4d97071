"""Serial arms from Denavit-Hartenberg tables (standard and modified) and robot files.

Conventions (lengths in the table's unit, converted to mm; angles converted to rad):

* **standard** (Denavit-Hartenberg 1955, as in Spong / Corke's ``DHRobot``):
  ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``, pose ``T = base A_1 ... A_n tool``.
* **modified** (Craig): ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``; row ``i`` holds
  ``alpha_{i-1}, a_{i-1}, d_i`` exactly as Craig's tables and Corke's ``RevoluteMDH`` do.

A revolute row moves ``theta_i = q_i + offset`` (``d`` fixed); a prismatic row moves
``d_i = d + offset + q_i`` with the fixed angle ``theta`` (default 0). Both map onto the URDF-like
:class:`~armpath.model.serial_arm.SerialArm`, so kinematics, IK and collision code never see the
table again.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import MAX_JOINTS
from armpath.errors import InvalidInputError
from armpath.model.lattice import MM_PER_LENGTH_UNIT
from armpath.model.serial_arm import (
    Joint,
    JointKind,
    SerialArm,
    check_length,
    check_rigid,
    check_turns,
    default_home,
)
from armpath.model.skeleton import link_radii, physical_links

FloatArray = NDArray[np.float64]

CONVENTIONS = ("standard", "modified")


@dataclass(frozen=True)
class DHRow:
    """One row of a D-H table, in mm and rad.

    ``limits`` is ``(lower, upper)`` of the joint variable ``q`` (rad, or mm for prismatic);
    ``theta`` is the fixed joint angle of a prismatic row (ignored for revolute rows).
    """

    a: float
    alpha: float
    d: float
    offset: float = 0.0
    kind: JointKind = JointKind.REVOLUTE
    limits: tuple[float, float] = (-np.inf, np.inf)
    theta: float = 0.0


def _rot_x(angle: float) -> FloatArray:
    c, s = np.cos(angle), np.sin(angle)
    T = np.eye(4)
    T[1:3, 1:3] = [[c, -s], [s, c]]
    return T


def _rot_z(angle: float) -> FloatArray:
    c, s = np.cos(angle), np.sin(angle)
    T = np.eye(4)
    T[0:2, 0:2] = [[c, -s], [s, c]]
    return T


def _trans(x: float = 0.0, z: float = 0.0) -> FloatArray:
    T = np.eye(4)
    T[0, 3] = x
    T[2, 3] = z
    return T


def _fixed_along_z(row: DHRow) -> FloatArray:
    """The part of ``Rz(theta) Tz(d)`` that does not move: offset angle or fixed angle/length."""
    if row.kind is JointKind.PRISMATIC:
        return _rot_z(row.theta) @ _trans(z=row.d + row.offset)
    return _trans(z=row.d) @ _rot_z(row.offset)


def dh_arm(
    rows: Sequence[DHRow],
    convention: str = "standard",
    *,
    name: str = "dh-arm",
    T_world_base: ArrayLike | None = None,
    T_flange_tool: ArrayLike | None = None,
    home: ArrayLike | None = None,
    link_radii_mm: float | Sequence[float] = 0.0,
    pedestal_mm: float = 0.0,
    parameters: tuple[tuple[str, float], ...] = (),
) -> SerialArm:
    """Build a :class:`SerialArm` (lengths mm) from D-H rows in ``convention``.

    Joint ``i``'s frame is placed on its axis (z) so that the chain reproduces the D-H product
    exactly. The landmarks are the base, every joint frame and the tool (in that order), then
    the corners the links turn at; the links are the physical skeleton of
    :func:`~armpath.model.skeleton.physical_links`: the table's ``a`` and ``d`` legs, zero-length
    ones dropped. ``link_radii_mm`` is one capsule radius for every link or ``n + 1`` of them
    (the fixed base, then the link each joint moves); ``pedestal_mm`` adds a base column below
    the base frame.
    """
    if convention not in CONVENTIONS:
        raise InvalidInputError(f"convention must be one of {CONVENTIONS}, got {convention!r}")
    if not rows:
        raise InvalidInputError("a D-H table needs at least one row")
    joints = []
    carry = np.eye(4)  # standard D-H: the previous row's Tx(a) Rx(alpha)
    for i, row in enumerate(rows):
        values = (row.a, row.alpha, row.d, row.offset, row.theta)
        if not all(np.isfinite(v) for v in values):
            raise InvalidInputError(f"D-H row {i + 1}: a, alpha, d, offset must be finite numbers")
        if convention == "standard":
            T_parent = carry @ _fixed_along_z(row)
            carry = _trans(x=row.a) @ _rot_x(row.alpha)
        else:
            T_parent = _rot_x(row.alpha) @ _trans(x=row.a) @ _fixed_along_z(row)
        joints.append(
            Joint(
                name=f"q{i + 1}",
                T_parent_joint=T_parent,
                axis=np.array([0.0, 0.0, 1.0]),
                kind=row.kind,
                limits=row.limits,
            )
        )
    tool = np.eye(4) if T_flange_tool is None else np.asarray(T_flange_tool, dtype=np.float64)
    if convention == "standard":
        tool = carry @ tool
    n = len(rows)
    home_q = default_home(joints) if home is None else np.asarray(home, dtype=np.float64)
    names = ("base", *(f"J{i + 1}" for i in range(n)), "tool")
    radii = link_radii(link_radii_mm, n, "link radii")
    landmarks, links = physical_links(joints, tool, names, radii, pedestal=pedestal_mm)
    return SerialArm(
        name=name,
        joints=tuple(joints),
        T_flange_tool=tool,
        T_joint_flange=carry if convention == "standard" else np.eye(4),
        landmarks=landmarks,
        links=links,
        home=home_q,
        length_unit="mm",
        T_world_base=np.eye(4) if T_world_base is None else np.asarray(T_world_base, dtype=float),
        parameters=parameters,
    )


# ---------------------------------------------------------------------------------------------
# Robot files
# ---------------------------------------------------------------------------------------------


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidInputError(f"{where} must be a number, got {value!r}")
    try:
        x = float(value)
    except OverflowError:  # an integer beyond any float (JSON integers have no limit)
        x = np.inf
    if not np.isfinite(x):
        raise InvalidInputError(f"{where} must be finite, got {x!r}")
    return x


def _length(value: Any, where: str, unit: str) -> float:
    """A length of the file (``unit``) in mm, within the model's largest length."""
    return check_length(_number(value, where), where, unit) * MM_PER_LENGTH_UNIT[unit]


def _transform(value: Any, where: str, unit: str) -> FloatArray:
    """A 4x4 rigid transform of the file, its translation (``unit``) in mm."""
    wrong = InvalidInputError(
        f"{where} must be a 4x4 matrix (nested or 16 finite numbers, row-major)"
    )
    if not isinstance(value, list):
        raise wrong
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):  # text, ragged rows, a huge integer
        raise wrong from None
    if arr.shape not in ((4, 4), (16,)) or not np.all(np.isfinite(arr)):
        raise wrong
    T = arr.reshape(4, 4).copy()
    for k, axis in enumerate("xyz"):
        check_length(float(T[k, 3]), f"{where}: translation {axis}", unit)
    check_rigid(T, where)
    T[:3, 3] *= MM_PER_LENGTH_UNIT[unit]
    return T


def robot_from_dict(
    doc: Mapping[str, Any], name: str = "robot", source: str = "robot file"
) -> SerialArm:
    """Build an arm from the JSON robot-file shape.

    ``{"convention": "standard" | "modified", "units": {"length": "mm" | "m", "angle": "deg" |
    "rad"}, "links": [{"a", "alpha", "d", "offset", "type": "revolute" | "prismatic", "limits":
    [lo, hi], "theta"}, ...], "base": 4x4, "tool": 4x4, "home": [q1, ...], "name": str,
    "link_radii_mm": r | [r0, r1, ..., rn]}``. Only ``links`` is required; ``units`` default to
    mm and deg, ``convention`` to standard. Limits are in the joint's unit (angle unit for
    revolute, length unit for prismatic); ``"limits": null`` (or leaving it out) means unlimited,
    and ``null`` for one bound leaves that side unlimited. ``link_radii_mm`` (always mm, default
    0) is the links' capsule radius: one for every link, or ``n + 1`` (the fixed base, then the
    link each joint moves; see :func:`~armpath.model.skeleton.physical_links`). Messages begin
    with ``source`` (the file's name).
    """
    if not isinstance(doc, Mapping):
        raise InvalidInputError(f"{source} must hold a JSON object")
    known = {"convention", "units", "links", "base", "tool", "name", "home", "link_radii_mm"}
    unknown = sorted(set(doc) - known)
    if unknown:
        raise InvalidInputError(f"{source}: unknown key(s) {unknown}; known: {sorted(known)}")
    convention = doc.get("convention", "standard")
    if convention not in CONVENTIONS:
        raise InvalidInputError(f"{source}: convention must be one of {CONVENTIONS}")
    units = doc.get("units", {})
    if not isinstance(units, Mapping):
        raise InvalidInputError(f'{source}: units must be an object like {{"length": "mm"}}')
    length_unit = units.get("length", "mm")
    angle_unit = units.get("angle", "deg")
    if length_unit not in MM_PER_LENGTH_UNIT:
        raise InvalidInputError(f"{source}: units.length must be 'mm' or 'm', got {length_unit!r}")
    if angle_unit not in ("deg", "rad"):
        raise InvalidInputError(f"{source}: units.angle must be 'deg' or 'rad', got {angle_unit!r}")
    L = MM_PER_LENGTH_UNIT[length_unit]
    A = np.pi / 180.0 if angle_unit == "deg" else 1.0
    links = doc.get("links")
    if not isinstance(links, list) or not links:
        raise InvalidInputError(f"{source}: 'links' must be a non-empty list of D-H rows")
    if len(links) > MAX_JOINTS:  # before what is counted against them (home, link radii)
        raise InvalidInputError(
            f"{source}: a serial arm may have at most {MAX_JOINTS} joints, got {len(links)} links"
        )
    rows = []
    row_keys = {"a", "alpha", "d", "offset", "type", "limits", "theta"}
    for i, link in enumerate(links):
        where = f"{source}: links[{i}]"
        if not isinstance(link, Mapping):
            raise InvalidInputError(f"{where} must be an object with a, alpha, d")
        bad = sorted(set(link) - row_keys)
        if bad:
            raise InvalidInputError(f"{where}: unknown key(s) {bad}; known: {sorted(row_keys)}")
        kind_name = link.get("type", "revolute")
        if kind_name not in ("revolute", "prismatic"):
            raise InvalidInputError(f"{where}.type must be 'revolute' or 'prismatic'")
        kind = JointKind(kind_name)
        q_scale = A if kind is JointKind.REVOLUTE else L
        limits_raw = link.get("limits")
        if limits_raw is None:  # absent or null: unlimited
            limits_raw = [None, None]
        if not isinstance(limits_raw, list) or len(limits_raw) != 2:
            raise InvalidInputError(
                f"{where}.limits must be [lower, upper] (null for an unlimited side) or null "
                f"for an unlimited joint, got {limits_raw!r}"
            )
        lo = -np.inf if limits_raw[0] is None else _number(limits_raw[0], f"{where}.limits[0]")
        hi = np.inf if limits_raw[1] is None else _number(limits_raw[1], f"{where}.limits[1]")
        if kind is JointKind.PRISMATIC:  # lengths, as a, d and offset
            for side, v in enumerate((lo, hi)):
                if np.isfinite(v):
                    check_length(v, f"{where}.limits[{side}]", length_unit)
        if lo > hi:
            raise InvalidInputError(f"{where}.limits: lower {lo} exceeds upper {hi}")
        if kind is JointKind.REVOLUTE:
            check_turns(
                (lo * A, hi * A),
                f"{where}.limits",
                angle_unit,
                "were they written in degrees? (units.angle is rad)"
                if angle_unit == "rad"
                else None,
            )
        offset = link.get("offset", 0.0)
        rows.append(
            DHRow(
                a=_length(link.get("a", 0.0), f"{where}.a", length_unit),
                alpha=_number(link.get("alpha", 0.0), f"{where}.alpha") * A,
                d=_length(link.get("d", 0.0), f"{where}.d", length_unit),
                offset=(
                    _length(offset, f"{where}.offset", length_unit)
                    if kind is JointKind.PRISMATIC
                    else _number(offset, f"{where}.offset") * A
                ),
                kind=kind,
                limits=(lo * q_scale, hi * q_scale),
                theta=_number(link.get("theta", 0.0), f"{where}.theta") * A,
            )
        )
    base = _transform(doc["base"], f"{source}: base", length_unit) if "base" in doc else None
    tool = _transform(doc["tool"], f"{source}: tool", length_unit) if "tool" in doc else None
    home = None
    if "home" in doc:
        raw = doc["home"]
        if not isinstance(raw, list) or len(raw) != len(rows):
            raise InvalidInputError(f"{source}: home must list {len(rows)} joint values")
        home = [
            _number(v, f"{source}: home[{i}]") * A
            if r.kind is JointKind.REVOLUTE
            else _length(v, f"{source}: home[{i}]", length_unit)
            for i, (v, r) in enumerate(zip(raw, rows, strict=True))
        ]
    radii: float | list[float] = 0.0
    if "link_radii_mm" in doc:
        raw = doc["link_radii_mm"]
        where = f"{source}: link_radii_mm"
        if isinstance(raw, list):
            values = [_length(v, f"{where}[{i}]", "mm") for i, v in enumerate(raw)]
        else:
            values = [_length(raw, where, "mm")]
        radii = link_radii(values if isinstance(raw, list) else values[0], len(rows), where)
    label = doc.get("name", name)
    return dh_arm(
        rows,
        convention,
        name=str(label),
        T_world_base=base,
        T_flange_tool=tool,
        home=home,
        link_radii_mm=radii,
    )


def load_robot_file(path: str | Path, tip_link: str | None = None) -> SerialArm:
    """Load a robot from a JSON file (``.json``: a D-H table, or armpath's model document as
    ``armpath model convert --to json`` writes it) or a URDF (``.urdf``, up to ``tip_link``,
    default its deepest link no gripper finger carries); lengths become mm."""
    p = Path(path)
    if not p.is_file():
        raise InvalidInputError(f"robot file {str(p)!r} does not exist")
    suffix = p.suffix.lower()
    if suffix == ".urdf":
        from armpath.model.urdf import arm_from_urdf

        return arm_from_urdf(p, tip_link)
    if tip_link is not None:
        raise InvalidInputError(
            f"a tip link (--tip-link, tip_link=) names a link of a URDF; {p.name!r} is not one"
        )
    if suffix != ".json":
        raise InvalidInputError(f"robot file {p.name!r}: expected a .json D-H file or a .urdf")
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InvalidInputError(f"robot file {p.name!r} is not valid JSON: {exc}") from exc
    if isinstance(doc, dict) and "joints" in doc and "version" in doc:
        from armpath.model.serialize import arm_from_dict  # armpath's own model document

        return arm_from_dict(doc, f"robot file {p.name!r}").in_mm()  # like a D-H table's
    return robot_from_dict(doc, name=p.stem, source=f"robot file {p.name!r}")
