"""Conservative enclosing proxies of a point set (mesh vertices) for a fast broad phase.

Each proxy contains every input point, so its signed distance is a lower bound of the signed
distance to any solid spanned by the points (the solid is a subset of the proxy):

* :func:`enclosing_sphere` — the exact minimum enclosing sphere (Welzl's incremental algorithm).
* :func:`enclosing_cylinder` — a small-volume enclosing cylinder: axis direction from
  :func:`trimesh.bounds.minimum_cylinder` (a local optimisation, not a proven global minimum),
  then the exact smallest radius and height about that direction.
* :func:`enclosing_frustum` — the smallest-volume enclosing truncated cone about an axis (by
  default the cylinder's axis): its side line is tangent to the upper convex hull of the points'
  ``(h, r)`` cylindrical coordinates.

Lengths are in the points' unit. The fits are returned as named tuples (they unpack like plain
tuples); ``.solid(name)`` turns each into an obstacle of :mod:`armpath.geometry.primitives`
(:class:`~armpath.geometry.primitives.Sphere`, :func:`~armpath.geometry.primitives.cylinder`,
:func:`~armpath.geometry.primitives.cone_frustum`).
After every fit the radius (or both radii) is raised by the largest measured violation, so the
returned proxy contains every point as evaluated in floating point.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import trimesh
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import ConvexHull, QhullError

from armpath.errors import InvalidInputError
from armpath.geometry.primitives import SolidOfRevolution, Sphere, cone_frustum, cylinder

FloatArray = NDArray[np.float64]

#: Relative tolerance (times the point set's extent) below which a point counts as on a ball.
_BALL_TOLERANCE = 1e-12
#: Fixed seed of the random insertion order of Welzl's algorithm (results are reproducible).
_WELZL_SEED = 20240229


# --------------------------------------------------------------------------------------------
# fits
# --------------------------------------------------------------------------------------------


class SphereFit(NamedTuple):
    """Enclosing sphere: ``center`` ``(3,)`` and ``radius`` (length unit)."""

    center: FloatArray
    radius: float

    def solid(self, name: str) -> Sphere:
        """The sphere as an obstacle (needs a positive radius: at least two distinct points)."""
        return Sphere(name, self.center, self.radius)


class CylinderFit(NamedTuple):
    """Enclosing cylinder.

    ``origin`` ``(3,)`` is the centre of the bottom cap, ``axis`` ``(3,)`` the unit direction
    from the bottom to the top cap; ``radius`` and ``height`` are in the length unit.
    """

    origin: FloatArray
    axis: FloatArray
    radius: float
    height: float

    def solid(self, name: str) -> SolidOfRevolution:
        """The cylinder as a solid of revolution (a rectangular ``(r, z)`` profile)."""
        return cylinder(name, self.origin, self.axis, self.radius, self.height)

    @property
    def volume(self) -> float:
        """Volume (length unit cubed)."""
        return float(np.pi * self.radius**2 * self.height)


class FrustumFit(NamedTuple):
    """Enclosing truncated cone.

    ``origin`` ``(3,)`` is the centre of the bottom cap, ``axis`` ``(3,)`` the unit direction
    towards the top cap; the radius is ``r_bottom`` at the origin and ``r_top`` at ``height``
    along the axis (both ``>= 0``, length unit).
    """

    origin: FloatArray
    axis: FloatArray
    r_bottom: float
    r_top: float
    height: float

    def solid(self, name: str) -> SolidOfRevolution:
        """The frustum as a solid of revolution."""
        return cone_frustum(name, self.origin, self.axis, self.r_bottom, self.r_top, self.height)

    @property
    def volume(self) -> float:
        """Volume (length unit cubed)."""
        rb, rt = self.r_bottom, self.r_top
        return float(np.pi / 3.0 * self.height * (rb * rb + rb * rt + rt * rt))


@dataclass(frozen=True)
class MeshProxies:
    """The three enclosing proxies of one point set (each contains every point)."""

    sphere: Sphere
    cylinder: SolidOfRevolution
    frustum: SolidOfRevolution


# --------------------------------------------------------------------------------------------
# public functions
# --------------------------------------------------------------------------------------------


def enclosing_sphere(points: ArrayLike) -> SphereFit:
    """The minimum enclosing sphere of points ``(N, 3)``.

    Welzl's randomized incremental algorithm (fixed seed, expected linear time) on the vertices
    of the convex hull; the result is the unique smallest ball up to a relative tolerance of
    about 1e-12 of the set's extent. The radius is finally set to the largest distance from the
    centre to any point, so every point is inside.

    Returns
    -------
    SphereFit
        ``(center (3,), radius)`` in the points' length unit.
    """
    pts = _check_points(points, "enclosing sphere", minimum=1)
    hull = _hull_points(pts)
    center = _minimum_ball(hull)
    radius = float(np.max(np.linalg.norm(pts - center, axis=-1)))
    return SphereFit(center, radius)


def enclosing_cylinder(points: ArrayLike) -> CylinderFit:
    """A small-volume cylinder enclosing points ``(N, 3)``.

    The axis direction is that of :func:`trimesh.bounds.minimum_cylinder` (sampled directions
    refined by local optimisation: small, not proven globally minimal). About that direction the
    radius is the exact minimum (smallest enclosing circle of the points projected on the plane
    normal to the axis) and the height is the exact extent along it.

    Returns
    -------
    CylinderFit
        ``(origin, axis, radius, height)``: centre of the bottom cap, unit axis, length unit.

    Raises
    ------
    InvalidInputError
        If the points do not span a volume (fewer than 4 points or all coplanar).
    """
    pts = _check_points(points, "enclosing cylinder", minimum=4)
    _require_volume(pts, "enclosing cylinder")
    try:
        fit = trimesh.bounds.minimum_cylinder(pts)  # type: ignore[no-untyped-call]
    except (ValueError, QhullError) as exc:  # pragma: no cover - degenerate input caught above
        raise InvalidInputError(f"enclosing cylinder: trimesh could not fit one ({exc})") from exc
    axis = _unit(np.asarray(fit["transform"], dtype=np.float64)[:3, 2])
    origin, radius, height = _cylinder_about(pts, axis)
    return CylinderFit(origin, axis, radius, height)


def enclosing_frustum(points: ArrayLike, axis: ArrayLike | None = None) -> FrustumFit:
    """The smallest-volume truncated cone about an axis enclosing points ``(N, 3)``.

    The axis line has direction ``axis`` (default: that of :func:`enclosing_cylinder`) and
    passes through the centre of the smallest circle enclosing the points projected on the plane
    normal to it. With ``h`` the height along the axis and ``r`` the distance from it, the side
    of the frustum is the line ``r = a + b h`` lying above every ``(h, r)`` that minimises the
    volume between ``h_min`` and ``h_max``. The volume is a convex quadratic of the end radii
    and the line must touch the upper convex hull of the ``(h, r)`` points, so the optimum is
    found exactly by minimising over the lines through each hull vertex (slope clamped to the
    vertex's supporting range). Both radii are ``>= 0``; one may be 0 (a cone).

    Parameters
    ----------
    points:
        ``(N, 3)`` points (length unit).
    axis:
        Direction ``(3,)`` of the frustum's axis (any non-zero length), or ``None``.

    Returns
    -------
    FrustumFit
        ``(origin, axis, r_bottom, r_top, height)``: centre of the bottom cap, unit axis from
        the bottom (radius ``r_bottom``) to the top (radius ``r_top``), length unit.

    Raises
    ------
    InvalidInputError
        If the points have no extent along the axis or do not span a volume (default axis), or
        the axis is not a finite non-zero 3-vector.
    """
    pts = _check_points(points, "enclosing frustum", minimum=1)
    if axis is None:
        direction = enclosing_cylinder(pts).axis
    else:
        raw = np.asarray(axis, dtype=np.float64)
        if raw.shape != (3,) or not np.all(np.isfinite(raw)) or np.linalg.norm(raw) < 1e-300:
            raise InvalidInputError(
                f"enclosing frustum: axis must be a finite non-zero 3-vector, got {axis!r}"
            )
        direction = _unit(raw)
    origin, _, height = _cylinder_about(pts, direction)

    def profile_coords(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        rel = x - origin
        h = rel @ direction
        radial = np.linalg.norm(rel - h[:, None] * direction, axis=-1)
        return np.clip(h / height, 0.0, 1.0), radial

    # a frustum is convex: containing the hull vertices is containing every point
    r_bottom, r_top = _best_frustum_line(*profile_coords(_hull_points(pts)))
    s, r = profile_coords(pts)
    # raise the side line by the largest floating-point violation (containment as evaluated)
    excess = float(np.max(r - (r_bottom * (1.0 - s) + r_top * s)))
    if excess > 0:
        r_bottom += excess
        r_top += excess
    return FrustumFit(origin, direction, r_bottom, r_top, height)


def enclosing_proxies(points: ArrayLike, name: str) -> MeshProxies:
    """The sphere, cylinder and frustum proxies of points ``(N, 3)`` as obstacles.

    The obstacles are named ``f"{name} sphere"``, ``f"{name} cylinder"`` and
    ``f"{name} frustum"``; the frustum uses the cylinder's axis.
    """
    pts = _check_points(points, "enclosing proxies", minimum=4)
    cyl = enclosing_cylinder(pts)
    return MeshProxies(
        sphere=enclosing_sphere(pts).solid(f"{name} sphere"),
        cylinder=cyl.solid(f"{name} cylinder"),
        frustum=enclosing_frustum(pts, cyl.axis).solid(f"{name} frustum"),
    )


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def _check_points(points: ArrayLike, what: str, minimum: int) -> FloatArray:
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < minimum:
        raise InvalidInputError(
            f"{what}: points must be an (N >= {minimum}, 3) array, got shape {pts.shape}"
        )
    if not np.all(np.isfinite(pts)):
        raise InvalidInputError(f"{what}: points must be finite (no NaN or inf)")
    return pts


def _require_volume(pts: FloatArray, what: str) -> None:
    centred = pts - pts.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    if sv[0] == 0 or sv[-1] <= 1e-12 * sv[0]:
        raise InvalidInputError(
            f"{what}: the points are coplanar, collinear or coincident; a cylinder or frustum "
            "proxy needs points spanning a volume"
        )


def _unit(v: FloatArray) -> FloatArray:
    return np.asarray(v / np.linalg.norm(v), dtype=np.float64)


def _hull_points(pts: FloatArray) -> FloatArray:
    """Vertices of the convex hull (all points if the hull is degenerate or tiny)."""
    if pts.shape[0] <= pts.shape[1] + 1:
        return pts
    try:
        hull = ConvexHull(pts)
    except (QhullError, ValueError):
        return pts
    return np.asarray(pts[hull.vertices])


def _plane_basis(axis: FloatArray) -> FloatArray:
    """Two unit vectors ``(2, 3)`` orthogonal to ``axis`` and to each other."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    u = _unit(np.cross(axis, helper))
    return np.stack([u, np.cross(axis, u)])


def _cylinder_about(pts: FloatArray, axis: FloatArray) -> tuple[FloatArray, float, float]:
    """Bottom-cap centre, exact minimum radius and height of the cylinder along ``axis``."""
    basis = _plane_basis(axis)
    flat = pts @ basis.T
    center_2d = _minimum_ball(_hull_points_2d(flat))
    h = pts @ axis
    h_min, h_max = float(h.min()), float(h.max())
    height = h_max - h_min
    if not height > 0:
        raise InvalidInputError(
            "enclosing cylinder/frustum: the points have no extent along the axis "
            f"{axis.tolist()}; they must span a volume"
        )
    origin = center_2d @ basis + h_min * axis
    rel = pts - origin
    radial = rel - (rel @ axis)[:, None] * axis
    radius = float(np.max(np.linalg.norm(radial, axis=-1)))
    return np.asarray(origin, dtype=np.float64), radius, height


def _hull_points_2d(flat: FloatArray) -> FloatArray:
    if flat.shape[0] <= 3:
        return flat
    try:
        hull = ConvexHull(flat)
    except (QhullError, ValueError):
        return flat
    return np.asarray(flat[hull.vertices])


def _minimum_ball(pts: FloatArray) -> FloatArray:
    """Centre of the smallest ball enclosing ``pts`` ``(N, d)`` (Welzl, incremental form).

    The points are visited in a random (seeded) order; whenever a point lies outside the current
    ball, the ball is recomputed as the smallest one that has that point on its boundary and
    contains all points visited before it. Recursion depth is at most ``d + 1``.
    """
    order = np.random.default_rng(_WELZL_SEED).permutation(pts.shape[0])
    shuffled = np.ascontiguousarray(pts[order])
    extent = float(np.max(np.ptp(shuffled, axis=0), initial=0.0))
    tol = _BALL_TOLERANCE * max(extent, np.finfo(np.float64).tiny)
    center, _ = _ball_with_support(shuffled, shuffled.shape[0], [], tol)
    return center


def _ball_with_support(
    pts: FloatArray, n: int, support: list[FloatArray], tol: float
) -> tuple[FloatArray, float]:
    """Smallest ball containing ``pts[:n]`` with every point of ``support`` on its boundary."""
    dim = pts.shape[1]
    if support:
        center, radius = _circumball(np.stack(support))
        start = 0
    else:
        center, radius = pts[0].copy(), 0.0
        start = 1
    if len(support) == dim + 1:
        return center, radius
    while start < n:
        dist = np.linalg.norm(pts[start:n] - center, axis=-1)
        outside = np.flatnonzero(dist > radius + tol)
        if outside.size == 0:
            break
        k = start + int(outside[0])
        center, radius = _ball_with_support(pts, k, [*support, pts[k]], tol)
        start = k + 1
    return center, radius


def _circumball(support: FloatArray) -> tuple[FloatArray, float]:
    """Smallest ball with all ``support`` points ``(k, d)`` (``k <= d + 1``) on its boundary.

    Its centre lies in the affine hull of the points: ``c = p0 + Q^T lam`` with
    ``Q = p_i - p0``, and ``|c - p_i| = |c - p0|`` gives ``2 Q Q^T lam = |Q|^2``. Degenerate
    (affinely dependent) sets are solved in the least-squares sense.
    """
    p0 = support[0]
    if support.shape[0] == 1:
        return p0.copy(), 0.0
    q = support[1:] - p0
    gram = 2.0 * (q @ q.T)
    rhs = np.sum(q * q, axis=-1)
    lam = np.linalg.lstsq(gram, rhs, rcond=None)[0]
    center = p0 + lam @ q
    radius = float(np.max(np.linalg.norm(support - center, axis=-1)))
    return np.asarray(center, dtype=np.float64), radius


def _best_frustum_line(s: FloatArray, r: FloatArray) -> tuple[float, float]:
    """End radii ``(R0, R1)`` of the line above all ``(s, r)`` (``s`` in [0, 1]) of least volume.

    The frustum volume is proportional to ``f = R0^2 + R0 R1 + R1^2`` (convex, increasing for
    non-negative radii). A line through upper-hull vertex ``(s_v, r_v)`` with slope ``m`` has
    ``R0 = r_v - m s_v`` and ``R1 = r_v + m (1 - s_v)``; ``f`` is then a convex quadratic in
    ``m`` minimised at ``m* = -3 r_v (t - s_v) / (2 (s_v^2 - s_v t + t^2))`` with ``t = 1 - s_v``,
    clamped to the slopes of the hull edges on either side of the vertex.
    """
    hull = _upper_hull(s, r)
    hs, hr = hull[:, 0], hull[:, 1]
    slopes = np.diff(hr) / np.diff(hs) if hull.shape[0] > 1 else np.empty(0)
    m_left = np.concatenate([[np.inf], slopes])  # slope of the edge arriving at each vertex
    m_right = np.concatenate([slopes, [-np.inf]])  # slope of the edge leaving each vertex
    t = 1.0 - hs
    m_star = -3.0 * hr * (t - hs) / (2.0 * (hs * hs - hs * t + t * t))
    m = np.clip(m_star, m_right, m_left)
    r0 = hr - m * hs
    r1 = hr + m * t
    f = r0 * r0 + r0 * r1 + r1 * r1
    best = int(np.argmin(f))
    return max(float(r0[best]), 0.0), max(float(r1[best]), 0.0)


def _upper_hull(s: FloatArray, r: FloatArray) -> FloatArray:
    """Upper convex hull ``(V, 2)`` of points ``(s, r)``, left to right, one point per ``s``."""
    order = np.lexsort((r, s))
    ss, rr = s[order], r[order]
    keep = np.r_[ss[1:] != ss[:-1], True]  # the largest r of each distinct s
    pts = np.column_stack([ss[keep], rr[keep]])
    hull: list[FloatArray] = []
    for p in pts:
        while len(hull) >= 2:
            o, a = hull[-2], hull[-1]
            cross = (a[0] - o[0]) * (p[1] - o[1]) - (a[1] - o[1]) * (p[0] - o[0])
            if cross >= 0:  # a is below or on the chord o -> p: not an upper-hull vertex
                hull.pop()
            else:
                break
        hull.append(p)
    return np.array(hull)
