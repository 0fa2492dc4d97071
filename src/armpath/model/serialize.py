"""A whole arm as plain JSON types, and back: what result files carry so that any arm's result
replays anywhere, with the same forward kinematics, collision links and command lattice.

The document lists the chain as armpath holds it (every joint's fixed transform, axis, kind,
limits, tick and command limit; the tool and base transforms; the landmarks and links with their
radii; the home pose), in the model's own units: lengths in ``length_unit``, angles rad. It is
exact: :func:`arm_from_dict` of :func:`arm_to_dict` gives an arm with the same numbers.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from armpath.errors import InvalidInputError
from armpath.model.lattice import DEFAULT_COMMAND_PERIOD_S, MM_PER_LENGTH_UNIT
from armpath.model.serial_arm import Joint, JointKind, Landmark, Link, SerialArm, check_length

T = TypeVar("T")

#: Version of the document layout below.
ARM_DOCUMENT_VERSION = 1


def _limit(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def arm_to_dict(arm: SerialArm) -> dict[str, Any]:
    """The arm as plain JSON types (lengths in its unit, angles rad; unlimited bounds null)."""
    return {
        "version": ARM_DOCUMENT_VERSION,
        "name": arm.name,
        "length_unit": arm.length_unit,
        "joints": [
            {
                "name": j.name,
                "T_parent_joint": np.asarray(j.T_parent_joint).tolist(),
                "axis": np.asarray(j.axis).tolist(),
                "kind": j.kind.value,
                "limits": [_limit(j.limits[0]), _limit(j.limits[1])],
                "tick": float(arm.lattice.tick[i]),
                "max_ticks": int(arm.lattice.max_ticks[i]),
                "steps_per_tick": int(j.steps_per_tick),
            }
            for i, j in enumerate(arm.joints)
        ],
        "T_flange_tool": np.asarray(arm.T_flange_tool).tolist(),
        "T_joint_flange": np.asarray(arm.T_joint_flange).tolist(),
        "T_world_base": np.asarray(arm.T_world_base).tolist(),
        "landmarks": [
            {"name": lm.name, "frame": lm.frame, "offset": list(lm.offset)} for lm in arm.landmarks
        ],
        "links": [
            {
                "name": lk.name,
                "start": lk.start,
                "end": lk.end,
                "radius": float(lk.radius),
                "checked": bool(lk.checked),
            }
            for lk in arm.links
        ],
        "home": np.asarray(arm.home).tolist(),
        "parameters": [[k, float(v)] for k, v in arm.parameters],
        "approach_axis": list(arm.approach_axis),
        "command_period_s": float(arm.command_period_s),
    }


def _text(item: dict[str, Any], key: str) -> str:
    value = item[key]
    if not isinstance(value, str):
        raise ValueError(f"{key} must be text, got {value!r}")
    return value


def _number(item: dict[str, Any], key: str) -> float:
    return _as_number(item[key], key)


def _as_number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{what} must be a number, got {value!r}")
    return float(value)


#: Largest whole number a model document's field may hold (ticks a command, steps a tick,
#: frame and landmark indices).
_MAX_WHOLE = 2**31 - 1


def _whole(item: dict[str, Any], key: str) -> int:
    value = item[key]
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not -_MAX_WHOLE <= value <= _MAX_WHOLE  # also refuses inf and nan
        or value != int(value)
    ):
        raise ValueError(f"{key} must be a whole number of at most {_MAX_WHOLE:,}, got {value!r}")
    return int(value)


def _numbers(item: dict[str, Any], key: str, shape: tuple[int, ...]) -> np.ndarray:
    """``item[key]`` as numbers of ``shape`` (a 4x4 transform, a 3-vector), named when not."""
    value = item[key]
    size = " x ".join(str(n) for n in shape)
    wrong = ValueError(f"{key} must be {size} numbers, got {value!r}"[:200])
    try:
        given = np.asarray(value)
    except (TypeError, ValueError):  # rows of different lengths
        raise wrong from None
    if given.shape != shape or given.dtype.kind not in "iuf":  # not text, true or null
        raise wrong
    return np.asarray(given, dtype=np.float64)


def _lengths(values: np.ndarray, key: str, unit: str) -> np.ndarray:
    """``values`` (lengths in ``unit``: a translation, an offset), each within the largest
    length a model may use."""
    for k, v in enumerate(values.ravel().tolist()):
        check_length(v, key if values.size == 1 else f"{key}[{k}]", unit)
    return values


def _placement(item: dict[str, Any], key: str, unit: str) -> np.ndarray:
    """``item[key]``, a 4x4 transform whose translation (``unit``) is within the largest length
    a model may use (its rigidity is :class:`SerialArm`'s to check)."""
    T = _numbers(item, key, (4, 4))
    for k, axis in enumerate("xyz"):
        check_length(float(T[k, 3]), f"{key} translation {axis}", unit)
    return T


def _limits(j: dict[str, Any]) -> tuple[float, float]:
    """A joint's ``[lower, upper]``, null for an open side."""
    value = j["limits"]
    if not (isinstance(value, list) and len(value) == 2):
        raise ValueError(f"limits must be [lower, upper] (null for an open side), got {value!r}")
    lower, upper = value
    return (
        -np.inf if lower is None else _as_number(lower, "limits"),
        np.inf if upper is None else _as_number(upper, "limits"),
    )


def arm_from_dict(doc: dict[str, Any], what: str = "model") -> SerialArm:
    """The arm of an :func:`arm_to_dict` document; :class:`InvalidInputError` names what is
    wrong."""
    if not isinstance(doc, dict):
        raise InvalidInputError(f"{what}: expected a table of keys")
    version = doc.get("version")
    if version != ARM_DOCUMENT_VERSION:
        raise InvalidInputError(
            f"{what}: document version {version!r}, this armpath reads {ARM_DOCUMENT_VERSION}"
        )
    where = ["the document"]  # the part being read, for the message

    def parts(key: str, part: str, build: Callable[[dict[str, Any]], T]) -> tuple[T, ...]:
        """``build`` of each table of the list ``doc[key]``, ``where`` naming it meanwhile."""
        items = doc[key]
        if not isinstance(items, list):
            raise TypeError(f"{key} must be a list, got {type(items).__name__}")
        out = []
        for i, item in enumerate(items):
            where[0] = f"{part} {i + 1}"
            if not isinstance(item, dict):
                raise TypeError(f"expected a table of keys, got {type(item).__name__}")
            out.append(build(item))
        where[0] = "the document"
        return tuple(out)

    def joint(j: dict[str, Any]) -> Joint:
        name = _text(j, "name")
        T_parent_joint = _placement(j, "T_parent_joint", unit)
        axis = _numbers(j, "axis", (3,))
        kind = j["kind"]
        if kind not in [k.value for k in JointKind]:
            raise ValueError(f"kind must be 'revolute' or 'prismatic', got {kind!r}")
        limits = _limits(j)
        if kind == JointKind.PRISMATIC.value:  # lengths, as the translations
            for side, v in zip(("lower", "upper"), limits, strict=True):
                if np.isfinite(v):
                    check_length(v, f"limits ({side})", unit)
        return Joint(
            name,
            T_parent_joint,
            axis,
            JointKind(kind),
            limits,
            None if j["tick"] is None else _number(j, "tick"),
            _whole(j, "max_ticks"),
            _whole(j, "steps_per_tick") if "steps_per_tick" in j else 1,
        )

    def landmark(m: dict[str, Any]) -> Landmark:
        offset = (
            _lengths(_numbers(m, "offset", (3,)), "offset", unit) if "offset" in m else np.zeros(3)
        )
        return Landmark(_text(m, "name"), _whole(m, "frame"), tuple(offset.tolist()))

    def link(k: dict[str, Any]) -> Link:
        checked = k["checked"]
        if not isinstance(checked, bool):
            raise ValueError(f"checked must be true or false, got {checked!r}")
        return Link(
            _text(k, "name"),
            _whole(k, "start"),
            _whole(k, "end"),
            check_length(_number(k, "radius"), "radius", unit),
            checked,
        )

    try:
        unit = _text(doc, "length_unit")  # of every length below
        if unit not in MM_PER_LENGTH_UNIT:
            raise ValueError(f"length_unit must be 'mm' or 'm', got {unit!r}")
        joints = parts("joints", "joint", joint)
        if not joints:
            raise ValueError("joints is empty: a serial arm needs at least one joint")
        landmarks = parts("landmarks", "landmark", landmark)
        links = parts("links", "link", link)
        parameters = doc.get("parameters", [])
        if not isinstance(parameters, list) or not all(
            isinstance(p, list) and len(p) == 2 and isinstance(p[0], str) for p in parameters
        ):
            raise ValueError(
                f"parameters must be a list of [name, number] pairs, got {parameters!r}"
            )
        home = _numbers(doc, "home", (len(joints),))
        prismatic = np.array([j.kind is JointKind.PRISMATIC for j in joints])
        _lengths(home[prismatic], "home (a prismatic joint's)", unit)
        return SerialArm(
            name=_text(doc, "name"),
            joints=joints,
            T_flange_tool=_placement(doc, "T_flange_tool", unit),
            T_joint_flange=(
                _placement(doc, "T_joint_flange", unit) if "T_joint_flange" in doc else np.eye(4)
            ),
            landmarks=landmarks,
            links=links,
            home=home,
            length_unit=unit,
            T_world_base=_placement(doc, "T_world_base", unit),
            parameters=tuple((k, _as_number(v, k)) for k, v in parameters),
            approach_axis=tuple(
                _numbers(doc, "approach_axis", (3,)).tolist()
                if "approach_axis" in doc
                else (0.0, 0.0, 1.0)
            ),
            command_period_s=(
                _number(doc, "command_period_s")
                if "command_period_s" in doc
                else DEFAULT_COMMAND_PERIOD_S
            ),
        )
    except KeyError as exc:
        raise InvalidInputError(
            f"{what}: incomplete arm: {where[0]} has no {exc.args[0]!r}"
        ) from None
    except (TypeError, ValueError, IndexError) as exc:  # InvalidInputError is a ValueError
        raise InvalidInputError(f"{what}: malformed arm: {where[0]}: {exc}") from None


__all__ = ["ARM_DOCUMENT_VERSION", "arm_from_dict", "arm_to_dict"]
