"""What every ``armpath`` command shares: the typer app, the consoles, option types, error
handling and the small parsing and formatting helpers (deg / mm on the command line)."""

from __future__ import annotations

import contextlib
import math
import re
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Generic, NoReturn, TypeVar

import numpy as np
import typer
from numpy.typing import NDArray
from rich.console import Console
from rich.markup import escape

from armpath.budget import MAX_COORDINATE_MM, MAX_PERIOD_S, check_time_limit_value, time_limit
from armpath.errors import ArmpathError, ArmpathWarning, InvalidInputError
from armpath.geometry import WallThickness
from armpath.model.catalog import BUILTIN_MODELS
from armpath.planning.choices import Objective

if TYPE_CHECKING:
    from armpath.commands import CommandSequence
    from armpath.export import OutputFolder
    from armpath.model.serial_arm import SerialArm
    from armpath.scenes import Scene

app = typer.Typer(
    add_completion=True,
    pretty_exceptions_enable=False,
    no_args_is_help=True,
    help=(
        "Motion design for serial arms driven by quantized joint commands (each joint moves a "
        "whole number of ticks per command: for the seed arm 0.1 deg, at most 2 deg; any arm "
        "brings its own lattice). Angles in deg, lengths in mm."
    ),
)
out_console = Console(highlight=False)
err_console = Console(stderr=True, highlight=False)

IntArray = NDArray[np.int64]

LOOSE = {"ignore_unknown_options": True}  # lets negative numbers through as arguments

WallOption = Annotated[
    WallThickness | None,
    typer.Option(
        help="How the hollow workpiece's wall thickness is measured: normal to the wall, or "
        "horizontally (the seed papers' reading). Default: as the scene file says.",
        show_default=False,
    ),
]
LinkRadiusOption = Annotated[
    float | None,
    typer.Option(
        help="Radius of every link's capsule, mm. Default: the model's own (the seed arm: 0, "
        "as in the seeds).",
        show_default=False,
    ),
]
SceneOption = Annotated[
    Path | None,
    typer.Option(
        "--scene",
        help="Scene file (TOML or YAML). Default: the seed scene; with another --model, no "
        "scene (the arm alone: give --scene for trace and spotweld).",
    ),
]
ObjectiveOption = Annotated[
    Objective,
    typer.Option(
        help="What to minimise: number of commands, fingertip path length, or weighted joint "
        "travel (energy). Every plan reports all three. A tour plans each leg for it and keeps, "
        "of the tours it plans, the one least in it (the orders planned are chosen by their "
        "bounds on commands)."
    ),
]
JsonOption = Annotated[bool, typer.Option("--json", help="Print the result JSON on stdout.")]
AnimateOption = Annotated[
    bool,
    typer.Option(
        "--animate", help="Also write an animation of the motion (<task>.gif) into --out."
    ),
]


def _animate_into(
    folder: OutputFolder,
    stem: str,
    arm: SerialArm,
    scene: Scene,
    seq: CommandSequence,
    title: str,
    targets: np.ndarray | None = None,
    curve: np.ndarray | None = None,
) -> None:
    """Write ``stem.gif``: the arm through the commands, the targets and the curve."""
    from armpath.viz.animation import sequence_animation, write_animation

    with err_console.status(f"animating {stem} ..."):
        write_animation(
            folder.file(f"{stem}.gif"),
            sequence_animation(arm, scene, seq, title, targets, curve),
            max_frames=64,
        )


def print_written(folder: OutputFolder | None) -> None:
    """The files a command wrote (``wrote PATH``), then those an earlier command had written
    into the same folder that it removed (a folder holds one run's results)."""
    if folder is None:
        return
    for path in folder.written:  # a long path on one line, not wrapped at the console's width
        out_console.print(f"wrote {path}", markup=False, soft_wrap=True)
    for path in folder.removed:
        out_console.print(
            f"removed {path} (an earlier command's result in this folder)",
            markup=False,
            soft_wrap=True,
        )


def _animate_needs_out(animate: bool, out: Path | None) -> None:
    if animate and out is None:
        raise InvalidInputError("--animate needs --out FOLDER to write the GIF into")


SeedOption = Annotated[int, typer.Option(help="Random seed of the planner (same seed, same plan).")]

BoundSamplesOption = Annotated[
    int | None,
    typer.Option(
        "--bound-samples",
        metavar="N",
        help="Live samples past which the lower bound's search over sampled goal "
        "configurations stops splitting (1,000 to 2,000,000; default 50,000; its first round "
        "may hold more, and the result reports what it held; its rounds grow in proportion, "
        "16 at the default): more give a tighter bound, later (with 200,000 the UR5 cell's "
        "seam: 104.9 rather than 102.9, its bound 91.2 s rather than 33.9 s; "
        "benchmarks/results/bounds.md). Every trace's bound samples; a tour of at most 8 "
        "welds is bounded over its lattice goal states "
        "instead when they can all be listed and their legs measured, and then N is not read "
        "(the seed's Task 3: 117 either way).",
        show_default=False,
    ),
]

TimeLimitOption = Annotated[
    float | None,
    typer.Option(
        "--time-limit",
        metavar="SECONDS",
        help="Stop with an error if the computation takes longer than this (s). "
        "Default: no limit (every search still ends by its own budget).",
        show_default=False,
    ),
]


@contextlib.contextmanager
def _cli_errors(time_limit_s: float | None = None) -> Iterator[None]:
    """Turn armpath's errors into a one-line message and exit status 1; run the block under
    ``time_limit_s`` (see :mod:`armpath.budget`)."""
    try:
        check_time_limit_value(time_limit_s, "--time-limit")
        with time_limit(time_limit_s), warnings.catch_warnings():
            # armpath's warnings as the CLI says them: one "warning:" line each
            warnings.simplefilter("always", ArmpathWarning)
            warnings.showwarning = _said_as_cli(warnings.showwarning)
            yield
    except UnknownOptionError as exc:  # a usage error, as the parser's own
        _error_line(str(exc), status=2)
    except ArmpathError as exc:
        _error_line(str(exc))
    except OSError as exc:  # the machine, not the input: a full disk, a closed pipe, ...
        where = f" ({exc.filename})" if exc.filename else ""
        _error_line(f"{exc.strerror or exc}{where}")
    except MemoryError:
        _error_line(
            "out of memory: the problem is too large for this machine; make it smaller "
            "(fewer samples, coarser grids, shorter motions)"
        )


def _said_as_cli(
    show: Callable[..., None],
) -> Callable[..., None]:
    """``warnings.showwarning`` printing an :class:`ArmpathWarning` as one ``warning:`` line on
    stderr and passing any other warning to ``show``."""

    def said(message: Warning | str, category: type[Warning], *args: Any, **kw: Any) -> None:
        if issubclass(category, ArmpathWarning):
            err_console.print(f"warning: {message}", markup=False, soft_wrap=True)
        else:
            show(message, category, *args, **kw)

    return said


def _error_line(message: str, status: int = 1) -> NoReturn:
    """Print ``error: message`` as one line on stderr and exit with ``status``."""
    err_console.print(f"error: {' '.join(message.split())}", markup=False, soft_wrap=True)
    raise typer.Exit(status)


class UnknownOptionError(InvalidInputError):
    """An option the command does not have, taken in with its numbers (the commands that let
    negative numbers through as arguments): a usage error, exit status 2 as the parser's."""


#: Seconds before progress lines start when stderr is not a terminal: quick commands (and
#: input refused up front) print nothing but their result or their one error line.
PROGRESS_DELAY_S = 2.0
#: ``armpath -v``: every progress message as a timed line on stderr, from the start.
VERBOSE = {"on": False}


@contextlib.contextmanager
def progress(title: str) -> Iterator[Callable[[str], None]]:
    """Report progress on stderr: a live status line on a terminal; otherwise, once the work
    has run for :data:`PROGRESS_DELAY_S`, one line per new message
    (``armpath: [12.3 s] message``), so logs and pipes show what a long command is doing.

    With ``-v`` (:data:`VERBOSE`) every message is a timed line from the start, on a terminal
    too. Yields the callback that takes each progress message.
    """
    verbose = VERBOSE["on"]
    if err_console.is_terminal and not verbose:
        with err_console.status(title) as status:
            yield lambda msg: status.update(escape(msg))
        return
    started = time.monotonic()
    last = [title, ""]  # latest message, last printed
    delay = 0.0 if verbose else PROGRESS_DELAY_S
    lock = threading.Lock()

    def say(msg: str) -> None:
        with lock:
            last[0] = msg
            elapsed = time.monotonic() - started
            if elapsed >= delay and msg != last[1]:
                last[1] = msg
                err_console.print(
                    f"armpath: [{elapsed:6.1f} s] {msg}", markup=False, soft_wrap=True
                )

    if verbose:
        say(title)
    # a stage begun before the delay and still running at it is shown then, not at its end
    timer = threading.Timer(delay, lambda: say(last[0]))
    timer.daemon = True
    timer.start()
    try:
        yield say
    finally:
        timer.cancel()


T = TypeVar("T")


class BackgroundJob(Generic[T]):
    """``fn()`` computed in a forked child process while the caller goes on (the machine's
    other core); :meth:`result` waits for it and returns its value or raises its exception.

    The child may run any kernel: where its parent had started numba's threads it takes the
    kernels' serial versions (GNU OpenMP would kill it; see :mod:`armpath.jit`). Where ``fork``
    is not available (Windows, macOS's default), ``fn`` runs when :meth:`result` is called."""

    def __init__(self, fn: Callable[[], T]) -> None:
        import multiprocessing
        import os
        import sys

        self._fn = fn
        self._conn: Any = None
        self._process: Any = None
        if "fork" in multiprocessing.get_all_start_methods() and (os.cpu_count() or 1) > 1:
            context = multiprocessing.get_context("fork")
            sys.stdout.flush()  # (else the child would write what is buffered once more)
            sys.stderr.flush()
            self._conn, child = context.Pipe(duplex=False)
            self._process = context.Process(target=self._child, args=(child,), daemon=True)
            self._process.start()
            child.close()

    def _child(self, conn: Any) -> None:  # pragma: no cover - runs in the child process
        import signal

        # the parent's cancel() terminates the child: it must end then, not unwind into a
        # send nobody receives (the CLI's SIGTERM handler, inherited through fork, would)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        try:
            conn.send((True, self._fn()))
        except BaseException as exc:  # handed to the parent to raise
            conn.send((False, exc))
        finally:
            conn.close()

    def result(self) -> T:
        if self._process is None:
            return self._fn()
        try:
            ok, value = self._conn.recv()
        except EOFError:
            raise ArmpathError(
                f"a background computation ended without a result (exit code "
                f"{self._process.exitcode})"
            ) from None
        finally:
            self._process.join()
        if not ok:
            raise value
        return value  # type: ignore[no-any-return]

    def cancel(self) -> None:
        """Stop the child (when the caller gives up first)."""
        if self._process is not None and self._process.is_alive():
            self._process.kill()  # SIGKILL: ends it even before it can reset SIGTERM
            self._process.join()


def is_number(text: str) -> bool:
    """Whether ``text`` reads as a number (``-inf`` and ``nan`` too: checked as finite later)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _numbers(values: list[str], count: int, what: str) -> list[float]:
    unknown = [v for v in values if re.fullmatch(r"--?[A-Za-z].*", v) and not is_number(v)]
    if unknown:  # an option the command does not have, taken in with the numbers
        raise UnknownOptionError(f"no such option: {unknown[0]} (see the command's --help)")
    if len(values) != count:
        raise InvalidInputError(f"{what}: expected {count} numbers, got {len(values)}: {values}")
    out = []
    for v in values:
        try:
            x = float(v)
        except ValueError:
            raise InvalidInputError(f"{what}: {v!r} is not a number") from None
        if not math.isfinite(x):
            raise InvalidInputError(f"{what}: {v!r} is not a finite number")
        out.append(x)
    return out


def _point_mm(values: list[str], what: str) -> list[float]:
    """Three coordinates (mm) of a target point: finite numbers within the coordinate limit."""
    from armpath.budget import check_point_mm

    return check_point_mm(_numbers(values, 3, what), what)


def _scene(scene_file: Path | None, wall: WallThickness | str | None) -> Scene:
    from armpath.scenes import load_scene

    scene = load_scene(scene_file)
    return scene.with_wall_thickness(wall) if wall else scene


def _arm(link_radius_mm: float) -> SerialArm:
    from armpath.model.seed_arm import SeedArmGeometry, seed_arm

    return seed_arm(SeedArmGeometry(link_radius_mm=_checked_link_radius(link_radius_mm)))


def _checked_link_radius(link_radius_mm: float) -> float:
    """``--link-radius`` (mm), or :class:`InvalidInputError` unless finite, >= 0 and within the
    largest size accepted."""
    if not (math.isfinite(link_radius_mm) and 0 <= link_radius_mm <= MAX_COORDINATE_MM):
        raise InvalidInputError(
            f"--link-radius must be >= 0 and <= {MAX_COORDINATE_MM:g} mm, got {link_radius_mm:g}"
        )
    return link_radius_mm


TipLinkOption = Annotated[
    str | None,
    typer.Option(
        "--tip-link",
        help="The URDF link that carries the tool (default: the deepest link no gripper finger "
        "joint carries; outputs name "
        "the link chosen).",
        show_default=False,
    ),
]


def task_setup(
    model: str | None,
    scene_file: Path | None,
    wall: WallThickness | str | None,
    link_radius_mm: float | None,
    tip_link: str | None = None,
) -> tuple[SerialArm, Scene]:
    """The arm and the scene of a task command, decided once: the scene file (or the seed
    scene for the seed arm, or no obstacles for another arm standing alone), its ``[arm]`` or
    ``--model`` (which replaces the scene's model), and ``--link-radius`` (mm, every link).
    Run within :func:`_cli_errors` (which says armpath's warnings)."""
    from armpath.api import arm_and_scene, default_scene, load_scene

    scene = load_scene(scene_file) if scene_file is not None else default_scene(model)
    if wall:
        scene = scene.with_wall_thickness(wall)
    radius = None if link_radius_mm is None else _checked_link_radius(link_radius_mm)
    # arm_and_scene's warnings (a base inside an obstacle, ...) are said by _cli_errors as they
    # come, after every check here that can refuse the input (a refusal stays one line)
    arm, scene = arm_and_scene(model, scene, tip_link=tip_link)
    if radius is not None:
        arm = arm.with_link_radii(radius)  # arms are in mm
    return arm, scene


def joint_state(arm: SerialArm, values: str | None, option: str) -> IntArray:
    """A lattice state of ``arm`` from an option's joint values (deg, or mm for prismatic
    joints, separated by spaces or commas); ``None``: the arm's home pose."""
    if values is None:
        return arm.lattice.to_ticks(arm.home, "the arm's home pose")
    words = values.replace(",", " ").split()
    numbers = _numbers(words, arm.n_joints, f"{option} ({arm.n_joints} joint values of {arm.name})")
    return arm.lattice.from_display(np.array(numbers), f"{option}")


def _fmt(v: Any, digits: int = 4) -> str:
    """Numbers to ``digits`` decimals, in parentheses; those of 10**9 or more in exponent form
    (``fk 1e300 ...`` printed 300 digits)."""
    return "(" + ", ".join(_number_text(x, digits) for x in np.asarray(v, dtype=float)) + ")"


def _number_text(x: float, digits: int) -> str:
    return f"{x:.{digits}f}" if abs(x) < 1e9 else f"{x:.{max(digits, 3)}e}"


#: The built-in models as --help lists them.
BUILTIN_NAMES = ", ".join(BUILTIN_MODELS)

ModelOption = Annotated[
    str,
    typer.Option(
        "--model",
        help=f"Built-in model ({BUILTIN_NAMES}) or a robot file (.json D-H table or .urdf).",
    ),
]


PeriodOption = Annotated[
    float,
    typer.Option(help=f"Controller period, s (one command each; at most {MAX_PERIOD_S:g} s)."),
]


def _joint_units(arm: SerialArm) -> list[str]:
    from armpath.model.serial_arm import JointKind

    return ["mm" if j.kind is JointKind.PRISMATIC else "deg" for j in arm.joints]


def _units_text(units: tuple[str, ...] | list[str]) -> str:
    """``deg`` for an arm of revolute joints, else the unit of each joint (``deg, deg, mm``)."""
    return "deg" if set(units) == {"deg"} else "(" + ", ".join(units) + ")"


def _to_display(arm: SerialArm, q: np.ndarray) -> np.ndarray:
    """Joint values (rad / the model's length unit) for output: deg for revolute joints, mm for
    prismatic ones (:meth:`~armpath.model.lattice.Lattice.joint_display`)."""
    return arm.lattice.joint_display(q)


def _from_display(arm: SerialArm, values: list[float]) -> np.ndarray:
    """Joint values given in deg (revolute) and mm (prismatic) in rad / model units."""
    return arm.lattice.joint_from_display(values)


def _commands_csv(sequence: Any) -> str:
    """``step, d1..dn`` in ticks, one row per command."""
    cmds = sequence.commands
    return _csv_rows(
        ["step"] + [f"d{j + 1}_ticks" for j in range(cmds.shape[1])],
        np.column_stack([np.arange(1, len(cmds) + 1), cmds]),
        "{:d}",
    )


def _csv_rows(header: list[str], rows: np.ndarray, fmt: str = "{:.6f}") -> str:
    """CSV text of a numeric table, every value written with ``fmt``."""
    from armpath.export import csv_text

    return csv_text(header, [[fmt.format(v) for v in row] for row in rows])
