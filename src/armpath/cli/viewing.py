"""``armpath view`` and ``armpath animate``: the 3D viewer, HTML replays and animations."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer

from armpath.cli.common import (
    TipLinkOption,
    _cli_errors,
    app,
    err_console,
    out_console,
    progress,
    task_setup,
)
from armpath.errors import InvalidInputError

if TYPE_CHECKING:
    from armpath.model.serial_arm import SerialArm
    from armpath.results import Result
    from armpath.scenes import Scene


def _standing(arm: SerialArm, scene: Scene) -> Result:
    """A result of no commands: the arm standing at its home pose in its scene."""
    from armpath.commands import CommandSequence
    from armpath.results import Result

    start = arm.lattice.to_ticks(arm.home, "the arm's home pose")
    sequence = CommandSequence(start, np.zeros((0, arm.n_joints), dtype=np.int64), arm.lattice)
    doc = {"task": "plan", "model": {"name": arm.name}, "scene": {"name": scene.name}}
    return Result(
        "plan", doc, arm, scene, sequence, np.zeros((0, 3)), None, Path(f"{arm.name}.json")
    )


@app.command()
def view(
    model: Annotated[
        str | None,
        typer.Option(
            "--model",
            help="The arm: a built-in model or a robot file. Default: the scene's \\[arm], else "
            "the seed arm.",
            show_default=False,
        ),
    ] = None,
    tip_link: TipLinkOption = None,
    scene_file: Annotated[
        Path | None,
        typer.Option(
            "--scene",
            help="Scene file (TOML or YAML). Default: with --result, the scene the result "
            "carries; else the seed scene, or with another --model no scene (the arm alone).",
        ),
    ] = None,
    result: Annotated[
        Path | None,
        typer.Option(
            "--result",
            help="A result JSON (reach, trace, spotweld, plan) to replay; its model and scene "
            "come with it.",
        ),
    ] = None,
    host: Annotated[str, typer.Option(help="Address to serve on.")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="Port to serve on.")] = 8080,
    export_html: Annotated[
        Path | None,
        typer.Option(
            "--export-html",
            help="Write a self-contained HTML replay of --result (or, without it, the arm in "
            "its scene) to this file and exit (opens offline in any browser).",
        ),
    ] = None,
    fps: Annotated[
        float, typer.Option(help="Commands per second in the HTML replay (0.01 to 1000).")
    ] = 15.0,
) -> None:
    """Interactive 3D viewer in the browser: the arm in its scene, a slider per joint (0.1
    steps within the limits), live fingertip position and clearance (collisions in red), a
    target point to plan a reach to, and the replay of a result (play, pause, step,
    timeline)."""
    from armpath.export import output_folder
    from armpath.results import load_result

    with _cli_errors():
        if export_html is None:  # where to serve, before any work
            if not (0 < port < 65536):
                raise InvalidInputError(f"--port must be in 1..65535, got {port}")
            from armpath.viewer.app import check_address

            check_address(host, port)
        else:
            from armpath.viewer.app import check_replay_fps

            check_replay_fps(fps, "--fps")
        loaded = load_result(result, scene_file) if result is not None else None
        if export_html is not None:
            if loaded is None:  # the arm alone (or in its scene), at its home pose
                arm, scene = task_setup(model, scene_file, None, None, tip_link)
                loaded = _standing(arm, scene)
            if export_html.suffix.lower() not in (".html", ".htm"):
                raise InvalidInputError(f"--export-html must end in .html, got {export_html.name}")
            from armpath.viewer.app import replay_html

            notes: list[str] = []
            with err_console.status("recording the replay ..."):
                page = replay_html(loaded, fps=fps, notes=notes)
            for note in notes:
                err_console.print(f"warning: {note}", markup=False, soft_wrap=True)
            with output_folder(export_html.parent, prune=False) as folder:
                folder.write_text(export_html.name, page)
            out_console.print(f"wrote {export_html}", markup=False)
            return
        from armpath.viewer.app import ArmViewer

        if loaded is not None:
            arm, scene = loaded.arm, loaded.scene
        else:
            arm, scene = task_setup(model, scene_file, None, None, tip_link)
        viewer = ArmViewer(arm, scene, host=host, port=port, result=loaded)
        for note in viewer.notes:
            err_console.print(f"warning: {note}", markup=False, soft_wrap=True)
        out_console.print(
            f"armpath viewer on http://{host}:{viewer.server.get_port()} (Ctrl-C to stop)",
            markup=False,
        )
        try:
            while True:
                time.sleep(3600)
        except KeyboardInterrupt:
            viewer.stop()


@app.command()
def animate(
    result: Annotated[Path, typer.Argument(help="A result JSON (reach, trace, spotweld, plan).")],
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="GIF or MP4 file to write. Default: the result's name, .gif (a file there, "
            "such as the GIF a run wrote, is replaced, and the output says so).",
        ),
    ] = None,
    scene_file: Annotated[
        Path | None,
        typer.Option(
            "--scene",
            help="Scene file (TOML or YAML) to show the motion in. Default: the scene the "
            "result carries.",
        ),
    ] = None,
    fps: Annotated[
        int, typer.Option(help="Frames per second (at most 50 for a GIF, 120 for an MP4).")
    ] = 15,
    frames: Annotated[int, typer.Option(help="Largest number of frames (at most 1000).")] = 120,
) -> None:
    """Animate a result: the arm through its commands in the scene, the fingertip's path, the
    targets and the curve (GIF with Pillow, MP4 with ffmpeg)."""
    from armpath.export import output_folder
    from armpath.results import load_result
    from armpath.viz.animation import ANIMATION_FORMATS, check_animation_rate, write_animation

    with _cli_errors():
        target = out if out is not None else result.with_suffix(".gif")
        if target.suffix in ANIMATION_FORMATS:  # (else write_animation names the formats)
            check_animation_rate(target.suffix, fps, frames, ("--fps", "--frames"))
        loaded = load_result(result, scene_file)
        replaced = target.exists()
        with output_folder(target.parent, prune=False) as folder, progress("animating ..."):
            n = write_animation(
                folder.file(target.name), loaded.animation(), fps=fps, max_frames=frames
            )
        note = ", replacing the file that was there" if replaced else ""
        out_console.print(f"wrote {target} ({n} frames{note})", markup=False)
