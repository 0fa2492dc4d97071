"""PNG figures of a sampled workspace: sections through the voxel grid."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from armpath.workspace import VoxelGrid
from armpath.workspace.blindzones import FaceBlindness, PlaneMap
from armpath.workspace.design import DesignMetrics


def pretty_units(text: str) -> str:
    """``mm^2``, ``m^3`` ... written with superscripts (mm², m³) for figure text."""
    return text.replace("^2", "²").replace("^3", "³")


def _axis_label(name: str) -> str:
    """Axis label of a plane-map coordinate: ``rho`` is the signed distance from axis 1."""
    if name == "rho":
        return "±ρ, distance from axis 1 [mm] (mirrored)"
    return f"{name} [mm]"


#: Most pixels a map is drawn with along each side: a finer map is drawn in blocks, each
#: showing its highest level (a blind pixel stays visible), as a figure shows no more; 50
#: million pixels drawn whole took 2 GB.
_MOST_DRAWN_PIXELS = 2000


def _draw_levels(
    ax: Axes, image: np.ndarray, extent: tuple[float, float, float, float], cmap: ListedColormap
) -> None:
    """A map of levels 0, 1, 2 (``image[u, v]``) over ``extent``, u to the right."""
    block = -(-max(image.shape) // _MOST_DRAWN_PIXELS)
    if block > 1:
        nu, nv = -(-image.shape[0] // block), -(-image.shape[1] // block)
        padded = np.zeros((nu * block, nv * block), dtype=np.uint8)
        padded[: image.shape[0], : image.shape[1]] = image
        image = padded.reshape(nu, block, nv, block).max(axis=(1, 3))
    ax.imshow(
        image.T,
        origin="lower",
        extent=extent,
        cmap=cmap,
        vmin=0,
        vmax=2,
        interpolation="nearest",
    )


def plot_workspace_sections(
    path: str | Path, grid: VoxelGrid, centre: np.ndarray, title: str = ""
) -> Figure:
    """Two sections of the reachable voxels through ``centre`` (mm): the vertical plane
    y = centre_y (x-z) and the horizontal plane z = centre_z (x-y); boundary voxels darker,
    explained in a legend at the bottom. Returns the figure written."""
    boundary = grid.boundary()
    fig = Figure(figsize=(11, 5.6), dpi=110, layout="constrained")
    colours = ["white", "#9ecae1", "#08519c"]
    cmap = ListedColormap(colours)
    for k, (axis, value, labels) in enumerate(
        (("y", centre[1], ("x [mm]", "z [mm]")), ("z", centre[2], ("x [mm]", "y [mm]")))
    ):
        ax = fig.add_subplot(1, 2, k + 1)
        occ, extent = grid.section(axis, float(value))
        edge, _ = grid.section(axis, float(value), boundary)
        _draw_levels(ax, occ.astype(int) + edge.astype(int), extent, cmap)
        ax.set_xlabel(labels[0])
        ax.set_ylabel(labels[1])
        ax.set_aspect("equal")
        ax.set_title(f"section {axis} = {value:.0f} mm")
        ax.grid(alpha=0.3)
    fig.suptitle(pretty_units(title))
    _level_legend(fig, colours, ("not reached", "reachable voxel", "boundary voxel"))
    fig.savefig(path)
    return fig


def _level_legend(fig: Figure, colours: Sequence[str], names: Sequence[str]) -> None:
    """A legend of the map colours (edged squares), in a row at the bottom."""
    handles = [Patch(facecolor=c, edgecolor="0.4", linewidth=0.6) for c in colours]
    fig.legend(handles, names, loc="outside lower center", ncol=len(names), frameon=False)


def plot_blind_maps(path: str | Path, maps: list[tuple[PlaneMap, str]], title: str = "") -> Figure:
    """Reachable (blue) and enclosed blind (red) pixels of plane maps, side by side, with a
    legend of the colours at the bottom. Returns the figure written."""
    colours = ["white", "#9ecae1", "#de2d26"]
    cmap = ListedColormap(colours)
    fig = Figure(figsize=(5.4 * len(maps), 6.0), dpi=110, layout="constrained")
    for k, (m, label) in enumerate(maps):
        ax = fig.add_subplot(1, len(maps), k + 1)
        nu, nv = m.reach.shape
        extent = (
            float(m.origin[0]),
            float(m.origin[0] + nu * m.pixel),
            float(m.origin[1]),
            float(m.origin[1] + nv * m.pixel),
        )
        _draw_levels(ax, m.reach.astype(np.uint8) + 2 * m.blind.astype(np.uint8), extent, cmap)
        ax.set_xlabel(_axis_label(m.axes[0]))
        ax.set_ylabel(_axis_label(m.axes[1]))
        ax.set_aspect("equal")
        ax.set_title(pretty_units(f"{label}\nblind (red) {m.blind_area / 100:.0f} cm^2"))
        ax.grid(alpha=0.3)
    fig.suptitle(pretty_units(title))
    _level_legend(fig, colours, ("not reached", "reachable", "blind: enclosed, not reached"))
    fig.savefig(path)
    return fig


def plot_face_blindness(path: str | Path, faces: list[FaceBlindness], title: str = "") -> Figure:
    """Blind fraction of each horizontal circle against its height, per face; returns the
    figure written."""
    fig = Figure(figsize=(6.5, 4.5), dpi=110, layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    for f in faces:
        ax.plot(
            100.0 * f.blind_mm / f.length_mm,
            f.heights,
            "o-",
            label=f"{f.face} face: {100 * f.blind_fraction:.1f} % blind",
        )
    ax.set_xlabel("unreachable part of the circle [%]")
    ax.set_ylabel("height z [mm]")
    ax.set_xlim(-2, 102)  # markers at 0 % and 100 % drawn whole
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(pretty_units(title))
    fig.savefig(path)
    return fig


def plot_design_sweep(
    path: str | Path, results: Sequence[DesignMetrics], reference: DesignMetrics
) -> Figure:
    """Reach volume above the table against the central blind zone of each candidate design;
    returns the figure written."""
    fig = Figure(figsize=(7, 5), dpi=110, layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    blind = [r.blind_volume_mm3 / 1e6 for r in results]
    vol = [r.reach_volume_mm3 / 1e9 for r in results]
    ab = [r.geometry.ab_mm for r in results]
    sc = ax.scatter(blind, vol, c=ab, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="AB [mm]")
    ax.scatter(
        [reference.blind_volume_mm3 / 1e6],
        [reference.reach_volume_mm3 / 1e9],
        marker="*",
        s=200,
        c="red",
        label="seed arm",
    )
    best = results[0]
    ax.scatter(
        [best.blind_volume_mm3 / 1e6],
        [best.reach_volume_mm3 / 1e9],
        marker="o",
        s=160,
        facecolors="none",
        edgecolors="k",
        label="recommended",
    )
    ax.set_xlabel("central blind zone [litres]")
    ax.set_ylabel("reach volume above the table [m³]")
    ax.margins(0.06)  # markers at the extremes drawn whole
    ax.grid(alpha=0.3)
    ax.legend(loc="best")
    ax.set_title("seed-arm designs at a fixed total link length")
    fig.savefig(path)
    return fig
