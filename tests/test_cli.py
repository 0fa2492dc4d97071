"""The command line as a user runs it: real subprocesses, exit codes, files."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import independent
from cli_checks import error_lines

ARMPATH = [sys.executable, "-m", "armpath"]


def run(*args, cwd=None):
    return subprocess.run([*ARMPATH, *args], capture_output=True, text=True, cwd=cwd, timeout=600)


@pytest.mark.parametrize(
    "theta",
    [
        [30, -45, 60, 0, -30, 0],
        [-120, 20, -100, 45, 80, 10],
        [12.5, -33.3, 71.2, -150, 99.9, 45],  # not in SPEC
        [-400, 110, -20.5, 720, -130, 3],
    ],
)
def test_fk_json_matches_the_independent_model(theta):
    r = run("fk", *map(str, theta), "--json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    ref = independent.points(np.array(theta, float))
    for name, p in zip("ABCDE", ref, strict=True):
        np.testing.assert_allclose(doc["points"][name], p, atol=1e-9)
    np.testing.assert_allclose(doc["tip"], ref[4], atol=1e-9)


def test_fk_human_output_and_below_table_warning():
    r = run("fk", "400", "-125", "138", "-270", "133.5", "0")
    assert r.returncode == 0
    assert "-134.2679" in r.stdout and "198.6061" in r.stdout
    assert "below the table" in r.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["fk", "1", "2", "3"], "expected 6 numbers, got 3"),
        (["fk", "1", "2", "3", "nan", "4", "5"], "'nan' is not a finite number"),
        (["fk", "1", "2", "x", "0", "4", "5"], "'x' is not a number"),
        (["reach", "0", "0", "800"], "out of reach"),
        (["reach", "20", "-200", "120", "--from", "0", "-130", "0", "0", "-90", "0"], "joint 2"),
        (["reach", "20", "-200", "120", "--from", "-90", "-90", "0", "0", "-90", "0"], "collision"),
        (["reach", "20", "-200", "120", "--from", "0", "-90.05", "0", "0", "-90", "0"], "0.1 deg"),
        (["reach", "20", "-200"], "expected 3 numbers"),
        (["reach", "20", "-200", "120", "--bogus"], "no such option: --bogus"),
        (["fk", "1", "2", "3", "-x", "4", "5"], "no such option: -x"),
        (["reach", "20", "-inf", "120"], "'-inf' is not a finite number"),
        (["reach", "20", "-200", "120", "--tolerance", "0"], "tolerance"),
        # a tolerance without its rule was ignored
        (["reach", "20", "-200", "120", "--axis-tolerance", "5"], "give --tool-axis too"),
        (["reach", "20", "-200", "120", "--angle-tolerance", "5"], "give --pose too"),
    ],
)
def test_bad_input_gives_one_line_and_nonzero_exit(args, message, tmp_path):
    r = run(*args, "--out", str(tmp_path / "out")) if args[0] == "reach" else run(*args)
    usage = message.startswith("no such option")  # a usage error, as the parser's own: 2
    assert r.returncode == (2 if usage else 1), r.stdout + r.stderr
    lines = error_lines(r.stderr)
    assert len(lines) == 1 and lines[0].startswith("error: ")
    assert message in lines[0]
    assert not (tmp_path / "out").exists()
    assert list(tmp_path.iterdir()) == []  # no staging folder left behind


def _choices():
    """Per option with a fixed set of values: the command line before it, the option (None:
    the argument) and the values the code behind it accepts."""
    from armpath.cli.models import CONVERT_FORMATS
    from armpath.controller_export import FORMATS
    from armpath.ik.solve import METHODS as IK_METHODS
    from armpath.schemas import RESULT_KINDS
    from armpath.trajectory.minsnap import ORDERS, QP_SOLVERS
    from armpath.workspace.sampling import METHODS as SAMPLING_METHODS

    return [
        (["ik", "--xyz", "300", "200", "100"], "--method", IK_METHODS),
        (["workspace"], "--method", SAMPLING_METHODS),
        (["trajectory", "--waypoints", "wp.csv"], "--kind", tuple(ORDERS)),
        (["trajectory", "--waypoints", "wp.csv"], "--solver", QP_SOLVERS),
        (["rcm"], "--kind", tuple(ORDERS)),
        (["export", "reach.json"], "--format", FORMATS),
        (["schema"], None, RESULT_KINDS),
        (["model", "convert", "ur5", "--out", "x.json"], "--to", CONVERT_FORMATS),
    ]


@pytest.mark.parametrize("case", range(8))
def test_a_bad_choice_is_a_usage_error_and_help_lists_the_choices(case, tmp_path):
    """An option with a fixed set of values lists them in --help (the parser's choices, the
    same set the code behind it accepts) and refuses another value as the parser refuses
    ``--wall diagonal``: one error line naming the valid values, exit status 2, nothing
    written."""
    words, option, accepted = _choices()[case]
    command = words[:2] if words[0] == "model" else words[:1]  # a command group's command
    shown = subprocess.run(
        [*ARMPATH, *command, "--help"],
        capture_output=True,
        text=True,
        env={**os.environ, "COLUMNS": "200"},
        timeout=600,
    )
    assert shown.returncode == 0, shown.stderr
    line = next(ln for ln in shown.stdout.splitlines() if (option or "kind") in ln and "<" in ln)
    listed = re.search(r"<([^>]*)>", line)
    assert listed is not None and set(listed.group(1).split("|")) == set(accepted), line
    bad = ["bogus"] if option is None else [option, "bogus"]
    r = run(*words, *bad, cwd=tmp_path)
    assert r.returncode == 2, r.stdout + r.stderr
    lines = error_lines(r.stderr)
    assert len(lines) == 1 and lines[0].startswith("error: ") and "'bogus'" in lines[0]
    assert all(f"'{value}'" in lines[0] for value in accepted), lines[0]
    assert r.stdout == "" and list(tmp_path.iterdir()) == []


def test_unwritable_output_folder(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    r = run("reach", "20", "-200", "120", "--out", str(blocker / "sub"))
    assert r.returncode == 1
    assert r.stderr.startswith("error: ") and "not a folder" in r.stderr
    r = run("run", "--out", "/proc/armpath-out")
    assert r.returncode == 1 and "not writable" in r.stderr
    # it says where no folder can be made (it read "not writable: No such file or directory"
    # of /proc, which exists)
    assert "not writable: no folder can be made in /proc (" in r.stderr


def test_reach_writes_json_csv_xlsx_and_figures(tmp_path):
    out = tmp_path / "res"
    r = run("reach", "20", "-200", "120", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "provably fewest" in r.stdout
    names = sorted(p.name for p in out.iterdir())
    written = ["reach.csv", "reach.json", "reach.xlsx", "reach_joints.png", "reach_motion.png"]
    assert names == [".armpath-files", *written]
    assert (out / ".armpath-files").read_text().split() == written
    doc = json.loads((out / "reach.json").read_text())
    for key in (
        "initial_deg",
        "commands",
        "target",
        "tip",
        "error_mm",
        "n_commands",
        "min_clearance_mm",
        "lower_bound_commands",
        "model",
        "scene",
        "units",
    ):
        assert key in doc
    # the CSV replays to the same states as the JSON commands
    rows = (out / "reach.csv").read_text().strip().splitlines()
    header = rows[0].split(",")
    assert header[:7] == [
        "step",
        "d1_ticks",
        "d2_ticks",
        "d3_ticks",
        "d4_ticks",
        "d5_ticks",
        "d6_ticks",
    ]
    table = np.array([[float(v) for v in row.split(",")] for row in rows[1:]])
    assert len(table) == doc["n_commands"]
    np.testing.assert_array_equal(table[:, 1:7], doc["commands"])
    states = independent.replay(doc["initial_deg"], doc["commands"])
    np.testing.assert_allclose(table[:, 7:13], states[1:], atol=1e-9)
    np.testing.assert_allclose(table[-1, 13:16], doc["tip"], atol=1e-5)
    from openpyxl import load_workbook

    wb = load_workbook(out / "reach.xlsx")
    assert wb["commands"].max_row == doc["n_commands"] + 1
    # the summary sheet holds the JSON's numbers as the JSON writes them (75.0, where it held
    # 75.00000000000006)
    summary = {row[0]: row[1] for row in wb["summary"].iter_rows(min_row=2, values_only=True)}
    for key in ("min_clearance_mm", "error_mm", "n_commands"):
        assert summary[key] == doc[key], key
    assert (out / "reach_motion.png").read_bytes()[:4] == b"\x89PNG"


def test_a_second_run_into_the_same_folder_leaves_no_stale_files(tmp_path):
    out = tmp_path / "res"
    first = run("plan", "--to", "10", "-80", "10", "0", "-80", "0", "--out", str(out), "--animate")
    assert first.returncode == 0, first.stderr
    (out / "my_notes.txt").write_text("mine")
    assert (out / "plan.gif").exists()
    second = run("plan", "--to", "20", "-80", "10", "0", "-80", "0", "--out", str(out))
    assert second.returncode == 0, second.stderr
    names = sorted(p.name for p in out.iterdir())
    # the earlier run's animation is gone (this run wrote none); the user's file stays
    assert "plan.gif" not in names and "my_notes.txt" in names
    # and says so: the removed file named, no other (it did not say, and a reach's results
    # went from a folder a plan was then written to without a word)
    removed = [line for line in second.stdout.splitlines() if line.startswith("removed ")]
    assert removed == [f"removed {out / 'plan.gif'} (an earlier command's result in this folder)"]
    doc = json.loads((out / "plan.json").read_text())
    assert doc["final_deg"] == [20.0, -80.0, 10.0, 0.0, -80.0, 0.0]


@pytest.mark.slow
def test_reach_json_on_stdout_from_another_start():
    r = run("reach", "300", "250", "300", "--from", "90", "-40", "60", "30", "-45", "10", "--json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["initial_deg"] == [90, -40, 60, 30, -45, 10]
    tip = independent.points(independent.replay(doc["initial_deg"], doc["commands"])[-1])[4]
    assert np.linalg.norm(tip - [300, 250, 300]) <= 0.05


def test_reach_without_a_point_goes_to_the_scenes_target(tmp_path):
    """``armpath trace`` and ``spotweld`` take the scene's task by default, but ``reach`` made
    its X Y Z required ("Missing argument"), though a scene names its ``[tasks.reach]``
    target. Without X Y Z it is now the scene's target (the seed's Task 1: 63 commands to
    (20, -200, 120) mm, replayed on the independent kinematics); a scene that names none is
    refused in one line saying what to give."""
    from cli_in_process import run_in_process

    r = run_in_process(["reach", "--json"], tmp_path)
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["n_commands"] == 63 and doc["target"] == [20.0, -200.0, 120.0]
    tip = independent.points(independent.replay(doc["initial_deg"], doc["commands"])[-1])[4]
    assert np.linalg.norm(tip - [20, -200, 120]) <= 0.05
    (tmp_path / "bare.toml").write_text('name = "bare"\n', encoding="utf-8")
    r = run_in_process(["reach", "--scene", "bare.toml"], tmp_path)
    assert r.returncode == 1 and error_lines(r.stderr) == [
        "error: give the target X Y Z (mm): scene bare.toml names no [tasks.reach] target_mm"
    ]


def test_reach_above_its_bound_says_why_fewer_were_not_taken(tmp_path):
    """The UR5 cell to a point whose least-change members (54 commands) put the arm into the
    table: the summary's "fewer commands" row says why each count below the plan's was
    refused, consecutive counts with one reason as a range, as the JSON lists them."""
    from armpath.cli.tasks import _rejected_text

    scene = os.path.join(os.path.dirname(__file__), "..", "examples", "ur5_cell.toml")
    r = run("reach", "410", "-200", "150", "--scene", scene, "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "out" / "reach.json").read_text())
    rejected = doc["fewer_commands_rejected"]
    assert doc["n_commands"] > doc["lower_bound_commands"] and rejected
    counts = [int(m.group(1)) for t in rejected if (m := re.match(r"(\d+) commands: ", t))]
    assert counts == list(range(doc["lower_bound_commands"], counts[-1] + 1))
    words = " ".join(r.stdout.replace("│", " ").split())
    assert "fewer commands " + " ".join(_rejected_text(tuple(rejected)).split()) in words
    # the grouping itself: ranges of equal reasons, other reasons and gaps kept apart
    reasons = ("5 commands: a", "6 commands: a", "7 commands: b", "9 commands: b", "searched")
    assert _rejected_text(reasons) == "5-6 commands: a; 7 commands: b; 9 commands: b; searched"


def test_run_writes_every_task_and_a_summary(seed_run):
    from armpath.report import arc_ends

    out, stdout = seed_run
    names = {p.name for p in out.iterdir()}
    for stem in ("reach", "spotweld"):
        assert {f"{stem}.json", f"{stem}.csv", f"{stem}.xlsx", f"{stem}_motion.png"} <= names
    assert "summary.md" in names
    doc = json.loads((out / "reach.json").read_text())
    assert doc["n_commands"] <= 63 and doc["error_mm"] <= 0.05
    weld = json.loads((out / "spotweld.json").read_text())
    assert "63" in stdout and str(weld["n_commands"]) in stdout
    summary = (out / "summary.md").read_text()
    assert "Task 1" in summary and "Task 3" in summary
    # the report shows every figure and animation it names, and they were written
    for name in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", summary):
        assert name in names, name
    assert {"reach.gif", "trace.gif", "spotweld.gif"} <= names
    assert "## Task 2: trace the crack" in summary and "unreachable 382.8" in summary
    # every arc not covered, with its reason, in the summary and on stdout
    trace = json.loads((out / "trace.json").read_text())
    for arc in trace["unreachable"] + trace["not_traced"]:
        start, end = arc_ends(arc, trace)  # within the length of a closed curve
        span = f"{start:.2f}..{end:.2f}"
        assert span in summary and arc["reason"] in summary and span in stdout
    # the blind-zone summary: the central blind zone and both workpiece faces
    assert {"blind_maps.png", "face_blindness.png", "blindzones.csv"} <= names
    assert "central blind zone" in summary and "inner face" in summary
    assert "Blind zones: central blind zone" in stdout
    rows = (out / "blindzones.csv").read_text().splitlines()
    assert rows[0] == "face,height_mm,circumference_mm,unreachable_mm" and len(rows) == 7


@pytest.mark.slow
def test_spotweld_horizontal_wall_given_order(tmp_path):
    r = run(
        "spotweld", "--wall", "horizontal", "--order", "given", "--no-bound", "--no-pools",
        "--json", "--out", str(tmp_path),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert json.loads((tmp_path / "spotweld.json").read_text()) == doc
    assert doc["wall_thickness"] == "horizontal" and doc["order"] == [1, 2, 3, 4]
    # --no-bound: the plan and its goal states' bound only (--no-pools: the guided plan, sooner)
    assert doc["lower_bound"] is None and doc["lower_bound_commands"] is None
    assert 0 < doc["goal_states_bound_commands"] <= doc["n_commands"]
    targets = np.array(doc["targets"])
    # horizontal convention: the inner radius is 8 mm (not 8.616) inside the outer one
    r_in = 168 - 0.4 * targets[:, 2] - 8.0
    np.testing.assert_allclose(np.hypot(targets[:, 0] - 210, targets[:, 1]), r_in, atol=1e-9)
    states = independent.replay(doc["initial_deg"], doc["commands"])
    for v in doc["visits"]:
        tip = independent.points(states[v["after_command"]])[4]
        assert np.linalg.norm(tip - v["target"]) <= 0.05
    assert doc["clearance"]["certified"]


def test_choices_are_listed_and_a_wrong_one_is_a_usage_error(tmp_path):
    r = run("reach", "20", "-200", "120", "--wall", "diagonal", "--out", str(tmp_path / "o"))
    assert r.returncode == 2
    (line,) = error_lines(r.stderr)  # one line, like every error
    assert line.startswith(
        "error: Invalid value for '--wall': 'diagonal' is not one of 'normal', 'horizontal'. (see:"
    ) and line.endswith(" reach --help)")
    assert list(tmp_path.iterdir()) == []
    h = run("reach", "--help")
    assert "<normal|horizontal>" in h.stdout and "<bool>" not in h.stdout
    assert "--from" in h.stdout and "θ1 … θn" in h.stdout  # one number per joint
    assert "X Y Z" in h.stdout and "float,float" not in h.stdout


@pytest.mark.parametrize("empty", [["--out", ""], ["--out="], ["--scene", ""]])
def test_an_empty_option_value_is_a_usage_error_and_writes_nothing(tmp_path, empty):
    """``--out ""`` would be the current folder: refused before any work, nothing written."""
    r = run("reach", "20", "-200", "120", *empty, cwd=tmp_path)
    assert r.returncode == 2
    (line,) = error_lines(r.stderr)
    assert line == f"error: {empty[0].rstrip('=')} was given an empty value (see: armpath --help)"
    assert list(tmp_path.iterdir()) == []


def test_plan_and_spotweld_errors():
    r = run("spotweld", "--order", "random")  # a usage error: the parser's status 2
    assert r.returncode == 2 and "'random' is not one of 'auto', 'given'" in r.stderr
    assert len(error_lines(r.stderr)) == 1
    r = run("plan", "--to", "0", "-90", "0", "0", "-90", "0", "--to-xyz", "1", "2", "3")
    assert r.returncode == 1 and "exactly one goal" in r.stderr
    r = run("plan", "--to", "0", "120", "60", "0", "0", "0")
    assert r.returncode == 1 and "goal state is in collision" in r.stderr
    r = run("plan", "--to-xyz", "5000", "0", "0")
    assert r.returncode == 1 and error_lines(r.stderr) == [
        "error: target (5000, 0, 0) mm is out of reach within the joint limits: the nearest "
        "reachable point (574.77, 0.00, 123.91) mm is 4426.960 mm away"
    ]
    # the nearest point of the seed arm's reach sphere (B + 575 mm toward the target), by hand
    b = np.array([0.0, 0.0, 140.0])
    d = np.array([5000.0, 0.0, 0.0]) - b
    assert np.linalg.norm(d) - 575.0 == pytest.approx(4426.960, abs=1e-3)
    np.testing.assert_allclose(b + 575.0 * d / np.linalg.norm(d), [574.77, 0.0, 123.91], atol=5e-3)


def test_help_texts_state_units():
    r = run("--help")
    assert r.returncode == 0 and "deg" in r.stdout and "mm" in r.stdout
    r = run("reach", "--help")
    assert "--from" in r.stdout and "--tolerance" in r.stdout


def test_plan_to_an_unreachable_point_names_the_nearest_for_any_arm():
    """Another arm's plan --to-xyz named no nearest point (reach did); the point it names lies
    at the stated distance, and that distance is the least found by an independent search."""
    from armpath.kinematics import tool_position
    from armpath.model.catalog import resolve_model

    r = run("plan", "--model", "painter004", "--to-xyz", "300", "0", "300")
    (line,) = error_lines(r.stderr)
    assert r.returncode == 1 and "out of reach within the joint limits" in line
    found = re.search(r"nearest reachable point \(([^)]*)\) mm is ([0-9.]+) mm away", line)
    assert found is not None, line
    point = np.array([float(v) for v in found.group(1).split(",")])
    assert np.linalg.norm(point - [300.0, 0.0, 300.0]) == pytest.approx(
        float(found.group(2)), abs=0.01
    )
    # independently: the least distance over the joint limits from 40 random starts (scipy)
    from scipy.optimize import minimize

    arm = resolve_model("painter004")
    lo = np.where(np.isfinite(arm.lower), arm.lower, -np.pi)
    hi = np.where(np.isfinite(arm.upper), arm.upper, np.pi)
    target = np.array([300.0, 0.0, 300.0])
    rng = np.random.default_rng(0)
    best = min(
        minimize(
            lambda q: float(np.linalg.norm(tool_position(arm, q) - target)),
            rng.uniform(lo, hi),
            bounds=list(zip(lo, hi, strict=True)),
            method="L-BFGS-B",
        ).fun
        for _ in range(40)
    )
    assert float(found.group(2)) == pytest.approx(best, abs=0.01)


def test_a_proven_bound_the_plan_meets_is_reported_as_the_fewest():
    """Summary and report say a plan that meets its proven bound has the fewest commands, and
    give the gap otherwise; an estimate is never called the fewest."""
    from armpath.cli.tasks import _bound_text
    from armpath.report import _bound_words

    met = {"commands": 107, "gap_commands": 0, "gap_percent": 0.0, "proven": True,
           "sampling": {"lattice_goal_states": 9238.0}}  # fmt: skip
    above = {**met, "gap_commands": 5, "gap_percent": 4.67}
    guess = {**met, "proven": False}
    assert "the plan meets it: the fewest commands" in _bound_text(met, "every order")
    assert "plan 5 above it (4.7 %)" in _bound_text(above, "every order")
    assert "fewest" not in _bound_text(guess, "every order")
    assert "the fewest commands" in _bound_words({"lower_bound": met})
    assert "plan 5 above it" in _bound_words({"lower_bound": above})
    assert "fewest" not in _bound_words({"lower_bound": guess})
    # above an estimate the difference is in commands, never a percentage read as a gap
    # (a Baxter circle printed "plan 43 above it (330.8 %)")
    rough = {**guess, "gap_commands": 43, "gap_percent": 330.77}
    for text in (_bound_text(rough, "one pass"), _bound_words({"lower_bound": rough})):
        assert "plan 43 above the estimate" in text and "%" not in text
    # a bound that is mostly sampling error says so (a reviewer's 6-axis arm: >= 2 against 59)
    sampled = {"commands": 2, "value_commands": 2.0, "gap_commands": 57, "gap_percent": 2850.0,
               "proven": True, "sampling": {"largest_error_on_path_commands": 29.59}}  # fmt: skip
    assert "weak: 29.6 commands of sampling error" in _bound_text(sampled, "every order")
    tight = {**sampled, "commands": 103, "value_commands": 102.5,
             "sampling": {"largest_error_on_path_commands": 1.11}}  # fmt: skip
    assert "weak" not in _bound_text(tight, "one pass")


def test_a_bound_the_plan_undercuts_is_reported_refuted_with_why():
    """A sampled bound above the plan's commands is no lower bound (the SO-101's welds: 45
    "proven" against a tour of 31, printed as "plan -14 above it"). It is kept as an estimate
    that says it was refuted, with the audit's reason where there was one, and the words say
    the plan lies below it; a bound the plan does not undercut is returned as it is."""
    from armpath.cli.tasks import _bound_text
    from armpath.planning.bounds.value import CommandBound
    from armpath.report import _bound_words

    proven = CommandBound(45, 44.2, "the family")
    assert proven.against_plan(45) is proven and proven.against_plan(60) is proven
    refuted = proven.against_plan(31)
    assert not refuted.proven and refuted.commands == 45
    assert refuted.unproven_because.startswith("refuted by a plan of 31 commands")
    audited = CommandBound(45, 44.2, "the family", unproven_because="261 lie out")
    assert audited.against_plan(31).unproven_because.endswith("; 261 lie out")
    doc = {**refuted.describe(), "gap_commands": -14, "gap_percent": -31.11}
    assert doc["proven"] is False and doc["unproven_because"] == refuted.unproven_because
    for text in (_bound_text(doc, "every order"), _bound_words({"lower_bound": doc})):
        assert "plan 14 below it: no lower bound" in text and "above it" not in text
        assert "refuted by a plan of 31 commands" in text and "self-motion" not in text


def test_huge_joint_values_print_in_exponent_form_and_a_zero_tool_axis_is_named():
    """``fk 1e300 0 0 0 0 0`` printed the angle's 301 digits in its header; a zero tool axis
    was called a 'cone direction' (from a review of the command line)."""
    r = run("fk", "1e300", "0", "0", "0", "0", "0")
    assert r.returncode == 0 and "1.000e+300" in r.stdout
    assert max(len(line) for line in r.stdout.splitlines()) < 120
    r = run("plan", "--to-xyz", "300", "0", "200", "--tool-axis", "0", "0", "0")
    assert r.returncode == 1 and "the tool-axis direction (--tool-axis" in r.stderr


def test_an_arm_named_with_brackets_keeps_them_in_the_table_titles(tmp_path):
    """A URDF arm is named with its tip link ("bot [f]"): the tables read the brackets as
    markup and showed "bot "."""
    from cli_in_process import run_in_process

    (tmp_path / "bot.urdf").write_text(
        '<robot name="bot"><link name="b"/><link name="f"/>'
        '<joint name="j1" type="revolute"><parent link="b"/><child link="f"/>'
        '<origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint></robot>'
    )
    for args in (["fk", "--model", "bot.urdf", "10"], ["model", "show", "bot.urdf"]):
        r = run_in_process(args, tmp_path)
        assert r.returncode == 0, r.stderr
        assert "bot [f]" in r.stdout


def test_an_arc_through_a_closed_curves_start_says_so():
    """A pass round the seed crack printed 'arc 483.07 .. 382.87 mm (765.75 mm ...)', which reads
    like the 100 mm between them; an arc that runs on past a closed curve's 0 mm now says it
    goes through it, one all round says so, one within the curve does not, nor one of an open
    curve."""
    from armpath.report import arc_text

    closed = {"curve": {"closed": True, "length_mm": 865.95}}
    assert arc_text({"start_mm": 483.07, "end_mm": 1248.82}, closed) == (
        "arc 483.07 .. 382.87 mm, through 0 mm"
    )
    assert arc_text({"start_mm": 10.0, "end_mm": 20.0}, closed) == "arc 10.00 .. 20.00 mm"
    # a pass once round that runs on 0.2 mm past where it began read as a 0.2 mm arc
    assert arc_text({"start_mm": 483.07, "end_mm": 483.07 + 865.95 + 0.2}, closed) == (
        "arc once round from 483.07 mm"
    )
    assert arc_text({"start_mm": 483.07, "end_mm": 483.07 + 865.95 - 0.01}, closed) == (
        "arc 483.07 .. 483.06 mm, through 0 mm"  # 0.01 mm short of once round
    )
    opened = {"curve": {"closed": False, "length_mm": 865.95}}
    assert arc_text({"start_mm": 10.0, "end_mm": 20.0}, opened) == "arc 10.00 .. 20.00 mm"


def test_trace_and_spotweld_start_where_from_says(tmp_path):
    """An arm whose home pose collides was told to start elsewhere with --from, which trace and
    spotweld did not have (the Python API's start_deg). Both take it now: the result starts
    there (its initial_deg; the independent replay of its first command begins there and
    moves by it); a --from of the wrong length is one error line."""
    (tmp_path / "cell.toml").write_text(
        'name = "free"\n[tasks.trace]\ncurve = { type = "polyline", points_mm = '
        "[[0, 480, 150], [30, 480, 150]] }\n[tasks.spotweld]\npoints_mm = [[20, 470, 140]]\n"
    )
    start = [10.0, -80.0, 5.0, 0.0, -90.0, 0.0]
    for task in ("trace", "spotweld"):
        r = run(task, "--scene", "cell.toml", "--from", *map(str, start), "--no-bound", "--json",
                cwd=tmp_path)  # fmt: skip
        assert r.returncode == 0, r.stderr
        doc = json.loads(r.stdout)
        assert doc["initial_deg"] == start
        states = independent.replay(start, doc["commands"][:1])
        assert len(states) == 2 and np.allclose(states[0], start)
    bad = run("trace", "--scene", "cell.toml", "--from", "0", "-80", cwd=tmp_path)
    assert bad.returncode != 0
    assert bad.stderr.strip().splitlines()[-1].startswith("error: --from (6 joint values")


def test_armpath_alone_prints_its_help_and_no_error():
    """``armpath`` with no command printed its help, then "error:  (see: armpath --help)" (an
    empty message) with exit status 2; now its help alone, status 0, as ``armpath model``
    does. An unknown command is still one error line."""
    r = run()
    assert r.returncode == 0 and "error" not in r.stderr
    assert "Commands" in r.stdout and "trace" in r.stdout
    bad = run("bogus")
    assert bad.returncode == 2
    assert bad.stderr.strip().splitlines() == [
        "error: No such command 'bogus'. (see: armpath --help)"
    ]


def test_a_trajectory_without_a_model_warns_of_waypoints_beyond_the_seed_arms_limits(tmp_path):
    """Without --model no joint limits apply (any number of joints): six columns with joint 2
    at -200 deg went through without a word, while --model seed refuses them. Now a warning
    names the waypoint, the joint and the seed arm's limits; within them, none."""
    (tmp_path / "off.csv").write_text("0,0,0,0,0,0\n10,-200,0,0,0,0\n")
    (tmp_path / "on.csv").write_text("0,0,0,0,0,0\n10,-100,0,0,0,0\n")
    off = run("trajectory", "--waypoints", "off.csv", cwd=tmp_path)
    assert off.returncode == 0, off.stderr
    said = " ".join(off.stderr.split())
    assert (
        "no joint limits are checked without --model: waypoint 2: joint 2 (theta2) = -200 deg "
        "is outside its limits [-125, 125] deg, the seed arm's" in said
    )
    on = run("trajectory", "--waypoints", "on.csv", cwd=tmp_path)
    assert on.returncode == 0 and "warning" not in on.stderr
    strict = run("trajectory", "--waypoints", "off.csv", "--model", "seed", cwd=tmp_path)
    assert strict.returncode != 0 and "outside its limits" in strict.stderr


def test_a_curve_too_long_to_scan_names_the_scan_step_option(tmp_path):
    """A 120 m curve scanned every 4 mm needs 30,000 points (the limit 25,000): the refusal
    named TraceOptions.scan_step_mm in Python only; trace has --scan-step now, named there,
    and a scan step of 0 or inf is one error line naming it. (Every 8 mm, the scan's size within the
    limit, the part of the curve near the arm is traced: about 40 s, not run here.)"""
    (tmp_path / "long.csv").write_text("x,y,z\n0,300,200\n60000,300,200\n120000,300,200\n")
    base = ("trace", "--curve", "long.csv", "--scene", "none", "--no-bound")
    too_long = run(*base, cwd=tmp_path)
    assert too_long.returncode != 0
    line = too_long.stderr.strip().splitlines()[-1]
    assert "would need 30,000 (the limit is 25,000)" in line and "--scan-step" in line
    for bad in ("0", "inf"):
        refused = run(*base, "--scan-step", bad, cwd=tmp_path)
        assert refused.returncode != 0
        assert refused.stderr.strip().splitlines() == [
            f"error: --scan-step must be a finite length > 0 mm, got {bad}"
        ]


def test_waypoints_that_do_not_move_are_refused_unless_timed(tmp_path):
    """Two identical waypoints were timed at 0.001 s with a warning about the period; with no
    motion to time they are refused in one line. With a column of times the arm is held still
    that long (2 s, every lattice error 0)."""
    (tmp_path / "same.csv").write_text("0,0,0,0,0,0\n0,0,0,0,0,0\n")
    (tmp_path / "hold.csv").write_text("t,a,b\n0,0,0\n2,0,0\n")
    same = run("trajectory", "--waypoints", "same.csv", cwd=tmp_path)
    assert same.returncode == 1
    (line,) = same.stderr.strip().splitlines()
    assert line.startswith("error: --waypoints same.csv: every row is the same")
    hold = run("trajectory", "--waypoints", "hold.csv", cwd=tmp_path)
    assert hold.returncode == 0, hold.stderr
    assert re.search(r"duration\s+2\.000\s+s", hold.stdout)


def test_a_table_separated_by_semicolons_says_so(tmp_path):
    """Values separated by ';' were read as one column name per line: the first line taken
    silently as a header and the error pointing at line 2. Now line 1 is named and the
    separators to use."""
    (tmp_path / "semi.csv").write_text("0;300;200\n10;300;200\n")
    r = run("trace", "--curve", "semi.csv", "--scene", "none", cwd=tmp_path)
    assert r.returncode != 0
    assert r.stderr.strip().splitlines()[-1] == (
        "error: --curve semi.csv: line 1 has values separated by ';'; separate them by commas "
        "or spaces"
    )


@pytest.mark.slow
def test_a_weld_listed_twice_is_one_warning_line(tmp_path):
    """A warning raised while a task runs is said as the command line says warnings, one
    ``warning:`` line (not Python's file and line), and the tour still visits every weld."""
    (tmp_path / "dup.toml").write_text(
        'name = "dup"\n[arm]\nmodel = "ur5"\n[tasks.spotweld]\n'
        "points_mm = [[400, 100, 300], [300, -200, 400], [400, 100, 300]]\n"
    )
    r = run(
        "spotweld",
        "--scene",
        "dup.toml",
        "--no-bound",
        "--order",
        "given",
        "--no-pools",
        "--json",
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    warned = [line for line in r.stderr.splitlines() if "listed twice" in line]
    assert len(warned) == 1 and warned[0].startswith("warning: targets 1 and 3 (0.000 mm apart)")
    assert "ArmpathWarning" not in r.stderr
    doc = json.loads(r.stdout)
    assert len(doc["visits"]) == 3


@pytest.mark.slow  # 16 s: the UR5 cell's tour with the axis rule, through the CLI
def test_a_weld_the_axis_rule_keeps_out_of_clearance_names_the_rule(tmp_path):
    """The UR5 cell's fourth weld, (450, 95, 100) mm, beside the clamp: the arm reaches it
    clear (an 80-command plan), but with the torch within 10 deg of the surface normal its
    120 mm torch runs into the clamp. The error named the clearance alone, as if the weld
    could not be reached clear at all; it now names the rule too."""
    cell = str(Path(__file__).parents[1] / "examples" / "ur5_cell.toml")
    free = run("reach", "450", "95", "100", "--scene", cell, "--out", str(tmp_path / "free"))
    assert free.returncode == 0, free.stderr
    ruled = run(
        "reach", "450", "95", "100", "--scene", cell, "--out", str(tmp_path / "ruled"),
        "--tool-axis", "0", "-0.9701", "-0.2425", "--axis-tolerance", "10",
    )  # fmt: skip
    assert ruled.returncode == 1 and not (tmp_path / "ruled").exists()
    (line,) = [x for x in ruled.stderr.splitlines() if x.startswith("error:")]
    assert line.startswith(
        "error: no configuration reaching (450, 95, 100) mm with its tool axis within 10 deg "
        "of (0, -0.9701, -0.2425) keeps the links 1 mm clear of the obstacles"
    )


def test_spotweld_along_the_normal_refuses_a_weld_on_no_surface(tmp_path):
    """``--tool-axis normal`` took the normal of the nearest obstacle however far the weld lay
    from it (a weld 100 mm above a table in free space was planned with the table's normal,
    exit 0); trace refuses a curve on no surface, and spotweld now refuses such a weld the
    same way, naming how far it lies from the nearest surface."""
    scene = tmp_path / "one_weld.toml"
    scene.write_text(
        'name = "one weld"\n[[obstacles]]\ntype = "half_space"\nname = "table"\n'
        "point = [0, 0, 0]\nnormal = [0, 0, 1]\n[tasks.spotweld]\npoints_mm = [[300, 0, 100]]\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    r = run("spotweld", "--scene", str(scene), "--tool-axis", "normal", "--no-bound",
            "--out", str(out))  # fmt: skip
    assert r.returncode == 1 and not out.exists()
    assert r.stderr.strip().splitlines()[-1] == (
        "error: a tool axis along the surface normal needs each weld on an obstacle's surface "
        "(within 5 mm); the weld at (300, 0, 100) mm lies 100.0 mm from the nearest, table"
    )


@pytest.mark.slow  # 15 s: a tour of two welds and back, bounded and replayed, through the CLI
def test_a_tour_back_to_the_start_in_the_order_given_says_both(tmp_path):
    """``spotweld --order given --return`` bounds the given order alone, back to the start, but
    its table said "every order" and had no row for the way back (the seed's Task 3: 282
    commands, its last weld after command 214). Two welds: the bound row names the order
    given and the way back, a row gives the way back's commands, and the independent replay
    of the commands visits each weld where the table says and ends where it began."""
    scene = tmp_path / "two.toml"
    scene.write_text(
        'name = "two welds"\n[[obstacles]]\ntype = "half_space"\nname = "floor"\n'
        "point = [0, 0, -50]\nnormal = [0, 0, 1]\n[tasks.spotweld]\n"
        "points_mm = [[300, 0, 200], [250, 150, 250]]\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    r = run("spotweld", "--scene", str(scene), "--order", "given", "--return", "--out", str(out))
    assert r.returncode == 0, r.stderr
    rows = [line.split("│") for line in r.stdout.splitlines() if line.count("│") == 3]
    values = " ".join(" ".join(cells[2].split()) for cells in rows if cells[2].strip())
    assert "(the order given, back to the start, every lattice goal state" in values
    doc = json.loads((out / "spotweld.json").read_text(encoding="utf-8"))
    states = independent.replay(doc["initial_deg"], doc["commands"])
    for v in doc["visits"]:
        tip = independent.points(states[v["after_command"]])[4]
        assert np.linalg.norm(tip - v["target"]) <= doc["tolerance_mm"]
    np.testing.assert_allclose(states[-1], doc["initial_deg"], atol=1e-9)
    last = doc["visits"][-1]["after_command"]
    assert doc["n_commands"] > last
    assert re.search(
        rf"back to the start\s*│\s*commands {last + 1}-{doc['n_commands']}\b", r.stdout
    )
    assert doc["lower_bound"]["commands"] <= doc["n_commands"]


def test_a_seed_reach_too_tight_for_the_lattice_names_the_nearest_error_found(tmp_path):
    """The seed arm's reach at 0.001 mm said only "a wider tolerance finds one"; the refusal
    now names the smallest error of the lattice states it looked at, as other arms' refusals
    do, and a tolerance that admits it (rounded up), which plans the reach: its independent
    replay ends within it. The nearest named is the least of every search that ran (it named
    0.0137 mm, the goal states' alone, and "allow at least that", where the search at more
    commands had found 0.0018 mm)."""
    r = run("reach", "300", "100", "200", "--tolerance", "0.001", "--out", str(tmp_path / "a"))
    assert r.returncode == 1 and r.stderr.count("error:") == 1
    found = re.search(
        r"the nearest found is ([0-9.e-]+) mm away: a tolerance of ([0-9.e-]+) mm admits it",
        r.stderr,
    )
    assert found is not None, r.stderr
    nearest, allowed = float(found.group(1)), float(found.group(2))
    assert 0.001 < nearest <= allowed < 0.0025
    out = tmp_path / "b"
    r = run("reach", "300", "100", "200", "--tolerance", found.group(2), "--out", str(out))
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "reach.json").read_text(encoding="utf-8"))
    tip = independent.points(independent.replay(doc["initial_deg"], doc["commands"])[-1])[4]
    assert np.linalg.norm(tip - [300.0, 100.0, 200.0]) <= allowed + 1e-9
