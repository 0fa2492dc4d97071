"""Loading scene files (TOML or YAML) and the built-in seed scene."""

from __future__ import annotations

import tomllib
from collections.abc import Hashable
from importlib import resources
from pathlib import Path
from typing import Any, get_args

from pydantic import ValidationError

from armpath.errors import InvalidInputError, SceneError
from armpath.geometry import CollisionWorld
from armpath.scenes.build import build_obstacle
from armpath.scenes.scene import Scene
from armpath.scenes.schema import SceneFile


def scene_from_dict(
    data: dict[str, object], source: str = "<dict>", base_dir: Path | None = None
) -> Scene:
    """Validate a parsed scene file and build the scene (relative mesh paths from
    ``base_dir``)."""
    if not isinstance(data, dict):
        raise SceneError(f"scene {source}: the top level must be a table of keys")
    try:
        spec = SceneFile.model_validate(data)
    except ValidationError as exc:
        raise SceneError(f"scene {source}: {_schema_message(exc)}") from None
    try:
        obstacles = tuple(build_obstacle(o, base_dir) for o in spec.obstacles)
        world = CollisionWorld(
            obstacles,
            spec.clearance.margin_mm,
            spec.clearance.tool_tip_exempt_mm,
            spec.clearance.self_margin_mm,
        )
    except InvalidInputError as exc:
        raise SceneError(f"scene {source}: {exc}") from None
    reach = spec.tasks.reach.target_mm if spec.tasks.reach else None
    definition = spec.model_dump(mode="json")
    for o_spec, o in zip(definition["obstacles"], obstacles, strict=True):
        if o_spec["type"] == "mesh":
            o_spec["file"] = str(Path(getattr(o, "source", None) or o_spec["file"]).resolve())
    if spec.arm is not None and base_dir is not None:
        robot = Path(spec.arm.model)
        if not robot.is_absolute() and (base_dir / robot).is_file():
            definition["arm"]["model"] = str((base_dir / robot).resolve())
    scene = Scene(
        spec.name,
        spec.description,
        world,
        reach,
        source,
        spec.tasks.spotweld,
        spec.tasks.trace,
        definition,
        spec.arm,
        None if base_dir is None else str(base_dir),
        spec.tasks.reach.tolerance_mm if spec.tasks.reach else None,
    )
    if spec.arm is not None:
        from armpath.scenes.arm import scene_arm

        scene_arm(scene)  # validates the arm: model, base, tool, home within the limits
    if scene.spotweld is not None:
        scene.spotweld_targets_mm()  # validates the workpiece name and the points
    if scene.trace is not None:
        scene.trace_curve()  # validates the curve against the obstacles
    return scene


def _schema_message(exc: ValidationError) -> str:
    """The first thing wrong with a scene file, a key it does not know first (a misspelt key
    also leaves a required one missing: ``center_mm`` for ``center``), with the keys that table
    takes."""
    errors = exc.errors()
    unknown = [e for e in errors if e["type"] == "extra_forbidden"]
    first = unknown[0] if unknown else errors[0]
    loc = tuple(first["loc"])
    if first["type"] == "missing" and loc and isinstance(loc[-1], int):  # a short list
        where = ".".join(str(p) for p in loc[:-1])
        return f"{where}: too few values (value {loc[-1] + 1} is missing)"
    if first["type"] == "string_type":
        where = ".".join(str(p) for p in loc)
        return f"{where}: must be text in quotes, got {first.get('input')!r}"
    if first["type"] != "extra_forbidden":
        msg = str(first["msg"]).removeprefix("Value error, ")
        return f"{'.'.join(str(p) for p in loc)}: {msg}"
    table = ".".join(str(p) for p in loc[:-1]) or "the top level"
    keys = _keys_at(SceneFile, loc[:-1])
    takes = f" ({table} takes {', '.join(keys)})" if keys else ""
    return f"{table}: unknown key {loc[-1]!r}{takes}"


def _keys_at(model: object, loc: tuple[object, ...]) -> list[str] | None:
    """The keys of the table at ``loc`` (a validation error's location: field names, list
    indices, a tagged union's tag) in the schema ``model``; None when it cannot tell."""
    from pydantic import BaseModel

    def models_in(kind: object) -> list[type[BaseModel]]:
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            return [kind]
        return [m for arg in get_args(kind) for m in models_in(arg)]

    current: list[object] = [model]
    for part in loc:
        if isinstance(part, int):  # a list's item: the item type
            current = [arg for kind in current for arg in get_args(kind)] or current
            continue
        found: list[object] = []
        for m in (m for kind in current for m in models_in(kind)):
            if part in m.model_fields:
                found.append(m.model_fields[part].annotation)
            tag = m.model_fields.get("type")
            if tag is not None and part in get_args(tag.annotation):
                found.append(m)  # the tagged union's member
        if not found:
            return None
        current = found
    tables = [m for kind in current for m in models_in(kind)]
    return sorted(tables[0].model_fields) if len(tables) == 1 else None


def _one_line(exc: Exception) -> str:
    """A parser's message on one line (YAML's point at the error over several)."""
    return " ".join(str(exc).split())


def load_scene(path: str | Path | None = None) -> Scene:
    """Load a scene file (``.toml``, or ``.yaml``/``.yml``); ``None`` loads the seed scene."""
    base_dir = None
    suffix = ".toml"
    if path is None:
        text = resources.files("armpath.scenes").joinpath("seed.toml").read_text("utf-8")
        source = "built-in seed.toml"
    else:
        p = Path(path)
        suffix = p.suffix.lower()
        if suffix not in (".toml", ".yaml", ".yml"):
            raise SceneError(f"scene file {p} must end in .toml, .yaml or .yml")
        try:
            text = p.read_text("utf-8")
        except OSError as exc:
            raise SceneError(f"cannot read scene file {p}: {exc.strerror}") from None
        except UnicodeDecodeError as exc:
            raise SceneError(
                f"scene file {p} is not UTF-8 text (byte {exc.start}: {exc.reason})"
            ) from None
        source = str(p)
        base_dir = p.parent
    data: object
    if suffix == ".toml":
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"scene {source}: not valid TOML: {_one_line(exc)}") from None
    else:
        import yaml

        try:
            data = yaml.load(text, Loader=_unique_keys_loader())  # a SafeLoader
        except yaml.YAMLError as exc:
            raise SceneError(f"scene {source}: not valid YAML: {_one_line(exc)}") from None
    return scene_from_dict(data, source, base_dir)  # type: ignore[arg-type]


def _unique_keys_loader() -> type:
    """PyYAML's safe loader refusing a key written twice in one mapping (TOML refuses it; YAML
    would keep the last silently)."""
    import yaml

    class UniqueKeys(yaml.SafeLoader):  # type: ignore[misc]
        def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
            seen: set[object] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue  # '<<: *anchor': its keys may be overridden, as YAML means
                key = self.construct_object(key_node, deep=deep)
                if not isinstance(key, Hashable):
                    continue  # refused by the safe loader itself, naming it
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"key {key!r} written twice", key_node.start_mark
                    )
                seen.add(key)
            return dict(super().construct_mapping(node, deep=deep))

    return UniqueKeys


def seed_scene() -> Scene:
    """The built-in seed scene of SPEC section 3."""
    return load_scene(None)
