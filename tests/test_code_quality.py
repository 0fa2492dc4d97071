"""The code stays ruff- and mypy-clean, and layers import downward only."""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "armpath"

# each module may import only from its own layer and the layers below (DESIGN.md)
LAYERS = [
    {"errors", "budget", "jit", "lazy", "angles", "poses", "model", "kinematics"},
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


def test_mypy_clean():
    r = subprocess.run([_tool("mypy")], cwd=ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
