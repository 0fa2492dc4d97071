"""The choices a plan is asked for: what it minimises and how a tour orders its targets.

Kept apart from the planners so the command line can offer them without importing a planner.
"""

from __future__ import annotations

from enum import StrEnum


class Objective(StrEnum):
    """What a plan minimises after reaching its goal."""

    COMMANDS = "commands"  # number of commands (time)
    PATH = "path"  # fingertip path length (mm)
    ENERGY = "energy"  # weighted joint travel (deg)


class VisitOrder(StrEnum):
    """How a tour orders its targets."""

    AUTO = "auto"  # every order ranked by its lower bound, the best planned
    GIVEN = "given"  # as listed


__all__ = ["Objective", "VisitOrder"]
