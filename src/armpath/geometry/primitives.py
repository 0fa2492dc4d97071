"""Analytic obstacle solids with vectorized signed distance.

Signed distance is negative inside the solid, zero on its surface and positive outside; it is
the exact Euclidean distance to the surface (1-Lipschitz), in the scene's length unit.

* :class:`HalfSpace` — everything on one side of a plane (the table).
* :class:`Sphere`, :class:`Capsule` — closed forms.
* :class:`Box` — an oriented box.
* :class:`SolidOfRevolution` — a polygonal profile ``(r, z)`` revolved about an axis. Cylinders
  (:func:`cylinder`), cone frustums (:func:`cone_frustum`) and hollow vessels such as the seed
  workpiece (:func:`hollow_frustum`) are instances.

Every primitive also gives the smallest signed distance along line segments (a link of the arm)
in closed form or by an exact compiled kernel (:mod:`armpath.geometry.kernels`): exact (to
rounding) while the segment stays outside, and a negative value the segment attains when it
enters the solid. Obstacles without such a form (meshes) fall back on the generic, certified
sampling of :meth:`Obstacle.segment_distance_bounds`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.errors import InvalidInputError
from armpath.geometry import kernels
from armpath.jit import in_slices

FloatArray = NDArray[np.float64]

#: Spacing (length unit) of the samples along a segment before local refinement.
SEGMENT_SAMPLE_SPACING = 2.0
#: How many local minima of the samples along a segment are refined.
REFINED_MINIMA = 3
#: Spacing (length unit) of the samples that tighten a lower bound near a required clearance.
FINE_SAMPLE_SPACING = 0.02
#: Segment distance (length unit) at or below which a segment counts as touching a solid.
TOUCHING = 1e-9
#: Allowance (length unit) for floating-point rounding subtracted from exact kernel results to
#: give proven lower bounds.
ROUNDING_ALLOWANCE = 1e-7
#: Least slack (length unit) beyond its requirement a pair must show at a state for the proven
#: lower bound there to meet the requirement: the rounding allowance, and a mesh's relative one
#: (1e-8 of distance plus the part's reach) for parts within a metre or so. A goal state whose
#: tool tip touches a surface exactly (a SCARA's vertical axis lands on it to the tick) is
#: clear by its value but could never be certified.
PROVABLE_SLACK = 1e-5
#: Fewest segments whose distances to a solid of revolution are split between threads, one
#: slice per core, where a core is free (a segment takes about a microsecond and starting the
#: threads about two milliseconds).
REVOLUTION_THREAD_BATCH = 5_000


def golden_section_min(
    f: Callable[[FloatArray], FloatArray],
    lo: FloatArray,
    hi: FloatArray,
    iterations: int = 40,
) -> tuple[FloatArray, FloatArray]:
    """Batched golden-section search of ``f`` on the intervals ``[lo, hi]`` (any shape).

    ``f`` is evaluated on whole arrays of arguments. Returns the best arguments found and their
    values; the interval shrinks by 0.618 per step (40 steps: below 1e-8 of its length).
    """
    golden = (np.sqrt(5.0) - 1.0) / 2.0
    x1 = hi - golden * (hi - lo)
    x2 = lo + golden * (hi - lo)
    f1, f2 = f(x1), f(x2)
    for _ in range(iterations):
        left = f1 < f2
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        x2n = np.where(left, x1, lo + golden * (hi - lo))
        x1n = np.where(left, hi - golden * (hi - lo), x2)
        fn = f(np.where(left, x1n, x2n))
        f1, f2 = np.where(left, fn, f2), np.where(left, f1, fn)
        x1, x2 = x1n, x2n
    better = f1 < f2
    return np.where(better, x1, x2), np.where(better, f1, f2)


def _flat_segments(p0: ArrayLike, p1: ArrayLike) -> tuple[FloatArray, FloatArray, tuple[int, ...]]:
    """Broadcast segment end points to flat contiguous ``(K, 3)`` arrays plus the batch shape."""
    a = np.asarray(p0, dtype=np.float64)
    b = np.asarray(p1, dtype=np.float64)
    a, b = np.broadcast_arrays(a, b)
    if a.shape[-1:] != (3,):
        raise InvalidInputError(f"segment end points must have shape (..., 3), got {a.shape}")
    shape = a.shape[:-1]
    return np.ascontiguousarray(a.reshape(-1, 3)), np.ascontiguousarray(b.reshape(-1, 3)), shape


class ExactSegmentDistance(ABC):
    """Mixin for obstacles whose :meth:`segment_distance_exact` is exact (to rounding).

    ``exact_inside`` False means the kernel is exact only for segments that stay outside (value
    above :data:`TOUCHING`); for a segment that touches or enters the solid its value is
    attained but may not be the deepest. Such segments get the lower bound ``-inf`` (the motion
    is rejected anyway), unless ``certify`` asks for a bound: then the generic certified
    sampling of :meth:`Obstacle.segment_distance_bounds` supplies value and lower bound.
    """

    exact_inside: bool = True

    @abstractmethod
    def segment_distance_exact(self, p0: FloatArray, p1: FloatArray) -> FloatArray:
        """Smallest signed distance of flat segments ``(K, 3)``, ``(K,)``."""

    def segment_distance_bounds(
        self, p0: ArrayLike, p1: ArrayLike, certify: ArrayLike = -np.inf
    ) -> tuple[FloatArray, FloatArray]:
        """Exact: the value, and the value less :data:`ROUNDING_ALLOWANCE` as the lower bound."""
        a, b, shape = _flat_segments(p0, p1)
        d = self.segment_distance_exact(a, b)
        lower = d - ROUNDING_ALLOWANCE
        if not self.exact_inside and isinstance(self, Obstacle):
            touching = d <= TOUCHING
            lower[touching] = -np.inf
            threshold = np.broadcast_to(np.asarray(certify, dtype=np.float64), shape).reshape(-1)
            redo = np.flatnonzero(touching & (threshold > -np.inf))
            if redo.size:
                v, lo = Obstacle.segment_distance_bounds(self, a[redo], b[redo], threshold[redo])
                d[redo] = np.minimum(d[redo], v)
                lower[redo] = lo
        return d.reshape(shape), lower.reshape(shape)


class Obstacle(ABC):
    """A solid obstacle with an exact signed distance."""

    name: str

    @abstractmethod
    def signed_distance(self, points: ArrayLike) -> FloatArray:
        """Signed distance of points ``(..., 3)`` to the solid, shape ``(...)``."""

    @abstractmethod
    def describe(self) -> dict[str, object]:
        """The obstacle's parameters for result files (plain JSON types)."""

    def outward_normal(self, points: ArrayLike, h: float = 1e-4) -> FloatArray:
        """Unit outward normal ``(..., 3)`` at ``points``: the signed distance's gradient by
        central differences of step ``h`` (NaN where the gradient vanishes)."""
        p = np.asarray(points, dtype=np.float64)
        grad = np.stack(
            [
                (self.signed_distance(p + h * e) - self.signed_distance(p - h * e)) / (2 * h)
                for e in np.eye(3)
            ],
            axis=-1,
        )
        norm = np.linalg.norm(grad, axis=-1, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.asarray(np.where(norm >= 1e-9, grad / norm, np.nan), dtype=np.float64)

    def enclosing_ball(self) -> tuple[FloatArray, float] | None:
        """A ball ``(center, radius)`` containing the solid (broad phase), or None if unbounded."""
        return None

    def face_curvature_bound(self, points: ArrayLike, radius: float) -> FloatArray:
        """An upper bound on the normal curvature (per length unit) of the solid's surface
        within ``radius`` of each of ``points (..., 3)``, where one smooth face alone passes
        there; inf where that is not known (an edge or a corner may lie within it, or the
        solid does not say). Outside the solid and within ``r <= radius`` of a point ``p`` of
        that face, a point lies at most ``kappa r^2 / 2`` behind the face's tangent plane at
        ``p``. This default knows nothing: inf."""
        p = np.asarray(points, dtype=np.float64)
        return np.full(p.shape[:-1], np.inf)

    def broad_phase(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """A lower bound of the signed distance of each segment ``a[k] -> b[k]`` (``(K, 3)``
        contiguous), ``(K,)``: the distance to :meth:`enclosing_ball` (-inf: none)."""
        ball = self.enclosing_ball()
        if ball is None:
            return np.full(a.shape[0], -np.inf)
        c = np.ascontiguousarray(np.broadcast_to(ball[0], a.shape))
        return np.asarray(kernels.segments_to_point(a, b, c) - ball[1])

    def enclosing_solid(self) -> Obstacle | None:
        """A cheaper solid containing this one (second broad-phase level), or None."""
        return None

    def segment_distance(self, p0: ArrayLike, p1: ArrayLike) -> FloatArray:
        """Smallest signed distance over segments ``p0 -> p1`` (each ``(..., 3)``).

        A value the segment really attains (see :meth:`segment_distance_bounds`).
        """
        return self.segment_distance_bounds(p0, p1)[0]

    def segment_distance_bounds(
        self, p0: ArrayLike, p1: ArrayLike, certify: ArrayLike = -np.inf
    ) -> tuple[FloatArray, FloatArray]:
        """Smallest signed distance over segments, as ``(value, proven lower bound)``.

        Generic method: every segment is sampled at most :data:`SEGMENT_SAMPLE_SPACING` apart and
        the lowest :data:`REFINED_MINIMA` local minima of the samples are refined by
        golden-section search; ``value`` is the smallest distance found (attained by a point of
        the segment). Because signed distance is 1-Lipschitz, the distance on a piece between two
        samples ``h`` apart is at least ``min(ends) - h / 2``; the smallest such bound is a proven
        lower bound of the true minimum. Pieces whose bound is below ``certify`` (broadcast
        against the segments) are sampled again :data:`FINE_SAMPLE_SPACING` apart, so the bound
        there comes within ``FINE_SAMPLE_SPACING / 2`` of the true distance. Subclasses with a
        closed form override this.
        """
        a = np.asarray(p0, dtype=np.float64)
        b = np.asarray(p1, dtype=np.float64)
        a, b = np.broadcast_arrays(a, b)
        shape = a.shape[:-1]
        a, b = a.reshape(-1, 3), b.reshape(-1, 3)
        threshold = np.broadcast_to(np.asarray(certify, dtype=np.float64), shape).reshape(-1)
        length = np.linalg.norm(b - a, axis=-1)
        n = max(2, int(np.ceil(float(np.max(length, initial=0.0)) / SEGMENT_SAMPLE_SPACING)) + 1)
        t = np.linspace(0.0, 1.0, n)
        d = self.signed_distance(a[:, None, :] + t[:, None] * (b - a)[:, None, :])
        value = np.minimum(d.min(axis=-1), self._refine(a, b, d))
        h = length / (n - 1)
        piece_lower = np.minimum(d[:, :-1], d[:, 1:]) - h[:, None] / 2
        seg, piece = np.nonzero(piece_lower < threshold[:, None])
        if seg.size:
            m = max(2, int(np.ceil(float(h.max()) / FINE_SAMPLE_SPACING)) + 1)
            s = (piece[:, None] + np.linspace(0.0, 1.0, m)[None, :]) / (n - 1)  # (k, m)
            step = max(1, 2_000_000 // m)
            for c in range(0, seg.size, step):
                sg, pc, sc = seg[c : c + step], piece[c : c + step], s[c : c + step]
                fine = self.signed_distance(a[sg, None, :] + sc[..., None] * (b - a)[sg, None, :])
                tight = np.minimum(fine[:, :-1], fine[:, 1:]).min(axis=-1) - h[sg] / (m - 1) / 2
                piece_lower[sg, pc] = np.maximum(piece_lower[sg, pc], tight)
                np.minimum.at(value, sg, fine.min(axis=-1))
        return value.reshape(shape), piece_lower.min(axis=-1).reshape(shape)

    def _refine(self, a: FloatArray, b: FloatArray, d: FloatArray) -> FloatArray:
        """Golden-section search around the lowest local minima of samples ``d`` ``(K, n)``."""
        n = d.shape[1]
        padded = np.concatenate([d[:, :1] + 1.0, d, d[:, -1:] + 1.0], axis=-1)
        is_min = (d <= padded[:, :-2]) & (d <= padded[:, 2:])
        ranked = np.argsort(np.where(is_min, d, np.inf), axis=-1)[:, :REFINED_MINIMA]
        step = 1.0 / (n - 1)
        a_k, b_k = a[:, None, :], b[:, None, :]
        lo = np.clip(ranked * step - step, 0.0, 1.0)
        hi = np.clip(ranked * step + step, 0.0, 1.0)

        def at(s: FloatArray) -> FloatArray:
            return self.signed_distance(a_k + s[..., None] * (b_k - a_k))

        _, f = golden_section_min(at, lo, hi)
        return np.asarray(f.min(axis=-1), dtype=np.float64)


@dataclass(frozen=True, eq=False)
class HalfSpace(Obstacle):
    """The solid ``{x : normal . (x - point) <= 0}``; ``normal`` points into free space."""

    name: str
    point: FloatArray
    normal: FloatArray

    def __post_init__(self) -> None:
        p = np.array(self.point, dtype=np.float64)
        n = np.array(self.normal, dtype=np.float64)
        if p.shape != (3,) or n.shape != (3,) or not np.all(np.isfinite(np.r_[p, n])):
            raise InvalidInputError(f"half-space {self.name!r}: point and normal must be 3-vectors")
        norm = float(np.linalg.norm(n))
        if norm < 1e-12:
            raise InvalidInputError(f"half-space {self.name!r}: normal must be non-zero")
        object.__setattr__(self, "point", p)
        object.__setattr__(self, "normal", n / norm)

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        x = np.asarray(points, dtype=np.float64)
        return np.asarray((x - self.point) @ self.normal, dtype=np.float64)

    def face_curvature_bound(self, points: ArrayLike, radius: float) -> FloatArray:
        """0: a plane does not bend."""
        return np.zeros(np.asarray(points, dtype=np.float64).shape[:-1])

    def segment_distance_bounds(
        self, p0: ArrayLike, p1: ArrayLike, certify: ArrayLike = -np.inf
    ) -> tuple[FloatArray, FloatArray]:
        """Exact: a linear function is smallest at an end point (value = lower bound)."""
        d = np.minimum(self.signed_distance(p0), self.signed_distance(p1))
        return d, d

    def describe(self) -> dict[str, object]:
        return {
            "type": "half_space",
            "name": self.name,
            "point": self.point.tolist(),
            "normal": self.normal.tolist(),
        }


def orthonormal_frame(axis: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Unit vectors ``u``, ``v`` with ``(u, v, axis)`` right-handed, for a unit ``axis``
    ``(3,)`` or a batch ``(..., 3)`` (one call for many: ``np.cross`` costs microseconds per
    call): ``u = axis x h`` normalised (``h`` = x, or y when ``axis`` is close to x),
    ``v = axis x u``."""
    a = np.asarray(axis, dtype=np.float64)
    helper = np.where((np.abs(a[..., :1]) < 0.9), [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(a, helper)
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    return u, np.cross(a, u)


def _vector3(value: ArrayLike, what: str) -> FloatArray:
    v = np.array(value, dtype=np.float64)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise InvalidInputError(f"{what} must be a finite 3-vector, got {value!r}")
    v.setflags(write=False)
    return v


def _positive(value: float, what: str) -> float:
    v = float(value)
    if not (np.isfinite(v) and v > 0):
        raise InvalidInputError(f"{what} must be a positive number, got {value!r}")
    return v


@dataclass(frozen=True, eq=False)
class Sphere(ExactSegmentDistance, Obstacle):
    """A ball of ``radius`` about ``center``."""

    name: str
    center: FloatArray
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector3(self.center, f"sphere {self.name!r} center"))
        object.__setattr__(self, "radius", _positive(self.radius, f"sphere {self.name!r} radius"))

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        x = np.asarray(points, dtype=np.float64)
        return np.asarray(np.linalg.norm(x - self.center, axis=-1) - self.radius)

    def enclosing_ball(self) -> tuple[FloatArray, float]:
        return self.center, self.radius

    def face_curvature_bound(self, points: ArrayLike, radius: float) -> FloatArray:
        """One over the sphere's radius, everywhere."""
        shape = np.asarray(points, dtype=np.float64).shape[:-1]
        return np.full(shape, 1.0 / self.radius)

    def segment_distance_exact(self, p0: FloatArray, p1: FloatArray) -> FloatArray:
        """Exact, also inside: the distance of the segment to the centre less the radius."""
        c = np.ascontiguousarray(np.broadcast_to(self.center, p0.shape))
        return np.asarray(kernels.segments_to_point(p0, p1, c) - self.radius)

    def describe(self) -> dict[str, object]:
        return {
            "type": "sphere",
            "name": self.name,
            "center": self.center.tolist(),
            "radius": self.radius,
        }


@dataclass(frozen=True, eq=False)
class Capsule(ExactSegmentDistance, Obstacle):
    """All points within ``radius`` of the segment ``start -> end``."""

    name: str
    start: FloatArray
    end: FloatArray
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", _vector3(self.start, f"capsule {self.name!r} start"))
        object.__setattr__(self, "end", _vector3(self.end, f"capsule {self.name!r} end"))
        object.__setattr__(self, "radius", _positive(self.radius, f"capsule {self.name!r} radius"))

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        x = np.asarray(points, dtype=np.float64)
        flat = np.ascontiguousarray(x.reshape(-1, 3))
        d = kernels.segments_to_point(
            np.broadcast_to(self.start, flat.shape).copy(),
            np.broadcast_to(self.end, flat.shape).copy(),
            flat,
        )
        return np.asarray(d.reshape(x.shape[:-1]) - self.radius)

    def enclosing_ball(self) -> tuple[FloatArray, float]:
        half = 0.5 * float(np.linalg.norm(self.end - self.start))
        return 0.5 * (self.start + self.end), half + self.radius

    def segment_distance_exact(self, p0: FloatArray, p1: FloatArray) -> FloatArray:
        """Exact, also inside: segment-to-segment distance less the radius."""
        a0 = np.broadcast_to(self.start, p0.shape).copy()
        a1 = np.broadcast_to(self.end, p0.shape).copy()
        return np.asarray(kernels.segment_segment_distance(p0, p1, a0, a1) - self.radius)

    def describe(self) -> dict[str, object]:
        return {
            "type": "capsule",
            "name": self.name,
            "start": self.start.tolist(),
            "end": self.end.tolist(),
            "radius": self.radius,
        }


@dataclass(frozen=True, eq=False)
class Box(ExactSegmentDistance, Obstacle):
    """An oriented box: ``center``, ``half_extents`` along its axes, ``rotation`` (3x3).

    The columns of ``rotation`` are the box axes in world coordinates (identity: axis-aligned).
    """

    name: str
    center: FloatArray
    half_extents: FloatArray
    rotation: FloatArray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector3(self.center, f"box {self.name!r} center"))
        half = _vector3(self.half_extents, f"box {self.name!r} half extents")
        if np.any(half <= 0):
            raise InvalidInputError(f"box {self.name!r}: half extents must be positive")
        object.__setattr__(self, "half_extents", half)
        rot = np.array(self.rotation, dtype=np.float64)
        if rot.shape != (3, 3) or not np.allclose(rot.T @ rot, np.eye(3), atol=1e-9):
            raise InvalidInputError(f"box {self.name!r}: rotation must be a 3x3 rotation matrix")
        if np.linalg.det(rot) < 0:
            raise InvalidInputError(f"box {self.name!r}: rotation must not be a reflection")
        rot = np.ascontiguousarray(rot)
        rot.setflags(write=False)
        object.__setattr__(self, "rotation", rot)

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        x = np.asarray(points, dtype=np.float64)
        local = np.abs((x - self.center) @ self.rotation) - self.half_extents
        outside = np.linalg.norm(np.maximum(local, 0.0), axis=-1)
        inside = np.minimum(local.max(axis=-1), 0.0)
        return np.asarray(outside + inside)

    def enclosing_ball(self) -> tuple[FloatArray, float]:
        return self.center, float(np.linalg.norm(self.half_extents))

    def broad_phase(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """The ball's bound or, where larger, the widest gap between the segment's and the
        box's extents along one box axis: every point's signed distance is at least
        ``|x_i| - h_i`` on each axis ``i`` (box coordinates), and the least of that over a
        segment is the gap (``-h_i`` where the segment crosses the middle plane)."""
        gap = np.full(a.shape[0], -np.inf)
        da, db = a - self.center, b - self.center
        for i in range(3):
            r, h = self.rotation[:, i], self.half_extents[i]
            # (summed in the compiled loop's order, so both give the same numbers)
            e0 = da[:, 0] * r[0] + da[:, 1] * r[1] + da[:, 2] * r[2]
            e1 = db[:, 0] * r[0] + db[:, 1] * r[1] + db[:, 2] * r[2]
            gap = np.maximum(gap, np.maximum(np.minimum(e0, e1) - h, -h - np.maximum(e0, e1)))
            gap = np.maximum(gap, -h)
        return np.asarray(np.maximum(super().broad_phase(a, b), gap))

    def segment_distance_exact(self, p0: FloatArray, p1: FloatArray) -> FloatArray:
        """Exact outside (piecewise quadratic); inside, golden-section search of the convex
        signed distance along the segment."""
        return np.asarray(
            kernels.segments_to_box(p0, p1, self.center, self.rotation, self.half_extents)
        )

    def describe(self) -> dict[str, object]:
        return {
            "type": "box",
            "name": self.name,
            "center": self.center.tolist(),
            "half_extents": self.half_extents.tolist(),
            "rotation": self.rotation.tolist(),
        }


@dataclass(frozen=True, eq=False)
class SolidOfRevolution(ExactSegmentDistance, Obstacle):
    """A closed polygon in the half-plane ``r >= 0`` revolved about an axis.

    Parameters
    ----------
    name:
        Obstacle name used in reports.
    origin:
        A point on the axis; ``z = 0`` of the profile.
    axis:
        Direction of the axis (normalised).
    profile:
        ``(V, 2)`` vertices ``(r, z)`` of a simple closed polygon with ``r >= 0``. Edges with both
        ends on the axis (``r = 0``) are interior in 3-D and are not part of the surface.
    """

    name: str
    origin: FloatArray
    axis: FloatArray
    profile: FloatArray
    exact_inside = False

    def __post_init__(self) -> None:
        o = np.array(self.origin, dtype=np.float64)
        ax = np.array(self.axis, dtype=np.float64)
        prof = np.array(self.profile, dtype=np.float64)
        if o.shape != (3,) or ax.shape != (3,):
            raise InvalidInputError(f"solid {self.name!r}: origin and axis must be 3-vectors")
        if prof.ndim != 2 or prof.shape[1] != 2 or prof.shape[0] < 3:
            raise InvalidInputError(f"solid {self.name!r}: profile must be (V >= 3, 2) (r, z)")
        if not np.all(np.isfinite(prof)) or not np.all(np.isfinite(np.r_[o, ax])):
            raise InvalidInputError(f"solid {self.name!r}: profile, origin and axis must be finite")
        if np.any(prof[:, 0] < 0):
            raise InvalidInputError(f"solid {self.name!r}: profile radii must be >= 0")
        norm = float(np.linalg.norm(ax))
        if norm < 1e-12:
            raise InvalidInputError(f"solid {self.name!r}: axis must be non-zero")
        for arr in (o, prof):
            arr.setflags(write=False)
        object.__setattr__(self, "origin", o)
        object.__setattr__(self, "axis", ax / norm)
        object.__setattr__(self, "profile", prof)

    @property
    def boundary_edges(self) -> NDArray[np.bool_]:
        """Per profile edge, whether it is part of the 3-D surface (not on the axis)."""
        return self._boundary

    @property
    def _boundary(self) -> NDArray[np.bool_]:
        cached = self.__dict__.get("_boundary_cache")
        if cached is None:
            a = self.profile
            b = np.roll(self.profile, -1, axis=0)
            cached = np.ascontiguousarray(~((a[:, 0] == 0.0) & (b[:, 0] == 0.0)))
            cached.setflags(write=False)
            self.__dict__["_boundary_cache"] = cached
        return np.asarray(cached)

    def to_profile_coords(self, points: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Cylindrical coordinates ``(r, z)`` of points about the axis."""
        x = np.asarray(points, dtype=np.float64) - self.origin
        z = x @ self.axis
        radial = x - z[..., None] * self.axis
        return np.linalg.norm(radial, axis=-1), z

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        x = np.asarray(points, dtype=np.float64)
        flat = np.ascontiguousarray(x.reshape(-1, 3))
        d = kernels.points_to_revolution(
            flat, self.origin, self.axis, self.profile, self.boundary_edges
        )
        return np.asarray(d.reshape(x.shape[:-1]), dtype=np.float64)

    def face_curvature_bound(self, points: ArrayLike, radius: float) -> FloatArray:
        """Where one edge of the profile alone lies within ``radius`` of a point (in the
        profile's half-plane, where the distance to a revolved edge is measured), its face is
        a cone, a cylinder or a flat ring, whose normal curvature is at most one over the
        distance from the axis: one over the point's distance less ``radius``; inf where two
        edges (a rim, where faces meet) or the axis lie within it."""
        r, z = self.to_profile_coords(points)
        a = self.profile[self.boundary_edges]
        b = np.roll(self.profile, -1, axis=0)[self.boundary_edges]
        x = np.stack([r, z], axis=-1)[..., None, :]  # (..., 1, 2)
        d = b - a
        t = np.clip(np.sum((x - a) * d, axis=-1) / np.maximum(np.sum(d * d, axis=-1), 1e-300), 0, 1)
        near = np.linalg.norm(x - (a + t[..., None] * d), axis=-1) <= radius  # (..., E)
        alone = (np.sum(near, axis=-1) == 1) & (r > radius)
        with np.errstate(divide="ignore"):
            return np.asarray(np.where(alone, 1.0 / np.maximum(r - radius, 1e-300), np.inf))

    def enclosing_ball(self) -> tuple[FloatArray, float]:
        z = self.profile[:, 1]
        z_mid = 0.5 * float(z.min() + z.max())
        radius = float(np.max(np.hypot(self.profile[:, 0], z - z_mid)))
        return self.origin + z_mid * self.axis, radius

    def segment_distance_exact(self, p0: FloatArray, p1: FloatArray) -> FloatArray:
        """Each segment's own search along it (see :func:`kernels.segments_to_revolution`);
        a batch of :data:`REVOLUTION_THREAD_BATCH` or more is split between the cores."""
        a = np.ascontiguousarray(p0, dtype=np.float64)
        b = np.ascontiguousarray(p1, dtype=np.float64)

        def part(lo: int, hi: int) -> FloatArray:
            return np.asarray(
                kernels.segments_to_revolution(
                    a[lo:hi], b[lo:hi], self.origin, self.axis, self.profile, self.boundary_edges
                ),
                dtype=np.float64,
            )

        return np.concatenate(in_slices(part, a.shape[0], REVOLUTION_THREAD_BATCH))

    def describe(self) -> dict[str, object]:
        return {
            "type": "solid_of_revolution",
            "name": self.name,
            "origin": self.origin.tolist(),
            "axis": self.axis.tolist(),
            "profile_rz": self.profile.tolist(),
        }


class WallThickness(StrEnum):
    """How the wall thickness of a conical vessel is measured."""

    NORMAL = "normal"  # perpendicular to the wall (SPEC default)
    HORIZONTAL = "horizontal"  # along a horizontal line, as in the seed papers


@dataclass(frozen=True, eq=False)
class Opening:
    """A disc through which a hollow solid's inside is entered: its ``center``, unit
    ``normal`` (pointing out of the solid) and ``radius`` (length unit), at the inner wall."""

    center: FloatArray
    normal: FloatArray
    radius: float

    def square_grid(self, spacing: float) -> tuple[FloatArray, FloatArray]:
        """A square grid of ``spacing`` in the disc's plane, centred on it and reaching one
        cell beyond its rim: the offsets ``(N, 2)`` of its points from the centre (along the
        plane's axes :func:`orthonormal_frame` of the normal) and the points ``(N, 3)``."""
        u, v = orthonormal_frame(self.normal)
        k = int(np.ceil(self.radius / spacing)) + 1
        i, j = np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij")
        xy = np.column_stack([i.ravel(), j.ravel()]) * spacing
        points = self.center + xy[:, :1] * u + xy[:, 1:] * v
        return np.asarray(xy, dtype=np.float64), np.asarray(points, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class HollowFrustum(SolidOfRevolution):
    """A hollow truncated cone (open or closed ends); built by :func:`hollow_frustum`."""

    height: float = 0.0
    r_bottom: float = 0.0
    r_top: float = 0.0
    wall: float = 0.0
    wall_thickness: WallThickness = WallThickness.NORMAL
    open_top: bool = True
    closed_bottom: bool = True

    def inner_radius(self, z: ArrayLike) -> FloatArray:
        """Radius of the inner wall surface at height ``z`` above the base."""
        zz = np.asarray(z, dtype=np.float64)
        return self.outer_radius(zz) - self.horizontal_wall

    def outer_radius(self, z: ArrayLike) -> FloatArray:
        zz = np.asarray(z, dtype=np.float64)
        return self.r_bottom + (self.r_top - self.r_bottom) * zz / self.height

    def inner_wall_point(self, x: float, y: float) -> tuple[float, float, float]:
        """The point of the inner wall whose projection along the axis is ``(x, y)``.

        For the usual vertical axis this is the point above ``(x, y)`` on the inner surface:
        its height comes from inverting the inner radius. Raises :class:`InvalidInputError`
        when no point of the inner wall (between the bottom plate and the rim) projects there.
        """
        if not np.allclose(self.axis, [0.0, 0.0, 1.0]):
            raise InvalidInputError(f"{self.name!r}: inner wall points need a vertical axis")
        r = float(np.hypot(x - self.origin[0], y - self.origin[1]))
        slope = (self.r_top - self.r_bottom) / self.height  # dr/dz of the inner wall
        z_lo = self.wall if self.closed_bottom else 0.0
        z_hi = self.height if self.open_top else self.height - self.wall
        z = (r - (self.r_bottom - self.horizontal_wall)) / slope if slope else float("nan")
        if not (np.isfinite(z) and z_lo <= z <= z_hi):
            lo, hi = self.inner_radius(z_hi), self.inner_radius(z_lo)
            raise InvalidInputError(
                f"({x:g}, {y:g}) is {r:.3f} mm from the axis of {self.name!r}; its inner wall "
                f"spans radii {min(lo, hi):.3f} to {max(lo, hi):.3f} mm"
            )
        return (float(x), float(y), float(self.origin[2] + z))

    def outer_wall_point(self, x: float, y: float) -> tuple[float, float, float]:
        """The point of the outer side face whose projection along the (vertical) axis is
        ``(x, y)``: its height from inverting the outer radius. Raises
        :class:`InvalidInputError` when no point of the outer face projects there."""
        if not np.allclose(self.axis, [0.0, 0.0, 1.0]):
            raise InvalidInputError(f"{self.name!r}: outer wall points need a vertical axis")
        r = float(np.hypot(x - self.origin[0], y - self.origin[1]))
        slope = (self.r_top - self.r_bottom) / self.height
        z = (r - self.r_bottom) / slope if slope else float("nan")
        if not (np.isfinite(z) and 0.0 <= z <= self.height):
            lo, hi = sorted((self.r_bottom, self.r_top))
            raise InvalidInputError(
                f"({x:g}, {y:g}) is {r:.3f} mm from the axis of {self.name!r}; its outer face "
                f"spans radii {lo:.3f} to {hi:.3f} mm"
            )
        return (float(x), float(y), float(self.origin[2] + z))

    def hull_side(self, points: ArrayLike, margin: float) -> NDArray[np.int8]:
        """Per point ``(..., 3)``: 1 where every point within ``margin`` of it lies in the
        *hull* (the solid with its inside filled: the outer face and the end planes), -1
        where none does, 0 otherwise. Conservative both ways: the hull's radius is linear in
        the height, so over the heights within ``margin`` it is at least (at most) its value
        at one of their ends."""
        r, z = self.to_profile_coords(points)
        m = float(margin)
        below, above = np.clip(z - m, 0.0, self.height), np.clip(z + m, 0.0, self.height)
        ends = np.stack([self.outer_radius(below), self.outer_radius(above)])
        inside = (z - m >= 0.0) & (z + m <= self.height) & (r + m <= ends.min(axis=0))
        outside = (z + m < 0.0) | (z - m > self.height) | (r - m > ends.max(axis=0))
        return np.where(inside, 1, np.where(outside, -1, 0)).astype(np.int8)

    def openings(self) -> tuple[Opening, ...]:
        """The discs through which the inside is entered: the rim of an open top, the rim of
        an open bottom (each at the inner wall, its normal pointing out along the axis)."""
        out = []
        if self.open_top:
            top = self.origin + self.height * self.axis
            out.append(Opening(top, self.axis.copy(), float(self.inner_radius(self.height))))
        if not self.closed_bottom:
            out.append(Opening(self.origin.copy(), -self.axis, float(self.inner_radius(0.0))))
        return tuple(out)

    @property
    def horizontal_wall(self) -> float:
        """Wall thickness measured horizontally (equals ``wall`` for the horizontal convention)."""
        if self.wall_thickness is WallThickness.HORIZONTAL:
            return self.wall
        slope = (self.r_bottom - self.r_top) / self.height
        return float(self.wall * np.sqrt(1.0 + slope * slope))

    def describe(self) -> dict[str, object]:
        return {
            "type": "hollow_frustum",
            "name": self.name,
            "base_center": self.origin.tolist(),
            "axis": self.axis.tolist(),
            "height": self.height,
            "r_bottom": self.r_bottom,
            "r_top": self.r_top,
            "wall": self.wall,
            "wall_thickness": self.wall_thickness.value,
            "horizontal_wall": self.horizontal_wall,
            "open_top": self.open_top,
            "closed_bottom": self.closed_bottom,
        }


def hollow_frustum(
    name: str,
    base_center: ArrayLike,
    height: float,
    r_bottom: float,
    r_top: float,
    wall: float,
    wall_thickness: WallThickness | str = WallThickness.NORMAL,
    open_top: bool = True,
    closed_bottom: bool = True,
    axis: ArrayLike = (0.0, 0.0, 1.0),
) -> HollowFrustum:
    """A hollow truncated cone: outer radius ``r_bottom`` at the base, ``r_top`` at ``height``.

    The wall is ``wall`` thick, measured normal to the wall or horizontally (``wall_thickness``);
    closed ends are plates of the same thickness. The rim at an open end is cut perpendicular to
    the axis.
    """
    convention = _wall_convention(wall_thickness)
    if not (height > 0 and r_bottom > 0 and r_top > 0 and wall > 0):
        raise InvalidInputError(
            f"hollow frustum {name!r}: height, radii and wall must be positive numbers"
        )
    slope = (r_bottom - r_top) / height
    dh = wall if convention is WallThickness.HORIZONTAL else wall * float(np.sqrt(1 + slope**2))
    if dh >= min(r_bottom, r_top):
        raise InvalidInputError(f"hollow frustum {name!r}: wall {wall} leaves no hollow inside")
    plate = wall
    if (closed_bottom and not open_top and 2 * plate >= height) or plate >= height:
        raise InvalidInputError(f"hollow frustum {name!r}: end plates thicker than the height")

    def r_in(z: float) -> float:
        return r_bottom - slope * z - dh

    z_lo = plate if closed_bottom else 0.0
    z_hi = height - plate if not open_top else height
    profile: list[tuple[float, float]] = []
    profile += [(0.0, 0.0)] if closed_bottom else [(r_in(0.0), 0.0)]
    profile += [(r_bottom, 0.0), (r_top, height)]
    profile += [(r_top - dh, height)] if open_top else [(0.0, height), (0.0, z_hi)]
    profile += [(r_in(z_hi), z_hi)] if not open_top else []
    profile += [(r_in(z_lo), z_lo)]
    profile += [(0.0, z_lo)] if closed_bottom else []
    # drop consecutive duplicates (e.g. open top and bottom)
    pts = [p for i, p in enumerate(profile) if p != profile[i - 1]]
    return HollowFrustum(
        name=name,
        origin=np.asarray(base_center, dtype=np.float64),
        axis=np.asarray(axis, dtype=np.float64),
        profile=np.array(pts),
        height=float(height),
        r_bottom=float(r_bottom),
        r_top=float(r_top),
        wall=float(wall),
        wall_thickness=convention,
        open_top=open_top,
        closed_bottom=closed_bottom,
    )


def _wall_convention(value: WallThickness | str) -> WallThickness:
    try:
        return WallThickness(value)
    except ValueError:
        valid = ", ".join(repr(w.value) for w in WallThickness)
        raise InvalidInputError(
            f"wall thickness convention must be one of {valid}, got {value!r}"
        ) from None


def cone_frustum(
    name: str,
    base_center: ArrayLike,
    axis: ArrayLike,
    r_bottom: float,
    r_top: float,
    height: float,
) -> SolidOfRevolution:
    """A solid truncated cone: radius ``r_bottom`` at ``base_center``, ``r_top`` at ``height``
    along ``axis``. Either radius may be 0 (a cone)."""
    h = _positive(height, f"cone frustum {name!r} height")
    rb, rt = float(r_bottom), float(r_top)
    if not (np.isfinite(rb) and np.isfinite(rt) and rb >= 0 and rt >= 0 and rb + rt > 0):
        raise InvalidInputError(f"cone frustum {name!r}: radii must be >= 0, not both 0")
    profile = [(0.0, 0.0), (rb, 0.0), (rt, h), (0.0, h)]
    pts = [p for i, p in enumerate(profile) if p != profile[i - 1]]
    return SolidOfRevolution(name, np.asarray(base_center), np.asarray(axis), np.array(pts))


def cylinder(
    name: str, base_center: ArrayLike, axis: ArrayLike, radius: float, height: float
) -> SolidOfRevolution:
    """A solid cylinder of ``radius`` from ``base_center`` to ``height`` along ``axis``."""
    r = _positive(radius, f"cylinder {name!r} radius")
    return cone_frustum(name, base_center, axis, r, r, height)
