"""``armpath model show`` and ``armpath model convert``: look at a model, write it as a URDF or
as armpath's model document."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import typer
from rich.markup import escape
from rich.table import Table

from armpath.cli.common import TipLinkOption, _cli_errors, _to_display, app, out_console
from armpath.kinematics import last_axis_across_approach
from armpath.model.catalog import BUILTIN_MODELS

model_app = typer.Typer(
    help="Look at an arm model and convert it (URDF, armpath's JSON model document)."
)
app.add_typer(model_app, name="model")


@model_app.callback(invoke_without_command=True)
def _model_help(ctx: typer.Context) -> None:
    if ctx.invoked_subcommand is None:  # plain `armpath model`: its help, not an error
        typer.echo(ctx.get_help())
        raise typer.Exit(0)


ModelArgument = Annotated[
    str,
    typer.Argument(
        help=f"A built-in model ({', '.join(BUILTIN_MODELS)}) or a robot file (.json, .urdf).",
        show_default=False,
    ),
]
#: The formats ``model convert`` writes.
CONVERT_FORMATS = ("urdf", "json", "dh", "mdh")
#: ``--to`` of ``armpath model convert``: the parser's choices (--help lists them; another is a
#: usage error), :data:`CONVERT_FORMATS` spelled out (``tests/test_cli.py`` checks).
ConvertFormat = Literal["urdf", "json", "dh", "mdh"]
CONVENTION_OF = {"dh": "standard", "mdh": "modified"}


@model_app.command("show")
def show(
    model: Annotated[
        str | None,
        typer.Argument(
            help=f"A built-in model ({', '.join(BUILTIN_MODELS)}) or a robot file (.json, "
            ".urdf). Default: the arm of --scene.",
            show_default=False,
        ),
    ] = None,
    tip_link: TipLinkOption = None,
    scene_file: Annotated[
        Path | None,
        typer.Option(
            "--scene",
            help="Show the arm as this scene file's [arm] builds it (its base, tool, home and "
            "lattice); with MODEL, that model on the scene's base, as the tasks take it.",
        ),
    ] = None,
    json_out: Annotated[bool, typer.Option("--json", help="Print the model document.")] = False,
) -> None:
    """The model's joints (placement, axis, limits, command lattice), tool and base."""
    from armpath.errors import InvalidInputError
    from armpath.export import json_text
    from armpath.model.catalog import resolve_model
    from armpath.model.serialize import arm_to_dict

    with _cli_errors():
        if scene_file is not None:
            from armpath.scenes import load_scene
            from armpath.scenes.arm import scene_arm

            arm = scene_arm(load_scene(scene_file), model, tip_link)
        elif model is None:
            raise InvalidInputError("give a model (a built-in name or a robot file) or --scene")
        else:
            arm = resolve_model(model, tip_link)
        if json_out:
            typer.echo(json_text(arm_to_dict(arm)), nl=False)
            return
        units = arm.lattice.units
        table = Table(
            title=escape(f"{arm.name}: {arm.n_joints} joints, lengths in {arm.length_unit}")
        )
        for col in ("joint", "kind", "axis", "limits", "tick", "max ticks"):
            table.add_column(col)
        shown_limits = _to_display(arm, np.vstack([arm.lower, arm.upper]))
        for i, j in enumerate(arm.joints):
            lo, hi = shown_limits[:, i]
            unlimited = not (np.isfinite(lo) or np.isfinite(hi))
            table.add_row(
                j.name,
                j.kind.value,
                " ".join(f"{v:g}" for v in j.axis),
                "none" if unlimited else f"{lo:g} … {hi:g} {units[i]}",
                f"{arm.lattice.tick_display[i]:g} {units[i]}",
                str(int(arm.lattice.max_ticks[i])),
            )
        out_console.print(table)
        tool = np.asarray(arm.T_flange_tool)  # from the last joint's frame
        flange = np.asarray(arm.T_joint_flange)
        from_flange = np.linalg.solve(flange, tool)[:3, 3] + 0.0  # + 0.0: no "-0"
        where = f"{' '.join(f'{v:.6g}' for v in from_flange)} {arm.length_unit} from the flange"
        if not np.allclose(flange, np.eye(4)):  # a URDF's tip link, a file's flange offset
            where += (
                f" ({' '.join(f'{v + 0.0:.6g}' for v in tool[:3, 3])} {arm.length_unit} from "
                "the last joint's frame; a scene's [arm] tool is given from the flange)"
            )
        turn = last_axis_across_approach(arm)
        across = ""
        if turn is not None:
            # a URDF tip frame whose x is the flange's normal: a tool along its z sits across
            about = " ".join(f"{v + 0.0:.6g}" for v in np.round(turn, 9))
            across = (
                f"; the last joint turns about {about} of it (a tool or --tool-axis along z "
                "lies across that axis)"
            )
        out_console.print(
            f"tool: {where}, approach axis {' '.join(f'{v:g}' for v in arm.approach_axis)} "
            f"(tool frame{across})",
            markup=False,
        )
        base = np.asarray(arm.T_world_base)
        out_console.print(
            f"base at {' '.join(f'{v:g}' for v in base[:3, 3])} {arm.length_unit}; home "
            f"{' '.join(f'{v:g}' for v in _to_display(arm, arm.home))} ({', '.join(units)})",
            markup=False,
        )
        below = [-lm.offset[2] for lm in arm.landmarks if lm.frame == 0 and lm.offset[2] < 0]
        if below:  # a column under the base frame (the PUMA 560's D-H base is its shoulder)
            out_console.print(
                f"the base frame stands {max(below):g} {arm.length_unit} above the arm's foot "
                "(a base column; a scene's [arm] base places the base frame, not the foot)",
                markup=False,
            )


@model_app.command("convert")
def convert(
    model: ModelArgument,
    to: Annotated[
        ConvertFormat,
        typer.Option(
            "--to",
            help="urdf (chain, limits and tool; metres), dh or mdh (a JSON robot file: the "
            "standard or modified D-H table with base and tool transforms, mm and rad) or json "
            "(armpath's model document: also the command lattice, home pose and link radii).",
            show_default=False,
        ),
    ],
    out: Annotated[Path, typer.Option("--out", help="The file to write.", show_default=False)],
    tip_link: TipLinkOption = None,
) -> None:
    """Write the model as a URDF, a D-H or modified D-H robot file, or armpath's model document;
    each loads back with the same forward kinematics (--model FILE; a URDF with --tip-link
    tool)."""
    from armpath.errors import InvalidInputError
    from armpath.export import output_folder
    from armpath.model.catalog import resolve_model
    from armpath.model.dh_export import dh_document
    from armpath.model.serialize import arm_to_dict
    from armpath.model.urdf_export import arm_to_urdf

    with _cli_errors():
        if to not in CONVERT_FORMATS:
            raise InvalidInputError(f"--to must be one of {', '.join(CONVERT_FORMATS)}, got {to!r}")
        wanted = ".urdf" if to == "urdf" else ".json"
        if out.suffix.lower() != wanted:
            raise InvalidInputError(f"--out must end in {wanted} for --to {to}, got {out.name!r}")
        arm = resolve_model(model, tip_link)
        if to == "urdf":
            text = arm_to_urdf(arm)
        else:  # a model keeps every digit (results round theirs)
            doc = arm_to_dict(arm) if to == "json" else dh_document(arm, CONVENTION_OF[to])
            text = json.dumps(doc, indent=2, allow_nan=False) + "\n"
        target = out.expanduser()
        with output_folder(target.parent, prune=False) as folder:
            folder.write_text(target.name, text)
        out_console.print(f"wrote {target}", markup=False)
