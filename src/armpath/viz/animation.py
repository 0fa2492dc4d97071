"""Animations (GIF, or MP4 when ffmpeg is installed) of an arm moving through joint states."""

from __future__ import annotations

import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.animation import FFMpegWriter, FuncAnimation, PillowWriter
from matplotlib.artist import Artist
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.axes3d import Axes3D
from numpy.typing import ArrayLike, NDArray

from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError
from armpath.kinematics import landmark_positions, tool_position
from armpath.model.serial_arm import SerialArm
from armpath.results import PlannedResult
from armpath.scenes import Scene
from armpath.viz.figures import draw_obstacles, draw_table, set_equal_axes

FloatArray = NDArray[np.float64]
ANIMATION_FORMATS = (".gif", ".mp4")


@dataclass(frozen=True)
class Overlay:
    """Fixed things drawn in every frame: ``points`` ``(k, 3)`` as markers or a ``line``."""

    points: FloatArray
    label: str
    style: str = "line"  # "line" or "points"
    color: str = "tab:green"


@dataclass(frozen=True)
class Animation:
    """What to animate: joint states ``q`` ``(frames, n)`` (rad, or model unit if prismatic) at
    ``times`` (s, or command number with ``clock="command {:.0f}"``); optional scene, overlays
    and a per-frame caption."""

    arm: SerialArm
    q: FloatArray
    times: FloatArray
    title: str = ""
    scene: Scene | None = None
    overlays: Sequence[Overlay] = field(default_factory=tuple)
    caption: Callable[[int], str] | None = None
    clock: str = "t = {:7.2f} s"


def sequence_animation(
    arm: SerialArm,
    scene: Scene | None,
    sequence: CommandSequence,
    title: str,
    targets_mm: ArrayLike | None = None,
    curve_mm: ArrayLike | None = None,
    substeps: int = 4,
) -> Animation:
    """The arm through every command of ``sequence`` (``substeps`` frames a command before
    thinning) in its scene, with the targets and the curve drawn."""
    q = sequence.sample_motion(substeps)
    steps = np.linspace(0.0, sequence.n_commands, q.shape[0])
    overlays: list[Overlay] = []
    if curve_mm is not None:
        overlays.append(Overlay(np.asarray(curve_mm, dtype=float), "curve", "line", "tab:orange"))
    targets = np.zeros((0, 3)) if targets_mm is None else np.asarray(targets_mm, float)
    targets = targets.reshape(-1, 3)
    if len(targets):
        overlays.append(Overlay(targets, "target" if len(targets) == 1 else "targets", "points"))
    return Animation(
        arm, q, steps, title, scene=scene, overlays=tuple(overlays), clock="command {:4.0f}"
    )


def result_animation(result: PlannedResult, substeps: int = 4) -> Animation:
    """The animation of a result document read back (``armpath.results.load_result``)."""
    return sequence_animation(
        result.arm,
        result.scene,
        result.sequence,
        result.title(),
        result.targets_mm,
        result.curve_mm,
        substeps,
    )


def frames_for(times: ArrayLike, max_frames: int) -> NDArray[np.int64]:
    """Indices of at most ``max_frames`` samples evenly spread over ``times`` (first and last
    included)."""
    n = len(np.asarray(times))
    if n == 0:
        raise InvalidInputError("nothing to animate: no states")
    return np.unique(np.linspace(0, n - 1, min(n, max(2, max_frames))).round().astype(np.int64))


def write_animation(
    path: str | Path,
    anim: Animation,
    *,
    fps: int = 15,
    max_frames: int = 120,
    dpi: int = 80,
) -> int:
    """Write ``anim`` to ``path`` (``.gif`` with Pillow, ``.mp4`` with ffmpeg); returns the
    number of frames. At most ``max_frames`` evenly spread states are drawn; the fingertip's
    path so far is traced in red."""
    out = Path(path)
    if out.suffix not in ANIMATION_FORMATS:
        raise InvalidInputError(f"animation must be one of {ANIMATION_FORMATS}, got {out.name!r}")
    if out.suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise InvalidInputError("MP4 needs ffmpeg on the PATH; write a .gif instead")
    q = np.asarray(anim.q, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != anim.arm.n_joints or q.shape[0] != len(anim.times):
        raise InvalidInputError(
            f"need one state of {anim.arm.n_joints} joints per time, got {q.shape} for "
            f"{len(anim.times)} times"
        )
    idx = frames_for(anim.times, max_frames)
    arms = landmark_positions(anim.arm, q[idx])
    tips = tool_position(anim.arm, q)
    fig = Figure(figsize=(6.4, 5.6))
    ax = fig.add_subplot(projection="3d")
    assert isinstance(ax, Axes3D)
    framing = [arms.reshape(-1, 3), tips, np.zeros((1, 3))]
    if anim.scene is not None:
        framing += draw_obstacles(ax, anim.scene)
    for overlay in anim.overlays:
        pts = np.asarray(overlay.points, dtype=np.float64).reshape(-1, 3)
        if overlay.style == "points":
            ax.scatter(
                *pts.T, color=overlay.color, s=40, marker="*", label=overlay.label, depthshade=False
            )
        else:
            ax.plot(*pts.T, color=overlay.color, lw=1.2, label=overlay.label)
        framing.append(pts)
    set_equal_axes(ax, np.vstack(framing))
    if anim.scene is not None:
        draw_table(ax, anim.scene)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(4))  # fewer labels: each is redrawn every frame
    ax.view_init(elev=22, azim=-60)
    (arm_line,) = ax.plot([], [], [], "-o", color="tab:blue", lw=2.5, ms=4, label="arm")
    (trail,) = ax.plot([], [], [], color="tab:red", lw=1.2, label="fingertip path")
    ax.legend(loc="upper left", fontsize=7)
    caption = fig.text(0.02, 0.02, "", fontsize=9, family="monospace")
    fig.suptitle(anim.title, fontsize=10)

    def draw(frame: int) -> list[Artist]:
        k = int(idx[frame])
        arm_line.set_data_3d(*arms[frame].T)
        trail.set_data_3d(*tips[: k + 1].T)
        text = anim.clock.format(anim.times[k])
        if anim.caption is not None:
            text += "   " + anim.caption(k)
        caption.set_text(text)
        return [arm_line, trail, caption]

    animation = FuncAnimation(fig, draw, frames=len(idx), blit=False)
    writer = PillowWriter(fps=fps) if out.suffix == ".gif" else FFMpegWriter(fps=fps)
    animation.save(str(out), writer=writer, dpi=dpi)
    return len(idx)
