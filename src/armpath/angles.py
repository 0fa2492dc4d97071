"""Angle helpers (radians)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def wrap_to_pi(angle: ArrayLike) -> NDArray[np.float64]:
    """Equivalent angle in ``[-pi, pi)``."""
    a = np.asarray(angle, dtype=np.float64)
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


def nearest_equivalent(angle: ArrayLike, reference: ArrayLike) -> NDArray[np.float64]:
    """The angle congruent to ``angle`` (mod 2 pi) that is closest to ``reference``."""
    ref = np.asarray(reference, dtype=np.float64)
    return np.asarray(ref + wrap_to_pi(np.asarray(angle, dtype=np.float64) - ref))
