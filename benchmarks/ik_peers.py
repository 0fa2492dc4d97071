"""Test arms, scoring and one adapter per IK library for ``bench_ik.py``.

Convention of every arm, pose and joint vector here (armpath's): standard D-H, mm and rad,
``A_i = Rz(q_i + offset_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``, ``T = A_1 ... A_6``, no base or tool.
Each adapter converts the arm to its library's own model and units and maps the returned joint
vectors back to this convention, so that one piece of code (this module's FK) scores every
library. ``measure`` runs one (library, arm) pair; ``measure_isolated`` runs it in a child process
with a time limit (for the set-ups that take minutes). ``python ik_peers.py IN OUT`` is that child.
"""

from __future__ import annotations

import importlib.util
import os
import pickle
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

PI = np.pi
HERE = Path(__file__).resolve().parent


# --- arms, poses, forward kinematics, scoring --------------------------------------------------


def dh_table(a, alpha, d, offset=None) -> dict[str, np.ndarray]:
    """A standard D-H table (mm, rad) as four arrays."""
    off = np.zeros(6) if offset is None else np.asarray(offset, float)
    return {
        "a": np.asarray(a, float),
        "alpha": np.asarray(alpha, float),
        "d": np.asarray(d, float),
        "offset": off,
    }


def link_transform(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def fk(dh: dict[str, np.ndarray], q: np.ndarray) -> np.ndarray:
    """Flange pose (mm) of joint vector ``q`` (rad)."""
    T = np.eye(4)
    for i in range(6):
        T = T @ link_transform(q[i] + dh["offset"][i], dh["d"][i], dh["a"][i], dh["alpha"][i])
    return T


def puma560() -> dict[str, np.ndarray]:
    return dh_table(
        a=[0, 431.8, 20.32, 0, 0, 0],
        alpha=[PI / 2, 0, -PI / 2, PI / 2, -PI / 2, 0],
        d=[0, 0, 150.05, 431.8, 0, 0],
    )


def ur5() -> dict[str, np.ndarray]:
    return dh_table(
        a=[0, -425, -392.25, 0, 0, 0],
        alpha=[PI / 2, 0, 0, PI / 2, -PI / 2, 0],
        d=[89.159, 0, 0, 109.15, 94.65, 82.3],
    )


def random_arms(n: int, seed: int = 1) -> list[dict[str, np.ndarray]]:
    """General 6R arms: a, d uniform in [-500, 500] mm, alpha uniform in [-pi, pi] (drawn arm by
    arm, so the first k arms do not depend on ``n``)."""
    rng = np.random.default_rng(seed)
    arms = []
    for _ in range(n):
        a = rng.uniform(-500, 500, 6)
        d = rng.uniform(-500, 500, 6)
        alpha = rng.uniform(-PI, PI, 6)
        arms.append(dh_table(a, alpha, d))
    return arms


def test_arms(n_random: int) -> list[tuple[str, dict[str, np.ndarray]]]:
    """PUMA 560, UR5 and the first ``n_random`` random arms (seed 1), named rand00, rand01, ..."""
    arms = [("puma560", puma560()), ("ur5", ur5())]
    arms += [(f"rand{i:02d}", a) for i, a in enumerate(random_arms(n_random))]
    return arms


def test_joints(n: int, seed: int = 2) -> np.ndarray:
    """The same generating joint vectors for every arm: uniform in [-pi, pi), one (n, 6) draw of
    the first ``max(n, 200)`` (so that the first 50 are the same in a 50- and a 200-pose run)."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-PI, PI, (max(n, 200), 6))[:n]


def wrap(x: np.ndarray) -> np.ndarray:
    return (np.asarray(x) + PI) % (2 * PI) - PI


def contains(sols: np.ndarray, q: np.ndarray, tol: float = 1e-4) -> bool:
    """Whether ``q`` is among the rows of ``sols`` (max abs difference mod 2 pi below ``tol``)."""
    sols = np.asarray(sols, float).reshape(-1, 6)
    if len(sols) == 0:
        return False
    return bool(np.any(np.max(np.abs(wrap(sols - q[None, :])), axis=1) < tol))


def residual(dh: dict[str, np.ndarray], q: np.ndarray, T: np.ndarray) -> tuple[float, float]:
    """Position (mm) and rotation (rad) distance of FK(q) from ``T``; the angle comes from the
    chord, accurate near 0."""
    Tq = fk(dh, q)
    pos = float(np.linalg.norm(Tq[:3, 3] - T[:3, 3]))
    chord = np.linalg.norm(Tq[:3, :3] - T[:3, :3]) / (2.0 * np.sqrt(2.0))
    return pos, float(2.0 * np.arcsin(min(1.0, chord)))


def dh_to_poe(dh: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Standard D-H -> product of exponentials ``(H (6,3), P (7,3), R_home)`` in the base frame at
    q = 0 (the IK-Geo / EAIK convention): ``FK(q) = Tr(P0) Rot(H1,q1) Tr(P1) ... Rot(H6,q6)
    Tr(P6) [R_home]``. Offsets are folded in (q = 0 is our zero)."""
    frames = [np.eye(4)]
    T = np.eye(4)
    for i in range(6):
        T = T @ link_transform(dh["offset"][i], dh["d"][i], dh["a"][i], dh["alpha"][i])
        frames.append(T.copy())
    H = np.array([frames[i][:3, 2] for i in range(6)])
    origins = np.array([f[:3, 3] for f in frames])
    P = np.vstack([origins[0], np.diff(origins[:6], axis=0), origins[6] - origins[5]])
    return H, P, frames[6][:3, :3].copy()


def _closest(r1, h1, r2, h2):
    """Closest points of two lines and their distance (None if parallel)."""
    n = np.cross(h1, h2)
    nn = n @ n
    if nn < 1e-18:
        return None
    w = r2 - r1
    x1 = r1 + (np.cross(w, h2) @ n / nn) * h1
    x2 = r2 + (np.cross(w, h1) @ n / nn) * h2
    return x1, x2, float(np.linalg.norm(x1 - x2))


def canonical_poe(dh: dict[str, np.ndarray], tol: float = 1e-9):
    """``dh_to_poe`` with each joint's reference point slid along its axis so that intersecting
    consecutive axes share their point (P[k] = 0), as IK-Geo's special families assume (a
    spherical wrist needs P[4] = P[5] = 0)."""
    H, P, Rh = dh_to_poe(dh)
    r = np.cumsum(P[:6], axis=0)
    ee = r[5] + P[6]
    scale = max(1.0, np.abs(P).max())
    fixed = [False] * 6
    for j in range(4):  # spherical triples first
        a = _closest(r[j], H[j], r[j + 1], H[j + 1])
        b = _closest(r[j + 1], H[j + 1], r[j + 2], H[j + 2])
        c = _closest(r[j], H[j], r[j + 2], H[j + 2])
        if (
            a
            and b
            and c
            and max(a[2], b[2], c[2]) < tol * scale
            and np.linalg.norm(a[0] - b[0]) < tol * scale * 10
        ):
            for k in (j, j + 1, j + 2):
                if not fixed[k]:
                    r[k], fixed[k] = a[0], True
    for j in range(5):  # then pairs
        a = _closest(r[j], H[j], r[j + 1], H[j + 1])
        if a and a[2] < tol * scale and not (fixed[j] and fixed[j + 1]):
            for k in (j, j + 1):
                if not fixed[k]:
                    r[k], fixed[k] = a[0], True
    P2 = np.vstack([r[0], np.diff(r, axis=0), ee - r[5]])
    P2[np.abs(P2) < 1e-12 * scale] = 0.0
    return H, P2, Rh


def _metres(T: np.ndarray) -> np.ndarray:
    T2 = np.array(T, dtype=float)
    T2[..., :3, 3] /= 1000.0
    return T2


# --- adapters ----------------------------------------------------------------------------------


class UnsupportedError(Exception):
    """The library declines this arm's geometry (recorded, not an error)."""


class Adapter:
    """One IK library. ``load`` (imports, not timed), ``setup`` (timed, per arm; returns a short
    description of the solver it picked), ``solve`` (one pose in mm -> (k, 6) rad in our
    convention), ``solve_batch`` if ``batch`` (an (N, 4, 4) stack -> list of (k_i, 6))."""

    name = "?"
    label = "?"
    module = ""  # the importable module that must be present
    pip = ""  # what to pip install
    batch = False

    def __init__(self, opts: dict[str, Any] | None = None) -> None:
        self.opts = opts or {}
        self.note = ""  # set by solve: why a pose got no solution (ours)

    def load(self) -> None:
        pass

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        raise NotImplementedError

    def solve(self, T: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def solve_batch(self, Ts: np.ndarray) -> list[np.ndarray]:
        raise NotImplementedError

    @classmethod
    def installed(cls) -> bool:
        return importlib.util.find_spec(cls.module) is not None


class Ours(Adapter):
    """armpath's ``complete_solver``: closed form (spherical wrist, three parallel axes) or
    Raghavan-Roth elimination."""

    name, label, module, pip, batch = "ours", "armpath (ours)", "armpath", "-e .", True

    def load(self) -> None:
        from armpath.ik import complete_solver
        from armpath.model.dh import DHRow, dh_arm

        self._complete, self._row, self._arm = complete_solver, DHRow, dh_arm
        # load every numba kernel from the disk cache (serial and parallel) before any timing
        Q = test_joints(300, seed=99)
        for dh in (puma560(), ur5(), random_arms(1)[0]):
            solver = complete_solver(self._build("warm-up", dh))
            Ts = np.array([fk(dh, q) for q in Q])
            solver.solve(Ts[0])
            solver.solve_batch(Ts)

    def _build(self, arm_name: str, dh: dict[str, np.ndarray]):
        rows = [
            self._row(a=dh["a"][i], alpha=dh["alpha"][i], d=dh["d"][i], offset=dh["offset"][i])
            for i in range(6)
        ]
        return self._arm(rows, "standard", name=arm_name)

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        self.solver = self._complete(self._build(arm_name, dh))
        if self.solver is None:
            raise UnsupportedError("no complete solver")
        self.methods: dict[str, int] = {}
        return type(self.solver).__name__

    def solve(self, T: np.ndarray) -> np.ndarray:
        r = self.solver.solve(T)
        self.methods[r.method] = self.methods.get(r.method, 0) + 1
        self.note = r.reason if r.count == 0 else ""
        return r.solutions

    def solve_batch(self, Ts: np.ndarray) -> list[np.ndarray]:
        batch = self.solver.solve_batch(Ts)  # padded arrays; per-pose views are free
        return [batch.solutions[i, :k] for i, k in enumerate(batch.counts)]

    def describe(self) -> str:
        top = sorted(self.methods.items(), key=lambda kv: -kv[1])
        return ", ".join(m if len(top) == 1 else f"{m} x{n}" for m, n in top[:3])


class EAIK(Adapter):
    """EAIK (subproblem decomposition, C++). ``DhRobot`` has no theta offset (lib q = our q +
    offset); solutions flagged least-squares are dropped. Batch: ``IK_batched``, 2 threads."""

    name, label, module, pip, batch = "eaik", "EAIK", "eaik", "EAIK==1.2.2", True

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        from eaik.IK_DH import DhRobot

        self.off = dh["offset"]
        self.bot = DhRobot(dh["alpha"], dh["a"], dh["d"])
        family = self.bot.getKinematicFamily()
        if not self.bot.hasKnownDecomposition():
            raise UnsupportedError(family)
        return family

    def _ours(self, s) -> np.ndarray:
        Q = np.asarray(s.Q, float).reshape(-1, 6)
        return Q[~np.asarray(s.is_LS, bool).reshape(-1)] - self.off

    def solve(self, T: np.ndarray) -> np.ndarray:
        return self._ours(self.bot.IK(T))

    def solve_batch(self, Ts: np.ndarray) -> list[np.ndarray]:
        return [self._ours(s) for s in self.bot.IK_batched(Ts, num_worker_threads=2)]


_IKGEO_FACTORY = {  # py-ikgeo-kinematics' family -> ik_geo factory
    "spherical": "spherical",
    "spherical_two_intersecting": "spherical_two_intersecting",
    "spherical_two_parallel": "spherical_two_parallel",
    "three_parallel": "three_parallel",
    "three_parallel_two_intersecting": "three_parallel_two_intersecting",
    "three_parallel_two_parallel": "three_parallel",
    "two_parallel": "two_parallel",
    "two_parallel_two_parallel": "two_parallel",
    "two_intersecting": "two_intersecting",
    "two_intersecting_two_intersecting": "two_intersecting",
    "two_intersecting_two_parallel": "two_intersecting",
    "general": "gen_six_dof",
}


class IKGeo(Adapter):
    """ik-geo (Rust IK-Geo). It does not detect the family: py-ikgeo-kinematics' detector picks
    the factory. Reference points must be canonical, and the rotation goes in transposed (the
    binding reads 3x3 arrays column-major). Least-squares outputs are dropped."""

    name, label, module, pip = "ikgeo", "ik-geo", "ik_geo", "ik-geo==1.0.3"

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        from ik_geo import Robot
        from py_ikgeo_kinematics import KinematicModel
        from py_ikgeo_kinematics import Robot as Detector

        H, P, self.Rh = canonical_poe(dh)
        family = Detector(KinematicModel(H.T, P.T), degrees=False).family
        factory = _IKGEO_FACTORY.get(family, "gen_six_dof")
        self.robot = getattr(Robot, factory)(H, P)
        return factory

    def solve(self, T: np.ndarray) -> np.ndarray:
        R = T[:3, :3] @ self.Rh.T
        sols = self.robot.get_ik(np.ascontiguousarray(R.T), T[:3, 3])
        return np.array([q for q, is_ls in sols if not is_ls], float).reshape(-1, 6)


class PyIKGeo(Adapter):
    """py-ikgeo-kinematics (IK-Geo with family detection, Rust). Single: ``inverse`` (through
    scipy's ``RigidTransform``); batch: ``reach`` (every branch), 2 threads."""

    name, label, module, pip, batch = (
        "pyikgeo",
        "py-ikgeo-kinematics",
        "py_ikgeo_kinematics",
        "py-ikgeo-kinematics==0.0.2",
        True,
    )

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        from py_ikgeo_kinematics import KinematicModel, RigidTransform, Robot

        self.rigid = RigidTransform
        H, P, self.Rh = dh_to_poe(dh)
        self.robot = Robot(KinematicModel(H.T, P.T), degrees=False)
        return str(self.robot.family)

    def _lib(self, T: np.ndarray) -> np.ndarray:
        T2 = np.array(T, dtype=float)
        T2[..., :3, :3] = T[..., :3, :3] @ self.Rh.T
        return T2

    def solve(self, T: np.ndarray) -> np.ndarray:
        sols = self.robot.inverse(self.rigid.from_matrix(self._lib(T)))
        return np.array(sols, float).reshape(-1, 6)

    def solve_batch(self, Ts: np.ndarray) -> list[np.ndarray]:
        res = self.robot.reach(self.rigid.from_matrix(self._lib(Ts)), threads=2)
        return [J[~np.isnan(J[:, 0])] for J in np.asarray(res.joints)]


class IKDH(Adapter):
    """ikdh (Husty-Pfurner, C++). ``DHTable(a, d, alpha, theta)`` with theta = our offset, metres;
    answers in degrees; limits +-360 deg so that nothing is filtered."""

    name, label, module, pip = "ikdh", "ikdh", "ikdh", "ikdh==1.2.0"

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        import ikdh

        table = ikdh.DHTable(
            list(dh["a"] / 1000.0), list(dh["d"] / 1000.0), list(dh["alpha"]), list(dh["offset"])
        )
        self.solver = ikdh.Solver(table, ikdh.JointLimits([(-360.0, 360.0)] * 6))
        return "Husty-Pfurner"

    def solve(self, T: np.ndarray) -> np.ndarray:
        return np.radians(np.array(self.solver.solve(_metres(T)), float).reshape(-1, 6))


class SSIK(Adapter):
    """ssik: ``Manipulator.from_dh`` (metres, no offsets: lib q = our q + offset), ``prepare()``
    (the symbolic Raghavan-Roth derivation of a general arm, cached on disk in
    ``$SSIK_DERIVATION_CACHE``), then the native artifact (``emit_artifact`` plus, for a general
    arm, the baked RR tensor) -- all of it timed as set-up. ``respect_limits=False``."""

    name, label, module, pip = "ssik", "ssik", "ssik", "ssik==8.2.0"

    def load(self) -> None:
        import ssik
        import sympy  # noqa: F401  (imported lazily by emit_artifact: not set-up time)
        from ssik import _native
        from ssik.core.codegen import emit_artifact

        self.ssik, self.native, self.emit = ssik, _native, emit_artifact

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        self.off = dh["offset"]
        arm = self.ssik.Manipulator.from_dh(dh["alpha"], dh["a"] / 1000.0, dh["d"] / 1000.0)
        arm.prepare()
        out = Path(self.opts.get("ssik_dir") or tempfile.mkdtemp(prefix="ssik_art_"))
        module = f"bench_{arm_name}_ik"
        path = out / f"{module}.py"
        self.emit(kb=arm.kinbody, plan=arm.dispatch_plan, module_name=module, output_path=path)
        if arm.solver_name == "ikgeo.general_6r":  # the native sidecar: <stem without _ik>_rr.npz
            self.native.bake_rr_tensor_npz(arm.kinbody, str(out / f"bench_{arm_name}_rr.npz"))
        spec = importlib.util.spec_from_file_location(module, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[module] = mod
        spec.loader.exec_module(mod)
        self.fn = mod.solve
        return str(arm.solver_name)

    def solve(self, T: np.ndarray) -> np.ndarray:
        sols = self.fn(_metres(T), respect_limits=False)
        return np.array([s.q for s in sols], float).reshape(-1, 6) - self.off


def _rtb_robot(arm_name: str, dh: dict[str, np.ndarray]):
    import roboticstoolbox as rtb

    links = [
        rtb.RevoluteDH(
            d=dh["d"][i] / 1000.0,
            a=dh["a"][i] / 1000.0,
            alpha=dh["alpha"][i],
            offset=dh["offset"][i],
            qlim=[-2 * PI, 2 * PI],
        )
        for i in range(6)
    ]
    return rtb.DHRobot(links, name=arm_name)


class RTBAnalytic(Adapter):
    """roboticstoolbox-python ``analytic_ik()`` (metres; symbolic derivation plus its own
    100-pose validation) for the closed-form classes. For a general arm ``analytic_ik()`` derives
    three splits and validates them (it did not finish in 13.5 min on this machine), so the
    harness's shortcut ``General6RIK(robot, k=2)`` (one split, no validation) is used instead."""

    name, label, module, pip = (
        "rtb_analytic",
        "rtb analytic_ik",
        "roboticstoolbox",
        "roboticstoolbox-python[ik]==1.5.0",
    )

    def load(self) -> None:
        import roboticstoolbox  # noqa: F401
        import sympy  # noqa: F401

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        from roboticstoolbox.robot.symbolic_ik_rr import ClosedFormIK, General6RIK, classify

        robot = _rtb_robot(arm_name, dh)
        general = classify(robot).general
        if general:
            self.ik = General6RIK(robot, k=int(self.opts.get("rtb_split", 2)))
            return f"General6RIK(k={self.opts.get('rtb_split', 2)})"
        try:
            self.ik = robot.analytic_ik()
        except ValueError:  # its validation refused the arm: build the class directly
            self.ik = ClosedFormIK(robot)
            return "ClosedFormIK (analytic_ik refused)"
        return type(self.ik).__name__

    def solve(self, T: np.ndarray) -> np.ndarray:
        sol = self.ik.solve(_metres(T), joint_limits=False)
        return np.atleast_2d(np.asarray(sol.q, float)) if sol.success else np.zeros((0, 6))


class RTBLM(Adapter):
    """roboticstoolbox-python ``ikine_LM`` (numerical, one solution per call): all solutions
    emulated by K random starts per pose (ilimit 30, slimit 1, tol 1e-14; the default tol 1e-6 on
    E = e'We/2 allows ~1 mm), distinct converged results kept."""

    name, label, module, pip = (
        "rtb_lm",
        "rtb ikine_LM",
        "roboticstoolbox",
        "roboticstoolbox-python==1.5.0",
    )

    def load(self) -> None:
        import roboticstoolbox  # noqa: F401

    def setup(self, arm_name: str, dh: dict[str, np.ndarray]) -> str:
        self.ets = _rtb_robot(arm_name, dh).ets()
        self.rng = np.random.default_rng(0)
        self.starts = int(self.opts.get("lm_starts", 16))
        return f"ikine_LM x{self.starts} random starts"

    def solve(self, T: np.ndarray) -> np.ndarray:
        T2 = _metres(T)
        out: list[np.ndarray] = []
        for _ in range(self.starts):
            q0 = self.rng.uniform(-PI, PI, 6)
            s = self.ets.ikine_LM(T2, q0=q0, ilimit=30, slimit=1, tol=1e-14, joint_limits=False)
            if s.success:
                q = np.asarray(s.q, float)
                if not contains(np.array(out), q, 1e-5):
                    out.append(q)
        return np.array(out, float).reshape(-1, 6)


ADAPTERS: dict[str, type[Adapter]] = {
    c.name: c for c in (Ours, EAIK, IKGeo, PyIKGeo, IKDH, SSIK, RTBAnalytic, RTBLM)
}


# --- measuring ---------------------------------------------------------------------------------


def measure(
    lib: str, arm_name: str, dh: dict[str, np.ndarray], Q: np.ndarray, opts: dict[str, Any]
) -> dict[str, Any]:
    """Set up ``lib`` for one arm and solve the poses FK(Q): raw solutions and times.

    Single calls: wall (``perf_counter``) and calling-thread CPU (``thread_time``) per pose, after
    one untimed warm-up call, stopping after ``opts['budget']`` seconds. Batched call (if any): the
    median wall time over up to ``opts['batch_repeats']`` calls on all poses.
    """
    warnings.simplefilter("ignore")
    rec: dict[str, Any] = {"lib": lib, "arm": arm_name, "load": [os.getloadavg()[0]]}
    A = ADAPTERS[lib](opts)
    t = time.perf_counter()
    A.load()
    rec["load_s"] = time.perf_counter() - t
    c, t = time.process_time(), time.perf_counter()
    try:
        rec["info"] = A.setup(arm_name, dh)
    except UnsupportedError as e:
        rec["unsupported"] = str(e)
        return rec
    except Exception as e:
        rec["error"] = f"set-up failed: {e!r}"[:300]
        return rec
    rec["setup_s"] = time.perf_counter() - t
    rec["setup_cpu_s"] = time.process_time() - c
    Ts = np.array([fk(dh, q) for q in Q])
    try:
        A.solve(Ts[0])
    except Exception as e:
        rec["error"] = f"first call failed: {e!r}"[:300]
        return rec
    sols, wall, cpu, notes, errors = [], [], [], [], 0
    start = time.perf_counter()
    for T in Ts:
        c, t = time.thread_time(), time.perf_counter()
        try:
            S = A.solve(T)
        except Exception as e:
            S = np.zeros((0, 6))
            errors += 1
            rec.setdefault("first_error", repr(e)[:200])
        wall.append(time.perf_counter() - t)
        cpu.append(time.thread_time() - c)
        sols.append(np.asarray(S, float).reshape(-1, 6))
        notes.append(A.note)
        if time.perf_counter() - start > opts.get("budget", 600.0):
            rec["budget_stop"] = len(sols)
            break
    rec.update(sols=sols, wall=wall, cpu=cpu, notes=notes, errors=errors)
    if isinstance(A, Ours):
        rec["info"] = A.describe()
    if A.batch:
        times, spent = [], 0.0
        for _ in range(max(1, opts.get("batch_repeats", 3))):
            t = time.perf_counter()
            batch = A.solve_batch(Ts)
            times.append(time.perf_counter() - t)
            spent += times[-1]
            if spent > 10.0:
                break
        rec["batch_s"] = float(np.median(times))
        rec["batch_n"] = len(Ts)
        rec["batch_sols"] = [np.asarray(S, float).reshape(-1, 6) for S in batch]
    rec["load"].append(os.getloadavg()[0])
    return rec


def measure_isolated(
    lib: str,
    arm_name: str,
    dh: dict[str, np.ndarray],
    Q: np.ndarray,
    opts: dict[str, Any],
    timeout: float,
    env: dict[str, str] | None = None,
) -> dict[str, Any]:
    """``measure`` in a child process killed after ``timeout`` seconds (a fresh interpreter, so a
    derivation that takes minutes cannot hold up the run)."""
    with tempfile.TemporaryDirectory(prefix="bench_ik_") as tmp:
        src, dst = Path(tmp) / "in.pkl", Path(tmp) / "out.pkl"
        src.write_bytes(pickle.dumps((lib, arm_name, dh, Q, opts)))
        t = time.perf_counter()
        try:
            proc = subprocess.run(
                [sys.executable, str(Path(__file__)), str(src), str(dst)],
                env={**os.environ, **(env or {})},
                timeout=timeout,
                capture_output=True,
                text=True,
            )
        except subprocess.TimeoutExpired:
            return {"lib": lib, "arm": arm_name, "timeout": timeout}
        if proc.returncode != 0 or not dst.exists():
            tail = (proc.stderr or "").strip().splitlines()[-1:] or ["?"]
            return {"lib": lib, "arm": arm_name, "error": f"child failed: {tail[0][:200]}"}
        rec = pickle.loads(dst.read_bytes())
        rec["child_wall_s"] = time.perf_counter() - t
        return rec


if __name__ == "__main__":
    args = pickle.loads(Path(sys.argv[1]).read_bytes())
    Path(sys.argv[2]).write_bytes(pickle.dumps(measure(*args)))
