"""The arm that works in a scene: its ``[arm]`` table applied to a built-in model or robot file.

``[arm]`` gives the model (built-in name or robot file, relative to the scene file), where the
arm stands in the cell (``base``), the tool centre point (``tool``, a transform from the
flange), the home pose, link radii and the command lattice. Without ``[arm]`` the seed arm works
in the scene. A model chosen on the command line (``--model``) replaces the scene's model and
keeps only where the scene puts it (``base``): the rest of ``[arm]`` belongs to its own model.
Naming the scene's own model keeps the whole ``[arm]``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError, SceneError
from armpath.model.catalog import resolve_model
from armpath.model.lattice import MM_PER_LENGTH_UNIT
from armpath.model.serial_arm import SerialArm, nearest_on_lattice
from armpath.scenes.build import rotation_matrix
from armpath.scenes.scene import Scene
from armpath.scenes.schema import ArmSpec, PlacementSpec


def placement_matrix(spec: PlacementSpec, length_unit: str = "mm") -> NDArray[np.float64]:
    """The 4x4 transform of a placement (its position converted from mm to ``length_unit``)."""
    T = np.eye(4)
    T[:3, :3] = rotation_matrix(spec.rotation_deg)
    T[:3, 3] = np.asarray(spec.position_mm) / MM_PER_LENGTH_UNIT[length_unit]
    return T


def _model(name: str, base_dir: str | None, tip_link: str | None = None) -> SerialArm:
    path = Path(name)
    if base_dir is not None and not path.is_absolute() and (Path(base_dir) / path).is_file():
        return resolve_model(str(Path(base_dir) / path), tip_link)
    return resolve_model(name, tip_link)


def _per_joint(value: float | int | list[float] | list[int], n: int, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise InvalidInputError(f"{what} needs one number or {n} (one per joint), got {arr.size}")
    return arr


def arm_from_spec(spec: ArmSpec, base_dir: str | None = None) -> SerialArm:
    """The arm an ``[arm]`` table describes."""
    arm = _model(spec.model, base_dir, spec.tip_link)
    n = arm.n_joints
    mm = 1.0 / arm.mm_per_unit  # model units per mm
    if spec.tick is not None or spec.max_ticks is not None:
        tick = None
        if spec.tick is not None:
            shown = _per_joint(spec.tick, n, "arm.tick")
            tick = arm.lattice.joint_from_display(shown)  # a tick is a joint value
        most = None if spec.max_ticks is None else _per_joint(spec.max_ticks, n, "arm.max_ticks")
        arm = arm.with_lattice(tick, most)  # the lattice checks them whole and in range
        if spec.home_deg is None and np.any(arm.lattice.off_lattice(arm.home)):
            # the model's home lies off these ticks: the nearest state on them within limits
            arm = arm.with_home(nearest_on_lattice(arm.joints, arm.home))
    if spec.steps_per_tick is not None or spec.command_period_s is not None:
        arm = arm.with_lattice(
            steps_per_tick=spec.steps_per_tick, command_period_s=spec.command_period_s
        )
    if spec.link_radii_mm is not None:
        radii = np.asarray(spec.link_radii_mm, dtype=np.float64) * mm
        arm = arm.with_link_radii(float(radii) if radii.ndim == 0 else radii.tolist())
    if spec.tool is not None:
        radius = None if spec.tool.radius_mm is None else spec.tool.radius_mm * mm
        arm = arm.with_tool(
            placement_matrix(spec.tool, arm.length_unit), radius, spec.tool.approach_axis
        )
    if spec.base is not None:
        arm = arm.placed(placement_matrix(spec.base, arm.length_unit))
    if spec.home_deg is not None:
        home = _per_joint(spec.home_deg, n, "arm.home_deg")
        arm = arm.with_home(arm.lattice.joint_from_display(home))
        arm.lattice.from_display(home, "arm.home_deg")  # the tasks start there: on the lattice
    return arm


def scene_arm(scene: Scene, model: str | None = None, tip_link: str | None = None) -> SerialArm:
    """The arm that works in ``scene``: its ``[arm]``, or the seed arm if it has none; ``model``
    (a built-in name or robot file) replaces the scene's model and keeps only its ``base``,
    unless it names the scene's own model, which keeps the whole ``[arm]`` (its tool, home,
    radii and lattice); ``tip_link`` chooses a URDF's tool link."""
    spec = scene.arm_spec
    if spec is not None and model == spec.model:
        model = None  # the scene's own arm, written out: keep all of [arm]
    if model is not None:  # the caller's model: its errors are the caller's, not the scene's
        return arm_from_spec(
            ArmSpec(model=model, base=spec.base if spec is not None else None, tip_link=tip_link),
            None,
        )
    try:
        base = spec or ArmSpec()
        if tip_link is not None:
            base = base.model_copy(update={"tip_link": tip_link})
        return arm_from_spec(base, scene.base_dir)
    except SceneError:
        raise
    except InvalidInputError as exc:
        raise SceneError(f"scene {scene.source}: arm: {exc}") from None


#: How deep inside an obstacle an arm's base may stand before :func:`buried_base_note` says so
#: (mm): a base on an obstacle's face stands at 0.
BURIED_BASE_MM = 1.0


def buried_base_note(arm: SerialArm, scene: Scene) -> str | None:
    """A note where the arm's base frame lies more than :data:`BURIED_BASE_MM` inside one of
    the scene's obstacles (its fixed base is not checked against them, so a base placed at the
    floor under a pedestal, say, goes unnoticed), else None."""
    origin = (
        np.asarray(arm.T_world_base[:3, 3], dtype=np.float64) * MM_PER_LENGTH_UNIT[arm.length_unit]
    )
    for o in scene.world.obstacles:
        depth = -float(np.asarray(o.signed_distance(origin[None]))[0])
        if depth > BURIED_BASE_MM:
            where = ", ".join(f"{v:g}" for v in origin)
            return (
                f"the arm's base at ({where}) mm lies {depth:.0f} mm inside obstacle {o.name!r} "
                "(an arm's fixed base is not checked against obstacles): is that where it stands?"
            )
    return None


__all__ = ["arm_from_spec", "buried_base_note", "placement_matrix", "scene_arm"]
