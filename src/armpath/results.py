"""Reading result JSON documents back (``armpath reach/trace/spotweld/plan/run`` output), for
replays and animations: the arm and scene they were planned in, and every lattice state."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from armpath.commands import CommandSequence
from armpath.errors import InvalidInputError
from armpath.kinematics import tool_position
from armpath.model.seed_arm import seed_arm, seed_geometry_from
from armpath.model.serial_arm import SerialArm
from armpath.model.serialize import arm_from_dict
from armpath.scenes import Scene, load_scene, scene_from_dict

FloatArray = NDArray[np.float64]
RESULT_TASKS = ("reach", "trace", "spotweld", "plan")


@dataclass(frozen=True)
class PlannedResult:
    """A result document with what it needs to be replayed: the arm, the scene, the command
    sequence, the targets (``(K, 3)`` mm; empty if none) and the curve (``(M, 3)`` mm, trace
    results only)."""

    path: Path
    task: str
    doc: dict[str, Any]
    arm: SerialArm
    scene: Scene
    sequence: CommandSequence
    targets_mm: FloatArray
    curve_mm: FloatArray | None

    @property
    def states_rad(self) -> FloatArray:
        """Joint angles after each command, ``(n_commands + 1, 6)`` rad."""
        return self.sequence.states_joint()

    @property
    def tip_path_mm(self) -> FloatArray:
        """Fingertip position after each command, ``(n_commands + 1, 3)`` mm."""
        return tool_position(self.arm, self.states_rad)

    def title(self) -> str:
        n = self.sequence.n_commands
        return f"{self.task}: {n} commands ({self.path.name})"


def _arm(model: dict[str, Any]) -> SerialArm:
    definition = model.get("definition")
    if isinstance(definition, dict):
        return arm_from_dict(definition, "the result's model")
    if model.get("name") != "seed":
        raise InvalidInputError(
            f"result documents of model {model.get('name')!r} cannot be replayed; only the seed "
            "arm's"
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
        return load_scene(scene)
    described = doc.get("scene", {})
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
        raise InvalidInputError(
            f"the result was planned in scene {source!r}, which is not found here; give the "
            "scene file (--scene)"
        )
    return loaded.with_wall_thickness(wall) if wall else loaded


def load_result(path: str | Path, scene: Scene | str | Path | None = None) -> PlannedResult:
    """Read a result JSON document; its scene comes from ``scene`` or, if omitted, from the
    scene definition the document carries (older documents: the source it names, the built-in
    seed scene or a scene file that still exists)."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise InvalidInputError(f"cannot read result file {p}: {exc.strerror}") from None
    except json.JSONDecodeError as exc:
        raise InvalidInputError(f"result file {p} is not valid JSON: {exc.msg}") from None
    if not isinstance(doc, dict) or doc.get("task") not in RESULT_TASKS:
        raise InvalidInputError(
            f"result file {p}: expected an armpath result with task one of {RESULT_TASKS}"
        )
    arm = _arm(doc.get("model", {}))
    try:
        start = arm.lattice.from_display(doc["initial_deg"], f"result file {p}: initial_deg")
        commands = np.asarray(doc["commands"], dtype=np.int64).reshape(-1, arm.n_joints)
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidInputError(f"result file {p}: no valid initial_deg/commands ({exc})") from None
    sequence = CommandSequence(start, commands, arm.lattice)
    if "targets" in doc:
        targets = np.asarray(doc["targets"], dtype=float).reshape(-1, 3)
    elif doc.get("target") is not None:
        targets = np.asarray(doc["target"], dtype=float).reshape(-1, 3)
    else:
        targets = np.zeros((0, 3))
    curve = doc.get("curve", {}).get("points_mm")
    return PlannedResult(
        p,
        str(doc["task"]),
        doc,
        arm,
        _scene(doc, scene),
        sequence,
        targets,
        None if curve is None else np.asarray(curve, dtype=float).reshape(-1, 3),
    )
