"""The code stays ruff- and mypy-clean, and layers import downward only."""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "armpath"

# each module may import only from its own layer and the layers below (DESIGN.md)
LAYERS = [
    {"errors", "budget", "tolerances", "jit", "lazy", "angles", "poses", "model", "kinematics"},
    {"geometry"},
    {"ik"},
    {"commands"},
    {"scenes", "planning", "workspace", "trajectory"},
    {"tasks"},
    {
        "export",
        "results",
        "schemas",
        "controller_export",
        "report",
        "viz",
        "viewer",
        "api",
        "cli",
        "__main__",
    },
]


def _layer(module: str) -> int:
    for i, names in enumerate(LAYERS):
        if module in names:
            return i
    raise AssertionError(f"module {module!r} is not placed in a layer")


def test_layers_import_downward_only():
    for path in SRC.rglob("*.py"):
        rel = path.relative_to(SRC)
        top = rel.parts[0].removesuffix(".py")
        if top == "__init__":
            continue
        own = _layer(top)
        for node in ast.walk(ast.parse(path.read_text())):
            if (
                isinstance(node, ast.ImportFrom)
                and node.module
                and node.module.startswith("armpath.")
            ):
                target = node.module.split(".")[1]
                assert _layer(target) <= own, f"{rel} imports {node.module} (upward)"


def _tool(name):
    exe = shutil.which(name, path=str(Path(sys.executable).parent))
    assert exe is not None, f"{name} is part of the test dependencies but is not installed"
    return exe


def test_ruff_clean():
    r = subprocess.run(
        [_tool("ruff"), "check", "src", "tests"], cwd=ROOT, capture_output=True, text=True
    )
    assert r.returncode == 0, r.stdout + r.stderr


@pytest.mark.slow
def test_mypy_clean():
    r = subprocess.run([_tool("mypy")], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_ci_runs_the_readmes_test_command_and_it_runs_the_slow_tests():
    """`.ci/run` ends in exactly the README's test command, and that command selects the
    `slow` tests (the proofs plain `pytest` leaves out) but not the `extra` ones."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    commands = [
        line
        for line in readme.splitlines()
        if "pip install '.[test]'" in line and "python -m pytest" in line
    ]
    assert len(commands) == 1, commands
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").strip().splitlines()
    assert ci[-1] == commands[0]
    assert commands[0].endswith("-m pytest -m 'not extra'")
    config = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert "-m 'not slow and not extra'" in config  # plain pytest: the quick run
