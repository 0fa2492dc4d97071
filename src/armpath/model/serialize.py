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
from armpath.model.lattice import DEFAULT_COMMAND_PERIOD_S
from armpath.model.serial_arm import Joint, JointKind, Landmark, Link, SerialArm

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
        return Joint(
            str(j["name"]),
            np.array(j["T_parent_joint"], dtype=np.float64),
            np.array(j["axis"], dtype=np.float64),
            JointKind(j["kind"]),
            (
                -np.inf if j["limits"][0] is None else float(j["limits"][0]),
                np.inf if j["limits"][1] is None else float(j["limits"][1]),
            ),
            float(j["tick"]),
            int(j["max_ticks"]),
            int(j.get("steps_per_tick", 1)),
        )

    def landmark(m: dict[str, Any]) -> Landmark:
        return Landmark(str(m["name"]), int(m["frame"]), tuple(m.get("offset", (0, 0, 0))))

    def link(k: dict[str, Any]) -> Link:
        return Link(
            str(k["name"]), int(k["start"]), int(k["end"]), float(k["radius"]), bool(k["checked"])
        )

    try:
        joints = parts("joints", "joint", joint)
        landmarks = parts("landmarks", "landmark", landmark)
        links = parts("links", "link", link)
        return SerialArm(
            name=str(doc["name"]),
            joints=joints,
            T_flange_tool=np.array(doc["T_flange_tool"], dtype=np.float64),
            landmarks=landmarks,
            links=links,
            home=np.array(doc["home"], dtype=np.float64),
            length_unit=str(doc["length_unit"]),
            T_world_base=np.array(doc["T_world_base"], dtype=np.float64),
            parameters=tuple((str(k), float(v)) for k, v in doc.get("parameters", [])),
            approach_axis=tuple(doc.get("approach_axis", (0.0, 0.0, 1.0))),
            command_period_s=float(doc.get("command_period_s", DEFAULT_COMMAND_PERIOD_S)),
        )
    except KeyError as exc:
        raise InvalidInputError(
            f"{what}: incomplete arm: {where[0]} has no {exc.args[0]!r}"
        ) from None
    except (TypeError, ValueError, IndexError) as exc:  # InvalidInputError is a ValueError
        raise InvalidInputError(f"{what}: malformed arm: {where[0]}: {exc}") from None


__all__ = ["ARM_DOCUMENT_VERSION", "arm_from_dict", "arm_to_dict"]
