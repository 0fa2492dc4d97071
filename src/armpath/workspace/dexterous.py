"""Dexterous workspace: points the tool reaches in every orientation (seed 003).

A point is tested by solving the inverse kinematics, with every solution, for the tool at that
point in each orientation of a grid (fixed X-Y-Z angles), and keeping the solutions inside the
joint limits. The complete solvers (closed form or elimination) make this a batched call per
point.

Bounds (:mod:`armpath.budget`): at most ``MAX_ORIENTATIONS`` orientations, ``MAX_CHUNK`` points
and ``MAX_SAMPLES`` poses (points x orientations), checked before any work; poses go to the
solver ``POSE_BATCH`` at a time, with the time limit in force checked between batches.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from armpath.budget import (
    MAX_CHUNK,
    MAX_ORIENTATIONS,
    MAX_SAMPLES,
    check_size,
    check_time,
)
from armpath.errors import InvalidInputError
from armpath.ik import limits_mask, require_complete_solver
from armpath.ik.compiled import CompiledSolver
from armpath.model.serial_arm import SerialArm
from armpath.workspace.sampling import check_count, random_generator

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
#: Poses solved in one batched IK call (bounds the memory of the solutions).
POSE_BATCH = 100_000


def orientation_grid(step: float, lo: float = -np.pi, hi: float = np.pi) -> FloatArray:
    """Rotation matrices ``(k, 3, 3)`` of every fixed-angle triple (alpha about x, beta about y,
    gamma about z, applied in that order about the fixed axes) on a grid ``lo:step:hi`` (rad,
    both ends included): seed 003 uses [-pi, pi] in steps of 0.1 pi, 21^3 = 9261 orientations.
    At most ``MAX_ORIENTATIONS`` (refused before any is built)."""
    if not (np.isfinite(step) and step > 0 and np.isfinite(lo) and np.isfinite(hi) and hi >= lo):
        raise InvalidInputError(
            f"orientation grid needs a finite step > 0 and hi >= lo, got {step}, {lo}, {hi}"
        )
    per_axis = float(np.floor((hi - lo) / step + 1e-9)) + 1.0  # may be beyond any integer
    check_size(  # Python floats: inf rather than an overflow warning
        per_axis * per_axis * per_axis, MAX_ORIENTATIONS, "orientations of the grid", "the step"
    )
    n = int(per_axis)
    angles = lo + step * np.arange(n)
    a, b, c = np.meshgrid(angles, angles, angles, indexing="ij")
    triples = np.stack([a.ravel(), b.ravel(), c.ravel()], axis=1)
    return np.asarray(Rotation.from_euler("xyz", triples).as_matrix(), dtype=np.float64)


@dataclass(frozen=True)
class Dexterity:
    """How many of the tested orientations the tool reaches at ``point`` (model unit)."""

    point: FloatArray
    reached: BoolArray
    solutions: NDArray[np.int64]

    @property
    def n_reached(self) -> int:
        return int(np.count_nonzero(self.reached))

    @property
    def n_tested(self) -> int:
        return int(self.reached.shape[0])

    @property
    def dexterous(self) -> bool:
        """Every tested orientation is reached."""
        return bool(self.reached.all())


def dexterity(
    arm: SerialArm,
    point: FloatArray,
    rotations: FloatArray,
    *,
    solver: CompiledSolver | None = None,
) -> Dexterity:
    """Test the tool at ``point`` in each of ``rotations`` ``(k, 3, 3)``: reached when some
    inverse-kinematics solution lies inside the joint limits. ``solver`` defaults to the arm's
    complete solver (one is required)."""
    solver = solver or require_complete_solver(arm, "dexterity")
    p = np.asarray(point, dtype=np.float64).reshape(3)
    R = np.asarray(rotations, dtype=np.float64).reshape(-1, 3, 3)
    check_size(R.shape[0], MAX_ORIENTATIONS, "orientations", "the rotations")
    counts = np.zeros(R.shape[0], dtype=np.int64)
    for start in range(0, R.shape[0], POSE_BATCH):
        check_time("testing orientations")
        part = R[start : start + POSE_BATCH]
        T = np.zeros((part.shape[0], 4, 4))
        T[:, :3, :3] = part
        T[:, :3, 3] = p
        T[:, 3, 3] = 1.0
        batch = solver.solve_batch(T)
        counts[start : start + part.shape[0]] = limits_mask(arm, batch.solutions).sum(axis=1)
    return Dexterity(p, counts > 0, counts)


@dataclass(frozen=True)
class DexterousSample:
    """Monte-Carlo estimate of the dexterous workspace: ``points`` ``(N, 3)`` drawn uniformly
    in the box ``[lo, hi]`` (model unit), ``dexterous`` whether each reached every one of
    ``n_orientations`` orientations."""

    points: FloatArray
    dexterous: BoolArray
    lo: FloatArray
    hi: FloatArray
    n_orientations: int

    @property
    def fraction(self) -> float:
        return float(np.mean(self.dexterous))

    @property
    def volume(self) -> float:
        """Estimated dexterous volume (model unit cubed): fraction times the box volume. A finite
        orientation grid can miss small unreachable caps, so points just outside the true
        dexterous set may count: an upper estimate."""
        return self.fraction * float(np.prod(self.hi - self.lo))

    @property
    def standard_error(self) -> float:
        """Standard error of :attr:`volume` from the binomial sampling (model unit cubed)."""
        f = self.fraction
        n = self.dexterous.shape[0]
        return float(np.sqrt(f * (1.0 - f) / n) * np.prod(self.hi - self.lo))


def dexterous_workspace(
    arm: SerialArm,
    n_points: int,
    rotations: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    *,
    seed: int = 0,
    chunk_points: int = 500,
    progress: Callable[[int, int], None] | None = None,
) -> DexterousSample:
    """Draw ``n_points`` uniformly in the box ``[lo, hi]`` and test each in every orientation of
    ``rotations`` (seed 003's Monte-Carlo method), a chunk of points per batched IK call (at most
    ``chunk_points`` points and ``POSE_BATCH`` poses). Refused before any work: more than
    ``MAX_CHUNK`` points, ``MAX_ORIENTATIONS`` orientations or ``MAX_SAMPLES`` poses."""
    n_points = check_count(n_points, "n_points", MAX_CHUNK, "points held at once")
    chunk_points = check_count(chunk_points, "chunk_points", MAX_CHUNK, "points a chunk")
    lo = np.asarray(lo, dtype=np.float64).reshape(3)
    hi = np.asarray(hi, dtype=np.float64).reshape(3)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi > lo)):
        raise InvalidInputError(f"the sampling box needs finite hi > lo, got {lo} .. {hi}")
    R = np.asarray(rotations, dtype=np.float64).reshape(-1, 3, 3)
    check_size(R.shape[0], MAX_ORIENTATIONS, "orientations", "the rotations")
    check_size(
        float(n_points) * R.shape[0], MAX_SAMPLES, "poses (points x orientations)", "the points"
    )
    rng = random_generator(seed)
    solver = require_complete_solver(arm, "the dexterous workspace")
    chunk_points = max(1, min(chunk_points, POSE_BATCH // max(R.shape[0], 1)))
    pts = rng.uniform(lo, hi, (n_points, 3))
    dexterous = np.zeros(n_points, dtype=bool)
    for start in range(0, n_points, chunk_points):
        check_time(f"testing points for dexterity ({start:,} of {n_points:,})")
        chunk = pts[start : start + chunk_points]
        if R.shape[0] > POSE_BATCH:  # one point at a time, its orientations in batches
            dexterous[start] = dexterity(arm, chunk[0], R, solver=solver).dexterous
        else:
            T = np.zeros((chunk.shape[0], R.shape[0], 4, 4))
            T[:, :, :3, :3] = R[None]
            T[:, :, :3, 3] = chunk[:, None, :]
            T[:, :, 3, 3] = 1.0
            batch = solver.solve_batch(T.reshape(-1, 4, 4))
            reached = limits_mask(arm, batch.solutions).any(axis=1).reshape(chunk.shape[0], -1)
            dexterous[start : start + chunk.shape[0]] = reached.all(axis=1)
        if progress is not None:
            progress(min(start + chunk_points, n_points), n_points)
    return DexterousSample(pts, dexterous, lo, hi, R.shape[0])
