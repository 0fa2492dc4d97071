"""Bounds on work and memory of the non-planning commands (issue 17, item 4): workspace,
blindzones, design-sweep, trajectory and rcm.

Every input that sets the size of the work is refused before any work with one ``error:`` line
on stderr that names the option to change, exit status 1, nothing on stdout and no output
folder (nor a staging folder left beside it). The sizes refused here would need gigabytes or
hours; they are refused from the arithmetic alone. The refusals run the CLI's entry point in
the test's process (``cli_in_process``: no interpreter start per run); ``--time-limit``, which
ends long runs with the time-limit message and writes nothing, is checked on real processes.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from armpath.budget import MAX_COMMANDS, MAX_PERIODS, MAX_WAYPOINTS
from cli_in_process import run_in_process

ARMPATH = [sys.executable, "-m", "armpath"]


def _run(args: list[str], cwd: Path, process: bool = False) -> subprocess.CompletedProcess[str]:
    """``armpath *args`` in ``cwd``: in this process, or a real one (``process``)."""
    if not process:
        return run_in_process(args, cwd)
    return subprocess.run([*ARMPATH, *args], capture_output=True, text=True, timeout=600, cwd=cwd)


def _error_line(proc: subprocess.CompletedProcess[str]) -> str:
    """The one ``error:`` line of a refused run (progress lines, ``armpath: [..]``, may come
    before it on stderr; nothing else may)."""
    lines = proc.stderr.strip().splitlines()
    errors = [ln for ln in lines if ln.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    assert all(ln.startswith(("error:", "armpath: [")) for ln in lines), proc.stderr
    return errors[0]


def _refused(tmp_path: Path, args: list[str], *needles: str, process: bool = False) -> str:
    """Run with ``--out`` (in a real process if ``process``); exit 1, one error line containing
    every needle, no stdout, no output or staging folder."""
    out = tmp_path / "out"
    before = set(tmp_path.iterdir())
    proc = _run([*args, "--out", str(out)], tmp_path, process)
    assert proc.returncode == 1, (proc.returncode, proc.stdout, proc.stderr)
    line = _error_line(proc)
    for needle in needles:
        assert needle in line, line
    assert proc.stdout == ""
    assert not out.exists()
    assert set(tmp_path.iterdir()) == before  # no .armpath-* staging folder left
    assert "Traceback" not in proc.stderr
    return line


# --- trajectory -----------------------------------------------------------------------------


def _waypoints(tmp_path: Path, text: str | bytes, name: str = "wp.csv") -> str:
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return name


def test_trajectory_far_waypoints_are_refused_by_their_periods(tmp_path):
    """1e7 deg at the default 30 deg/s and 60 deg/s^2 lasts 1e7/30 + 30/60 s: 33 million
    periods of 0.01 s (the 6.4 GB of the report), more than MAX_PERIODS."""
    wp = _waypoints(tmp_path, "0,0,0,0,0,0\n1e7,0,0,0,0,0\n")
    periods = math.ceil((1e7 / 30.0 + 30.0 / 60.0) / 0.01)
    assert periods > MAX_PERIODS
    line = _refused(tmp_path, ["trajectory", "--waypoints", wp], "controller periods", "--period")
    assert f"{periods:,}" in line
    wp = _waypoints(tmp_path, "0,0,0,0,0,0\n1e9,0,0,0,0,0\n", "far.csv")
    _refused(tmp_path, ["trajectory", "--waypoints", wp], "controller periods", "--period")


def test_trajectory_tiny_period_is_refused(tmp_path):
    wp = _waypoints(tmp_path, "t,q1,q2\n0,0,0\n1.5,10,20\n")
    line = _refused(
        tmp_path,
        ["trajectory", "--waypoints", wp, "--period", "1e-9"],
        "controller periods",
        "--period",
    )
    assert "1,500,000,000" in line  # 1.5 s / 1e-9 s


def test_trajectory_span_beyond_the_command_limit_is_refused(tmp_path):
    """With a long period the periods are few, but a joint moving 1e9 deg needs 1e10 ticks /
    20 = 5e8 commands, more than MAX_COMMANDS."""
    wp = _waypoints(tmp_path, "t,q1\n0,0\n1,1e9\n")
    line = _refused(
        tmp_path, ["trajectory", "--waypoints", wp, "--period", "10"], "commands", "--waypoints"
    )
    assert "500,000,000" in line


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--max-velocity", "0"),
        ("--max-velocity", "-1"),
        ("--max-velocity", "nan"),
        ("--max-velocity", "1e300"),
        ("--max-acceleration", "0"),
        ("--max-acceleration", "inf"),
        ("--max-acceleration", "-5"),
        ("--max-jerk", "0"),
        ("--max-jerk", "nan"),
        ("--max-jerk", "1e20"),
        ("--period", "0"),
        ("--period", "nan"),
        ("--period", "1e9"),
    ],
)
def test_trajectory_bad_option_values(tmp_path, option, value):
    wp = _waypoints(tmp_path, "0,0\n10,20\n")
    _refused(tmp_path, ["trajectory", "--waypoints", wp, "--bounded", option, value], option)


def test_trajectory_tiny_velocity_limit_names_the_limits(tmp_path):
    """1e-300 deg/s spaces the waypoints 1e301 s apart: refused by the periods, naming the
    options that set the duration."""
    wp = _waypoints(tmp_path, "0,0\n10,20\n")
    _refused(
        tmp_path,
        ["trajectory", "--waypoints", wp, "--max-velocity", "1e-300"],
        "controller periods",
        "--max-velocity",
    )


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        (b"\xff\xfe,1\n1,2\n", "not UTF-8"),
        (b"0,0\n\xe9\n", "line 2 is not UTF-8"),
        (b"", "is empty"),
        (b"\n  \n", "is empty"),
        (b"q1,q2\n", "no rows, only a header"),
        (b"1,2\n", "at least 2 waypoint rows"),
        (b"q1,q2\n1,abc\n2,3\n", "line 2, column 2: 'abc' is not a number"),
        (b"1,2,3\n4,5\n", "line 2 has 2 values, the first row has 3"),
        (b"q1,q2,q3\n4,5\n6,7\n", "line 2 has 2 values, the header has 3"),
        (b"1,2\nnan,3\n", "line 2, column 1: 'nan' is not a finite number"),
        (b"1,2\n3,inf\n", "'inf' is not a finite number"),
        (b"t,q1\n0,1\n0,2\n", "must increase strictly"),
        (b"t\n0\n1\n", "no joint column"),
        (b"1," * 40_000 + b"\n", "longer than 65,536 bytes"),
        (b",".join([b"1"] * 70) + b"\n", "line 1 has 70 values; a row holds at most 65"),
    ],
)
def test_trajectory_malformed_waypoint_files(tmp_path, content, needle):
    wp = _waypoints(tmp_path, content)
    line = _refused(tmp_path, ["trajectory", "--waypoints", wp], "--waypoints", needle)
    assert wp in line


def test_trajectory_too_many_waypoints_and_missing_file(tmp_path):
    rows = "".join(f"{0.01 * k:.2f},0\n" for k in range(MAX_WAYPOINTS + 1))
    wp = _waypoints(tmp_path, rows)
    _refused(tmp_path, ["trajectory", "--waypoints", wp], "--waypoints", "more than 10,000")
    _refused(tmp_path, ["trajectory", "--waypoints", "nowhere.csv"], "--waypoints", "nowhere")


def test_trajectory_byte_order_mark_and_time_column(tmp_path):
    """A UTF-8 file with a byte-order mark (as spreadsheets save it) keeps its 't' column as
    the times: 1000 ticks in one 5 s period are ceil(1000 / 20) = 50 commands of 20 ticks."""
    wp = _waypoints(tmp_path, b"\xef\xbb\xbft,q1,q2\n0,0,0\n1,100,-37.3\n")
    out = tmp_path / "tr"
    proc = _run(["trajectory", "--waypoints", wp, "--period", "5", "--out", str(out)], tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = np.loadtxt(out / "commands.csv", delimiter=",", skiprows=1, dtype=np.int64)
    assert rows.shape == (math.ceil(1000 / 20), 3)
    assert rows[:, 1].tolist() == [20] * 50  # joint 1: 100 deg = 1000 ticks
    assert rows[:, 2].sum() == -373 and np.abs(rows[:, 2]).max() <= 20
    samples = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    assert samples[:, 0].tolist() == [0.0, 1.0]  # one period, clipped to the 1 s trajectory
    assert "periods split (> 20 ticks: 2 deg)" in proc.stdout
    # 50 commands at one a 5 s period take 250 s, not the trajectory's 1 s: said, and why
    took = next(ln for ln in proc.stdout.splitlines() if "commands take" in ln)
    assert took.split()[2] == "250.000"
    warning = " ".join(proc.stderr.split())
    assert "the commands take 250 s at one a period, not the trajectory's 1 s" in warning
    assert "1 of 1 periods move a joint farther than one command may" in warning
    assert "the period is longer than the 1 s trajectory" in warning


def test_a_period_longer_than_the_trajectory_is_warned_of_alone(tmp_path):
    """A 1 deg move takes 0.26 s at the default limits; a 60 s period holds it in one
    command that takes 60 s, no period split: the warning says why all the same."""
    wp = _waypoints(tmp_path, "0 0\n1 1\n")
    proc = _run(["trajectory", "--waypoints", wp, "--period", "60"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    split = next(ln for ln in proc.stdout.splitlines() if "periods split" in ln)
    assert split.split()[-1] == "0"
    warning = " ".join(proc.stderr.split())
    assert "the commands take 60 s at one a period" in warning
    assert "the period is longer than the 0.258 s trajectory" in warning
    assert "split into several" not in warning


def test_trajectory_time_limit_ends_the_bounded_search(tmp_path):
    rng = np.random.default_rng(1)
    rows = "\n".join(",".join(f"{v:.3f}" for v in row) for row in rng.uniform(-90, 90, (600, 6)))
    wp = _waypoints(tmp_path, rows + "\n")
    _refused(
        tmp_path,
        ["trajectory", "--waypoints", wp, "--bounded", "--time-limit", "1"],
        "time limit of 1 s ran out",
        "--time-limit",
        process=True,
    )


# --- rcm ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--points", "100000"], ("points on the circle", "--points", "9,999")),
        (["--points", "2"], ("--points must be >= 3",)),
        (["--duration", "1e9"], ("controller periods", "--duration")),
        (["--period", "1e-9"], ("controller periods", "--period")),
        (["--duration", "0"], ("--duration",)),
        (["--duration", "nan"], ("--duration",)),
        (["--duration", "inf"], ("--duration",)),
        (["--duration", "1e-300"], ("--duration",)),
        (["--duration", "1e-9"], ("--duration", "less than one controller period", "0.24 s")),
        (["--period", "1e9"], ("--period", "(0, 60]")),
        (["--period", "-1"], ("--period",)),
        (["--cone", "0"], ("--cone",)),
        (["--cone", "nan"], ("--cone",)),
        (["--axis", "0,0,0"], ("--axis",)),
        (["--centre", "1,2"], ("--centre",)),
        (["--time-limit", "-1"], ("--time-limit",)),
    ],
)
def test_rcm_refusals(tmp_path, args, needles):
    _refused(tmp_path, ["rcm", *args], *needles)


def test_rcm_counts_commands_and_names_the_command_limit(tmp_path):
    """One turn in 8 s at 0.01 s periods: 800 periods, and no period needs more than the
    command limit (20 ticks, 2 deg or 2 mm), so 800 commands; the table says so."""
    proc = _run(["rcm", "--points", "12"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "periods split (> 20 ticks: 2 deg, 2 mm)" in proc.stdout
    assert "2 ticks)" not in proc.stdout
    commands = next(ln for ln in proc.stdout.splitlines() if ln.strip().startswith("commands"))
    assert commands.split()[1] == str(round(8.0 / 0.01))
    assert "warning" not in proc.stderr  # one command a period keeps the trajectory's timing


# --- workspace ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--voxel", "0.001"], ("voxels", "--voxel", "50,000,000")),
        (["--voxel", "1e-300"], ("voxels", "--voxel")),
        (["--voxel", "nan"], ("--voxel",)),
        (["--voxel", "-2"], ("--voxel",)),
        (["--voxel", "1e9"], ("larger than the arm's reach (715 mm)", "--voxel")),
        (["--voxel", "1e103"], ("larger than the arm's reach", "--voxel")),  # was a traceback
        (["--voxel", "3.9"], ("at least 3.91", "50,243,409", "--voxel")),
        (["--samples", "1000000000"], ("joint samples", "--samples", "200,000,000")),
        (["--samples", "0"], ("--samples",)),
        (["--chunk", "100000000"], ("--chunk", "4,000,000")),
        (["--chunk", "0"], ("--chunk",)),
        (["--seed", "-1"], ("--seed",)),
        (["--time-limit", "0"], ("--time-limit",)),
        (["--time-limit", "nan"], ("--time-limit",)),
    ],
)
def test_workspace_refusals(tmp_path, args, needles):
    _refused(tmp_path, ["workspace", *args], *needles)


def test_workspace_time_limit(tmp_path):
    _refused(
        tmp_path,
        ["workspace", "--samples", "200000000", "--time-limit", "1"],
        "time limit of 1 s ran out while sampling the workspace",
        "--time-limit",
        process=True,
    )


# --- blindzones -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--pixel", "0.001"], ("pixels", "--pixel", "50,000,000")),
        (["--pixel", "0"], ("--pixel",)),
        (["--pixel", "inf"], ("--pixel",)),
        (["--pixel", "1e103"], ("larger than the map (1150 x 1150 mm)", "--pixel")),
        (["--samples", "100000000"], ("joint samples", "--samples", "200,000,000")),
        (["--samples", "0"], ("--samples",)),
        (["--bands", "101"], ("circles", "--bands", "the limit is 100")),
        (["--bands", "-1"], ("--bands",)),
        (["--seed", "-3"], ("--seed",)),
    ],
)
def test_blindzones_refusals(tmp_path, args, needles):
    _refused(tmp_path, ["blindzones", *args], *needles)


def test_blindzones_time_limit(tmp_path):
    _refused(
        tmp_path,
        ["blindzones", "--time-limit", "1"],
        "time limit of 1 s ran out",
        "--time-limit",
        process=True,
    )


# --- design-sweep ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--jobs", "0"], ("--jobs", "-1 (every core)")),
        (["--jobs", "-2"], ("--jobs",)),
        (["--jobs", "1000"], ("parallel jobs", "--jobs", "256")),
        (["--samples", "10000000"], ("joint samples of the sweep", "--samples", "410,000,000")),
        (["--samples", "0"], ("--samples",)),
        (["--pixel", "0.01"], ("pixels", "--pixel")),
        (["--pixel", "nan"], ("--pixel",)),
        (["--total", "nan"], ("--total",)),
        (["--total", "1e300"], ("pixels", "--total")),
        (["--pixel", "1e160"], ("larger than the map", "--pixel")),  # was a traceback
        (["--top", "0"], ("--top",)),
        (["--seed", "-1"], ("--seed",)),
    ],
)
def test_design_sweep_refusals(tmp_path, args, needles):
    _refused(tmp_path, ["design-sweep", *args], *needles)


def test_design_sweep_time_limit_stops_the_workers(tmp_path):
    """Two worker processes on 4 million samples a design would run for minutes; the limit
    ends the sweep (the parent stops waiting, the workers stop at their own deadline)."""
    _refused(
        tmp_path,
        ["design-sweep", "--samples", "4000000", "--jobs", "2", "--time-limit", "2"],
        "time limit of 2 s ran out while evaluating designs",
        "--time-limit",
        process=True,
    )


@pytest.mark.parametrize("quiet", [False, True])
def test_the_worker_tracker_stays_quiet_about_what_it_removes(tmp_path, quiet):
    """What a time limit can leave to loky's resource tracker (a semaphore registered, then
    gone before the process exits), made on purpose: the tracker warns twice on stderr, unless
    the warning filter design-sweep sets (before its first worker) has reached it."""
    code = (
        "from armpath.cli.workspace import quiet_worker_tracker\n"
        + ("quiet_worker_tracker()\n" if quiet else "")
        + "from joblib.externals.loky.backend import resource_tracker\n"
        + "resource_tracker.register('/armpath-test-gone', 'semlock')\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    if quiet:
        assert proc.stderr == ""
    else:  # the two lines the CI run once showed after design-sweep's error line
        assert "1 leaked semlock objects" in proc.stderr
        assert "/armpath-test-gone: FileNotFoundError" in proc.stderr


def test_design_sweep_every_core_stays_valid(tmp_path):
    """--jobs -1 (the default) passes the checks: a refusal further on (the pixel count) is
    the one reported."""
    line = _refused(tmp_path, ["design-sweep", "--jobs", "-1", "--pixel", "0.01"], "--pixel")
    assert "--jobs" not in line


def test_refusals_come_before_the_output_folder_is_touched(tmp_path):
    """An existing output folder keeps its files when the run is refused."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    proc = _run(["workspace", "--voxel", "0.001", "--out", str(out)], tmp_path)
    assert proc.returncode == 1
    assert [p.name for p in out.iterdir()] == ["keep.txt"]
    assert MAX_COMMANDS == 1_000_000  # the limit the messages above quote


def test_help_texts_quote_the_limits_in_force(tmp_path):
    """The limits --help quotes are the budget's (the docstrings state two of them in words)."""
    # the words of the help, the frame of its option table left out (it wraps the lines)
    text = " ".join(_run(["trajectory", "--help"], tmp_path).stdout.replace("│", " ").split())
    assert f"At most {MAX_PERIODS:,} controller periods" in text
    assert f"and {MAX_COMMANDS:,} commands" in text
    assert f"{MAX_WAYPOINTS:,} rows of 64 joints" in text
    text = " ".join(_run(["rcm", "--help"], tmp_path).stdout.replace("│", " ").split())
    assert f"At most {MAX_PERIODS:,} controller periods" in text and "1,000,000 commands" in text


def test_trajectory_waypoints_separated_by_spaces(tmp_path):
    """A file of values separated by spaces and tabs (as a newcomer writes it) reads like its
    CSV twin: the same commands, line for line."""
    commands = []
    for name, text in (
        ("spaces", "t q1 q2\n0 0 0\n1\t100  -37.3\n"),
        ("csv", "t,q1,q2\n0,0,0\n1,100,-37.3\n"),
    ):
        wp = _waypoints(tmp_path, text, f"{name}.txt")
        out = tmp_path / name
        proc = _run(["trajectory", "--waypoints", wp, "--period", "5", "--out", str(out)], tmp_path)
        assert proc.returncode == 0, proc.stderr
        commands.append((out / "commands.csv").read_text())
    assert commands[0] == commands[1] and commands[0].count("\n") == 51


@pytest.mark.parametrize("tolerance", ["0", "-1", "1e9", "nan"])
def test_plan_tolerance_is_checked_before_any_work(tmp_path, tolerance):
    """plan --tolerance outside the range reach accepts is refused with the range (stress
    suite: it used to be taken as given)."""
    _refused(
        tmp_path,
        ["plan", "--to-xyz", "300", "0", "200", "--tolerance", tolerance],
        "tolerance must be between",
        "mm, got",
    )


@pytest.mark.parametrize("tolerance", ["0", "-1", "1e9", "nan"])
def test_spotweld_tolerance_is_checked_before_any_work(tmp_path, tolerance):
    """spotweld --tolerance outside the range reach accepts is refused with the range (a
    tolerance of 1e9 mm used to give a tour of no commands)."""
    _refused(
        tmp_path,
        ["spotweld", "--tolerance", tolerance],
        "tolerance must be between",
        "mm, got",
    )


@pytest.mark.parametrize(
    "args",
    [
        ["reach", "1e200", "0", "0"],
        ["plan", "--to-xyz", "0", "0", "-5e9"],
        ["reach", "0", "2e9", "1"],
    ],
)
def test_target_coordinates_beyond_the_limit_are_refused(tmp_path, args):
    """A target point beyond 1e9 mm (the limit scenes have) is refused before any work, the
    limit named (1e200 mm used to overflow the nearest-point search: a warning, a wrong point)."""
    _refused(tmp_path, args, "mm is beyond the largest coordinate accepted (1e+09 mm)")


@pytest.mark.parametrize(
    ("task", "samples"),
    [("trace", "10"), ("spotweld", "3000000"), ("trace", "2500000"), ("run", "5")],
)
def test_a_bound_sample_budget_outside_its_range_is_refused(tmp_path, task, samples):
    """--bound-samples outside 1,000..2,000,000 is refused with the range before any work."""
    _refused(tmp_path, [task, "--bound-samples", samples], "bound samples must be between", "got")


# --- results read back ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def reach_document():
    import armpath

    return armpath.reach("seed", [300.0, 100.0, 200.0]).doc


@pytest.mark.parametrize(
    ("model", "needle"),
    [
        ("nosuch", 'the result\'s "model" must be an object'),  # was an AttributeError
        ({"name": "ur5"}, "model 'ur5' carries no definition"),
        ({}, "model (no name) carries no definition"),
    ],
)
@pytest.mark.parametrize("command", ["export", "animate"])
def test_a_result_whose_model_cannot_be_rebuilt_is_refused(
    tmp_path, reach_document, command, model, needle
):
    doc = dict(reach_document, model=model)
    source = tmp_path / "result.json"
    source.write_text(json.dumps(doc), encoding="utf-8")
    out_name = "out.csv" if command == "export" else "out.gif"
    proc = _run([command, str(source), "--out", str(tmp_path / out_name)], tmp_path)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    assert needle in _error_line(proc)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        # a GIF's frames last whole hundredths of a second and browsers show one of under
        # 20 ms for 100 ms: --fps 1000 came out at 10 frames a second
        (["animate", "--fps", "51"], ("--fps must be from 1 to 50", "for a GIF, got 51")),
        (["animate", "--fps", "0"], ("--fps must be from 1 to 50",)),
        # each frame is held as an image until written: 1.4 MB each
        (["animate", "--frames", "1001"], ("--frames must be", "from 2 to 1000, got 1001")),
        (["animate", "--frames", "1"], ("--frames must be", "got 1")),
        (["view", "--export-html", "page.html", "--fps", "5000"], ("--fps must be", "1000")),
        (["view", "--export-html", "page.html", "--fps", "nan"], ("--fps must be", "got nan")),
        # a replay that never moves
        (["view", "--export-html", "page.html", "--fps", "1e-300"], ("from 0.01 to 1000",)),
    ],
)
def test_animation_and_replay_rates_are_refused_naming_their_option(
    tmp_path, reach_document, args, needles
):
    source = tmp_path / "result.json"
    source.write_text(json.dumps(reach_document), encoding="utf-8")
    command, *rest = args
    where = [str(source)] if command == "animate" else ["--result", str(source)]
    proc = _run([command, *where, *rest], tmp_path)
    assert proc.returncode == 1 and "Traceback" not in proc.stderr
    line = _error_line(proc)
    assert all(n in line for n in needles), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]


def test_a_python_animation_is_refused_in_its_arguments_names(tmp_path, reach_document):
    """From Python the same limits name the arguments; 50 frames a second are written."""
    from armpath.errors import InvalidInputError
    from armpath.results import load_result

    source = tmp_path / "result.json"
    source.write_text(json.dumps(reach_document), encoding="utf-8")
    result = load_result(source)
    with pytest.raises(InvalidInputError, match=r"max_frames must be .* from 2 to 1000"):
        result.animate(tmp_path / "a.gif", max_frames=5000)
    assert result.animate(tmp_path / "a.gif", fps=50, max_frames=3) == 3


def test_energy_weights_beyond_the_limit_are_refused(tmp_path):
    """Weights of 1e308 made the weighted travel overflow to inf (a warning, then a result
    saying 'joint travel inf deg'); only their ratios matter, so they are capped."""
    _refused(
        tmp_path,
        ["plan", "--to-xyz", "300", "0", "200", "--objective", "energy", "--weights",
         "1e308,1,1,1,1,1"],
        "energy weights must be in [0, 1e+06]",
    )  # fmt: skip
    # all 0: every motion would cost nothing, so the objective would choose nothing
    _refused(
        tmp_path,
        ["plan", "--to-xyz", "300", "0", "200", "--objective", "energy", "--weights",
         "0,0,0,0,0,0"],
        "energy weights must not all be 0",
    )  # fmt: skip


def test_a_scenes_max_ticks_beyond_the_lattice_limit_is_refused_without_warnings(tmp_path):
    """max_ticks = 2**63 - 1 was cast to int64 (a RuntimeWarning, then the error echoed
    -9223372036854775808); the lattice checks the range before any cast, in a real process
    whose stderr is the one error line."""
    scene = tmp_path / "s.toml"
    scene.write_text('name = "s"\n[arm]\nmodel = "ur5"\nmax_ticks = 9223372036854775807\n')
    line = _refused(
        tmp_path, ["reach", "300", "100", "200", "--scene", str(scene)],
        "max ticks per command must be in [1, 1,000,000]", "9.223372036854776e+18",
        process=True,
    )  # fmt: skip
    assert "-9223372036854775808" not in line


@pytest.mark.parametrize("scale", [1e-300, 1e-200, 1.0, 1e200, 1e308])
def test_a_tool_axis_of_any_magnitude_is_its_direction(scale):
    """Directions are scaled by their largest component before they are normalised: 1e308
    overflowed to a zero vector and 1e-200 underflowed to one (both refused as zero)."""
    from armpath.cli.tasks import axis_rule
    from armpath.ik.target import AxisCone

    v = np.array([0.6, 0.0, -0.8]) * scale
    cone = AxisCone(v, 0.1)
    np.testing.assert_allclose(cone.direction, [0.6, 0.0, -0.8], atol=1e-15)
    rule = axis_rule(" ".join(repr(float(x)) for x in v), 5.0)
    np.testing.assert_allclose(rule.direction, [0.6, 0.0, -0.8], atol=1e-15)


def test_too_many_welds_for_every_order_are_counted_in_a_short_number(tmp_path):
    """501 welds have 501! orders: the refusal printed all 1,136 digits of it."""
    points = ", ".join(f"[{300 + i % 20}, {i // 20}, 300]" for i in range(501))
    scene = tmp_path / "welds.toml"
    scene.write_text(f'name = "many"\n[tasks.spotweld]\npoints_mm = [{points}]\n', "utf-8")
    line = _refused(tmp_path, ["spotweld", "--scene", str(scene), "--order", "auto"], "--order")
    assert "501 targets have 6.11e1136 visiting orders" in line and len(line) < 200
    nine = ", ".join(f"[{300 + i}, 0, 300]" for i in range(9))
    scene.write_text(f'name = "nine"\n[tasks.spotweld]\npoints_mm = [{nine}]\n', "utf-8")
    line = _refused(tmp_path, ["spotweld", "--scene", str(scene), "--order", "auto"], "--order")
    assert "9 targets have 362,880 visiting orders" in line  # 9!, every digit


# --- ik -------------------------------------------------------------------------------------


@pytest.mark.parametrize("seeds", ["0", "10001"])
def test_ik_seeds_beyond_the_solver_limit_are_refused(tmp_path, seeds):
    """Each numerical seed is a Levenberg-Marquardt run (iiwa14: about 0.8 ms); 100,000 took
    100 s, so the limit is 10,000."""
    xyz = ["--xyz", "400", "100", "300", "--model", "iiwa14"]
    proc = _run(["ik", *xyz, "--seeds", seeds], tmp_path)
    assert proc.returncode == 1 and proc.stdout == ""
    assert _error_line(proc) == f"error: --seeds must be in [1, 10000], got {seeds}"


def test_a_trajectory_of_too_many_joint_values_is_refused_before_its_samples(tmp_path):
    """64 joints over 9,990 s at 0.01 s periods (999,000 periods, within the period and command
    limits) held 3.1 GB and wrote 768 MB; periods times joints are capped, named with the
    options that set them, before any sample is built; 6 joints over the same time are not."""
    from armpath.budget import MAX_TRAJECTORY_VALUES

    header = "t," + ",".join(f"j{i}" for i in range(64))
    rows = ["0," + ",".join(["0"] * 64), "9990," + ",".join(["100"] * 64)]
    wp = _waypoints(tmp_path, "\n".join([header, *rows]) + "\n")
    _refused(
        tmp_path, ["trajectory", "--waypoints", wp],
        "joint values of the trajectory", "64 joints", "63,936,000",
        f"the limit is {MAX_TRAJECTORY_VALUES:,}", "--period",
    )  # fmt: skip
    from armpath.trajectory import minimum_snap
    from armpath.trajectory.quantize import quantize

    six = minimum_snap(np.radians([[0.0] * 6, [1.0] * 6]), [0.0, 9990.0])
    assert MAX_TRAJECTORY_VALUES >= 999_000 * 6
    assert quantize(six, 0.01).n_periods == 999_000
