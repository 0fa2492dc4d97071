"""The one-page report of ``armpath run``: the three seed tasks and the blind zones, numbers
first, then one short section per task with its figures and animation (Markdown, and HTML on
request)."""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from typing import Any

from armpath import __version__

#: The kinds of figure :data:`FILES` lists under ``*.png``, each with the file names that hold it.
_PNG_KINDS = (
    ("each motion in 3-D", ("_motion.png", "_3d.png")),
    ("the joint angles", ("_joints.png",)),
    ("the trace's deviation", ("trace_deviation.png",)),
    ("blind-zone maps", ("blind_maps.png", "face_blindness.png")),
)


FILES = {
    "reach.json": "Task 1 result (commands, lower bound, clearance)",
    "trace.json": "Task 2 result (passes, coverage, unreachable arcs and why)",
    "spotweld.json": "Task 3 result (order, visits, per-weld error)",
    "*.csv / *.xlsx": "the commands (ticks of the lattice), joint values and tool point after each",
    "*.png": "figures: " + ", ".join(kind for kind, _ in _PNG_KINDS),
    "*.gif": "animations of the motions",
    "blindzones.csv / .npz": "blind parts of the workpiece faces; the arm-plane and meridian maps",
    "summary.html": "this report as a web page",
}


def _listed(entry: str, available: set[str]) -> bool:
    """Whether a :data:`FILES` entry (a name, or patterns ``*.csv / *.xlsx``, ``x.csv / .npz``)
    names a file that was written (every entry when nothing is known of what was)."""
    if not available:
        return True
    first = entry.split(" / ")[0]
    if first.startswith("*."):
        return any(name.endswith(first[1:]) for name in available)
    return first in available


def _png_kinds(available: set[str]) -> str:
    """What ``*.png`` stands for among the ``available`` files: the kinds of figure written
    (a run without the trace listed "the trace's deviation" all the same)."""
    kinds = [
        kind for kind, ends in _PNG_KINDS if any(n.endswith(e) for n in available for e in ends)
    ]
    return "figures: " + (", ".join(kinds) if kinds else "the motions")


def _mm(value: float | None) -> str:
    """A length in mm to 3 decimals, or a dash when there was nothing to measure."""
    return "-" if value is None else f"{value:.3f}"


def tip_and_links_text(doc: dict[str, Any], tip: str = "tool tip") -> str:
    """A trace's or a tour's smallest clearances (mm): ``0.005 (tool tip) / 1.017 (links)``,
    each of its own part (not the overall least, which is either)."""
    c = doc["clearance"]
    return (
        f"{_mm(c['min_tool_tip_clearance_mm'])} ({tip}) / {_mm(c['min_body_clearance_mm'])} (links)"
    )


def arc_ends(arc: dict[str, Any], doc: dict[str, Any]) -> tuple[float, float]:
    """Where an arc of a trace result's curve begins and ends (mm) as a reader counts them:
    on a closed curve each within its length, so an arc that runs on past the curve's start
    ends before it begins (``375.17..2.50`` on a 376.99 mm circle;
    :func:`~armpath.geometry.curves.arc_within_round`)."""
    return _arc_place(arc, doc)[:2]


def _arc_place(arc: dict[str, Any], doc: dict[str, Any]) -> tuple[float, float, bool, bool]:
    """:func:`~armpath.geometry.curves.arc_within_round` of a result's arc (an open curve's:
    as it is, neither whole nor through 0)."""
    from armpath.geometry.curves import arc_within_round

    start, end = float(arc["start_mm"]), float(arc["end_mm"])
    curve = doc.get("curve", {})
    length = float(curve.get("length_mm", 0.0))
    if not (curve.get("closed") and length > 0.0):
        return start, end, False, False
    return arc_within_round(start, end, length)


def arc_text(arc: dict[str, Any], doc: dict[str, Any]) -> str:
    """``arc 375.17 .. 2.50 mm``, with ``through 0 mm`` where it runs on past the closed
    curve's start (see :func:`arc_ends`), or ``arc once round from 375.17 mm`` where it covers
    the whole curve (it may end a little past where it began: ``arc 375.17 .. 375.37 mm``
    read as a 0.2 mm arc)."""
    start, end, whole, through = _arc_place(arc, doc)
    if whole:
        return f"arc once round from {start:.2f} mm"
    return f"arc {start:.2f} .. {end:.2f} mm" + (", through 0 mm" if through else "")


def uncovered_arcs(doc: dict[str, Any]) -> list[tuple[str, str, str]]:
    """The arcs a trace result did not cover, ``(what, where, reason)``: its unreachable arcs,
    then those reachable but not traced, each kind's arcs of one reason together
    (``("not traced", "0.00..2.50, 69.79..79.40", reason)``), in the order the reasons first
    come."""
    out = []
    for what, key in (("unreachable", "unreachable"), ("not traced", "not_traced")):
        spans: dict[str, list[str]] = {}
        for arc in doc.get(key, []):
            start, end = arc_ends(arc, doc)
            where = f"{start:.2f}..{end:.2f}"
            spans.setdefault(arc["reason"], []).append(where)
        out += [(what, ", ".join(where), reason) for reason, where in spans.items()]
    return out


def commands_text(n: int) -> str:
    """'1 command', '2 commands'."""
    return f"{n} command" + ("" if n == 1 else "s")


def coverage_text(cov: dict[str, Any]) -> str:
    """How much of a trace's reachable length its passes cover (``cov``: a result's
    ``coverage``). ``of_reachable`` is what they cover within the reachable arcs; the passes
    may also run a little past their ends, which made "765.75 of 765.68 mm reachable covered"
    read as more than all. All of it is said so, with how far they run past."""
    reachable = cov["reachable_mm"]
    within = cov["of_reachable"] * reachable
    if within >= reachable - 0.005:
        past = cov["covered_mm"] - within
        beyond = f" (the passes run {past:.2f} mm past its ends in all)" if past >= 0.005 else ""
        return f"all {reachable:.2f} mm reachable covered{beyond}"
    return f"{within:.2f} of {reachable:.2f} mm reachable covered"


def coverage_percent_text(cov: dict[str, Any]) -> str:
    """The share of the reachable length covered (``cov``: a result's ``coverage``), in percent
    to two decimals, rounded down: 100.00 % only where :func:`coverage_text` says all of it
    (a 0.015 mm gap in 600 mm read "100.00 %" beside "599.98 of 600.00 mm")."""
    reachable = cov["reachable_mm"]
    if cov["of_reachable"] * reachable >= reachable - 0.005:
        return "100.00 %"
    # the 1e-6: 10,000 x 0.29 is 2899.99..., which floors to 28.99
    return f"{math.floor(10_000.0 * cov['of_reachable'] + 1e-6) / 100.0:.2f} %"


def passes_text(n: int) -> str:
    """'1 pass', '2 passes'."""
    return f"{n} pass" + ("" if n == 1 else "es")


def _glance(tasks: Sequence[tuple[str, dict[str, Any]]]) -> tuple[list[str], list[str]]:
    lines = [
        "| task | commands | lower bound | tool point error [mm] | min clearance [mm] | wall |",
        "|---|---:|---:|---:|---:|---|",
    ]
    notes = []
    for title, doc in tasks:
        if doc["task"] == "trace":
            lines.append(
                f"| {title} | {doc['n_commands']} | {bound_cell(doc)} | "
                f"{doc['max_deviation_mm']:.4f} (largest "
                f"deviation of the continuous path) | {tip_and_links_text(doc)} | "
                f"{doc['wall_thickness'] or '-'} |"
            )
            continue
        bound, error = bound_cell(doc), f"{doc['error_mm']:.4f}"
        if doc["task"] == "reach" and not proven(doc):
            notes.append(f"~ {title}: {ESTIMATE_NOTE}.")
        clearance = _mm(doc["min_clearance_mm"])
        if doc["task"] == "spotweld":
            bound = f"{bound_cell(doc)}, {doc['goal_states_bound_commands']}*"
            error += " (largest)"
            clearance = tip_and_links_text(doc)
            order = " → ".join(str(i) for i in doc["order"])
            first = (
                f"the first bound holds for every order and {bound_scope(doc['lower_bound'])}"
                if doc.get("lower_bound") is not None
                else "no bound over every order was computed (-)"
            )
            notes.append(
                f"\\* Task 3, order {order}: {first}; the second counts direct motions between "
                "the chosen goal states of this order. The tool tip touches the wall at each weld."
            )
        lines.append(
            f"| {title} | {doc['n_commands']} | {bound} | {error} | {clearance} | "
            f"{doc['wall_thickness'] or '-'} |"
        )
    return lines, notes


#: What a trace's or tour's lower bound ranges over, in words.
BOUND_SCOPE = "every configuration that may be clear, obstacles ignored between the sampled points"
#: What such a bound adds where a leg goes into a hollow obstacle.
BOUND_OPENING = "legs from the start into a hollow obstacle through its opening"


#: The same for a trace or tour bounded by its arm's carriage
#: (:mod:`armpath.planning.bounds.carriage`).
CARRIAGE_SCOPE = "the carriage's travel to where the arm reaches every point, anything else ignored"
#: The same for a trace along a circle bounded by the band
#: (:mod:`armpath.planning.bounds.band_trace`).
BAND_SCOPE = (
    "the longest arc one command can follow within the tolerance band, every configuration "
    "that may be clear; the least approach to any point of the curve"
)
#: The same for a tour bounded over its lattice goal states (all of them listed).
LATTICE_SCOPE = (
    "every lattice goal state within the tolerance that keeps the clearance rule, all listed, "
    "obstacles ignored between the targets"
)


def over_lattice(bound: dict[str, Any]) -> bool:
    """Whether a result's ``lower_bound`` is a tour's over its listed lattice goal states."""
    return "lattice_goal_states" in (bound.get("sampling") or {})


def by_carriage(bound: dict[str, Any]) -> bool:
    """Whether a result's ``lower_bound`` is its carriage's travel (an arm on a track)."""
    return "carriage_reach_mm" in (bound.get("sampling") or {})


def by_band(bound: dict[str, Any]) -> bool:
    """Whether a result's ``lower_bound`` is a trace's band bound (along a circle)."""
    return "command_arc_limit_mm" in (bound.get("sampling") or {})


def bound_scope(bound: dict[str, Any]) -> str:
    """:data:`BOUND_SCOPE` (or :data:`LATTICE_SCOPE`, :data:`CARRIAGE_SCOPE`,
    :data:`BAND_SCOPE`) of a result's ``lower_bound``, with :data:`BOUND_OPENING` where the
    bound sampled an opening."""
    if by_carriage(bound):
        return CARRIAGE_SCOPE
    if by_band(bound):
        return BAND_SCOPE
    scope = LATTICE_SCOPE if over_lattice(bound) else BOUND_SCOPE
    opening = "opening_samples" in (bound.get("sampling") or {})
    return f"{scope}; {BOUND_OPENING}" if opening else scope


def unproven(bound: dict[str, Any]) -> str:
    """What an unproven bound document is called, with why (see :class:`CommandBound`; a
    document written before it said why: a redundant arm's)."""
    why = bound.get("unproven_because") or "the arm's self-motion is not sampled"
    return f"estimate, not proven: {why}"


#: What a bound marked ``~`` in a table is (a reach's sampled bound, a redundant arm's).
ESTIMATE_NOTE = (
    "the bound is an estimate (the least over sampled configurations), not proven, so the "
    "plan is not proven fewest"
)
#: What a plan that meets its proven bound is said to have.
MEETS_BOUND = "the plan meets it: the fewest commands"


def proven(doc: dict[str, Any]) -> bool:
    """Whether a result's lower bound is a proof (results written before the flag: yes)."""
    b = doc.get("lower_bound")
    return b is None or bool(b.get("proven", True))


def bound_cell(doc: dict[str, Any]) -> str:
    """A result's lower bound for a table (- when not computed; ~N an estimate)."""
    bound = doc.get("lower_bound_commands")
    if bound is None:
        return "-"
    return str(bound) if proven(doc) else f"~{bound}"


def plan_gap(bound: dict[str, Any]) -> str:
    """The plan against a bound document, in words: how far above it, or that a plan below it
    refutes it (a sampled value whose samples missed members of the family). Above an estimate
    the difference is given in commands only: a percentage would read as a proven gap."""
    gap = bound["gap_commands"]
    if gap is not None and gap < 0:
        return f"plan {-gap} below it: no lower bound"
    if not bound.get("proven", True):
        return f"plan {gap} above the estimate"
    pct = bound.get("gap_percent")
    return f"plan {gap} above it" + ("" if pct is None else f" ({pct:.1f} %)")


def _bound_words(doc: dict[str, Any]) -> str:
    """A trace's or tour's lower bound and the gap to it, in words."""
    b = doc.get("lower_bound")
    if b is None:
        return "no lower bound computed"
    meets = b["gap_commands"] == 0 and proven(doc)
    words = f"lower bound {b['commands']} commands over {bound_scope(b)} " + (
        f"({MEETS_BOUND})" if meets else f"({plan_gap(b)})"
    )
    return words if proven(doc) else f"{words}; {unproven(b)}"


def _figures(names: Sequence[str], available: set[str]) -> str:
    shown = [n for n in names if n in available]
    return " ".join(f"![{n}]({n})" for n in shown)


def summary_markdown(
    tasks: Sequence[tuple[str, dict[str, Any]]],
    blind_zone_lines: Sequence[str] = (),
    files: Sequence[str] = (),
    heading: str = "seed tasks",
    failed: Sequence[tuple[str, str]] = (),
    unfinished: Sequence[tuple[str, str]] = (),
) -> str:
    """The report: ``tasks`` are (title, result document) for reach, trace and spot welds;
    ``blind_zone_lines`` the blind-zone summary; ``files`` the names written beside it (figures
    are shown when present); ``heading`` what was run (the seed tasks, or an arm in a scene);
    ``failed`` (title, why) for each task that found no plan; ``unfinished`` (title, why) for
    each task the time limit cut short or left unrun."""
    available = set(files)
    glance, notes = _glance(tasks)
    wall = next((doc["wall_thickness"] for _, doc in tasks), None)
    first = tasks[0][1] if tasks else {}
    model = first.get("model", {}).get("name", "seed")
    scene = first.get("scene", {}).get("name", "seed")
    lattice = first.get("units", {}).get(
        "commands", "ticks of 0.1 deg (at most 20 per joint and command)"
    )
    out = [
        f"# armpath {__version__}: {heading}",
        "",
        f"Arm {model} in scene {scene}"
        + (f", workpiece wall measured {wall}" if wall else "")
        + f". Lengths in mm, angles in deg, commands in {lattice}.",
        "",
        *glance,
        "",
        *notes,
    ]
    for title, doc in tasks:
        out += ["", f"## {title}", ""]
        c = doc["clearance"]
        if c["min_clearance_mm"] is None:
            clearance = "no obstacles to keep clear of"
        else:
            clearance = (
                f"closest approach {c['min_clearance_mm']:.3f} mm ({c['closest_part']} to "
                f"{c['closest_obstacle']}) over the whole continuous motion"
            )
        if doc["task"] == "reach":
            proven = (doc.get("lower_bound") or {}).get("proven", True)
            bound = f"lower bound {doc['lower_bound_commands']}" + ("" if proven else " estimated")
            fewest = "provably the fewest" if doc.get("provably_fewest") else "not proven fewest"
            fewest = f"{fewest}; {bound}"
            out.append(
                f"- {commands_text(doc['n_commands'])} ({fewest}) to "
                f"({', '.join(f'{v:g}' for v in doc['target'])})"
                f" mm, tool point error {doc['error_mm']:.4f} mm; {clearance}."
            )
            figs = ["reach_motion.png", "reach_joints.png", "reach.gif"]
        elif doc["task"] == "trace":
            cov = doc["coverage"]
            out.append(
                f"- {commands_text(doc['n_commands'])} in {passes_text(len(doc['passes']))}; "
                f"{coverage_text(cov)} ({100 * cov['of_curve']:.1f} % of the "
                f"{cov['curve_mm']:.2f} mm curve); largest "
                f"deviation {doc['max_deviation_mm']:.4f} mm (bound "
                f"{doc['max_deviation_bound_mm']:.4f} mm); {_bound_words(doc)}; {clearance}."
            )
            out += [f"- {what} {where} mm: {why}." for what, where, why in uncovered_arcs(doc)]
            figs = ["trace_3d.png", "trace_deviation.png", "trace.gif"]
        else:
            order = " → ".join(str(i) for i in doc["order"])
            errors = ", ".join(f"{v['error_mm']:.4f}" for v in doc["visits"])
            out.append(
                f"- order {order}: {commands_text(doc['n_commands'])} (bound "
                f"{doc['goal_states_bound_commands']} for this order and its goal states; "
                f"{_bound_words(doc)}); weld errors {errors} mm in visiting order; {clearance}."
            )
            figs = ["spotweld_motion.png", "spotweld_joints.png", "spotweld.gif"]
        shown = _figures(figs, available)
        if shown:
            out += ["", shown]
    for title, why in failed:
        out += ["", f"## {title}: no plan", "", f"- {why}"]
    for title, why in unfinished:
        out += ["", f"## {title}: not finished", "", f"- {why}"]
    if blind_zone_lines:
        out += ["", "## Blind zones of the seed arm", ""]
        out += [f"- {line}" for line in blind_zone_lines]
        out += [
            "",
            "(3 circles a face scanned every 16 mm here; `armpath blindzones` for finer maps.)",
        ]
        shown = _figures(["blind_maps.png", "face_blindness.png"], available)
        if shown:
            out += ["", shown]
    out += ["", "## Files", ""]
    out += [
        f"- `{name}`: {_png_kinds(available) if name == '*.png' and available else what}"
        for name, what in FILES.items()
        if _listed(name, available)
    ]
    return "\n".join(out) + "\n"


CSS = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
table { border-collapse: collapse; margin: 1em 0; }
th, td { border: 1px solid #ccc; padding: 4px 8px; }
th { background: #f3f3f3; }
img { max-width: 32%; vertical-align: top; margin: 2px; border: 1px solid #eee; }
code { background: #f5f5f5; padding: 0 3px; }
"""


def summary_html(markdown_text: str, title: str = "armpath report") -> str:
    """The report as a standalone HTML page (figures linked beside it)."""
    from markdown_it import MarkdownIt

    body = MarkdownIt("commonmark").enable("table").render(markdown_text)
    return (
        "<!doctype html>\n<html><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title><style>{CSS}</style></head>\n"
        f"<body>\n{body}</body></html>\n"
    )
