"""Every result armpath writes validates against the JSON Schema of its kind (issue 19): the
seed run's files, the plans and reaches of the Python API, any arm; the committed schema files
are what ``armpath schema`` prints; a document that breaks the layout is refused."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

from armpath.schemas import RESULT_KINDS, SCHEMA_VERSION, result_schema

ROOT = Path(__file__).resolve().parents[1]


def _valid(doc: dict) -> None:
    schema = result_schema(doc["task"])
    Draft202012Validator.check_schema(schema)
    errors = sorted(Draft202012Validator(schema).iter_errors(doc), key=str)
    assert not errors, [f"{list(e.absolute_path)}: {e.message}" for e in errors[:5]]


@pytest.mark.parametrize("kind", RESULT_KINDS)
def test_committed_schemas_are_what_armpath_schema_prints(kind):
    printed = subprocess.run(
        [sys.executable, "-m", "armpath", "schema", kind],
        capture_output=True,
        text=True,
        check=True,
    )
    committed = json.loads((ROOT / "docs" / "schemas" / f"{kind}.schema.json").read_text("utf-8"))
    assert json.loads(printed.stdout) == committed == result_schema(kind)


@pytest.mark.slow
def test_api_results_of_any_arm_validate(tmp_path):
    import armpath

    docs = [
        armpath.reach("ur5", [400.0, 100.0, 300.0]).doc,
        armpath.plan("seed", to_deg=[10, -80, 10, 0, -90, 0]).doc,
        armpath.plan("seed", to_mm=[300.0, 100.0, 200.0]).doc,
        armpath.spotweld("seed", [[300.0, 100.0, 200.0], [250.0, -100.0, 250.0]], scene="none").doc,
        # (without the bound: a null lower bound must validate too; the seed run's has one)
        armpath.trace(
            "seed", [[250.0, -20.0, 250.0], [250.0, 20.0, 250.0]], scene="none", bound=False
        ).doc,
    ]
    assert [d["task"] for d in docs] == ["reach", "plan", "plan", "spotweld", "trace"]
    for doc in docs:
        assert doc["schema_version"] == SCHEMA_VERSION
        _valid(doc)


def test_the_seed_runs_files_validate(seed_run):
    out, _ = seed_run
    for kind in ("reach", "trace", "spotweld"):
        doc = json.loads((out / f"{kind}.json").read_text("utf-8"))
        assert doc["task"] == kind
        _valid(doc)


def test_a_document_that_breaks_the_layout_is_refused():
    import armpath

    doc = armpath.plan("seed", to_deg=[1, -90, 0, 0, -90, 0]).doc
    _valid(doc)
    validator = Draft202012Validator(result_schema("plan"))
    for broken in (
        {**doc, "commands": [[1.5, 0, 0, 0, 0, 0]]},  # a command is whole ticks
        {k: v for k, v in doc.items() if k != "clearance"},
        {**doc, "schema_version": SCHEMA_VERSION + 1},
        {**doc, "task": "reach"},
        {**doc, "n_commands": "10"},
    ):
        assert not validator.is_valid(broken)


def test_a_newer_schema_version_is_refused_when_loading(tmp_path):
    import armpath
    from armpath.errors import InvalidInputError

    path = armpath.plan("seed", to_deg=[1, -90, 0, 0, -90, 0]).save(tmp_path / "p.json")
    doc = json.loads(path.read_text("utf-8"))
    doc["schema_version"] = SCHEMA_VERSION + 1
    path.write_text(json.dumps(doc), encoding="utf-8")
    with pytest.raises(InvalidInputError, match="newer than this armpath reads"):
        armpath.load_result(path)
