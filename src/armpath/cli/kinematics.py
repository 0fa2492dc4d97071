"""``armpath fk`` and ``armpath ik``: forward and inverse kinematics of any model."""

from __future__ import annotations

import json
from typing import Annotated, Literal

import numpy as np
import typer
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from armpath.budget import MAX_IK_SEEDS
from armpath.cli.common import (
    LOOSE,
    JsonOption,
    ModelOption,
    TipLinkOption,
    _cli_errors,
    _fmt,
    _from_display,
    _joint_units,
    _numbers,
    _point_mm,
    _to_display,
    _units_text,
    app,
    err_console,
    out_console,
)
from armpath.errors import InvalidInputError


@app.command(context_settings=LOOSE)
def fk(
    angles: Annotated[
        list[str],
        typer.Argument(
            help="Joint values: deg for revolute joints, mm for prismatic ones",
            show_default=False,
            metavar="q1 … qn",
        ),
    ],
    model: ModelOption = "seed",
    tip_link: TipLinkOption = None,
    json_out: Annotated[bool, typer.Option("--json", help="Print JSON on stdout.")] = False,
) -> None:
    """Forward kinematics: the arm's joint points and the tool pose (mm, deg).

    For the seed arm the points are A–E and the fingertip; for other models the joint frame
    origins, the corners where a link bends on its way to a frame (that frame's name primed:
    elbow' lies between shoulder and elbow), and the tool frame (4x4 pose, row-major).
    """
    from armpath.export import fk_document, json_line
    from armpath.model.catalog import resolve_model

    with _cli_errors():
        arm = resolve_model(model, tip_link)
        units = _joint_units(arm)
        what = f"joint values q1 … q{arm.n_joints} ({', '.join(units)})"
        q = _from_display(arm, _numbers(angles, arm.n_joints, what))
        doc = fk_document(arm, q)
        if json_out:
            typer.echo(json_line(doc))
        else:
            shown = _fmt(_to_display(arm, q), 1)
            table = Table(title=escape(f"{arm.name}, q = {shown} {_units_text(units)}"))
            for col in ("point", "x [mm]", "y [mm]", "z [mm]"):
                table.add_column(escape(col), justify="right")
            for n, p in doc["points"].items():
                table.add_row(n, *(f"{c:.4f}" for c in p))
            if arm.name == "seed":
                table.add_row("tip", *(f"{c:.4f}" for c in doc["tip"]))
            out_console.print(table)
            if arm.name != "seed":
                rows = "\n".join("  " + "  ".join(f"{c:11.6f}" for c in r) for r in doc["pose"])
                out_console.print(f"tool pose (rotation | position mm):\n{rows}")
        for w in doc["warnings"]:
            err_console.print(f"warning: {w}", markup=False, soft_wrap=True)


def _pose_argument(text: str) -> np.ndarray:
    values = _numbers(text.replace(",", " ").split(), 16, "--pose (row-major 4x4)")
    T = np.array(values).reshape(4, 4)
    if not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0], atol=1e-9):
        raise InvalidInputError(f"--pose: the last row must be 0 0 0 1, got {T[3].tolist()}")
    R = T[:3, :3]
    err = float(np.abs(R @ R.T - np.eye(3)).max())
    if err > 1e-4 or np.linalg.det(R) < 0:
        raise InvalidInputError(
            f"--pose: the upper-left 3x3 block is not a rotation (|R R^T - I| = {err:.2g})"
        )
    U, _, Vt = np.linalg.svd(R)
    T[:3, :3] = U @ Vt  # nearest rotation: poses are often printed to a few digits
    return T


#: ``armpath ik --method``: the parser's choices, so --help lists them and another value is a
#: usage error (exit status 2); the same as :data:`armpath.ik.solve.METHODS`
#: (``tests/test_cli.py`` checks), spelled out so that --help need not import the solvers.
IkMethod = Literal["auto", "spherical-wrist", "three-parallel", "general", "numerical"]


@app.command(context_settings=LOOSE)
def ik(
    model: ModelOption = "seed",
    tip_link: TipLinkOption = None,
    pose: Annotated[
        str | None,
        typer.Option(help="Target tool pose: 16 numbers, row-major 4x4, lengths mm."),
    ] = None,
    xyz: Annotated[
        tuple[float, float, float] | None,
        typer.Option(help="Target tool position only, mm (numerical solver)."),
    ] = None,
    method: Annotated[
        IkMethod,
        typer.Option(
            help="auto, spherical-wrist, three-parallel, general (Raghavan-Roth) or numerical "
            "(--xyz: auto or numerical)."
        ),
    ] = "auto",
    seeds: Annotated[
        int, typer.Option(help=f"Seeds of the numerical solver (1 to {MAX_IK_SEEDS:,}).")
    ] = 48,
    near: Annotated[
        str | None,
        typer.Option(
            help="A joint state (deg, mm for prismatic joints; one value per joint): the "
            "numerical search starts there and solutions are listed nearest to it first."
        ),
    ] = None,
    json_out: JsonOption = False,
) -> None:
    """Inverse kinematics: every solution for a tool pose (or position), deg / mm.

    Complete methods return every real solution: closed form for arms with a spherical wrist
    or three parallel axes (UR type), Raghavan-Roth elimination for any other 6R arm. Each
    solution carries its forward-kinematics residual. An arm with more joints than the target
    constrains (7 axes and a pose, or any --xyz goal of a 6-axis arm) has a continuous family
    of solutions: the output says so and lists samples of it (--near picks the part of the
    family nearest a state). Exit status 1 if there is no solution; solutions outside the
    joint limits are listed, marked off limits, and count as solutions.
    """
    from armpath.export import ik_document
    from armpath.ik import solve_ik
    from armpath.ik.solve import METHODS as IK_METHODS
    from armpath.model.catalog import resolve_model

    with _cli_errors():
        if (pose is None) == (xyz is None):
            raise InvalidInputError("give exactly one target: --pose '16 numbers' or --xyz X Y Z")
        if method not in IK_METHODS:
            raise InvalidInputError(
                f"--method must be one of {', '.join(IK_METHODS)}, got {method!r}"
            )
        if xyz is not None and method not in ("auto", "numerical"):
            raise InvalidInputError(
                f"--method {method} solves full poses (--pose); a position (--xyz) is solved by "
                "the numerical method (--method auto or numerical)"
            )
        if not 1 <= seeds <= MAX_IK_SEEDS:
            raise InvalidInputError(f"--seeds must be in [1, {MAX_IK_SEEDS}], got {seeds}")
        arm = resolve_model(model, tip_link)
        near_q = None
        if near is not None:
            words = near.replace(",", " ").split()
            near_q = _from_display(
                arm, _numbers(words, arm.n_joints, f"--near ({arm.n_joints} joint values)")
            )
        if pose is not None:
            target = _pose_argument(pose)
            result = solve_ik(arm, target, method=method, seeds=seeds, near=near_q)
        else:
            assert xyz is not None
            target = np.array(_point_mm([str(v) for v in xyz], "--xyz"))
            result = solve_ik(arm, target, position_only=True, seeds=seeds, near=near_q)
        units = _joint_units(arm)
        doc = ik_document(arm, result, target, pose is not None)
        if json_out:
            typer.echo(json.dumps(doc))
        elif result.count:  # no solution: the error line alone
            if result.family_dimension:
                found = (
                    f"{result.count} sample(s) of a {result.family_dimension}-dimensional family "
                    "of solutions" + (", nearest --near first" if near_q is not None else "")
                )
            else:
                found = f"{result.count} solution(s)"
            table = Table(
                title=escape(
                    f"{arm.name}: {found}, {result.method}; joint values {_units_text(units)}"
                ),
                box=box.SIMPLE_HEAD,
            )
            table.add_column("#", justify="right")
            for i in range(arm.n_joints):
                table.add_column(f"q{i + 1}", justify="right")
            table.add_column("resid. mm", justify="right")
            table.add_column("notes")
            inside = doc["within_limits"]
            for k, s in enumerate(doc["solutions"]):
                notes = []
                if inside and not inside[k]:
                    notes.append("off limits")
                if doc["near_double"][k]:
                    notes.append("near-double")
                if doc["near_singular"][k]:
                    notes.append("near-singular")
                table.add_row(
                    str(k + 1),
                    *(f"{v:.4f}" for v in s),
                    f"{doc['residuals'][k]['position_mm']:.0e}",
                    ", ".join(notes),
                )
            Console(highlight=False, width=max(out_console.width, 120)).print(table)
        if result.count == 0:
            raise InvalidInputError(f"no solution ({result.method}): {result.reason}")
