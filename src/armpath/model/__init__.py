"""Robot models: serial chains of joints with axes, origins and limits."""

from armpath.model.seed_arm import SEED_HOME_DEG, SeedArmGeometry, seed_arm, seed_geometry_of
from armpath.model.serial_arm import Joint, JointKind, Landmark, Link, SerialArm

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
