"""The ``armpath`` command line (typer).

Angles on the command line are degrees, lengths mm; command increments are ticks of 0.1 deg.
Every error armpath detects is printed as one line ``error: ...`` on stderr with exit status 1;
usage errors (unknown option, missing or malformed value) are one ``error:`` line too, exit
status 2. Each module registers its commands on the shared app: kinematics (fk, ik), models
(model show, model convert), tasks (reach, plan, spotweld, trace, run), workspace (workspace,
blindzones, design-sweep), motion (trajectory, rcm), viewing (view, animate) and exporting
(export, schema).
"""

from __future__ import annotations

import importlib
import inspect
import re
import signal
import sys
from typing import Annotated, Any, NoReturn

import typer

from armpath import __version__
from armpath.cli.common import VERBOSE, app, err_console, is_number, out_console
from armpath.errors import ArmpathError

# Register the commands, in the order --help lists them.
for _module in ("kinematics", "models", "tasks", "workspace", "motion", "viewing", "exporting"):
    importlib.import_module(f"armpath.cli.{_module}")


@app.callback(invoke_without_command=True)
def _root(
    version: Annotated[bool, typer.Option("--version", help="Print the version and exit.")] = False,
    verbose: Annotated[
        bool,
        typer.Option(
            "--verbose", "-v", help="Print every progress message on stderr, with its time."
        ),
    ] = False,
) -> None:
    VERBOSE["on"] = verbose
    if version:
        out_console.print(f"armpath {__version__}")
        raise typer.Exit(0)


def _reflow(text: str) -> str:
    """A docstring's paragraphs as single lines (typer keeps its line breaks, which then
    wrap twice in a narrow terminal); a line starting a bullet (``*``, ``-``) stays a line."""
    paragraphs = re.split(r"\n\s*\n", inspect.cleandoc(text))
    out = []
    for para in paragraphs:
        lines: list[str] = []
        for line in para.splitlines():
            if lines and not line.lstrip().startswith(("* ", "- ")):
                lines[-1] += " " + line.strip()
            else:
                lines.append(line.strip())
        out.append("\n".join(lines))
    return "\n\n".join(out)


def _tidy_help(command: Any) -> Any:
    """Help conventions for every command, in one place: paragraphs reflowed; an on/off flag
    (``--help`` included) shows no value type (typer would print ``<bool>``); an option that
    takes several separate numbers shows one ``NUM`` per number rather than a comma-joined type
    list, unless it names them itself; an argument with a metavar (``X Y Z``) shows no type
    column."""
    commands = getattr(command, "commands", {})
    for sub in commands.values():
        _tidy_help(sub)
    if command.help:
        command.help = _reflow(command.help)
    for param in command.params:
        if param.param_type_name == "argument" and param.metavar:
            # the metavar (X Y Z) already names the values; no type column
            param.display_type_rich = lambda ctx: ""
        if param.param_type_name != "option":
            continue
        if param.is_flag:
            param.metavar = ""
        elif param.nargs > 1 and param.metavar is None:
            param.metavar = " ".join(["NUM"] * param.nargs)
    help_option = command.get_help_option

    def get_help_option(ctx: Any) -> Any:
        option = help_option(ctx)
        if option is not None:
            option.metavar = ""
        return option

    command.get_help_option = get_help_option
    return command


def cli_command() -> Any:
    """The ``armpath`` command (all subcommands registered, help conventions applied)."""
    return _tidy_help(typer.main.get_command(app))


#: Options whose numbers follow them as separate words (one value per joint of the chosen arm,
#: or a direction): the words are joined into the option's one value before parsing.
JOINT_LIST_OPTIONS = ("--from", "--to", "--tool-axis", "--near")


def join_number_lists(args: list[str], options: tuple[str, ...] = JOINT_LIST_OPTIONS) -> list[str]:
    """``--from 0 -90 0 0 -90 0`` becomes ``--from "0 -90 0 0 -90 0"``: the numbers that
    follow one of ``options`` (up to the next word that is not a number) become its value."""

    out: list[str] = []
    i = 0
    while i < len(args):
        word = args[i]
        out.append(word)
        i += 1
        if word in options:
            numbers = []
            while i < len(args) and (is_number(args[i]) or "," in args[i]):
                numbers.append(args[i])
                i += 1
            if numbers:
                out.append(" ".join(numbers))
    return out


def empty_option(args: list[str]) -> str | None:
    """The first option of ``args`` given an empty value (``--out ""`` or ``--out=``), which
    the parser would take as the current folder for a path; None if there is none."""
    for i, arg in enumerate(args):
        if not arg.startswith("--"):
            continue
        name, equals, value = arg.partition("=")
        if (equals and not value) or (not equals and i + 1 < len(args) and args[i + 1] == ""):
            return name
    return None


#: Set when SIGTERM arrived (the command then unwinds as from Ctrl-C).
_TERMINATED: list[int] = []
#: The exit status of a command ended by Ctrl-C (the parser's) and by SIGTERM (128 + 15).
_INTERRUPTED_STATUS = 130
_TERMINATED_STATUS = 143


#: How soon an interrupt put off while numba compiles is tried again (s).
_RETRY_INTERRUPT_S = 0.05


def _on_terminate(signum: int, frame: object) -> None:
    """SIGTERM: raised where the command is as an interrupt, so what it staged is removed."""
    _TERMINATED.append(signum)
    _interrupt_when_safe()


def _on_interrupt(signum: int, frame: object) -> None:
    """Ctrl-C (SIGINT): as Python's own handler, but never inside numba's compiler."""
    _interrupt_when_safe()


def _interrupt_when_safe(signum: int | None = None, frame: object = None) -> None:
    """Raise :class:`KeyboardInterrupt` where the command is, unless numba is compiling a kernel
    there: an interrupt inside its compiler left it broken ("no compiled object yet for
    <Library ...>" as a traceback, or the interrupt escaping the command's handler, exit status
    -2, about one run in twenty with the kernels not yet cached). Then the interrupt is
    tried again a moment later (SIGALRM), until the compiler is done."""
    if _compiling():
        signal.signal(signal.SIGALRM, _interrupt_when_safe)
        signal.setitimer(signal.ITIMER_REAL, _RETRY_INTERRUPT_S)
        return
    raise KeyboardInterrupt


def _compiling() -> bool:
    """Whether this thread holds numba's compiler lock (numba is compiling a kernel)."""
    lock = sys.modules.get("numba.core.compiler_lock")
    return lock is not None and bool(lock.global_compiler_lock.is_locked())


def _interrupted() -> NoReturn:
    """One error line for a command ended by Ctrl-C or SIGTERM, and its exit status."""
    word = "terminated" if _TERMINATED else "interrupted"
    err_console.print(f"error: {word}", markup=False)
    sys.exit(_TERMINATED_STATUS if _TERMINATED else _INTERRUPTED_STATUS)


def main() -> None:
    """Console entry point: a usage error (unknown option, missing, empty or malformed value)
    is one ``error:`` line naming the command's --help, exit status 2. Interrupted (Ctrl-C,
    exit status 130) or terminated (SIGTERM, 143), a command ends with one ``error:`` line and
    leaves no staged output behind."""
    signal.signal(signal.SIGTERM, _on_terminate)
    signal.signal(signal.SIGINT, _on_interrupt)
    empty = empty_option(sys.argv[1:])
    if empty is not None:
        message = f"error: {empty} was given an empty value (see: armpath --help)"
        err_console.print(message, markup=False)
        sys.exit(2)
    try:
        rc = cli_command()(
            args=join_number_lists(sys.argv[1:]), prog_name="armpath", standalone_mode=False
        )
    except (typer.Abort, KeyboardInterrupt):
        _interrupted()
    except typer.TyperException as exc:  # the parser's errors (typer's click)
        if type(exc).__name__ == "NoArgsIsHelpError":  # plain `armpath`: its help, printed
            sys.exit(0)
        message = " ".join(str(getattr(exc, "format_message", exc.__str__)()).split())
        message = message.replace(": Value error, ", ": ")  # the enum converter's prefix
        ctx = getattr(exc, "ctx", None)
        where = f" (see: {ctx.command_path} --help)" if ctx is not None else ""
        err_console.print(f"error: {message}{where}", markup=False, soft_wrap=True)
        sys.exit(int(getattr(exc, "exit_code", 2)))
    except ArmpathError as exc:  # pragma: no cover - commands already convert these
        err_console.print(f"error: {exc}", markup=False)
        sys.exit(1)
    if rc == _INTERRUPTED_STATUS or _TERMINATED:  # the parser ended it without a word
        _interrupted()
    if isinstance(rc, int) and rc:
        sys.exit(rc)


__all__ = ["app", "cli_command", "empty_option", "join_number_lists", "main"]
