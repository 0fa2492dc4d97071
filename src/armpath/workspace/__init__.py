"""Workspace analysis: reachable voxels by joint-space sampling, dexterous points."""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.workspace.sampling import (
        METHODS,
        GridSpec,
        VoxelGrid,
        joint_ranges,
        sample_workspace,
    )

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "sampling": (
            "METHODS",
            "GridSpec",
            "VoxelGrid",
            "joint_ranges",
            "sample_workspace",
        ),
    },
)

__all__ = ["METHODS", "GridSpec", "VoxelGrid", "joint_ranges", "sample_workspace"]
