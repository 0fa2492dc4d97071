"""PNG figures of plans: a 3-D view of the motion in the scene, joint angles per step."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.axes3d import Axes3D
from numpy.typing import ArrayLike

from armpath.commands import CommandSequence, ticks_to_deg, ticks_to_rad
from armpath.geometry.primitives import Box, HalfSpace, SolidOfRevolution, Sphere
from armpath.kinematics import landmark_positions
from armpath.model.serial_arm import SerialArm
from armpath.scenes import Scene


def _draw_solid(ax: Axes3D, solid: SolidOfRevolution, n_theta: int = 48) -> np.ndarray:
    """Draw the surface of a solid of revolution (every profile edge off the axis).

    Returns the drawn surface points ``(K, 3)`` for framing the view.
    """
    drawn = []
    axis = solid.axis
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    theta = np.linspace(0.0, 2.0 * np.pi, n_theta)
    prof = solid.profile
    for a, b, keep in zip(prof, np.roll(prof, -1, axis=0), solid.boundary_edges, strict=True):
        if not keep:
            continue
        s = np.linspace(0.0, 1.0, 2)
        r = a[0] + s * (b[0] - a[0])
        z = a[1] + s * (b[1] - a[1])
        R, T = np.meshgrid(r, theta)
        Z, _ = np.meshgrid(z, theta)
        pts = (
            solid.origin
            + R[..., None] * (np.cos(T)[..., None] * u + np.sin(T)[..., None] * v)
            + Z[..., None] * axis
        )
        ax.plot_surface(
            pts[..., 0],
            pts[..., 1],
            pts[..., 2],
            color="tan",
            alpha=0.25,
            linewidth=0,
            shade=True,
        )
        drawn.append(pts.reshape(-1, 3))
    return np.vstack(drawn) if drawn else np.zeros((0, 3))


def _draw_sphere(ax: Axes3D, s: Sphere) -> np.ndarray:
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.linspace(0, np.pi, 12))
    x = s.center[0] + s.radius * np.cos(u) * np.sin(v)
    y = s.center[1] + s.radius * np.sin(u) * np.sin(v)
    z = s.center[2] + s.radius * np.cos(v)
    ax.plot_surface(x, y, z, color="tan", alpha=0.25, linewidth=0)
    return np.stack([x, y, z], axis=-1).reshape(-1, 3)


def _draw_box(ax: Axes3D, b: Box) -> np.ndarray:
    signs = np.array([[(c >> k) & 1 for k in range(3)] for c in range(8)]) * 2 - 1
    corners = b.center + (signs * b.half_extents) @ b.rotation.T
    for i in range(8):
        for k in range(3):
            j = i ^ (1 << k)
            if j > i:
                ax.plot(*corners[[i, j]].T, color="saddlebrown", alpha=0.6, linewidth=1)
    return np.asarray(corners)


def _draw_table(ax: Axes3D) -> None:
    """The plane z = 0 across the current x and y limits."""
    X, Y = np.meshgrid(np.array(ax.get_xlim()), np.array(ax.get_ylim()))
    ax.plot_surface(X, Y, np.zeros_like(X), color="0.8", alpha=0.2, linewidth=0)


def _set_equal(ax: Axes3D, pts: np.ndarray) -> None:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    center = (lo + hi) / 2
    half = max(float((hi - lo).max()) / 2, 1.0)
    ax.set_xlim(center[0] - half, center[0] + half)
    ax.set_ylim(center[1] - half, center[1] + half)
    ax.set_zlim(max(center[2] - half, -10.0), center[2] + half)
    ax.set_box_aspect((1, 1, 1))


def plot_motion_3d(
    path: str | Path,
    arm: SerialArm,
    scene: Scene,
    seq: CommandSequence,
    target: ArrayLike | None = None,
    title: str = "",
) -> None:
    """3-D view: obstacles, the arm at start (grey) and end (blue), the continuous tip path."""
    fig = Figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    assert isinstance(ax, Axes3D)
    motion = landmark_positions(arm, seq.sample_motion(8))
    states = landmark_positions(arm, ticks_to_rad(seq.states()))
    pts = [motion.reshape(-1, 3), np.zeros((1, 3))]
    for obstacle in scene.world.obstacles:
        if isinstance(obstacle, SolidOfRevolution):
            pts.append(_draw_solid(ax, obstacle))
        elif isinstance(obstacle, Sphere):
            pts.append(_draw_sphere(ax, obstacle))
        elif isinstance(obstacle, Box):
            pts.append(_draw_box(ax, obstacle))
    step = max(1, len(states) // 12)
    for k in range(0, len(states), step):
        ax.plot(*states[k].T, color="0.6", alpha=0.35, linewidth=1)
    ax.plot(*states[0].T, "-o", color="0.35", linewidth=2.5, markersize=4, label="start")
    ax.plot(*states[-1].T, "-o", color="tab:blue", linewidth=2.5, markersize=4, label="end")
    ax.plot(*motion[:, -1].T, color="tab:red", linewidth=1.5, label="fingertip path")
    if target is not None:
        t = np.asarray(target, dtype=float).reshape(-1, 3)
        label = "target" if len(t) == 1 else "targets"
        ax.scatter(*t.T, color="tab:green", s=60, marker="*", label=label, depthshade=False)
        for k, p in enumerate(t if len(t) > 1 else []):
            ax.text(*p, f" {k + 1}", fontsize=9, color="tab:green")
        pts.append(t)
    for name, p in zip(arm.landmark_names, states[-1], strict=True):
        ax.text(*p, f" {name}", fontsize=8, color="tab:blue")
    _set_equal(ax, np.vstack(pts))
    if any(isinstance(o, HalfSpace) for o in scene.world.obstacles):
        _draw_table(ax)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    ax.set_title(title or f"{seq.n_commands} commands")
    ax.legend(loc="upper left", fontsize=8)
    ax.view_init(elev=22, azim=-60)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_joint_angles(path: str | Path, seq: CommandSequence, title: str = "") -> None:
    """Joint angles (deg) after each command, one line per joint."""
    degs = ticks_to_deg(seq.states())
    fig = Figure(figsize=(8, 4.5))
    ax = fig.add_subplot()
    steps = np.arange(degs.shape[0])
    for i in range(degs.shape[1]):
        ax.plot(steps, degs[:, i], label=f"θ{i + 1}", linewidth=1.6)
    ax.set_xlabel("command (0 = start)")
    ax.set_ylabel("joint angle [deg]")
    ax.set_title(title or "joint angles per command")
    ax.grid(alpha=0.3)
    ax.legend(ncol=6, fontsize=8, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
