"""The ``armpath`` command line (typer).

Angles on the command line are degrees, lengths mm; command increments are ticks of 0.1 deg.
Every error armpath detects is printed as one line ``error: ...`` on stderr with exit status 1;
usage errors exit with status 2. Each module registers its commands on the shared app: kinematics
(fk, ik), tasks (reach, plan, spotweld, trace, run), workspace (workspace, blindzones,
design-sweep), motion (trajectory, rcm) and viewing (view, animate).
"""

from __future__ import annotations

import importlib
import sys
from typing import Annotated

import typer

from armpath import __version__
from armpath.cli.common import app, err_console, out_console
from armpath.errors import ArmpathError

# Register the commands, in the order --help lists them.
for _module in ("kinematics", "tasks", "workspace", "motion", "viewing"):
    importlib.import_module(f"armpath.cli.{_module}")


@app.callback(invoke_without_command=True)
def _root(
    version: Annotated[bool, typer.Option("--version", help="Print the version and exit.")] = False,
) -> None:
    if version:
        out_console.print(f"armpath {__version__}")
        raise typer.Exit(0)


def main() -> None:
    """Console entry point."""
    try:
        app()
    except ArmpathError as exc:  # pragma: no cover - commands already convert these
        err_console.print(f"error: {exc}", markup=False)
        sys.exit(1)


__all__ = ["app", "main"]
