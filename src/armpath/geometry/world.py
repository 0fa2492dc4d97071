"""Clearance of an arm's links (capsules) to a set of obstacles.

Each checked link of the arm is a capsule: the segment between two landmarks with the link's
radius. The last ``tip_exempt`` length of the last link is the *tool tip*: it may touch the
surface it works on (clearance >= 0) while every other part must keep ``margin`` (SPEC section 3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.errors import InvalidInputError
from armpath.geometry.primitives import Obstacle
from armpath.kinematics import landmark_positions
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Part:
    """A capsule of the arm checked for clearance: a piece of link ``link`` (name)."""

    name: str
    link: str
    radius: float
    is_tip: bool


@dataclass(frozen=True)
class CollisionWorld:
    """Obstacles plus the clearance rule.

    Parameters
    ----------
    obstacles:
        The solids to keep clear of.
    margin:
        Clearance every part of the arm except the tool tip must keep (length unit, default 1).
    tip_exempt:
        Length at the end of the last link that only must not penetrate (default 5).
    """

    obstacles: tuple[Obstacle, ...]
    margin: float = 1.0
    tip_exempt: float = 5.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.margin) and self.margin >= 0):
            raise InvalidInputError(f"clearance margin must be >= 0, got {self.margin}")
        if not (np.isfinite(self.tip_exempt) and self.tip_exempt >= 0):
            raise InvalidInputError(f"tool-tip exempt length must be >= 0, got {self.tip_exempt}")
        names = [o.name for o in self.obstacles]
        if len(set(names)) != len(names):
            raise InvalidInputError(f"obstacle names must be unique, got {names}")

    @property
    def obstacle_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.obstacles)

    def parts(self, arm: SerialArm) -> tuple[Part, ...]:
        """The capsules checked: every checked link, the last one split into body and tip."""
        checked = [link for link in arm.links if link.checked]
        out: list[Part] = []
        for k, link in enumerate(checked):
            last = k == len(checked) - 1
            if last and self.tip_exempt > 0:
                out.append(Part(link.name, link.name, link.radius, False))
                out.append(Part(f"{link.name} tip", link.name, link.radius, True))
            else:
                out.append(Part(link.name, link.name, link.radius, False))
        return tuple(out)

    def part_segments(self, arm: SerialArm, q: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """End points of every part, each ``(..., P, 3)``, in the order of :meth:`parts`."""
        pts = landmark_positions(arm, q)
        checked = [link for link in arm.links if link.checked]
        starts, ends = [], []
        for k, link in enumerate(checked):
            a, b = pts[..., link.start, :], pts[..., link.end, :]
            if k == len(checked) - 1 and self.tip_exempt > 0:
                length = np.linalg.norm(b - a, axis=-1, keepdims=True)
                frac = np.clip(self.tip_exempt / np.where(length > 0, length, 1.0), 0.0, 1.0)
                cut = b - frac * (b - a)
                starts += [a, cut]
                ends += [cut, b]
            else:
                starts.append(a)
                ends.append(b)
        return np.stack(starts, axis=-2), np.stack(ends, axis=-2)

    def required(self, arm: SerialArm) -> FloatArray:
        """Clearance each part must keep: the margin, or 0 for the tool tip, ``(P,)``."""
        return np.array([0.0 if p.is_tip else self.margin for p in self.parts(arm)])

    def clearances(self, arm: SerialArm, q: ArrayLike) -> FloatArray:
        """Clearance of every part to every obstacle, ``(..., P, O)``; capsule radii subtracted."""
        return self.clearance_bounds(arm, q)[0]

    def clearance_bounds(
        self, arm: SerialArm, q: ArrayLike, tighten_below: ArrayLike | None = None
    ) -> tuple[FloatArray, FloatArray]:
        """Clearances ``(..., P, O)`` and proven lower bounds of them.

        Lower bounds below ``tighten_below`` (a clearance per part, ``(P,)`` or scalar) are
        tightened to within :data:`~armpath.geometry.primitives.FINE_SAMPLE_SPACING` / 2 of the
        true value; ``None`` leaves them at the coarse sampling's bound.
        """
        p0, p1 = self.part_segments(arm, q)
        radii = np.array([p.radius for p in self.parts(arm)])
        threshold = (
            np.full(radii.shape, -np.inf)
            if tighten_below is None
            else np.broadcast_to(np.asarray(tighten_below, dtype=np.float64), radii.shape) + radii
        )
        values, lowers = [], []
        for o in self.obstacles:
            v, lo = o.segment_distance_bounds(p0, p1, threshold)
            values.append(v - radii)
            lowers.append(lo - radii)
        return np.stack(values, axis=-1), np.stack(lowers, axis=-1)

    def slack(self, arm: SerialArm, q: ArrayLike) -> FloatArray:
        """Per configuration, the smallest ``clearance - required`` over parts and obstacles.

        Non-negative exactly when the configuration satisfies the clearance rule.
        """
        c = self.clearances(arm, q) - self.required(arm)[:, None]
        return np.asarray(c.min(axis=(-2, -1)), dtype=np.float64)

    def describe(self) -> dict[str, object]:
        return {
            "obstacles": [o.describe() for o in self.obstacles],
            "clearance_margin_mm": self.margin,
            "tool_tip_exempt_mm": self.tip_exempt,
        }
