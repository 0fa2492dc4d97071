"""What a task asks of the tool: a point, and optionally how the tool must be turned there.

* :class:`ToolTarget` with ``orientation=None``: only the tool centre point's position counts
  (the seed tasks).
* :class:`AxisCone`: the tool's approach axis (a direction fixed in the tool frame, z by
  default) must lie within ``tolerance_rad`` of a world direction: a torch kept near a surface
  normal or pointing down.
* :class:`PoseOrientation`: the whole tool frame within ``tolerance_rad`` (rotation angle) of a
  given rotation.

Positions are in the model's length unit (mm for every built-in model), angles in rad. The
target tells how far a configuration is from it (:meth:`ToolTarget.errors`) and draws tool
rotations that satisfy its orientation rule (:meth:`ToolTarget.rotations`), which the
all-solutions IK turns into configurations.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.errors import InvalidInputError

FloatArray = NDArray[np.float64]


#: Largest angle of the tool's approach axis from the direction of its rule, and of the tool
#: frame from a whole pose, where none is given (deg).
DEFAULT_AXIS_TOLERANCE_DEG = 15.0
DEFAULT_ANGLE_TOLERANCE_DEG = 5.0


def refuse_alone(name: str, value: object, needs: str, given: object) -> None:
    """Refuse ``name`` given (not None) without ``needs``, the rule it qualifies (it would be
    ignored)."""
    if value is not None and given is None:
        raise InvalidInputError(f"{name} qualifies {needs}; give {needs} too")


def rule_tolerances(
    axis_tolerance_deg: float | None,
    angle_tolerance_deg: float | None,
    tool_axis: object,
    pose: object,
    names: tuple[str, str, str, str] = (
        "tool_axis",
        "axis_tolerance_deg",
        "pose",
        "angle_tolerance_deg",
    ),
) -> tuple[float, float]:
    """The axis and angle tolerances (deg) of an orientation rule, each refused without its
    rule (``tool_axis``, ``pose``) and outside [0, 180], their defaults where not given
    (:data:`DEFAULT_AXIS_TOLERANCE_DEG`, :data:`DEFAULT_ANGLE_TOLERANCE_DEG`); ``names``: the
    rule's and tolerance's names where they were given (arguments or options)."""
    axis_name, axis_tol_name, pose_name, angle_tol_name = names
    if tool_axis is not None and pose is not None:
        raise InvalidInputError(f"give {axis_name} or {pose_name}, not both")
    refuse_alone(axis_tol_name, axis_tolerance_deg, axis_name, tool_axis)
    refuse_alone(angle_tol_name, angle_tolerance_deg, pose_name, pose)
    axis = DEFAULT_AXIS_TOLERANCE_DEG if axis_tolerance_deg is None else axis_tolerance_deg
    angle = DEFAULT_ANGLE_TOLERANCE_DEG if angle_tolerance_deg is None else angle_tolerance_deg
    for what, v in ((axis_tol_name, axis), (angle_tol_name, angle)):
        if not (np.isfinite(v) and 0.0 <= v <= 180.0):
            raise InvalidInputError(f"{what} must be between 0 and 180 deg, got {v}")
    return float(axis), float(angle)


def unit_vector(v: ArrayLike, what: str) -> FloatArray:
    """``v`` (a finite non-zero 3-vector of any magnitude) scaled to length 1, read-only;
    :class:`InvalidInputError` naming ``what`` otherwise."""
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or not np.any(a):
        raise InvalidInputError(f"{what} must be a finite non-zero 3-vector, got {a.tolist()}")
    scaled = a / np.abs(a).max()  # any magnitude, 1e-300 or 1e300, without under- or overflow
    out = np.asarray(scaled / np.linalg.norm(scaled), dtype=np.float64)
    out.setflags(write=False)
    return out


def _check_tolerance(tol: float, what: str) -> float:
    if not (np.isfinite(tol) and 0.0 <= tol <= np.pi):
        raise InvalidInputError(f"{what} must be between 0 and 180 deg, got {np.degrees(tol)}")
    return float(tol)


@dataclass(frozen=True)
class AxisCone:
    """The tool's approach axis ``axis_tool`` (tool frame) within ``tolerance_rad`` of the world
    direction ``direction``."""

    direction: FloatArray
    tolerance_rad: float
    axis_tool: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def __post_init__(self) -> None:
        what = "the tool-axis direction (--tool-axis; tool_axis= in Python)"
        object.__setattr__(self, "direction", unit_vector(self.direction, what))
        object.__setattr__(self, "axis_tool", unit_vector(self.axis_tool, "tool approach axis"))
        object.__setattr__(
            self, "tolerance_rad", _check_tolerance(self.tolerance_rad, "axis tolerance")
        )

    def describe(self) -> dict[str, object]:
        return {
            "type": "axis_cone",
            "direction": self.direction.tolist(),
            "tool_axis": self.axis_tool.tolist(),
            "tolerance_deg": float(np.degrees(self.tolerance_rad)),
        }

    def words(self) -> str:
        """The rule in words, for messages: ``tool axis within 10 deg of (0, 0, -1)``."""
        toward = ", ".join(f"{v:.4g}" for v in self.direction + 0.0)  # + 0.0: no "-0"
        return f"tool axis within {np.degrees(self.tolerance_rad):g} deg of ({toward})"


@dataclass(frozen=True)
class PoseOrientation:
    """The tool frame within ``tolerance_rad`` (angle of the relative rotation) of
    ``R_world_tool``."""

    R_world_tool: FloatArray
    tolerance_rad: float

    def __post_init__(self) -> None:
        R = np.array(self.R_world_tool, dtype=np.float64)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)):
            raise InvalidInputError("a tool orientation must be a finite 3x3 rotation matrix")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
            raise InvalidInputError("a tool orientation must be a rotation matrix")
        u, _, vt = np.linalg.svd(R)
        R = u @ vt  # the nearest exact rotation
        R.setflags(write=False)
        object.__setattr__(self, "R_world_tool", R)
        object.__setattr__(
            self, "tolerance_rad", _check_tolerance(self.tolerance_rad, "angle tolerance")
        )

    def describe(self) -> dict[str, object]:
        return {
            "type": "pose",
            "R_world_tool": self.R_world_tool.tolist(),
            "tolerance_deg": float(np.degrees(self.tolerance_rad)),
        }

    def words(self) -> str:
        """The rule in words, for messages."""
        return f"tool frame within {np.degrees(self.tolerance_rad):g} deg of the pose asked"


Orientation = AxisCone | PoseOrientation


@dataclass(frozen=True)
class ToolTarget:
    """A point for the tool centre (model length unit) and an optional orientation rule."""

    position: FloatArray
    orientation: Orientation | None = None

    def __post_init__(self) -> None:
        p = np.array(self.position, dtype=np.float64).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise InvalidInputError(f"a target point must be three finite numbers, got {p}")
        p.setflags(write=False)
        object.__setattr__(self, "position", p)

    @property
    def position_only(self) -> bool:
        return self.orientation is None

    def angle_errors(self, R_world_tool: FloatArray) -> FloatArray:
        """How far each tool rotation ``(..., 3, 3)`` is outside the orientation rule (rad; 0
        inside it, or when there is no rule)."""
        R = np.asarray(R_world_tool, dtype=np.float64)
        o = self.orientation
        if o is None:
            return np.zeros(R.shape[:-2])
        return np.maximum(self.angles(R) - o.tolerance_rad, 0.0)

    def angles(self, R_world_tool: FloatArray) -> FloatArray:
        """The angle each tool rotation ``(..., 3, 3)`` makes with the rule's direction or
        rotation (rad; 0 without a rule)."""
        R = np.asarray(R_world_tool, dtype=np.float64)
        o = self.orientation
        if o is None:
            return np.zeros(R.shape[:-2])
        if isinstance(o, AxisCone):
            axis = R @ o.axis_tool
            return np.asarray(np.arccos(np.clip(axis @ o.direction, -1.0, 1.0)))
        rel = np.swapaxes(R, -1, -2) @ o.R_world_tool
        cos = (np.trace(rel, axis1=-2, axis2=-1) - 1.0) / 2.0
        return np.asarray(np.arccos(np.clip(cos, -1.0, 1.0)))

    def rotations(self, count: int, rng: np.random.Generator) -> FloatArray:
        """About ``count`` tool rotations ``(M, 3, 3)`` that satisfy the rule, spread over it:
        with no rule every rotation (approach directions on a Fibonacci sphere, each with
        turns about it); with a cone, directions inside the cone; with a pose, rotations within
        the angle of it (and the pose itself first)."""
        if count < 1:
            raise InvalidInputError("rotation count must be >= 1")
        o = self.orientation
        if isinstance(o, PoseOrientation):
            out = [o.R_world_tool]
            if o.tolerance_rad > 0 and count > 1:
                axes = _fibonacci(count - 1)
                angles = o.tolerance_rad * np.cbrt(rng.uniform(0.0, 1.0, count - 1))
                out += [
                    o.R_world_tool @ _rodrigues(a, t) for a, t in zip(axes, angles, strict=True)
                ]
            return np.array(out)
        rolls = max(round(float(np.sqrt(count / 16.0))), 1)
        n_dirs = max(count // rolls, 1)
        if isinstance(o, AxisCone):
            dirs = _cone_directions(o.direction, o.tolerance_rad, n_dirs)
            axis_tool = o.axis_tool
        else:
            dirs = _fibonacci(n_dirs)
            axis_tool = np.array([0.0, 0.0, 1.0])
        out = []
        phase = rng.uniform(0.0, 2 * np.pi)
        for k in range(rolls):
            turn = _rodrigues(axis_tool, phase + 2 * np.pi * k / rolls)
            for d in dirs:
                out.append(_taking(axis_tool, d) @ turn)
        return np.array(out)

    def describe(self) -> dict[str, object]:
        return {
            "position": self.position.tolist(),
            "orientation": None if self.orientation is None else self.orientation.describe(),
        }


def _fibonacci(n: int) -> FloatArray:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    a = i * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(a), r * np.sin(a), z], axis=-1)


def _cone_directions(direction: FloatArray, half_angle: float, n: int) -> FloatArray:
    """``n`` unit vectors spread over the cap within ``half_angle`` of ``direction`` (the
    direction itself first)."""
    if n <= 1 or half_angle <= 0:
        return direction[None].copy()
    i = np.arange(n - 1) + 0.5
    cos = 1.0 - (1.0 - np.cos(half_angle)) * i / (n - 1)  # equal areas on the cap
    sin = np.sqrt(np.maximum(1.0 - cos * cos, 0.0))
    a = i * np.pi * (3.0 - np.sqrt(5.0))
    local = np.stack([sin * np.cos(a), sin * np.sin(a), cos], axis=-1)
    R = _taking(np.array([0.0, 0.0, 1.0]), direction)
    return np.vstack([direction[None], local @ R.T])


def _rodrigues(axis: FloatArray, angle: float) -> FloatArray:
    k = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.asarray(np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K))


def _taking(a: FloatArray, b: FloatArray) -> FloatArray:
    """A rotation that takes unit vector ``a`` to unit vector ``b``."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    v = np.cross(a, b)
    c = float(a @ b)
    s = float(np.linalg.norm(v))
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        axis = np.cross(a, helper)
        return _rodrigues(axis, np.pi)
    return _rodrigues(v / s, float(np.arctan2(s, c)))


__all__ = ["AxisCone", "Orientation", "PoseOrientation", "ToolTarget", "unit_vector"]
