"""CLI habits (issue 19, item 6): --version, -v/--verbose progress, shell completion, --seed
wherever randomness enters."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import independent_replay as ir
from armpath import __version__


def _cli(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "armpath", *args],
        capture_output=True,
        text=True,
        env={**os.environ, **(env or {})},
    )


def test_version():
    r = _cli("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"armpath {__version__}"


def test_verbose_prints_timed_progress_from_the_start():
    r = _cli("-v", "reach", "300", "100", "200", "--json")
    assert r.returncode == 0, r.stderr
    lines = r.stderr.splitlines()
    assert lines and all(re.match(r"armpath: \[\s*\d+\.\d s\] ", line) for line in lines)
    assert lines[0].startswith("armpath: [   0.0 s] planning the reach")
    json.loads(r.stdout)  # stdout keeps only the result


def test_shell_completion_completes_commands_and_subcommands():
    """The installed ``armpath`` script answers the shell's completion requests."""
    script = str(Path(sys.executable).parent / "armpath")

    def complete(words: str, index: int) -> list[str]:
        env = {
            **os.environ,
            "_ARMPATH_COMPLETE": "complete_bash",
            "COMP_WORDS": words,
            "COMP_CWORD": str(index),
        }
        return subprocess.run([script], capture_output=True, text=True, env=env).stdout.split()

    assert complete("armpath mo", 1) == ["model"]
    assert complete("armpath model c", 2) == ["convert"]
    assert {"reach", "trace", "export", "schema"} <= set(complete("armpath ", 1))
    # Typer names the shell from the process's ancestors (shellingham) and then ignores the
    # argument; a test run started outside any shell has none. Its test switch makes the
    # shell an argument instead.
    shown = _cli(
        "--show-completion", "bash", env={"_TYPER_COMPLETE_TEST_DISABLE_SHELL_DETECTION": "1"}
    )
    assert shown.returncode == 0 and "_ARMPATH_COMPLETE" in shown.stdout


@pytest.mark.parametrize("command", ["run", "reach", "plan", "trace", "spotweld", "workspace"])
def test_every_command_with_randomness_takes_a_seed(command):
    r = _cli(command, "--help")
    assert r.returncode == 0 and "--seed" in r.stdout


@pytest.mark.parametrize(
    ("command", "default"), [("reach", "0.05"), ("spotweld", "0.05"), ("trace", "0.1")]
)
def test_the_tolerance_help_names_the_scene_key(command, default):
    """--tolerance's help names the scene key it defaults to; written unescaped, the rich
    help took "[tasks.reach]" for markup and printed "the scene's  tolerance_mm"."""
    r = _cli(command, "--help", env={"COLUMNS": "200"})
    text = " ".join(r.stdout.replace("│", " ").split())
    assert f"Default: the scene's [tasks.{command}] tolerance_mm, else {default}." in text


def test_reach_seeds_give_replayable_results():
    """Another seed may take another path through the search; every seed's result replays."""
    for seed in ("0", "7"):
        r = _cli("reach", "20", "-200", "120", "--seed", seed, "--json")
        assert r.returncode == 0, r.stderr
        doc = json.loads(r.stdout)
        rep = ir.replay_result(doc, truth=ir.Truth(target=[20, -200, 120], tolerance=0.05))
        assert rep.ok, rep.problems
        assert doc["n_commands"] == doc["lower_bound_commands"] == 63


def test_a_stage_begun_before_the_progress_delay_is_shown_when_it_passes(capsys, monkeypatch):
    """Progress lines start after PROGRESS_DELAY_S when stderr is not a terminal; a stage that
    began before then and runs on is printed at the delay (a long curve's scan, begun at
    0.4 s, printed nothing for minutes), and a command done before the delay prints nothing."""
    import time

    from armpath.cli import common

    monkeypatch.setattr(common, "PROGRESS_DELAY_S", 0.3)
    with common.progress("working") as say:
        say("quick")
    time.sleep(0.5)
    assert capsys.readouterr().err == ""
    with common.progress("working") as say:
        say("scanning")
        time.sleep(0.6)  # the stage runs on past the delay, no new message
        err = capsys.readouterr().err
        say("scanning")  # the same message again is not repeated
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("armpath: [") and lines[0].endswith("scanning")
    assert 0.3 <= float(lines[0].split("[")[1].split(" s]")[0]) < 0.6
    assert capsys.readouterr().err == ""


def test_the_reports_files_list_only_what_was_written():
    """A run of a scene with a trace task alone listed spotweld.json, the blind zones' files and
    'the three motions' among its files (from a review of the command line)."""
    from armpath.report import summary_markdown

    text = summary_markdown([], files=["trace.json", "trace.csv", "trace.gif", "summary.md"])
    files = text.split("## Files", 1)[1]
    assert "`trace.json`" in files and "`*.csv / *.xlsx`" in files and "`*.gif`" in files
    assert "spotweld.json" not in files and "blindzones" not in files and "reach.json" not in files
    # the figures and the web page are listed where they were written (they were not at all)
    assert "`*.png`" not in files and "summary.html" not in files
    text = summary_markdown([], files=["trace.json", "trace_3d.png", "summary.md", "summary.html"])
    files = text.split("## Files", 1)[1]
    assert "- `*.png`: figures" in files and "- `summary.html`: this report as a web page" in files
    # the figures named are the kinds written: a run of the reach alone listed the trace's
    # deviation and the blind-zone maps too
    reach = ["reach.json", "reach_motion.png", "reach_joints.png", "summary.md"]
    files = summary_markdown([], files=reach).split("## Files", 1)[1]
    assert "- `*.png`: figures: each motion in 3-D, the joint angles\n" in files
    everything = [*reach, "trace_3d.png", "trace_deviation.png", "blind_maps.png"]
    files = summary_markdown([], files=everything).split("## Files", 1)[1]
    assert (
        "- `*.png`: figures: each motion in 3-D, the joint angles, the trace's deviation, "
        "blind-zone maps\n" in files
    )


def test_a_reach_bound_that_is_an_estimate_is_marked_so_in_the_summary_table(monkeypatch):
    """The UR5 cell's reach had a sampled bound (``lower_bound.proven`` false): the summary's
    table showed "51 | 51" as if the plan were proven fewest. It is now "~51" with a note; a
    proven bound stays a plain number. (That reach's bound is now proven over the lattice;
    with too small a budget for the listing, the family's estimate is kept.)"""
    import copy
    from pathlib import Path

    import armpath
    from armpath.planning import reach_generic
    from armpath.report import summary_markdown

    cell = Path(__file__).resolve().parents[1] / "examples" / "ur5_cell.toml"
    r = armpath.reach(None, [450, -150, 250], scene=cell)
    assert r.doc["lower_bound"]["proven"] is True and r.doc["lower_bound_commands"] == 51
    monkeypatch.setattr(reach_generic, "LATTICE_BOUND_BOXES", 10)
    r = armpath.reach(None, [450, -150, 250], scene=cell)
    assert r.doc["lower_bound"]["proven"] is False
    n, bound = r.n_commands, r.doc["lower_bound_commands"]
    text = summary_markdown([("Task 1: reach", r.doc)])
    assert f"| Task 1: reach | {n} | ~{bound} |" in text
    assert "~ Task 1: reach: the bound is an estimate" in text
    doc = copy.deepcopy(r.doc)
    doc["lower_bound"]["proven"] = True
    text = summary_markdown([("Task 1: reach", doc)])
    assert f"| Task 1: reach | {n} | {bound} |" in text and "is an estimate" not in text


def test_one_command_is_said_in_the_singular():
    """A reach one command away was titled "reach: 1 commands" (the result's title, the CLI's
    figures and summary)."""
    import armpath
    from armpath.report import commands_text, summary_markdown

    r = armpath.reach(None, [-17.8670691713, 511.645918213, 92.838339562])
    assert r.n_commands == 1 and r.title() == "reach: 1 command"
    assert "- 1 command (provably the fewest; lower bound 1) to" in summary_markdown(
        [("Task 1", r.doc)]
    )
    assert [commands_text(n) for n in (0, 1, 2)] == ["0 commands", "1 command", "2 commands"]


def test_coverage_past_the_reachable_ends_is_said_as_all_of_it():
    """The seed crack's pass runs a little past both ends of its reachable arc, and the tables
    said "765.75 of 765.68 mm reachable covered", more than all; now "all 765.68 mm reachable
    covered (the passes run 0.06 mm past its ends in all)". Less than all is said as before."""
    from armpath.report import coverage_text

    def cov(covered, reachable, within=None):
        within = min(covered, reachable) if within is None else within
        return {
            "covered_mm": covered,
            "reachable_mm": reachable,
            "of_reachable": within / reachable,
        }

    assert coverage_text(cov(765.745439555, 765.68376038)) == (
        "all 765.68 mm reachable covered (the passes run 0.06 mm past its ends in all)"
    )
    assert coverage_text(cov(572.18, 572.18)) == "all 572.18 mm reachable covered"
    assert coverage_text(cov(500.0, 572.18)) == "500.00 of 572.18 mm reachable covered"
    # running 0.2 mm past an end while leaving 0.15 mm between two passes is not all of it
    assert coverage_text(cov(600.05, 600.0, within=599.85)) == (
        "599.85 of 600.00 mm reachable covered"
    )


def test_a_gap_in_the_coverage_never_reads_as_100_percent():
    """painter004 round a 100 mm circle left 0.015 mm of its 628 mm between two passes, and the
    table read "628.30 of 628.32 mm reachable covered (100.00 %)"; the share is now rounded
    down, 100.00 % only where all of it is covered."""
    from armpath.report import coverage_percent_text, coverage_text

    def cov(within, reachable):
        return {"covered_mm": within, "reachable_mm": reachable, "of_reachable": within / reachable}

    gap = cov(628.3035, 628.3185)
    assert coverage_text(gap) == "628.30 of 628.32 mm reachable covered"
    assert coverage_percent_text(gap) == "99.99 %"
    assert coverage_percent_text(cov(572.18, 572.18)) == "100.00 %"
    assert coverage_percent_text(cov(572.177, 572.18)) == "100.00 %"  # all, as coverage_text says
    assert coverage_percent_text(cov(286.09, 572.18)) == "50.00 %"
    assert coverage_percent_text(cov(0.0, 572.18)) == "0.00 %"
    assert coverage_percent_text(cov(29.0, 100.0)) == "29.00 %"  # 10,000 x 0.29 is 2899.99...


def test_the_tables_name_the_tool_tips_own_clearance_not_the_least_of_all():
    """``run``'s table and the summary put the least clearance of all under "(tool tip)": a
    link 30 mm from a ball was reported as the tool tip's though the tip stayed 75 mm above
    the table. At the start the seed arm's link BC runs 40 mm above a 10 mm ball and its
    fingertip is 75 mm above the table (SPEC's start pose); nothing comes nearer after."""
    from armpath.api import trace
    from armpath.report import summary_markdown

    centre, radius = np.array([330.0, 60.0, 260.0]), 25.0
    ball = [0.0, 255.0, 100.0]  # 40 mm below C = (0, 255, 140) at the start, on BC
    scene = {
        "name": "ball by the elbow",
        "obstacles": [
            {"type": "half_space", "name": "table", "point": [0, 0, 0], "normal": [0, 0, 1]},
            {"type": "sphere", "name": "ball", "center": ball, "radius": 10.0},
        ],
    }
    half = np.linspace(0.0, np.pi, 20)
    points = np.column_stack(
        [centre[0] + radius * np.cos(half), centre[1] + radius * np.sin(half), 0 * half + 260]
    )
    r = trace("seed", points, scene=scene, bound=False)
    c = r.doc["clearance"]
    assert c["min_body_clearance_mm"] == pytest.approx(40.0 - 10.0, abs=1e-6)
    assert c["min_tool_tip_clearance_mm"] == pytest.approx(75.0, abs=1e-6)
    text = summary_markdown([("trace", r.doc)])
    assert "| 75.000 (tool tip) / 30.000 (links) |" in text
