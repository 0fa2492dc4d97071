"""armpath: motion design for serial arms driven by quantized incremental joint commands.

The Python API (millimetres and degrees; see ``docs/api.md``)::

    import armpath

    result = armpath.reach("seed", [300.0, 100.0, 200.0])
    print(result.n_commands, result.doc["error_mm"])
    result.save("reach.json")

:func:`load_arm`, :func:`load_scene`, :func:`forward_kinematics`, :func:`inverse_kinematics`,
:func:`reach`, :func:`plan`, :func:`trace`, :func:`spotweld` and :func:`load_result` are
imported on first use, so ``import armpath`` stays cheap.
"""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

__version__ = "0.1.0"

if TYPE_CHECKING:
    from armpath.api import (
        forward_kinematics,
        inverse_kinematics,
        load_arm,
        load_scene,
        plan,
        reach,
        spotweld,
        trace,
    )
    from armpath.results import Result, load_result

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "api": (
            "forward_kinematics",
            "inverse_kinematics",
            "load_arm",
            "load_scene",
            "plan",
            "reach",
            "spotweld",
            "trace",
        ),
        "results": ("Result", "load_result"),
    },
)

__all__ = [
    "Result",
    "__version__",
    "forward_kinematics",
    "inverse_kinematics",
    "load_arm",
    "load_result",
    "load_scene",
    "plan",
    "reach",
    "spotweld",
    "trace",
]
