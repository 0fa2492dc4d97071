"""``armpath export`` (a result file's commands as a timed trajectory for a controller) and
``armpath schema`` (the JSON Schema of a result kind)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import typer

from armpath.cli.common import _cli_errors, _numbers, app, out_console

#: ``armpath export --format`` and ``armpath schema KIND``: the parser's choices (--help lists
#: them; another value is a usage error, exit status 2); the same as
#: :data:`armpath.controller_export.FORMATS` and :data:`armpath.schemas.RESULT_KINDS`
#: (``tests/test_cli.py`` checks), spelled out so that --help need not import them.
ExportFormat = Literal["csv", "joint-trajectory", "steps"]
ResultKind = Literal["reach", "plan", "trace", "spotweld"]


@app.command("export")
def export_result(
    result_file: Annotated[
        Path,
        typer.Argument(
            help="A result file (reach.json, trace.json, ... or --json output).", show_default=False
        ),
    ],
    fmt: Annotated[
        ExportFormat,
        typer.Option(
            "--format",
            help="csv: time and joint values (deg / mm); joint-trajectory: the ROS "
            "trajectory_msgs/JointTrajectory layout as JSON (rad); steps: motor steps per "
            "command.",
        ),
    ] = "csv",
    command_period: Annotated[
        float | None,
        typer.Option(
            "--command-period",
            help="Seconds per command (default: the model's command_period_s, 0.1 s unless set).",
            show_default=False,
        ),
    ] = None,
    steps_per_tick: Annotated[
        str | None,
        typer.Option(
            "--steps-per-tick",
            metavar="N|N1,…,Nn",
            help="Motor steps per tick: one number for every joint or one per joint (default: the "
            "model's steps_per_tick, 1 unless set).",
            show_default=False,
        ),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Write to this file (default: print).", show_default=False),
    ] = None,
) -> None:
    """Convert a result's commands into a timed trajectory: the state after command k is
    reached at k times the command period, each command moving the joints linearly."""
    from armpath.api import load_scene
    from armpath.controller_export import FORMATS
    from armpath.errors import InvalidInputError
    from armpath.export import output_folder
    from armpath.results import load_result

    with _cli_errors():
        if fmt not in FORMATS:
            raise InvalidInputError(f"--format must be one of {', '.join(FORMATS)}, got {fmt!r}")
        # the commands and the model are what an export needs: the result's scene is not
        # looked for (a result planned in a scene file not found here exports all the same)
        result = load_result(result_file, load_scene("none"))
        steps: list[float] | None = None
        if steps_per_tick is not None:
            words = steps_per_tick.replace(",", " ").split()
            count = 1 if len(words) == 1 else result.arm.n_joints
            steps = _numbers(words, count, "--steps-per-tick") * (result.arm.n_joints // count)
        text = result.export_text(fmt, command_period, steps)
        if out is None:
            typer.echo(text, nl=False)
            return
        target = out.expanduser()
        with output_folder(target.parent, prune=False) as folder:
            folder.write_text(target.name, text)
        out_console.print(f"wrote {target}", markup=False)


@app.command("schema")
def schema(
    kind: Annotated[
        ResultKind,
        typer.Argument(help="The result kind: reach, plan, trace or spotweld.", show_default=False),
    ],
) -> None:
    """Print the JSON Schema (draft 2020-12) of a result kind's documents: every field, its type
    and unit. Results carry the schema_version it describes."""
    import json

    from armpath.schemas import result_schema

    with _cli_errors():
        typer.echo(json.dumps(result_schema(kind), indent=2, ensure_ascii=False))
