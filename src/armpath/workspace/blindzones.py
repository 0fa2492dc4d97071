"""Blind zones of the seed arm (seeds 000 section 6.2, 001 section 6.3.2).

* **In the arm plane**: joints 2, 3 and 5 bend the arm in one vertical plane (joints 1, 4, 6 at
  zero). Sampling them inside their limits marks the fingertip's reachable pixels; unreachable
  pixels enclosed by reachable ones are the *central blind zone* (seed 000's figure 7: with the
  default limits the fingertip cannot fold back to the base A or the shoulder B), the rest of the
  unreachable plane lies *outside the reach*.
* **In 3-D**: joint 1 turns that picture about the vertical axis, and joint 4 twists the wrist out
  of the plane. Sampling joints 2-5 and keeping the fingertip's distance from the axis and height
  gives the meridian map; its enclosed holes, turned about the axis, are the 3-D blind volume
  (Pappus: each pixel contributes ``2 pi rho`` times its area).
* **On the workpiece**: horizontal circles on the outer and inner faces of the hollow cone, each
  checked by the curve-reachability search (every joint inside its limits, the clearance rule
  kept, the tool coming from outside the surface), give the unreachable part of each circle;
  integrating over height gives the blind area of each face and its fraction.

Sizes are checked before any work (:mod:`armpath.budget`): a map has at most
``MAX_GRID_CELLS`` pixels and ``MAX_SAMPLES`` samples (``MAX_CHUNK`` held at once), a face at
most ``MAX_BANDS`` circles of at most ``MAX_CURVE_POINTS`` scan points. The time limit in force
is checked before every chunk of samples and every circle.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from armpath.budget import (
    MAX_BANDS,
    MAX_CHUNK,
    MAX_CURVE_POINTS,
    MAX_GRID_CELLS,
    MAX_SAMPLES,
    check_size,
    check_time,
)
from armpath.errors import InvalidInputError
from armpath.geometry.curves import ConeSection
from armpath.geometry.primitives import SolidOfRevolution
from armpath.geometry.world import CollisionWorld
from armpath.kinematics import tool_position
from armpath.model.seed_arm import seed_geometry_of
from armpath.model.serial_arm import SerialArm
from armpath.planning.trace import curve_reachability
from armpath.workspace.sampling import check_count, joint_ranges, random_generator

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class PlaneMap:
    """Reachable pixels of the fingertip in a plane (mm).

    Pixel ``[i, j]`` spans ``u in origin[0] + pixel * [i, i+1)``, ``v in origin[1] + pixel *
    [j, j+1)``; ``axes`` names u and v (``("y", "z")`` for the arm plane, ``("rho", "z")`` for the
    meridian map, where negative rho is the mirror image).
    """

    origin: FloatArray
    pixel: float
    reach: BoolArray
    axes: tuple[str, str]
    samples: int
    #: the blind area (mm^2) of the map from the first half of its samples: where the whole
    #: map's differs much from it, the samples are too few for the pixels (the reachable set
    #: still fills, and its unfilled pixels count as blind); None where not measured
    half_blind_area: float | None = None
    #: the reachable area (mm^2) of the map from the first half of its samples (None where
    #: not measured): where it grew much over the second half, the samples are too few
    half_reach_area: float | None = None

    #: Largest change of the blind area between half the samples and all of them (a share of
    #: the larger, or 4 pixels where that is more) at which the map is taken as settled.
    SETTLED_SHARE = 0.05

    #: Enclosed unreachable regions smaller than this many pixels are sampling gaps, not blind
    #: zones.
    min_hole_pixels = 4

    @functools.cached_property
    def blind(self) -> BoolArray:
        """Unreachable pixels enclosed by reachable ones (holes of the reachable set of at least
        :attr:`min_hole_pixels` pixels); found once (a map of 50 million pixels labels its holes
        in 200 MB)."""
        holes = ndimage.binary_fill_holes(self.reach) & ~self.reach
        labels, n = ndimage.label(holes)
        if n == 0:
            return np.zeros_like(self.reach)
        sizes = np.bincount(labels.ravel())
        keep = sizes >= self.min_hole_pixels
        keep[0] = False
        return np.asarray(keep[labels])

    @property
    def blind_area(self) -> float:
        """Area of the enclosed blind pixels (mm^2)."""
        return float(np.count_nonzero(self.blind)) * self.pixel**2

    @property
    def settled(self) -> bool:
        """Whether the blind area hardly changed over the second half of the samples (see
        :attr:`half_blind_area`) and the reachable area hardly grew (by at most
        :attr:`SETTLED_SHARE` of it: a map of a handful of samples has almost no reachable
        pixels, and so no blind ones either); True where that was not measured."""
        if self.half_blind_area is not None:
            full, half = self.blind_area, self.half_blind_area
            if abs(full - half) > max(self.SETTLED_SHARE * max(full, half), 4 * self.pixel**2):
                return False
        if self.half_reach_area is not None:
            grown = self.reach_area - self.half_reach_area
            return grown <= self.SETTLED_SHARE * self.reach_area
        return True

    @property
    def reach_area(self) -> float:
        return float(np.count_nonzero(self.reach)) * self.pixel**2

    def centers(self) -> tuple[FloatArray, FloatArray]:
        """Pixel centre coordinates along u and v (mm)."""
        nu, nv = self.reach.shape
        return (
            self.origin[0] + (np.arange(nu) + 0.5) * self.pixel,
            self.origin[1] + (np.arange(nv) + 0.5) * self.pixel,
        )

    def at(self, u: float, v: float) -> tuple[int, int]:
        i = int(np.floor((u - self.origin[0]) / self.pixel))
        j = int(np.floor((v - self.origin[1]) / self.pixel))
        return i, j

    def revolved_volume(self, mask: BoolArray) -> float:
        """Volume (mm^3) swept by the pixels of ``mask`` of a meridian map turned about u = 0
        (Pappus; the map is mirrored, so each side counts half)."""
        if self.axes[0] != "rho":
            raise InvalidInputError("only a meridian map (rho, z) can be revolved")
        u, _ = self.centers()
        rho = np.abs(u)[:, None]
        return float(np.sum(mask * np.pi * rho) * self.pixel**2)

    def revolved_blind_volume(self) -> float:
        """Volume (mm^3) of the 3-D blind zone: the blind pixels turned about the axis."""
        return self.revolved_volume(self.blind)


def _grid(
    extent_u: tuple[float, float],
    extent_v: tuple[float, float],
    pixel: float,
    option: str = "the pixel size",
) -> tuple[FloatArray, tuple[int, int]]:
    """Origin and shape of a pixel grid over the extents with a pixel of margin; refused
    (naming ``option``) above ``MAX_GRID_CELLS`` pixels."""
    if not (np.isfinite(pixel) and pixel > 0):
        raise InvalidInputError(f"pixel size must be a positive length, got {pixel}")
    if pixel > max(extent_u[1] - extent_u[0], extent_v[1] - extent_v[0]):
        raise InvalidInputError(
            f"pixel size {pixel:g} mm is larger than the map ({extent_u[1] - extent_u[0]:.0f} x "
            f"{extent_v[1] - extent_v[0]:.0f} mm); change {option}"
        )
    lo = np.array([extent_u[0], extent_v[0]]) - pixel
    n = np.ceil((np.array([extent_u[1], extent_v[1]]) + pixel - lo) / pixel)  # floats
    cells = float(n[0]) * float(n[1])  # Python floats: inf rather than an overflow warning
    check_size(cells, MAX_GRID_CELLS, f"pixels of a {pixel:g} mm map", option)
    return lo, (int(n[0]), int(n[1]))


def _map_extent(arm: SerialArm) -> tuple[tuple[float, float], tuple[float, float]]:
    """The (u, v) box every fingertip position of the plane and meridian maps lies in (mm):
    the reach from the shoulder B."""
    g = seed_geometry_of(arm)
    reach_mm = g.bc_mm + g.cd_mm + g.de_mm
    if not (np.isfinite(reach_mm) and np.isfinite(g.ab_mm) and reach_mm > 0):
        raise InvalidInputError(f"the arm's link lengths must be finite, got reach {reach_mm}")
    return (-reach_mm, reach_mm), (g.ab_mm - reach_mm, g.ab_mm + reach_mm)


def map_shape(arm: SerialArm, pixel: float, option: str = "the pixel size") -> tuple[int, int]:
    """Pixels ``(nu, nv)`` of a plane or meridian map of ``arm`` with ``pixel`` mm pixels,
    without allocating it; refused above ``MAX_GRID_CELLS`` pixels, naming ``option``."""
    return _grid(*_map_extent(arm), pixel, option)[1]


def _mark(points: FloatArray, origin: FloatArray, pixel: float, reach: BoolArray) -> None:
    idx = np.floor((points - origin) / pixel).astype(np.int64)
    reach[idx[:, 0], idx[:, 1]] = True


def _sample_map(
    arm: SerialArm,
    pixel: float,
    samples: int,
    seed: int,
    chunk: int,
    joints: tuple[int, ...],
    meridian: bool,
) -> PlaneMap:
    """Sample ``joints`` (0-based) inside their limits, the others at zero, and mark the
    fingertip's (y, z) or, for the meridian map, its (+-rho, z) pixels."""
    samples = check_count(samples, "samples", MAX_SAMPLES, "joint samples of a map")
    chunk = check_count(chunk, "chunk", MAX_CHUNK, "samples a chunk")
    rng = random_generator(seed)
    origin, shape = _grid(*_map_extent(arm), pixel)
    reach = np.zeros(shape, dtype=bool)
    ranges = joint_ranges(arm)
    what = "the meridian map" if meridian else "the arm-plane map"
    axes = ("rho", "z") if meridian else ("y", "z")
    half, half_map = samples // 2, None
    done = 0
    while done < samples:  # done grows by n >= 1 each time
        check_time(f"sampling {what} ({done:,} of {samples:,} samples)")
        if done == half:
            half_map = PlaneMap(origin, float(pixel), reach.copy(), axes, half)
        n = min(chunk, samples - done, half - done if done < half else samples)
        q = np.zeros((n, 6))
        for j in joints:
            q[:, j] = rng.uniform(ranges[j, 0], ranges[j, 1], n)
        p = tool_position(arm, q)
        if meridian:
            rho = np.hypot(p[:, 0], p[:, 1])
            for sign in (1.0, -1.0):
                _mark(np.stack([sign * rho, p[:, 2]], axis=1), origin, pixel, reach)
        else:
            _mark(p[:, 1:], origin, pixel, reach)
        done += n
    assert half_map is not None  # done passes half (0 included) on its way to samples
    return PlaneMap(
        origin,
        float(pixel),
        reach,
        axes,
        samples,
        half_map.blind_area,
        half_map.reach_area,
    )


def arm_plane_map(
    arm: SerialArm,
    pixel: float = 5.0,
    samples: int = 2_000_000,
    *,
    seed: int = 0,
    chunk: int = 500_000,
) -> PlaneMap:
    """Reachable fingertip pixels in the arm plane (joints 1, 4, 6 at zero; u = y, v = z, mm)."""
    return _sample_map(arm, pixel, samples, seed, chunk, (1, 2, 4), meridian=False)


def meridian_map(
    arm: SerialArm,
    pixel: float = 5.0,
    samples: int = 4_000_000,
    *,
    seed: int = 0,
    chunk: int = 500_000,
) -> PlaneMap:
    """Reachable fingertip pixels in (distance from the vertical axis, height), mirrored to
    negative distances: joints 2-5 sampled inside their limits, joint 1 turns it about the axis."""
    return _sample_map(arm, pixel, samples, seed, chunk, (1, 2, 3, 4), meridian=True)


#: Finest location of the ends of an unreachable arc on a face (mm).
MIN_RESOLUTION_MM = 1e-6


@dataclass(frozen=True)
class FaceBlindness:
    """Unreachable part of one side face of a solid of revolution, by horizontal circles.

    ``heights`` (mm) are the circles' heights, each the middle of a band of height
    ``band_mm``; ``length_mm`` their circumferences, ``blind_mm`` their unreachable lengths and
    ``reasons`` why (one text per unreachable arc). Areas follow by the bands' slant heights.
    """

    face: str
    heights: FloatArray
    band_mm: float
    slant: float
    length_mm: FloatArray
    blind_mm: FloatArray
    reasons: tuple[tuple[str, ...], ...]

    @property
    def area_mm2(self) -> float:
        return float(np.sum(self.length_mm) * self.band_mm * self.slant)

    @property
    def blind_area_mm2(self) -> float:
        return float(np.sum(self.blind_mm) * self.band_mm * self.slant)

    @property
    def blind_fraction(self) -> float:
        return self.blind_area_mm2 / self.area_mm2


def side_faces(solid: SolidOfRevolution) -> dict[str, int]:
    """Profile edges of the outer and inner side faces (conical or cylindrical) of a hollow
    solid: the outer one rises from the outermost bottom corner, the inner one is the other."""
    prof = solid.profile
    n = len(prof)
    sides = [k for k in range(n) if prof[k][1] != prof[(k + 1) % n][1]]
    bottom = int(np.argmax(np.where(prof[:, 1] == prof[:, 1].min(), prof[:, 0], -np.inf)))
    inner = [k for k in sides if k != bottom and prof[k][0] > 0 and prof[(k + 1) % n][0] > 0]
    if bottom not in sides or len(inner) != 1:
        raise InvalidInputError(f"{solid.name!r} is not a hollow solid with one inner side face")
    return {"outer": bottom, "inner": inner[0]}


def surface_blindness(
    arm: SerialArm,
    world: CollisionWorld,
    solid: SolidOfRevolution,
    bands: int = 9,
    *,
    faces: tuple[str, ...] = ("outer", "inner"),
    scan_step_mm: float = 8.0,
    resolution_mm: float = 0.5,
    progress: Callable[[str], None] | None = None,
) -> list[FaceBlindness]:
    """Blind parts of the side faces of ``solid`` (a hollow solid of revolution in ``world``):
    ``bands`` horizontal bands per face (at most ``MAX_BANDS``), each represented by the circle
    at its middle height. Each circle is scanned every ``scan_step_mm`` and the ends of its
    unreachable arcs located to ``resolution_mm`` (at least ``MIN_RESOLUTION_MM``, so the
    bisection ends well above the floating-point resolution of the arc length). The time limit
    in force is checked before every circle."""
    bands = check_count(bands, "bands", MAX_BANDS, "circles a face")
    if not (np.isfinite(resolution_mm) and resolution_mm >= MIN_RESOLUTION_MM):
        raise InvalidInputError(
            f"resolution must be at least {MIN_RESOLUTION_MM:g} mm, got {resolution_mm}"
        )
    if not (np.isfinite(scan_step_mm) and scan_step_mm >= resolution_mm):
        raise InvalidInputError(
            f"scan step must be a length of at least the resolution ({resolution_mm:g} mm), "
            f"got {scan_step_mm}"
        )
    edges = side_faces(solid)
    for face in faces:
        if face not in edges:
            raise InvalidInputError(f"face must be one of {tuple(edges)}, got {face!r}")
        k = edges[face]
        widest = max(abs(solid.profile[k][0]), abs(solid.profile[(k + 1) % len(solid.profile)][0]))
        check_size(
            2.0 * np.pi * widest / scan_step_mm,
            MAX_CURVE_POINTS,
            f"scan points of a circle on the {face} face",
            "the scan step",
        )
    out = []
    for face in faces:
        k = edges[face]
        (ra, za), (rb, zb) = solid.profile[k], solid.profile[(k + 1) % len(solid.profile)]
        lo, hi = min(za, zb), max(za, zb)
        band = (hi - lo) / bands
        heights = lo + band * (np.arange(bands) + 0.5)
        lengths, blind, reasons = [], [], []
        for z in heights:
            check_time(f"scanning the {face} face at z = {z:.1f} mm")
            if progress is not None:
                progress(f"blind zones: {face} face at z = {z:.1f} mm")
            circle = ConeSection(
                f"{face} face at z = {z:.1f} mm",
                solid,
                k,
                solid.origin + z * solid.axis,
                solid.axis,
            )
            result = curve_reachability(arm, world, circle, scan_step_mm, resolution_mm)
            lengths.append(circle.length)
            blind.append(sum(a.length_mm for a in result.unreachable))
            reasons.append(tuple(a.reason for a in result.unreachable))
        out.append(
            FaceBlindness(
                face,
                heights,
                float(band),
                float(np.hypot(1.0, (rb - ra) / (zb - za))),
                np.array(lengths),
                np.array(blind, dtype=np.float64),
                tuple(reasons),
            )
        )
    return out
