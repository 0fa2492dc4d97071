"""What a lower bound on commands reports."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class CommandBound:
    """A lower bound on commands: ``commands`` (the value rounded up), the ``value`` in
    fractional commands, its parts (a trace's ``approach`` and ``along``), how it was
    computed, and the joint path that attains it (the *guide*: configurations rad, one per
    layer, with the arc length of each layer for a trace; for a tour whose orders are bounded
    together, ``guide_order`` the order of its targets). A tour's ``clear_path_q``: the
    cheapest path the search found through members that are clear themselves (configurations
    rad, one per target in its order ``clear_path_order``; None without one), which a plan may
    follow. ``unproven_because``: why the value is not proven, in words ("" where it is:
    :attr:`proven`); where the samples do not cover the family (an arm with more joints than
    the tool point and its direction need: one member of its self-motion per tool frame), or
    a plan undercut it, the value is an estimate."""

    commands: int
    value: float
    method: str
    parts: dict[str, float] = field(default_factory=dict)
    sampling: dict[str, float] = field(default_factory=dict)
    guide_q: FloatArray | None = None
    guide_s_mm: FloatArray | None = None
    guide_order: tuple[int, ...] | None = None
    clear_path_q: FloatArray | None = None
    clear_path_order: tuple[int, ...] | None = None
    unproven_because: str = ""

    @property
    def proven(self) -> bool:
        """Whether the value is a proven lower bound (no reason it is not)."""
        return not self.unproven_because

    def describe(self) -> dict[str, object]:
        return {
            "commands": self.commands,
            "value_commands": round(self.value, 4),
            "proven": self.proven,
            **({"unproven_because": self.unproven_because} if not self.proven else {}),
            "method": self.method,
            "parts_commands": {k: round(v, 4) for k, v in self.parts.items()},
            "sampling": {k: round(v, 6) for k, v in self.sampling.items()},
        }

    def against_plan(self, commands: int) -> CommandBound:
        """This bound as a plan of ``commands`` commands leaves it: itself where it is no more;
        above the plan it is no lower bound (its samples missed members of the family), and is
        kept as an estimate that says so."""
        if self.commands <= commands:
            return self
        why = f"refuted by a plan of {commands} commands" + (
            f"; {self.unproven_because}"
            if self.unproven_because
            else ": the samples missed members of the family"
        )
        return replace(self, unproven_because=why)
