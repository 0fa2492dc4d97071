"""The choices a plan is asked for: what it minimises and how a tour orders its targets.

Kept apart from the planners so the command line can offer them without importing a planner.
"""

from __future__ import annotations

from enum import StrEnum

from armpath.errors import InvalidInputError


class Objective(StrEnum):
    """What a plan minimises after reaching its goal."""

    COMMANDS = "commands"  # number of commands (time)
    PATH = "path"  # fingertip path length (mm)
    ENERGY = "energy"  # weighted joint travel (deg)


def objective_of(value: Objective | str) -> Objective:
    """The objective named ``value``; :class:`InvalidInputError` lists the valid names."""
    try:
        return Objective(value)
    except ValueError:
        valid = ", ".join(o.value for o in Objective)
        raise InvalidInputError(f"objective must be one of {valid}, got {value!r}") from None


class VisitOrder(StrEnum):
    """How a tour orders its targets."""

    AUTO = "auto"  # every order ranked by its lower bound, the best planned
    GIVEN = "given"  # as listed


__all__ = ["Objective", "VisitOrder", "objective_of"]
