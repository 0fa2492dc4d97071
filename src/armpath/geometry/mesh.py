"""Closed triangle meshes (STL, OBJ, ...) as obstacles.

:class:`MeshObstacle` is a watertight, consistently oriented triangle mesh with

* an exact signed distance of points: the Euclidean distance to the nearest triangle, negative
  inside. Inside/outside is decided by the generalized winding number (the sum of the solid
  angles of the triangles seen from the point, over 4π: 1 inside, 0 outside). Both come from
  one compiled (numba) loop over all points × all triangles: ``O(points × triangles)``.
* an exact smallest distance of segments to the mesh when a segment is clear of it, computed by
  coal (a radius-0 :class:`coal.Capsule` against an OBBRSS bounding-volume hierarchy of the
  mesh); segments that touch or enter the solid fall back to sampling (see
  :meth:`MeshObstacle.segment_distance_bounds`).
* an optional broad phase by its minimum enclosing sphere (:mod:`armpath.geometry.proxies`).

Lengths are in the mesh's unit after ``scale`` (:func:`load_mesh`); nothing is converted.
trimesh's own ``proximity.signed_distance`` is not used: it needs the optional ``rtree``
package and returns positive values inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import check_time
from armpath.errors import InvalidInputError
from armpath.jit import njit, prange, threads_pay_off

try:
    import coal  # type: ignore[import-untyped]
    import trimesh
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ImportError(
        "mesh obstacles need the optional packages trimesh and coal: pip install 'armpath[mesh]'"
    ) from exc
from armpath.geometry.primitives import (
    ROUNDING_ALLOWANCE,
    TOUCHING,
    Obstacle,
    Sphere,
)
from armpath.geometry.proxies import MeshProxies, enclosing_proxies, enclosing_sphere

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: File suffixes :func:`load_mesh` accepts (read by trimesh).
MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off", ".glb", ".gltf")
#: Point-triangle pairs from which the point kernel runs on several threads.
_PARALLEL_PAIRS = 1 << 17
#: Points sampled along a segment that touches or enters the mesh (its attained value).
QUICK_SAMPLES = 9
#: Batches of segments smaller than this get their coal frames from plain-float arithmetic.
_SMALL_BATCH = 16
#: GJK tolerance handed to coal.
_GJK_TOLERANCE = 1e-9
#: Relative allowance subtracted from coal's distance for the proven lower bound: the distance
#: is at most this fraction of ``(distance + bounding radius)`` above the true one.
_COAL_RELATIVE_ERROR = 1e-8


@dataclass(frozen=True, eq=False)
class MeshObstacle(Obstacle):
    """A closed triangle mesh as a solid obstacle.

    Parameters
    ----------
    name:
        Obstacle name used in reports.
    vertices:
        ``(V, 3)`` vertex positions in the scene's length unit. Duplicate vertices are merged
        on construction, so the stored array may be shorter than the one given.
    faces:
        ``(F, 3)`` vertex indices of the triangles. The mesh must be watertight (every edge
        shared by exactly two triangles) and consistently wound; faces wound inward are flipped
        so the normals point out.
    source:
        Path of the file the mesh was read from, or ``None``.
    broad_phase_cutoff:
        Segments whose distance to the enclosing sphere exceeds this (length unit) are not
        sent to coal; ``inf`` (default) always computes the exact distance. See
        :meth:`segment_distance_bounds`.

    Raises
    ------
    InvalidInputError
        For empty, non-finite, non-watertight or inconsistently wound meshes.
    """

    name: str
    vertices: FloatArray
    faces: IntArray
    source: str | None = None
    broad_phase_cutoff: float = math.inf
    bounding_sphere: Sphere = field(init=False, repr=False)
    _bvh: coal.BVHModelOBBRSS = field(init=False, repr=False)

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=np.float64)
        f = np.asarray(self.faces)
        label = f"mesh {self.name!r}" + (f" ({self.source})" if self.source else "")
        if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
            raise InvalidInputError(
                f"{label}: vertices must be (V, 3) and faces (F, 3), got {v.shape} and {f.shape}"
            )
        if v.shape[0] == 0 or f.shape[0] == 0:
            raise InvalidInputError(f"{label}: the mesh is empty (no vertices or no triangles)")
        if not np.all(np.isfinite(v)):
            raise InvalidInputError(f"{label}: vertices must be finite (no NaN or inf)")
        if not np.issubdtype(f.dtype, np.integer) or f.min() < 0 or f.max() >= v.shape[0]:
            raise InvalidInputError(
                f"{label}: faces must be integer indices in [0, {v.shape[0] - 1}]"
            )
        if not (self.broad_phase_cutoff == math.inf or np.isfinite(self.broad_phase_cutoff)):
            raise InvalidInputError(
                f"{label}: broad_phase_cutoff must be a number or inf, "
                f"got {self.broad_phase_cutoff}"
            )
        mesh = trimesh.Trimesh(vertices=v, faces=f, process=True, validate=False)
        tri = np.asarray(mesh.faces)
        distinct = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
        if not np.all(distinct):  # triangles collapsed to an edge or point by merged vertices
            mesh.update_faces(distinct)
            mesh.remove_unreferenced_vertices()
        if len(mesh.faces) == 0:
            raise InvalidInputError(f"{label}: every triangle is degenerate (repeated corners)")
        if not mesh.is_watertight:
            raise InvalidInputError(
                f"{label}: the mesh is not watertight (some edges do not join exactly two "
                "triangles); a signed distance needs a closed surface: close the holes "
                "(e.g. trimesh's fill_holes) or export the part as a closed solid"
            )
        if not mesh.is_winding_consistent:
            raise InvalidInputError(
                f"{label}: the triangles are not consistently wound; fix the normals "
                "(e.g. trimesh's fix_normals) before using it as an obstacle"
            )
        faces = np.asarray(mesh.faces, dtype=np.int64)
        if mesh.volume < 0:  # wound inward: flip every triangle
            faces = faces[:, ::-1].copy()
        verts = np.asarray(mesh.vertices, dtype=np.float64).copy()
        verts.setflags(write=False)
        faces.setflags(write=False)
        object.__setattr__(self, "vertices", verts)
        object.__setattr__(self, "faces", faces)
        object.__setattr__(self, "broad_phase_cutoff", float(self.broad_phase_cutoff))
        fit = enclosing_sphere(verts)
        object.__setattr__(self, "bounding_sphere", fit.solid(f"{self.name} sphere"))
        object.__setattr__(self, "_bvh", _build_bvh(verts, faces))

    # ---------------------------------------------------------------------------------------
    # construction
    # ---------------------------------------------------------------------------------------

    @classmethod
    def from_trimesh(
        cls,
        mesh: trimesh.Trimesh,
        name: str,
        source: str | None = None,
        broad_phase_cutoff: float = math.inf,
    ) -> MeshObstacle:
        """An obstacle from a :class:`trimesh.Trimesh` (its vertices and faces are copied)."""
        if not isinstance(mesh, trimesh.Trimesh):
            raise InvalidInputError(
                f"mesh {name!r}: expected a trimesh.Trimesh, got {type(mesh).__name__}"
            )
        return cls(
            name=name,
            vertices=np.asarray(mesh.vertices, dtype=np.float64),
            faces=np.asarray(mesh.faces, dtype=np.int64),
            source=source,
            broad_phase_cutoff=broad_phase_cutoff,
        )

    def to_trimesh(self) -> trimesh.Trimesh:
        """A new :class:`trimesh.Trimesh` of the obstacle (outward normals)."""
        return trimesh.Trimesh(vertices=self.vertices.copy(), faces=self.faces.copy())

    # ---------------------------------------------------------------------------------------
    # pickling: the coal hierarchy is rebuilt rather than serialized
    # ---------------------------------------------------------------------------------------

    def __getstate__(self) -> dict[str, object]:
        state = dict(self.__dict__)
        state.pop("_bvh", None)
        state.pop("_proxies", None)
        state.pop("_triangles", None)
        state.pop("_bounds", None)
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        object.__setattr__(self, "_bvh", _build_bvh(self.vertices, self.faces))

    # ---------------------------------------------------------------------------------------
    # distances
    # ---------------------------------------------------------------------------------------

    def signed_distance(self, points: ArrayLike) -> FloatArray:
        """Exact signed distance of points ``(..., 3)`` to the solid, shape ``(...)``.

        Negative inside. The magnitude is the distance to the nearest triangle; the sign comes
        from the generalized winding number (inside where it exceeds 1/2). Cost
        ``O(points × triangles)`` in a compiled loop (about 60 ns per point-triangle pair on
        one core of the development machine: 30 µs per point for 512 triangles).
        """
        x = np.asarray(points, dtype=np.float64)
        if x.shape[-1:] != (3,):
            raise InvalidInputError(f"mesh {self.name!r}: points must be (..., 3), got {x.shape}")
        flat = np.ascontiguousarray(x.reshape(-1, 3))
        tri, centre, reach = self._triangles
        # outside the bounding box is outside: no winding number needed there
        lo, hi = self._bounds
        in_box = np.all((flat >= lo) & (flat <= hi), axis=-1)
        dist, winding = _points_to_triangles(flat, tri, centre, reach, True, in_box)
        return np.asarray(np.where(winding > 0.5, -dist, dist).reshape(x.shape[:-1]))

    def contains(self, points: ArrayLike) -> NDArray[np.bool_]:
        """Whether points ``(..., 3)`` lie inside the solid (winding number > 1/2), ``(...)``.

        Points outside the mesh's bounding box are outside without further work; the rest cost
        ``O(triangles)`` each. Points on the surface may go either way.
        """
        x = np.asarray(points, dtype=np.float64)
        if x.shape[-1:] != (3,):
            raise InvalidInputError(f"mesh {self.name!r}: points must be (..., 3), got {x.shape}")
        flat = x.reshape(-1, 3)
        lo, hi = self._bounds
        out = np.zeros(flat.shape[0], dtype=bool)
        candidates = np.flatnonzero(np.all((flat >= lo) & (flat <= hi), axis=-1))
        if candidates.size:
            pts = np.ascontiguousarray(flat[candidates])
            tri, centre, reach = self._triangles
            every = np.ones(pts.shape[0], dtype=bool)
            out[candidates] = _points_to_triangles(pts, tri, centre, reach, False, every)[1] > 0.5
        return out.reshape(x.shape[:-1])

    def segment_distance_bounds(
        self, p0: ArrayLike, p1: ArrayLike, certify: ArrayLike = -np.inf
    ) -> tuple[FloatArray, FloatArray]:
        """Smallest signed distance over segments ``p0 -> p1`` as ``(value, lower bound)``.

        Segments (each ``(..., 3)``, broadcast; length unit) are handled in three ways:

        * **Clear of the mesh** (the usual case): coal gives the exact distance from the segment
          to the surface; when it exceeds :data:`~armpath.geometry.primitives.TOUCHING` and the
          segment starts outside, that is the value. The lower bound is the value less
          :data:`~armpath.geometry.primitives.ROUNDING_ALLOWANCE` and a relative allowance of
          ``1e-8 × (value + bounding radius)`` for coal's GJK tolerance.
        * **Touching or inside** (the segment meets the surface or lies in the solid): the
          value is a negative (or touching) distance the segment attains — the least of the
          signed distances at :data:`QUICK_SAMPLES` evenly spaced points and 0 where the
          segment crosses the surface — but not necessarily the deepest, so the lower bound is
          ``-inf``, as for the analytic solids whose kernels are exact outside only. Where
          ``certify`` (broadcast against the segments) is above ``-inf``, the generic certified
          sampling of :meth:`Obstacle.segment_distance_bounds` supplies the value (if lower)
          and a proven lower bound instead.
        * **Broad phase** (only with a finite :attr:`broad_phase_cutoff`): if the distance
          ``s`` from the segment to the enclosing sphere exceeds the cutoff and is at least
          ``certify``, coal is skipped; the lower bound is ``s`` less the rounding allowance
          (the mesh lies inside the sphere) and the value is the mesh's signed distance at the
          segment point nearest the sphere's centre: attained by the segment, but only an
          upper estimate of its minimum.

        Cost: one coal query per segment in a Python loop (about 25-30 µs per segment in
        batches for a 512-triangle mesh on the development machine, growing roughly with the
        logarithm of the triangle count), plus the compiled ``O(triangles)`` inside test of
        :meth:`contains` for segments starting inside the mesh's bounding box; a
        single-segment call costs about 100 µs in all (numpy overhead). Touching segments cost
        :data:`QUICK_SAMPLES` point evaluations each, and many more when certified.
        """
        a = np.asarray(p0, dtype=np.float64)
        b = np.asarray(p1, dtype=np.float64)
        a, b = np.broadcast_arrays(a, b)
        if a.shape[-1:] != (3,):
            raise InvalidInputError(
                f"mesh {self.name!r}: segment end points must be (..., 3), got {a.shape}"
            )
        shape = a.shape[:-1]
        a, b = np.ascontiguousarray(a.reshape(-1, 3)), np.ascontiguousarray(b.reshape(-1, 3))
        threshold = np.broadcast_to(np.asarray(certify, dtype=np.float64), shape).reshape(-1)
        value = np.empty(a.shape[0])
        lower = np.empty(a.shape[0])

        sphere = self.bounding_sphere
        far = np.zeros(a.shape[0], dtype=bool)
        if self.broad_phase_cutoff < math.inf:
            proxy = sphere.segment_distance_exact(a, b)
            far = (proxy > self.broad_phase_cutoff) & (proxy >= threshold)
            if np.any(far):
                lower[far] = proxy[far] - ROUNDING_ALLOWANCE
                nearest = _closest_on_segments(sphere.center, a[far], b[far])
                value[far] = self.signed_distance(nearest)

        near = np.flatnonzero(~far)
        if near.size:
            surface = self._surface_distance(a[near], b[near])
            clear = surface > TOUCHING
            clear[clear] = ~self.contains(a[near[clear]])
            exact = near[clear]
            value[exact] = surface[clear]
            allowance = ROUNDING_ALLOWANCE + _COAL_RELATIVE_ERROR * (surface[clear] + sphere.radius)
            lower[exact] = surface[clear] - allowance
            deep = near[~clear]
            if deep.size:
                t = np.linspace(0.0, 1.0, QUICK_SAMPLES)
                ad, bd = a[deep], b[deep]
                samples = self.signed_distance(ad[:, None, :] + t[:, None] * (bd - ad)[:, None, :])
                # a segment crossing the surface attains 0; one within TOUCHING attains that
                value[deep] = np.minimum(samples.min(axis=-1), np.maximum(surface[~clear], 0.0))
                lower[deep] = -np.inf
                redo = deep[threshold[deep] > -np.inf]
                if redo.size:
                    generic = Obstacle.segment_distance_bounds
                    v, lo = generic(self, a[redo], b[redo], threshold[redo])
                    value[redo] = np.minimum(value[redo], v)
                    lower[redo] = np.minimum(lo, value[redo])
        return value.reshape(shape), lower.reshape(shape)

    def _surface_distance(self, a: FloatArray, b: FloatArray) -> FloatArray:
        """Unsigned distance from segments ``a -> b`` ``(K, 3)`` to the surface (coal).

        Exact (up to GJK tolerance) when positive; ``<= 0`` when the segment meets a triangle.
        """
        rot, half = _segment_frames(a, b)
        mid = 0.5 * (a + b)
        capsule = coal.Capsule(0.0, 0.0)
        request = coal.DistanceRequest()
        request.gjk_tolerance = _GJK_TOLERANCE
        identity = coal.Transform3s()
        out = np.empty(a.shape[0])
        for k in range(a.shape[0]):
            if k % 256 == 255:
                check_time("measuring distances to a mesh")
            capsule.halfLength = float(half[k])
            result = coal.DistanceResult()
            out[k] = coal.distance(
                capsule, coal.Transform3s(rot[k], mid[k]), self._bvh, identity, request, result
            )
        return out

    # ---------------------------------------------------------------------------------------
    # proxies and reporting
    # ---------------------------------------------------------------------------------------

    @cached_property
    def _triangles(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Corners ``(F, 3, 3)``, centroids ``(F, 3)`` and corner reach ``(F,)`` of triangles."""
        tri = np.ascontiguousarray(self.vertices[self.faces])
        centre = np.ascontiguousarray(tri.mean(axis=1))
        reach = np.linalg.norm(tri - centre[:, None, :], axis=-1).max(axis=-1) * (1 + 1e-12)
        return tri, centre, np.ascontiguousarray(reach)

    @cached_property
    def _bounds(self) -> tuple[FloatArray, FloatArray]:
        """Corners of the axis-aligned bounding box of the vertices."""
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    @cached_property
    def _proxies(self) -> MeshProxies:
        return enclosing_proxies(self.vertices, self.name)

    def enclosing_ball(self) -> tuple[FloatArray, float]:
        """The smallest enclosing ball of the vertices (broad phase)."""
        return self.bounding_sphere.center, self.bounding_sphere.radius

    def enclosing_solid(self) -> Obstacle:
        """The enclosing cone frustum (exact analytic distance: the mesh's broad phase)."""
        return self.proxies().frustum

    def proxies(self) -> MeshProxies:
        """Enclosing sphere, cylinder and frustum of the vertices (each contains the mesh).

        Computed once (the cylinder's axis search takes a fraction of a second) and cached.
        """
        return self._proxies

    def describe(self) -> dict[str, object]:
        return {
            "type": "mesh",
            "name": self.name,
            "source": self.source,
            "vertices": int(self.vertices.shape[0]),
            "faces": int(self.faces.shape[0]),
            "bounding_sphere": {
                "center": self.bounding_sphere.center.tolist(),
                "radius": self.bounding_sphere.radius,
            },
        }


def load_mesh(
    path: str | Path,
    name: str,
    scale: float = 1.0,
    transform: ArrayLike | None = None,
    broad_phase_cutoff: float = math.inf,
) -> MeshObstacle:
    """Read a closed triangle mesh file as an obstacle.

    Parameters
    ----------
    path:
        An STL, OBJ, PLY, OFF or glTF file (see :data:`MESH_SUFFIXES`); multi-part files are
        merged into one mesh.
    name:
        Obstacle name used in reports.
    scale:
        Factor from the file's length unit to the scene's (e.g. 1000 for a file in metres and a
        scene in mm); must be > 0.
    transform:
        Optional ``(4, 4)`` homogeneous pose applied after scaling:
        ``x_scene = transform @ (scale * x_file)``. Its last row must be ``[0, 0, 0, 1]``.
    broad_phase_cutoff:
        See :class:`MeshObstacle`.

    Raises
    ------
    InvalidInputError
        If the file is missing, has an unsupported suffix, cannot be read, holds no triangles,
        or the mesh is not closed (watertight) — a signed distance needs a closed surface.
    """
    p = Path(path)
    if not p.is_file():
        what = "is not a regular file" if p.exists() else "does not exist"
        raise InvalidInputError(f"mesh {name!r}: file {str(p)!r} {what}")
    suffix = p.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise InvalidInputError(
            f"mesh {name!r}: unsupported file type {suffix or '(none)'!r} of {str(p)!r}; "
            f"valid: {', '.join(MESH_SUFFIXES)}"
        )
    if not (math.isfinite(scale) and scale > 0):
        raise InvalidInputError(f"mesh {name!r}: scale must be a finite number > 0, got {scale}")
    matrix = np.eye(4)
    if transform is not None:
        matrix = np.asarray(transform, dtype=np.float64)
        if (
            matrix.shape != (4, 4)
            or not np.all(np.isfinite(matrix))
            or not np.allclose(matrix[3], (0.0, 0.0, 0.0, 1.0))
            or abs(np.linalg.det(matrix[:3, :3])) < 1e-12
        ):
            raise InvalidInputError(
                f"mesh {name!r}: transform must be a finite, invertible 4x4 homogeneous matrix "
                "with last row [0, 0, 0, 1]"
            )
    try:
        loaded = trimesh.load(str(p), file_type=suffix[1:], force="mesh")
    except Exception as exc:  # trimesh raises many types for malformed files
        raise InvalidInputError(
            f"mesh {name!r}: could not read {str(p)!r} as {suffix[1:].upper()}: {exc}"
        ) from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise InvalidInputError(
            f"mesh {name!r}: {str(p)!r} holds no triangles (empty or not a surface mesh)"
        )
    vertices = np.asarray(loaded.vertices, dtype=np.float64) * scale
    vertices = vertices @ matrix[:3, :3].T + matrix[:3, 3]
    return MeshObstacle(
        name=name,
        vertices=vertices,
        faces=np.asarray(loaded.faces, dtype=np.int64),
        source=str(p),
        broad_phase_cutoff=broad_phase_cutoff,
    )


# ------------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------------


def _closest_on_segments(point: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """The point of each segment ``a -> b`` ``(K, 3)`` nearest to ``point`` ``(3,)``."""
    ab = b - a
    ll = np.sum(ab * ab, axis=-1)
    t = np.sum((point - a) * ab, axis=-1) / np.where(ll > 0, ll, 1.0)
    return np.asarray(a + np.clip(t, 0.0, 1.0)[:, None] * ab)


def _segment_frames(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Frames of the segments ``a -> b`` ``(K, 3)`` for coal's z-aligned capsule.

    Returns rotations ``(K, 3, 3)`` whose third column is the unit direction ``z`` from ``a`` to
    ``b`` (first column ``helper × z`` normalised, helper ``e_x``, or ``e_y`` when ``z`` is
    nearly along ``e_x``; second ``z × x``) and half-lengths ``(K,)``. Zero-length segments get
    the identity. Small batches are done with plain floats, large ones with numpy (whose
    per-call overhead dominates small batches); both give the same frames.
    """
    if a.shape[0] < _SMALL_BATCH:
        rots, halves = [], []
        for p, q in zip(a.tolist(), b.tolist(), strict=True):
            r, h = _frame_of(q[0] - p[0], q[1] - p[1], q[2] - p[2])
            rots.append(r)
            halves.append(h)
        return np.array(rots).reshape(-1, 3, 3), np.array(halves)
    d = b - a
    length = np.sqrt(np.sum(d * d, axis=-1))
    degenerate = length == 0
    z = d / np.where(degenerate, 1.0, length)[:, None]
    z[degenerate] = (0.0, 0.0, 1.0)
    zx, zy, zz = z[:, 0], z[:, 1], z[:, 2]
    use_x = np.abs(zx) < 0.9
    xx = np.where(use_x, 0.0, zz)
    xy = np.where(use_x, -zz, 0.0)
    xz = np.where(use_x, zy, -zx)
    n = np.sqrt(xx * xx + xy * xy + xz * xz)
    xx, xy, xz = xx / n, xy / n, xz / n
    rot = np.empty((a.shape[0], 3, 3))
    rot[:, :, 0] = np.stack([xx, xy, xz], axis=-1)
    rot[:, :, 1] = np.stack([zy * xz - zz * xy, zz * xx - zx * xz, zx * xy - zy * xx], axis=-1)
    rot[:, :, 2] = z
    rot[degenerate] = np.eye(3)
    return rot, 0.5 * length


def _frame_of(dx: float, dy: float, dz: float) -> tuple[list[list[float]], float]:
    """One segment's frame (see :func:`_segment_frames`) from its direction ``(dx, dy, dz)``."""
    length = math.sqrt(dx * dx + dy * dy + dz * dz)
    if length == 0.0:
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], 0.0
    zx, zy, zz = dx / length, dy / length, dz / length
    if abs(zx) < 0.9:
        xx, xy, xz = 0.0, -zz, zy
    else:
        xx, xy, xz = zz, 0.0, -zx
    n = math.sqrt(xx * xx + xy * xy + xz * xz)
    xx, xy, xz = xx / n, xy / n, xz / n
    yx, yy, yz = zy * xz - zz * xy, zz * xx - zx * xz, zx * xy - zy * xx
    return [[xx, yx, zx], [xy, yy, zy], [xz, yz, zz]], 0.5 * length


def _build_bvh(vertices: FloatArray, faces: IntArray) -> coal.BVHModelOBBRSS:
    bvh = coal.BVHModelOBBRSS()
    bvh.beginModel(int(faces.shape[0]), int(vertices.shape[0]))
    bvh.addVertices(np.ascontiguousarray(vertices, dtype=np.float64))
    bvh.addTriangles(np.ascontiguousarray(faces, dtype=np.int32))
    bvh.endModel()
    return bvh


@njit(cache=True)
def _point_to_triangles(
    i: int,
    points: np.ndarray,
    tri: np.ndarray,
    centre: np.ndarray,
    reach: np.ndarray,
    with_distance: bool,
    with_winding: np.ndarray,
    dist: np.ndarray,
    wind: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Distance to the nearest triangle and generalized winding number of point ``i``.

    ``points`` is ``(N, 3)``, ``tri`` ``(F, 3, 3)`` (outward-wound corners), ``centre``
    ``(F, 3)`` and ``reach`` ``(F,)`` a ball around each triangle (centroid and largest corner
    distance). Writes point ``i``'s into ``dist`` and ``wind`` ``(N,)``; with ``with_distance``
    False the distances are not computed (left as they are), nor the winding numbers of points
    whose ``with_winding`` ``(N,)`` is False (zeros: the caller knows they are outside).

    Distance: where the point projects inside a triangle it is the distance to the triangle's
    plane; otherwise the nearest point lies on the triangle's boundary, the nearest of its three
    edges. Triangles whose ball is farther than the nearest distance found so far are skipped
    (their distance is at least the distance to the ball).

    Winding number: the sum of the signed solid angles ``Ω`` of the triangles seen from the
    point, over 4π (Van Oosterom and Strackee:
    ``tan(Ω / 2) = A·(B×C) / (|A||B||C| + (A·B)|C| + (A·C)|B| + (B·C)|A|)`` for the corners
    ``A, B, C`` relative to the point): 1 inside a closed mesh, 0 outside.
    """
    px, py, pz = points[i, 0], points[i, 1], points[i, 2]
    best = np.inf
    omega = 0.0
    solid_angles = with_winding[i]
    for f in range(tri.shape[0]):
        ax, ay, az = tri[f, 0, 0] - px, tri[f, 0, 1] - py, tri[f, 0, 2] - pz
        bx, by, bz = tri[f, 1, 0] - px, tri[f, 1, 1] - py, tri[f, 1, 2] - pz
        cx, cy, cz = tri[f, 2, 0] - px, tri[f, 2, 1] - py, tri[f, 2, 2] - pz
        if solid_angles:
            la = math.sqrt(ax * ax + ay * ay + az * az)
            lb = math.sqrt(bx * bx + by * by + bz * bz)
            lc = math.sqrt(cx * cx + cy * cy + cz * cz)
            det = ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)
            den = (
                la * lb * lc
                + (ax * bx + ay * by + az * bz) * lc
                + (ax * cx + ay * cy + az * cz) * lb
                + (bx * cx + by * cy + bz * cz) * la
            )
            omega += 2.0 * math.atan2(det, den)
        if with_distance:
            gx, gy, gz = centre[f, 0] - px, centre[f, 1] - py, centre[f, 2] - pz
            gap = math.sqrt(gx * gx + gy * gy + gz * gz) - reach[f]
            if gap <= 0.0 or gap * gap < best:
                d2 = _point_triangle_distance_sq(ax, ay, az, bx, by, bz, cx, cy, cz)
                best = min(best, d2)
    if with_distance:
        dist[i] = math.sqrt(best)
    wind[i] = omega / (4.0 * math.pi)


@njit(cache=True)
def _points_to_triangles_serial(
    points: np.ndarray,
    tri: np.ndarray,
    centre: np.ndarray,
    reach: np.ndarray,
    with_distance: bool,
    with_winding: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """:func:`_point_to_triangles` of every point ``(N, 3)``: distances and winding numbers."""
    dist, wind = np.zeros(points.shape[0]), np.zeros(points.shape[0])
    for i in range(points.shape[0]):
        _point_to_triangles(i, points, tri, centre, reach, with_distance, with_winding, dist, wind)
    return dist, wind


@njit(cache=True, parallel=True)
def _points_to_triangles_parallel(
    points: np.ndarray,
    tri: np.ndarray,
    centre: np.ndarray,
    reach: np.ndarray,
    with_distance: bool,
    with_winding: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """:func:`_points_to_triangles_serial` on numba's threads."""
    dist, wind = np.zeros(points.shape[0]), np.zeros(points.shape[0])
    for i in prange(points.shape[0]):
        _point_to_triangles(i, points, tri, centre, reach, with_distance, with_winding, dist, wind)
    return dist, wind


def _points_to_triangles(
    points: FloatArray,
    tri: FloatArray,
    centre: FloatArray,
    reach: FloatArray,
    with_distance: bool,
    with_winding: NDArray[np.bool_],
) -> tuple[FloatArray, FloatArray]:
    """:func:`_point_to_triangles` of every point, threaded only for large batches.

    Starting the threads costs about 100 µs on a busy machine, more than a small batch.
    """
    parallel = threads_pay_off(points.shape[0] * tri.shape[0], _PARALLEL_PAIRS)
    kernel = _points_to_triangles_parallel if parallel else _points_to_triangles_serial
    dist, wind = kernel(points, tri, centre, reach, with_distance, with_winding)
    return np.asarray(dist, dtype=np.float64), np.asarray(wind, dtype=np.float64)


@njit(cache=True)
def _point_triangle_distance_sq(
    ax: float,
    ay: float,
    az: float,
    bx: float,
    by: float,
    bz: float,
    cx: float,
    cy: float,
    cz: float,
) -> float:
    """Squared distance from the origin to the triangle with corners ``a, b, c``."""
    e0x, e0y, e0z = bx - ax, by - ay, bz - az
    e1x, e1y, e1z = cx - ax, cy - ay, cz - az
    d00 = e0x * e0x + e0y * e0y + e0z * e0z
    d01 = e0x * e1x + e0y * e1y + e0z * e1z
    d11 = e1x * e1x + e1y * e1y + e1z * e1z
    denom = d00 * d11 - d01 * d01
    # w = origin - a = -a
    d20 = -(ax * e0x + ay * e0y + az * e0z)
    d21 = -(ax * e1x + ay * e1y + az * e1z)
    if denom > 0.0:
        v = (d11 * d20 - d01 * d21) / denom
        u = (d00 * d21 - d01 * d20) / denom
        if v >= 0.0 and u >= 0.0 and u + v <= 1.0:
            qx = ax + v * e0x + u * e1x
            qy = ay + v * e0y + u * e1y
            qz = az + v * e0z + u * e1z
            return qx * qx + qy * qy + qz * qz
    return min(
        _origin_segment_distance_sq(ax, ay, az, bx, by, bz),
        _origin_segment_distance_sq(bx, by, bz, cx, cy, cz),
        _origin_segment_distance_sq(cx, cy, cz, ax, ay, az),
    )


@njit(cache=True)
def _origin_segment_distance_sq(
    ax: float, ay: float, az: float, bx: float, by: float, bz: float
) -> float:
    """Squared distance from the origin to the segment ``a -> b``."""
    ex, ey, ez = bx - ax, by - ay, bz - az
    ll = ex * ex + ey * ey + ez * ez
    t = -(ax * ex + ay * ey + az * ez) / ll if ll > 0.0 else 0.0
    t = min(max(t, 0.0), 1.0)
    qx, qy, qz = ax + t * ex, ay + t * ey, az + t * ez
    return qx * qx + qy * qy + qz * qz
