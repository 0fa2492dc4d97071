"""The solution family of the tool point on a curve: the configurations that put it on the
curve at arc length ``s``, for one arm and scene.

A point of the curve is *reachable* when some configuration puts the tool point exactly on it
with every joint within its limits and the clearance rule kept (links keep the margin from every
obstacle and each other; the tool tip may touch but not penetrate). For a curve that lies on an
obstacle's surface (the *surface*, e.g. the weld seam on the workpiece) the tool must come from
outside: only tool directions (the tool frame's approach axis, from the flange to the tool
point) with ``direction . n <= 0`` (``n`` the outward normal) are searched, and a rule for the
tool axis (within a cone about the surface normal, or a fixed direction) narrows them further.

The family is searched over tool directions: :class:`SeedCurveFamily` by the seed arm's closed
form (the wrist point on a sphere around the point, four geometric branches), polished by a
batched pattern search over the tool direction; :class:`GenericCurveFamily` for any other arm
by the all-solutions IK of each tool direction with turns about it (six joints),
Levenberg-Marquardt from warm starts (five or seven joints and more; an arm on a linear
track also with its carriage where :mod:`armpath.planning.trace.carriage` schedules it along
the curve), or, where fewer than
five joints move the tool point (a SCARA, whose tool points down; a five-joint arm whose last
joint rolls the tool) or five whose family the tool directions do not chart (the tool's axis
barely turns along one of its dimensions), the point alone, each solution counted for the
searched direction nearest its own, if one lies within the scan's spacing of it.

A family member's *score* is its smallest slack: a pair's clearance less what it needs (mm) or a
joint's distance to its limit (deg, counted 1:1 with mm -- only the sign decides).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.errors import InvalidInputError
from armpath.geometry.curves import Curve
from armpath.geometry.primitives import Obstacle, orthonormal_frame
from armpath.geometry.world import CollisionWorld, SlackGroup
from armpath.ik.compiled import CompiledSolver
from armpath.ik.family import GenericFamily, shift_into_limits
from armpath.ik.seed_position import family_from_wrist
from armpath.ik.solve import complete_solver
from armpath.ik.target import DEFAULT_AXIS_TOLERANCE_DEG, ToolTarget, unit_vector
from armpath.kinematics import (
    landmark_positions,
    last_axis_across_approach,
    self_motion_axis_rates,
    tool_point_joints,
    tool_pose,
)
from armpath.model.seed_arm import SeedArmGeometry, seed_geometry_of
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.planning.trace.carriage import CarriageSchedule, carriage_joint, carriage_schedule

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Most waves in which a new lineage of an arm's self-motion starts from the member of the
#: nearest frame solved (:attr:`GenericCurveFamily._anchored`); each must solve a frame more. A
#: KUKA iiwa at one point, 600 tool directions: 85 solved from its home, 385 after seven waves.
_MAX_WAVES = 12
#: A tool point this close to the surface (or inside by at most this much) touches it (mm).
TOUCH_MM = 1e-6
#: Tool directions this far past tangent to the surface are still searched (cosine).
_PAST_TANGENT = 0.02
#: Branches of :func:`family_from_wrist` that differ geometrically (wrist flip dropped).
_BRANCHES = (0, 2, 4, 6)
#: The polish of the seed family (:meth:`SeedCurveFamily._polish`): the best grid members it
#: starts from, the neighbours it scores each round, its first step and the step it stops
#: below (rad, about 2.3 deg: the fine grid's spacing; about 0.006 deg), and its most rounds.
_POLISH_STARTS = 3
_POLISH_DIRECTIONS = 8
_POLISH_STEP = 0.04
_POLISH_TOLERANCE = 1e-4
_POLISH_ROUNDS = 120
_POLISH_GROW = 1.25
_POLISH_SHRINK = 0.6
_GOLDEN = np.pi * (3.0 - np.sqrt(5.0))
#: Farthest a solution's tool direction may lie from a searched one it is counted for, when
#: the point alone is solved (:attr:`GenericCurveFamily._point_alone`): the spacing of the
#: scan's 600 directions (rad, about 8.3 deg).
_POINT_ALONE_SPACING = float(np.sqrt(4.0 * np.pi / 600))
#: Slowest turn of the tool's axis along a five-joint family (rad per rad of the joints) for
#: which the tool directions chart it (:attr:`GenericCurveFamily._directions_chart`): the
#: scan's directions, about 8 deg apart, then solve members at most about 80 deg apart along
#: it; and the configurations the rate is judged at.
_CHART_MIN_TURN_RATE = 0.1
_CHART_CONFIGS = 64
#: How many scores of a grid :meth:`CurveFamily.best` needs exactly (the polish's starts), and
#: how many configurations of most joint-limit slack it scores first to find a floor for them.
_EXACT_TOP = _POLISH_STARTS
_FIRST_SCORED = 64
#: Just below the tool tip's threshold: the floor that keeps the tip's verdict exact.
_BELOW_TOUCH = float(np.nextafter(-TOUCH_MM, -np.inf))


def fibonacci_directions(count: int) -> FloatArray:
    """``count`` nearly uniform unit vectors ``(count, 3)`` (Fibonacci sphere)."""
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    phi = np.pi * (1.0 + np.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


@dataclass(frozen=True)
class Verdict:
    """The best configuration the family search found for one curve point.

    ``score`` is the smallest slack there (>= 0: reachable); ``q`` joints (rad) or NaN when the
    point has no real solution; ``limiting`` names the constraints at the smallest slack (see
    :meth:`CurveFamily.limiting`).
    """

    s_mm: float
    score: float
    q: FloatArray
    limiting: tuple[str, ...]

    @property
    def reachable(self) -> bool:
        return bool(self.score >= 0.0)

    @property
    def out_of_reach(self) -> bool:
        """No configuration at all puts the tool point there."""
        return not bool(np.all(np.isfinite(self.q)))


@dataclass(frozen=True)
class AxisRule:
    """Where the tool's approach axis may point while it is on the curve: within
    ``tolerance_rad`` of the surface's inward normal (``normal=True``: a torch kept near the
    normal), or of a fixed world ``direction``."""

    tolerance_rad: float
    normal: bool = True
    direction: FloatArray | None = None

    @classmethod
    def of(
        cls,
        tool_axis: str | ArrayLike,
        tolerance_deg: float | None = None,
        names: tuple[str, str] = ("tool_axis", "axis_tolerance_deg"),
    ) -> AxisRule:
        """The rule of ``tool_axis``, ``"normal"`` or a world direction (any length), within
        ``tolerance_deg`` (in (0, 180]; None: :data:`DEFAULT_AXIS_TOLERANCE_DEG`), refused in
        the words of ``names`` (the arguments or options that gave them)."""
        tol = DEFAULT_AXIS_TOLERANCE_DEG if tolerance_deg is None else tolerance_deg
        if not (isinstance(tol, int | float | np.number) and 0.0 < tol <= 180.0):
            raise InvalidInputError(f"{names[1]} must be in (0, 180] deg, got {tol}")
        tol_rad = float(np.radians(tol))
        if isinstance(tool_axis, str):
            if tool_axis.strip() != "normal":
                raise InvalidInputError(
                    f"{names[0]} must be 'normal' or a direction X Y Z, got {tool_axis!r}"
                )
            return cls(tol_rad)
        return cls(tol_rad, normal=False, direction=unit_vector(tool_axis, names[0]))

    def words(self) -> str:
        """The rule in words: 'within 10 deg of the surface normal'."""
        if self.normal or self.direction is None:
            about = "the surface normal"
        else:
            about = "(" + ", ".join(f"{v:.3g}" for v in self.direction) + ")"
        return f"within {np.degrees(self.tolerance_rad):g} deg of {about}"

    def describe(self) -> dict[str, object]:
        return {
            "type": "normal" if self.normal else "direction",
            "direction": None if self.direction is None else np.asarray(self.direction).tolist(),
            "tolerance_deg": float(np.degrees(self.tolerance_rad)),
        }


@dataclass
class CurveFamily:
    """The solution family of the tool point on a curve (the machinery every arm shares).

    ``surface`` is the obstacle the curve lies on (found automatically: the one whose surface is
    within 1e-6 mm of every sampled curve point), or None for a curve in free space. ``rule``
    narrows the tool directions (:class:`AxisRule`).
    """

    arm: SerialArm
    world: CollisionWorld
    curve: Curve
    rule: AxisRule | None = None
    surface: Obstacle | None = field(init=False)

    def __post_init__(self) -> None:
        pts = self.curve.sample(257)
        self.surface = None
        for o in self.world.obstacles:
            if np.max(np.abs(o.signed_distance(pts))) <= 1e-6:
                self.surface = o
        if self.surface is not None:
            blocker = self.world.touch_blocker(self.arm)
            if blocker is not None:
                raise InvalidInputError(
                    f"curve {self.curve.name!r} lies on {self.surface.name}, but {blocker}"
                )
        if self.rule is not None and self.rule.normal and self.surface is None:
            raise InvalidInputError(
                f"the tool axis can follow the surface normal only on a curve that lies on an "
                f"obstacle's surface; {self.curve.name!r} lies on none"
            )
        pairs = self.world.pairs(self.arm)
        self._required = self.world.required(self.arm)
        touching = np.array(
            [p.is_tip and self.surface is not None and p.other == self.surface.name for p in pairs],
            dtype=bool,
        )
        #: per clearance pair, whether it is the tool tip and the surface the curve lies on
        #: (the one pair the tip may touch while tracing)
        self.touch_pairs: NDArray[np.bool_] = touching
        self._labels = [p.label for p in pairs]
        self._others = [p.other for p in pairs]
        self._is_self = np.array([p.is_self for p in pairs], dtype=bool)
        #: revolute joints without limits (turning by whole turns gives the same links; an
        #: unlimited prismatic joint does not repeat)
        revolute = np.array([j.kind is JointKind.REVOLUTE for j in self.arm.joints])
        self.unlimited = revolute & ~(np.isfinite(self.arm.lower) | np.isfinite(self.arm.upper))
        #: revolute joints that may turn a whole turn within their limits (the unlimited ones,
        #: and a UR5's +-360 deg): their members are the same a turn apart, so the reference
        #: follows them round (then turned by whole turns into the limits). Not a joint with
        #: its own self-collision ranges (:meth:`CollisionWorld.joint_bands`): a UR5's elbow
        #: cannot fold through its upper arm, so from 90 deg it reaches -149 deg, not 211
        #: (the way round through 180 that a whole turn would count as 121 deg)
        banded = np.zeros(self.arm.n_joints, dtype=bool)
        banded[list(self.world.joint_bands(self.arm))] = True
        with np.errstate(invalid="ignore"):
            self.turns_freely = (
                revolute & (self.arm.upper - self.arm.lower >= 2.0 * np.pi - 1e-9) & ~banded
            )
        self._lo = np.where(np.isfinite(self.arm.lower), self.arm.lower, -np.inf)
        self._hi = np.where(np.isfinite(self.arm.upper), self.arm.upper, np.inf)
        #: joint values to the units slack is read in: deg for a revolute joint, mm (model
        #: units) for a prismatic one
        self._to_slack_units = np.where(revolute, 180.0 / np.pi, 1.0)

    # -- what differs between arms ------------------------------------------------------------
    @cached_property
    def tip_joints(self) -> BoolArray:
        """Joints that move the tool point (the others turn the tool about it)."""
        from armpath.planning.motion import active_joints

        return tool_point_joints(self.arm) & active_joints(self.arm)

    def configs_at(self, E: FloatArray, dirs: FloatArray) -> FloatArray:
        """Family members ``(M, n)`` with the tool point at ``E`` and the tool pointing along
        ``dirs`` (every solution; members without a real solution dropped)."""
        raise NotImplementedError

    @property
    def turns_per_direction(self) -> int:
        """Tool frames sampled about each tool direction (1: the turn moves no link)."""
        return 1

    @property
    def directions_span(self) -> bool:
        """Whether the tool directions (and the turns sampled about each) span the family's
        dimensions, so that the members found are taken to cover it (see
        :attr:`unspanned_because`)."""
        return not self.unspanned_because

    @property
    def unspanned_because(self) -> str:
        """Why the tool directions do not span the family, in words ("" where they do): the
        joints that move the tool point beyond its three are more than a direction (two) and
        a turn about it (one, where several turns are sampled). A redundant arm's self-motion
        is not spanned: one member of it is found per tool frame, so a point where none found
        is clear may still have clear members."""
        extra = int(np.count_nonzero(self.tip_joints)) - 3
        if extra <= 2 + (1 if self.turns_per_direction > 1 else 0):
            return ""
        return "one member of the arm's self-motion is found per tool frame"

    def members(self, E: FloatArray, dirs: FloatArray) -> tuple[FloatArray, NDArray[np.int64]]:
        """Every family member ``(M, n)`` rad with the tool point at ``E`` and the tool along
        ``dirs``, configurations with the same links included (the seed arm's wrist flip),
        within the joint limits, with the index into ``dirs`` of each: what the lower bounds
        (:mod:`armpath.planning.bounds`) sample the family by."""
        q, index = self.solutions(E, dirs)
        ok = self.arm.within_limits(q) if q.shape[0] else np.zeros(0, dtype=bool)
        return q[ok], index[ok]

    def solutions(self, E: FloatArray, dirs: FloatArray) -> tuple[FloatArray, NDArray[np.int64]]:
        """What :meth:`members` finds before the joint limits drop any (revolute joints turned
        into them where a whole turn allows): where :attr:`solves_completely`, every real
        solution, so a direction with fewer than its neighbour's lies past a fold where two
        branches meet and end."""
        raise NotImplementedError

    @property
    def solves_completely(self) -> bool:
        """Whether :meth:`solutions` finds every real solution (closed forms), not those some
        starts lead to."""
        return True

    def same_links(self, q: FloatArray, half_turn: float) -> FloatArray:
        """Configurations ``(..., n)`` and the others with the same links, stacked
        ``(R, ..., n)`` (``half_turn``: 180 for degrees, pi for radians). Whole turns of
        unlimited joints are handled by the caller."""
        return np.asarray(q)[None]

    def flipped(self, q_deg: FloatArray) -> FloatArray | None:
        """The configurations (deg) with the same links that a pass may choose instead (the
        seed arm's wrist flip), or None."""
        return None

    def _polish(
        self,
        s: float,
        q: FloatArray,
        sc: FloatArray,
        limits: bool,
        obstacles: tuple[str, ...] | None,
        best_q: FloatArray,
        best_sc: float,
    ) -> tuple[FloatArray, float]:
        return best_q, best_sc

    # -- geometry of the curve -------------------------------------------------------------
    def frame(self, s: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Point, unit tangent and outward normal (zero without a surface) at arc length ``s``
        (mm; brought onto the curve by :meth:`Curve.wrap`)."""
        h = 1e-3
        while True:  # wider where the curve barely moves (a parameter's plateau)
            c, before, after = self.curve.at_arc_length(np.array([s, s - h, s + h]))
            t = after - before
            norm = float(np.linalg.norm(t))
            if norm > 1e-9 or h >= self.curve.length:
                break
            h *= 10.0
        if not norm > 0:
            c, after = self.curve.at_arc_length(np.array([s, s + 1e-3]))
            if np.linalg.norm(after - c) > 0:  # it moves on, the way it came
                raise InvalidInputError(
                    f"curve {self.curve.name!r} turns back along itself at {s:.3f} mm (the "
                    "stretches before and after that point lie on one another), so its "
                    "direction there is none; give each stretch once, or as separate curves"
                )
            raise InvalidInputError(f"curve {self.curve.name!r} has no direction at {s:.3f} mm")
        t = t / norm
        if self.surface is None:
            return c, t, np.zeros(3)
        n = self.surface.outward_normal(c)
        n = n - (n @ t) * t
        return c, t, n / np.linalg.norm(n)

    @cached_property
    def coarse_dirs(self) -> FloatArray:
        """Tool directions of the scan (2000, about 4.5 deg apart)."""
        return fibonacci_directions(2000)

    @cached_property
    def fine_dirs(self) -> FloatArray:
        """Tool directions of the refined search (8000, about 2.3 deg apart)."""
        return fibonacci_directions(8000)

    def allowed_dirs(self, s: float, dirs: FloatArray) -> FloatArray:
        """The directions of ``dirs`` the tool may point along at ``s``: into the surface (or
        along it) when the curve lies on one, and within the axis rule."""
        kept = dirs[self.allowed_mask(s, dirs)]
        if kept.shape[0] == 0 and self.rule is not None:
            _, _, n = self.frame(s)
            return (-n if self.rule.normal else np.asarray(self.rule.direction, float))[None]
        return kept

    def allowed_mask(self, s: float, dirs: FloatArray) -> BoolArray:
        """Which of ``dirs`` the tool may point along at ``s`` (see :meth:`allowed_dirs`)."""
        _, _, n = self.frame(s)
        ok = np.ones(dirs.shape[0], dtype=bool)
        if self.surface is not None:
            ok &= dirs @ n <= _PAST_TANGENT
        if self.rule is not None:
            axis = -n if self.rule.normal else np.asarray(self.rule.direction, dtype=np.float64)
            ok &= dirs @ axis >= np.cos(self.rule.tolerance_rad)
        return ok

    def axis_angles(self, q: FloatArray) -> FloatArray:
        """The angle (rad) between the tool's approach axis and the rule's axis (the surface's
        inward normal at the tool point, or the rule's direction) for configurations
        ``(..., n)``; zero without a rule."""
        q = np.asarray(q, dtype=np.float64)
        if self.rule is None:
            return np.zeros(q.shape[:-1])
        T = tool_pose(self.arm, q)
        a = T[..., :3, :3] @ np.asarray(self.arm.approach_axis)
        if self.rule.normal:
            assert self.surface is not None
            axis = -self.surface.outward_normal(T[..., :3, 3])
        else:
            axis = np.broadcast_to(np.asarray(self.rule.direction, dtype=np.float64), a.shape)
        cos = np.einsum("...i,...i->...", a, axis)
        return np.asarray(np.arccos(np.clip(cos, -1.0, 1.0)))

    def axis_ok(self, q: FloatArray, margin: float = 0.0) -> BoolArray:
        """Whether each configuration keeps the tool axis within the rule (less ``margin``
        rad); everything passes without a rule."""
        if self.rule is None:
            return np.ones(np.asarray(q).shape[:-1], dtype=bool)
        return np.asarray(self.axis_angles(q) <= self.rule.tolerance_rad - margin)

    # -- the family at one point -------------------------------------------------------------
    def configs(self, s: float, dirs: FloatArray) -> FloatArray:
        """Family members ``(M, n)`` rad with the tool point on the curve at ``s`` and the tool
        along the allowed ones of ``dirs``."""
        c, _, _ = self.frame(s)
        return self.configs_at(c, self.allowed_dirs(s, dirs))

    def slacks(self, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Per configuration: joint slacks ``(M, n)`` deg (mm for a prismatic joint), pair
        slacks ``(M, K)`` mm (the tool tip against the surface excluded: NaN) and whether the
        tool tip stays out of the surface."""
        with np.errstate(invalid="ignore"):
            joint = np.minimum(self._hi - q, q - self._lo) * self._to_slack_units
        values, _ = self.world.pair_clearances(self.arm, q)
        pair = values - self._required
        tip_ok = np.all(pair[:, self.touch_pairs] >= -TOUCH_MM, axis=-1)
        pair[:, self.touch_pairs] = np.nan
        return joint, pair, tip_ok

    def score(
        self,
        q: FloatArray,
        limits: bool = True,
        obstacles: tuple[str, ...] | None = None,
        floor: FloatArray | float = -np.inf,
        ceiling: float = np.inf,
    ) -> FloatArray:
        """Smallest slack per configuration (-inf when the tool tip enters the surface).

        ``limits=False`` ignores joint limits; ``obstacles`` keeps only the pairs against those
        obstacles (None: every pair, link pairs included; ``()``: no pair). Scores above
        ``floor`` (scalar or per configuration) are exact; one at or below it may be any value
        between the true score and the floor (see :meth:`CollisionWorld.smallest_slacks`).
        Scores above ``ceiling`` are reported as ``ceiling`` (no distance beyond it is measured).
        """
        q = np.asarray(q, dtype=np.float64)
        top = np.full(q.shape[0], ceiling)
        if limits:
            with np.errstate(invalid="ignore"):
                room = np.min(
                    np.minimum(self._hi - q, q - self._lo) * self._to_slack_units, axis=-1
                )
            top = np.minimum(top, room)
        keep = self._columns(obstacles)
        groups = [SlackGroup(keep, top, floor)] if np.any(keep) else []
        if np.any(self.touch_pairs):  # the tool tip only must not enter the surface
            # (a floor just below the threshold keeps the verdict exact)
            groups.append(SlackGroup(self.touch_pairs, -TOUCH_MM, _BELOW_TOUCH))
        if not groups:
            return top
        found = self.world.smallest_slacks(self.arm, q, groups)
        out = found[0] if np.any(keep) else top
        if np.any(self.touch_pairs):
            return np.where(found[-1] >= -TOUCH_MM, out, -np.inf)
        return out

    def _best_scores(
        self, q: FloatArray, limits: bool, obstacles: tuple[str, ...] | None
    ) -> FloatArray:
        """Scores of ``q`` exact for its best :data:`_EXACT_TOP` (the others may be any value
        between their true score and the last of those): the configurations of most
        joint-limit slack are scored first, and their third best score is the floor of the
        rest, which skips the distances of configurations that cannot be among the best."""
        if q.shape[0] <= _FIRST_SCORED:
            return self.score(q, limits, obstacles)
        if limits:
            with np.errstate(invalid="ignore"):
                room = np.min(
                    np.minimum(self._hi - q, q - self._lo) * self._to_slack_units, axis=-1
                )
            first = np.argpartition(-np.nan_to_num(room, nan=-np.inf), _FIRST_SCORED)
        else:
            first = np.arange(q.shape[0])
        head, rest = first[:_FIRST_SCORED], first[_FIRST_SCORED:]
        out = np.empty(q.shape[0])
        out[head] = self.score(q[head], limits, obstacles)
        top = np.sort(out[head])[-_EXACT_TOP]
        out[rest] = self.score(q[rest], limits, obstacles, floor=np.nextafter(top, -np.inf))
        return out

    def _columns(self, obstacles: tuple[str, ...] | None) -> NDArray[np.bool_]:
        cols = ~self.touch_pairs
        if obstacles is None:
            return cols
        chosen = np.array([o in obstacles for o in self._others], dtype=bool)
        return np.asarray(cols & chosen & ~self._is_self, dtype=bool)

    def limiting(
        self,
        q: FloatArray,
        limits: bool = True,
        obstacles: tuple[str, ...] | None = None,
        within: float = 0.01,
    ) -> tuple[str, ...]:
        """Constraints within ``within`` of the smallest slack at one configuration ``(n,)``
        (among those :meth:`score` counts with the same ``limits`` and ``obstacles``)."""
        joint, pair, _ = self.slacks(q[None])
        joint = joint[0] if limits else np.full(joint.shape[1], np.inf)
        pair = np.where(self._columns(obstacles), pair[0], np.nan)
        lowest = min(float(np.min(joint)), float(np.nanmin(pair, initial=np.inf)))
        out = []
        for j in np.flatnonzero(joint <= lowest + within):
            which = "upper" if self._hi[j] - q[j] < q[j] - self._lo[j] else "lower"
            limit = self._hi[j] if which == "upper" else self._lo[j]
            value, unit = (
                (float(np.degrees(limit)), "deg")
                if self._to_slack_units[j] != 1.0
                else (limit, "mm")
            )
            out.append(f"joint {j + 1} at its {which} limit {value:g} {unit}")
        for k in np.flatnonzero(np.nan_to_num(pair, nan=np.inf) <= lowest + within):
            need = self._required[k]
            out.append(f"{self._labels[k]} clearance {pair[k] + need:.3f} mm (needs {need:g})")
        return tuple(out)

    def best(
        self,
        s: float,
        fine: bool = False,
        limits: bool = True,
        obstacles: tuple[str, ...] | None = None,
    ) -> Verdict:
        """The family member with the largest score at ``s``: grid, then (``fine``) a finer grid
        polished where the arm has a way to (the seed arm: a pattern search over the tool
        direction)."""
        dirs = self.fine_dirs if fine else self.coarse_dirs
        q = self.configs(s, dirs)
        if q.shape[0] == 0:
            return Verdict(s, -np.inf, np.full(self.arm.n_joints, np.nan), ("out of reach",))
        sc = self._best_scores(q, limits, obstacles)
        k = int(np.argmax(sc))
        best_q, best_sc = q[k], float(sc[k])
        if fine:
            best_q, best_sc = self._polish(s, q, sc, limits, obstacles, best_q, best_sc)
        lim = self.limiting(best_q, limits, obstacles) if best_sc > -np.inf else ()
        return Verdict(s, best_sc, best_q, lim)


@dataclass
class SeedCurveFamily(CurveFamily):
    """The seed arm's family in closed form: the wrist point D on the sphere of radius DE
    around the point, four geometric branches (arm side x elbow; the wrist flip gives the same
    links and the same limit slack); joint 6 turns the tool only."""

    geometry: SeedArmGeometry = field(init=False)

    def __post_init__(self) -> None:
        self.geometry = seed_geometry_of(self.arm)
        super().__post_init__()

    @cached_property
    def tip_joints(self) -> BoolArray:
        return np.array([True, True, True, True, True, False])

    def configs_at(self, E: FloatArray, dirs: FloatArray) -> FloatArray:
        wrist = E - self.geometry.de_mm * dirs
        sol = family_from_wrist(self.geometry, E, wrist)[:, _BRANCHES, :]
        q = np.concatenate([sol, np.zeros((*sol.shape[:-1], 1))], axis=-1).reshape(-1, 6)
        return q[np.all(np.isfinite(q), axis=-1)]

    def solutions(self, E: FloatArray, dirs: FloatArray) -> tuple[FloatArray, NDArray[np.int64]]:
        wrist = E - self.geometry.de_mm * dirs
        sol = family_from_wrist(self.geometry, E, wrist)  # (D, 8, 5): every branch and flip
        q = np.concatenate([sol, np.zeros((*sol.shape[:-1], 1))], axis=-1).reshape(-1, 6)
        index = np.repeat(np.arange(dirs.shape[0]), sol.shape[1])
        ok = np.all(np.isfinite(q), axis=-1)
        return q[ok], index[ok]

    def same_links(self, q: FloatArray, half_turn: float) -> FloatArray:
        """Itself, its wrist flip (joint 4 + half a turn, joint 5 negated), its arm-side flip
        (joint 1 + half a turn, joints 2 and 3 negated, joint 4 - half a turn) and both."""
        q = np.asarray(q, dtype=np.float64)
        wrist = q.copy()
        wrist[..., 3] += half_turn
        wrist[..., 4] *= -1.0
        side = q.copy()
        side[..., 0] += half_turn
        side[..., 1:3] *= -1.0
        side[..., 3] -= half_turn
        both = side.copy()
        both[..., 3] += half_turn
        both[..., 4] *= -1.0
        return np.stack([q, wrist, side, both])

    def flipped(self, q_deg: FloatArray) -> FloatArray | None:
        """The wrist flips (joint 4 in ``[-180, 180)``) of tip-joint configurations (deg)."""
        q = np.asarray(q_deg, dtype=np.float64)
        full = np.concatenate([q, np.zeros((*q.shape[:-1], 6 - q.shape[-1]))], axis=-1)
        other = self.same_links(full, 180.0)[1][..., : q.shape[-1]]
        other[..., 3] = (other[..., 3] + 180.0) % 360.0 - 180.0
        return np.asarray(other)

    def _polish(
        self,
        s: float,
        q: FloatArray,
        sc: FloatArray,
        limits: bool,
        obstacles: tuple[str, ...] | None,
        best_q: FloatArray,
        best_sc: float,
    ) -> tuple[FloatArray, float]:
        """Pattern search over the tool direction from the best few grid members, all starts
        at once: each round scores :data:`_POLISH_DIRECTIONS` neighbours of every start in
        one batch, moves a start to its best neighbour or halves its step, and ends when
        every step is below :data:`_POLISH_TOLERANCE` rad (at most :data:`_POLISH_ROUNDS`)."""
        c, _, _ = self.frame(s)
        starts = np.array([k for k in np.argsort(-sc)[:_POLISH_STARTS] if np.isfinite(sc[k])])
        if starts.size == 0:
            return best_q, best_sc
        d0 = self._wrist_dirs(q[starts], c)  # the tool direction E - D of each start
        branch = np.array([self._branch_of(q[k], c, d) for k, d in zip(starts, d0, strict=True)])
        frames = np.array([orthonormal_frame(d) for d in d0])  # (S, 2, 3) across each direction
        de = self.geometry.de_mm

        def members(x: FloatArray, which: NDArray[np.intp]) -> FloatArray:
            """Members (M, 6) of the starts ``which`` at tangent offsets ``x (M, 2)`` rad."""
            u = d0[which] + np.einsum("mk,mkj->mj", x, frames[which])
            u /= np.linalg.norm(u, axis=-1, keepdims=True)
            sol = family_from_wrist(self.geometry, c, c - de * u)
            picked = sol[np.arange(which.size), np.asarray(_BRANCHES)[branch[which]]]
            return np.concatenate([picked, np.zeros((which.size, 1))], axis=-1)

        def scores(cand: FloatArray, floor: FloatArray) -> FloatArray:
            """Scores of ``cand``, exact where above ``floor`` (a start's score so far)."""
            out = np.full(cand.shape[0], -np.inf)
            ok = np.all(np.isfinite(cand), axis=-1)
            if np.any(ok):
                out[ok] = self.score(cand[ok], limits, obstacles, floor[ok])
            return out

        every = np.arange(starts.size)
        x = np.zeros((starts.size, 2))
        at = members(x, every)
        fx = scores(at, np.full(starts.size, -np.inf))
        step = np.full(starts.size, _POLISH_STEP)
        for r in range(_POLISH_ROUNDS):
            live = np.flatnonzero(step >= _POLISH_TOLERANCE)
            if live.size == 0:
                break
            # the pattern turns by the golden angle each round, so that a ridge of the score
            # (where two slacks are equal) is soon met along it
            turn = 2.0 * np.pi * np.arange(_POLISH_DIRECTIONS) / _POLISH_DIRECTIONS + r * _GOLDEN
            pattern = np.stack([np.cos(turn), np.sin(turn)], axis=-1)
            trial = x[live, None, :] + step[live, None, None] * pattern  # (L, D, 2)
            which = np.repeat(live, _POLISH_DIRECTIONS)
            cand = members(trial.reshape(-1, 2), which)
            val = scores(cand, fx[which]).reshape(live.size, _POLISH_DIRECTIONS)
            j = np.argmax(val, axis=1)
            gain = val[np.arange(live.size), j] > fx[live]
            moved, stuck = live[gain], live[~gain]
            x[moved] = trial[gain, j[gain]]
            fx[moved] = val[gain, j[gain]]
            at[moved] = cand.reshape(live.size, _POLISH_DIRECTIONS, -1)[gain, j[gain]]
            step[moved] = np.minimum(step[moved] * _POLISH_GROW, _POLISH_STEP)
            step[stuck] *= _POLISH_SHRINK
        k = int(np.argmax(fx))
        if fx[k] > best_sc:
            return at[k], float(fx[k])
        return best_q, best_sc

    def _wrist_dirs(self, q: FloatArray, E: FloatArray) -> FloatArray:
        D = landmark_positions(self.arm, q)[:, -2, :]
        u = E - D
        return np.asarray(u / np.linalg.norm(u, axis=-1, keepdims=True), dtype=np.float64)

    def _branch_of(self, q: FloatArray, E: FloatArray, d: FloatArray) -> int:
        sols = family_from_wrist(self.geometry, E, (E - self.geometry.de_mm * d)[None])[
            0, _BRANCHES
        ]
        err = np.nan_to_num(np.abs(sols - q[:5]).max(axis=-1), nan=np.inf)
        return int(np.argmin(err))


@dataclass
class GenericCurveFamily(CurveFamily):
    """Any other arm's family: for each tool direction, the tool frames with that approach axis
    and a few turns about it, each solved by the all-solutions IK (six joints) or by
    Levenberg-Marquardt from the last solutions found (warm starts), else from the arm's start
    (more joints than a frame needs: :attr:`_anchored`) or random ones (the point alone when
    fewer than five joints move the tool point)."""

    rolls: int = 6
    #: the configuration the arm starts from (rad; model units for a prismatic joint), if
    #: known: it directs a carriage's schedule (:func:`.carriage.carriage_schedule`)
    start_q: FloatArray | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        six = self.arm.n_joints == 6 and not self._point_alone
        self._solver = complete_solver(self.arm) if six else None
        #: the last solution found for each tool frame (numerical family): warm starts
        self._last: dict[tuple[float, ...], FloatArray] = {}
        #: the same with the carriage at its scheduled value (:mod:`.carriage`)
        self._last_scheduled: dict[tuple[float, ...], FloatArray] = {}
        self._carriage = None if six else carriage_joint(self.arm, self.tip_joints)

    @cached_property
    def schedule(self) -> CarriageSchedule | None:
        """Where the arm's carriage stands along the curve (None: the arm has none)."""
        if self._carriage is None:
            return None
        start = None if self.start_q is None else float(self.start_q[self._carriage])
        return carriage_schedule(self.arm, self.curve, self._carriage, start)

    @cached_property
    def coarse_dirs(self) -> FloatArray:
        """Tool directions of the scan (600, about 8 deg apart; with the turns about each)."""
        return fibonacci_directions(600)

    @cached_property
    def fine_dirs(self) -> FloatArray:
        """Tool directions of the refined search (2400, about 4 deg apart)."""
        return fibonacci_directions(2400)

    @cached_property
    def _turns(self) -> int:
        # the turn about the tool axis moves no link when the tool point is on the last axis
        # and the tool axis is that axis (a tool axis across it, as a URDF's tip frame whose x
        # is the flange's normal may have, turns with the last joint: its turn is sampled);
        # there is none to sample when the point alone is solved
        idle = not self.tip_joints[-1] and last_axis_across_approach(self.arm) is None
        return 1 if idle or self._point_alone else self.rolls

    @cached_property
    def _point_alone(self) -> bool:
        """Whether the point alone is solved, each solution counted for the searched direction
        nearest its own: where fewer than five joints move the tool point, too few to set its
        direction as well (a SCARA; a five-joint arm whose last joint turns the tool about the
        point), and where five do but the tool directions do not chart their family
        (:attr:`_directions_chart`)."""
        tip = int(self.tip_joints.sum())
        return tip < 5 or (tip == 5 and not self._directions_chart)

    @cached_property
    def _directions_chart(self) -> bool:
        """Whether the tool directions chart the two-dimensional family of five joints that
        move the tool point: the slower of the rates at which the tool's axis turns along
        the family (:func:`~armpath.kinematics.self_motion_axis_rates`), median over
        :data:`_CHART_CONFIGS` configurations within the limits, is at least
        :data:`_CHART_MIN_TURN_RATE`. The SO-101's (its tool point 7 mm off its wrist's roll
        axis) is 0.015 rad per rad: directions 8 deg apart solved members up to 9 rad apart
        along the roll, neighbouring tool directions' members had unrelated rolls, and the
        reference path broke a 60 mm circle into 23 passes (352 commands; the point alone:
        one pass, 54). A KUKA-like five-axis arm with a 150 mm tool: 0.50."""
        lo, hi = self.arm.sampling_box()
        q = np.random.default_rng(0).uniform(lo, hi, (_CHART_CONFIGS, self.arm.n_joints))
        rates = self_motion_axis_rates(self.arm, q, self.tip_joints)
        return bool(np.median(rates[:, -1]) >= _CHART_MIN_TURN_RATE)

    @property
    def unspanned_because(self) -> str:
        # the point alone solved, one member is found from each start: a family of more than
        # one dimension beyond the point is not charted by the directions it is counted for
        if self._point_alone and int(np.count_nonzero(self.tip_joints)) - 3 > 1:
            return (
                "one member is found from each random start, the tool directions not "
                "charting the family (along one of its dimensions the tool's axis barely turns)"
            )
        return super().unspanned_because

    @property
    def turns_per_direction(self) -> int:
        return int(self._turns)

    @cached_property
    def _anchored(self) -> bool:
        """Whether each tool frame's first member is solved from one configuration (the arm's
        start if known, else its home; a random start where that fails) rather than from a
        random start of its own: for an arm with more joints than a tool frame needs and no
        carriage, whose self-motion the frames do not fix. Frames the start does not reach
        are solved from the member of the nearest frame solved, in waves (:data:`_MAX_WAVES`).
        Random starts put neighbouring frames' members at unrelated points of the self-motion
        and missed most frames (a KUKA iiwa at one point: 24 members of 600 tool directions,
        neighbours' joints a median 193 deg apart; anchored, 375 and 7 deg), and in the UR5
        cell its seam was traced in four passes, 256 commands, and its four welds in 131, with
        no member clear of the workpiece at two of them (anchored: 123 and 63)."""
        redundant = self.arm.n_joints > 6 and not self._point_alone
        return redundant and self._carriage is None

    def configs_at(self, E: FloatArray, dirs: FloatArray) -> FloatArray:
        return self.members(E, dirs)[0]

    def solutions(self, E: FloatArray, dirs: FloatArray) -> tuple[FloatArray, NDArray[np.int64]]:
        return self._solved(E, dirs)

    @property
    def solves_completely(self) -> bool:
        return self._solver is not None

    def _solved(self, E: FloatArray, dirs: FloatArray) -> tuple[FloatArray, NDArray[np.int64]]:
        """The configurations that reach ``E`` along ``dirs`` (the joint limits unchecked:
        :meth:`members` drops those past them) and the index into ``dirs`` of each."""
        if dirs.shape[0] == 0:
            return np.zeros((0, self.arm.n_joints)), np.zeros(0, dtype=np.int64)
        Rs = _frames_along(dirs, self._turns, np.asarray(self.arm.approach_axis))
        if self._solver is not None:
            q, frame = solve_frames(self.arm, self._solver, E, Rs)
        else:  # Levenberg-Marquardt's are turned as they are found
            q, frame = self._numerical(E, Rs)
            ok = np.all(np.isfinite(q), axis=1)
            q, frame = q[ok], frame[ok]
        index = frame // self._turns
        if q.shape[0] == 0:
            return q, index
        ok = GenericFamily(self.arm, ToolTarget(E)).reaches(q)
        return np.asarray(q[ok], dtype=np.float64), np.asarray(index[ok], dtype=np.int64)

    def _numerical(self, E: FloatArray, Rs: FloatArray) -> tuple[FloatArray, NDArray[np.int64]]:
        """Levenberg-Marquardt for each tool frame of ``Rs`` (the solutions found and the index
        of the frame of each): continued from the solution found
        for the same frame at the last point (so that neighbouring points of a curve get
        neighbouring configurations, which the reference path can follow), otherwise from a
        fixed random start of that frame; an arm :attr:`_anchored` tries the arm's start (or
        home) first, then the member of the nearest frame solved (:data:`_MAX_WAVES`)."""
        arm = self.arm
        fam = GenericFamily(arm, ToolTarget(E))
        keys = [(*np.round(R[:, 2], 6).tolist(), round(float(R[0, 0]), 6)) for R in Rs]
        lo, hi = arm.sampling_box()
        rng = np.random.default_rng(0)
        starts = rng.uniform(lo, hi, (Rs.shape[0], arm.n_joints))
        fresh = starts.copy()
        continued = np.array([key in self._last for key in keys], dtype=bool)
        if self._anchored:  # every new lineage from one configuration: see _anchored
            anchor = arm.home if self.start_q is None else self.start_q
            starts[:] = np.clip(anchor, lo, hi)
        starts, turn_near = _continued(self._last, keys, starts)
        a = np.asarray(arm.approach_axis)
        wanted = Rs @ a  # (M, 3) the tool direction of each frame
        if not self._point_alone:

            def solved(starts: FloatArray, rows: NDArray[np.intp]) -> tuple[FloatArray, BoolArray]:
                """The frames ``rows`` solved from ``starts``, and which reach the point."""
                if arm.n_joints < 6:  # five joints set the tool's direction, not its turn
                    q = fam.refine(starts, iterations=40, axes=wanted[rows])
                else:
                    q = fam.refine(starts, iterations=40, rotations=Rs[rows])
                # the tool axis exactly (the turn about it is free): keep what reaches the point
                axis_ok = np.einsum("mi,mi->m", tool_pose(arm, q)[:, :3, :3] @ a, wanted[rows])
                return q, (axis_ok > np.cos(np.radians(1.0))) & fam.exact(q)

            q, good = solved(starts, np.arange(Rs.shape[0]))
            if self._anchored:
                # a new lineage the anchor did not reach: from the member of the nearest frame
                # solved, in waves while they reach more, then from a random start
                from scipy.spatial import cKDTree

                flat = Rs.reshape(-1, 9)
                for _ in range(_MAX_WAVES):
                    solved_rows = np.flatnonzero(good)
                    open_rows = np.flatnonzero(~good & ~continued)
                    if solved_rows.size == 0 or open_rows.size == 0:
                        break
                    _, nearest = cKDTree(flat[solved_rows]).query(flat[open_rows])
                    q_w, good_w = solved(q[solved_rows[nearest]], open_rows)
                    if not np.any(good_w):
                        break
                    q[open_rows[good_w]], good[open_rows[good_w]] = q_w[good_w], True
                again = np.flatnonzero(~good & ~continued)
                q[again], good[again] = solved(fresh[again], again)
            frame = np.arange(Rs.shape[0])
        else:
            # too few joints to set the tool's direction (a SCARA's points down): the point
            # alone, each solution counted for the direction searched nearest its own, if one
            # lies within the scan's spacing of it (a direction the rule or the surface allows)
            from scipy.spatial import cKDTree

            q = fam.refine(starts, iterations=40)
            got = tool_pose(arm, q)[:, :3, :3] @ a
            apart, frame = cKDTree(wanted).query(got)  # chord between unit vectors
            near = apart <= 2.0 * np.sin(0.5 * _POINT_ALONE_SPACING)
            good = near & fam.exact(q)
        # turned by whole turns nearest 0 or the solution continued: a lineage crossing 180 deg
        # on a joint limited to +-360 deg (a UR5's) stays continuous; brought to [-180, 180)
        # it jumped a turn there, and the reference DP, seeing a turn, cut the curve in two
        q = shift_into_limits(arm, q, turn_near)
        for k in np.flatnonzero(good).tolist():
            self._last[keys[k]] = q[k]
        q, frame = np.asarray(q[good], dtype=np.float64), frame[good]
        if self.schedule is not None and not self._point_alone:
            q_s, frame_s = self._scheduled(fam, E, Rs, keys, fresh)
            q, frame = np.concatenate([q, q_s]), np.concatenate([frame, frame_s])
        return q, frame

    def _scheduled(
        self,
        fam: GenericFamily,
        E: FloatArray,
        Rs: FloatArray,
        keys: list[tuple[float, ...]],
        starts: FloatArray,
    ) -> tuple[FloatArray, NDArray[np.int64]]:
        """Each tool frame of ``Rs`` solved with the carriage held at its scheduled value for
        ``E`` (continued from the last such solution of the frame, else from ``starts``)."""
        assert self.schedule is not None
        arm, j = self.arm, self.schedule.joint
        v = float(np.clip(self.schedule.at(E), arm.lower[j], arm.upper[j]))
        starts, turn_near = _continued(self._last_scheduled, keys, starts)
        starts[:, j] = v
        lower = np.broadcast_to(arm.lower, starts.shape).copy()
        upper = np.broadcast_to(arm.upper, starts.shape).copy()
        lower[:, j] = upper[:, j] = v
        q = fam.refine(starts, iterations=40, rotations=Rs, lower=lower, upper=upper)
        a = np.asarray(arm.approach_axis)
        axis_ok = np.einsum("mi,mi->m", tool_pose(arm, q)[:, :3, :3] @ a, Rs @ a)
        good = (axis_ok > np.cos(np.radians(1.0))) & fam.exact(q)
        q = shift_into_limits(arm, q, turn_near)
        for k in np.flatnonzero(good).tolist():
            self._last_scheduled[keys[k]] = q[k]
        return np.asarray(q[good], dtype=np.float64), np.flatnonzero(good)


def _continued(
    last: dict[tuple[float, ...], FloatArray], keys: list[tuple[float, ...]], starts: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Levenberg-Marquardt's starts for the tool frames ``keys``: the solution ``last`` holds
    for a frame (a lineage continued from the last point), else its row of ``starts``; and what
    each solution is then turned nearest by whole turns (that solution, or 0)."""
    out = np.array(starts, dtype=np.float64, copy=True)
    turn_near = np.zeros_like(out)
    for i, key in enumerate(keys):
        found = last.get(key)
        if found is not None:
            out[i] = turn_near[i] = found
    return out, turn_near


def _frames_along(dirs: FloatArray, turns: int, approach: FloatArray | None = None) -> FloatArray:
    """Tool rotations ``(D * turns, 3, 3)`` that turn the tool's ``approach`` axis (tool
    frame, default z) onto each direction, ``turns`` turns about it each, evenly spaced."""
    return tool_frames(dirs, 2 * np.pi * np.arange(turns) / turns, approach)


def tool_frames(
    dirs: ArrayLike, angles: ArrayLike, approach: ArrayLike | None = None
) -> FloatArray:
    """Tool rotations ``(D * T, 3, 3)`` that take the tool's ``approach`` axis (tool frame,
    default z) onto each unit direction of ``dirs`` ``(D, 3)`` and turn the tool about it by
    each of ``angles`` rad (``(D, T)``, or ``(T,)`` the same for every direction), measured
    from :func:`~armpath.geometry.primitives.orthonormal_frame`'s first vector of the
    direction (where the approach axis's own first vector goes)."""
    d = np.asarray(dirs, dtype=np.float64).reshape(-1, 3)
    angle = np.atleast_2d(np.asarray(angles, dtype=np.float64))
    angle = np.broadcast_to(angle, (d.shape[0], angle.shape[1]))
    e1, e2 = orthonormal_frame(d)
    x = np.cos(angle)[..., None] * e1[:, None, :] + np.sin(angle)[..., None] * e2[:, None, :]
    dd = np.broadcast_to(d[:, None, :], x.shape)
    R = np.stack([x, np.cross(dd, x), dd], axis=-1).reshape(-1, 3, 3)
    if approach is None:
        return R
    a = np.asarray(approach, dtype=np.float64)
    a = a / np.linalg.norm(a)
    if np.allclose(a, [0.0, 0.0, 1.0]):
        return R
    a1, a2 = orthonormal_frame(a)
    return np.asarray(R @ np.stack([a1, a2, a], axis=-1).T)  # the approach axis onto z first


def solve_frames(
    arm: SerialArm, solver: CompiledSolver, E: FloatArray, Rs: FloatArray
) -> tuple[FloatArray, NDArray[np.int64]]:
    """Every real solution the all-solutions IK ``solver`` finds for the tool point ``E``
    (mm) with each tool rotation of ``Rs`` ``(M, 3, 3)``: the configurations (rad, each joint
    turned by whole turns into its limits where it can be; the limits not checked) and the
    index into ``Rs`` of each."""
    n = arm.n_joints
    if Rs.shape[0] == 0:
        return np.zeros((0, n)), np.zeros(0, dtype=np.int64)
    T = np.broadcast_to(np.eye(4), (Rs.shape[0], 4, 4)).copy()
    T[:, :3, :3] = Rs
    T[:, :3, 3] = E
    sol = solver.solve_batch(T).solutions  # (M, S, n)
    q = sol.reshape(-1, n)
    frame = np.repeat(np.arange(Rs.shape[0]), sol.shape[1])
    ok = np.all(np.isfinite(q), axis=1)
    q, frame = q[ok], frame[ok]
    if q.shape[0]:
        q = shift_into_limits(arm, q)
    return np.asarray(q, dtype=np.float64), np.asarray(frame, dtype=np.int64)


def charting_arm(arm: SerialArm) -> SerialArm:
    """``arm`` with its approach axis along its last joint's axis where that joint only turns
    the tool about the tool point but the approach axis lies across it
    (:func:`~armpath.kinematics.last_axis_across_approach`), else ``arm`` itself: for a family
    without an axis rule, whose tool directions then chart the members of the joints that
    move the tool point one to one. A UR5's URDF (its tip frame's x the flange's normal, z
    across it) charted by z: a tour's bound over five welds was an estimate (41 of 88
    members drawn at random lay outside every sample's error box, by up to 21 commands); by
    the flange's normal it is proven. The approach axis's only other use in a family
    without a rule is which way the tool may point at a surface (into it): the last link
    lies along that axis behind the tool point."""
    c, tip = last_axis_across_approach(arm), tool_point_joints(arm)
    if c is None or tip[-1] or tip.sum() < 5:
        return arm  # (fewer than five joints: the point alone is solved, no direction charted)
    return replace(arm, approach_axis=(float(c[0]), float(c[1]), float(c[2])))


def curve_family(
    arm: SerialArm,
    world: CollisionWorld,
    curve: Curve,
    rule: AxisRule | None = None,
    start_q: FloatArray | None = None,
) -> CurveFamily:
    """The family of ``curve`` for ``arm``: the seed closed form for the seed arm (at the
    origin, its fingertip as the tool, its lattice, no axis rule), the generic search for every
    other arm (``start_q``: where the arm starts, rad, if known). Without a rule, an arm whose
    approach axis lies across a last joint that only turns the tool is charted along that
    joint's axis (:func:`charting_arm`)."""
    if rule is None:
        arm = charting_arm(arm)
    if rule is None and arm.lattice.is_default:
        try:
            seed_geometry_of(arm)
        except InvalidInputError:
            pass  # not the plain seed arm
        else:
            return SeedCurveFamily(arm, world, curve)
    return GenericCurveFamily(arm, world, curve, rule, start_q=start_q)


__all__ = [
    "TOUCH_MM",
    "AxisRule",
    "CurveFamily",
    "GenericCurveFamily",
    "SeedCurveFamily",
    "Verdict",
    "curve_family",
    "fibonacci_directions",
]
