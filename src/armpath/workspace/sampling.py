"""Reachable workspace by sampling joint space into a voxel grid.

Joint vectors are drawn inside the joint limits (uniform, or stratified: a Latin hypercube per
chunk), seeded, in chunks of bounded size; a compiled kernel runs forward kinematics of the tool
point and marks the voxel it falls in. Memory is the grid (one byte a voxel) plus one chunk, so
10^8 samples run in bounded memory; a callback reports progress after each chunk. With a
collision world, samples that break its clearance rule are dropped before they are marked.

Sizes are checked before any work (:mod:`armpath.budget`): at most ``MAX_SAMPLES`` samples,
``MAX_CHUNK`` a chunk and ``MAX_GRID_CELLS`` voxels; the time limit in force is checked before
every chunk (and every batch of a chunk checked against the obstacles).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.budget import MAX_CHUNK, MAX_GRID_CELLS, MAX_SAMPLES, check_size, check_time
from armpath.errors import InvalidInputError
from armpath.geometry.world import CollisionWorld
from armpath.jit import njit, prange, threads_pay_off
from armpath.kinematics import z_axis_chain
from armpath.model.serial_arm import JointKind, SerialArm, check_arm

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
METHODS = ("uniform", "stratified")
#: Largest grid (voxels) a run may allocate, one byte each (the budget's ``MAX_GRID_CELLS``).
MAX_VOXELS = MAX_GRID_CELLS
#: Joint vectors checked against the obstacles at once (bounds the clearance test's memory).
OBSTACLE_BATCH = 65_536


@dataclass(frozen=True)
class VoxelGrid:
    """Which voxels of an axis-aligned box the tool point reached (world frame, model unit).

    Voxel ``(i, j, k)`` spans ``origin + voxel * [i, i+1) x [j, j+1) x [k, k+1)``.
    ``samples`` joint vectors were drawn, ``kept`` of them passed the clearance rule (all of them
    without a collision world).
    """

    origin: FloatArray
    voxel: float
    occupied: BoolArray
    samples: int
    kept: int

    @property
    def volume(self) -> float:
        """Volume of the occupied voxels (model unit cubed, e.g. mm^3)."""
        return float(np.count_nonzero(self.occupied)) * self.voxel**3

    @property
    def n_occupied(self) -> int:
        return int(np.count_nonzero(self.occupied))

    def centers(self, mask: BoolArray | None = None) -> FloatArray:
        """Centres ``(k, 3)`` of the voxels in ``mask`` (default: the occupied ones)."""
        idx = np.argwhere(self.occupied if mask is None else mask)
        return np.asarray(self.origin + (idx + 0.5) * self.voxel, dtype=np.float64)

    def boundary(self) -> BoolArray:
        """Occupied voxels with at least one free face neighbour (or on the grid's edge)."""
        occ = np.pad(self.occupied, 1, constant_values=False)
        inner = occ[1:-1, 1:-1, 1:-1].copy()
        for axis in range(3):
            for shift in (1, -1):
                inner &= np.roll(occ, shift, axis=axis)[1:-1, 1:-1, 1:-1]
        return np.asarray(self.occupied & ~inner)

    def bounding_box(self) -> FloatArray:
        """``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` of the occupied voxels (model unit)."""
        idx = np.argwhere(self.occupied)
        if idx.size == 0:
            raise InvalidInputError("no voxel is occupied")
        return np.asarray(
            [
                self.origin + idx.min(axis=0) * self.voxel,
                self.origin + (idx.max(axis=0) + 1) * self.voxel,
            ]
        )

    def section(
        self, axis: str, value: float, voxels: BoolArray | None = None
    ) -> tuple[BoolArray, tuple[float, float, float, float]]:
        """The slice of voxels containing the plane ``axis = value``: a 2-D mask indexed
        ``[u, v]`` over the two other axes in order (x, y, z), and its extent
        ``(u_min, u_max, v_min, v_max)``. ``voxels`` slices another mask of the grid's shape
        (e.g. :meth:`boundary`) instead of the occupied voxels."""
        if axis not in ("x", "y", "z"):
            raise InvalidInputError(f"section axis must be 'x', 'y' or 'z', got {axis!r}")
        a = "xyz".index(axis)
        k = int(np.floor((value - self.origin[a]) / self.voxel))
        if not 0 <= k < self.occupied.shape[a]:
            raise InvalidInputError(f"{axis} = {value} lies outside the grid")
        mask = np.take(self.occupied if voxels is None else voxels, k, axis=a)
        u, v = [i for i in range(3) if i != a]
        extent = (
            float(self.origin[u]),
            float(self.origin[u] + self.occupied.shape[u] * self.voxel),
            float(self.origin[v]),
            float(self.origin[v] + self.occupied.shape[v] * self.voxel),
        )
        return np.asarray(mask), extent

    def contains(self, points: FloatArray) -> BoolArray:
        """Whether each point ``(..., 3)`` lies in an occupied voxel."""
        p = np.asarray(points, dtype=np.float64)
        idx = np.floor((p - self.origin) / self.voxel).astype(np.int64)
        shape = np.array(self.occupied.shape)
        inside = np.all((idx >= 0) & (idx < shape), axis=-1)
        out = np.zeros(p.shape[:-1], dtype=bool)
        sel = idx[inside]
        out[inside] = self.occupied[sel[:, 0], sel[:, 1], sel[:, 2]]
        return out


def joint_ranges(arm: SerialArm) -> FloatArray:
    """Sampling range ``(n, 2)`` of each joint: its limits, a revolute joint without limits
    over one turn. A prismatic joint without limits cannot be sampled."""
    out = np.empty((arm.n_joints, 2))
    for i, joint in enumerate(arm.joints):
        lo, hi = joint.limits
        if joint.kind is JointKind.REVOLUTE:
            lo = lo if np.isfinite(lo) else -np.pi
            hi = hi if np.isfinite(hi) else lo + 2.0 * np.pi
        elif not (np.isfinite(lo) and np.isfinite(hi)):
            raise InvalidInputError(
                f"model {arm.name!r}: prismatic joint {i + 1} has no finite limits to sample"
            )
        out[i] = lo, hi
    return out


def reach_bound(arm: SerialArm) -> float:
    """Upper bound on the tool point's distance from joint 1's frame origin (model unit): the
    sum of the chain's fixed offsets beyond it plus each prismatic joint's largest extension."""
    C = z_axis_chain(arm)
    total = float(np.sum(np.linalg.norm(C[1:, :3, 3], axis=1)))
    ranges = joint_ranges(arm)
    for i, joint in enumerate(arm.joints):
        if joint.kind is JointKind.PRISMATIC:
            total += float(np.max(np.abs(ranges[i])))
    return total


@njit(cache=True)
def _mark(
    C: FloatArray,
    prismatic: BoolArray,
    q: FloatArray,
    origin: FloatArray,
    voxel: float,
    occupied: NDArray[np.uint8],
) -> int:
    """Tool point of each joint vector (rows of ``q``) -> mark its voxel; returns how many fell
    outside the grid (0 unless the reach bound is wrong)."""
    n = q.shape[1]
    nx, ny, nz = occupied.shape
    outside = 0
    for s in range(q.shape[0]):
        # Tool point in the frame after the last joint, carried back to the world.
        x, y, z = C[n, 0, 3], C[n, 1, 3], C[n, 2, 3]
        for j in range(n - 1, -1, -1):
            v = q[s, j]
            if prismatic[j]:
                z += v
            else:
                c, sn = np.cos(v), np.sin(v)
                x, y = c * x - sn * y, sn * x + c * y
            A = C[j]
            x, y, z = (
                A[0, 0] * x + A[0, 1] * y + A[0, 2] * z + A[0, 3],
                A[1, 0] * x + A[1, 1] * y + A[1, 2] * z + A[1, 3],
                A[2, 0] * x + A[2, 1] * y + A[2, 2] * z + A[2, 3],
            )
        i = int(np.floor((x - origin[0]) / voxel))
        k = int(np.floor((y - origin[1]) / voxel))
        m = int(np.floor((z - origin[2]) / voxel))
        if 0 <= i < nx and 0 <= k < ny and 0 <= m < nz:
            occupied[i, k, m] = 1
        else:
            outside += 1
    return outside


@njit(cache=True, parallel=True)
def _mark_parallel(
    C: FloatArray,
    prismatic: BoolArray,
    q: FloatArray,
    origin: FloatArray,
    voxel: float,
    occupied: NDArray[np.uint8],
    blocks: int,
) -> int:
    """:func:`_mark` over ``blocks`` slices of the rows in parallel (marks only set bytes to 1,
    so concurrent writes agree)."""
    size = (q.shape[0] + blocks - 1) // blocks
    outside = np.zeros(blocks, dtype=np.int64)
    for b in prange(blocks):
        lo = b * size
        hi = min(q.shape[0], lo + size)
        if lo < hi:
            outside[b] = _mark(C, prismatic, q[lo:hi], origin, voxel, occupied)
    return int(outside.sum())


@dataclass(frozen=True)
class GridSpec:
    """A cube of voxels around joint 1 that holds every reachable point."""

    origin: FloatArray
    voxel: float
    shape: tuple[int, int, int]

    @staticmethod
    def for_arm(arm: SerialArm, voxel: float, option: str = "the voxel size") -> GridSpec:
        """The grid for ``arm`` with voxels of edge ``voxel``; refused (naming ``option``) when
        it would have more than ``MAX_VOXELS`` voxels."""
        if not (np.isfinite(voxel) and voxel > 0):
            raise InvalidInputError(f"voxel size must be a positive length, got {voxel}")
        arm_reach = reach_bound(arm)
        if voxel > arm_reach:
            raise InvalidInputError(
                f"voxel size {voxel:g} is larger than the arm's reach ({arm_reach:.0f} "
                f"{arm.length_unit}); "
                f"change {option}"
            )
        reach = arm_reach + voxel
        centre = z_axis_chain(arm)[0, :3, 3]
        edge = float(np.ceil(2.0 * reach / voxel))  # may be beyond any integer, or inf
        per_edge = math.floor(MAX_VOXELS ** (1 / 3))
        least = math.ceil(200.0 * arm_reach / (per_edge - 2)) / 100.0  # edge <= per_edge
        check_size(
            edge * edge * edge,  # Python floats: inf rather than an overflow warning
            MAX_VOXELS,
            f"voxels of a {voxel:g} {arm.length_unit} grid over the reach ({reach:.0f} "
            f"{arm.length_unit}; use a voxel of at least {least:g} {arm.length_unit})",
            option,
        )
        n = int(edge)
        origin = centre - 0.5 * n * voxel
        return GridSpec(np.asarray(origin, dtype=np.float64), float(voxel), (n, n, n))


def _clear_samples(arm: SerialArm, world: CollisionWorld, q: FloatArray) -> FloatArray:
    """The rows of ``q`` that satisfy the clearance rule of ``world``, tested
    ``OBSTACLE_BATCH`` rows at a time (the time limit checked between them)."""
    keep = np.empty(q.shape[0], dtype=bool)
    for start in range(0, q.shape[0], OBSTACLE_BATCH):
        check_time("checking samples against the obstacles")
        part = q[start : start + OBSTACLE_BATCH]
        keep[start : start + part.shape[0]] = world.slack(arm, part) >= 0.0
    return q[keep]


def joint_samples(ranges: FloatArray, n: int, rng: np.random.Generator, method: str) -> FloatArray:
    """``n`` joint vectors in ``ranges`` (``(joints, 2)``): uniform, or a Latin hypercube
    (each joint's range cut into ``n`` strata, one sample in each)."""
    if method == "uniform":
        u = rng.random((n, ranges.shape[0]))
    elif method == "stratified":
        strata = np.stack([rng.permutation(n) for _ in range(ranges.shape[0])], axis=1)
        u = (strata + rng.random((n, ranges.shape[0]))) / n
    else:
        raise InvalidInputError(f"sampling method must be one of {METHODS}, got {method!r}")
    return np.asarray(ranges[:, 0] + u * (ranges[:, 1] - ranges[:, 0]), dtype=np.float64)


def check_count(value: int, option: str, limit: float, what: str = "", least: int = 1) -> int:
    """``value`` as an int, refused unless it is a whole number in ``[least, limit]``: the
    messages name ``option`` (the argument or command-line option to change) and ``what`` is
    counted (the upper end goes through :func:`armpath.budget.check_size`)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise InvalidInputError(f"{option} must be a whole number, got {value!r}")
    if value < least:
        raise InvalidInputError(f"{option} must be >= {least}, got {value}")
    check_size(int(value), limit, what or option, option)
    return int(value)


def random_generator(seed: int) -> np.random.Generator:
    """numpy's generator for a non-negative integer seed (refused otherwise)."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InvalidInputError(f"the random seed must be a whole number >= 0, got {seed!r}")
    return np.random.default_rng(int(seed))


def sample_workspace(
    arm: SerialArm,
    samples: int,
    voxel: float,
    *,
    seed: int = 0,
    method: str = "uniform",
    chunk: int = 1_000_000,
    world: CollisionWorld | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> VoxelGrid:
    """Reachable workspace of the tool point: ``samples`` joint vectors into voxels of edge
    ``voxel`` (model unit).

    ``world``: keep only joint vectors that satisfy its clearance rule (obstacles and self
    collision). ``progress(done, total)`` is called after each chunk.

    Refused before any work: more than ``MAX_SAMPLES`` samples, a chunk of more than
    ``MAX_CHUNK``, a grid of more than ``MAX_VOXELS`` voxels. An arm of more than six joints
    gets chunks of at most ``6 * MAX_CHUNK / joints`` samples (the same memory). The time limit
    in force (:func:`armpath.budget.check_time`) is checked before every chunk.
    """
    check_arm(arm)
    samples = check_count(samples, "samples", MAX_SAMPLES, "joint samples")
    chunk = check_count(chunk, "chunk", MAX_CHUNK, "samples a chunk")
    if method not in METHODS:
        raise InvalidInputError(f"sampling method must be one of {METHODS}, got {method!r}")
    rng = random_generator(seed)
    ranges = joint_ranges(arm)
    # a chunk holds at most MAX_CHUNK samples of six joints' worth of values
    chunk = min(chunk, max(1, 6 * MAX_CHUNK // max(arm.n_joints, 1)))
    spec = GridSpec.for_arm(arm, voxel)
    occupied = np.zeros(spec.shape, dtype=np.uint8)
    C = np.ascontiguousarray(z_axis_chain(arm))
    prismatic = np.array([j.kind is JointKind.PRISMATIC for j in arm.joints])
    done = kept = outside = 0
    while done < samples:  # done grows by n >= 1 each time
        check_time(f"sampling the workspace ({done:,} of {samples:,} samples)")
        n = min(chunk, samples - done)
        q = joint_samples(ranges, n, rng, method)
        if world is not None:
            q = _clear_samples(arm, world, q)
        kept += q.shape[0]
        if q.shape[0]:
            if threads_pay_off(q.shape[0], 4096):
                outside += _mark_parallel(C, prismatic, q, spec.origin, spec.voxel, occupied, 64)
            else:
                outside += _mark(C, prismatic, q, spec.origin, spec.voxel, occupied)
        done += n
        if progress is not None:
            progress(done, samples)
    if outside:
        raise AssertionError(f"{outside} tool points fell outside the reach bound's grid")
    check_time("sampling the workspace")
    return VoxelGrid(spec.origin, spec.voxel, occupied.view(np.bool_), samples, kept)
