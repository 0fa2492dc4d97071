"""PNG figures of a sampled workspace: sections through the voxel grid."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from armpath.workspace import VoxelGrid


def plot_workspace_sections(
    path: str | Path, grid: VoxelGrid, centre: np.ndarray, title: str = ""
) -> None:
    """Two sections of the reachable voxels through ``centre`` (mm): the vertical plane
    y = centre_y (x-z) and the horizontal plane z = centre_z (x-y); boundary voxels darker."""
    boundary = grid.boundary()
    fig = Figure(figsize=(11, 5.2), dpi=110)
    cmap = ListedColormap(["white", "#9ecae1", "#08519c"])
    for k, (axis, value, labels) in enumerate(
        (("y", centre[1], ("x [mm]", "z [mm]")), ("z", centre[2], ("x [mm]", "y [mm]")))
    ):
        ax = fig.add_subplot(1, 2, k + 1)
        occ, extent = grid.section(axis, float(value))
        edge, _ = VoxelGrid(grid.origin, grid.voxel, boundary, grid.samples, grid.kept).section(
            axis, float(value)
        )
        image = occ.astype(int) + edge.astype(int)
        ax.imshow(
            image.T,
            origin="lower",
            extent=extent,
            cmap=cmap,
            vmin=0,
            vmax=2,
            interpolation="nearest",
        )
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.set_aspect("equal")
        ax.set_title(f"section {axis} = {value:.0f} mm")
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path)
