"""The interactive viewer: a viser server showing the arm in its scene.

The page has one slider per joint (steps of one tick of the arm's lattice, 0.1 deg for the
seed arm, within the joint's limits), a live readout of the fingertip position and the clearance
(the violating parts turn red), a target-point input that runs the reach planner from the
current pose (starting at the target of a loaded reach result), and a replay of any result
(play, pause, step, timeline) with the fingertip's path and the result's curve and targets
drawn. Each link is drawn at its own capsule radius (at least a small share of the arm's
length, so thin ones stay visible), each joint as a sphere a little larger than the links
meeting there, and the base's axes at the arm's base; the page's title names the replay shown.

The scene is shown in metres (viser's unit); every number on the page is in mm and deg.
"""

from __future__ import annotations

import contextlib
import errno
import html
import io
import ipaddress
import json
import logging
import re
import socket
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from armpath.commands import CommandSequence
from armpath.errors import ArmpathError, InvalidInputError
from armpath.geometry.primitives import HalfSpace
from armpath.geometry.world import CollisionWorld, link_analysis
from armpath.kinematics import landmark_positions, tool_position
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.report import commands_text
from armpath.results import Result
from armpath.scenes import Scene
from armpath.trajectory.quantize import joint_ticks
from armpath.viewer.meshes import TriangleMesh, obstacle_mesh, sphere_mesh

if TYPE_CHECKING:
    from viser import LineSegmentsHandle

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)
MM = 1e-3  # display scale: mm -> m
#: Obstacles are drawn within a cube about the base of this many times the arm's length (at
#: least VIEW_BOX_MIN_MM): farther ones are skipped, larger ones cut to the cube.
VIEW_BOX_REACHES = 10.0
VIEW_BOX_MIN_MM = 2000.0
#: Seconds to wait for a host name to resolve.
RESOLVE_TIMEOUT_S = 5.0
LINK_COLOR = (25, 80, 170)
COLLISION_COLOR = (220, 30, 30)
OBSTACLE_COLOR = (210, 180, 140)
PATH_COLOR = (220, 60, 60)
CURVE_COLOR = (255, 140, 0)
TARGET_COLOR = (30, 160, 60)
JOINT_COLOR = (30, 30, 30)
#: Least radius a link is drawn with, as a fraction of the arm's length along its links at home,
#: so thin links stay visible (a 3 mm tool, the seed arm's links of radius 0): 1.25 % draws the
#: seed arm's 715 mm of links 18 mm thick.
MIN_DRAWN_RADIUS_OF_LENGTH = 0.0125
#: A joint marker's radius over the largest drawn radius of the links meeting at it.
JOINT_MARKER_SCALE = 1.15
#: Length and radius of the "/base" axes, as fractions of the arm's length along its links at
#: home (the seed arm's: 107 mm and 2.9 mm), so they reach out of the base's joint marker.
BASE_AXES_OF_LENGTH = 0.15
BASE_AXES_RADIUS_OF_LENGTH = 0.004
#: Where the "Reach a point" panel starts when neither a reach result nor the scene names a
#: target (mm): a point the seed arm reaches from its home (55 commands).
DEFAULT_REACH_TARGET_MM = (300.0, -170.0, 15.0)
#: Flags for Debian's Chromium run headless on a machine without outside network (the browser
#: test and docs/make_screenshots.py): no sandbox as root, no GPU, no background connections.
HEADLESS_CHROMIUM_ARGS = (
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
)


@dataclass
class ViewerState:
    """What the page shows: the joint state (ticks of the arm's lattice)
    and its readouts (fingertip mm, smallest clearance mm and its pair, colliding parts)."""

    ticks: NDArray[np.int64]
    tip_mm: FloatArray = field(default_factory=lambda: np.zeros(3))
    clearance_mm: float = float("inf")
    closest: str = ""
    colliding_parts: tuple[str, ...] = ()


def drawn_link_radii(arm: SerialArm, links: Sequence[str], length: float) -> FloatArray:
    """The radius (model's length unit) each of ``links`` (names of ``arm``'s links, one per
    drawn segment) is drawn with: the link's own capsule radius, at least
    :data:`MIN_DRAWN_RADIUS_OF_LENGTH` times ``length`` (the arm's length along its links)."""
    radius_of = {lk.name: lk.radius for lk in arm.links}
    least = MIN_DRAWN_RADIUS_OF_LENGTH * length
    return np.array([max(radius_of[name], least) for name in links], dtype=np.float64)


def joint_marker_radii(arm: SerialArm, length: float) -> FloatArray:
    """The radius (model's length unit) of the marker drawn at each of ``arm``'s landmarks:
    :data:`JOINT_MARKER_SCALE` times the largest drawn radius (:func:`drawn_link_radii`) of
    the links of non-zero length meeting at its point, or times the least drawn radius where
    none does."""
    analysis = link_analysis(arm)
    point_of = analysis.point_of
    least = MIN_DRAWN_RADIUS_OF_LENGTH * length
    radii = np.full(len(arm.landmarks), least)
    for lk, zero in zip(arm.links, analysis.degenerate, strict=True):
        if zero:
            continue
        drawn = max(lk.radius, least)
        at = (point_of == point_of[lk.start]) | (point_of == point_of[lk.end])
        radii[at] = np.maximum(radii[at], drawn)
    return JOINT_MARKER_SCALE * radii


def base_frame_pose(arm: SerialArm) -> tuple[FloatArray, FloatArray]:
    """Where the "/base" axes are drawn: the rotation (quaternion ``wxyz``) and the position
    (viser's metres, from the model's unit as the rest of the page) of ``arm.T_world_base``."""
    import viser.transforms as vtf

    T_world_base = np.asarray(arm.T_world_base, dtype=np.float64)
    wxyz = np.asarray(vtf.SO3.from_matrix(T_world_base[:3, :3]).wxyz, dtype=np.float64)
    return wxyz, T_world_base[:3, 3] * MM


def tab_title(shown: str) -> str:
    """The title of the page (its browser tab) while ``shown`` is on it."""
    return f"armpath - {shown}"


def with_title(page_html: str, title: str) -> str:
    """``page_html`` with the text of its (first) ``<title>`` element replaced by ``title``."""
    element = f"<title>{html.escape(title, quote=False)}</title>"
    return re.sub(r"<title>[^<]*</title>", lambda _m: element, page_html, count=1)


def reach_target_start_mm(
    result: Result | None, scene: Scene | None = None
) -> tuple[float, float, float]:
    """Where the "Reach a point" panel starts (mm): the target of ``result`` when it is a
    reach, else the scene's reach task's target, else :data:`DEFAULT_REACH_TARGET_MM`."""
    if result is not None and result.task == "reach" and len(result.targets_mm):
        x, y, z = (float(v) for v in result.targets_mm[0])
        return x, y, z
    if scene is not None and scene.reach_target_mm is not None:
        x, y, z = (float(v) for v in scene.reach_target_mm)
        return x, y, z
    return DEFAULT_REACH_TARGET_MM


class ArmViewer:
    """Serve the arm and scene on ``http://host:port``; see the module docstring."""

    def __init__(
        self,
        arm: SerialArm,
        scene: Scene,
        *,
        host: str = "127.0.0.1",
        port: int = 8080,
        result: Result | None = None,
        start_ticks: NDArray[np.int64] | None = None,
    ) -> None:
        import viser

        check_address(host, port)
        self.arm = arm
        self.scene = scene
        self.world: CollisionWorld = scene.world
        self._lock = threading.RLock()
        self._updating = False
        #: What the page leaves out or simplifies (obstacles outside the view box); also logged
        #: (logger ``armpath.viewer.app``, level INFO); ``armpath view`` prints them.
        self.notes: list[str] = []
        # viser prints a banner of its own; the CLI prints the address instead.
        with contextlib.redirect_stdout(io.StringIO()):
            self.server = viser.ViserServer(host=host, port=port, verbose=False)
        if port != 0 and self.server.get_port() != port:  # viser moved on: taken meanwhile
            taken = self.server.get_port()
            self.stop()
            raise InvalidInputError(
                f"port {port} on {host} is in use (viser would have taken {taken}); "
                "choose another --port"
            )
        self.server.scene.set_up_direction("+z")
        home_pts = landmark_positions(arm, arm.home)
        # the arm's length along its links at home (mm): frames the camera and the table patch
        self._reach_mm = float(
            sum(np.linalg.norm(home_pts[lk.end] - home_pts[lk.start]) for lk in arm.links)
        )
        self._base_mm = np.asarray(arm.T_world_base[:3, 3], dtype=np.float64)
        self._view_half_mm = max(VIEW_BOX_REACHES * self._reach_mm, VIEW_BOX_MIN_MM)
        size = max(self._reach_mm * MM, 0.2)
        self.server.initial_camera.look_at = (0.0, 0.0, 0.3 * size)
        self.server.initial_camera.position = (1.1 * size, -1.3 * size, 0.9 * size)
        self._tick = joint_ticks(arm)  # rad per tick (revolute) or mm per tick (prismatic)
        # one tick of each joint on the sliders, deg or mm (0.1 exactly, not 0.09999999999999999)
        self._steps = np.array([float(f"{t:.10g}") for t in arm.lattice.tick_display])
        home = np.rint(arm.home / self._tick).astype(np.int64)
        ticks = home if start_ticks is None else np.asarray(start_ticks, dtype=np.int64)
        self.state = ViewerState(ticks=ticks)
        self._parts = self.world.parts(arm)
        self._pairs = self.world.pairs(arm)
        self._required = self.world.required(arm)
        # drawn: the parts (checked links, the last split at the tool tip), then the fixed base's
        # links (checked against the moving links only) of non-zero length
        degenerate = link_analysis(arm).degenerate
        self._base_links = [
            lk for lk, zero in zip(arm.links, degenerate, strict=True) if not (lk.checked or zero)
        ]
        names = [p.name for p in self._parts] + [lk.name for lk in self._base_links]
        links = [p.link for p in self._parts] + [lk.name for lk in self._base_links]
        #: radius each drawn segment is drawn with, and each landmark's marker (model's unit)
        self._drawn_radii = drawn_link_radii(arm, links, self._reach_mm)
        self._marker_radii = joint_marker_radii(arm, self._reach_mm)
        # per pair, the drawn segments it turns red when broken: the part against an obstacle,
        # every segment of both links of a self pair
        self._pair_drawn = [
            [k for k, link in enumerate(links) if link in (pair.part, pair.other)]
            if pair.is_self
            else [names.index(pair.part)]
            for pair in self._pairs
        ]
        self._draw_scene()
        self._build_gui(reach_target_start_mm(result, scene))
        self.page_title = tab_title(f"{arm.name} in {scene.name}")
        self._replay: CommandSequence | None = None
        self._playing = False
        self._player: threading.Thread | None = None
        if result is not None:
            self.load_replay(result)
        self.set_ticks(ticks)

    # --- scene -----------------------------------------------------------------------------

    def _note(self, message: str) -> None:
        self.notes.append(message)
        logger.info(message)

    def _view_mesh(self, name: str, mesh: TriangleMesh) -> TriangleMesh | None:
        """The part of an obstacle's display mesh the page can show: ``None`` (and a note) when
        it lies wholly outside the view box or is not finite, its vertices cut to the box (and
        a note) when it reaches beyond it."""
        vertices, faces = mesh
        lo, hi = self._base_mm - self._view_half_mm, self._base_mm + self._view_half_mm
        box = f"the view box (±{self._view_half_mm:.0f} mm about the base)"
        with np.errstate(all="ignore"):
            finite = bool(np.all(np.isfinite(vertices)))
            outside = finite and bool(
                np.any(vertices.min(axis=0) > hi) or np.any(vertices.max(axis=0) < lo)
            )
        if not finite or outside:
            self._note(f"obstacle {name!r} is not drawn: it lies outside {box}")
            return None
        clipped = np.clip(vertices, lo, hi)
        if not np.array_equal(clipped, vertices):
            self._note(f"obstacle {name!r} is drawn cut to {box}")
        return clipped, faces

    def _draw_scene(self) -> None:
        scene = self.server.scene
        for k, obstacle in enumerate(self.world.obstacles):
            with np.errstate(all="ignore"):
                mesh = obstacle_mesh(obstacle, self._base_mm, 1.3 * self._reach_mm)
            shown = self._view_mesh(obstacle.name, mesh)
            if shown is None:
                continue
            vertices, faces = shown
            is_plane = isinstance(obstacle, HalfSpace)
            scene.add_mesh_simple(
                f"/obstacles/{k}_{obstacle.name}",
                vertices * MM,
                faces,
                color=(200, 200, 200) if is_plane else OBSTACLE_COLOR,
                opacity=0.35 if is_plane else 0.6,
                side="double",
            )
        wxyz, position_m = base_frame_pose(self.arm)
        self._base_frame = scene.add_frame(
            "/base",
            axes_length=BASE_AXES_OF_LENGTH * self._reach_mm * MM,
            axes_radius=BASE_AXES_RADIUS_OF_LENGTH * self._reach_mm * MM,
            wxyz=wxyz,
            position=position_m,
        )
        # one node of line segments per drawn radius (viser draws a node at one thickness)
        self._link_groups: list[tuple[LineSegmentsHandle, NDArray[np.intp]]] = []
        for k, radius in enumerate(np.unique(self._drawn_radii)):
            members = np.flatnonzero(self._drawn_radii == radius)
            handle = scene.add_line_segments(
                f"/arm/links/{k}",
                np.zeros((members.size, 2, 3)),
                np.tile(np.array(LINK_COLOR, dtype=np.uint8), (members.size, 2, 1)),
                thickness=2.0 * float(radius) * MM,
            )
            self._link_groups.append((handle, members))
        n_landmarks = len(self.arm.landmarks)
        unit_sphere = sphere_mesh(np.zeros(3), 1.0)
        self._joints = scene.add_batched_meshes_simple(
            "/arm/joints",
            unit_sphere[0],
            unit_sphere[1],
            batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (n_landmarks, 1)),
            batched_positions=np.zeros((n_landmarks, 3)),
            batched_scales=self._marker_radii * MM,
            batched_colors=JOINT_COLOR,
            side="double",
        )
        self._tip = scene.add_icosphere("/arm/tip", radius=6 * MM, color=(0, 0, 0))
        self._path = scene.add_line_segments(
            "/replay/path", np.zeros((1, 2, 3)), PATH_COLOR, thickness=3 * MM, visible=False
        )
        self._target_marker = scene.add_icosphere(
            "/target", radius=8 * MM, color=TARGET_COLOR, visible=False
        )

    # --- gui -------------------------------------------------------------------------------

    def _build_gui(self, target_mm: tuple[float, float, float]) -> None:
        gui = self.server.gui
        gui.configure_theme(control_width="large")
        grid = self.arm.lattice
        units = list(grid.units)
        steps = self._steps
        limits = self.arm.limits_in_ticks()
        shown = ", ".join(sorted({f"{t:.10g} {u}" for t, u in zip(steps, units, strict=True)}))
        with gui.add_folder(f"Joints (steps of one tick: {shown})"):
            self.sliders = []
            for i, joint in enumerate(self.arm.joints):
                prismatic = joint.kind is JointKind.PRISMATIC
                if joint.is_limited:
                    lo_t, hi_t = limits[0][i], limits[1][i]
                else:
                    span = 1000.0 if prismatic else 180.0
                    lo_t, hi_t = np.ceil(-span / steps[i]), np.floor(span / steps[i])
                lo, hi = round(float(lo_t * steps[i]), 10), round(float(hi_t * steps[i]), 10)
                slider = gui.add_slider(
                    f"{'d' if prismatic else 'θ'}{i + 1} [{units[i]}]",
                    min=lo,
                    max=hi,
                    step=float(steps[i]),
                    initial_value=round(float(np.clip(self.state.ticks[i] * steps[i], lo, hi)), 10),
                )
                slider.on_update(lambda _event: self._on_slider())
                self.sliders.append(slider)
        self.readout = gui.add_markdown("")
        with gui.add_folder("Reach a point (mm)"):
            self.target_input = gui.add_vector3("target", target_mm, step=1.0)
            self.reach_button = gui.add_button("Plan reach from here")
            self.reach_status = gui.add_markdown("")
            self.reach_button.on_click(lambda _event: self._on_reach())
        with gui.add_folder("Replay"):
            self.replay_info = gui.add_markdown("no result loaded")
            self.timeline = gui.add_slider("command", min=0, max=1, step=1, initial_value=0)
            self.timeline.on_update(lambda _event: self._on_timeline())
            self.play_buttons = gui.add_button_group("", ("◀ step", "play", "pause", "step ▶"))
            self.play_buttons.on_click(lambda event: self._on_play_button(event.target.value))
            self.speed = gui.add_slider("commands / s", min=1, max=60, step=1, initial_value=15)
        # viser (1.1) has no setting for the page's title and serves a page titled "Viser"; its
        # HTML element inserts markup as given, so an image that fails to load sets the title.
        self._title_setter = gui.add_html("")

    # --- state -----------------------------------------------------------------------------

    def set_ticks(self, ticks: NDArray[np.int64]) -> ViewerState:
        """Show the arm at ``ticks`` (of the arm's lattice); updates the sliders and
        readouts."""
        with self._lock:
            ticks = np.asarray(ticks, dtype=np.int64)
            q = ticks * self._tick
            pts = landmark_positions(self.arm, q)
            p0, p1 = self.world.part_segments(self.arm, q)
            values, _ = self.world.pair_clearances(self.arm, q)
            slack = values - self._required
            broken = {k for b in np.flatnonzero(slack < 0) for k in self._pair_drawn[b]}
            colliding = tuple(part.name for k, part in enumerate(self._parts) if k in broken)
            k = int(np.argmin(slack)) if slack.size else -1
            tip = tool_position(self.arm, q)
            self.state = ViewerState(
                ticks=ticks,
                tip_mm=tip,
                clearance_mm=float(values[k]) if k >= 0 else float("inf"),
                closest=self._pairs[k].label if k >= 0 else "",
                colliding_parts=colliding,
            )
            n_drawn = len(self._parts) + len(self._base_links)
            colors = np.array(
                [COLLISION_COLOR if k in broken else LINK_COLOR for k in range(n_drawn)],
                dtype=np.uint8,
            ).reshape(-1, 3)
            base = [(pts[lk.start], pts[lk.end]) for lk in self._base_links]
            segments = np.concatenate(
                [np.stack([p0, p1], axis=1), np.array(base, dtype=np.float64).reshape(-1, 2, 3)]
            )
            with self.server.atomic():
                for handle, members in self._link_groups:
                    handle.points = (segments[members] * MM).astype(np.float32)
                    handle.colors = np.repeat(colors[members, None, :], 2, axis=1)
                self._joints.batched_positions = (pts * MM).astype(np.float32)
                self._tip.position = tuple(tip * MM)
                self._updating = True
                try:
                    for slider, t, step in zip(self.sliders, ticks, self._steps, strict=True):
                        value = round(float(t) * float(step), 10)
                        if slider.value != value:
                            slider.value = value  # type: ignore[misc]
                finally:
                    self._updating = False
                self.readout.content = self._readout_text()
            return self.state

    def _readout_text(self) -> str:
        s = self.state
        x, y, z = s.tip_mm
        status = (
            f"**collision**: {', '.join(s.colliding_parts)}"
            if s.colliding_parts
            else "no collision"
        )
        clearance = (
            f"**Clearance** {s.clearance_mm:.2f} mm ({s.closest})"
            if s.closest
            else "**Clearance** nothing to keep clear of"
        )
        return f"**Fingertip** x = {x:.2f}, y = {y:.2f}, z = {z:.2f} mm  \n{clearance}  \n{status}"

    def _on_slider(self) -> None:
        if self._updating:
            return
        steps = self._steps
        ticks = np.array(
            [round(s.value / step) for s, step in zip(self.sliders, steps, strict=True)],
            dtype=np.int64,
        )
        self.set_ticks(ticks)

    # --- reach -----------------------------------------------------------------------------

    def _on_reach(self) -> None:
        from armpath.planning.reach import ReachOptions, plan_reach

        target = np.array(self.target_input.value, dtype=float)
        self._target_marker.position = tuple(target * MM)
        self._target_marker.visible = True
        self.reach_status.content = f"planning to {np.round(target, 1).tolist()} mm ..."
        self.reach_button.disabled = True
        try:
            options = ReachOptions(tolerance_mm=self.scene.tolerance_mm("reach"))
            result = plan_reach(self.arm, self.world, self.state.ticks, target, options)
        except ArmpathError as exc:
            self.reach_status.content = f"**not reached**: {exc}"
            return
        finally:
            self.reach_button.disabled = False
        self.reach_status.content = (
            f"{commands_text(result.n_commands)}, error {result.error_mm:.4f} mm, "
            f"min clearance {result.clearance.min_clearance:.2f} mm"
        )
        self._start_replay(
            result.sequence,
            f"reach {np.round(target, 1).tolist()} mm: {commands_text(result.n_commands)}",
        )

    # --- replay ----------------------------------------------------------------------------

    def load_replay(self, result: Result) -> None:
        """Replay a result document: its commands, fingertip path, curve and targets."""
        if result.curve_mm is not None and len(result.curve_mm) > 1:
            c = result.curve_mm * MM
            self.server.scene.add_line_segments(
                "/replay/curve", np.stack([c[:-1], c[1:]], axis=1), CURVE_COLOR, thickness=2 * MM
            )
        for k, p in enumerate(result.targets_mm):
            self.server.scene.add_icosphere(
                f"/replay/targets/{k}", radius=6 * MM, color=TARGET_COLOR, position=tuple(p * MM)
            )
        self._start_replay(result.sequence, result.title())

    def _start_replay(self, seq: CommandSequence, title: str) -> None:
        self._playing = False
        self._replay = seq
        tip = tool_position(self.arm, seq.sample_motion(4)) * MM
        segments = np.stack([tip[:-1], tip[1:]], axis=1) if len(tip) > 1 else np.zeros((1, 2, 3))
        self._path.points = segments.astype(np.float32)
        self._path.visible = True
        self.timeline.max = max(seq.n_commands, 1)
        self.timeline.value = 0  # type: ignore[misc]
        self.replay_info.content = f"**{title}**"
        self.page_title = tab_title(title)
        self.show_command(0)

    def show_command(self, k: int) -> None:
        """Show the state after command ``k`` of the replayed sequence (0: the start)."""
        if self._replay is None:
            raise InvalidInputError("no replay loaded")
        states = self._replay.states()
        k = int(np.clip(k, 0, len(states) - 1))
        self.set_ticks(states[k])
        if self.timeline.value != k:
            self._updating = True
            try:
                self.timeline.value = k  # type: ignore[misc]
            finally:
                self._updating = False

    def _on_timeline(self) -> None:
        if self._updating or self._replay is None:
            return
        self.show_command(int(self.timeline.value))

    def _on_play_button(self, label: str) -> None:
        if self._replay is None:
            return
        k = int(self.timeline.value)
        if label.startswith("◀"):
            self._playing = False
            self.show_command(k - 1)
        elif label.endswith("▶"):
            self._playing = False
            self.show_command(k + 1)
        elif label == "pause":
            self._playing = False
        elif label == "play" and not self._playing:
            self._playing = True
            if k >= self._replay.n_commands:
                self.show_command(0)
            self._player = threading.Thread(target=self._play, daemon=True)
            self._player.start()

    def _play(self) -> None:
        while self._playing and self._replay is not None:
            k = int(self.timeline.value) + 1
            if k > self._replay.n_commands:
                self._playing = False
                break
            self.show_command(k)
            time.sleep(1.0 / max(float(self.speed.value), 1.0))

    @property
    def page_title(self) -> str:
        """The title of the page (its browser tab, :func:`tab_title`): "armpath - " and the
        replay shown, or the arm and scene before any."""
        return self._page_title

    @page_title.setter
    def page_title(self, title: str) -> None:
        self._page_title = title
        script = html.escape(f"document.title = {json.dumps(title)}", quote=True)
        self._title_setter.content = f'<img src="data:," alt="" hidden onerror="{script}">'

    def stop(self) -> None:
        self._playing = False
        with contextlib.redirect_stdout(io.StringIO()):
            self.server.stop()


_HOST_NAME = re.compile(
    r"(?=.{1,253}\.?$)[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
    r"(\.[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?)*\.?"
)


def _resolve(host: str) -> list[tuple[int, tuple[object, ...]]]:
    """``(family, address)`` of every TCP address ``host`` names, resolved in a helper thread
    that is given up after ``RESOLVE_TIMEOUT_S``."""
    found: list[list[tuple[int, tuple[object, ...]]]] = []
    failed: list[OSError] = []

    def look_up() -> None:
        try:
            infos = socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
            found.append([(int(info[0]), tuple(info[4])) for info in infos])
        except OSError as exc:
            failed.append(exc)

    worker = threading.Thread(target=look_up, daemon=True)
    worker.start()
    worker.join(RESOLVE_TIMEOUT_S)
    if found and found[0]:
        return found[0]
    why = f" ({failed[0]})" if failed else f" (no answer in {RESOLVE_TIMEOUT_S:g} s)"
    raise InvalidInputError(f"--host {host!r} does not resolve to an address{why}")


def check_address(host: str, port: int) -> None:
    """Refuse, with :class:`InvalidInputError`, what the viewer could not serve on: a host that
    is neither an IPv4/IPv6 address nor a resolvable name, a port outside 1..65535 (0: any free
    port), an address this machine does not have, a port in use or not allowed."""
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise InvalidInputError(f"--port must be in 1..65535, got {port}")
    name = host[1:-1] if host.startswith("[") and host.endswith("]") else host
    try:
        ip = ipaddress.ip_address(name)
        family = socket.AF_INET6 if ip.version == 6 else socket.AF_INET
        addresses: list[tuple[int, tuple[object, ...]]] = [(int(family), (str(ip), 0))]
    except ValueError:
        if re.fullmatch(r"[0-9.]+", name):
            raise InvalidInputError(
                f"--host {host!r} is not a valid IPv4 address (four numbers 0..255)"
            ) from None
        if not _HOST_NAME.fullmatch(name):
            raise InvalidInputError(
                f"--host {host!r} is neither an IPv4/IPv6 address nor a host name"
            ) from None
        addresses = _resolve(name)
    for family_id, address in addresses:
        with socket.socket(family_id, socket.SOCK_STREAM) as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                s.bind((str(address[0]), port, *address[2:]))
            except OSError as exc:
                if exc.errno == errno.EADDRINUSE:
                    raise InvalidInputError(
                        f"port {port} on {host} is in use; choose another --port"
                    ) from None
                if exc.errno == errno.EADDRNOTAVAIL:
                    raise InvalidInputError(
                        f"--host {host!r}: address {address[0]} is not available on this "
                        "machine (use 127.0.0.1, 0.0.0.0 or one of its own addresses)"
                    ) from None
                if exc.errno == errno.EACCES:
                    raise InvalidInputError(
                        f"port {port} on {host} is not allowed (ports below 1024 need "
                        "privileges); choose another --port"
                    ) from None
                raise InvalidInputError(f"cannot serve on {host} port {port}: {exc}") from None


def free_port(host: str = "127.0.0.1") -> int:
    """A TCP port nothing listens on right now."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


#: Most commands per second a recorded replay plays (a page cannot show them faster).
MAX_REPLAY_FPS = 1000.0
#: Fewest commands per second a replay plays (one every 100 s; 1e-300 played none).
MIN_REPLAY_FPS = 0.01


def check_replay_fps(fps: float, name: str = "fps") -> None:
    """Refuse a replay's commands per second outside [:data:`MIN_REPLAY_FPS`,
    :data:`MAX_REPLAY_FPS`], naming it ``name`` (the option that set it)."""
    if not MIN_REPLAY_FPS <= fps <= MAX_REPLAY_FPS:
        raise InvalidInputError(
            f"{name} must be from {MIN_REPLAY_FPS:g} to {MAX_REPLAY_FPS:g} commands per second, "
            f"got {fps:g}"
        )


def replay_html(
    result: Result,
    *,
    fps: float = 15.0,
    max_frames: int = 600,
    notes: list[str] | None = None,
) -> str:
    """A self-contained HTML page (viser's client with the recording embedded) that replays
    ``result``: the scene, the curve and targets, the fingertip's path and the arm moving through
    the commands at ``fps`` commands per second (at most ``max_frames`` states, evenly spread).
    What the page leaves out (:attr:`ArmViewer.notes`) is appended to ``notes``."""
    check_replay_fps(fps)
    viewer = ArmViewer(result.arm, result.scene, port=free_port(), result=result)
    if notes is not None:
        notes.extend(viewer.notes)
    try:
        states = result.sequence.states()
        idx = np.unique(np.linspace(0, len(states) - 1, min(len(states), max_frames)).round())
        serializer = viewer.server.get_scene_serializer()
        for k in idx.astype(int):
            viewer.show_command(k)
            serializer.insert_sleep(1.0 / fps)
        return with_title(str(serializer.as_html()), viewer.page_title)
    finally:
        viewer.stop()
