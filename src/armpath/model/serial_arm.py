"""A serial arm as a chain of joints, each with a fixed origin, an axis and limits.

The description is URDF-like: joint ``i`` sits at the fixed transform ``T_parent_joint`` from the
frame of joint ``i - 1`` (after that joint's motion) and moves about or along ``axis``, given in its
own frame. Standard and modified D-H tables map onto this form, so later model sources slot in
without touching kinematics.

Frames are numbered ``0`` (world/base), ``1 .. n`` (joint ``i`` after its motion) and ``n + 1``
(tool). Named *landmarks* are points fixed in one frame (its origin, or an offset in it) along the
arm (for the seed arm A, B, C, D, E); *links* are straight segments between two landmarks, checked
for collision as capsules (see :mod:`armpath.model.skeleton` for how models from D-H tables and
URDF get theirs).

Angles are radians, lengths are in the model's ``length_unit``; nothing is converted silently.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import StrEnum
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import MAX_COORDINATE_MM, MAX_JOINTS
from armpath.errors import InvalidInputError, JointLimitError
from armpath.model.lattice import (
    DEFAULT_COMMAND_PERIOD_S,
    DEFAULT_MAX_TICKS,
    DEFAULT_PRISMATIC_TICK_MM,
    DEFAULT_REVOLUTE_TICK_RAD,
    MM_PER_LENGTH_UNIT,
    Lattice,
    check_command_period,
    check_steps_per_tick,
)
from armpath.poses import ORTHONORMAL_TOLERANCE

FloatArray = NDArray[np.float64]


def check_rigid(T: FloatArray, what: str) -> None:
    """Refuse a finite 4x4 ``T`` that is not a rigid transform (a rotation, then a translation),
    naming ``what``: its rotation block must be orthonormal with determinant +1 and its last
    row 0 0 0 1, each to :data:`~armpath.poses.ORTHONORMAL_TOLERANCE`. A scaling, shear or
    reflection would move every point the transform places, silently."""
    tol = ORTHONORMAL_TOLERANCE
    if np.abs(T[3] - [0.0, 0.0, 0.0, 1.0]).max() > tol:
        raise InvalidInputError(
            f"{what} is not a rigid transform: its last row must be 0 0 0 1, got "
            f"{' '.join(f'{v:g}' for v in T[3])}"
        )
    R = T[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > tol:
        raise InvalidInputError(
            f"{what} is not a rigid transform: its rotation block (the upper-left 3x3) must be "
            f"orthonormal (to {tol:g}), not scale, shear or collapse lengths"
        )
    if np.linalg.det(R) < 0:
        raise InvalidInputError(
            f"{what} is not a rigid transform: its rotation block is a reflection "
            "(determinant -1), not a rotation"
        )


def check_length(value: float, where: str, unit: str = "mm") -> float:
    """``value`` (a length in ``unit`` of a model: a link length, an offset, a translation, a
    prismatic limit), or :class:`InvalidInputError` naming ``where`` and the limit when it lies
    beyond :data:`~armpath.budget.MAX_COORDINATE_MM` (a model longer than a scene may be wide:
    its kinematics would lose every digit, or overflow)."""
    if abs(value) * MM_PER_LENGTH_UNIT[unit] > MAX_COORDINATE_MM:
        raise InvalidInputError(
            f"{where}: {value:g} {unit} is beyond the largest length a model may use "
            f"({MAX_COORDINATE_MM:g} mm, as for scenes and targets)"
        )
    return value


def _frozen(a: ArrayLike, shape: tuple[int, ...], what: str) -> FloatArray:
    arr = np.array(a, dtype=np.float64)
    if arr.shape != shape:
        raise InvalidInputError(f"{what} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InvalidInputError(f"{what} must be finite, got {arr.tolist()}")
    arr.setflags(write=False)
    return arr


class JointKind(StrEnum):
    """How a joint moves: about its axis (revolute) or along it (prismatic)."""

    REVOLUTE = "revolute"
    PRISMATIC = "prismatic"


@dataclass(frozen=True, eq=False)
class Joint:
    """One joint of a serial chain.

    Parameters
    ----------
    name:
        Human-readable name (``"theta1"``).
    T_parent_joint:
        4x4 fixed transform from the previous joint's moved frame to this joint's frame at zero.
    axis:
        Unit axis of motion in this joint's frame (normalised on construction).
    kind:
        Revolute (value in rad) or prismatic (value in the model's length unit).
    limits:
        ``(lower, upper)`` in rad or length unit; ``-inf``/``inf`` for an unlimited joint
        (a revolute joint may then turn past 360 degrees).
    tick:
        The controller's tick of this joint (rad, or length unit if prismatic); ``None``: the
        default, 0.1 deg or 0.1 mm (:mod:`armpath.model.lattice`).
    max_ticks:
        The most ticks one command may move this joint (default 20).
    steps_per_tick:
        Motor steps per tick for a stepper controller (default 1: a step is a tick).
    """

    name: str
    T_parent_joint: FloatArray
    axis: FloatArray
    kind: JointKind = JointKind.REVOLUTE
    limits: tuple[float, float] = (-np.inf, np.inf)
    tick: float | None = None
    max_ticks: int = DEFAULT_MAX_TICKS
    steps_per_tick: int = 1

    def __post_init__(self) -> None:
        T = _frozen(self.T_parent_joint, (4, 4), f"joint {self.name!r} T_parent_joint")
        check_rigid(T, f"joint {self.name!r}: T_parent_joint")
        axis = np.array(self.axis, dtype=np.float64)
        norm = float(np.linalg.norm(axis)) if axis.shape == (3,) else 0.0
        if axis.shape != (3,) or not np.isfinite(norm) or norm < 1e-12:
            raise InvalidInputError(f"joint {self.name!r}: axis must be a non-zero 3-vector")
        lo, hi = (float(v) for v in self.limits)
        if np.isnan(lo) or np.isnan(hi) or lo > hi:
            raise InvalidInputError(
                f"joint {self.name!r}: limits must satisfy lower <= upper, got ({lo}, {hi})"
            )
        object.__setattr__(self, "T_parent_joint", T)
        object.__setattr__(self, "axis", _frozen(axis / norm, (3,), "axis"))
        object.__setattr__(self, "kind", JointKind(self.kind))
        object.__setattr__(self, "limits", (lo, hi))
        if self.tick is not None and not (np.isfinite(self.tick) and self.tick > 0):
            raise InvalidInputError(f"joint {self.name!r}: tick must be > 0, got {self.tick}")
        if int(self.max_ticks) != self.max_ticks or self.max_ticks < 1:
            raise InvalidInputError(
                f"joint {self.name!r}: max ticks per command must be a whole number >= 1, got "
                f"{self.max_ticks}"
            )
        object.__setattr__(self, "max_ticks", int(self.max_ticks))
        steps = check_steps_per_tick(self.steps_per_tick, 1, f"joint {self.name!r}: steps per tick")
        object.__setattr__(self, "steps_per_tick", int(steps[0]))

    def same_as(self, other: Joint, atol: float = 1e-12) -> bool:
        """Whether ``other`` has the same placement, axis, kind, limits and lattice (names
        ignored)."""
        return (
            self.kind is other.kind
            and np.allclose(self.T_parent_joint, other.T_parent_joint, atol=atol)
            and np.allclose(self.axis, other.axis, atol=atol)
            and np.allclose(self.limits, other.limits, atol=atol)
            and self._tick_or_default() == other._tick_or_default()
            and self.max_ticks == other.max_ticks
            and self.steps_per_tick == other.steps_per_tick
        )

    def _tick_or_default(self) -> float:
        if self.tick is not None:
            return float(self.tick)
        if self.kind is JointKind.PRISMATIC:
            return DEFAULT_PRISMATIC_TICK_MM
        return DEFAULT_REVOLUTE_TICK_RAD

    @property
    def is_limited(self) -> bool:
        """Whether either limit is finite."""
        return bool(np.isfinite(self.limits[0]) or np.isfinite(self.limits[1]))


@dataclass(frozen=True)
class Landmark:
    """A named point of the arm, fixed in frame ``frame`` (0 base, i joint i, n+1 tool).

    ``offset`` is the point in that frame's coordinates (length unit); the default is the
    frame's origin.
    """

    name: str
    frame: int
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        off = tuple(float(v) for v in self.offset)
        if len(off) != 3 or not all(np.isfinite(off)):
            raise InvalidInputError(f"landmark {self.name!r}: offset must be 3 finite numbers")
        object.__setattr__(self, "offset", off)


@dataclass(frozen=True)
class Link:
    """A straight link between two landmarks (indices into ``SerialArm.landmarks``), checked for
    collision as a capsule.

    ``radius`` is in the model's length unit. ``checked`` is False for a link that is part of the
    fixed base (it stands on the table and never moves), e.g. the seed arm's column AB: it is not
    checked against obstacles, only against the moving links.
    """

    name: str
    start: int
    end: int
    radius: float = 0.0
    checked: bool = True


def tool_corner(T_tool: ArrayLike, last_axis: ArrayLike, tiny: float = 1e-9) -> FloatArray | None:
    """Where a tool's capsule turns, in the last joint's frame, or None for one straight leg.

    ``T_tool`` is the tool frame in the last joint's frame; its approach axis (z) ends the
    capsule. The turn is the point of that axis nearest the joint frame's origin, kept when
    the leg to it runs square to the last joint's axis (``last_axis``: a D-H table's ``a``
    leg, an offset gripper whose axis is the joint's) or along it (an offset along the joint's
    own axis): the arm's skeleton turns there. A leg oblique to the joint's axis would turn at
    a point off the tool (a torch 150 mm out and tilted 30 deg: 76 mm off it), so such a
    tool is one straight leg from the joint frame's origin to the tool point."""
    T = np.asarray(T_tool, dtype=np.float64)
    t, u = T[:3, 3], T[:3, 2]
    corner = t - float(t @ u) * u
    size = float(np.linalg.norm(corner))
    if size <= tiny or abs(float(t @ u)) <= tiny:
        return None  # one leg either way: straight along the axis, or square to it
    a = np.asarray(last_axis, dtype=np.float64)
    cos = abs(float(corner @ a)) / (size * max(float(np.linalg.norm(a)), tiny))
    return corner if cos <= _SQUARE or cos >= 1.0 - _SQUARE else None


#: How near square to (or along) the last joint's axis a tool's first leg must run for the
#: skeleton to turn at its corner (:func:`tool_corner`; cosine, about 0.06 deg).
_SQUARE = 1e-6


def check_arm(arm: object) -> None:
    """Refuse anything but a :class:`SerialArm` where the modules below the API take one (a
    model's name raised an AttributeError from deep inside)."""
    if not isinstance(arm, SerialArm):
        raise InvalidInputError(
            f"arm must be a SerialArm (armpath.load_arm({arm!r}) gives one), got {arm!r}"
        )


#: Farthest a revolute joint's limit may lie from zero (rad): two turns either way. Farther is
#: a unit slip (degrees read as radians: 185 "rad" is 10,600 deg); an unlimited side is null.
MAX_REVOLUTE_LIMIT_RAD = 4.0 * np.pi


def check_turns(
    limits_rad: tuple[float, float], where: str, unit: str = "rad", hint: str | None = None
) -> None:
    """Refuse revolute ``limits_rad`` with a finite side more than :data:`MAX_REVOLUTE_LIMIT_RAD`
    from zero, naming ``where``, the value in ``unit`` (``"rad"`` or ``"deg"``) and ``hint``
    (what to check; by default, for radians, whether degrees were written)."""
    for v in limits_rad:
        if np.isfinite(v) and abs(v) > MAX_REVOLUTE_LIMIT_RAD:
            shown = np.degrees(v) if unit == "deg" else v
            if hint is None:
                hint = (
                    "were the limits written in degrees?"
                    if unit == "rad"
                    else "leave a side out (null) for an unlimited joint"
                )
            raise InvalidInputError(
                f"{where}: {shown:g} {unit} is more than two turns (720 deg) from zero; {hint}"
            )


def _ticks_within(
    lower: ArrayLike, upper: ArrayLike, tick: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """Per joint, the lowest and highest whole number of ``tick`` within ``[lower, upper]``
    (``-inf`` / ``inf`` on an unlimited side; a limit within 1e-9 of a tick is that tick)."""
    lo, hi, t = (np.asarray(v, dtype=np.float64) for v in (lower, upper, tick))
    low = np.where(np.isfinite(lo), np.ceil(lo / t - 1e-9), -np.inf)
    high = np.where(np.isfinite(hi), np.floor(hi / t + 1e-9), np.inf)
    return low, high


def nearest_on_lattice(joints: Sequence[Joint], q: ArrayLike) -> FloatArray:
    """Joint values ``q`` (rad / length unit, one per joint) moved onto each joint's lattice,
    the nearest whole tick within its limits; a joint whose limits hold no whole tick keeps
    the value moved into them."""
    lower = np.array([j.limits[0] for j in joints])
    upper = np.array([j.limits[1] for j in joints])
    tick = np.array([j._tick_or_default() for j in joints])
    low, high = _ticks_within(lower, upper, tick)
    inside = np.clip(np.asarray(q, dtype=np.float64), lower, upper)
    on = np.clip(np.round(inside / tick), low, high) * tick
    return np.asarray(np.where(low > high, inside, on), dtype=np.float64) + 0.0  # no -0.0


def default_home(joints: Sequence[Joint]) -> FloatArray:
    """The home pose of a model that gives none (rad / length unit): zero moved into each
    joint's limits and onto its lattice, the nearest whole tick within them (a URDF's limit
    of -3.99925 deg, Franka's fourth joint, gave a home off the 0.1 deg lattice that no task
    could start from). A joint whose limits hold no whole tick keeps the limit nearest zero."""
    return nearest_on_lattice(joints, np.zeros(len(joints)))


@dataclass(frozen=True, eq=False, repr=False)
class SerialArm:
    """An immutable serial arm model.

    Parameters
    ----------
    name:
        Model name used in results.
    joints:
        The chain, base to tip.
    T_flange_tool:
        4x4 transform from the last joint frame to the tool frame (the fingertip for the seed
        arm), through the flange (:attr:`T_joint_flange`).
    landmarks:
        Named frame origins along the arm, base to tip.
    links:
        Links between landmarks (indices into ``landmarks``) with their capsule radii.
    home:
        Initial joint state, rad (or length unit for prismatic joints).
    length_unit:
        Unit of every length of the model (``"mm"`` or ``"m"``).
    T_world_base:
        4x4 placement of the base in the world.
    parameters:
        Model-specific numbers for results and reports (for the seed arm: link lengths in mm).
    """

    name: str
    joints: tuple[Joint, ...]
    T_flange_tool: FloatArray
    landmarks: tuple[Landmark, ...]
    links: tuple[Link, ...]
    home: FloatArray
    length_unit: str = "mm"
    T_world_base: FloatArray = field(default_factory=lambda: np.eye(4))
    parameters: tuple[tuple[str, float], ...] = ()
    #: The tool's approach axis in the tool frame (where a torch or gripper points): z unless
    #: the tool frame says otherwise (ur_description's ``ee_link`` points along x).
    approach_axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    #: The time one command takes on the arm's controller (s): the clock of timed exports.
    command_period_s: float = DEFAULT_COMMAND_PERIOD_S
    #: From the last joint frame to the flange, the frame a tool is given from
    #: (:meth:`with_tool`): a standard D-H table's last ``a`` and ``alpha``, a URDF's fixed
    #: joints up to its tip link; the identity where the last joint frame is the flange.
    T_joint_flange: FloatArray = field(default_factory=lambda: np.eye(4))

    def __repr__(self) -> str:
        kinds = "".join("P" if j.kind == JointKind.PRISMATIC else "R" for j in self.joints)
        joints = "1 joint" if self.n_joints == 1 else f"{self.n_joints} joints"
        return f"SerialArm({self.name!r}, {joints} {kinds}, {self.length_unit})"

    def __post_init__(self) -> None:
        n = len(self.joints)
        if n == 0:
            raise InvalidInputError("a serial arm needs at least one joint")
        if n > MAX_JOINTS:  # memory and time grow with the joints (300 joints: 2.7 GB a plan)
            raise InvalidInputError(f"a serial arm may have at most {MAX_JOINTS} joints, got {n}")
        object.__setattr__(self, "T_flange_tool", _frozen(self.T_flange_tool, (4, 4), "tool"))
        check_rigid(self.T_flange_tool, "tool (T_flange_tool)")
        object.__setattr__(self, "T_joint_flange", _frozen(self.T_joint_flange, (4, 4), "flange"))
        check_rigid(self.T_joint_flange, "flange (T_joint_flange)")
        object.__setattr__(self, "T_world_base", _frozen(self.T_world_base, (4, 4), "base"))
        check_rigid(self.T_world_base, "base (T_world_base)")
        object.__setattr__(self, "home", _frozen(self.home, (n,), "home"))
        for lm in self.landmarks:
            if not 0 <= lm.frame <= n + 1:
                raise InvalidInputError(f"landmark {lm.name!r}: frame must be in [0, {n + 1}]")
        for link in self.links:
            if not (0 <= link.start < len(self.landmarks) and 0 <= link.end < len(self.landmarks)):
                raise InvalidInputError(f"link {link.name!r}: landmark index out of range")
            if not (np.isfinite(link.radius) and link.radius >= 0):
                raise InvalidInputError(f"link {link.name!r}: radius must be >= 0")
        a = np.asarray(self.approach_axis, dtype=np.float64)
        if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) < 1e-12:
            raise InvalidInputError("the tool's approach axis must be a non-zero 3-vector")
        object.__setattr__(self, "approach_axis", tuple(float(v) for v in a / np.linalg.norm(a)))
        if self.length_unit not in ("mm", "m"):
            raise InvalidInputError(f"length_unit must be 'mm' or 'm', got {self.length_unit!r}")
        object.__setattr__(self, "command_period_s", check_command_period(self.command_period_s))
        self.check_limits(self.home, what="home pose")

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def mm_per_unit(self) -> float:
        """Millimetres per length unit of the model (1, or 1000 for metres)."""
        return MM_PER_LENGTH_UNIT[self.length_unit]

    @cached_property
    def lattice(self) -> Lattice:
        """The controller's command lattice: each joint's tick (its own, or 0.1 deg / 0.1 mm)
        and the most ticks a command may move it."""
        mm = 1.0 / self.mm_per_unit  # model units per mm
        ticks = [
            j.tick
            if j.tick is not None
            else (
                DEFAULT_PRISMATIC_TICK_MM * mm
                if j.kind is JointKind.PRISMATIC
                else DEFAULT_REVOLUTE_TICK_RAD
            )
            for j in self.joints
        ]
        return Lattice(
            np.array(ticks),
            np.array([j.max_ticks for j in self.joints]),
            np.array([j.kind is JointKind.PRISMATIC for j in self.joints]),
            self.length_unit,
            np.array([j.steps_per_tick for j in self.joints]),
            self.command_period_s,
        )

    def placed(self, T_world_cell_base: ArrayLike) -> SerialArm:
        """The arm standing at ``T_world_cell_base`` in a cell (its own base transform applied
        after it): where a scene puts the arm."""
        T = _frozen(T_world_cell_base, (4, 4), "base placement")
        check_rigid(T, "base placement")
        T_world_base = T @ self.T_world_base
        for v in T_world_base[:3, 3]:  # each within the limit alone, not always together
            check_length(v, "the arm's base (its placement after its own base)", self.length_unit)
        return replace(self, T_world_base=T_world_base)

    def with_tool(
        self,
        T_flange_tool: ArrayLike,
        radius: float | None = None,
        approach_axis: ArrayLike | None = None,
    ) -> SerialArm:
        """The arm carrying another tool: ``T_flange_tool`` from the flange
        (:attr:`T_joint_flange`) to the tool centre point, in place of the tool it carried.
        Landmarks in the tool frame (and the corner the old tool's leg turned at) are replaced
        by one at the new tool point (``TCP``), and links that ended at them end there (the
        tool's own capsule, turned at its :func:`tool_corner` as a robot file's tool is;
        ``radius`` replaces their radius when given). ``approach_axis`` (tool frame) is where
        the tool points (kept when not given)."""
        T = _frozen(T_flange_tool, (4, 4), "tool")
        check_rigid(T, "tool")
        T = _frozen(np.asarray(self.T_joint_flange) @ T, (4, 4), "tool")
        for v in T[:3, 3]:
            check_length(v, "the tool (after the flange)", self.length_unit)
        n = self.n_joints
        tool_frame = n + 1
        # the old tool's points, and the corner its leg turned at (named after the tool point,
        # in the last joint's frame): a new tool is not reached through the old one's corner
        tool_names = {f"{lm.name}'" for lm in self.landmarks if lm.frame == tool_frame}
        old = [
            i
            for i, lm in enumerate(self.landmarks)
            if lm.frame == tool_frame or (lm.frame == n and lm.name in tool_names)
        ]
        keep = [i for i in range(len(self.landmarks)) if i not in old]
        landmarks = [self.landmarks[i] for i in keep] + [Landmark("TCP", tool_frame)]
        index = {old_i: new_i for new_i, old_i in enumerate(keep)}
        tcp = len(landmarks) - 1
        links = []
        for link in self.links:
            start = tcp if link.start in old else index[link.start]
            end = tcp if link.end in old else index[link.end]
            if start == end:
                continue
            touches_tool = link.start in old or link.end in old
            r = radius if (touches_tool and radius is not None) else link.radius
            links.append(replace(link, start=start, end=end, radius=r))
        if not any(tcp in (lk.start, lk.end) for lk in links) and keep:
            # the tool point was not on any link: join it to the last point of the arm
            last = max(range(len(keep)), key=lambda i: landmarks[i].frame)
            links.append(Link("tool", last, tcp, 0.0 if radius is None else radius))
        links = self._tool_legs(links, landmarks, tcp, T)
        axis = self.approach_axis if approach_axis is None else tuple(np.asarray(approach_axis))
        return replace(
            self,
            T_flange_tool=T,
            landmarks=tuple(landmarks),
            links=tuple(links),
            approach_axis=axis,
        )

    def _tool_legs(
        self, links: list[Link], landmarks: list[Landmark], tcp: int, T_tool: FloatArray
    ) -> list[Link]:
        """The new tool's leg into the tool point ``tcp`` turned at its :func:`tool_corner`
        where it has one (a corner landmark added to ``landmarks``), as a robot file's tool
        is; the leg is named ``L{k}`` alone, ``L{k}a`` and ``L{k}b`` when it turns."""
        into = [i for i, lk in enumerate(links) if lk.end == tcp and lk.start != tcp]
        if len(into) != 1 or self.n_joints == 0:
            return links
        leg = links[into[0]]
        base = leg.name[:-1] if leg.name[-1:] in ("a", "b") and leg.name[:-1] else leg.name
        if any(lk.name in (f"{base}a", f"{base}b") for k, lk in enumerate(links) if k != into[0]):
            return links  # the joint's own corner already splits this link: keep its names
        corner = tool_corner(T_tool, self.joints[-1].axis)
        if corner is None:
            return [*links[: into[0]], replace(leg, name=base), *links[into[0] + 1 :]]
        offset = (float(corner[0]), float(corner[1]), float(corner[2]))
        landmarks.append(Landmark(f"{landmarks[tcp].name}'", self.n_joints, offset))
        turn = len(landmarks) - 1
        first = replace(leg, name=f"{base}a", end=turn)
        second = replace(leg, name=f"{base}b", start=turn)
        return [*links[: into[0]], first, second, *links[into[0] + 1 :]]

    def link_bodies(self) -> list[int]:
        """For each link, the body it belongs to: 0 for the fixed base (unchecked links), else
        the last joint of the chain before it. A landmark at the origin of frame k comes after
        joint k - 1 (joint k turns about that point), one offset in frame k after joint k."""

        def after(lm: Landmark) -> int:
            moved = lm.frame if any(lm.offset) else lm.frame - 1
            return min(max(moved, 0), self.n_joints)

        return [
            max(after(self.landmarks[lk.start]), after(self.landmarks[lk.end])) if lk.checked else 0
            for lk in self.links
        ]

    def with_link_radii(self, radii: float | Sequence[float] | Mapping[str, float]) -> SerialArm:
        """The same arm with other capsule radii (length unit): one number for every link,
        ``n + 1`` numbers (the fixed base, then the body each joint moves: see
        :meth:`link_bodies`), or a mapping from link names to radii."""
        n = self.n_joints
        if isinstance(radii, Mapping):
            unknown = set(radii) - {lk.name for lk in self.links}
            if unknown:
                names = ", ".join(lk.name for lk in self.links)
                raise InvalidInputError(
                    f"link radii name unknown links {sorted(unknown)} (links: {names})"
                )
            values = [float(radii.get(lk.name, lk.radius)) for lk in self.links]
        else:
            arr = np.asarray(radii, dtype=np.float64)
            if arr.ndim == 0:
                values = [float(arr)] * len(self.links)
            elif arr.shape == (n + 1,):
                values = [float(arr[b]) for b in self.link_bodies()]
            else:
                raise InvalidInputError(
                    f"link radii must be one number or {n + 1} (the fixed base, then the body "
                    f"each of the {n} joints moves), got {arr.size}"
                )
        if not all(np.isfinite(v) and v >= 0 for v in values):
            raise InvalidInputError(f"link radii must be finite and >= 0, got {values}")
        links = tuple(replace(lk, radius=v) for lk, v in zip(self.links, values, strict=True))
        # a model described by parameters (the seed arm's link_radius_mm) says the new radius
        # when it is one for every link, and no longer claims one otherwise
        parameters = tuple(
            (k, values[0]) if k == "link_radius_mm" else (k, v)
            for k, v in self.parameters
            if k != "link_radius_mm" or len(set(values)) == 1
        )
        return replace(self, links=links, parameters=parameters)

    def in_mm(self) -> SerialArm:
        """The same arm with every length in millimetres (the arm itself when it already is):
        placements, landmark offsets, capsule radii, and a prismatic joint's limits, tick and
        home value scaled. Where an arm enters a task (a model file, an arm given to
        :mod:`armpath.api`) it is taken in mm, the unit of every target, tolerance and
        obstacle."""
        k = self.mm_per_unit
        if k == 1.0:
            return self

        def moved(T: FloatArray) -> FloatArray:
            out = np.array(T, dtype=np.float64)
            out[:3, 3] *= k
            return out

        joints = []
        for j in self.joints:
            if j.kind is JointKind.PRISMATIC:
                j = replace(
                    j,
                    limits=(j.limits[0] * k, j.limits[1] * k),
                    tick=None if j.tick is None else j.tick * k,
                )
            joints.append(replace(j, T_parent_joint=moved(j.T_parent_joint)))
        return replace(
            self,
            joints=tuple(joints),
            T_flange_tool=moved(self.T_flange_tool),
            T_joint_flange=moved(self.T_joint_flange),
            T_world_base=moved(self.T_world_base),
            landmarks=tuple(
                replace(lm, offset=(lm.offset[0] * k, lm.offset[1] * k, lm.offset[2] * k))
                for lm in self.landmarks
            ),
            links=tuple(replace(lk, radius=lk.radius * k) for lk in self.links),
            home=np.where(self.lattice.prismatic, self.home * k, self.home),
            length_unit="mm",
        )

    def with_home(self, home: ArrayLike) -> SerialArm:
        """The same arm with another home pose (rad / length unit), checked against the
        limits."""
        return replace(self, home=_frozen(home, (self.n_joints,), "home"))

    def with_lattice(
        self,
        tick: ArrayLike | None = None,
        max_ticks: ArrayLike | None = None,
        steps_per_tick: ArrayLike | None = None,
        command_period_s: float | None = None,
    ) -> SerialArm:
        """The same arm with other ticks (per joint, rad or length unit; ``None`` keeps them),
        command limits (ticks per command), motor steps per tick and command period (s)."""
        n = self.n_joints
        old = self.lattice
        t = old.tick if tick is None else np.broadcast_to(np.asarray(tick, float), (n,))
        m = old.max_ticks if max_ticks is None else np.broadcast_to(np.asarray(max_ticks), (n,))
        steps = (
            old.steps_per_tick
            if steps_per_tick is None
            else check_steps_per_tick(steps_per_tick, n)
        )
        period = old.command_period_s if command_period_s is None else command_period_s
        new = Lattice(t, m, old.prismatic, self.length_unit, steps, period)  # validates
        assert new.steps_per_tick is not None
        joints = tuple(
            replace(
                j,
                tick=float(t[i]),
                max_ticks=int(m[i]),
                steps_per_tick=int(new.steps_per_tick[i]),
            )
            for i, j in enumerate(self.joints)
        )
        return replace(self, joints=joints, command_period_s=new.command_period_s)

    @property
    def lower(self) -> FloatArray:
        """Lower joint limits (rad / length unit), ``-inf`` where unlimited."""
        return np.array([j.limits[0] for j in self.joints])

    @property
    def upper(self) -> FloatArray:
        """Upper joint limits (rad / length unit), ``inf`` where unlimited."""
        return np.array([j.limits[1] for j in self.joints])

    @property
    def tick_limits(self) -> tuple[FloatArray, FloatArray]:
        """The lowest and highest lattice tick of each joint within its limits (whole numbers
        as floats; ``-inf`` / ``inf`` where unlimited)."""
        tick = np.asarray(self.lattice.tick, dtype=np.float64)
        with np.errstate(invalid="ignore"):
            lowest = np.where(np.isfinite(self.lower), np.ceil(self.lower / tick - 1e-9), -np.inf)
            highest = np.where(np.isfinite(self.upper), np.floor(self.upper / tick + 1e-9), np.inf)
        return lowest, highest

    @property
    def size(self) -> float:
        """A length of the arm's order (length unit): the sum of its fixed offsets (each
        joint's from the one before, the tool's from the flange), at least 1."""
        offsets = [float(np.linalg.norm(j.T_parent_joint[:3, 3])) for j in self.joints]
        offsets.append(float(np.linalg.norm(self.T_flange_tool[:3, 3])))
        return max(float(sum(offsets)), 1.0)

    def sampling_box(self) -> tuple[FloatArray, FloatArray]:
        """The box random configurations are drawn from, ``(lower, upper)`` (rad / length
        unit): each joint's limits, an unlimited side of a revolute joint at -pi or pi (with
        the other, every pose of the joint), of a prismatic joint at -:attr:`size` or
        :attr:`size`."""
        prismatic = np.array([j.kind is JointKind.PRISMATIC for j in self.joints])
        span = np.where(prismatic, self.size, np.pi)
        lower, upper = self.lower, self.upper
        return (
            np.where(np.isfinite(lower), lower, -span),
            np.where(np.isfinite(upper), upper, span),
        )

    def limits_in_ticks(self) -> tuple[FloatArray, FloatArray]:
        """Per joint, the lowest and highest lattice value within its limits (ticks, whole
        numbers; ``-inf`` / ``inf`` on an unlimited side). A limit within 1e-9 of a tick is
        that tick."""
        return _ticks_within(self.lower, self.upper, self.lattice.tick)

    @property
    def landmark_names(self) -> tuple[str, ...]:
        return tuple(lm.name for lm in self.landmarks)

    def within_limits(self, q: ArrayLike, tol: float = 1e-9) -> NDArray[np.bool_]:
        """Per configuration, whether every joint is within its limits (``(...)`` bool)."""
        q = np.asarray(q, dtype=np.float64)
        return np.asarray(np.all((q >= self.lower - tol) & (q <= self.upper + tol), axis=-1))

    def check_limits(self, q: ArrayLike, what: str = "joint state", tol: float = 1e-9) -> None:
        """Raise :class:`JointLimitError` naming the first joint outside its limits."""
        qa = np.asarray(q, dtype=np.float64).reshape(-1, self.n_joints)
        for i, joint in enumerate(self.joints):
            lo, hi = joint.limits
            bad = (qa[:, i] < lo - tol) | (qa[:, i] > hi + tol)
            if np.any(bad):
                value = float(qa[np.argmax(bad), i])
                if joint.kind is JointKind.REVOLUTE:
                    raise JointLimitError(
                        f"{what}: joint {i + 1} ({joint.name}) = {np.degrees(value):.4g} deg is "
                        f"outside its limits [{np.degrees(lo):.4g}, {np.degrees(hi):.4g}] deg"
                    )
                raise JointLimitError(
                    f"{what}: joint {i + 1} ({joint.name}) = {value:.4g} {self.length_unit} is "
                    f"outside its limits [{lo:.4g}, {hi:.4g}] {self.length_unit}"
                )
