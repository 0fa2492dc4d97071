"""Reading result JSON documents back (``armpath reach/trace/spotweld/plan/run`` output), for
replays and animations: the arm and scene they were planned in, and every lattice state."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import MAX_COMMANDS
from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError
from armpath.kinematics import tool_position
from armpath.model.lattice import Lattice
from armpath.model.seed_arm import seed_arm, seed_geometry_from
from armpath.model.serial_arm import SerialArm
from armpath.model.serialize import arm_from_dict
from armpath.scenes import Scene, load_scene, scene_from_dict
from armpath.schemas import SCHEMA_VERSION

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from armpath.viz.animation import Animation

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
RESULT_TASKS = ("reach", "trace", "spotweld", "plan")


@dataclass(frozen=True, repr=False)
class Result:
    """A planned result: its JSON document with what replaying it needs (the arm, the scene,
    the command sequence, the targets ``(K, 3)`` mm, empty if none, and the curve ``(M, 3)``
    mm of a trace). What :func:`armpath.reach` and the other tasks return, and what
    :func:`load_result` reads back from a file the CLI or :meth:`save` wrote.

    Units at this boundary: joint values in degrees (mm for a prismatic joint), positions in
    mm, commands in integer ticks of the arm's lattice (``arm.lattice``).
    """

    task: str
    doc: dict[str, Any]
    arm: SerialArm
    scene: Scene
    sequence: CommandSequence
    targets_mm: FloatArray
    curve_mm: FloatArray | None
    #: the file it was read from or last saved to (None: in memory only)
    path: Path | None = None

    @property
    def n_commands(self) -> int:
        """Number of commands."""
        return self.sequence.n_commands

    @property
    def commands(self) -> IntArray:
        """The commands, ``(n_commands, n_joints)`` integer ticks (one row per command)."""
        return np.array(self.sequence.commands, dtype=np.int64)

    @property
    def states_rad(self) -> FloatArray:
        """Joint values after each command, ``(n_commands + 1, n_joints)``, rad (prismatic
        joints in the model's length unit); row 0 is the start."""
        return self.sequence.states_joint()

    @property
    def states_deg(self) -> FloatArray:
        """Joint values after each command, ``(n_commands + 1, n_joints)``, deg (mm for a
        prismatic joint); row 0 is the start."""
        return np.asarray(self.sequence.grid.display(self.sequence.states()))

    @property
    def tool_positions_mm(self) -> FloatArray:
        """Tool point after each command, ``(n_commands + 1, 3)`` mm; row 0 is the start."""
        return np.asarray(tool_position(self.arm, self.states_rad) * self.arm.mm_per_unit)

    @property
    def tip_path_mm(self) -> FloatArray:
        """Alias of :attr:`tool_positions_mm` (the seed arm's tool is its fingertip)."""
        return self.tool_positions_mm

    @property
    def metrics(self) -> dict[str, Any]:
        """The result's numbers as the document states them: commands, lower bound, error,
        deviation and clearance (mm), and the plan's metrics where the task has them."""
        keys = (
            "n_commands",
            "lower_bound_commands",
            "error_mm",
            "max_deviation_mm",
            "coverage",
            "metrics",
            "clearance",
        )
        return {k: self.doc[k] for k in keys if k in self.doc}

    def __repr__(self) -> str:
        shown = ", ".join(
            f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v!r}"
            for k, v in self.metrics.items()
            if not isinstance(v, dict)
        )
        where = f", path={str(self.path)!r}" if self.path is not None else ""
        return (
            f"Result(task={self.task!r}, arm={self.arm.name!r}, scene={self.scene.name!r}, "
            f"{shown}{where})"
        )

    def title(self) -> str:
        name = f" ({self.path.name})" if self.path is not None else ""
        from armpath.report import commands_text

        return f"{self.task}: {commands_text(self.n_commands)}{name}"

    def to_json(self) -> str:
        """The JSON document, as the CLI writes it."""
        from armpath.export import json_text

        return json_text(self.doc)

    def save(self, path: str | Path) -> Path:
        """Write the result to the file ``path`` by its suffix, as the CLI writes it: ``.json``
        the document (what ``--json`` prints; :func:`load_result` reads it back), ``.csv`` the
        command table (step, ticks, joint values and tool point after each command), ``.xlsx``
        both (the table and a summary sheet). Missing folders on the way are created, as
        ``--out`` creates its folder; the file is written whole or not at all. Returns the
        path."""
        from armpath.export import output_folder, write_result_file

        out = _output_file(path, "path")
        with output_folder(out.parent, prune=False) as folder:  # whole file or nothing
            write_result_file(folder, out.name, self.doc, self.arm, self.sequence)
        if out.suffix.lower() == ".json":
            object.__setattr__(self, "path", out)
        return out

    def joint_trajectory(self, period_s: float | None = None) -> dict[str, Any]:
        """The motion as a ROS ``trajectory_msgs/JointTrajectory`` message (a JSON-ready dict:
        positions in rad (m for a prismatic joint), one point per state, ``period_s`` apart
        (default: the arm's command period); see :mod:`armpath.controller_export`)."""
        from armpath.controller_export import joint_trajectory

        return joint_trajectory(self.arm, self.sequence, period_s)

    def export_text(
        self,
        fmt: str,
        period_s: float | None = None,
        steps_per_tick: ArrayLike | None = None,
    ) -> str:
        """The motion for a controller: ``"csv"`` (time and joint values), ``"joint-trajectory"``
        (ROS JSON) or ``"steps"`` (motor steps per command), as ``armpath export`` writes it."""
        from armpath.controller_export import export_text

        return export_text(self.arm, self.sequence, fmt, period_s, steps_per_tick)

    def plot(self, path: str | Path | None = None) -> Figure:
        """The joint values after each command, one panel per joint (a matplotlib Figure);
        written to ``path`` when given (``.png``, ``.svg`` or ``.pdf``)."""
        from armpath.export import output_folder
        from armpath.viz.figures import FIGURE_SUFFIXES, plot_joint_angles

        if path is None:
            return plot_joint_angles(None, self.sequence, self.title())
        out = _output_file(path, "path")
        if out.suffix.lower() not in FIGURE_SUFFIXES:
            raise InvalidInputError(
                f"a figure is written as {', '.join(FIGURE_SUFFIXES)}, got {out.name!r}"
            )
        with output_folder(out.parent, prune=False) as folder:  # whole file or nothing
            return plot_joint_angles(folder.file(out.name), self.sequence, self.title())

    def animate(self, path: str | Path, *, fps: int = 15, max_frames: int = 120) -> int:
        """Write an animation of the motion (``.gif``, or ``.mp4`` with ffmpeg) to ``path``;
        returns the number of frames."""
        from armpath.viz.animation import write_animation

        out = _output_file(path, "path")
        return write_animation(out, self.animation(), fps=fps, max_frames=max_frames)

    def animation(self, substeps: int = 4) -> Animation:
        """The motion as an animation (:func:`armpath.viz.animation.sequence_animation`):
        ``substeps`` instants drawn per command."""
        from armpath.viz.animation import sequence_animation

        return sequence_animation(
            self.arm,
            self.scene,
            self.sequence,
            self.title(),
            self.targets_mm,
            self.curve_mm,
            substeps,
        )


def _output_file(path: Any, what: str) -> Path:
    """The file ``path`` (a ``str`` or ``os.PathLike``, ``~`` expanded) a result writes, or
    :class:`InvalidInputError` naming ``what`` when it is no path or names a folder."""
    text = os.fspath(path) if isinstance(path, str | os.PathLike) else None
    if not isinstance(text, str):
        raise InvalidInputError(
            f"{what} must be a file's path (str or pathlib.Path), got {type(path).__name__}"
        )
    out = Path(text).expanduser()
    if text.endswith(("/", os.sep)) or out.is_dir() or not out.name:
        raise InvalidInputError(
            f"{what} must name a file (a folder and a file name, e.g. results/reach.json), "
            f"got the folder {str(path)!r}"[:300]
        )
    return out


def _arm(model: Any) -> SerialArm:
    if not isinstance(model, dict):
        raise InvalidInputError(
            'the result\'s "model" must be an object (the model armpath wrote beside the '
            f"commands), got {type(model).__name__}"
        )
    definition = model.get("definition")
    if isinstance(definition, dict):
        return arm_from_dict(definition, "the result's model")
    if model.get("name") != "seed":
        named = f" {model['name']!r}" if model.get("name") is not None else " (no name)"
        raise InvalidInputError(
            f"the result's model{named} carries no definition, so it cannot be "
            "replayed (armpath writes every model's definition; only the seed arm is known by "
            "its parameters alone)"
        )
    p = model.get("parameters", {})
    limits = model.get("joint_limits_deg") or [None] * 6
    ranges = tuple(float("inf") if lim is None else float(lim[1]) for lim in limits)
    try:
        geometry = seed_geometry_from(p, ranges)
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidInputError(f"the result's model parameters are incomplete: {exc}") from None
    return seed_arm(geometry)


def _scene(doc: dict[str, Any], scene: Scene | str | Path | None) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if scene is not None:
        if not isinstance(scene, str | os.PathLike):
            raise InvalidInputError(
                "scene must be a Scene or a scene file's path (str or pathlib.Path), got "
                f"{type(scene).__name__}"
            )
        return load_scene(scene)
    described = doc.get("scene", {})
    if not isinstance(described, dict):
        raise InvalidInputError(
            f'the result\'s "scene" must be an object, got {type(described).__name__}'
        )
    source = described.get("source", "")
    wall = doc.get("wall_thickness") or described.get("wall_thickness")
    definition = described.get("definition")
    if isinstance(definition, dict) and definition:
        return scene_from_dict(definition, f"{source} (as stored in the result)")
    if source == "built-in seed.toml":
        loaded = load_scene(None)
    elif source and Path(source).is_file():
        loaded = load_scene(source)
    else:
        name = source or described.get("name") or "(unnamed)"
        raise InvalidInputError(
            f"the result was planned in scene {name!r}, which is not found here (the result "
            "holds no definition of it); give its scene file (--scene of animate and view; "
            "scene= of load_result)"
        )
    return loaded.with_wall_thickness(wall) if wall else loaded


#: Most bytes a result file may have (a six-joint command takes about 30, a trace's deviation
#: profile about 1.7 kB a command), beside its :data:`~armpath.budget.MAX_COMMANDS` commands:
#: export and animate read it whole.
MAX_RESULT_BYTES = 100_000_000


def _check_recorded_tip(doc: dict[str, Any], arm: SerialArm, seq: CommandSequence, p: Path) -> None:
    """The commands replayed on the document's model must end with the tool point where the
    document says (its ``tip``, written from the same replay): a model or commands changed
    after the run would otherwise replay, animate and export a different motion unnoticed."""
    recorded = doc.get("tip")
    if recorded is None:
        return
    try:
        tip = np.asarray(recorded, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise InvalidInputError(f"result file {p}: its tip is not three numbers") from None
    replayed = tool_position(arm, seq.states_joint()[-1])
    if not np.allclose(replayed, tip, rtol=0.0, atol=1e-3 / arm.mm_per_unit):
        mm = arm.mm_per_unit  # shown in mm, to the micrometre the check allows
        raise InvalidInputError(
            f"result file {p}: its commands on its model end with the tool point at "
            f"({', '.join(f'{v * mm:.4f}' for v in replayed)}) mm, not at its recorded tip "
            f"({', '.join(f'{v * mm:.4f}' for v in tip)}) mm: the model or the commands were "
            "changed after the run"
        )


def _commands(raw: Any, lattice: Lattice) -> IntArray:
    """A document's ``commands``: at most :data:`~armpath.budget.MAX_COMMANDS` rows of one whole
    number of ticks a joint, each within the joint's most ticks a command. Checked as JSON
    gives them, before any conversion: an integer beyond int64 (JSON has no limit) would
    overflow it, a fraction or ``true`` would be taken as a number of ticks."""
    n = lattice.n_joints
    if not isinstance(raw, list):
        got = type(raw).__name__
        raise InvalidInputError(f"commands must be a list of commands of {n} integers, got {got}")
    if len(raw) > MAX_COMMANDS:
        raise InvalidInputError(
            f"{len(raw):,} commands, more than the {MAX_COMMANDS:,} a result may have"
        )
    most = [int(m) for m in lattice.max_ticks]
    for k, row in enumerate(raw):
        if not (isinstance(row, list) and len(row) == n):
            shown = repr(row)[:100]
            raise InvalidInputError(f"command {k + 1} must be {n} integers (ticks), got {shown}")
        for i, (v, m) in enumerate(zip(row, most, strict=True)):
            if type(v) is not int:  # a float, text, null, or true (a bool is an int)
                raise InvalidInputError(
                    f"command {k + 1}, joint {i + 1}: a command moves a joint by an integer "
                    f"number of ticks, got {v!r}"[:200]
                )
            if not -m <= v <= m:
                raise lattice.increment_error(k, i, v)
    return np.array(raw, dtype=np.int64).reshape(-1, n)


def load_result(path: str | Path, scene: Scene | str | Path | None = None) -> Result:
    """Read a result JSON document; its scene comes from ``scene`` or, if omitted, from the
    scene definition the document carries (older documents: the source it names, the built-in
    seed scene or a scene file that still exists)."""
    if not isinstance(path, str | os.PathLike) or isinstance(os.fspath(path), bytes):
        raise InvalidInputError(
            f"path must be a result file's path (str or pathlib.Path), got {type(path).__name__}"
        )
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > MAX_RESULT_BYTES:
            raise InvalidInputError(
                f"result file {p} is {size:,} bytes, more than the {MAX_RESULT_BYTES:,} a "
                f"result may have ({MAX_COMMANDS:,} commands)"
            )
        doc = json.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InvalidInputError(f"cannot read result file {p}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise InvalidInputError(f"result file {p} is not UTF-8 text (not a result)") from None
    except json.JSONDecodeError as exc:
        raise InvalidInputError(f"result file {p} is not valid JSON: {exc}") from None
    if not isinstance(doc, dict) or doc.get("task") not in RESULT_TASKS:
        raise InvalidInputError(
            f"result file {p}: expected an armpath result with task one of {RESULT_TASKS}"
        )
    version = doc.get("schema_version", 1)
    if not isinstance(version, int) or version > SCHEMA_VERSION:
        raise InvalidInputError(
            f"result file {p}: schema_version {version!r} is newer than this armpath reads "
            f"({SCHEMA_VERSION}); update armpath"
        )
    arm = _arm(doc.get("model", {}))
    try:
        start = arm.lattice.from_display(doc["initial_deg"], "initial_deg")
        commands = _commands(doc["commands"], arm.lattice)
    except InvalidInputError as exc:  # names the key and what is wrong with it
        raise InvalidInputError(f"result file {p}: {exc}") from None
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidInputError(f"result file {p}: no valid initial_deg/commands ({exc})") from None
    sequence = CommandSequence(start, commands, arm.lattice)
    _check_recorded_tip(doc, arm, sequence, p)
    if "targets" in doc:
        targets = np.asarray(doc["targets"], dtype=float).reshape(-1, 3)
    elif doc.get("target") is not None:
        targets = np.asarray(doc["target"], dtype=float).reshape(-1, 3)
    else:
        targets = np.zeros((0, 3))
    curve = doc.get("curve", {}).get("points_mm")
    return Result(
        str(doc["task"]),
        doc,
        arm,
        _scene(doc, scene),
        sequence,
        targets,
        None if curve is None else np.asarray(curve, dtype=float).reshape(-1, 3),
        p,
    )


__all__ = ["RESULT_TASKS", "Result", "load_result"]
