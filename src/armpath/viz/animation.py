"""Animations (GIF, or MP4 when ffmpeg is installed) of an arm moving through joint states."""

from __future__ import annotations

import math
import shutil
import subprocess
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from matplotlib.artist import Artist
from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.ticker import MaxNLocator
from mpl_toolkits.mplot3d.axes3d import Axes3D
from numpy.typing import ArrayLike, NDArray
from PIL import Image

from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError
from armpath.kinematics import landmark_positions, tool_position
from armpath.model.serial_arm import SerialArm
from armpath.scenes import Scene
from armpath.viz.figures import (
    POINT_LABEL,
    draw_obstacles,
    draw_table,
    drawn_chain,
    label_axes_3d,
    set_equal_axes,
    tip_label,
)

FloatArray = NDArray[np.float64]
ANIMATION_FORMATS = (".gif", ".mp4")
#: Most frames per second of a GIF: its frames last a whole number of hundredths of a second,
#: and browsers show a frame of less than 20 ms for 100 ms (faster came out slower).
MAX_GIF_FPS = 50
#: Most frames per second of an MP4.
MAX_MP4_FPS = 120
#: Most frames of one animation: each is held as a 640 x 560 image (1.4 MB) until written.
MAX_ANIMATION_FRAMES = 1000
#: How long a GIF shows its last frame (s) before the loop starts again, so the final pose can
#: be seen rather than flashing for one frame.
GIF_HOLD_LAST_S = 1.0
#: Shortest motion a GIF shows (s, from the first frame to the last): a motion of few frames
#: gets longer frames rather than being over before it can be followed.
GIF_MIN_MOTION_S = 1.0
#: Fewest states :func:`sequence_animation` samples of a motion of at least one command: a
#: short sequence gets more instants a command, so it moves smoothly and lasts a while.
MIN_SEQUENCE_STATES = 25


def check_animation_rate(
    suffix: str, fps: float, max_frames: float, names: tuple[str, str] = ("fps", "max_frames")
) -> None:
    """Refuse frames per second or a frame count an animation of ``suffix`` (``.gif``,
    ``.mp4``) cannot have, naming them as ``names`` (the options that set them)."""
    most_fps = MAX_GIF_FPS if suffix == ".gif" else MAX_MP4_FPS
    if not (isinstance(fps, int | float | np.number) and 1 <= fps <= most_fps):
        raise InvalidInputError(
            f"{names[0]} must be from 1 to {most_fps} frames per second for a "
            f"{suffix.lstrip('.').upper()}, got {fps}"
        )
    if not (isinstance(max_frames, int | np.integer) and 2 <= max_frames <= MAX_ANIMATION_FRAMES):
        raise InvalidInputError(
            f"{names[1]} must be a whole number of frames from 2 to {MAX_ANIMATION_FRAMES}, "
            f"got {max_frames}"
        )


#: Resolution of the frames (dots per inch of the 6.4 x 5.6 inch figure: 640 x 560 pixels).
ANIMATION_DPI = 100
#: Font sizes (points) in the frames; at :data:`ANIMATION_DPI` the smallest, 10 pt, is 14 px.
TITLE_PT = 12.0
TEXT_PT = 10.5
TICK_PT = 10.0


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
    thinning, more for a sequence that would have fewer than :data:`MIN_SEQUENCE_STATES`) in
    its scene, with the targets and the curve drawn."""
    if sequence.n_commands:
        substeps = max(substeps, -(-(MIN_SEQUENCE_STATES - 1) // sequence.n_commands))
    q = sequence.sample_motion(substeps)
    steps = np.linspace(0.0, sequence.n_commands, q.shape[0])
    overlays: list[Overlay] = []
    if curve_mm is not None:
        # dark and thin: the red fingertip path drawn over it shows how far it is traced
        overlays.append(Overlay(np.asarray(curve_mm, dtype=float), "curve", "line", "0.15"))
    targets = np.zeros((0, 3)) if targets_mm is None else np.asarray(targets_mm, float)
    targets = targets.reshape(-1, 3)
    if len(targets):
        overlays.append(Overlay(targets, "target" if len(targets) == 1 else "targets", "points"))
    return Animation(
        arm, q, steps, title, scene=scene, overlays=tuple(overlays), clock="command {:4.0f}"
    )


def frames_for(times: ArrayLike, max_frames: int) -> NDArray[np.int64]:
    """Indices of at most ``max_frames`` samples evenly spread over ``times`` (first and last
    included)."""
    n = len(np.asarray(times))
    if n == 0:
        raise InvalidInputError("nothing to animate: no states")
    return np.unique(np.linspace(0, n - 1, min(n, max(2, max_frames))).round().astype(np.int64))


@dataclass(frozen=True)
class AnimationFrames:
    """The figure of an animation and how to draw its frames: ``draw(i)`` puts frame ``i``
    (state ``state_index[i]`` of the animation) into ``figure`` and returns the artists it
    changed."""

    figure: Figure
    axes: Axes3D
    state_index: NDArray[np.int64]
    draw: Callable[[int], list[Artist]]

    @property
    def n_frames(self) -> int:
        return len(self.state_index)


def _fit_width(fig: Figure, text: Text, renderer: RendererAgg) -> None:
    """Wrap ``text`` onto more lines until it fits inside the figure's width (2 % margins)."""
    limit = 0.96 * fig.bbox.width
    original = text.get_text()
    width = len(original)
    while width > 10 and text.get_window_extent(renderer).width > limit:
        width = int(width * 0.85)
        text.set_text(textwrap.fill(original, width))


def animation_frames(
    anim: Animation, max_frames: int = 120, dpi: int = ANIMATION_DPI
) -> AnimationFrames:
    """Build the figure of ``anim`` (at most ``max_frames`` evenly spread states) at ``dpi``.

    Title on top (wrapped to the width), the legend in a row under it, the 3-D view below and
    the caption (clock, ``anim.caption``) at the bottom. The axis limits frame everything any
    frame draws: every state's arm, the whole fingertip path, the overlays and the scene's
    obstacles, with equal scales on x, y and z.
    """
    q = np.asarray(anim.q, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != anim.arm.n_joints or q.shape[0] != len(anim.times):
        raise InvalidInputError(
            f"need one state of {anim.arm.n_joints} joints per time, got {q.shape} for "
            f"{len(anim.times)} times"
        )
    idx = frames_for(anim.times, max_frames)
    arms = landmark_positions(anim.arm, q[idx])[:, drawn_chain(anim.arm)]
    tips = tool_position(anim.arm, q)
    fig = Figure(figsize=(6.4, 5.6), dpi=dpi)
    # to measure the title and the legend
    renderer = FigureCanvasAgg(fig).get_renderer()  # type: ignore[no-untyped-call]
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0), projection="3d")
    assert isinstance(ax, Axes3D)
    framing = [arms.reshape(-1, 3), tips, np.zeros((1, 3))]
    if anim.scene is not None:
        framing += draw_obstacles(ax, anim.scene)
    for overlay in anim.overlays:
        pts = np.asarray(overlay.points, dtype=np.float64).reshape(-1, 3)
        if overlay.style == "points":
            ax.plot(*pts.T, "*", color=overlay.color, ms=10, label=overlay.label)
            for k, p in enumerate(pts if len(pts) > 1 else []):
                ax.text(*p, f"{k + 1}", **{**POINT_LABEL, "fontsize": TEXT_PT})
        else:
            ax.plot(*pts.T, color=overlay.color, lw=1.2, label=overlay.label)
        framing.append(pts)
    set_equal_axes(ax, np.vstack(framing), zoom=1.1)
    if anim.scene is not None:
        draw_table(ax, anim.scene)
    label_axes_3d(ax, fontsize=TEXT_PT, labelpad=9.0)
    ax.tick_params(labelsize=TICK_PT)
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(4))  # fewer labels: each is redrawn every frame
    ax.view_init(elev=22, azim=-60)
    (arm_line,) = ax.plot([], [], [], "-o", color="tab:blue", lw=2.5, ms=5, label="arm")
    (trail,) = ax.plot([], [], [], color="tab:red", lw=1.8, label=f"{tip_label(anim.arm)} path")

    # layout, measured from the top: title, legend, 3-D view, caption
    title = fig.suptitle(anim.title, fontsize=TITLE_PT, y=0.985, va="top")
    _fit_width(fig, title, renderer)
    below_title = title.get_window_extent(renderer).y0 / fig.bbox.height if anim.title else 0.99
    handles, labels = ax.get_legend_handles_labels()
    legend = fig.legend(
        handles,
        labels,
        loc="upper center",
        bbox_to_anchor=(0.5, below_title),
        ncol=min(len(labels), 4),
        fontsize=TEXT_PT,
        frameon=False,
        handlelength=1.6,
        columnspacing=1.2,
    )
    below_legend = legend.get_window_extent(renderer).y0 / fig.bbox.height
    caption = fig.text(0.02, 0.015, "", fontsize=TEXT_PT + 0.5, family="monospace")
    bottom = 0.08
    # the 3-D box leaves room around itself for its tick and axis labels
    ax.set_position((0.03, bottom, 0.94, below_legend - bottom))

    def draw(frame: int) -> list[Artist]:
        k = int(idx[frame])
        arm_line.set_data_3d(*arms[frame].T)
        trail.set_data_3d(*tips[: k + 1].T)
        text = anim.clock.format(anim.times[k])
        if anim.caption is not None:
            text += "   " + anim.caption(k)
        caption.set_text(text)
        return [arm_line, trail, caption]

    return AnimationFrames(fig, ax, idx, draw)


def write_animation(
    path: str | Path,
    anim: Animation,
    *,
    fps: int = 15,
    max_frames: int = 120,
    dpi: int = ANIMATION_DPI,
) -> int:
    """Write ``anim`` to ``path`` (``.gif`` with Pillow, ``.mp4`` with ffmpeg); returns the
    number of frames. At most ``max_frames`` evenly spread states are drawn
    (:func:`animation_frames`; at most :data:`MAX_ANIMATION_FRAMES`, ``fps`` at most
    :data:`MAX_GIF_FPS` for a GIF); the fingertip's path so far is traced in red.

    A GIF's frames last whole hundredths of a second: ``1/fps`` rounded to the nearest (15 fps:
    70 ms), longer if the motion would last less than :data:`GIF_MIN_MOTION_S`, and the last
    frame :data:`GIF_HOLD_LAST_S` more (:func:`gif_frame_durations_ms`). Every frame uses one
    palette, made from the first and the last frame, so fixed things keep their colours.

    The still part (scene, axes, title, legend) is drawn once; each frame redraws only the arm,
    its path and the caption over it (so the arm is never hidden behind an obstacle)."""
    out = Path(path)
    if out.suffix not in ANIMATION_FORMATS:
        raise InvalidInputError(f"animation must be one of {ANIMATION_FORMATS}, got {out.name!r}")
    check_animation_rate(out.suffix, fps, max_frames)
    ffmpeg = shutil.which("ffmpeg")
    if out.suffix == ".mp4" and ffmpeg is None:
        raise InvalidInputError("MP4 needs ffmpeg on the PATH; write a .gif instead")
    frames = animation_frames(anim, max_frames, dpi)
    images = render_frames(frames)
    if out.suffix == ".gif":
        _write_gif(out, images, gif_frame_durations_ms(len(images), fps))
    else:
        assert ffmpeg is not None
        _write_mp4(ffmpeg, out, images, fps)
    return frames.n_frames


def gif_frame_durations_ms(n_frames: int, fps: float) -> list[int]:
    """How long each of ``n_frames`` GIF frames lasts (ms) at ``fps``.

    A GIF stores a frame's delay in whole hundredths of a second, so ``1/fps`` is rounded to
    the nearest (half up; 15 fps: 70 ms, 14.3 frames a second); if the frames would move
    for less than :data:`GIF_MIN_MOTION_S` each lasts long enough that they do not (rounded up
    to a hundredth). The last frame lasts :data:`GIF_HOLD_LAST_S` longer: the final pose stays
    before the loop starts again. One frame: only the hold.
    """
    if n_frames < 1:
        raise InvalidInputError("nothing to animate: no frames")
    frame_cs = max(1, int(100.0 / fps + 0.5))
    if n_frames > 1:
        frame_cs = max(frame_cs, math.ceil(100.0 * GIF_MIN_MOTION_S / (n_frames - 1) - 1e-9))
    hold_cs = round(100.0 * GIF_HOLD_LAST_S)
    return [10 * frame_cs] * (n_frames - 1) + [10 * (frame_cs + hold_cs)]


#: Colours of a GIF's one palette (a GIF palette holds at most 256).
_GIF_COLOURS = 256


def gif_palette(images: Sequence[NDArray[np.uint8]]) -> Image.Image:
    """One palette for every frame of a GIF: the :data:`_GIF_COLOURS` colours most frequent in
    ``images`` (RGB or RGBA ``(height, width, 3 or 4)``; the alpha is ignored), as a ``P``
    image for ``Image.quantize(palette=...)``.

    The figures' lines, markers, text and panes are flat colours covering many pixels, so each
    is in the palette exactly; the rarer anti-aliased edge shades go to their nearest colour.
    """
    rgb = np.concatenate([np.asarray(im)[..., :3].reshape(-1, 3) for im in images])
    packed = (rgb[:, 0].astype(np.uint32) << 16) | (rgb[:, 1].astype(np.uint32) << 8) | rgb[:, 2]
    colours, counts = np.unique(packed, return_counts=True)
    kept = colours[np.argsort(-counts, kind="stable")[:_GIF_COLOURS]]
    kept = np.resize(kept, _GIF_COLOURS)  # fewer colours: repeated, the palette is whole
    table = np.stack([(kept >> 16) & 255, (kept >> 8) & 255, kept & 255], axis=1)
    palette = Image.new("P", (1, 1))
    palette.putpalette(table.astype(np.uint8).ravel().tobytes())
    return palette


def _write_gif(out: Path, images: list[NDArray[np.uint8]], durations_ms: list[int]) -> None:
    """Write RGBA ``images`` as a looping GIF whose frames last ``durations_ms``.

    One palette serves every frame (:func:`gif_palette` of the first and the last frame: the
    still part, the arm at both ends, the whole tip path), and each frame is mapped to it
    without dithering, so what does not move keeps its pixels. Quantized one by one, each frame
    got its own palette and a fixed line changed colour between frames (a red path turned
    brown).
    """
    palette = gif_palette([images[0], images[-1]])
    first, *rest = (
        Image.fromarray(rgba).convert("RGB").quantize(palette=palette, dither=Image.Dither.NONE)
        for rgba in images
    )
    first.save(out, save_all=True, append_images=rest, duration=durations_ms, loop=0)


def render_frames(frames: AnimationFrames) -> list[NDArray[np.uint8]]:
    """Every frame of ``frames`` as an RGBA image ``(height, width, 4)``: the figure without
    its moving artists is rendered once, then each frame restores it and draws only what
    :attr:`AnimationFrames.draw` changed."""
    fig = frames.figure
    canvas = FigureCanvasAgg(fig)
    moving = frames.draw(0)
    for artist in moving:
        artist.set_animated(True)
    # the still part; drawing it also sets the 3-D projection the moving lines use
    canvas.draw()  # type: ignore[no-untyped-call]
    background = canvas.copy_from_bbox(fig.bbox)  # type: ignore[no-untyped-call]
    out = []
    for i in range(frames.n_frames):
        canvas.restore_region(background)  # type: ignore[no-untyped-call]
        for artist in frames.draw(i):
            fig.draw_artist(artist)
        out.append(np.array(canvas.buffer_rgba(), dtype=np.uint8))  # type: ignore[no-untyped-call]
    return out


def _write_mp4(ffmpeg: str, out: Path, images: list[NDArray[np.uint8]], fps: int) -> None:
    """Encode RGBA ``images`` into ``out`` with ffmpeg (H.264, sides padded to even)."""
    height, width = images[0].shape[:2]
    command = [
        ffmpeg, "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgba",
        "-s", f"{width}x{height}", "-r", str(fps), "-i", "-",
        "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", "-vcodec", "libx264",
        str(out),
    ]  # fmt: skip
    done = subprocess.run(command, input=b"".join(i.tobytes() for i in images), check=False)
    if done.returncode != 0:
        out.unlink(missing_ok=True)
        raise InvalidInputError(f"ffmpeg could not write {out.name} (exit {done.returncode})")
