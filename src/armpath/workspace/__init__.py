"""Workspace analysis: reachable voxels by joint-space sampling, dexterous points."""

from armpath.workspace.sampling import METHODS, GridSpec, VoxelGrid, joint_ranges, sample_workspace

__all__ = ["METHODS", "GridSpec", "VoxelGrid", "joint_ranges", "sample_workspace"]
