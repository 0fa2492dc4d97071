"""The tool point's tolerances (mm): each task's default and the range it accepts, one place for
each, read by the planners, the scene files (a task's ``tolerance_mm``), the Python API and the
command line."""

from __future__ import annotations

import math

from armpath.errors import InvalidInputError

#: Largest tool point error accepted at a goal point by default: reaching a point, planning to
#: one, each spot weld (mm).
POINT_TOLERANCE_MM = 0.05
#: Smallest and largest tool point error a goal point accepts (mm): below a micrometre the
#: command lattice seldom comes closer, above 100 mm it is no target.
MIN_POINT_TOLERANCE_MM = 0.001
MAX_POINT_TOLERANCE_MM = 100.0
#: Largest distance of the continuous tool path from a traced curve by default (mm).
TRACE_TOLERANCE_MM = 0.1
#: Smallest and largest tracing tolerance (mm): the tracer's lattice search and the deviation
#: certificate's precision (a share of the tolerance) are sized for this range.
MIN_TRACE_TOLERANCE_MM = 0.005
MAX_TRACE_TOLERANCE_MM = 10.0


def _within(tolerance_mm: float, lowest: float, highest: float, what: str) -> float:
    """``tolerance_mm`` when finite and within ``[lowest, highest]``, else
    :class:`~armpath.errors.InvalidInputError` naming ``what`` and the range."""
    if not (math.isfinite(tolerance_mm) and lowest <= tolerance_mm <= highest):
        raise InvalidInputError(
            f"{what} must be between {lowest:g} and {highest:g} mm, got {tolerance_mm}"
        )
    return float(tolerance_mm)


def check_point_tolerance(tolerance_mm: float) -> float:
    """``tolerance_mm`` when it is a goal point's tolerance within the accepted range, else
    :class:`~armpath.errors.InvalidInputError` naming the range."""
    return _within(tolerance_mm, MIN_POINT_TOLERANCE_MM, MAX_POINT_TOLERANCE_MM, "tolerance")


def check_trace_tolerance(tolerance_mm: float) -> float:
    """``tolerance_mm`` when it is a tracing tolerance within the accepted range, else
    :class:`~armpath.errors.InvalidInputError` naming the range."""
    return _within(
        tolerance_mm, MIN_TRACE_TOLERANCE_MM, MAX_TRACE_TOLERANCE_MM, "tracing tolerance"
    )


def nearest_found_advice(nearest: float, unit: str = "mm") -> str:
    """What a refusal says of the nearest lattice state its search found, ``nearest`` (the
    tool point's error, in ``unit``) away: a tolerance that admits it, rounded up to three
    significant digits so that giving the figure as printed finds that state again. A search
    that found none nearer does not prove there is none, so no least tolerance is claimed."""
    digits = 2 - math.floor(math.log10(nearest)) if nearest > 0 else 0
    allow = math.ceil(nearest * 10**digits) / 10**digits
    if allow < nearest:  # the division's rounding: one more in the last digit
        allow = (math.ceil(nearest * 10**digits) + 1) / 10**digits
    return (
        f"the nearest found is {nearest:.4g} {unit} away: a tolerance of {allow:g} {unit} "
        "admits it (--tolerance, a scene task's tolerance_mm, or tolerance_mm= in Python)"
    )
