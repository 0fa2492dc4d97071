"""armpath from Python: load an arm and a scene, plan, and get a :class:`~armpath.Result`.

Units at this boundary are millimetres and degrees everywhere (mm for a prismatic joint's
value); commands are integer ticks of the arm's lattice, one row per command. Every task
returns a :class:`~armpath.results.Result` whose document is the JSON the CLI writes for the
same task, so ``result.save(path)`` and ``armpath view --result path`` work alike.

The arm and scene go together as on the command line: ``arm`` is a model (a
:class:`~armpath.model.serial_arm.SerialArm`, a built-in name or a robot file) and ``scene`` a
:class:`~armpath.scenes.Scene` or a scene file. Without a scene the seed arm works in the seed
scene and any other arm stands alone (self-collision only); a named model placed in a scene
stands where the scene's ``[arm]`` puts it.
"""

from __future__ import annotations

import contextlib
import math
import numbers
import reprlib
import warnings
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import check_point_mm, time_limit
from armpath.errors import ArmpathWarning, InvalidInputError
from armpath.ik.target import refuse_alone, rule_tolerances
from armpath.model.serial_arm import SerialArm
from armpath.results import Result, load_result
from armpath.scenes import Scene
from armpath.tolerances import POINT_TOLERANCE_MM

if TYPE_CHECKING:
    from armpath.commands import CommandSequence
    from armpath.geometry.curves import Curve
    from armpath.ik.target import Orientation
    from armpath.planning.trace import AxisRule

#: What names an arm: a model, a built-in model's name, or a robot file (``.json``, ``.urdf``).
ArmLike = SerialArm | str | Path
#: What names a scene: a scene, a scene file (``.toml``, ``.yaml``), or ``"seed"``.
SceneLike = Scene | str | Path | Mapping[str, Any]

#: The scene of an arm that stands alone: no obstacles, its links kept apart from each other.
ALONE_SCENE = {"name": "none (the arm alone)", "description": "no obstacles: self-collision only"}


def _checked(
    numbers_: dict[str, Any] | None = None,
    counts: dict[str, Any] | None = None,
    flags: dict[str, Any] | None = None,
    required: dict[str, Any] | None = None,
) -> None:
    """Refuse, by name, keyword values of the wrong kind before any work: ``numbers_`` must be
    real numbers (or None: the option's default), ``required`` real numbers (None is no
    value: a tolerance), ``counts`` whole numbers >= 0, ``flags`` True or False. The ranges
    are the options' own to check."""
    for name, value in [*(numbers_ or {}).items(), *(required or {}).items()]:
        if value is None and name not in (required or {}):
            continue
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
            raise InvalidInputError(f"{name} must be a number, got {value!r}")
    for name, value in (counts or {}).items():
        if (
            isinstance(value, bool | np.bool_)
            or not isinstance(value, numbers.Integral)
            or value < 0
        ):
            raise InvalidInputError(f"{name} must be a whole number >= 0, got {value!r}")
    for name, value in (flags or {}).items():
        if not isinstance(value, bool | np.bool_):
            raise InvalidInputError(f"{name} must be True or False, got {value!r}")


def _reals(values: ArrayLike, what: str) -> NDArray[Any]:
    """``values`` as an array of real numbers (integers or floats, any precision), or
    :class:`InvalidInputError` naming ``what``: text, complex numbers, flags and None are no
    joint values or coordinates (numpy would parse ``"1"``, and drop an imaginary part with a
    warning)."""

    def wrong() -> InvalidInputError:  # built only when raised: repr of a million points is slow
        return InvalidInputError(f"{what} must be real numbers, got {reprlib.repr(values)}")

    try:
        a = np.asarray(values)
        if a.dtype.kind == "O":  # Python objects: numbers of other types (Fraction), or not
            if not all(
                isinstance(v, numbers.Real) and not isinstance(v, bool | np.bool_)
                for v in a.ravel()
            ):
                raise wrong()
            a = a.astype(np.float64)
    except (TypeError, ValueError, OverflowError):  # ragged, or an integer beyond any float
        raise wrong() from None
    if a.dtype.kind not in "iuf":
        raise wrong()
    return a


def _degrees(values: ArrayLike, what: str) -> NDArray[np.float64]:
    """Joint values (deg, mm) as float64; float32 ones by their shortest decimal, so that a
    value written 12.3 stays on the 0.1 deg lattice (as float32 it is 12.300000190...)."""
    a = _reals(values, what)
    if a.dtype.kind == "f" and a.dtype.itemsize < 8:
        flat = [float(np.format_float_positional(v, unique=True)) for v in a.ravel()]
        return np.array(flat, dtype=np.float64).reshape(a.shape)
    return np.asarray(a, dtype=np.float64)


def load_arm(
    model: str | Path | None = None,
    *,
    scene: SceneLike | None = None,
    tip_link: str | None = None,
    link_radius_mm: float | None = None,
) -> SerialArm:
    """An arm: a built-in model by name (``"seed"``, ``"ur5"``, ``"puma560"``, ...) or a robot
    file (``.json`` D-H/MDH table, ``.urdf`` up to ``tip_link``); ``link_radius_mm`` gives
    every link that radius (mm) for collision checks. Without ``scene`` it stands where its
    own base puts it (no model: the seed arm). With ``scene`` it is the arm the tasks take
    there, for forward and inverse kinematics in the cell's frame: no model, the scene's own
    as its ``[arm]`` places it (base, tool, home); a model named, that model at the scene's
    base (its own tool and home)."""
    from armpath.model.catalog import resolve_model

    _checked({"link_radius_mm": link_radius_mm})
    if scene is not None:
        arm, _ = arm_and_scene(model, scene, tip_link=tip_link)
    else:
        arm = resolve_model(str(model or "seed"), tip_link)
    if link_radius_mm is not None:
        if not (math.isfinite(link_radius_mm) and link_radius_mm >= 0):
            raise InvalidInputError(f"link_radius_mm must be >= 0, got {link_radius_mm}")
        arm = arm.with_link_radii(link_radius_mm)  # every arm enters in mm (SerialArm.in_mm)
    return arm


def load_scene(source: SceneLike | None = None) -> Scene:
    """A scene: a scene file (``.toml``, ``.yaml``), ``None`` or ``"seed"`` for the seed scene,
    ``"none"`` for an empty cell (no obstacles), or a scene file's contents as a dict (the
    same keys and values; relative paths in it from the working directory)."""
    from armpath.scenes import load_scene as load_scene_file
    from armpath.scenes import scene_from_dict

    if isinstance(source, Scene):
        return source
    if isinstance(source, Mapping):
        return scene_from_dict(dict(source), "given as a dict")
    if not (source is None or isinstance(source, str | Path)):
        raise InvalidInputError(
            f"scene must be a Scene, a scene file's path, a dict of a scene file's contents, "
            f"'seed' or 'none', got {type(source).__name__}"
        )
    if source is None or str(source) == "seed":
        return load_scene_file(None)
    if str(source) == "none":
        return scene_from_dict(dict(ALONE_SCENE), "none (the arm alone)")
    return load_scene_file(Path(source))


def default_scene(arm: ArmLike | None) -> Scene:
    """The scene of a task given no scene: the seed scene for the seed arm (or no arm), else
    an empty cell where the arm stands alone."""
    if isinstance(arm, SerialArm):
        is_seed = arm.name == "seed"
    else:
        is_seed = arm is None or str(arm) == "seed"
    return load_scene(None if is_seed else "none")


def arm_and_scene(
    arm: ArmLike | None = None,
    scene: SceneLike | None = None,
    *,
    tip_link: str | None = None,
) -> tuple[SerialArm, Scene]:
    """The arm and the scene a task runs with, decided as the CLI decides them: the scene
    given, else the seed scene for the seed arm and an empty one for any other arm; the arm
    given (a model name or file is placed where the scene's ``[arm]`` stands it), else the
    scene's arm. An arm in metres is taken in millimetres (:meth:`SerialArm.in_mm`), the unit
    of every target, tolerance and obstacle. An arm whose base stands inside an obstacle, or a
    :class:`SerialArm` of the scene's own model placed otherwise than the scene places it, is
    pointed out with an :class:`~armpath.errors.ArmpathWarning` (a warning, not an error)."""
    from armpath.scenes.arm import buried_base_note, scene_arm

    the_scene = default_scene(arm) if scene is None else load_scene(scene)
    if isinstance(arm, SerialArm):
        the_arm = arm.in_mm()
        note = _placed_elsewhere_note(the_arm, the_scene)
    else:
        the_arm = scene_arm(the_scene, None if arm is None else str(arm), tip_link)
        note = None
    for said in (note, buried_base_note(the_arm, the_scene)):
        if said is not None:
            warnings.warn(said, ArmpathWarning, stacklevel=3)
    return the_arm, the_scene


def _placed_elsewhere_note(arm: SerialArm, scene: Scene) -> str | None:
    """A note where ``arm`` (a :class:`SerialArm` given as it is) is the model the scene's
    ``[arm]`` places, but stands or carries its tool otherwise than the scene's (a model loaded
    alone and given with the scene: its base at the origin, its file's tool)."""
    from armpath.errors import ArmpathError
    from armpath.scenes.arm import scene_arm

    if scene.arm_spec is None:
        return None
    try:
        placed = scene_arm(scene)
    except ArmpathError:  # the scene's model is not to be found here: nothing to compare
        return None
    if placed.name != arm.name or placed.n_joints != arm.n_joints:
        return None
    base = np.allclose(placed.T_world_base, arm.T_world_base, atol=1e-6)
    tool = np.allclose(placed.T_flange_tool, arm.T_flange_tool, atol=1e-6) and np.allclose(
        placed.T_joint_flange, arm.T_joint_flange, atol=1e-6
    )
    if base and tool:
        return None
    where = ", ".join(f"{v:g}" for v in np.round(placed.T_world_base[:3, 3], 3))
    differs = " and ".join(
        what
        for what, same in (
            ("stands where its own base puts it", base),
            ("carries another tool", tool),
        )
        if not same
    )
    return (
        f"the arm given ({arm.name!r}) {differs}, not as scene {scene.name!r} places its "
        f"{arm.name!r} (base at ({where}) mm, the scene's tool): armpath.load_arm(scene=...) "
        "gives the arm as the scene places it"
    )


@contextlib.contextmanager
def _placement_hint(arm: ArmLike | None, scene: Scene) -> Iterator[None]:
    """Name the likely cause of a collision where a :class:`SerialArm` given as it is stands
    elsewhere than the scene's ``[arm]`` puts its arm (a model named by string stands there)."""
    from armpath.errors import CollisionError
    from armpath.scenes.arm import placement_matrix

    try:
        yield
    except CollisionError as exc:
        spec = scene.arm_spec
        if not isinstance(arm, SerialArm) or spec is None or spec.base is None:
            raise
        if np.allclose(arm.T_world_base, placement_matrix(spec.base), atol=1e-9):
            raise
        where = ", ".join(f"{v:g}" for v in spec.base.position_mm)
        raise CollisionError(
            f"{exc} (the SerialArm given stands where its own base puts it, not at ({where}) "
            f"mm where the scene's [arm] stands its arm: give the model by name, "
            f"{spec.model!r}, to stand it there, or place it with SerialArm.placed)"
        ) from None


def _start_ticks(arm: SerialArm, start_deg: ArrayLike | None) -> NDArray[np.int64]:
    """The lattice state of ``start_deg`` (deg, mm for a prismatic joint); None: home."""
    if start_deg is None:
        return arm.lattice.to_ticks(arm.home, "the arm's home pose")
    return arm.lattice.from_display(_joint_values(arm, start_deg, "start_deg"), "start_deg")


def _joint_values(arm: SerialArm, values: ArrayLike, what: str) -> NDArray[np.float64]:
    """One joint state ``what`` of ``arm`` (deg, mm for a prismatic joint): one value a joint."""
    v = _degrees(values, what)
    if v.shape != (arm.n_joints,):
        raise InvalidInputError(
            f"{what} must be one joint state: {arm.n_joints} values (deg, mm for a prismatic "
            f"joint), got shape {v.shape}"
        )
    return v


def _point(values: ArrayLike, what: str, unit: str = "mm") -> NDArray[np.float64]:
    wrong = InvalidInputError(f"{what} must be three finite numbers ({unit}), got {values!r}")
    try:
        p = np.asarray(_reals(values, what), dtype=np.float64)
    except InvalidInputError:
        raise wrong from None
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise wrong
    return p


def _point_mm(values: ArrayLike, what: str) -> NDArray[np.float64]:
    """A target point (mm): three finite numbers within :data:`MAX_COORDINATE_MM`."""
    p = _point(values, what)
    check_point_mm(p.tolist(), what)
    return p


def _points_mm(values: ArrayLike, what: str, least: int) -> NDArray[np.float64]:
    """Points ``(K, 3)`` (mm), at least ``least`` of them: finite numbers within
    :data:`MAX_COORDINATE_MM`."""
    try:
        p = np.asarray(_reals(values, what), dtype=np.float64)
    except InvalidInputError:
        raise InvalidInputError(
            f"{what} must be points (K, 3) of numbers (mm), got {values!r}"[:300]
        ) from None
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < least or not np.all(np.isfinite(p)):
        raise InvalidInputError(
            f"{what} must be (K, 3) finite points (mm), K >= {least}, got shape {p.shape}"
            + ("" if np.all(np.isfinite(p)) else " with values not finite")
        )
    check_point_mm(p.ravel().tolist(), what)
    return p


def _axis_rule(tool_axis: Any, axis_tolerance_deg: float | None) -> AxisRule | None:
    """The tool-axis rule of a trace or a tour: ``"normal"`` or a world direction."""
    from armpath.planning.trace import AxisRule

    refuse_alone("axis_tolerance_deg", axis_tolerance_deg, "tool_axis", tool_axis)
    return None if tool_axis is None else AxisRule.of(tool_axis, axis_tolerance_deg)


def _pose_at(pose: Any, target_mm: NDArray[np.float64]) -> NDArray[np.float64]:
    """The 4x4 transform of ``pose`` (:func:`armpath.poses.pose_matrix` forms) at
    ``target_mm``: a pose with a position must hold it there (or at zero, a rotation alone)."""
    from armpath.poses import pose_matrix

    m = pose_matrix(pose)
    at = m[:3, 3]
    if np.any(at != 0.0) and np.linalg.norm(at - target_mm) > 1e-6:
        raise InvalidInputError(
            f"the pose's position {np.round(at, 6).tolist()} mm is not the target "
            f"{np.round(target_mm, 6).tolist()} mm: the target gives the position (give "
            "the pose as a rotation, or as a transform at the target)"
        )
    m[:3, 3] = target_mm
    return m


def _orientation(
    arm: SerialArm,
    pose: Any,
    angle_tolerance_deg: float | None,
    tool_axis: ArrayLike | None,
    axis_tolerance_deg: float | None,
    target_mm: NDArray[np.float64],
) -> Orientation | None:
    """The orientation rule of a whole pose (:func:`armpath.poses.pose_matrix` forms) or of a
    tool-axis cone about a fixed direction. A pose with a position (a 4x4 transform) must
    hold it at ``target_mm`` or at zero (a rotation alone): the target gives the position."""
    from armpath.ik.target import AxisCone, PoseOrientation

    axis_tolerance_deg, angle_tolerance_deg = rule_tolerances(
        axis_tolerance_deg, angle_tolerance_deg, tool_axis, pose
    )
    if pose is not None:
        m = _pose_at(pose, target_mm)
        return PoseOrientation(m[:3, :3], math.radians(angle_tolerance_deg))
    if isinstance(tool_axis, str):
        raise InvalidInputError(
            f"tool_axis of a reach or a plan is a direction (x, y, z), got {tool_axis!r}: the "
            "surface's normal ('normal') is a rule for trace and spotweld, along a surface"
        )
    if tool_axis is not None:
        return AxisCone(
            _point(tool_axis, "tool_axis", "a direction x, y, z"),
            math.radians(axis_tolerance_deg),
            np.asarray(arm.approach_axis),
        )
    return None


def _result(doc: dict[str, Any], arm: SerialArm, scene: Scene, seq: CommandSequence) -> Result:
    """A result of a document the export layer wrote (rounded as the CLI prints it)."""
    import json

    from armpath.export import json_text

    clean = json.loads(json_text(doc))
    targets = clean.get("targets", [clean["target"]] if clean.get("target") else [])
    curve = clean.get("curve", {}).get("points_mm")
    return Result(
        str(clean["task"]),
        clean,
        arm,
        scene,
        seq,
        np.asarray(targets, dtype=np.float64).reshape(-1, 3),
        None if curve is None else np.asarray(curve, dtype=np.float64).reshape(-1, 3),
    )


def _model(arm: ArmLike, tip_link: str | None = None) -> SerialArm:
    """The arm of a kinematics query: a model as it is (in mm; placed where its
    ``T_world_base`` puts it, as :meth:`SerialArm.placed` leaves it), or a built-in model or
    robot file by name, in the frame its own base transform puts it (no scene places it)."""
    from armpath.model.catalog import resolve_model

    if isinstance(arm, SerialArm):
        return arm.in_mm()
    if not isinstance(arm, str | Path):
        raise InvalidInputError(
            f"arm must be a SerialArm, a built-in model's name or a robot file, got {arm!r}"
        )
    return resolve_model(str(arm), tip_link)


def forward_kinematics(
    arm: ArmLike, joints_deg: ArrayLike, *, tip_link: str | None = None
) -> dict[str, Any]:
    """Forward kinematics of one joint state ``joints_deg`` (deg, mm for a prismatic joint)
    in the frame the arm's base transform puts it (a model named: its own; a
    :class:`SerialArm` placed in a cell: the cell's): the document ``armpath fk --json``
    prints, ``tip`` (mm), ``pose`` (4x4, mm), each of the arm's ``points`` (mm), and
    ``warnings`` (a joint beyond its limits; the seed arm below its table). Many states at
    once: :func:`armpath.kinematics.tool_position` (rad)."""
    import json

    from armpath.export import fk_document, json_line

    the_arm = _model(arm, tip_link)
    values = _joint_values(the_arm, joints_deg, "joints_deg")
    if not np.all(np.isfinite(values)):
        raise InvalidInputError(f"joints_deg must be finite numbers, got {values.tolist()}")
    doc = fk_document(the_arm, the_arm.lattice.joint_from_display(values))
    return dict(json.loads(json_line(doc)))  # rounded as the CLI prints it


def inverse_kinematics(
    arm: ArmLike,
    *,
    pose: Any = None,
    target_mm: ArrayLike | None = None,
    near_deg: ArrayLike | None = None,
    method: str = "auto",
    seeds: int = 48,
    tip_link: str | None = None,
) -> dict[str, Any]:
    """Every inverse-kinematics solution of a tool ``pose`` at ``target_mm`` (a rotation, in
    any form of :mod:`armpath.poses`; or a 4x4 transform alone, position in mm), or of the
    tool point alone at ``target_mm``: the document ``armpath ik --json`` prints, solutions
    in deg (mm for a prismatic joint) with their residuals, ``count`` 0 and a ``reason``
    where there is none. Complete methods (``method``: auto, spherical-wrist, three-parallel,
    general) give every real solution of a 6-axis pose; where the target leaves a family
    (``family_dimension`` > 0: a point alone, a 7-axis arm) the solutions are samples of it,
    nearest ``near_deg`` first where given."""
    from armpath.export import ik_document
    from armpath.ik import solve_ik
    from armpath.ik.solve import METHODS
    from armpath.poses import pose_matrix

    _checked(None, {"seeds": seeds})
    if method not in METHODS:
        raise InvalidInputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if pose is None and target_mm is None:
        raise InvalidInputError("give pose (with target_mm for a rotation alone) or target_mm")
    the_arm = _model(arm, tip_link)
    near = (
        None
        if near_deg is None
        else the_arm.lattice.joint_from_display(_joint_values(the_arm, near_deg, "near_deg"))
    )
    if pose is None:
        assert target_mm is not None
        point = _point_mm(target_mm, "target_mm")
        result = solve_ik(the_arm, point, position_only=True, seeds=seeds, near=near)
        return ik_document(the_arm, result, point, pose=False)
    T = (
        pose_matrix(pose)
        if target_mm is None
        else _pose_at(pose, _point_mm(target_mm, "target_mm"))
    )
    result = solve_ik(the_arm, T, method=method, seeds=seeds, near=near)
    return ik_document(the_arm, result, T, pose=True)


def reach(
    arm: ArmLike | None,
    target_mm: ArrayLike,
    *,
    scene: SceneLike | None = None,
    start_deg: ArrayLike | None = None,
    tolerance_mm: float | None = None,
    pose: Any = None,
    angle_tolerance_deg: float | None = None,
    tool_axis: ArrayLike | None = None,
    axis_tolerance_deg: float | None = None,
    seed: int = 0,
    time_limit_s: float | None = None,
) -> Result:
    """Reach ``target_mm`` (x, y, z) with the tool in the fewest commands, then the smallest
    error, from ``start_deg`` (default: the arm's home pose), certified clear of the scene.

    ``pose`` asks for the tool frame's rotation too (a 3x3 or 4x4 matrix, a quaternion
    ``("wxyz", q)`` / ``("xyzw", q)``, or a ``scipy.spatial.transform.Rotation``; see
    :mod:`armpath.poses`), within ``angle_tolerance_deg``; ``tool_axis`` keeps only the tool's
    approach axis within ``axis_tolerance_deg`` of a direction. ``tolerance_mm``: the largest
    tool point error accepted (None: the scene's ``[tasks.reach] tolerance_mm``, else
    :data:`~armpath.tolerances.POINT_TOLERANCE_MM`). The result's ``doc`` holds
    the lower bound on the commands and why fewer were rejected; ``seed`` seeds the random
    parts of the search (sampling, planning around obstacles)."""
    from armpath.export import reach_result_dict
    from armpath.planning.reach import ReachOptions, plan_reach

    _checked(
        {"tolerance_mm": tolerance_mm, "angle_tolerance_deg": angle_tolerance_deg,
         "axis_tolerance_deg": axis_tolerance_deg, "time_limit_s": time_limit_s},
        {"seed": seed},
    )  # fmt: skip
    with time_limit(time_limit_s):
        the_arm, the_scene = arm_and_scene(arm, scene)
        with _placement_hint(arm, the_scene):
            target = _point_mm(target_mm, "target_mm")
            rule = _orientation(
                the_arm, pose, angle_tolerance_deg, tool_axis, axis_tolerance_deg, target
            )
            found = plan_reach(
                the_arm,
                the_scene.world,
                _start_ticks(the_arm, start_deg),
                target,
                ReachOptions(tolerance_mm=the_scene.tolerance_mm("reach", tolerance_mm)),
                seed=seed,
                orientation=rule,
            )
            doc = reach_result_dict(found, the_arm, the_scene)
    return _result(doc, the_arm, the_scene, found.sequence)


def plan(
    arm: ArmLike | None,
    *,
    to_deg: ArrayLike | None = None,
    to_mm: ArrayLike | None = None,
    scene: SceneLike | None = None,
    start_deg: ArrayLike | None = None,
    tolerance_mm: float = POINT_TOLERANCE_MM,
    pose: Any = None,
    angle_tolerance_deg: float | None = None,
    tool_axis: ArrayLike | None = None,
    axis_tolerance_deg: float | None = None,
    objective: str = "commands",
    energy_weights: ArrayLike | None = None,
    seed: int = 0,
    time_limit_s: float | None = None,
) -> Result:
    """Plan a clear motion to the joint values ``to_deg`` or to a point ``to_mm`` (one of
    them) from ``start_deg`` (default: home), around the scene's obstacles; ``objective``
    (``"commands"``, ``"path"``, ``"energy"``, that one with ``energy_weights`` per joint) is
    what is minimised once the goal is reached; ``seed`` seeds the random search. With
    ``to_mm``, ``pose`` or ``tool_axis`` rule the tool's rotation at the goal as for
    :func:`reach` (what ``armpath plan --to-xyz`` does: both call
    :func:`~armpath.planning.reach.plan_to_point`)."""
    from armpath.export import plan_result_dict
    from armpath.planning.choices import objective_of
    from armpath.planning.motion import MotionOptions, plan_motion
    from armpath.planning.reach import plan_to_point

    if (to_deg is None) == (to_mm is None):
        raise InvalidInputError("give exactly one goal: to_deg or to_mm")
    _checked(
        {"angle_tolerance_deg": angle_tolerance_deg,
         "axis_tolerance_deg": axis_tolerance_deg, "time_limit_s": time_limit_s},
        {"seed": seed},
        required={"tolerance_mm": tolerance_mm},
    )  # fmt: skip
    with time_limit(time_limit_s):
        the_arm, the_scene = arm_and_scene(arm, scene)
        with _placement_hint(arm, the_scene):
            weights = None
            if energy_weights is not None:
                w = np.asarray(_reals(energy_weights, "energy_weights"), dtype=np.float64)
                if w.shape != (the_arm.n_joints,):
                    raise InvalidInputError(
                        f"energy_weights needs one number per joint ({the_arm.n_joints}), "
                        f"got {w.size}"
                    )
                weights = tuple(float(v) for v in w)
            options = MotionOptions(
                objective=objective_of(objective), energy_weights=weights, seed=seed
            )
            start = _start_ticks(the_arm, start_deg)
            world = the_scene.world
            target, rule = None, None
            if to_mm is not None:
                target = _point_mm(to_mm, "to_mm")
                rule = _orientation(
                    the_arm, pose, angle_tolerance_deg, tool_axis, axis_tolerance_deg, target
                )
                found = plan_to_point(
                    the_arm,
                    world,
                    start,
                    target,
                    tolerance_mm,
                    options,
                    rule,
                )
            else:
                if pose is not None or tool_axis is not None:
                    raise InvalidInputError("pose and tool_axis go with to_mm")
                assert to_deg is not None  # one goal given (checked above)
                to = _joint_values(the_arm, to_deg, "to_deg")
                goal = the_arm.lattice.from_display(to, "to_deg")
                found = plan_motion(the_arm, world, start, goal[None, :], options)
            doc = plan_result_dict(
                found,
                the_arm,
                the_scene,
                options.objective.value,
                target,
                tolerance_mm if target is not None else None,
                rule,
            )
    return _result(doc, the_arm, the_scene, found.sequence)


def trace(
    arm: ArmLike | None,
    curve: Curve | ArrayLike | None = None,
    *,
    scene: SceneLike | None = None,
    start_deg: ArrayLike | None = None,
    tolerance_mm: float | None = None,
    closed: bool = False,
    tool_axis: str | ArrayLike | None = None,
    axis_tolerance_deg: float | None = None,
    seed: int = 0,
    bound: bool = True,
    bound_samples: int | None = None,
    scan_step_mm: float = 4.0,
    time_limit_s: float | None = None,
) -> Result:
    """Go along ``curve`` with the tool (a :class:`~armpath.geometry.curves.Curve`, or points
    ``(M, 3)`` mm joined by straight pieces, ``closed`` back to the first, as are points whose
    last repeats the first; default: the scene's ``[tasks.trace]`` curve) within
    ``tolerance_mm`` of it (None: the scene's ``[tasks.trace] tolerance_mm``, else
    :data:`~armpath.tolerances.TRACE_TOLERANCE_MM`), every reachable part, in the fewest
    passes and commands; the document lists the arcs not traced and why.
    ``tool_axis``: keep the tool's approach axis within ``axis_tolerance_deg`` (default 15)
    of the surface's inward normal at each point (``"normal"``, a torch kept near the normal)
    or of a world direction (x, y, z), along the whole continuous motion of every pass.
    ``bound``: also prove a lower bound on the commands of any plan (the document's
    ``lower_bound``, with the plan's gap to it; the seed's Task 2: about a third of its time);
    False: ``None`` there. ``bound_samples``: the live samples past which the bound's search
    stops splitting (1,000 to 2,000,000; None: 50,000; its first round may hold more; the
    search's rounds grow in proportion): more give a tighter bound, later. ``scan_step_mm``:
    how far apart the curve's reachability is scanned (a longer curve needs a larger one: at
    most 25,000 points)."""
    from armpath.export import trace_result_dict
    from armpath.geometry.curves import Curve, Polyline
    from armpath.planning.motion import MotionOptions
    from armpath.planning.trace import TraceOptions
    from armpath.tasks import trace_task

    _checked(
        {"tolerance_mm": tolerance_mm, "axis_tolerance_deg": axis_tolerance_deg,
         "time_limit_s": time_limit_s},
        {"seed": seed} | ({} if bound_samples is None else {"bound_samples": bound_samples}),
        {"closed": closed, "bound": bound},
        {"scan_step_mm": scan_step_mm},
    )  # fmt: skip
    rule = _axis_rule(tool_axis, axis_tolerance_deg)
    with time_limit(time_limit_s):
        the_arm, the_scene = arm_and_scene(arm, scene)
        with _placement_hint(arm, the_scene):
            path: Curve | None
            if curve is None or isinstance(curve, Curve):
                if closed:
                    raise InvalidInputError(
                        "closed goes with a curve given as points; a Curve says itself whether it "
                        "is closed"
                    )
                path = curve
            else:
                path = Polyline("curve", _points_mm(curve, "curve", 2), closed=closed)
            options = TraceOptions(
                tolerance_mm=the_scene.tolerance_mm("trace", tolerance_mm),
                scan_step_mm=scan_step_mm,
                motion=MotionOptions(seed=seed),
                axis_rule=rule,
                bound=bound,
                bound_samples=bound_samples,
            )
            found = trace_task(
                the_scene,
                the_arm,
                options,
                start_ticks=_start_ticks(the_arm, start_deg),
                curve=path,
            )
            doc = trace_result_dict(found, the_arm, the_scene)
    return _result(doc, the_arm, the_scene, found.sequence)


def spotweld(
    arm: ArmLike | None,
    welds_mm: ArrayLike | None = None,
    *,
    scene: SceneLike | None = None,
    start_deg: ArrayLike | None = None,
    order: str = "auto",
    return_to_start: bool = False,
    tolerance_mm: float | None = None,
    tool_axis: str | ArrayLike | None = None,
    axis_tolerance_deg: float | None = None,
    objective: str = "commands",
    seed: int = 0,
    bound: bool = True,
    bound_samples: int | None = None,
    pools: bool = True,
    time_limit_s: float | None = None,
) -> Result:
    """Visit the spot welds ``welds_mm (K, 3)`` (default: the scene's ``[tasks.spotweld]``)
    in the best order (``order="auto"``: every order ranked by its lower bound, the best
    planned; ``"given"``: as listed), optionally back to the start, the tool point within
    ``tolerance_mm`` of each (None: the scene's ``[tasks.spotweld] tolerance_mm``, else
    :data:`~armpath.tolerances.POINT_TOLERANCE_MM`). ``tool_axis``: at each
    weld, keep the tool's approach axis within ``axis_tolerance_deg`` (default 15) of the
    surface's inward normal there (``"normal"``) or of a world direction (x, y, z).
    ``bound``: also prove a lower bound on the commands of any tour, over every order and goal
    configuration (the document's ``lower_bound``; the seed's Task 3: about a third of its
    time); False: ``None`` there. ``bound_samples``: the live samples past which the bound's
    search stops splitting (1,000 to 2,000,000; None: 50,000; its first round may hold more;
    the search's rounds grow in proportion): more give a tighter bound, later. It is read only
    where the bound samples: a tour of at most 8 welds whose lattice
    goal states can all be listed, and their legs measured, is bounded over those states
    instead (Task 3: 117 with any ``bound_samples``). ``pools``: plan the cheapest orders
    once more through pools of goal states (Task 3: 121 commands rather than 126, in about
    twice the time without the bound);
    False: the guided orders' goal states only. ``objective``: ``"commands"``, or ``"path"``
    (the tool point's path, mm) or ``"energy"`` (weighted joint travel): each leg is planned
    for it and, of the tours planned, the one least in it is kept (the orders planned are
    still chosen by their bounds on commands)."""
    from armpath.export import tour_result_dict
    from armpath.planning.choices import objective_of
    from armpath.planning.motion import MotionOptions
    from armpath.tasks import spotweld_task

    _checked(
        {"tolerance_mm": tolerance_mm, "axis_tolerance_deg": axis_tolerance_deg,
         "time_limit_s": time_limit_s},
        {"seed": seed} | ({} if bound_samples is None else {"bound_samples": bound_samples}),
        {"return_to_start": return_to_start, "bound": bound, "pools": pools},
    )  # fmt: skip
    rule = _axis_rule(tool_axis, axis_tolerance_deg)
    options = MotionOptions(objective=objective_of(objective), seed=seed)
    with time_limit(time_limit_s):
        the_arm, the_scene = arm_and_scene(arm, scene)
        with _placement_hint(arm, the_scene):
            targets = None if welds_mm is None else _points_mm(welds_mm, "welds_mm", 1)
            found = spotweld_task(
                the_scene,
                the_arm,
                order,
                return_to_start,
                tolerance_mm,
                options,
                start_ticks=_start_ticks(the_arm, start_deg),
                targets_mm=targets,
                tool_axis=rule,
                bound=bound,
                bound_samples=bound_samples,
                pools=pools,
            )
            doc = tour_result_dict(found, the_arm, the_scene, options.objective.value)
    return _result(doc, the_arm, the_scene, found.sequence)


__all__ = [
    "ALONE_SCENE",
    "ArmLike",
    "SceneLike",
    "arm_and_scene",
    "default_scene",
    "forward_kinematics",
    "inverse_kinematics",
    "load_arm",
    "load_result",
    "load_scene",
    "plan",
    "reach",
    "spotweld",
    "trace",
]
