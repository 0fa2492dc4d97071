"""Robot models: serial chains of joints with axes, origins and limits."""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.model.seed_arm import SEED_HOME_DEG, SeedArmGeometry, seed_arm, seed_geometry_of
    from armpath.model.serial_arm import Joint, JointKind, Landmark, Link, SerialArm

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "seed_arm": (
            "SEED_HOME_DEG",
            "SeedArmGeometry",
            "seed_arm",
            "seed_geometry_of",
        ),
        "serial_arm": (
            "Joint",
            "JointKind",
            "Landmark",
            "Link",
            "SerialArm",
        ),
    },
)

__all__ = [
    "SEED_HOME_DEG",
    "Joint",
    "JointKind",
    "Landmark",
    "Link",
    "SeedArmGeometry",
    "SerialArm",
    "seed_arm",
    "seed_geometry_of",
]
