"""Space curves for tracing: parametric expressions, polylines and plane sections of solids.

Every curve maps a parameter ``u`` in ``[0, 1]`` to points ``(..., 3)`` (length unit of the
scene). :class:`Curve` adds, for all of them, arc-length parametrization (``length``,
:meth:`Curve.at_arc_length`, :meth:`Curve.sample`) and the distance from points to the curve
(:meth:`Curve.closest`), computed on a dense table of the curve refined by golden-section search.

* :class:`ParametricCurve` — ``x(t), y(t), z(t)`` given as safe expressions
  (:mod:`armpath.geometry.expressions`) over ``[t0, t1]``.
* :class:`Polyline` — straight pieces through vertices, open or closed.
* :class:`CircularArc` — a circle, or an arc of one, about a centre in the plane normal to a
  given direction.
* :class:`ConeSection` — the intersection of one conical (or cylindrical) face of a solid of
  revolution with a plane, in closed form: around the axis at angle ``phi`` the face has radius
  ``R0 + R1 z``, so the plane fixes ``z(phi)`` by a linear equation. The seed crack is the
  workpiece's outer face cut by the plane ``x = 2 z`` (:func:`seed_crack`).
"""

from __future__ import annotations

import math
import warnings
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import MAX_COORDINATE_MM, MAX_CURVE_POINTS, check_size
from armpath.errors import ArmpathWarning, InvalidInputError
from armpath.geometry.expressions import Expression, parse_expression
from armpath.geometry.primitives import SolidOfRevolution

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

FloatArray = NDArray[np.float64]

#: Samples of the dense table behind arc length and closest points, at first; doubled (up to
#: :data:`MAX_TABLE_SAMPLES`) while the curve measured through the midpoints of the table's
#: intervals is longer than through the table by more than :data:`TABLE_LENGTH_SHARE` of its
#: length (a helix of 1,000 turns: 160,001 points; a circle, a seam: 20,001).
TABLE_SAMPLES = 20_001
MAX_TABLE_SAMPLES = 16 * (TABLE_SAMPLES - 1) + 1
TABLE_LENGTH_SHARE = 1e-4
#: Shortest curve (mm): a shorter one is a point to the tracer (0.01 mm found no lattice state
#: near it where 0.1 mm is traced).
MIN_CURVE_LENGTH_MM = 0.1
#: A curve whose end lies this near its start (mm) is closed: a points table's first row
#: written again at its end, or a parametric curve's ends meeting, up to rounding.
CLOSING_GAP_MM = 1e-6


class Curve(ABC):
    """A curve ``u -> point`` on ``[0, 1]``; ``closed`` when the end meets the start."""

    name: str
    closed: bool

    @abstractmethod
    def points(self, u: ArrayLike) -> FloatArray:
        """Points ``(..., 3)`` at parameters ``u`` in ``[0, 1]``."""

    @abstractmethod
    def describe(self) -> dict[str, object]:
        """The curve's definition for result files (plain JSON types)."""

    def parameter_text(self, u: float) -> str:
        """Where parameter ``u`` lies, in the terms the curve was given in (for messages)."""
        return f"{100.0 * u:.1f} % of the way along it"

    def table_parameters(self, count: int) -> FloatArray:
        """The parameters of a table of about ``count`` points: evenly over ``[0, 1]`` (a
        polyline adds its vertices, so its table has every corner)."""
        return np.linspace(0.0, 1.0, count)

    @property
    def corners_mm(self) -> FloatArray:
        """Arc lengths (ascending, in ``[0, length)``) where the curve turns by an angle rather
        than smoothly (a polyline's vertices; none for a smooth curve). Beside a corner the
        distance from a moving point to the curve peaks sharply where its nearest point
        passes from one side of the corner to the other, so a check of a motion at a few
        instants looks there too."""
        return np.zeros(0)

    @cached_property
    def _table(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        u = self.table_parameters(TABLE_SAMPLES)
        p = self._finite_points(u)
        while True:
            s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=-1))]
            u_mid = 0.5 * (u[1:] + u[:-1])
            mid = self._finite_points(u_mid)
            halves = np.linalg.norm(mid - p[:-1], axis=-1) + np.linalg.norm(p[1:] - mid, axis=-1)
            finer = float(halves.sum())
            if finer <= s[-1] * (1.0 + TABLE_LENGTH_SHARE) + 1e-12:
                break
            if u.size >= MAX_TABLE_SAMPLES:
                raise InvalidInputError(
                    f"curve {self.name!r} turns faster than {u.size:,} points along it follow "
                    f"(its length by them {s[-1]:.6g} mm, by twice as many {finer:.6g} mm): give "
                    "a shorter parameter range, or the curve in pieces"
                )
            # the next table: these points and the midpoints between them, already computed
            u = np.insert(u, np.arange(1, u.size), u_mid)
            p = np.insert(p, np.arange(1, p.shape[0]), mid, axis=0)
        if not s[-1] > 0:
            raise InvalidInputError(f"curve {self.name!r} has zero length (a single point)")
        if s[-1] < MIN_CURVE_LENGTH_MM:
            raise InvalidInputError(
                f"curve {self.name!r} is {s[-1]:.3g} mm long; a curve must be at least "
                f"{MIN_CURVE_LENGTH_MM:g} mm"
            )
        return u, p, s

    def _finite_points(self, u: FloatArray) -> FloatArray:
        """The curve's points at ``u``, refused where not finite or beyond the largest
        coordinate a scene may use."""
        with np.errstate(all="ignore"):
            p = self.points(u)
        bad = ~np.all(np.isfinite(p), axis=-1)
        if np.any(bad):
            where = self.parameter_text(float(u[int(np.argmax(bad))]))
            raise InvalidInputError(f"curve {self.name!r} is not finite at {where}")
        big = float(np.abs(p).max())
        if big > MAX_COORDINATE_MM:
            raise InvalidInputError(
                f"curve {self.name!r} reaches a coordinate of {big:.3g} mm, beyond the largest "
                f"a scene may use ({MAX_COORDINATE_MM:g} mm)"
            )
        return p

    @cached_property
    def _tree(self) -> cKDTree:
        from scipy.spatial import cKDTree  # imported when first needed (start-up time)

        return cKDTree(self._table[1])

    @property
    def length(self) -> float:
        """Arc length (length unit)."""
        return float(self._table[2][-1])

    def wrap(self, s: ArrayLike) -> FloatArray:
        """Arc lengths ``s`` brought onto the curve: modulo the length on a closed curve (an arc
        may run on past its start), clipped to ``[0, length]`` on an open one."""
        a = np.asarray(s, dtype=np.float64)
        if self.closed:
            return np.asarray(a % self.length)
        return np.asarray(np.clip(a, 0.0, self.length))

    def parameter_at(self, s: ArrayLike) -> FloatArray:
        """Parameters ``u`` at arc lengths ``s`` (brought onto the curve by :meth:`wrap`)."""
        u, _, table_s = self._table
        return np.asarray(np.interp(self.wrap(s), table_s, u))

    def arc_length_at(self, u: ArrayLike) -> FloatArray:
        """Arc lengths at parameters ``u``."""
        table_u, _, s = self._table
        return np.asarray(np.interp(np.clip(u, 0.0, 1.0), table_u, s))

    def at_arc_length(self, s: ArrayLike) -> FloatArray:
        """Points at arc lengths ``s``, ``(..., 3)``."""
        return self.points(self.parameter_at(s))

    def sample(self, count: int) -> FloatArray:
        """``count`` points equally spaced in arc length (both ends included)."""
        if count < 2:
            raise InvalidInputError("a curve sample needs at least 2 points")
        return self.at_arc_length(np.linspace(0.0, self.length, count))

    def closest(self, points: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Distance from each point ``(..., 3)`` to the curve and the arc length where it is
        attained.

        The nearest sample of the arc-length table (20,001 points or more), the exact projection
        onto the two table chords next to it (exact for polylines), then one Newton step on the
        curve itself (smooth curves: error far below 1e-6 mm).
        """
        x = np.asarray(points, dtype=np.float64)
        flat = x.reshape(-1, 3)
        _, table_p, table_s = self._table
        _, idx = self._tree.query(flat)
        best_d = np.full(flat.shape[0], np.inf)
        best_s = np.zeros(flat.shape[0])
        last = table_p.shape[0] - 1
        for lo in (np.maximum(idx - 1, 0), np.minimum(idx, last - 1)):
            a, b = table_p[lo], table_p[lo + 1]
            ab = b - a
            t = np.clip(
                np.einsum("ij,ij->i", flat - a, ab)
                / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300),
                0.0,
                1.0,
            )
            d = np.linalg.norm(a + t[:, None] * ab - flat, axis=-1)
            better = d < best_d
            best_d = np.where(better, d, best_d)
            best_s = np.where(better, table_s[lo] + t * (table_s[lo + 1] - table_s[lo]), best_s)
        # one Newton step on (c(u) - x) . c'(u) = 0 from the chord estimate, then keep the better
        u_tab = self._table[0]
        h = 0.25 / (u_tab.size - 1)  # a quarter of the table's even spacing
        u0 = self.parameter_at(best_s)
        u0 = np.clip(u0, h, 1.0 - h)
        c_m, c_0, c_p = self.points(u0 - h), self.points(u0), self.points(u0 + h)
        d1 = (c_p - c_m) / (2 * h)
        d2 = (c_p - 2 * c_0 + c_m) / (h * h)
        r = c_0 - flat
        f1 = np.einsum("ij,ij->i", r, d1)
        f2 = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", r, d2)
        u1 = np.clip(u0 - f1 / np.where(np.abs(f2) > 1e-300, f2, 1.0), 0.0, 1.0)
        d_new = np.linalg.norm(self.points(u1) - flat, axis=-1)
        better = d_new < best_d
        best_d = np.where(better, d_new, best_d)
        best_s = np.where(better, self.arc_length_at(u1), best_s)
        return best_d.reshape(x.shape[:-1]), best_s.reshape(x.shape[:-1])


@dataclass(frozen=True, eq=False)
class ParametricCurve(Curve):
    """``(x(t), y(t), z(t))`` for ``t`` in ``[t0, t1]``, each coordinate a safe expression."""

    name: str
    x: str
    y: str
    z: str
    t0: float = 0.0
    t1: float = 1.0
    closed: bool = field(init=False, default=False)
    _exprs: tuple[Expression, Expression, Expression] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.t0) and np.isfinite(self.t1) and self.t1 > self.t0):
            raise InvalidInputError(f"curve {self.name!r}: need finite t0 < t1")
        exprs = tuple(parse_expression(e, "t") for e in (self.x, self.y, self.z))
        object.__setattr__(self, "_exprs", exprs)
        with np.errstate(all="ignore"):
            ends = self.points(np.array([0.0, 1.0]))
            closed = bool(np.linalg.norm(ends[1] - ends[0]) < CLOSING_GAP_MM)
        object.__setattr__(self, "closed", closed)

    def points(self, u: ArrayLike) -> FloatArray:
        t = self.t0 + np.asarray(u, dtype=np.float64) * (self.t1 - self.t0)
        return np.stack([e(t) for e in self._exprs], axis=-1)

    def parameter_text(self, u: float) -> str:
        return f"t = {self.t0 + u * (self.t1 - self.t0):.6g}"

    def describe(self) -> dict[str, object]:
        return {
            "type": "parametric",
            "name": self.name,
            "x": self.x,
            "y": self.y,
            "z": self.z,
            "t": [self.t0, self.t1],
        }


@dataclass(frozen=True, eq=False)
class Polyline(Curve):
    """Straight pieces through ``vertices`` ``(V, 3)``; ``closed`` adds the piece back. Vertices
    whose last is their first (within :data:`CLOSING_GAP_MM`, four or more of them) are closed
    either way, as a parametric curve whose ends meet is: a pass may then begin anywhere on it
    and come round, rather than only at its ends."""

    name: str
    vertices: FloatArray
    closed: bool = False

    def __post_init__(self) -> None:
        v = np.array(self.vertices, dtype=np.float64)
        if v.ndim != 2 or v.shape[1] != 3:
            raise InvalidInputError(
                f"polyline {self.name!r}: each point needs 3 coordinates (x, y, z), got an array "
                f"of shape {v.shape}"
            )
        if v.shape[0] < 2:
            raise InvalidInputError(
                f"polyline {self.name!r}: a curve needs at least 2 points, got {v.shape[0]}"
            )
        if not np.all(np.isfinite(v)):
            raise InvalidInputError(f"polyline {self.name!r}: a coordinate is not a finite number")
        check_size(v.shape[0], MAX_CURVE_POINTS, f"vertices of polyline {self.name!r}", "the curve")
        given = np.arange(v.shape[0])  # each vertex's place among the points given
        repeats = np.flatnonzero(np.all(v[1:] == v[:-1], axis=-1)) + 1
        if repeats.size:  # a point written twice in a row (a measured seam's log) adds no piece
            if repeats.size == v.shape[0] - 1:
                raise InvalidInputError(
                    f"polyline {self.name!r}: all its {v.shape[0]} points are the same point; "
                    "a curve needs two"
                )
            shown = ", ".join(str(int(k) + 1) for k in repeats[:5])
            more = f" and {repeats.size - 5} more" if repeats.size > 5 else ""
            warnings.warn(
                f"polyline {self.name!r}: {repeats.size} point(s) the same as the one before "
                f"dropped (points {shown}{more}, counted from 1)",
                ArmpathWarning,
                stacklevel=3,
            )
            v = np.delete(v, repeats, axis=0)
            given = np.delete(given, repeats)
        if v.shape[0] >= 4 and np.linalg.norm(v[-1] - v[0]) < CLOSING_GAP_MM:
            v[-1] = v[0]
            object.__setattr__(self, "closed", True)
        if self.closed:
            if v.shape[0] > 2 and np.array_equal(v[-1], v[0]):
                v = v[:-1]  # closed already by its last vertex: the piece back is that one
                given = given[:-1]
            if v.shape[0] < 3:
                raise InvalidInputError(
                    f"polyline {self.name!r}: a closed polyline needs 3 or more vertices"
                )
            v = np.vstack([v, v[:1]])
            given = np.r_[given, given[0]]
        same = np.flatnonzero(np.linalg.norm(np.diff(v, axis=0), axis=-1) == 0)
        if same.size:
            k = int(same[0])
            nxt = 0 if self.closed and k + 1 == v.shape[0] - 1 else k + 1  # the piece back
            raise InvalidInputError(
                f"polyline {self.name!r}: points {given[k] + 1} and {given[nxt] + 1} (counted "
                "from 1) are the same point; a piece needs two"
            )
        v.setflags(write=False)
        object.__setattr__(self, "vertices", v)

    @cached_property
    def _knots(self) -> FloatArray:
        seg = np.linalg.norm(np.diff(self.vertices, axis=0), axis=-1)
        return np.asarray(np.r_[0.0, np.cumsum(seg)] / seg.sum(), dtype=np.float64)

    def points(self, u: ArrayLike) -> FloatArray:
        uu = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0)
        return np.stack([np.interp(uu, self._knots, self.vertices[:, k]) for k in range(3)], -1)

    @cached_property
    def corners_mm(self) -> FloatArray:
        """The vertices where the polyline turns (on a closed one also its first, at 0 mm)."""
        piece = np.diff(self.vertices, axis=0)
        piece /= np.linalg.norm(piece, axis=-1, keepdims=True)
        inner = np.arange(1, piece.shape[0])
        turns = np.einsum("ij,ij->i", piece[:-1], piece[1:]) < 1.0 - 1e-12
        at = list(inner[turns])
        if self.closed and float(piece[-1] @ piece[0]) < 1.0 - 1e-12:
            at.insert(0, 0)
        return np.asarray(self._knots[np.array(at, dtype=np.int64)] * self.length)

    def table_parameters(self, count: int) -> FloatArray:
        """Evenly over ``[0, 1]`` and every vertex: the table's length is the polyline's."""
        return np.asarray(np.unique(np.r_[np.linspace(0.0, 1.0, count), self._knots]))

    def describe(self) -> dict[str, object]:
        return {
            "type": "polyline",
            "name": self.name,
            "vertices": self.vertices[:-1].tolist() if self.closed else self.vertices.tolist(),
            "closed": self.closed,
        }


@dataclass(frozen=True, eq=False)
class CircularArc(Curve):
    """A circle of ``radius`` (mm) about ``center`` in the plane normal to ``normal``, or an arc
    of it: from ``start_direction`` (projected onto the plane; None: the world x axis, else y,
    whichever lies farther from the normal) round ``sweep_deg`` right-handed about ``normal``.
    A sweep of 360 deg is a closed circle: a pass may begin anywhere on it."""

    name: str
    center: FloatArray
    radius: float
    normal: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    start_direction: FloatArray | None = None
    sweep_deg: float = 360.0
    closed: bool = field(init=False, default=True)
    _axes: tuple[FloatArray, FloatArray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        c = np.array(self.center, dtype=np.float64)
        n = np.array(self.normal, dtype=np.float64)
        if c.shape != (3,) or n.shape != (3,) or not np.all(np.isfinite(np.r_[c, n])):
            raise InvalidInputError(
                f"circle {self.name!r}: need a finite centre and normal (x, y, z)"
            )
        if not np.linalg.norm(n) > 1e-12:
            raise InvalidInputError(f"circle {self.name!r}: the normal has no direction")
        n /= np.linalg.norm(n)
        r = float(self.radius)
        if not (np.isfinite(r) and 0.0 < r <= MAX_COORDINATE_MM):
            raise InvalidInputError(
                f"circle {self.name!r}: the radius must be above 0 and at most "
                f"{MAX_COORDINATE_MM:g} mm, got {r:g}"
            )
        sweep = float(self.sweep_deg)
        if not (np.isfinite(sweep) and 0.0 < sweep <= 360.0):
            raise InvalidInputError(
                f"circle {self.name!r}: the sweep must be above 0 and at most 360 deg, "
                f"got {sweep:g}"
            )
        if self.start_direction is None:
            helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        else:
            helper = np.array(self.start_direction, dtype=np.float64)
            if helper.shape != (3,) or not np.all(np.isfinite(helper)):
                raise InvalidInputError(
                    f"circle {self.name!r}: the start direction must be a finite (x, y, z)"
                )
        e1 = helper - (helper @ n) * n
        if not np.linalg.norm(e1) > 1e-9 * max(float(np.linalg.norm(helper)), 1e-300):
            raise InvalidInputError(
                f"circle {self.name!r}: the start direction lies along the normal; give one "
                "in the circle's plane"
            )
        e1 /= np.linalg.norm(e1)
        for name, value in (("center", c), ("normal", n), ("radius", r), ("sweep_deg", sweep)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "_axes", (e1, np.cross(n, e1)))
        object.__setattr__(self, "closed", sweep == 360.0)

    def points(self, u: ArrayLike) -> FloatArray:
        phi = np.radians(self.sweep_deg) * np.asarray(u, dtype=np.float64)
        e1, e2 = self._axes
        ring = np.cos(phi)[..., None] * e1 + np.sin(phi)[..., None] * e2
        return np.asarray(self.center + self.radius * ring)

    def parameter_text(self, u: float) -> str:
        return f"{u * self.sweep_deg:.1f} deg round from its start"

    def describe(self) -> dict[str, object]:
        return {
            "type": "circle",
            "name": self.name,
            "center_mm": self.center.tolist(),
            "radius_mm": self.radius,
            "normal": self.normal.tolist(),
            "start_direction": self._axes[0].tolist(),
            "sweep_deg": self.sweep_deg,
        }


@dataclass(frozen=True, eq=False)
class ConeSection(Curve):
    """Where the plane ``{p : normal . (p - point) = 0}`` cuts one face of a solid of revolution.

    ``edge`` is the index of the profile edge (from vertex ``edge`` to ``edge + 1``) whose
    surface is cut; it must be conical or cylindrical (not perpendicular to the axis). The
    parameter ``u`` is the angle ``2 pi u`` around the axis; the plane must cut the face in one
    closed curve within the edge's height range, otherwise :class:`InvalidInputError` says so.
    """

    name: str
    solid: SolidOfRevolution
    edge: int
    plane_point: FloatArray
    plane_normal: FloatArray
    closed: bool = field(init=False, default=True)

    def __post_init__(self) -> None:
        n = np.array(self.plane_normal, dtype=np.float64)
        p = np.array(self.plane_point, dtype=np.float64)
        if n.shape != (3,) or p.shape != (3,) or np.linalg.norm(n) < 1e-12:
            raise InvalidInputError(f"curve {self.name!r}: plane needs a point and a normal")
        object.__setattr__(self, "plane_normal", n / np.linalg.norm(n))
        object.__setattr__(self, "plane_point", p)
        prof = self.solid.profile
        if not 0 <= self.edge < len(prof):
            raise InvalidInputError(f"curve {self.name!r}: no profile edge {self.edge}")
        za, zb = prof[self.edge][1], prof[(self.edge + 1) % len(prof)][1]
        if za == zb:
            raise InvalidInputError(f"curve {self.name!r}: edge {self.edge} is not a side face")
        z = self._z(np.linspace(0.0, 2.0 * np.pi, 3601))
        if (
            not np.all(np.isfinite(z))
            or z.min() < min(za, zb) - 1e-9
            or z.max() > max(za, zb) + 1e-9
        ):
            raise InvalidInputError(
                f"curve {self.name!r}: the plane does not cut face {self.edge} of "
                f"{self.solid.name!r} in one closed curve between z = {min(za, zb):g} and "
                f"{max(za, zb):g}"
            )

    @cached_property
    def _frame(self) -> tuple[FloatArray, FloatArray, float, float]:
        a = self.solid.axis
        helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = helper - (helper @ a) * a
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        prof = self.solid.profile
        (ra, za), (rb, zb) = prof[self.edge], prof[(self.edge + 1) % len(prof)]
        r1 = (rb - ra) / (zb - za)
        return e1, e2, ra - r1 * za, r1

    def _z(self, phi: FloatArray) -> FloatArray:
        e1, e2, r0, r1 = self._frame
        n = self.plane_normal
        ne = np.cos(phi) * (n @ e1) + np.sin(phi) * (n @ e2)
        rhs = n @ (self.plane_point - self.solid.origin) - r0 * ne
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(rhs / (n @ self.solid.axis + r1 * ne))

    def points(self, u: ArrayLike) -> FloatArray:
        phi = 2.0 * np.pi * np.asarray(u, dtype=np.float64)
        e1, e2, r0, r1 = self._frame
        z = self._z(phi)
        radial = (np.cos(phi)[..., None] * e1 + np.sin(phi)[..., None] * e2) * (r0 + r1 * z)[
            ..., None
        ]
        return np.asarray(self.solid.origin + radial + z[..., None] * self.solid.axis)

    def describe(self) -> dict[str, object]:
        return {
            "type": "cone_section",
            "name": self.name,
            "solid": self.solid.name,
            "edge": self.edge,
            "plane_point": self.plane_point.tolist(),
            "plane_normal": self.plane_normal.tolist(),
        }


def arc_within_round(
    start_mm: float, end_mm: float, length_mm: float
) -> tuple[float, float, bool, bool]:
    """Where an arc of a closed curve ``length_mm`` long lies as a reader counts it (its arc
    lengths may run on past the curve's length): ``(start, end, whole, through_zero)``, both
    ends within one round (an arc that runs on past the curve's start ends before it begins:
    ``375.17, 2.50`` on a 376.99 mm circle; one that ends where the curve does ends at its
    length, not at 0), whether it covers the whole curve, and whether it runs through 0."""
    turns = math.floor(start_mm / length_mm)
    start, end = start_mm - turns * length_mm, end_mm - turns * length_mm
    through = end > length_mm + 1e-9
    if through:
        end -= length_mm
    return start, end, end_mm - start_mm >= length_mm - 1e-6, through


def plane_section(
    name: str,
    solid: SolidOfRevolution,
    plane_point: ArrayLike,
    plane_normal: ArrayLike,
    face: str = "outer",
) -> ConeSection:
    """Where a plane cuts a side face of ``solid``.

    ``face="outer"``: the profile edge that rises from the outermost bottom corner (for the
    seed workpiece, its outer conical face). ``face="inner"``: the inner side face of a hollow
    solid (the other side edge off the axis, the tallest if there are several).
    """
    prof = solid.profile
    bottom = int(np.argmax(np.where(prof[:, 1] == prof[:, 1].min(), prof[:, 0], -np.inf)))
    if face == "outer":
        return ConeSection(
            name,
            solid,
            bottom,
            np.asarray(plane_point, dtype=np.float64),
            np.asarray(plane_normal, dtype=np.float64),
        )
    if face != "inner":
        raise InvalidInputError(f"curve {name!r}: face must be 'outer' or 'inner', got {face!r}")
    nxt = np.roll(prof, -1, axis=0)
    side = (prof[:, 1] != nxt[:, 1]) & ((prof[:, 0] > 0) | (nxt[:, 0] > 0))
    side[bottom] = False
    if not np.any(side):
        raise InvalidInputError(f"curve {name!r}: {solid.name!r} has no inner side face")
    height = np.where(side, np.abs(nxt[:, 1] - prof[:, 1]), -np.inf)
    return ConeSection(
        name,
        solid,
        int(np.argmax(height)),
        np.asarray(plane_point, dtype=np.float64),
        np.asarray(plane_normal, dtype=np.float64),
    )


def seed_crack(workpiece: SolidOfRevolution) -> ConeSection:
    """SPEC section 4, Task 2: the workpiece's outer face cut by the plane ``x = 2 z``."""
    return plane_section("crack", workpiece, np.zeros(3), np.array([1.0, 0.0, -2.0]))
