"""PNG figures of plans: a 3-D view of the motion in the scene, joint angles per step, and the
crack trace (3-D view of the passes, deviation along the curve)."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator
from matplotlib.transforms import offset_copy
from mpl_toolkits.mplot3d import proj3d
from mpl_toolkits.mplot3d.axes3d import Axes3D
from numpy.typing import ArrayLike, NDArray

from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError
from armpath.geometry import is_mesh_obstacle
from armpath.geometry.primitives import (
    Box,
    Capsule,
    HalfSpace,
    SolidOfRevolution,
    Sphere,
    orthonormal_frame,
)
from armpath.kinematics import landmark_positions, tool_position
from armpath.model.lattice import Lattice
from armpath.model.serial_arm import SerialArm
from armpath.report import commands_text, passes_text
from armpath.scenes import Scene
from armpath.trajectory import PiecewisePolynomial

if TYPE_CHECKING:
    from armpath.geometry.mesh import MeshObstacle


def _draw_solid(ax: Axes3D, solid: SolidOfRevolution, n_theta: int = 48) -> np.ndarray:
    """Draw the surface of a solid of revolution (every profile edge off the axis).

    Returns the drawn surface points ``(K, 3)`` for framing the view.
    """
    drawn = []
    axis = solid.axis
    u, v = orthonormal_frame(axis)
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


def _draw_capsule(ax: Axes3D, c: Capsule) -> np.ndarray:
    """A capsule as its cylinder and the two spheres at its ends."""
    a, b = np.asarray(c.start, dtype=float), np.asarray(c.end, dtype=float)
    axis = b - a
    length = float(np.linalg.norm(axis))
    d = axis / length if length > 0 else np.array([0.0, 0.0, 1.0])
    e1, e2 = orthonormal_frame(d[None])
    u = np.linspace(0, 2 * np.pi, 24)
    ring = c.radius * (np.cos(u)[:, None] * e1 + np.sin(u)[:, None] * e2)  # (24, 3)
    t = np.array([0.0, 1.0])
    wall = a + t[:, None, None] * axis + ring[None]  # (2, 24, 3)
    ax.plot_surface(*np.moveaxis(wall, -1, 0), color="tan", alpha=0.25, linewidth=0)
    drawn = [wall.reshape(-1, 3)]
    for centre in (a, b):
        drawn.append(_draw_sphere(ax, Sphere("", centre, c.radius)))
    return np.vstack(drawn)


def _draw_mesh(ax: Axes3D, m: MeshObstacle) -> np.ndarray:
    """A mesh as its triangles (at most 4000 of them, evenly through the list)."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    faces = np.asarray(m.faces)
    if faces.shape[0] > 4000:
        faces = faces[np.linspace(0, faces.shape[0] - 1, 4000).astype(np.int64)]
    tri = np.asarray(m.vertices)[faces]
    ax.add_collection3d(
        Poly3DCollection(tri, facecolor="tan", edgecolor="saddlebrown", linewidths=0.2, alpha=0.25)
    )
    return np.asarray(m.vertices)


def _draw_box(ax: Axes3D, b: Box) -> np.ndarray:
    signs = np.array([[(c >> k) & 1 for k in range(3)] for c in range(8)]) * 2 - 1
    corners = b.center + (signs * b.half_extents) @ b.rotation.T
    for i in range(8):
        for k in range(3):
            j = i ^ (1 << k)
            if j > i:
                ax.plot(*corners[[i, j]].T, color="saddlebrown", alpha=0.6, linewidth=1)
    return np.asarray(corners)


def drawn_chain(arm: SerialArm) -> list[int]:
    """Landmark indices in the order the arm's links join them, base to tool point, each point
    with the others at the same place (a zero-length leg's ends: ``J6`` and ``tool``) beside
    it: the arm as one polyline. The landmarks list frame origins first and corners after, so
    drawn in their own order a line ran from a UR5's tool point back to its elbow."""
    order: list[int] = []
    for link in arm.links:
        for i in (link.start, link.end):
            if not order or order[-1] != i:
                order.append(i)
    at = landmark_positions(arm, arm.home)
    size = max(float(np.abs(at).max()), 1.0)
    for i in range(len(arm.landmarks)):
        if i in order:
            continue
        same = [k for k, o in enumerate(order) if np.linalg.norm(at[o] - at[i]) <= 1e-9 * size]
        if same:  # every landmark a link leaves out lies where the skeleton already is
            order.insert(same[0] + 1, i)
    return order


def tip_label(arm: SerialArm) -> str:
    """What the figures call the point the arm works with: the seed arm's fingertip (SPEC),
    any other arm's tool point."""
    return "fingertip" if arm.name == "seed" else "tool point"


def draw_table(ax: Axes3D, scene: Scene) -> None:
    """The table (plane z = 0) across the current x and y limits, if the scene has one; call
    after framing the axes."""
    if not any(isinstance(o, HalfSpace) for o in scene.world.obstacles):
        return
    X, Y = np.meshgrid(np.array(ax.get_xlim()), np.array(ax.get_ylim()))
    ax.plot_surface(X, Y, np.zeros_like(X), color="0.8", alpha=0.2, linewidth=0)


def set_equal_axes(
    ax: Axes3D, pts: np.ndarray, floor: float | None = -10.0, zoom: float = 1.0
) -> None:
    """Equal scales on x, y, z framing every point of ``pts`` ``(K, 3)`` (NaN rows ignored).

    The limits are a cube around the points; with ``floor`` (mm) the empty part of the cube
    below ``min(floor, lowest point)`` is cut off (the table scenes need nothing far below
    z = 0), never a drawn point. The box aspect follows the limits, so one millimetre has the
    same length on every axis; ``zoom`` goes to ``Axes3D.set_box_aspect``.
    """
    lo, hi = np.nanmin(pts, axis=0), np.nanmax(pts, axis=0)
    center = (lo + hi) / 2
    half = max(float((hi - lo).max()) / 2, 1.0)
    z_lo = center[2] - half
    if floor is not None:
        z_lo = max(z_lo, min(floor, float(lo[2])))
    z_hi = center[2] + half
    ax.set_xlim(center[0] - half, center[0] + half)
    ax.set_ylim(center[1] - half, center[1] + half)
    ax.set_zlim(z_lo, z_hi)
    ax.set_box_aspect((2 * half, 2 * half, z_hi - z_lo), zoom=zoom)


def label_axes_3d(ax: Axes3D, fontsize: float | None = None, labelpad: float = 4.0) -> None:
    """Label x, y, z in mm (``labelpad`` points from the tick labels); the z label is kept
    upright (read bottom to top) whatever the view, where matplotlib would turn it upside down
    for some azimuths."""
    ax.set_xlabel("x [mm]", fontsize=fontsize, labelpad=labelpad)
    ax.set_ylabel("y [mm]", fontsize=fontsize, labelpad=labelpad)
    ax.zaxis.set_rotate_label(False)
    ax.set_zlabel("z [mm]", rotation=90, fontsize=fontsize, labelpad=labelpad)


def draw_obstacles(ax: Axes3D, scene: Scene) -> list[np.ndarray]:
    """Draw every bounded obstacle (solids of revolution, spheres, boxes, capsules, meshes);
    returns their drawn points for framing the view."""
    drawn = []
    for obstacle in scene.world.obstacles:
        if isinstance(obstacle, SolidOfRevolution):
            drawn.append(_draw_solid(ax, obstacle))
        elif isinstance(obstacle, Sphere):
            drawn.append(_draw_sphere(ax, obstacle))
        elif isinstance(obstacle, Box):
            drawn.append(_draw_box(ax, obstacle))
        elif isinstance(obstacle, Capsule):
            drawn.append(_draw_capsule(ax, obstacle))
        elif is_mesh_obstacle(obstacle):
            drawn.append(_draw_mesh(ax, obstacle))
    return drawn


#: Most commands whose continuous motion a 3-D view samples (8 instants each); of a longer
#: sequence, its states only, evenly spaced to about as many points (a figure shows no more,
#: and 450,000 commands sampled whole held 1.2 GB).
_MOST_DRAWN = 16_000


def _drawn_motion(seq: CommandSequence, states: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joint values (rad) of the instants a 3-D view draws the tool path through (``states``:
    the sequence's, :meth:`CommandSequence.states_joint`)."""
    if seq.n_commands <= _MOST_DRAWN:
        return seq.sample_motion(8)
    every = np.unique(np.linspace(0, seq.n_commands, 8 * _MOST_DRAWN).astype(np.int64))
    return np.asarray(states[every], dtype=np.float64)


def plot_motion_3d(
    path: str | Path,
    arm: SerialArm,
    scene: Scene,
    seq: CommandSequence,
    target: ArrayLike | None = None,
    title: str = "",
) -> Figure:
    """3-D view: obstacles, the arm at start (grey) and end (blue), the continuous tip path;
    several targets are numbered 1, 2, ... in the order given. The end arm's joints are named
    where the names cover no other text, dot, link or target (:func:`_label_landmarks`).
    Returns the figure written."""
    fig = Figure(figsize=(8, 7))
    ax = fig.add_subplot(projection="3d")
    assert isinstance(ax, Axes3D)
    joints = seq.states_joint()
    drawn = _drawn_motion(seq, joints)
    motion = landmark_positions(arm, drawn)
    tips = tool_position(arm, drawn)
    every = np.unique(np.r_[0 : seq.n_commands + 1 : max(1, seq.n_commands // 12), seq.n_commands])
    chain = drawn_chain(arm)
    states = landmark_positions(arm, joints[every])[:, chain]  # the first and the last too
    pts = [motion.reshape(-1, 3), np.zeros((1, 3))]
    pts += draw_obstacles(ax, scene)
    for ghost in states:
        ax.plot(*ghost.T, color="0.6", alpha=0.35, linewidth=1)
    ax.plot(*states[0].T, "-o", color="0.35", linewidth=2.5, markersize=4, label="start")
    ax.plot(*states[-1].T, "-o", color="tab:blue", linewidth=2.5, markersize=4, label="end")
    ax.plot(*tips.T, color="tab:red", linewidth=1.5, label=f"{tip_label(arm)} path")
    if target is not None:
        t = np.asarray(target, dtype=float).reshape(-1, 3)
        label = "target" if len(t) == 1 else "targets (numbered)"
        ax.scatter(*t.T, color="tab:green", s=60, marker="*", label=label, depthshade=False)
        for k, p in enumerate(t if len(t) > 1 else []):
            ax.text(*p, f"{k + 1}", **POINT_LABEL, color="darkgreen")
        pts.append(t)
    set_equal_axes(ax, np.vstack(pts))
    draw_table(ax, scene)
    label_axes_3d(ax)
    ax.set_title(title or commands_text(seq.n_commands))
    ax.legend(loc="upper left", fontsize=9)
    ax.view_init(elev=22, azim=-60)
    fig.tight_layout()
    numbered = np.asarray(target, dtype=float).reshape(-1, 3) if target is not None else None
    names = [arm.landmark_names[i] for i in chain]
    _label_landmarks(ax, names, states[-1], numbered, color="tab:blue")
    fig.savefig(path, dpi=110)
    return fig


#: Where a joint's label may go, tried in order: horizontal and vertical alignment and the
#: offset (points) from the joint; above right first, then below right, above left, below left.
_LABEL_SPOTS = (
    ("left", "bottom", 4.0, 3.0),
    ("left", "top", 4.0, -3.0),
    ("right", "bottom", -4.0, 3.0),
    ("right", "top", -4.0, -3.0),
)
_LANDMARK_LABEL_PT = 9.0  # font size of the joint labels
_STAR_HALF_PT = 4.0  # half the size of a target star (scatter s=60: about 8 points across)
_DOT_HALF_PT = 2.0  # half the size of a joint's dot (markersize 4)
_LINK_HALF_PT = 1.5  # half the width of a drawn link (linewidth 2.5)
_SAME_SPOT_PX = 3.0  # joints drawn closer than this share one label ("J1/J2")


def _label_landmarks(
    ax: Axes3D,
    names: Sequence[str],
    points: np.ndarray,
    targets: np.ndarray | None,
    color: str,
) -> None:
    """Name the joints of one drawn arm (``points`` ``(L, 3)``, joined by its links) where the
    names stay clear; call after the view and the layout are final.

    Joints drawn at the same spot share one label ("J1/J2"). Each label goes to the first place
    of :data:`_LABEL_SPOTS` where it covers no label already written, none of the arm's dots
    and links, no target star and no target number (:data:`POINT_LABEL`); a label with no clear
    place is left out (a crowded wrist: a UR5's J4, J4', J5, J6 and TCP lie within a few
    pixels). The tool point is named first, then the joints from the base out.
    """
    fig = ax.get_figure()
    assert isinstance(fig, Figure)
    canvas = FigureCanvasAgg(fig)  # drawn once: the draw sets the projection (ax.M)
    canvas.draw()  # type: ignore[no-untyped-call]
    renderer = canvas.get_renderer()  # type: ignore[no-untyped-call]
    pt = fig.dpi / 72.0  # pixels a point

    def projected(xyz: np.ndarray) -> np.ndarray:
        xs, ys, _ = proj3d.proj_transform(xyz[:, 0], xyz[:, 1], xyz[:, 2], ax.M)
        return np.asarray(ax.transData.transform(np.column_stack([xs, ys])))

    def size(text: str, fontsize: float, weight: str = "normal") -> tuple[float, float]:
        prop = FontProperties(size=fontsize, weight=weight)
        w, h, _ = renderer.get_text_width_height_descent(text, prop, ismath=False)
        return float(w), float(h)

    def squares(centres: np.ndarray, half_pt: float) -> np.ndarray:
        """Boxes ``(K, 4)`` x0, y0, x1, y1 (pixels) of ``half_pt`` around ``centres``."""
        half = half_pt * pt
        return np.hstack([centres - half, centres + half])

    at = projected(points)
    taken = [squares(at, _DOT_HALF_PT)]
    for a, b in itertools.pairwise(at):
        n = max(2, int(np.ceil(np.linalg.norm(b - a) / (_LINK_HALF_PT * pt))) + 1)
        taken.append(squares(a + np.linspace(0.0, 1.0, n)[:, None] * (b - a), _LINK_HALF_PT))
    if targets is not None and len(targets):
        stars = projected(targets)
        taken.append(squares(stars, _STAR_HALF_PT))
        pad = _POINT_LABEL_PAD * POINT_LABEL["fontsize"] * pt
        for k, (x, y) in enumerate(stars if len(targets) > 1 else []):
            w, h = size(f"{k + 1}", POINT_LABEL["fontsize"], POINT_LABEL["fontweight"])
            taken.append(np.array([[x - pad, y - pad, x + w + pad, y + h + pad]]))
    blocked = np.vstack(taken)
    # one label per spot, named by every joint there, in order from the base
    groups: list[list[int]] = []
    for i in range(len(points)):
        near = [g for g in groups if np.linalg.norm(at[g[0]] - at[i]) < _SAME_SPOT_PX]
        if near:
            near[0].append(i)
        else:
            groups.append([i])
    tool = [g for g in groups if len(points) - 1 in g]
    for group in tool + [g for g in groups if g not in tool]:
        text = "/".join(names[i] for i in group)
        w, h = size(text, _LANDMARK_LABEL_PT)
        x, y = at[group[0]]
        for ha, va, dx, dy in _LABEL_SPOTS:
            x0 = x + dx * pt - (w if ha == "right" else 0.0)
            y0 = y + dy * pt - (h if va == "top" else 0.0)
            box = np.array([x0, y0, x0 + w, y0 + h])
            hit = (
                (blocked[:, 0] < box[2])
                & (box[0] < blocked[:, 2])
                & (blocked[:, 1] < box[3])
                & (box[1] < blocked[:, 3])
            )
            if hit.any():
                continue
            ax.text(
                *points[group[0]],
                text,
                ha=ha,
                va=va,
                fontsize=_LANDMARK_LABEL_PT,
                color=color,
                transform=offset_copy(ax.transData, fig=fig, x=dx, y=dy, units="points"),
            )
            blocked = np.vstack([blocked, box])
            break


_POINT_LABEL_PAD = 0.15  # room around a point's number inside its box (of the font size)
#: Style of numbers written next to points in 3-D views: above and right of the point (which
#: stays visible), bold on a light box, readable over the translucent solids and the lines.
POINT_LABEL: dict[str, Any] = {
    "horizontalalignment": "left",
    "verticalalignment": "bottom",
    "fontsize": 11,
    "fontweight": "bold",
    "zorder": 10,
    "bbox": {
        "boxstyle": f"round,pad={_POINT_LABEL_PAD}",
        "facecolor": "white",
        "alpha": 0.7,
        "linewidth": 0,
    },
}

#: One colour per joint (ten before they repeat, with another dash pattern), shared by the joint
#: figures.
JOINT_COLOURS = (
    "tab:blue",
    "tab:orange",
    "tab:green",
    "tab:red",
    "tab:purple",
    "tab:brown",
    "tab:pink",
    "tab:gray",
    "tab:olive",
    "tab:cyan",
)
#: One dash pattern per joint: where two joints' curves coincide both stay visible.
JOINT_STYLES: tuple[Any, ...] = (
    "-",
    (0, (5, 2)),
    (0, (7, 2, 1.5, 2)),
    (0, (1.5, 1.5)),
    (0, (7, 2, 1.5, 2, 1.5, 2)),
    (0, (3, 3)),
)
_MIN_SPAN_DEG = 10.0  # smallest y range of a joint panel: a constant joint shows as flat
_MOST_DOTTED_STATES = 41  # the joint figure marks each state with a dot up to 40 commands


def _check_marks(marks: Sequence[tuple[int, str]], n_commands: int) -> list[tuple[int, str]]:
    out = [(int(k), str(label)) for k, label in marks]
    for k, label in out:
        if not 0 <= k <= n_commands:
            raise InvalidInputError(
                f"mark {label!r} at command {k} is outside the sequence (0 .. {n_commands})"
            )
    return sorted(out)


def _label_marks(ax: Axes, marks: list[tuple[int, str]], x_span: float) -> None:
    """Write each mark's label just above ``ax`` at its x; labels closer than 9 % of the x
    range to the previous one go one line higher, so neighbours do not overlap."""
    last_x = -np.inf
    level = 0
    for k, label in marks:
        level = 1 - level if k - last_x < 0.09 * x_span else 0
        last_x = k
        ax.annotate(
            label,
            xy=(k, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(0, 2 + 12 * level),
            textcoords="offset points",
            ha="center",
            va="bottom",
            fontsize=9,
            color="0.2",
        )


#: The files a figure may be written as.
FIGURE_SUFFIXES = (".png", ".svg", ".pdf")


def plot_joint_angles(
    path: str | Path | None,
    seq: CommandSequence,
    title: str = "",
    marks: Sequence[tuple[int, str]] = (),
) -> Figure:
    """Joint angles (deg) after each command, one panel per joint sharing the command axis, so
    joints with equal angles never hide each other; the command axis has whole-number ticks,
    and up to 40 commands each state is a dot (a sequence of no commands is its start alone).
    Returns the figure written.

    Parameters
    ----------
    path
        PNG file to write (None: the figure is only returned).
    seq
        The command sequence; x = k is the state after command k (0: the start).
    title
        Figure title (default: "joint angles after each command").
    marks
        ``(k, label)`` pairs, e.g. the command after which each weld is reached: a dotted
        vertical line at x = k through every panel, labelled above the top panel.
    """
    degs = seq.grid.display(seq.states())
    n_joints = degs.shape[1]
    steps = np.arange(degs.shape[0])
    checked = _check_marks(marks, seq.n_commands)
    fig = Figure(figsize=(9, 1.2 + 1.2 * n_joints), layout="constrained")
    axes = fig.subplots(n_joints, 1, sharex=True, squeeze=False)[:, 0]
    x_span = max(seq.n_commands, 1)
    # each state a dot when they are few: a line of one state is not drawn at all
    marker = "o" if len(steps) <= _MOST_DOTTED_STATES else None
    for i, ax in enumerate(axes):
        ax.plot(
            steps,
            degs[:, i],
            color=JOINT_COLOURS[i % len(JOINT_COLOURS)],
            lw=1.6,
            marker=marker,
            markersize=4,
            label=f"θ{i + 1}",
        )
        lo, hi = float(degs[:, i].min()), float(degs[:, i].max())
        if hi - lo < _MIN_SPAN_DEG:
            mid = (lo + hi) / 2
            ax.set_ylim(mid - 0.5 * _MIN_SPAN_DEG, mid + 0.5 * _MIN_SPAN_DEG)
        for k, _ in checked:
            ax.axvline(k, color="0.3", linestyle=":", linewidth=1.2, gid="mark")
        ax.set_ylabel(f"θ{i + 1} [{seq.grid.units[i]}]")
        ax.yaxis.set_major_locator(MaxNLocator(4))
        ax.grid(alpha=0.3)
    _label_marks(axes[0], checked, x_span)
    # a little room on both sides: a mark (or a dot) at the first or last command is not hidden
    # by a spine; no commands: the start alone, in the middle
    room = 0.5 if seq.n_commands == 0 else (0.03 if marker else 0.015) * x_span
    axes[-1].set_xlim(-room, seq.n_commands + room)
    # whole commands only (a short sequence had ticks at 0.2, 0.4, ...)
    axes[-1].xaxis.set_major_locator(MaxNLocator(integer=True, steps=[1, 2, 5, 10], min_n_ticks=1))
    axes[-1].set_xlabel("command (0 = start; the angles after each command)")
    fig.suptitle(title or "joint angles after each command")
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


_PASS_COLOURS = ("tab:blue", "tab:green", "tab:purple", "tab:orange", "tab:cyan", "tab:olive")
_SUBSTEPS = 8  # instants sampled per command when drawing the continuous motion


_TRACE_VIEW = (24.0, -140.0)  # elevation, azimuth (deg): from the arm's side, slightly above
_HIDDEN_ALPHA = 0.3  # opacity factor of line parts seen through an obstacle


def _eye_direction(elev_deg: float, azim_deg: float) -> np.ndarray:
    """Unit vector from the scene toward the camera of ``Axes3D.view_init(elev, azim)``."""
    e, a = np.radians(elev_deg), np.radians(azim_deg)
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def _hidden(points: np.ndarray, scene: Scene, eye: np.ndarray) -> np.ndarray:
    """Which points ``(K, 3)`` are behind a bounded obstacle as seen from direction ``eye``.

    A point is hidden when the ray from 1 mm in front of it toward the camera enters an obstacle
    (exact segment distance below 0), so points on a surface facing the camera stay visible.
    """
    hidden = np.zeros(len(points), dtype=bool)
    for obstacle in scene.world.obstacles:
        ball = obstacle.enclosing_ball()
        if ball is None or not len(points):
            continue
        center, radius = ball
        reach = np.linalg.norm(points - center, axis=1) + radius + 1.0
        d = obstacle.segment_distance(points + eye, points + reach[:, None] * eye)
        hidden |= np.asarray(d) < 0.0
    return hidden


def _plot_depth_cued(
    ax: Axes3D,
    pts: np.ndarray,
    hidden: np.ndarray,
    *fmt: str,
    alpha: float = 1.0,
    label: str | None = None,
    **style: object,
) -> None:
    """Plot a 3-D polyline ``(K, 3)``, fading (``alpha`` times :data:`_HIDDEN_ALPHA`) the
    segments with a hidden end point; ``label`` goes to the visible part, ``fmt`` and ``style``
    to ``Axes3D.plot``.
    """
    seg_hidden = hidden[:-1] | hidden[1:]
    for faded in (False, True):
        seg = seg_hidden if faded else ~seg_hidden
        keep = np.zeros(len(pts), dtype=bool)
        keep[:-1] |= seg
        keep[1:] |= seg
        if faded and not keep.any():
            continue
        xyz = np.where(keep[:, None], pts, np.nan)
        ax.plot(
            *xyz.T,
            *fmt,
            alpha=alpha * _HIDDEN_ALPHA if faded else alpha,
            label=None if faded else label,
            **style,
        )


def _plot_arm_depth_cued(
    ax: Axes3D,
    landmarks: np.ndarray,
    scene: Scene,
    eye: np.ndarray,
    *,
    color: str,
    linewidth: float,
    markersize: float,
    label: str,
) -> None:
    """Draw an arm (its landmarks ``(L, 3)`` joined by straight links, a dot at each) solid,
    fading the parts behind an obstacle seen from ``eye`` (as :func:`_plot_depth_cued`; each
    link is tested at 24 points, so a link partly behind a solid fades only there)."""
    s = np.linspace(0.0, 1.0, 24, endpoint=False)[:, None, None]
    dense = (landmarks[:-1] + s * (landmarks[1:] - landmarks[:-1])).transpose(1, 0, 2)
    dense = np.vstack([dense.reshape(-1, 3), landmarks[-1:]])
    _plot_depth_cued(ax, dense, _hidden(dense, scene, eye), color=color, linewidth=linewidth)
    hidden = _hidden(landmarks, scene, eye)
    for faded in (False, True):
        dots = landmarks[hidden == faded]
        if len(dots):
            alpha = _HIDDEN_ALPHA if faded else 1.0
            ax.plot(*dots.T, "o", color=color, markersize=markersize, alpha=alpha)
    # the legend's entry: a line with a dot
    style = {"color": color, "linewidth": linewidth, "markersize": markersize}
    ax.plot([], [], [], "-o", label=label, **style)


def _check_passes(passes: Sequence[tuple[int, int]], n_commands: int) -> list[tuple[int, int]]:
    """The passes as state-index pairs ``(i, j)``, checked: ``0 <= i < j <= n_commands`` and in
    order without overlap."""
    out = [(int(i), int(j)) for i, j in passes]
    last = 0
    for i, j in out:
        if not 0 <= i < j <= n_commands or i < last:
            raise InvalidInputError(
                f"pass ({i}, {j}) is not a state range 0 <= i < j <= {n_commands} after the "
                "previous pass; passes must be ordered and must not overlap"
            )
        last = j
    return out


def plot_trace_3d(
    path: str | Path,
    arm: SerialArm,
    scene: Scene,
    sequence: CommandSequence,
    curve_points: ArrayLike,
    passes: Sequence[tuple[int, int]],
    unreachable_points: Sequence[ArrayLike] = (),
    title: str = "",
    curve_name: str = "",
) -> Figure:
    """3-D view of a curve trace (all lengths in mm, the seed arm's unit); returns the figure
    written.

    Seen from the arm's side (elevation 24°, azimuth -140°) with equal axes; lines are drawn
    over the translucent obstacles, and the parts of them behind an obstacle are faded.

    Parameters
    ----------
    path
        PNG file to write.
    arm, scene
        The arm and the scene whose obstacles are drawn (semi-transparent).
    sequence
        The whole command sequence; state 0 is its start, state ``k`` the state after command
        ``k``.
    curve_points
        ``(M, 3)`` points along the curve, drawn as a thin dark line.
    passes
        ``(i, j)`` state-index ranges during which the fingertip traces the curve; the continuous
        tip path over commands ``i+1 .. j`` is drawn thick, one colour per pass. Every other
        command (approach, lift-off, transit) is drawn thin, dashed and grey.
    unreachable_points
        One ``(K, 3)`` array of curve points per arc that cannot be traced, drawn in red.
    title
        Figure title (default: command and pass counts).
    curve_name
        The curve's name (``Curve.name``, e.g. "crack") for the legend: "curve (name)"; empty:
        "curve".
    """
    spans = _check_passes(passes, sequence.n_commands)
    curve = np.asarray(curve_points, dtype=np.float64).reshape(-1, 3)
    arcs = [np.asarray(a, dtype=np.float64).reshape(-1, 3) for a in unreachable_points]
    fig = Figure(figsize=(9, 7.5))
    # draw order is the call order (lines over the translucent solids); matplotlib's depth sort
    # would hide lines behind the surfaces unpredictably. Depth is shown by fading instead.
    ax = fig.add_subplot(projection="3d", computed_zorder=False)
    assert isinstance(ax, Axes3D)
    eye = _eye_direction(*_TRACE_VIEW)
    tip = tool_position(arm, sequence.sample_motion(_SUBSTEPS))  # state k is row k * _SUBSTEPS
    states = landmark_positions(arm, sequence.states_joint())[:, drawn_chain(arm)]
    first = spans[0][0] if spans else 0
    pts = [tip, curve, states[[first, -1]].reshape(-1, 3)]
    pts += draw_obstacles(ax, scene)
    # both arms solid where seen, faded only where an obstacle is in front of them (the note
    # under the figure says so); the final state lighter and thinner than the pass's start
    _plot_arm_depth_cued(
        ax,
        states[-1],
        scene,
        eye,
        color="0.6",
        linewidth=1.5,
        markersize=3,
        label=f"arm at the final state ({sequence.n_commands})",
    )
    _plot_arm_depth_cued(
        ax,
        states[first],
        scene,
        eye,
        color="0.3",
        linewidth=2.0,
        markersize=4,
        label=f"arm at the start of pass 1 (state {first})",
    )
    for k, arc in enumerate(arcs):
        _plot_depth_cued(
            ax,
            arc,
            _hidden(arc, scene, eye),
            color="tab:red",
            linewidth=3.5,
            solid_capstyle="butt",
            label="unreachable" if k == 0 else None,
        )
    tip_hidden = _hidden(tip, scene, eye)
    # transit: every command outside the passes
    bounds = [0, *[b for ij in spans for b in ij], sequence.n_commands]
    labelled = False
    for a, b in zip(bounds[::2], bounds[1::2], strict=True):
        if b > a:
            rows = slice(a * _SUBSTEPS, b * _SUBSTEPS + 1)
            _plot_depth_cued(
                ax,
                tip[rows],
                tip_hidden[rows],
                "--",
                color="0.35",
                linewidth=1.0,
                label=None if labelled else "transit (approach / lift-off)",
            )
            labelled = True
    for k, (i, j) in enumerate(spans):
        rows = slice(i * _SUBSTEPS, j * _SUBSTEPS + 1)
        _plot_depth_cued(
            ax,
            tip[rows],
            tip_hidden[rows],
            color=_PASS_COLOURS[k % len(_PASS_COLOURS)],
            linewidth=3.0,
            alpha=0.9,
            label=f"{tip_label(arm)}, pass {k + 1}: states {i}–{j}",
        )
    # the curve over the passes: a thin dark centre line in each coloured band
    _plot_depth_cued(
        ax,
        curve,
        _hidden(curve, scene, eye),
        color="0.1",
        linewidth=0.8,
        label=f"curve ({curve_name})" if curve_name else "curve",
    )
    for k, (i, j) in enumerate(spans):
        p, q = tip[i * _SUBSTEPS], tip[j * _SUBSTEPS]
        ax.scatter(
            *p,
            color="k",
            marker="o",
            s=40,
            depthshade=False,
            label="pass start (number)" if k == 0 else None,
        )
        ax.scatter(
            *q, color="k", marker="s", s=28, depthshade=False, label="pass end" if k == 0 else None
        )
        ax.text(*p, f"{k + 1}", **POINT_LABEL)
    set_equal_axes(ax, np.vstack(pts), zoom=1.15)
    draw_table(ax, scene)
    label_axes_3d(ax)
    counts = f"{commands_text(sequence.n_commands)}, {passes_text(len(spans))}"
    ax.set_title(title or f"curve trace: {counts}")
    ax.view_init(elev=_TRACE_VIEW[0], azim=_TRACE_VIEW[1])
    fig.legend(loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.text(
        0.99, 0.01, "faded: behind an obstacle", ha="right", va="bottom", fontsize=7, color="0.4"
    )
    fig.tight_layout(rect=(0.0, 0.08, 1.0, 1.0))
    fig.savefig(path, dpi=110)
    return fig


def plot_trace_deviation(
    path: str | Path,
    s_mm: ArrayLike,
    deviation_mm: ArrayLike,
    tolerance_mm: float,
    unreachable: Sequence[tuple[float, float]] = (),
    curve_length_mm: float | None = None,
    title: str = "",
) -> Figure:
    """Deviation of the continuous tip path from the curve along the curve's arc length;
    returns the figure written.

    Parameters
    ----------
    path
        PNG file to write.
    s_mm, deviation_mm
        Arc length along the curve (mm) and the tip's distance from the curve there (mm), same
        length, in any order (they are sorted by ``s``); NaN deviations (not traced) are left
        as gaps, and the line is never drawn across an unreachable arc.
    tolerance_mm
        Allowed deviation (mm), drawn as a dashed horizontal line.
    unreachable
        Arcs ``(start, end)`` in mm of arc length that cannot be traced, shaded. On a closed
        curve of length ``curve_length_mm`` an arc with ``end > curve_length_mm`` wraps past 0:
        both pieces are shaded.
    curve_length_mm
        Length of the curve (mm); sets the x range (default: the data range).
    title
        Figure title.
    """
    s = np.asarray(s_mm, dtype=np.float64).ravel()
    dev = np.asarray(deviation_mm, dtype=np.float64).ravel()
    if s.shape != dev.shape:
        raise InvalidInputError(
            f"s_mm and deviation_mm must have the same length, got {s.size} and {dev.size}"
        )
    order = np.argsort(s, kind="stable")
    s, dev = s[order], dev[order]
    length = curve_length_mm
    pieces: list[tuple[float, float]] = []
    for a, b in unreachable:
        if length is not None and b > length:
            pieces += [(float(a), length), (0.0, float(b) - length)]
        else:
            pieces.append((float(a), float(b)))
    # never draw the deviation line across an unreachable arc, even without a NaN there
    mid = (s[:-1] + s[1:]) / 2
    cut = np.flatnonzero(np.any([(lo < mid) & (mid < hi) for lo, hi in pieces], axis=0))
    if pieces and cut.size:
        s = np.insert(s, cut + 1, mid[cut])
        dev = np.insert(dev, cut + 1, np.nan)
    fig = Figure(figsize=(9, 4.2))
    ax = fig.add_subplot()
    for m, (lo, hi) in enumerate(pieces):
        ax.axvspan(
            lo,
            hi,
            color="tab:red",
            alpha=0.15,
            linewidth=0,
            label="unreachable" if m == 0 else None,
        )
    ax.plot(s, dev, color="tab:blue", linewidth=1.4, label="tip deviation")
    ax.axhline(
        tolerance_mm,
        color="k",
        linestyle="--",
        linewidth=1.0,
        label=f"tolerance {tolerance_mm:g} mm",
    )
    finite = np.isfinite(dev)
    if finite.any():
        k = int(np.nanargmax(dev))
        ax.plot(
            s[k],
            dev[k],
            "v",
            color="tab:blue",
            markersize=7,
            label=f"max {dev[k]:.3f} mm at s = {s[k]:.1f} mm",
        )
    top = max(float(np.nanmax(dev)) if finite.any() else 0.0, tolerance_mm)
    ax.set_ylim(0.0, 1.1 * top if top > 0 else 1.0)
    if length is not None:
        ax.set_xlim(0.0, length)
    elif s.size:
        ax.set_xlim(float(s[0]), float(s[-1]))
    ax.set_xlabel("arc length along the curve s [mm]")
    ax.set_ylabel("deviation from the curve [mm]")
    ax.set_title(title or "deviation of the continuous tip path from the curve", pad=24)
    ax.grid(alpha=0.3)
    # above the axes, under the title: never over the data
    ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=4, fontsize=8, frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return fig


def plot_trajectory(
    path: str | Path, traj: PiecewisePolynomial, title: str = "", lattice: Lattice | None = None
) -> Figure:
    """Position, velocity, acceleration, jerk and snap of every joint (deg, deg/s, ...; a
    prismatic joint of ``lattice`` in mm, mm/s, ...), one colour and dash pattern per joint
    (coinciding joints stay visible), the waypoint times as grey vertical lines; returns the
    figure written."""
    t = np.linspace(traj.times[0], traj.times[-1], 1500)
    grid = Lattice.uniform(traj.coefficients.shape[2]) if lattice is None else lattice
    units = grid.unit_kinds

    def per_time(power: str) -> str:
        return ", ".join(f"{u}{power}" for u in units)

    names = (
        f"position [{per_time('')}]",
        f"velocity [{per_time('/s')}]",
        f"acceleration [{per_time('/s²')}]",
        f"jerk [{per_time('/s³')}]",
        f"snap [{per_time('/s⁴')}]",
    )
    mixed = len(units) > 1
    fig = Figure(figsize=(9, 11.5), dpi=100, layout="constrained")
    axes = fig.subplots(len(names), 1, sharex=True)
    for d, (ax, name) in enumerate(zip(axes, names, strict=True)):
        values = grid.joint_display(traj.evaluate(t, d))
        # one collection of vertical lines (thousands of waypoints stay one artist)
        ax.vlines(traj.times, 0, 1, transform=ax.get_xaxis_transform(), color="0.75", lw=0.8,
                  zorder=0)  # fmt: skip
        for j in range(values.shape[1]):
            ax.plot(
                t,
                values[:, j],
                lw=1.5,
                color=JOINT_COLOURS[j % len(JOINT_COLOURS)],
                linestyle=JOINT_STYLES[j % len(JOINT_STYLES)],
                label=f"joint {j + 1}" + (f" [{grid.units[j]}]" if mixed else ""),
            )
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    handles, labels = axes[0].get_legend_handles_labels()
    handles.append(Line2D([], [], color="0.75", lw=0.8))
    labels.append("waypoint time")
    # above the top panel, under the title: never over the curves
    axes[0].legend(
        handles,
        labels,
        loc="lower center",
        bbox_to_anchor=(0.5, 1.0),
        ncol=4,
        fontsize=9,
        frameon=False,
    )
    fig.suptitle(title)
    fig.savefig(path)
    return fig


def plot_tip_deviation(
    path: str | Path,
    series: Sequence[tuple[np.ndarray, np.ndarray, str]],
    title: str = "",
) -> Figure:
    """Distance of the tool tip from where it should be (mm) against time (s), one line per
    ``(times_s, distance_mm, label)``; earlier series are drawn over later ones (a smooth
    reference stays visible over the jagged quantized motion). Returns the figure written."""
    fig = Figure(figsize=(8, 4.4), layout="constrained")
    ax = fig.add_subplot()
    colours = ("tab:blue", "tab:orange", "tab:green", "tab:red")
    for k, (times, dist, label) in enumerate(series):
        ax.plot(
            times,
            dist,
            lw=1.6 if k == 0 else 1.0,
            color=colours[k % len(colours)],
            zorder=2 + len(series) - k,
            label=f"{label} (max {np.max(dist):.2f} mm)",
        )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("tip distance from the point [mm]")
    ax.grid(alpha=0.3)
    # above the axes, under the title: never over the data
    ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=2, fontsize=9, frameon=False)
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    return fig
