"""One exception hierarchy for everything armpath rejects.

Every message says what was wrong and what would be valid, so the CLI can print it as a
one-line error and exit with a non-zero status.
"""

from __future__ import annotations


class ArmpathError(Exception):
    """Base class of every error armpath raises on purpose."""


class InvalidInputError(ArmpathError, ValueError):
    """An argument, file or value is malformed (NaN, wrong length, out of range, ...)."""


class JointLimitError(InvalidInputError):
    """A joint state lies outside the model's joint limits."""


class CommandError(InvalidInputError):
    """A command increment is not an integer number of ticks in [-20, 20]."""


class SceneError(InvalidInputError):
    """A scene file or scene description is invalid."""


class CollisionError(ArmpathError):
    """A state or motion violates the required clearance to an obstacle."""


class UnreachableError(ArmpathError):
    """A target cannot be reached; the message names the nearest reachable distance."""


class PlanningError(ArmpathError):
    """A planner could not produce a plan that meets all requirements."""


class TimeLimitError(ArmpathError):
    """The time limit set for a computation (``--time-limit``) ran out before it finished."""


class OutputError(ArmpathError):
    """Results could not be written (for example an unwritable output folder)."""


class ArmpathWarning(UserWarning):
    """Something about the input that is allowed but probably not meant (for example an arm's
    base standing inside an obstacle); the CLI prints it as one ``warning:`` line."""
