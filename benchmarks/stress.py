"""Seeded randomized stress suite (issue 17), in the spirit of ruckig's.

``python benchmarks/stress.py --cases N [--seed S] [--kinds fk,ik,...] [--time-limit-per-case S]
[--jobs J]`` generates N random cases, runs each in-process through the library functions the
command line calls (``armpath.tasks``, ``armpath.planning``, ``armpath.ik``, ``armpath.scenes``,
``armpath.export``) under ``armpath.budget.time_limit``, and classifies it:

* **result**: the result document is then replayed by ``tests/independent_replay.py`` (no
  armpath code): legal commands, limits, continuous clearance, error or deviation within the
  tolerance, forward kinematics by the textbook product, IK solutions by forward kinematics,
  signed distances of loaded scenes;
* **clear error**: an ``armpath.errors.ArmpathError`` with a one-line, non-empty message that
  does not contradict what the generator knows (an unreachable-target error for a target that is
  the fingertip of a configuration inside the limits is a failure, for example);
* **failure**: any other exception, a result the replay rejects, a result for input that is
  invalid by construction, a result JSON that is not strict JSON, or a hang: each case runs in a
  worker process watched by the parent, and a case still running after twice its budget is
  killed and recorded.

A small share of the cases (``--cli-share``, default 6 %) goes through the real command line as
a subprocess instead; it must exit 0 with output (the JSON is replayed the same way), or exit 1
with exactly one stderr line ``error: ...`` after any progress lines ``armpath: ...``, no
traceback, and no output folder left behind.

Kinds: ``fk`` and ``ik`` (random D-H robot files, standard or modified, mm/m, deg/rad, prismatic
joints, spherical wrists, UR-like arms, built-in models; poses at and near singularities;
unreachable poses; malformed files), ``scene`` (random scene files, TOML or YAML: 0-8 obstacles of
every type, degenerate sizes, huge and tiny coordinates, malformed files), ``reach``, ``plan``
(``--to`` and ``--to-xyz``), ``trace`` (plane sections of hollow frusta, free-space circles and
arcs, polylines, parametric curves, curves on a surface; kept short) and ``spotweld``. Starts
include joint limits; targets are reachable (fingertips of random configurations), unreachable,
inside obstacles, on surfaces, on joint 1's axis, at full stretch.

Every case is reproducible on its own: its random generator is seeded by ``(seed, case)``.
``--case K`` reruns case K verbosely (its inputs, the equivalent command line, the traceback or
the replay's findings). The run writes ``benchmarks/results/stress.md``: cases by kind with
results, clear errors and failures, the seed and command, and a reproducer line per failure.
Budgets: ``--time-limit-per-case`` (default 20 s) for every kind, 1.5 times that for traces and
twice that for spot welds (the goal states of every weld are searched first).
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import datetime as dt
import faulthandler
import json
import math
import multiprocessing as mp
import multiprocessing.connection as mpc
import os
import platform
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import independent_replay as ir  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"

#: Share of each kind in a run (normalised over the kinds chosen).
WEIGHTS = {
    "fk": 0.08,
    "ik": 0.14,
    "scene": 0.12,
    "reach": 0.24,
    "plan": 0.22,
    "trace": 0.10,
    "spotweld": 0.10,
}
#: Default budget of a case (s), ``--time-limit-per-case``.
DEFAULT_BUDGET_S = 20.0
#: Budget of a kind as a multiple of ``--time-limit-per-case``.
BUDGET_FACTOR = {"trace": 1.5, "spotweld": 2.0}
#: A case still running after this multiple of its budget is killed and counted a failure.
HANG_FACTOR = 2.0
#: Extra seconds allowed to a command-line case (interpreter start, imports, compiled caches).
CLI_STARTUP_S = 10.0
#: A replay running longer than this (s) is killed (a problem of the replay, reported as such).
REPLAY_LIMIT_S = 600.0

HOME_DEG = (0.0, -90.0, 0.0, 0.0, -90.0, 0.0)
#: What a scene-file case asks of the command line: reach this point from home.
CLI_SCENE_TARGET = [300.0, 0.0, 200.0]
SEED_LIMITS = {1: 125.0, 2: 138.0, 4: 133.5}
ARM_REACH = 255.0 + 255.0 + 65.0  # from B


# =============================================================================================
# Random inputs
# =============================================================================================


def _f(x: float) -> float:
    return float(round(float(x), 6))


def _vec(v: Any) -> list[float]:
    return [_f(x) for x in v]


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _logu(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _workspace_point(rng: np.random.Generator, z_lo: float = -20.0) -> np.ndarray:
    r = rng.uniform(120.0, 720.0)
    phi = rng.uniform(0.0, 2 * math.pi)
    return np.array([r * math.cos(phi), r * math.sin(phi), rng.uniform(z_lo, 650.0)])


def _rotvec_deg(rng: np.random.Generator) -> list[float]:
    return _vec(_unit(rng) * rng.uniform(0.0, 180.0)) if rng.random() < 0.7 else [0.0, 0.0, 0.0]


def _axis(rng: np.random.Generator) -> list[float]:
    return [0.0, 0.0, 1.0] if rng.random() < 0.6 else _vec(_unit(rng))


# --- convex meshes -------------------------------------------------------------------------


def _polyhedron(rng: np.random.Generator) -> tuple[str, np.ndarray, list[list[int]]]:
    """A closed convex polyhedron with outward-wound triangles (unit size)."""
    shape = str(rng.choice(["box", "tetra", "octa", "icosa"]))
    if shape == "box":
        V = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
        F = [t for q in quads for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])]
    elif shape == "tetra":
        V = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
        F = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]]
    elif shape == "octa":
        V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
        F = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    else:
        g = (1 + 5**0.5) / 2
        V = np.array(
            [
                [-1, g, 0],
                [1, g, 0],
                [-1, -g, 0],
                [1, -g, 0],
                [0, -1, g],
                [0, 1, g],
                [0, -1, -g],
                [0, 1, -g],
                [g, 0, -1],
                [g, 0, 1],
                [-g, 0, -1],
                [-g, 0, 1],
            ],
            float,
        )
        F = [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ]
    # orient every triangle outward
    c = V.mean(axis=0)
    out = []
    for a, b, d in F:
        n = np.cross(V[b] - V[a], V[d] - V[a])
        out.append([a, b, d] if n @ (V[a] - c) > 0 else [a, d, b])
    return shape, V, out


def _mesh_text(V: np.ndarray, F: list[list[int]], fmt: str) -> str:
    P = [[float(x) for x in v] for v in V]
    if fmt == "obj":
        lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in P]
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
        return "\n".join(lines) + "\n"
    lines = ["solid stress"]
    for a, b, c in F:
        n = np.cross(V[b] - V[a], V[c] - V[a])
        n = [float(x) for x in n / np.linalg.norm(n)]
        lines += [f"facet normal {n[0]!r} {n[1]!r} {n[2]!r}", "outer loop"]
        lines += [f"vertex {P[i][0]!r} {P[i][1]!r} {P[i][2]!r}" for i in (a, b, c)]
        lines += ["endloop", "endfacet"]
    return "\n".join([*lines, "endsolid stress"]) + "\n"


# --- obstacles -----------------------------------------------------------------------------

OBSTACLE_TYPES = (
    "half_space",
    "sphere",
    "capsule",
    "box",
    "cylinder",
    "cone_frustum",
    "hollow_frustum",
    "mesh",
)


def _size(rng: np.random.Generator, mode: str, lo: float = 5.0, hi: float = 150.0) -> float:
    if mode == "tiny":
        return _logu(rng, 1e-6, 1e-1)
    if mode == "huge":
        return _logu(rng, 1e3, 1e6)
    return _logu(rng, lo, hi)


def _place(rng: np.random.Generator, mode: str, size: float) -> np.ndarray:
    """A centre: in the workspace; for huge solids far enough that the arm may still fit;
    for 'far' mode at huge coordinates."""
    if mode == "far":
        return _unit(rng) * _logu(rng, 1e5, 1e9)
    if mode == "huge":
        u = _unit(rng)
        u[2] = abs(u[2]) * 0.3 + 0.2
        u /= np.linalg.norm(u)
        return u * (size + rng.uniform(300.0, 1500.0))
    p = _workspace_point(rng)
    if mode == "tiny" and rng.random() < 0.3:
        p = p + rng.normal(size=3) * 1e-9
    return p


def random_obstacle(
    rng: np.random.Generator, kind: str, name: str, files: dict[str, str]
) -> dict[str, Any]:
    """One valid obstacle of ``kind`` (scene-file schema)."""
    mode = str(rng.choice(["normal", "tiny", "huge", "far"], p=[0.7, 0.1, 0.1, 0.1]))
    if kind == "half_space":
        u = _unit(rng)
        if rng.random() < 0.5:  # a wall or a ceiling the origin is outside of
            D = _logu(rng, 1e6, 1e9) if mode == "far" else rng.uniform(150.0, 900.0)
            return {"type": kind, "name": name, "point": _vec(u * D), "normal": _vec(-u)}
        return {
            "type": kind,
            "name": name,
            "point": [0.0, 0.0, _f(-rng.uniform(0, 50))],
            "normal": [0.0, 0.0, 1.0],
        }
    if kind == "sphere":
        r = _size(rng, mode)
        return {"type": kind, "name": name, "center": _vec(_place(rng, mode, r)), "radius": _f(r)}
    if kind == "capsule":
        r = _size(rng, mode, 2.0, 60.0)
        a = _place(rng, mode, r)
        length = 0.0 if rng.random() < 0.1 else _size(rng, mode, 1.0, 300.0)
        return {
            "type": kind,
            "name": name,
            "start": _vec(a),
            "end": _vec(a + _unit(rng) * length),
            "radius": _f(r),
        }
    if kind == "box":
        size = [_size(rng, mode, 2.0, 250.0) for _ in range(3)]
        if rng.random() < 0.15:
            size[int(rng.integers(3))] = _logu(rng, 1e-6, 1e-2)  # a thin plate
        c = _place(rng, mode, max(size))
        return {
            "type": kind,
            "name": name,
            "center": _vec(c),
            "size": _vec(size),
            "rotation_deg": _rotvec_deg(rng),
        }
    if kind in ("cylinder", "cone_frustum"):
        h = _size(rng, mode, 5.0, 300.0)
        c = _place(rng, mode, h)
        if rng.random() < 0.4 and mode == "normal":
            c[2] = 0.0
        out = {
            "type": kind,
            "name": name,
            "base_center": _vec(c),
            "axis": _axis(rng),
            "height": _f(h),
        }
        if kind == "cylinder":
            out["radius"] = _f(_size(rng, mode, 2.0, 120.0))
        else:
            rb, rt = _size(rng, mode, 2.0, 150.0), _size(rng, mode, 2.0, 150.0)
            if rng.random() < 0.3:
                (rb, rt) = (0.0, rt) if rng.random() < 0.5 else (rb, 0.0)
            out["r_bottom"], out["r_top"] = _f(rb), _f(rt)
        return out
    if kind == "hollow_frustum":
        return random_hollow_frustum(rng, name, mode)
    assert kind == "mesh"
    _, V, F = _polyhedron(rng)
    fmt = "obj" if rng.random() < 0.7 else "stl"
    fname = f"{name}.{fmt}"
    files[fname] = _mesh_text(V, F, fmt)
    scale = _size(rng, mode, 5.0, 120.0)
    return {
        "type": "mesh",
        "name": name,
        "file": fname,
        "scale": _f(scale),
        "translation": _vec(_place(rng, mode, scale)),
        "rotation_deg": _rotvec_deg(rng),
    }


def random_hollow_frustum(
    rng: np.random.Generator, name: str, mode: str = "normal", vertical: bool = False
) -> dict[str, Any]:
    """A valid hollow frustum (the wall leaves a hollow; end plates thinner than the part)."""
    for _ in range(50):
        h = _size(rng, mode, 20.0, 250.0)
        rb = _size(rng, mode, 30.0, 200.0)
        rt = rb * rng.uniform(0.4, 1.3)
        wall = max(min(rb, rt, h) * rng.uniform(0.02, 0.3), 1e-3)
        out = {
            "type": "hollow_frustum",
            "name": name,
            "base_center": [0.0, 0.0, 0.0],
            "height": _f(h),
            "r_bottom": _f(rb),
            "r_top": _f(rt),
            "wall": _f(wall),
            "wall_thickness": str(rng.choice(["normal", "horizontal"])),
            "open_top": bool(rng.random() < 0.7),
            "closed_bottom": bool(rng.random() < 0.7),
            "axis": [0.0, 0.0, 1.0] if vertical or rng.random() < 0.8 else _vec(_unit(rng)),
        }
        try:
            ir.obstacle_from_spec(out)
        except ValueError:
            mode = "normal"
            continue
        c = _place(rng, mode, max(h, rb))
        if mode == "normal":
            c[2] = 0.0
        out["base_center"] = _vec(c)
        return out
    raise AssertionError("no valid hollow frustum drawn")


#: Mutations that make a scene invalid: (name, function(spec, rng, files) -> None).
def _invalidate(spec: dict[str, Any], rng: np.random.Generator, files: dict[str, str]) -> str:
    obs = spec["obstacles"]
    if not obs:
        obs.append(random_obstacle(rng, "sphere", "ball", files))
    o = obs[int(rng.integers(len(obs)))]
    choice = str(
        rng.choice(
            [
                "negative",
                "nan",
                "inf",
                "zero_normal",
                "zero_axis",
                "duplicate",
                "unknown_type",
                "missing",
                "extra",
                "string",
                "short_vector",
                "margin",
                "thick_wall",
                "mesh_missing",
                "mesh_open",
                "mesh_empty",
                "syntax",
                "wall_convention",
            ]
        )
    )
    numeric = [k for k, v in o.items() if isinstance(v, float) and k not in ("scale",)]
    if choice == "negative" and numeric:
        key = next((k for k in ("radius", "height", "r_bottom", "wall") if k in o), None)
        if key is None and o["type"] == "box":
            o["size"][0] = -abs(o["size"][0])
            return "a negative box size"
        if key is None:
            choice = "nan"
        else:
            o[key] = -abs(o[key]) - 1.0
            return f"a negative {key}"
    if choice in ("nan", "inf"):
        vec = [k for k, v in o.items() if isinstance(v, list) and v and isinstance(v[0], float)]
        key = vec[0] if vec else None
        if key:
            o[key][int(rng.integers(len(o[key])))] = math.nan if choice == "nan" else math.inf
            return f"{choice} in {o['name']}.{key}"
        choice = "unknown_type"
    if choice == "zero_normal":
        obs.append(
            {
                "type": "half_space",
                "name": "zero_normal",
                "point": [0.0, 0.0, -5.0],
                "normal": [0.0, 0.0, 0.0],
            }
        )
        return "a half-space with a zero normal"
    if choice == "zero_axis":
        obs.append(
            {
                "type": "cylinder",
                "name": "zero_axis",
                "base_center": [400.0, 0.0, 0.0],
                "axis": [0.0, 0.0, 0.0],
                "radius": 10.0,
                "height": 20.0,
            }
        )
        return "a cylinder with a zero axis"
    if choice == "duplicate":
        obs.append(dict(o))
        return f"two obstacles named {o['name']!r}"
    if choice == "unknown_type":
        obs.append({"type": "torus", "name": "donut", "center": [0.0, 0.0, 0.0]})
        return "an unknown obstacle type"
    if choice == "missing":
        key = next(k for k in o if k not in ("type", "name"))
        del o[key]
        if o["type"] in ("hollow_frustum", "cylinder", "cone_frustum") and key == "axis":
            o.pop("height", None)  # axis has a default: drop a required field too
        if o["type"] == "box" and key == "rotation_deg":
            o.pop("size", None)
        if o["type"] == "mesh" and key in ("scale", "translation", "rotation_deg"):
            o.pop("file", None)
        return f"{o['name']} without its {key}"
    if choice == "extra":
        o["colour"] = "red"
        return "an unknown key"
    if choice == "string":
        key = next(k for k in o if k not in ("type", "name", "file", "wall_thickness"))
        if isinstance(o[key], bool):
            o[key] = "maybe"
        else:
            o[key] = "twelve"
        return f"a string for {o['name']}.{key}"
    if choice == "short_vector":
        vec = [k for k, v in o.items() if isinstance(v, list) and len(v) == 3]
        if vec:
            o[vec[0]] = o[vec[0]][:2]
            return f"{o['name']}.{vec[0]} with two numbers"
        o["name"] = 7
        return "a number for a name"
    if choice == "margin":
        spec["clearance"] = {"margin_mm": -1.0}
        return "a negative margin"
    if choice == "thick_wall":
        hf = random_hollow_frustum(rng, "thick")
        hf["wall"] = max(hf["r_bottom"], hf["r_top"]) * 1.5
        obs.append(hf)
        return "a hollow frustum whose wall fills it"
    if choice in ("mesh_missing", "mesh_open", "mesh_empty"):
        _, V, F = _polyhedron(rng)
        name = f"bad_{choice}.obj"
        if choice == "mesh_open":
            files[name] = _mesh_text(V, F[:-1], "obj")
        elif choice == "mesh_empty":
            files[name] = "# nothing\n"
        obs.append(
            {
                "type": "mesh",
                "name": "bad_mesh",
                "file": name,
                "scale": 20.0,
                "translation": [300.0, 300.0, 300.0],
            }
        )
        return {
            "mesh_missing": "a missing mesh file",
            "mesh_open": "a mesh with a hole",
            "mesh_empty": "an empty mesh file",
        }[choice]
    if choice == "syntax":
        spec["__syntax_error__"] = True
        return "a file that does not parse"
    spec["obstacles"].append(random_hollow_frustum(rng, "conv"))
    spec["obstacles"][-1]["wall_thickness"] = "diagonal"
    return "an unknown wall-thickness convention"


def random_scene(
    rng: np.random.Generator, files: dict[str, str], n_max: int = 8, table: float = 0.85
) -> dict[str, Any]:
    """A valid scene: the table (usually), then 0..n_max obstacles of random types."""
    spec: dict[str, Any] = {"name": "stress", "obstacles": []}
    if rng.random() < 0.25:
        spec["clearance"] = {
            "margin_mm": _f(rng.choice([0.0, 0.5, 1.0, 2.0, 1e-6, rng.uniform(0, 5)])),
            "tool_tip_exempt_mm": _f(rng.choice([0.0, 1.0, 5.0, 65.0, 100.0])),
            "self_margin_mm": _f(rng.choice([0.0, 1.0, 3.0])),
        }
    if rng.random() < table:
        spec["obstacles"].append(
            {
                "type": "half_space",
                "name": "table",
                "point": [0.0, 0.0, 0.0],
                "normal": [0.0, 0.0, 1.0],
            }
        )
    n = int(rng.integers(0, n_max + 1))
    for i in range(n):
        kind = str(rng.choice(OBSTACLE_TYPES))
        spec["obstacles"].append(random_obstacle(rng, kind, f"{kind}{i}", files))
    return spec


# --- scene files ---------------------------------------------------------------------------


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def toml_text(spec: dict[str, Any]) -> str:
    """A scene file in TOML (the schema's shape: top-level keys, [clearance], [[obstacles]],
    [tasks.*])."""
    lines = []
    for k, v in spec.items():
        if k not in ("clearance", "obstacles", "tasks") and not k.startswith("__"):
            lines.append(f"{k} = {_toml_value(v)}")
    if "clearance" in spec:
        lines += ["", "[clearance]"] + [
            f"{k} = {_toml_value(v)}" for k, v in spec["clearance"].items()
        ]
    for o in spec.get("obstacles", []):
        lines += ["", "[[obstacles]]"] + [f"{k} = {_toml_value(v)}" for k, v in o.items()]
    for t, body in spec.get("tasks", {}).items():
        lines += ["", f"[tasks.{t}]"] + [f"{k} = {_toml_value(v)}" for k, v in body.items()]
    if spec.get("__syntax_error__"):
        lines.insert(1, "[[obstacles]\nname = ")
    return "\n".join(lines) + "\n"


def _plain(v: Any) -> Any:
    """Plain Python values (numpy scalars and arrays converted), recursively."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, list | tuple | np.ndarray):
        return [_plain(x) for x in v]
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.floating):
        return float(v)
    return v


def write_scene(rng: np.random.Generator, spec: dict[str, Any], files: dict[str, str]) -> str:
    """Add the scene file (TOML or YAML) to ``files``; returns its name."""
    spec.update(_plain(spec))
    if rng.random() < 0.7:
        files["scene.toml"] = toml_text(spec)
        return "scene.toml"
    import yaml

    clean = {k: v for k, v in spec.items() if not k.startswith("__")}
    text = yaml.safe_dump(clean, sort_keys=False)
    if spec.get("__syntax_error__"):
        text = "obstacles: [\n" + text
    files["scene.yaml"] = text
    return "scene.yaml"


def truth_scene(
    spec: dict[str, Any], base: Path, link_radius: float = 0.0, wall: str | None = None
) -> tuple[ir.Scene, ir.SeedArm]:
    """The independent scene and arm of a (valid) scene spec."""
    if wall:
        spec = json.loads(json.dumps(spec))
        for o in spec["obstacles"]:
            if o["type"] == "hollow_frustum":
                o["wall_thickness"] = wall
    return ir.Scene.from_spec(spec, base), ir.SeedArm(link_radius=link_radius)


# --- joint states and targets --------------------------------------------------------------


def random_configs(rng: np.random.Generator, n: int, at_limit: float = 0.15) -> np.ndarray:
    """Joint states (deg, on the 0.1 deg lattice) inside the seed arm's limits."""
    q = np.column_stack(
        [
            rng.uniform(-200, 200, n) + np.where(rng.random(n) < 0.1, 360.0, 0.0),
            rng.uniform(-125, 125, n),
            rng.uniform(-138, 138, n),
            rng.uniform(-200, 200, n),
            rng.uniform(-133.5, 133.5, n),
            rng.uniform(-180, 180, n),
        ]
    )
    q = np.round(q * 10) / 10
    for j, lim in SEED_LIMITS.items():
        hit = rng.random(n) < at_limit
        q[hit, j] = lim * rng.choice([-1.0, 1.0], size=int(hit.sum()))
    return q


def clear_config(
    rng: np.random.Generator, scene: ir.Scene, arm: ir.SeedArm, at_limit: float = 0.15
) -> np.ndarray | None:
    """A random state inside the limits that keeps the clearance rule (None if none found)."""
    for _ in range(4):
        q = random_configs(rng, 256, at_limit)
        slack = ir.config_slack(arm, scene, q, 1.0)
        good = np.flatnonzero(slack > 0.05)
        if good.size:
            return q[int(rng.choice(good))]
    return None


def is_clear(scene: ir.Scene, arm: ir.SeedArm, q: Any) -> bool:
    """Whether the state provably keeps the clearance rule: links sampled every 0.25 mm, so the
    sampled slack exceeds the true one by at most 0.125 mm."""
    return bool(ir.config_slack(arm, scene, np.asarray(q, float)[None], 0.25)[0] > 0.126)


def tip_of(q: Any) -> np.ndarray:
    return ir.SeedArm.points(np.asarray(q, float))[4]


# =============================================================================================
# Cases
# =============================================================================================


@dataclass
class Case:
    """One generated case. ``params`` are its inputs (JSON); ``truth`` what the generator knows
    independently; ``expect_error`` says why the input is invalid (a result is then wrong)."""

    seed: int
    index: int
    kind: str
    budget: float
    cli: bool
    summary: str = ""
    params: dict[str, Any] = field(default_factory=dict)
    expect_error: str = ""
    files: dict[str, str] = field(default_factory=dict)
    facts: dict[str, Any] = field(default_factory=dict)  # generator's knowledge (JSON)
    scene: ir.Scene | None = None
    arm: ir.SeedArm | None = None
    curve: ir.DenseCurve | None = None
    targets: np.ndarray | None = None


def _choose_kind(rng: np.random.Generator, kinds: list[str]) -> str:
    w = np.array([WEIGHTS[k] for k in kinds])
    return str(kinds[int(rng.choice(len(kinds), p=w / w.sum()))])


def _kind_of(seed: int, index: int, kinds: list[str]) -> str:
    """The kind of case ``index`` of run ``seed`` (the first draw of :func:`make_case`)."""
    return _choose_kind(np.random.default_rng([seed, index]), kinds)


def make_case(
    seed: int, index: int, kinds: list[str], base_budget: float, cli_share: float, work: Path
) -> Case:
    """Generate case ``index`` of run ``seed`` (writing its files into ``work``)."""
    rng = np.random.default_rng([seed, index])
    kind = _choose_kind(rng, kinds)
    cli = bool(rng.random() < cli_share)
    case = Case(seed, index, kind, base_budget * BUDGET_FACTOR.get(kind, 1.0), cli)
    GENERATORS[kind](case, rng, work)
    for name, text in case.files.items():
        (work / name).write_text(text)
    return case


def _scene_for_motion(case: Case, rng: np.random.Generator, work: Path, n_max: int = 6) -> None:
    """A random scene file for a motion case, with its truth (scene, arm) and link radius."""
    files: dict[str, str] = {}
    spec = random_scene(rng, files, n_max)
    p = case.params
    p["link_radius"] = _f(rng.choice([0.0, 0.0, 0.0, 0.5, 3.0, rng.uniform(0, 15)]))
    p["wall"] = str(rng.choice(["", "", "", "normal", "horizontal"]))
    if rng.random() < 0.03:
        case.expect_error = _invalidate(spec, rng, files)
    elif rng.random() < 0.02:
        p["wall"] = "slanted"
        case.expect_error = "an unknown --wall convention"
    elif rng.random() < 0.02:
        p["link_radius"] = -1.0
        case.expect_error = "a negative link radius"
    for name, text in files.items():
        (work / name).write_text(text)
    case.files.update(files)
    p["scene_spec"] = spec
    p["scene_file"] = write_scene(rng, spec, case.files)
    if not case.expect_error:
        case.scene, case.arm = truth_scene(spec, work, p["link_radius"], p["wall"] or None)


def _start(case: Case, rng: np.random.Generator) -> list[float]:
    """A start state: home, a clear random state (often at a limit), anything, or invalid."""
    u = rng.random()
    assert case.arm is not None or case.expect_error
    if u < 0.04 and not case.expect_error:
        case.expect_error = "a start state off the 0.1 deg lattice"
        return [0.05, -90.0, 0.0, 0.0, -90.0, 0.0]
    if u < 0.08 and not case.expect_error:
        j = int(rng.choice(list(SEED_LIMITS)))
        q = list(HOME_DEG)
        q[j] = SEED_LIMITS[j] + 0.1
        case.expect_error = f"a start state beyond joint {j + 1}'s limit"
        return q
    if u < 0.45 or case.scene is None or case.arm is None:
        return list(HOME_DEG)
    if u < 0.9:
        q = clear_config(rng, case.scene, case.arm)
        if q is not None:
            return _vec(q)
    return _vec(random_configs(rng, 1)[0])


def _target(case: Case, rng: np.random.Generator, start: list[float]) -> list[float]:
    """A fingertip target and what is known about it (case.facts['target_kind'], ...)."""
    kinds = ["fk"] * 4 + ["fk_limit"] + ["near_start"] * 2
    kinds += ["far", "inside", "surface", "axis", "blind", "stretch", "huge"]
    t = str(rng.choice(kinds))
    case.facts["target_kind"] = t
    B = np.array([0.0, 0.0, 140.0])
    scene, arm = case.scene, case.arm
    if t in ("fk", "fk_limit", "near_start"):
        if t == "near_start":
            q = np.array(start) + np.round(rng.uniform(-6, 6, 6) * 10) / 10
            q[1:3] = np.clip(q[1:3], [-125, -138], [125, 138])
            q[4] = np.clip(q[4], -133.5, 133.5)
        else:
            q = None
            if scene is not None and arm is not None:
                q = clear_config(rng, scene, arm, 0.5 if t == "fk_limit" else 0.1)
            if q is None:
                q = random_configs(rng, 1, 0.5 if t == "fk_limit" else 0.1)[0]
        case.facts["target_reachable"] = True  # the fingertip of a state inside the limits
        case.facts["target_from"] = _vec(q)
        return _vec(tip_of(q))
    if t == "far":
        u = _unit(rng)
        case.facts["target_reachable"] = False
        case.expect_error = case.expect_error or "a target out of reach"
        return _vec(B + u * (ARM_REACH + rng.uniform(0.5, 800.0)))
    if t == "huge":
        case.facts["target_reachable"] = False
        case.expect_error = case.expect_error or "a target out of reach"
        return _vec(_unit(rng) * _logu(rng, 1e5, 1e15))
    if t == "stretch":
        # full stretch from B along a direction joint 2 can point to: reachable exactly at
        # 575 mm, within the tolerance up to 575 + tolerance
        u = _unit(rng)
        while math.degrees(math.acos(np.clip(u[2], -1, 1))) > 120:
            u = _unit(rng)
        extra = float(rng.choice([0.0, -0.5, 0.01, 0.04, 0.2]))
        case.facts["stretch_extra_mm"] = extra
        if extra <= 0.01:
            case.facts["target_reachable"] = True
        return _vec(B + u * (ARM_REACH + extra))
    if t == "axis":
        return [0.0, 0.0, _f(rng.uniform(150.0, 700.0))]
    if t == "blind":
        return _vec(B + _unit(rng) * rng.uniform(0.0, 110.0))
    obstacles = [
        o
        for o in (case.params.get("scene_spec") or {}).get("obstacles", [])
        if o["type"] in ("sphere", "box", "cylinder", "capsule")
    ]
    if t == "inside":
        if obstacles:
            o = obstacles[int(rng.integers(len(obstacles)))]
            c = np.array(o.get("center") or o.get("start") or o.get("base_center"), float)
            if o["type"] == "cylinder":
                c = c + np.array(o["axis"]) / np.linalg.norm(o["axis"]) * o["height"] / 2
            return _vec(c)
        return [300.0, 0.0, _f(-rng.uniform(0.5, 50.0))]  # below the table
    # "surface": on a sphere's surface toward the arm, or on the table
    spheres = [o for o in obstacles if o["type"] == "sphere"]
    if spheres:
        o = spheres[0]
        c = np.array(o["center"], float)
        d = -c / max(np.linalg.norm(c), 1e-9)
        return _vec(c + d * o["radius"])
    p = _workspace_point(rng)
    p[2] = 0.0
    return _vec(p)


def _tolerance(case: Case, rng: np.random.Generator, default: float = 0.05) -> float:
    u = rng.random()
    if u < 0.03 and not case.expect_error:
        case.expect_error = "a tolerance that is not a positive number"
        return float(rng.choice([0.0, -0.1]))
    if u < 0.75:
        return default
    return _f(rng.choice([1e-3, 0.01, 0.2, 1.0, 5.0]))


def _scene_text(name: str, spec: dict[str, Any]) -> str:
    if name.endswith(".toml"):
        return toml_text(spec)
    import yaml

    return yaml.safe_dump(_plain(spec), sort_keys=False)


def _add_blocker(case: Case, rng: np.random.Generator, work: Path, q_from: Any, q_to: Any) -> None:
    """Sometimes put a small or thin solid where link CD or DE passes half-way between two
    states (a thin disk, a small ball, a plate, a ring around the link, a small cone), often
    with a zero margin: the direct motion is then blocked or grazes it."""
    if case.expect_error or case.scene is None or q_to is None or rng.random() < 0.7:
        return
    p = case.params
    mid = (np.asarray(q_from, float) + np.asarray(q_to, float)) / 2
    P = ir.SeedArm.points(mid)
    j = int(rng.choice([2, 3]))
    u = (P[j + 1] - P[j]) / np.linalg.norm(P[j + 1] - P[j])
    at = P[j] + (P[j + 1] - P[j]) * rng.uniform(0.2, 0.8)
    kind = str(rng.choice(["disk", "ball", "plate", "ring", "cone"]))
    axis = u if rng.random() < 0.5 else _unit(rng)
    if kind == "disk":
        h = rng.uniform(0.3, 3.0)
        o = {
            "type": "cylinder",
            "base_center": _vec(at - axis * h / 2),
            "axis": _vec(axis),
            "radius": _f(rng.uniform(3.0, 30.0)),
            "height": _f(h),
        }
    elif kind == "ball":
        o = {"type": "sphere", "center": _vec(at), "radius": _f(rng.uniform(1.0, 20.0))}
    elif kind == "plate":
        o = {
            "type": "box",
            "center": _vec(at),
            "size": _vec([rng.uniform(10, 80), rng.uniform(10, 80), rng.uniform(0.2, 2.0)]),
            "rotation_deg": _rotvec_deg(rng),
        }
    elif kind == "ring":
        h = rng.uniform(2.0, 20.0)
        r = rng.uniform(4.0, 20.0) + p["link_radius"]
        o = {
            "type": "hollow_frustum",
            "base_center": _vec(at - u * h / 2),
            "axis": _vec(u),
            "height": _f(h),
            "r_bottom": _f(r),
            "r_top": _f(r),
            "wall": _f(rng.uniform(0.5, 2.0)),
            "open_top": True,
            "closed_bottom": False,
        }
    else:
        h = rng.uniform(2.0, 30.0)
        o = {
            "type": "cone_frustum",
            "base_center": _vec(at - axis * h / 2),
            "axis": _vec(axis),
            "r_bottom": _f(rng.uniform(1.0, 15.0)),
            "r_top": 0.0,
            "height": _f(h),
        }
    spec = json.loads(json.dumps(p["scene_spec"]))
    spec["obstacles"].append({"name": "blocker", **o})
    if rng.random() < 0.4:
        spec["clearance"] = {**spec.get("clearance", {}), "margin_mm": 0.0}
    scene, arm = truth_scene(spec, work, p["link_radius"], p["wall"] or None)
    if not (is_clear(scene, arm, q_from) and is_clear(scene, arm, q_to)):
        return
    p["scene_spec"] = spec
    case.files[p["scene_file"]] = _scene_text(p["scene_file"], spec)
    case.scene, case.arm = scene, arm
    case.facts["blocker"] = kind


def gen_reach(case: Case, rng: np.random.Generator, work: Path) -> None:
    _scene_for_motion(case, rng, work)
    p = case.params
    p["start_deg"] = _start(case, rng)
    p["target"] = _target(case, rng, p["start_deg"])
    p["tolerance"] = _tolerance(case, rng)
    _add_blocker(case, rng, work, p["start_deg"], case.facts.get("target_from"))
    case.summary = (
        f"reach {p['target']} from {p['start_deg']} ({case.facts['target_kind']} target), "
        f"{len(p['scene_spec']['obstacles'])} obstacles, tol {p['tolerance']}, "
        f"radius {p['link_radius']}"
        + (f", a {case.facts['blocker']} in the way" if "blocker" in case.facts else "")
    )


def gen_plan(case: Case, rng: np.random.Generator, work: Path) -> None:
    _scene_for_motion(case, rng, work)
    p = case.params
    p["start_deg"] = _start(case, rng)
    p["objective"] = str(rng.choice(["commands", "commands", "path", "energy"]))
    if p["objective"] == "energy" and rng.random() < 0.5:
        p["weights"] = _vec(rng.uniform(0, 3, 6))
    p["seed"] = int(rng.integers(0, 5))
    if rng.random() < 0.5:
        p["tolerance"] = 0.05  # not used with --to
        p["to"] = _goal(case, rng, p["start_deg"])
        _add_blocker(case, rng, work, p["start_deg"], p["to"])
        case.summary = f"plan --to {p['to']} from {p['start_deg']}"
    else:
        p["tolerance"] = _tolerance(case, rng)
        p["to_xyz"] = _target(case, rng, p["start_deg"])
        _add_blocker(case, rng, work, p["start_deg"], case.facts.get("target_from"))
        case.summary = (
            f"plan --to-xyz {p['to_xyz']} ({case.facts['target_kind']}) from {p['start_deg']}"
        )
    case.summary += f", {len(p['scene_spec']['obstacles'])} obstacles, objective {p['objective']}"
    if "blocker" in case.facts:
        case.summary += f", a {case.facts['blocker']} in the way"


def _goal(case: Case, rng: np.random.Generator, start: list[float]) -> list[float]:
    u = rng.random()
    if u < 0.05 and not case.expect_error:
        case.expect_error = "a goal beyond a joint limit"
        q = list(start)
        q[2] = 138.1
        return q
    if u < 0.08 and not case.expect_error:
        case.expect_error = "a goal off the 0.1 deg lattice"
        return [*start[:5], start[5] + 0.03]
    if u < 0.12:
        case.facts["goal_kind"] = "start"
        return list(start)
    if u < 0.35:
        q = np.array(start) + np.round(rng.uniform(-15, 15, 6) * 10) / 10
        q[1:3] = np.clip(q[1:3], [-125, -138], [125, 138])
        q[4] = np.clip(q[4], -133.5, 133.5)
        case.facts["goal_kind"] = "near"
        return _vec(q)
    if case.scene is not None and case.arm is not None:
        q = clear_config(rng, case.scene, case.arm)
        if q is not None:
            case.facts["goal_kind"] = "clear"
            return _vec(q)
    case.facts["goal_kind"] = "random"
    return _vec(random_configs(rng, 1)[0])


# --- traces --------------------------------------------------------------------------------


def _expr(c: float, terms: list[tuple[float, str]]) -> str:
    return " + ".join([f"({_f(c)!r})"] + [f"({_f(a)!r})*{f}" for a, f in terms if a != 0.0])


def _circle(
    rng: np.random.Generator, center: np.ndarray, radius: float, arc: float
) -> tuple[dict[str, Any], Callable[[np.ndarray], np.ndarray], float]:
    n = _unit(rng)
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    c, U, V = np.array(_vec(center)), np.array(_vec(u * radius)), np.array(_vec(v * radius))
    spec = {
        "type": "parametric",
        "name": "circle",
        **{ax: _expr(c[k], [(U[k], "cos(t)"), (V[k], "sin(t)")]) for k, ax in enumerate("xyz")},
        "t": [0.0, arc],
    }

    def f(t: np.ndarray) -> np.ndarray:
        return c + np.cos(t)[:, None] * U + np.sin(t)[:, None] * V

    return spec, f, arc


def gen_trace(case: Case, rng: np.random.Generator, work: Path) -> None:
    files: dict[str, str] = {}
    spec = random_scene(rng, files, 3, table=0.9)
    p = case.params
    p["tolerance"] = _f(rng.choice([0.1, 0.1, 0.1, 0.05, 0.5, 1.0]))
    p["seed"] = int(rng.integers(0, 3))
    arm = ir.SeedArm()
    for name, text in files.items():
        (work / name).write_text(text)
    sc = ir.Scene.from_spec(spec, work)
    home_ok = is_clear(sc, arm, HOME_DEG)
    if not home_ok:  # keep the start clear most of the time: drop the obstacles
        spec["obstacles"] = spec["obstacles"][:1]
        sc = ir.Scene.from_spec(spec, work)
    q = clear_config(rng, sc, arm, 0.05)
    center = tip_of(q) if q is not None else np.array([330.0, 60.0, 260.0])
    shape = str(
        rng.choice(
            [
                "circle",
                "arc",
                "line",
                "polyline",
                "section",
                "wave",
                "on_sphere",
                "on_table",
                "far",
                "degenerate",
            ],
            p=[0.2, 0.12, 0.1, 0.15, 0.15, 0.08, 0.07, 0.06, 0.04, 0.03],
        )
    )
    case.facts["curve"] = shape
    truth: ir.DenseCurve | None = None
    if shape in ("circle", "arc", "far"):
        r = rng.uniform(3.0, 25.0)
        if shape == "far":
            center = center + _unit(rng) * 2000.0
            case.expect_error = "a curve nowhere within reach"
        arc = 2 * math.pi if shape != "arc" else rng.uniform(0.3, 5.0)
        curve, f, t1 = _circle(rng, center, r, arc)
        truth = ir.sampled_curve(f, 0.0, t1)
    elif shape == "line":
        d = _unit(rng) * rng.uniform(5.0, 60.0)
        c, dd = np.array(_vec(center)), np.array(_vec(d))
        curve = {
            "type": "parametric",
            "name": "line",
            **{ax: _expr(c[k], [(dd[k], "t")]) for k, ax in enumerate("xyz")},
            "t": [0.0, 1.0],
        }
        truth = ir.sampled_curve(lambda t: c + t[:, None] * dd, 0.0, 1.0)
    elif shape == "wave":
        a, b = _unit(rng), _unit(rng)
        amp, w = rng.uniform(1.0, 6.0), rng.uniform(1.0, 4.0)
        c, A, Bv = np.array(_vec(center)), np.array(_vec(a * 10.0)), np.array(_vec(b * amp))
        curve = {
            "type": "parametric",
            "name": "wave",
            **{
                ax: _expr(c[k], [(A[k], "t"), (Bv[k], f"sin({_f(w)!r}*t)")])
                for k, ax in enumerate("xyz")
            },
            "t": [0.0, _f(rng.uniform(1.0, 4.0))],
        }
        ww = _f(w)
        truth = ir.sampled_curve(
            lambda t: c + t[:, None] * A + np.sin(ww * t)[:, None] * Bv, 0.0, curve["t"][1]
        )
    elif shape in ("polyline", "degenerate"):
        k = int(rng.integers(2, 6))
        V = [np.array(_vec(center))]
        for _ in range(k - 1):
            V.append(np.array(_vec(V[-1] + _unit(rng) * rng.uniform(5.0, 30.0))))
        closed = bool(k >= 3 and rng.random() < 0.4)
        if shape == "degenerate":
            V = [V[0], V[0].copy()]
            closed = False
            case.expect_error = "a curve of zero length"
        curve = {
            "type": "polyline",
            "name": "poly",
            "points_mm": [list(v) for v in V],
            "closed": closed,
        }
        if shape != "degenerate":
            truth = ir.polyline_curve(V, closed)
    elif shape == "on_table":
        p0 = np.array([_f(center[0]), _f(center[1]), 0.0])
        d = _unit(rng)
        d[2] = 0.0
        d /= np.linalg.norm(d)
        p1 = np.array(_vec(p0 + d * rng.uniform(10.0, 40.0)))
        p1[2] = 0.0
        if not any(o.get("name") == "table" for o in spec["obstacles"]):
            spec["obstacles"].insert(
                0,
                {
                    "type": "half_space",
                    "name": "table",
                    "point": [0.0, 0.0, 0.0],
                    "normal": [0.0, 0.0, 1.0],
                },
            )
        curve = {"type": "polyline", "name": "seam", "points_mm": [list(p0), list(p1)]}
        truth = ir.polyline_curve([p0, p1])
    elif shape == "on_sphere":
        R = rng.uniform(20.0, 60.0)
        n = -center / np.linalg.norm(center)  # the sphere sits behind the curve, away from base
        cs = np.array(_vec(center - n * R))
        spec["obstacles"].append(
            {"type": "sphere", "name": "ball", "center": list(cs), "radius": _f(R)}
        )
        lat = rng.uniform(0.2, 1.2)
        u = np.cross(n, [0.0, 0.0, 1.0])
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        cc = cs + n * R * math.sin(lat)
        rr = R * math.cos(lat)
        c, U, Vv = cc, u * rr, v * rr
        curve = {
            "type": "parametric",
            "name": "latitude",
            **{
                ax: _expr(c[k], [(U[k], "cos(t)"), (Vv[k], "sin(t)")]) for k, ax in enumerate("xyz")
            },
            "t": [0.0, _f(rng.choice([2 * math.pi, rng.uniform(0.5, 3.0)]))],
        }
        cf, Uf, Vf = (np.array([_f(x) for x in w]) for w in (c, U, Vv))
        truth = ir.sampled_curve(
            lambda t: cf + np.cos(t)[:, None] * Uf + np.sin(t)[:, None] * Vf, 0.0, curve["t"][1]
        )
    else:  # section of a small hollow frustum near the chosen point
        hf = random_hollow_frustum(rng, "part", vertical=True)
        h = rng.uniform(20.0, 80.0)
        rb = rng.uniform(15.0, 60.0)
        rt = rb * rng.uniform(0.5, 1.2)
        hf.update(
            height=_f(h),
            r_bottom=_f(rb),
            r_top=_f(rt),
            wall=_f(min(rb, rt) * 0.2),
            base_center=[_f(center[0]), _f(center[1]), 0.0],
        )
        spec["obstacles"].append(hf)
        tilt = math.atan(0.8 * (h / 2) / max(rb, rt)) * rng.uniform(0.0, 1.0)
        phi = rng.uniform(0, 2 * math.pi)
        normal = [
            _f(math.sin(tilt) * math.cos(phi)),
            _f(math.sin(tilt) * math.sin(phi)),
            _f(math.cos(tilt)),
        ]
        pp = [_f(center[0]), _f(center[1]), _f(h * rng.uniform(0.35, 0.65))]
        if rng.random() < 0.1:
            pp[2] = _f(h * 3)  # the plane misses the part
            case.expect_error = "a plane that does not cut the part's face"
        curve = {
            "type": "plane_section",
            "name": "section",
            "solid": "part",
            "plane_point": pp,
            "plane_normal": normal,
        }
        if not case.expect_error:
            try:
                truth = ir.frustum_section_curve(
                    hf["base_center"], hf["axis"], h, rb, rt, pp, normal
                )
            except ValueError:
                case.expect_error = "a plane that leaves the part's face"
    spec["tasks"] = {"trace": {"curve": curve}}
    case.files.update(files)
    p["scene_spec"] = spec
    p["scene_file"] = write_scene(rng, spec, case.files)
    case.scene, case.arm = truth_scene(spec, work)
    case.curve = truth
    case.summary = f"trace a {shape} curve ({curve['type']}), {len(spec['obstacles'])} obstacles"


def gen_spotweld(case: Case, rng: np.random.Generator, work: Path) -> None:
    files: dict[str, str] = {}
    p = case.params
    if rng.random() < 0.3:  # the seed workpiece, a random subset of the seed's welds
        hf = {
            "type": "hollow_frustum",
            "name": "workpiece",
            "base_center": [210.0, 0.0, 0.0],
            "height": 180.0,
            "r_bottom": 168.0,
            "r_top": 96.0,
            "wall": 8.0,
            "wall_thickness": str(rng.choice(["normal", "horizontal"])),
        }
        pts = [[320.0, -104.0], [120.0, 106.0], [190.0, -125.0], [255.0, 88.0]]
        pick = rng.permutation(4)[: 1 if rng.random() < 0.5 else int(rng.integers(2, 4))]
        xy = [pts[i] for i in pick]
        others = 0
    else:
        hf = random_hollow_frustum(rng, "workpiece", vertical=True)
        r = rng.uniform(250.0, 450.0)
        a = rng.uniform(0, 2 * math.pi)
        hf.update(
            base_center=[_f(r * math.cos(a)), _f(r * math.sin(a)), 0.0],
            height=_f(rng.uniform(60.0, 200.0)),
            r_bottom=_f(rng.uniform(80.0, 180.0)),
            open_top=True,
            axis=[0.0, 0.0, 1.0],
        )
        hf["r_top"] = _f(hf["r_bottom"] * rng.uniform(0.5, 1.0))
        hf["wall"] = _f(rng.uniform(2.0, 10.0))
        slope = (hf["r_bottom"] - hf["r_top"]) / hf["height"]
        dh = (
            hf["wall"] * math.sqrt(1 + slope**2) if hf["wall_thickness"] == "normal" else hf["wall"]
        )
        xy = []
        for _ in range(1 if rng.random() < 0.5 else int(rng.integers(2, 4))):
            z = rng.uniform(hf["wall"] + 5.0, hf["height"] - 5.0)
            rho = hf["r_bottom"] - slope * z - dh
            ang = rng.uniform(0, 2 * math.pi)
            xy.append(
                [
                    _f(hf["base_center"][0] + rho * math.cos(ang)),
                    _f(hf["base_center"][1] + rho * math.sin(ang)),
                ]
            )
        others = int(rng.integers(0, 3))
    spec: dict[str, Any] = {
        "name": "welds",
        "obstacles": [
            {
                "type": "half_space",
                "name": "table",
                "point": [0.0, 0.0, 0.0],
                "normal": [0.0, 0.0, 1.0],
            },
            hf,
        ],
    }
    for i in range(others):
        kind = str(rng.choice(OBSTACLE_TYPES[1:]))
        spec["obstacles"].append(random_obstacle(rng, kind, f"{kind}{i}", files))
    for name, text in files.items():
        (work / name).write_text(text)
    sc = ir.Scene.from_spec(spec, work)
    if not is_clear(sc, ir.SeedArm(), HOME_DEG):
        spec["obstacles"] = spec["obstacles"][:2]
    spec["tasks"] = {"spotweld": {"workpiece": "workpiece", "points_xy_mm": xy}}
    case.files.update(files)
    p["scene_spec"] = spec
    p["scene_file"] = write_scene(rng, spec, case.files)
    p["order"] = str(rng.choice(["auto", "given"]))
    p["return"] = bool(rng.random() < 0.3)
    p["tolerance"] = _f(rng.choice([0.05, 0.05, 0.05, 0.1, 0.02]))
    p["objective"] = str(rng.choice(["commands", "commands", "path", "energy"]))
    p["seed"] = int(rng.integers(0, 3))
    case.scene, case.arm = truth_scene(spec, work)
    targets = [
        ir.hollow_frustum_inner_point(
            hf["base_center"],
            hf["height"],
            hf["r_bottom"],
            hf["r_top"],
            hf["wall"],
            hf["wall_thickness"],
            x,
            y,
        )
        for x, y in xy
    ]
    if any(t is None for t in targets):
        case.expect_error = "a weld with no inner-wall point above it"
    else:
        case.targets = np.array(targets)
    case.summary = (
        f"spotweld {len(xy)} welds, order {p['order']}, return {p['return']}, "
        f"{len(spec['obstacles'])} obstacles, objective {p['objective']}"
    )


# --- robots (fk, ik) -----------------------------------------------------------------------

#: Textbook D-H tables (mm, deg) of two built-in models, for the replay of their fk / ik.
BUILTIN_TABLES = {
    "puma560": {
        "convention": "standard",
        "links": [
            {"a": 0.0, "alpha": 90.0, "d": 0.0, "limits": [-160, 160]},
            {"a": 431.8, "alpha": 0.0, "d": 0.0, "limits": [-45, 225]},
            {"a": 20.32, "alpha": -90.0, "d": 150.05, "limits": [-225, 45]},
            {"a": 0.0, "alpha": 90.0, "d": 431.8, "limits": [-110, 170]},
            {"a": 0.0, "alpha": -90.0, "d": 0.0, "limits": [-100, 100]},
            {"a": 0.0, "alpha": 0.0, "d": 0.0, "limits": [-266, 266]},
        ],
    },
    "ur5": {
        "convention": "standard",
        "links": [
            {"a": 0.0, "alpha": 90.0, "d": 89.159, "limits": [-360, 360]},
            {"a": -425.0, "alpha": 0.0, "d": 0.0, "limits": [-360, 360]},
            {"a": -392.25, "alpha": 0.0, "d": 0.0, "limits": [-360, 360]},
            {"a": 0.0, "alpha": 90.0, "d": 109.15, "limits": [-360, 360]},
            {"a": 0.0, "alpha": -90.0, "d": 94.65, "limits": [-360, 360]},
            {"a": 0.0, "alpha": 0.0, "d": 82.3, "limits": [-360, 360]},
        ],
    },
}


def _rigid(rng: np.random.Generator, reach: float) -> list[list[float]]:
    from scipy.spatial.transform import Rotation

    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(_unit(rng) * rng.uniform(0, math.pi)).as_matrix()
    T[:3, 3] = rng.normal(size=3) * reach
    return [[float(x) for x in row] for row in T]


def random_robot(rng: np.random.Generator) -> tuple[dict[str, Any], str, str]:
    """A robot file (JSON dict), its style, and why it is invalid ('' if valid)."""
    n = 6 if rng.random() < 0.8 else int(rng.integers(1, 9))
    style = str(rng.choice(["random", "spherical_wrist", "ur_like", "prismatic", "sparse"]))
    if n != 6 and style in ("spherical_wrist", "ur_like"):
        style = "random"
    conv = str(rng.choice(["standard", "modified"]))
    rows = []
    for _ in range(n):
        # mostly general geometry; some zero offsets and parallel axes (degenerate arms whose
        # solutions form families) stay in the mix
        a = 0.0 if rng.random() < 0.2 else _f(rng.uniform(-500, 500))
        d = 0.0 if rng.random() < 0.2 else _f(rng.uniform(-500, 500))
        u = rng.random()
        al = _f(rng.uniform(-180, 180)) if u < 0.6 else float(rng.choice([90.0, -90.0, 0.0]))
        row: dict[str, Any] = {"a": a, "alpha": al, "d": d}
        if rng.random() < 0.3:
            row["offset"] = _f(rng.uniform(-90, 90))
        lim = rng.random()
        if lim < 0.3:
            row["limits"] = [None, None]
        elif lim < 0.6:
            row["limits"] = [-180.0, 180.0]
        elif lim < 0.8:
            lo = _f(rng.uniform(-200, 0))
            row["limits"] = [lo, _f(lo + rng.uniform(30, 300))]
        if style == "prismatic" and rng.random() < 0.35:
            row["type"] = "prismatic"
            row["limits"] = [0.0, _f(rng.uniform(50, 600))]
            if rng.random() < 0.5:
                row["theta"] = _f(rng.uniform(-90, 90))
        rows.append(row)
    if style == "spherical_wrist":
        al = 90.0 if rng.random() < 0.5 else -90.0
        if conv == "standard":
            rows[3].update(a=0.0, alpha=al)
            rows[4].update(a=0.0, d=0.0, alpha=-al)
            rows[5].update(a=0.0, alpha=0.0)
        else:
            rows[4].update(a=0.0, d=0.0, alpha=al)
            rows[5].update(a=0.0, alpha=-al)
            rows[3].update(d=rows[3]["d"] or 300.0)
    if style == "ur_like" and conv == "standard":
        rows[0].update(a=0.0, alpha=90.0)
        rows[1].update(alpha=0.0, d=0.0)
        rows[2].update(alpha=0.0, d=0.0)
        rows[3].update(a=0.0, alpha=90.0)
        rows[4].update(a=0.0, alpha=-90.0)
        rows[5].update(a=0.0, alpha=0.0)
    doc: dict[str, Any] = {"convention": conv, "links": rows}
    length, angle = str(rng.choice(["mm", "mm", "m"])), str(rng.choice(["deg", "deg", "rad"]))
    if length != "mm" or angle != "deg" or rng.random() < 0.3:
        doc["units"] = {"length": length, "angle": angle}
    L = 1000.0 if length == "m" else 1.0
    A = math.pi / 180.0 if angle == "rad" else 1.0
    for row in rows:
        pris = row.get("type") == "prismatic"
        for k in ("a", "d"):
            row[k] = row[k] / L
        row["alpha"] = row["alpha"] * A
        if "theta" in row:
            row["theta"] = row["theta"] * A
        qs = 1.0 / L if pris else A
        if "offset" in row:
            row["offset"] = row["offset"] * qs
        if "limits" in row:
            row["limits"] = [None if v is None else v * qs for v in row["limits"]]
    if rng.random() < 0.3:
        doc["base"] = _rigid(rng, 300.0)
        for r in doc["base"][:3]:
            r[3] /= L
    if rng.random() < 0.3:
        doc["tool"] = _rigid(rng, 100.0)
        for r in doc["tool"][:3]:
            r[3] /= L
    bad = ""
    if rng.random() < 0.08:
        what = str(
            rng.choice(
                [
                    "unknown_key",
                    "limits",
                    "string",
                    "nan",
                    "base",
                    "convention",
                    "empty",
                    "joint_type",
                ]
            )
        )
        if what == "unknown_key":
            doc["links"][0]["twist"] = 1.0
            bad = "an unknown key in a D-H row"
        elif what == "limits":
            doc["links"][0]["limits"] = [10.0, -10.0]
            bad = "limits with lower > upper"
        elif what == "string":
            doc["links"][-1]["a"] = "long"
            bad = "a string for a length"
        elif what == "nan":
            doc["links"][0]["d"] = math.nan
            bad = "NaN in the table"
        elif what == "base":
            doc["base"] = [[1, 0, 0], [0, 1, 0]]
            bad = "a base that is not 4x4"
        elif what == "convention":
            doc["convention"] = "denavit"
            bad = "an unknown convention"
        elif what == "empty":
            doc["links"] = []
            bad = "no links"
        else:
            doc["links"][0]["type"] = "spherical"
            bad = "an unknown joint type"
    return doc, f"{n}-joint {style} {conv} ({length}, {angle})", bad


def _robot_for(case: Case, rng: np.random.Generator, work: Path) -> tuple[str, dict[str, Any]]:
    """The ``--model`` value (a file or a built-in name) and its D-H table (robot-file dict)."""
    u = rng.random()
    if u < 0.12:
        name = str(rng.choice(list(BUILTIN_TABLES)))
        case.facts["robot"] = name
        return name, BUILTIN_TABLES[name]
    doc, style, bad = random_robot(rng)
    case.facts["robot"] = style
    if bad:
        case.expect_error = bad
    case.files["robot.json"] = json.dumps(doc)
    return "robot.json", doc


def _q_for(rng: np.random.Generator, robot: ir.DHRobot, singular: bool) -> np.ndarray:
    lo = np.where(np.isfinite(robot.lower), robot.lower, np.where(robot.prismatic, 0, -np.pi))
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.where(robot.prismatic, 500, np.pi))
    q = rng.uniform(lo, hi)
    if rng.random() < 0.2:  # a joint at its limit
        j = int(rng.integers(robot.n))
        q[j] = lo[j] if rng.random() < 0.5 else hi[j]
    if singular and robot.n >= 5:
        j = int(rng.integers(robot.n))
        if not robot.prismatic[j]:
            q[j] = float(rng.choice([0.0, math.pi / 2, math.pi, -math.pi / 2]))
            q[j] = float(np.clip(q[j], lo[j], hi[j]))
    return q


def gen_fk(case: Case, rng: np.random.Generator, work: Path) -> None:
    p = case.params
    if rng.random() < 0.25:
        p["model"] = "seed"
        q = random_configs(rng, 1)[0] if rng.random() < 0.8 else rng.uniform(-400, 400, 6)
        p["q_display"] = _vec(q)
        case.summary = f"fk seed {p['q_display']}"
        return
    p["model"], table = _robot_for(case, rng, work)
    p["table"] = table
    if case.expect_error:
        p["q_display"] = [0.0] * max(1, len(table["links"]))
        case.summary = f"fk of an invalid robot file ({case.expect_error})"
        return
    robot = ir.DHRobot.from_file(table)
    q = _q_for(rng, robot, rng.random() < 0.3)
    p["q_internal"] = [float(x) for x in q]
    p["q_display"] = [
        float(math.degrees(v)) if not pr else float(v)
        for v, pr in zip(q, robot.prismatic, strict=True)
    ]
    if rng.random() < 0.05:
        p["q_display"] = p["q_display"][:-1] + ([] if robot.n > 1 else [0.0, 0.0])
        case.expect_error = "the wrong number of joint values"
    case.summary = f"fk {case.facts['robot']}"


def gen_ik(case: Case, rng: np.random.Generator, work: Path) -> None:
    p = case.params
    if rng.random() < 0.15:
        p["model"] = "seed"
        q = random_configs(rng, 1)[0]
        target = tip_of(q)
        if rng.random() < 0.2:
            target = target / np.linalg.norm(target) * 2000.0
            case.facts["reachable"] = False
        else:
            case.facts["reachable"] = True
        p["xyz"] = _vec(target)
        case.summary = f"ik seed --xyz {p['xyz']}"
        return
    p["model"], table = _robot_for(case, rng, work)
    p["table"] = table
    if case.expect_error:
        p["pose"] = np.eye(4).tolist()
        case.summary = f"ik with an invalid robot file ({case.expect_error})"
        return
    robot = ir.DHRobot.from_file(table)
    singular = rng.random() < 0.25
    q = _q_for(rng, robot, singular)
    T = robot.pose(q)
    case.facts["singular_try"] = singular
    if rng.random() < 0.12:  # out of reach: the pose moved far away
        T[:3, 3] = T[:3, 3] + _unit(rng) * (1e4 + np.abs(table_reach(robot)))
        case.facts["reachable"] = False
    else:
        case.facts["reachable"] = True
        p["generating_q"] = [float(x) for x in q]
    if rng.random() < 0.2 or robot.n != 6:
        p["xyz"] = _vec(T[:3, 3])
        case.summary = f"ik {case.facts['robot']} --xyz"
    else:
        p["pose"] = T.tolist()
        case.summary = f"ik {case.facts['robot']} --pose" + (" (singular)" if singular else "")


def table_reach(robot: ir.DHRobot) -> float:
    return float(np.abs(robot.a).sum() + np.abs(robot.d).sum() + 500.0)


# --- scene files ---------------------------------------------------------------------------


def gen_scene(case: Case, rng: np.random.Generator, work: Path) -> None:
    files: dict[str, str] = {}
    spec = random_scene(rng, files, 8)
    if rng.random() < 0.35:
        case.expect_error = _invalidate(spec, rng, files)
    case.files.update(files)
    case.params["scene_spec"] = spec
    case.params["scene_file"] = write_scene(rng, spec, case.files)
    types = collections.Counter(o.get("type") for o in spec["obstacles"])
    case.summary = "load a scene: " + ", ".join(f"{n} {t}" for t, n in sorted(types.items()))
    if case.expect_error:
        case.summary += f" ({case.expect_error})"


GENERATORS: dict[str, Callable[[Case, np.random.Generator, Path], None]] = {
    "fk": gen_fk,
    "ik": gen_ik,
    "scene": gen_scene,
    "reach": gen_reach,
    "plan": gen_plan,
    "trace": gen_trace,
    "spotweld": gen_spotweld,
}


# =============================================================================================
# Running a case through the library
# =============================================================================================


class RejectedError(Exception):
    """The case failed: a rejected result, a wrong error, an invalid result document."""


def _strict_json(doc: dict[str, Any]) -> dict[str, Any]:
    try:
        return json.loads(json.dumps(doc, allow_nan=False))
    except (ValueError, TypeError) as exc:
        raise RejectedError(f"the result document is not strict JSON: {exc}") from None


def _replay_motion(case: Case, doc: dict[str, Any]) -> dict[str, Any]:
    p = case.params
    truth = ir.Truth(
        start_deg=p.get("start_deg", HOME_DEG),
        target=p.get("target") or p.get("to_xyz"),
        goal_deg=p.get("to"),
        targets=case.targets,
        curve=case.curve,
        tolerance=p.get("tolerance"),
        return_to_start=p.get("return"),
    )
    rep = ir.replay_result(doc, case.scene, truth, arm=case.arm)
    if rep.problems:
        raise RejectedError("; ".join(rep.problems[:4]))
    facts = {k: v for k, v in rep.facts.items() if isinstance(v, int | float | str)}
    facts["commands"] = doc.get("n_commands")
    _check_lower_bound(doc, truth)
    return facts


#: Largest claimed lower bound checked exhaustively (the check of ``b - 1`` commands takes about
#: 1 s for b = 2 and 10 s for b = 3).
LOWER_BOUND_CHECKED = 3


def _check_lower_bound(doc: dict[str, Any], truth: ir.Truth) -> None:
    """A reach's lower bound ``b`` (over every configuration, obstacles ignored) is wrong if
    some lattice state within ``b - 1`` commands of the start puts the fingertip within the
    tolerance: ``independent.lattice_has_state_within`` enumerates them (small ``b`` only)."""
    import independent

    b = doc.get("lower_bound_commands")
    if doc.get("task") != "reach" or not isinstance(b, int) or not 2 <= b <= LOWER_BOUND_CHECKED:
        return
    if independent.lattice_has_state_within(
        truth.target, truth.start_deg, b - 1, float(truth.tolerance or doc["tolerance_mm"])
    ):
        raise RejectedError(
            f"claims a lower bound of {b} commands, but a lattice state within {b - 1} "
            "commands puts the fingertip within the tolerance (exhaustive independent search)"
        )


def _library_scene(case: Case, work: Path) -> Any:
    from armpath.scenes import load_scene

    scene = load_scene(work / case.params["scene_file"])
    wall = case.params.get("wall")
    return scene.with_wall_thickness(wall) if wall else scene


def _seed_arm(case: Case) -> Any:
    from armpath.model.seed_arm import SeedArmGeometry, seed_arm

    return seed_arm(SeedArmGeometry(link_radius_mm=case.params.get("link_radius", 0.0)))


def run_reach(case: Case, work: Path) -> dict[str, Any]:
    from armpath.commands import deg_to_ticks
    from armpath.export import reach_result_dict
    from armpath.planning.reach import ReachOptions, plan_reach

    p = case.params
    arm = _seed_arm(case)
    start = deg_to_ticks(p["start_deg"], what="--from angles")
    options = ReachOptions(tolerance_mm=p["tolerance"])
    scene = _library_scene(case, work)
    result = plan_reach(arm, scene.world, start, np.array(p["target"]), options)
    return reach_result_dict(result, arm, scene)


def run_plan(case: Case, work: Path) -> dict[str, Any]:
    from armpath.commands import deg_to_ticks
    from armpath.export import plan_result_dict
    from armpath.planning.motion import MotionOptions, plan_motion
    from armpath.planning.reach import goal_states

    p = case.params
    arm = _seed_arm(case)
    start = deg_to_ticks(p["start_deg"], what="--from angles")
    options = MotionOptions(
        objective=p["objective"],
        energy_weights=tuple(p["weights"]) if p.get("weights") else None,
        seed=p["seed"],
    )
    scene = _library_scene(case, work)
    if "to_xyz" in p:
        xyz = np.array(p["to_xyz"])
        goals, _ = goal_states(arm, scene.world, start, xyz, p["tolerance"])
        plan = plan_motion(arm, scene.world, start, goals, options)
        return plan_result_dict(plan, arm, scene, p["objective"], xyz, p["tolerance"])
    goal = deg_to_ticks(p["to"], what="--to angles")
    plan = plan_motion(arm, scene.world, start, goal[None, :], options)
    return plan_result_dict(plan, arm, scene, p["objective"], None, None)


def run_trace(case: Case, work: Path) -> dict[str, Any]:
    from armpath.export import trace_result_dict
    from armpath.planning.motion import MotionOptions
    from armpath.planning.trace import TraceOptions
    from armpath.tasks import trace_task

    p = case.params
    arm = _seed_arm(case)
    scene = _library_scene(case, work)
    options = TraceOptions(tolerance_mm=p["tolerance"], motion=MotionOptions(seed=p["seed"]))
    result = trace_task(scene, arm, options)
    return trace_result_dict(result, arm, scene)


def run_spotweld(case: Case, work: Path) -> dict[str, Any]:
    from armpath.export import tour_result_dict
    from armpath.planning.motion import MotionOptions
    from armpath.tasks import spotweld_task

    p = case.params
    arm = _seed_arm(case)
    scene = _library_scene(case, work)
    options = MotionOptions(objective=p["objective"], seed=p["seed"])
    result = spotweld_task(scene, arm, p["order"], p["return"], p["tolerance"], options)
    return tour_result_dict(result, arm, scene, p["objective"])


def _display_to_internal(arm: Any, values: list[float]) -> np.ndarray:
    from armpath.errors import InvalidInputError
    from armpath.model.serial_arm import JointKind

    if len(values) != arm.n_joints:
        raise InvalidInputError(f"expected {arm.n_joints} joint values, got {len(values)}")
    return np.array(
        [
            math.radians(v) if j.kind is JointKind.REVOLUTE else v
            for v, j in zip(values, arm.joints, strict=True)
        ]
    )


def run_fk(case: Case, work: Path) -> dict[str, Any]:
    from armpath.kinematics import landmark_positions, tool_pose
    from armpath.model.catalog import resolve_model

    p = case.params
    model = p["model"] if p["model"] in ("seed", *BUILTIN_TABLES) else str(work / p["model"])
    arm = resolve_model(model)
    q = _display_to_internal(arm, p["q_display"])
    pts = landmark_positions(arm, q)
    return {
        "points": {n: [float(c) for c in x] for n, x in zip(arm.landmark_names, pts, strict=True)},
        "pose": tool_pose(arm, q).tolist(),
    }


def run_ik(case: Case, work: Path) -> dict[str, Any]:
    from armpath.errors import PlanningError
    from armpath.ik import solve_ik
    from armpath.model.catalog import resolve_model

    p = case.params
    model = p["model"] if p["model"] in ("seed", *BUILTIN_TABLES) else str(work / p["model"])
    arm = resolve_model(model)
    if "xyz" in p:
        result = solve_ik(arm, np.array(p["xyz"]), position_only=True)
    else:
        result = solve_ik(arm, np.array(p["pose"]))
    doc = {
        "method": result.method,
        "count": result.count,
        "solutions": result.solutions.tolist(),
        "within_limits": [
            bool(v) for v in (result.within_limits if result.within_limits is not None else [])
        ],
        "reason": result.reason,
    }
    if result.count == 0:  # the command line's exit: a clear error (or not)
        if not result.reason.strip() or "\n" in result.reason:
            raise RejectedError(f"no solution and no one-line reason: {result.reason!r}")
        case.facts["ik_doc"] = doc
        raise PlanningError(f"no solution ({result.method}): {result.reason}")
    return doc


def _complete_method(method: str) -> bool:
    """Whether an IK method claims every solution (closed forms, the elimination), not a
    numerical search (Levenberg-Marquardt from seeds, also as a fallback)."""
    return not any(k in method for k in ("levenberg", "numerical"))


def check_fk_doc(case: Case, doc: dict[str, Any]) -> dict[str, Any]:
    p = case.params
    if p["model"] == "seed":
        problems = ir.check_fk(None, p["q_display"], doc)
    else:
        problems = ir.check_fk(ir.DHRobot.from_file(p["table"]), p["q_internal"], doc)
    if problems:
        raise RejectedError("; ".join(problems[:4]))
    return {}


def check_ik_doc(case: Case, doc: dict[str, Any]) -> dict[str, Any]:
    p = case.params
    if p["model"] == "seed":
        sols = np.degrees(np.asarray(doc["solutions"], float).reshape(-1, 6))
        miss = np.linalg.norm(ir.SeedArm.points(sols)[:, 4] - np.array(p["xyz"]), axis=1)
        if miss.size and miss.max() > 1e-3:
            raise RejectedError(f"a seed-arm solution misses the point by {miss.max():.3g} mm")
        return {"solutions": len(sols)}
    robot = ir.DHRobot.from_file(p["table"])
    gen = np.array(p["generating_q"]) if "generating_q" in p else None
    if "xyz" in p:
        problems, facts = ir.check_ik(robot, np.array(p["xyz"]), doc, None, position_only=True)
    else:
        problems, facts = ir.check_ik(robot, np.array(p["pose"]), doc, gen)
        complete = _complete_method(doc["method"])
        if gen is not None and complete and not facts.get("found_generating", True):
            sigma = facts.get("generating_sigma_min", 0.0)
            case.facts["missed_generating"] = sigma
            if sigma > 1e-2:
                problems.append(
                    f"{doc['method']} (complete) misses the generating solution "
                    f"{np.round(gen, 6).tolist()} (well conditioned: sigma_min {sigma:.3g})"
                )
    if problems:
        raise RejectedError("; ".join(problems[:4]))
    return {k: v for k, v in facts.items() if isinstance(v, int | float | bool)}


def run_scene(case: Case, work: Path) -> Any:
    from armpath.scenes import load_scene

    return load_scene(work / case.params["scene_file"])


def check_scene(case: Case, scene: Any, work: Path) -> dict[str, Any]:
    """The loaded obstacles' signed distances and segment minima against the independent
    formulas, at random points around every obstacle."""
    rng = np.random.default_rng([case.seed, case.index, 7])
    truth = ir.Scene.from_spec(case.params["scene_spec"], work)
    mine = {o.name: o for o in truth.obstacles}
    theirs = {o.name: o for o in scene.world.obstacles}
    if sorted(mine) != sorted(theirs):
        raise RejectedError(f"obstacles {sorted(theirs)} loaded, the file has {sorted(mine)}")
    worst = 0.0
    for name, o in mine.items():
        center, radius = o.ball if o.ball else (np.zeros(3), 800.0)
        radius = min(radius, 2e3) if o.ball is None or radius > 1e4 else radius
        if o.ball is not None and o.scale > 1e4 and radius > 1e4:
            # a huge solid: look near the arm, where its surface matters
            center, radius = np.zeros(3), 1500.0
        X = center + rng.normal(size=(200, 3)) * radius * 0.8
        X = np.vstack([X, rng.normal(size=(60, 3)) * 400.0])
        want = o.sdf(X)
        got = np.asarray(theirs[name].signed_distance(X), float)
        scale = 1.0 + float(np.abs(X).max()) + o.scale
        tol = 1e-6 + 1e-12 * scale + 1e-9 * np.abs(want)
        bad = np.abs(got - want) > tol
        if np.any(bad):
            k = int(np.argmax(np.abs(got - want) - tol))
            raise RejectedError(
                f"{name} ({o.kind}): signed distance at {X[k].tolist()} is {got[k]:.9g}, "
                f"independent {want[k]:.9g}"
            )
        # segments: the reported minimum over a segment against dense samples of it
        A, B = X[:40], X[40:80]
        s = np.linspace(0.0, 1.0, 401)
        seg_min = np.array(
            [o.sdf(a + s[:, None] * (b - a)).min() for a, b in zip(A, B, strict=True)]
        )
        spacing = np.linalg.norm(B - A, axis=1) / 400
        value, lower = theirs[name].segment_distance_bounds(A, B)
        value, lower = np.asarray(value, float), np.asarray(lower, float)
        tol = 1e-6 + 1e-12 * scale + 1e-9 * np.abs(seg_min)
        if np.any(lower > seg_min + tol):
            k = int(np.argmax(lower - seg_min))
            raise RejectedError(
                f"{name}: segment lower bound {lower[k]:.9g} above a sampled "
                f"distance {seg_min[k]:.9g} on {A[k].tolist()} -> {B[k].tolist()}"
            )
        if np.any(value < seg_min - spacing / 2 - tol):
            k = int(np.argmax(seg_min - spacing / 2 - value))
            raise RejectedError(
                f"{name}: segment minimum {value[k]:.9g} below anything the segment "
                f"attains (sampled {seg_min[k]:.9g}, spacing {spacing[k]:.3g})"
            )
        if o.kind != "mesh" and np.any(value > seg_min + tol):
            k = int(np.argmax(value - seg_min))
            if value[k] >= 0 > seg_min[k]:
                raise RejectedError(
                    f"{name} ({o.kind}): segment_distance_bounds gives {value[k]:.3g} (lower "
                    f"bound {lower[k]:.3g}) for a segment that goes {-seg_min[k]:.4g} mm into "
                    f"the solid: {A[k].tolist()} -> {B[k].tolist()}"
                )
            raise RejectedError(
                f"{name}: segment minimum {value[k]:.9g} above a sampled distance "
                f"{seg_min[k]:.9g} on {A[k].tolist()} -> {B[k].tolist()}"
            )
        worst = max(worst, float(np.abs(got - want).max()))
    return {"obstacles": len(mine), "worst_sdf_diff": worst}


RUNNERS: dict[str, Callable[[Case, Path], Any]] = {
    "fk": run_fk,
    "ik": run_ik,
    "scene": run_scene,
    "reach": run_reach,
    "plan": run_plan,
    "trace": run_trace,
    "spotweld": run_spotweld,
}


def check_result(case: Case, result: Any, work: Path) -> dict[str, Any]:
    if case.expect_error:
        raise RejectedError(f"accepted invalid input ({case.expect_error})")
    if case.kind == "scene" and not isinstance(result, dict):
        return check_scene(case, result, work)
    if case.kind == "scene":  # through the command line: a reach in the scene
        case.scene, case.arm = truth_scene(case.params["scene_spec"], work)
        case.params.update(start_deg=list(HOME_DEG), target=CLI_SCENE_TARGET, tolerance=0.05)
    doc = _strict_json(result)
    if case.kind == "fk":
        return check_fk_doc(case, doc)
    if case.kind == "ik":
        return check_ik_doc(case, doc)
    return _replay_motion(case, doc)


def check_error(case: Case, exc: BaseException) -> None:
    """Raise :class:`RejectedError` when an armpath error is malformed or contradicts the truth."""
    msg = str(exc)
    if not msg.strip():
        raise RejectedError(f"{type(exc).__name__} with an empty message")
    if "\n" in msg.strip():
        raise RejectedError(f"{type(exc).__name__} message has several lines: {msg[:200]!r}")
    name = type(exc).__name__
    if case.expect_error or name == "TimeLimitError":
        return
    f, p = case.facts, case.params
    extra = f.get("stretch_extra_mm")
    if name == "UnreachableError" and extra is not None and extra <= p.get("tolerance", 0) - 1e-6:
        raise RejectedError(
            f"says unreachable, but the target is {extra} mm beyond full stretch and the "
            f"tolerance is {p['tolerance']} mm: {msg}"
        )
    if name == "UnreachableError" and f.get("target_reachable"):
        raise RejectedError(
            f"says unreachable, but the target is the fingertip of "
            f"{f.get('target_from', 'a state inside the limits')}: {msg}"
        )
    if case.kind in ("reach", "plan") and case.scene is not None and case.arm is not None:
        start_ok = is_clear(case.scene, case.arm, p["start_deg"])
        if name == "CollisionError":
            target = p.get("target") or p.get("to_xyz")
            outside = target is None or bool(np.all(case.scene.sdf(np.array([target]))[0] > 1e-3))
            goal_ok = "to" not in p or is_clear(case.scene, case.arm, p["to"])
            if start_ok and outside and goal_ok:
                raise RejectedError(
                    f"CollisionError, but the start{' and goal' if 'to' in p else ''} "
                    f"keep the clearance rule and the target is outside: {msg}"
                )
        if name == "JointLimitError":
            raise RejectedError(f"JointLimitError for states inside the limits: {msg}")
    if case.kind == "ik" and "generating_q" in p and "pose" in p and p["model"] != "seed":
        method = case.facts.get("ik_doc", {}).get("method", "")
        if _complete_method(method):
            robot = ir.DHRobot.from_file(p["table"])
            J = robot.pose_jacobian(np.array(p["generating_q"]))
            sigma = float(np.linalg.svd(J, compute_uv=False)[-1])
            if sigma > 1e-2:
                raise RejectedError(
                    f"no solution from {method} (complete) for the pose of "
                    f"{np.round(p['generating_q'], 6).tolist()} (sigma_min "
                    f"{sigma:.3g}): {msg}"
                )


# =============================================================================================
# The command line
# =============================================================================================


def _armpath_cmd() -> list[str]:
    exe = Path(sys.executable).parent / "armpath"
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "armpath"]


_TIME_LIMIT_SUPPORT: dict[str, bool] = {}


def _accepts_time_limit(command: str) -> bool:
    if command not in _TIME_LIMIT_SUPPORT:
        r = subprocess.run(
            [*_armpath_cmd(), command, "--help"],
            capture_output=True,
            text=True,
            env={**os.environ, "COLUMNS": "200"},
            timeout=60,
        )
        _TIME_LIMIT_SUPPORT[command] = "--time-limit" in r.stdout
    return _TIME_LIMIT_SUPPORT[command]


def _num(x: float) -> str:
    return repr(float(x)) if math.isfinite(x) else str(x)


def cli_args(case: Case, work: Path, out_dir: Path | None) -> list[str]:
    """The command line equivalent of the case (``--json``, or ``--out`` when given)."""
    p = case.params
    k = case.kind
    if k == "fk":
        model = p["model"] if p["model"] in ("seed", *BUILTIN_TABLES) else str(work / p["model"])
        args = ["fk", *map(_num, p["q_display"]), "--model", model]
    elif k == "ik":
        model = p["model"] if p["model"] in ("seed", *BUILTIN_TABLES) else str(work / p["model"])
        args = ["ik", "--model", model]
        if "xyz" in p:
            args += ["--xyz", *map(_num, p["xyz"])]
        else:
            args += ["--pose", " ".join(_num(v) for row in p["pose"] for v in row)]
    elif k in ("reach", "scene"):
        target = p.get("target", CLI_SCENE_TARGET)
        args = ["reach", *map(_num, target), "--scene", str(work / p["scene_file"])]
        if k == "reach":
            args += [
                "--from",
                *map(_num, p["start_deg"]),
                "--tolerance",
                _num(p["tolerance"]),
                "--link-radius",
                _num(p["link_radius"]),
            ]
            if p.get("wall"):
                args += ["--wall", p["wall"]]
    elif k == "plan":
        args = [
            "plan",
            "--scene",
            str(work / p["scene_file"]),
            "--from",
            *map(_num, p["start_deg"]),
            "--objective",
            p["objective"],
            "--seed",
            str(p["seed"]),
            "--tolerance",
            _num(p["tolerance"]),
            "--link-radius",
            _num(p["link_radius"]),
        ]
        args += (
            ["--to", *map(_num, p["to"])] if "to" in p else ["--to-xyz", *map(_num, p["to_xyz"])]
        )
        if p.get("weights"):
            args += ["--weights", ",".join(map(_num, p["weights"]))]
        if p.get("wall"):
            args += ["--wall", p["wall"]]
    elif k == "trace":
        args = [
            "trace",
            "--scene",
            str(work / p["scene_file"]),
            "--tolerance",
            _num(p["tolerance"]),
            "--seed",
            str(p["seed"]),
        ]
    else:
        args = [
            "spotweld",
            "--scene",
            str(work / p["scene_file"]),
            "--order",
            p["order"],
            "--tolerance",
            _num(p["tolerance"]),
            "--objective",
            p["objective"],
            "--seed",
            str(p["seed"]),
        ]
        if p["return"]:
            args.append("--return")
    if out_dir is not None and k in ("reach", "plan", "trace", "spotweld", "scene"):
        args += ["--out", str(out_dir)]
    else:
        args.append("--json")
    if _accepts_time_limit(args[0]):
        args += ["--time-limit", _num(case.budget)]
    return args


def run_cli(case: Case, work: Path) -> dict[str, Any]:
    """Run the case through the command line; returns facts or raises Rejected / a clear
    error marker (:class:`CliError`)."""
    rng = np.random.default_rng([case.seed, case.index, 11])
    use_out = case.kind in ("reach", "plan", "trace", "spotweld", "scene") and rng.random() < 0.4
    out_dir = work / "out" / "sub" if use_out else None
    args = cli_args(case, work, out_dir)
    env = {**os.environ, "COLUMNS": "120", "NO_COLOR": "1", "NUMBA_NUM_THREADS": "1"}
    started = time.monotonic()
    try:
        proc = subprocess.run(
            [*_armpath_cmd(), *args],
            capture_output=True,
            text=True,
            cwd=work,
            env=env,
            timeout=HANG_FACTOR * case.budget + CLI_STARTUP_S,
        )
    except subprocess.TimeoutExpired:
        raise HangError(
            f"the command line ran past {HANG_FACTOR} x its budget: armpath {shlex.join(args)}"
        ) from None
    took = time.monotonic() - started
    if took > HANG_FACTOR * case.budget + CLI_STARTUP_S:
        raise HangError(
            f"the command line took {took:.1f} s, past {HANG_FACTOR:g} x its budget of "
            f"{case.budget:g} s (+{CLI_STARTUP_S:g} s to start): armpath {shlex.join(args)}"
        )
    err_lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    if "Traceback" in proc.stderr:
        raise RejectedError(
            f"exit {proc.returncode} with a traceback: {proc.stderr.strip().splitlines()[-1]}"
        )
    if proc.returncode == 0:
        if out_dir is not None:
            stem = {"scene": "reach"}.get(case.kind, case.kind)
            path = out_dir / f"{stem}.json"
            if not path.is_file():
                raise RejectedError(f"exit 0 but no {path.name} in --out")
            doc = json.loads(path.read_text())
        else:
            if not proc.stdout.strip():
                raise RejectedError("exit 0 without output")
            doc = json.loads(proc.stdout)
        if case.kind in ("fk", "ik"):
            doc = _cli_kinematics_doc(case, doc)
        return check_result(case, doc, work)
    if proc.returncode == 2 and case.expect_error:
        # the option parser refused an invalid value (e.g. a --wall choice): a usage error,
        # one 'error:' line like every other error
        usage = [ln for ln in err_lines if not ln.startswith("armpath:")]
        if len(usage) != 1 or not usage[0].startswith("error:"):
            raise RejectedError(
                f"exit 2 but stderr is not one 'error:' line: {proc.stderr[:400]!r}"
            )
        raise CliError(usage[0][len("error:") :].strip())
    if proc.returncode != 1:
        raise RejectedError(f"exit {proc.returncode}: {proc.stderr.strip()[:300]}")
    errors = [ln for ln in err_lines if ln.startswith("error:")]
    others = [ln for ln in err_lines if not ln.startswith(("error:", "armpath:", "warning:"))]
    if len(errors) != 1 or others or not err_lines[-1].startswith("error:"):
        raise RejectedError(
            f"exit 1 but stderr is not one 'error:' line after progress lines: "
            f"{proc.stderr.strip()[:400]!r}"
        )
    if out_dir is not None:
        leftovers = [q.name for q in work.glob(".armpath-*")] + [
            q.name for q in (work / "out").glob(".armpath-*") if (work / "out").is_dir()
        ]
        if out_dir.exists() or leftovers:
            raise RejectedError(
                f"an error left output behind: {out_dir if out_dir.exists() else leftovers}"
            )
    raise CliError(errors[0][len("error:") :].strip())


def _cli_kinematics_doc(case: Case, doc: dict[str, Any]) -> dict[str, Any]:
    """The command line's fk / ik JSON in the library's units (rad / mm)."""
    if case.kind == "fk":
        return {"points": doc["points"], "pose": doc["pose"]}
    units = doc.get("units", {}).get("joints", [])
    sols = np.array(doc["solutions"], float)
    for j, u in enumerate(units):
        if u == "deg" and sols.size:
            sols[:, j] = np.radians(sols[:, j])
    return {
        "method": doc["method"],
        "solutions": sols.tolist(),
        "within_limits": doc.get("within_limits"),
    }


class CliError(Exception):
    """The command line exited 1 with one error line (a clear error)."""


class HangError(Exception):
    """The case ran past twice its budget."""


# =============================================================================================
# One case, start to end
# =============================================================================================


def _check_finished_in_time(case: Case, elapsed: float) -> None:
    if elapsed > HANG_FACTOR * case.budget:
        raise HangError(
            f"finished after {elapsed:.1f} s, past {HANG_FACTOR:g} x its budget "
            f"of {case.budget:g} s"
        )


def run_case(
    case: Case, work: Path, on_solved: Callable[[], None] = lambda: None
) -> dict[str, Any]:
    """Run a generated case: ``{"outcome": "result" | "error" | "failure", ...}``."""
    from armpath.budget import time_limit
    from armpath.errors import ArmpathError

    rec: dict[str, Any] = {
        "index": case.index,
        "kind": case.kind,
        "cli": case.cli,
        "summary": case.summary,
        "budget": case.budget,
    }
    t0 = time.monotonic()
    try:
        if case.cli:
            try:
                rec["facts"] = run_cli(case, work)
                rec["outcome"] = "result"
            except CliError as exc:
                rec.update(outcome="error", category="cli error", message=str(exc))
            return rec
        try:
            with time_limit(case.budget):
                result = RUNNERS[case.kind](case, work)
        except ArmpathError as exc:
            rec["elapsed"] = time.monotonic() - t0
            on_solved()
            _check_finished_in_time(case, rec["elapsed"])
            check_error(case, exc)
            rec.update(outcome="error", category=type(exc).__name__, message=str(exc)[:300])
            return rec
        rec["elapsed"] = time.monotonic() - t0
        on_solved()
        _check_finished_in_time(case, rec["elapsed"])
        t1 = time.monotonic()
        rec["facts"] = check_result(case, result, work)
        rec["replay_s"] = time.monotonic() - t1
        rec["outcome"] = "result"
    except RejectedError as exc:
        rec.update(outcome="failure", category="rejected", message=str(exc)[:1500])
    except HangError as exc:
        rec.update(outcome="failure", category="hang", message=str(exc)[:600])
    except Exception as exc:
        tb = traceback.format_exc()
        rec.update(
            outcome="failure",
            category=f"crash: {type(exc).__name__}",
            message=f"{type(exc).__name__}: {str(exc)[:400]}",
            traceback=tb[-4000:],
        )
    finally:
        rec.setdefault("elapsed", time.monotonic() - t0)
    return rec


# =============================================================================================
# Workers and the watchdog
# =============================================================================================


def _worker(conn: mpc.Connection, seed: int, kinds: list[str], budget: float, share: float) -> None:
    import resource

    for var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ[var] = "1"  # one core per worker (armpath is imported after this)

    with contextlib.suppress(ValueError, OSError):
        resource.setrlimit(resource.RLIMIT_AS, (6 << 30, 6 << 30))
    # on SIGUSR1 (sent by the watchdog before it kills a hung case) write where it is stuck
    stacks = _stack_file(os.getpid()).open("w")
    faulthandler.register(signal.SIGUSR1, file=stacks, all_threads=False)
    import warnings

    warnings.filterwarnings("ignore")
    while True:
        index = conn.recv()
        if index is None:
            stacks.close()
            _stack_file(os.getpid()).unlink(missing_ok=True)
            return
        work = Path(tempfile.mkdtemp(prefix=f"stress-{seed}-{index}-"))
        try:
            try:
                case = make_case(seed, index, kinds, budget, share, work)
            except Exception as exc:
                conn.send(
                    (
                        "done",
                        index,
                        {
                            "index": index,
                            "kind": "?",
                            "outcome": "failure",
                            "category": "generator",
                            "message": f"{type(exc).__name__}: {exc}",
                            "traceback": traceback.format_exc()[-3000:],
                        },
                    )
                )
                continue
            conn.send(("start", index, case.kind, case.budget, case.cli, case.summary))
            rec = run_case(case, work, lambda i=index: conn.send(("solved", i)))
            conn.send(("done", index, rec))
        finally:
            shutil.rmtree(work, ignore_errors=True)


def _stack_file(pid: int) -> Path:
    return Path(tempfile.gettempdir()) / f"armpath-stress-stack-{pid}.txt"


def where_stuck(dump: str) -> str:
    """The innermost armpath frames of a faulthandler dump, as ``; in f (file:line) < ...``."""
    frames = []
    for line in dump.splitlines():
        line = line.strip()
        if line.startswith("File ") and "/armpath/" in line:
            path, _, rest = line.partition(", line ")
            lineno, _, func = rest.partition(" in ")
            frames.append(f"{func} ({path.split('/armpath/')[-1].rstrip(chr(34))}:{lineno})")
    return ("; stuck in " + " < ".join(frames[:4])) if frames else ""


@dataclass
class _Slot:
    proc: Any = None
    conn: Any = None
    index: int | None = None
    phase: str = ""
    since: float = 0.0
    budget: float = 0.0
    cli: bool = False
    info: dict[str, Any] = field(default_factory=dict)


def run_pool(
    seed: int,
    indices: list[int],
    kinds: list[str],
    budget: float,
    share: float,
    jobs: int,
    on_record: Callable[[dict[str, Any]], None],
) -> None:
    ctx = mp.get_context("fork")
    todo = collections.deque(indices)
    slots = [_Slot() for _ in range(jobs)]

    def start(slot: _Slot) -> None:
        parent, child = ctx.Pipe()
        slot.proc = ctx.Process(
            target=_worker, args=(child, seed, kinds, budget, share), daemon=True
        )
        slot.proc.start()
        child.close()
        slot.conn = parent
        slot.index = None

    def kill(slot: _Slot) -> None:
        with contextlib.suppress(Exception):
            slot.proc.kill()
            slot.proc.join(5)
        _stack_file(slot.proc.pid).unlink(missing_ok=True)
        start(slot)

    def stuck_at(slot: _Slot) -> str:
        """Where the worker's Python code is (its innermost armpath frames)."""
        with contextlib.suppress(Exception):
            os.kill(slot.proc.pid, signal.SIGUSR1)
            time.sleep(1.0)
            return where_stuck(_stack_file(slot.proc.pid).read_text())
        return ""

    for s in slots:
        start(s)
    while todo or any(s.index is not None for s in slots):
        for s in slots:
            if s.index is None and todo:
                s.index = todo.popleft()
                s.phase, s.since, s.info = "generating", time.monotonic(), {}
                s.conn.send(s.index)
        busy = [s.conn for s in slots if s.index is not None]
        for conn in mpc.wait(busy, timeout=1.0):
            s = next(x for x in slots if x.conn is conn)
            try:
                msg = conn.recv()
            except (EOFError, OSError):
                code = s.proc.exitcode
                on_record(
                    {
                        "index": s.index,
                        "kind": s.info.get("kind", "?"),
                        "cli": s.info.get("cli", False),
                        "summary": s.info.get("summary", ""),
                        "outcome": "failure",
                        "category": "worker died",
                        "message": f"the worker process died (exit code {code}) during the "
                        f"{s.phase} phase",
                    }
                )
                kill(s)
                continue
            if msg[0] == "start":
                _, _, kind, b, cli, summary = msg
                s.phase, s.since, s.budget, s.cli = "solving", time.monotonic(), b, cli
                s.info = {"kind": kind, "cli": cli, "summary": summary}
            elif msg[0] == "solved":
                s.phase, s.since = "replaying", time.monotonic()
            else:
                on_record(msg[2])
                s.index = None
        now = time.monotonic()
        for s in slots:
            if s.index is None:
                continue
            limit = {
                "generating": 300.0,
                "solving": HANG_FACTOR * s.budget + (CLI_STARTUP_S + 30 if s.cli else 0.5),
                "replaying": REPLAY_LIMIT_S,
            }[s.phase]
            if now - s.since > limit:
                what = {
                    "solving": "hang",
                    "replaying": "replay timeout",
                    "generating": "generator timeout",
                }[s.phase]
                on_record(
                    {
                        "index": s.index,
                        "kind": s.info.get("kind", "?"),
                        "cli": s.info.get("cli", False),
                        "summary": s.info.get("summary", ""),
                        "outcome": "failure",
                        "category": what,
                        "elapsed": now - s.since,
                        "message": f"still {s.phase} after {now - s.since:.0f} s (budget "
                        f"{s.budget:g} s); killed" + stuck_at(s),
                    }
                )
                kill(s)
    for s in slots:
        with contextlib.suppress(Exception):
            s.conn.send(None)
            s.proc.join(5)


# =============================================================================================
# The report
# =============================================================================================


def _git_commit() -> str:
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "src"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
        return head + (" (src/ with uncommitted changes)" if dirty else "")
    except OSError:
        return "?"


def reproducer(args: argparse.Namespace, index: int) -> str:
    """The command that reruns case ``index`` of this run on its own."""
    line = f"python benchmarks/stress.py --seed {args.seed}"
    if args.kinds != ",".join(WEIGHTS):
        line += f" --kinds {args.kinds}"
    if args.time_limit_per_case != DEFAULT_BUDGET_S:
        line += f" --time-limit-per-case {args.time_limit_per_case:g}"
    return line + f" --case {index}"


def report(
    records: list[dict[str, Any]], args: argparse.Namespace, command: str, wall_s: float
) -> str:
    kinds = [k for k in WEIGHTS if any(r["kind"] == k for r in records)]
    kinds += sorted({r["kind"] for r in records} - set(kinds))
    factors = ", ".join(f"{k} x{v:g}" for k, v in BUDGET_FACTOR.items())
    lines = [
        "# Stress suite",
        "",
        f"`{command}` — seed {args.seed}, {len(records)} cases, budget "
        f"{args.time_limit_per_case:g} s per case ({factors}), "
        f"{args.jobs} worker(s), {wall_s / 60:.1f} min wall time; armpath at {_git_commit()}; "
        f"{platform.python_version()}, {dt.datetime.now().astimezone():%Y-%m-%d %H:%M %Z}.",
        "",
        "Each case runs in-process through the library (or, for the `cli` share, as an "
        "`armpath` subprocess) under its time limit; a result is replayed by "
        "`tests/independent_replay.py` (no armpath code). *Late*: finished (result or error) "
        "after its budget but before twice it; a case still running at twice its budget is a "
        "failure (hang).",
        "",
        "| kind | cases | results | clear errors | failures | via CLI | late | median s | max s |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for k in [*kinds, "all"]:
        rs = records if k == "all" else [r for r in records if r["kind"] == k]
        c = collections.Counter(r["outcome"] for r in rs)
        late = sum(
            1
            for r in rs
            if r.get("elapsed", 0) > r.get("budget", math.inf) and r["outcome"] != "failure"
        )
        times = [r["elapsed"] for r in rs if "elapsed" in r]
        med = f"{statistics.median(times):.1f}" if times else "-"
        mx = f"{max(times):.1f}" if times else "-"
        name = "**all**" if k == "all" else k
        lines.append(
            f"| {name} | {len(rs)} | {c['result']} | {c['error']} | {c['failure']} | "
            f"{sum(1 for r in rs if r.get('cli'))} | {late} | {med} | {mx} |"
        )
    errs = collections.Counter(r.get("category") for r in records if r["outcome"] == "error")
    lines += [
        "",
        "Clear errors by type: "
        + (", ".join(f"{n} {e}" for e, n in errs.most_common()) or "none")
        + ".",
    ]
    fails = [r for r in records if r["outcome"] == "failure"]
    lines += ["", f"## Failures: {len(fails)}", ""]
    for r in sorted(fails, key=lambda r: r["index"]):
        repro = reproducer(args, r["index"])
        msg = " ".join(str(r.get("message", "")).split())
        lines += [
            f"- case {r['index']} ({r['kind']}{', cli' if r.get('cli') else ''}; "
            f"{r.get('summary', '')}): **{r.get('category')}**: {msg[:700]}  ",
            f"  `{repro}`",
        ]
    if not fails:
        lines.append("None.")
    return "\n".join(lines) + "\n"


# =============================================================================================
# Command line of the suite
# =============================================================================================


def _show_case(args: argparse.Namespace, kinds: list[str]) -> int:
    """Rerun one case in this process, verbosely."""
    code = 0
    for index in args.case:
        work = Path(tempfile.mkdtemp(prefix=f"stress-{args.seed}-{index}-"))
        case = make_case(args.seed, index, kinds, args.time_limit_per_case, args.cli_share, work)
        print(f"case {index}: {case.kind}{' (cli)' if case.cli else ''}: {case.summary}")
        if case.expect_error:
            print(f"  invalid input by construction: {case.expect_error}")
        print(f"  files in {work}: {sorted(case.files)}")
        shown = {k: v for k, v in case.params.items() if k != "scene_spec"}
        print("  params: " + json.dumps(shown)[:2000])
        print("  facts: " + json.dumps(case.facts)[:1000])
        with contextlib.suppress(Exception):
            print("  command line: armpath " + shlex.join(cli_args(case, work, None)))
        t0 = time.monotonic()
        faulthandler.dump_traceback_later(HANG_FACTOR * case.budget + 1.0, exit=False)
        rec = run_case(case, work)
        faulthandler.cancel_dump_traceback_later()
        print(f"  -> {rec['outcome']} ({rec.get('category', '')}) in {time.monotonic() - t0:.1f} s")
        if rec.get("message"):
            print("  " + rec["message"])
        if rec.get("traceback"):
            print(rec["traceback"])
        if rec.get("facts"):
            print("  " + json.dumps(rec["facts"]))
        code |= rec["outcome"] == "failure"
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    return code


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=100, help="number of cases (default 100)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the run (default 0)")
    ap.add_argument("--first", type=int, default=0, help="index of the first case (default 0)")
    ap.add_argument(
        "--kinds",
        default=",".join(WEIGHTS),
        help=f"comma-separated kinds (default all: {','.join(WEIGHTS)})",
    )
    ap.add_argument(
        "--time-limit-per-case",
        type=float,
        default=DEFAULT_BUDGET_S,
        help="budget of a case, s (traces 1.5 x, spot welds 2 x; default 20)",
    )
    ap.add_argument(
        "--cli-share",
        type=float,
        default=0.06,
        help="share of cases run through the command line (default 0.06)",
    )
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument(
        "--only",
        choices=list(WEIGHTS),
        help="run only the cases of the range that are of this kind (the same cases as in the "
        "whole run: e.g. the traces of a 2,000-case run after a change to the tracer)",
    )
    ap.add_argument("--case", type=int, action="append", help="rerun this case verbosely")
    ap.add_argument("--keep", action="store_true", help="with --case: keep the case's files")
    ap.add_argument("--out", type=Path, default=RESULTS / "stress.md", help="report file")
    ap.add_argument("--log", type=Path, help="append each case's record here (JSON lines)")
    args = ap.parse_args(argv)
    kinds = [k for k in args.kinds.split(",") if k]
    unknown = sorted(set(kinds) - set(WEIGHTS))
    if unknown:
        ap.error(f"unknown kinds {unknown}; valid: {', '.join(WEIGHTS)}")
    if args.case:
        return _show_case(args, kinds)
    records: list[dict[str, Any]] = []
    t0 = time.monotonic()
    log = args.log.open("a") if args.log else None

    def on_record(rec: dict[str, Any]) -> None:
        records.append(rec)
        if log:
            log.write(json.dumps(rec, default=str) + "\n")
            log.flush()
        mark = {"result": ".", "error": "e", "failure": "F"}[rec["outcome"]]
        done = len(records)
        if rec["outcome"] == "failure":
            print(
                f"\nFAIL case {rec['index']} ({rec['kind']}): {rec.get('category')}: "
                f"{' '.join(str(rec.get('message', '')).split())[:300]}\n  "
                + reproducer(args, rec["index"]),
                flush=True,
            )
        else:
            print(mark, end="\n" if done % 50 == 0 else "", flush=True)

    indices = list(range(args.first, args.first + args.cases))
    if args.only:
        indices = [i for i in indices if _kind_of(args.seed, i, kinds) == args.only]
    run_pool(
        args.seed, indices, kinds, args.time_limit_per_case, args.cli_share, args.jobs, on_record
    )
    wall = time.monotonic() - t0
    cmd = "python benchmarks/stress.py " + " ".join(
        shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)
    )
    text = report(sorted(records, key=lambda r: r["index"]), args, cmd.strip(), wall)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print("\n" + text)
    return 1 if any(r["outcome"] == "failure" for r in records) else 0


if __name__ == "__main__":
    sys.exit(main())
