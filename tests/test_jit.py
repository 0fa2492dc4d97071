"""Deferred numba kernels (armpath.jit): commands that run no kernel never import numba, and
kernels compiled after the deferral give the same numbers as the plain Python functions."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

from armpath.geometry import kernels
from armpath.model.catalog import resolve_model


def _modules_after(code: str) -> set[str]:
    proc = subprocess.run(
        [sys.executable, "-c", f"{code}\nimport sys\nprint(' '.join(sorted(sys.modules)))"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    return set(proc.stdout.split())


def test_the_cli_and_forward_kinematics_do_not_load_numba_or_scipy() -> None:
    loaded = _modules_after(
        "import armpath.cli\n"
        "from armpath.kinematics import landmark_positions, tool_pose\n"
        "from armpath.model.catalog import resolve_model\n"
        "arm = resolve_model('puma560', None)\n"
        "landmark_positions(arm, [0.1] * 6); tool_pose(arm, [0.1] * 6)"
    )
    assert "armpath.cli" in loaded
    assert not any(m == "numba" or m.startswith("numba.") for m in loaded)
    assert not any(m == "scipy" or m.startswith("scipy.") for m in loaded)


def test_running_a_kernel_loads_numba_and_rebinds_every_kernel() -> None:
    loaded = _modules_after(
        "import numpy as np\n"
        "from armpath.geometry import kernels\n"
        "import armpath.ik.general6r as g\n"
        "kernels.segments_to_point(np.zeros((1, 3)), np.ones((1, 3)), np.zeros((1, 3)))\n"
        "import numba\n"
        "assert isinstance(g._solve_parallel, numba.core.registry.CPUDispatcher)\n"
        "assert g.prange is numba.prange\n"
        "assert g._solve_parallel.targetoptions['parallel']"
    )
    assert "numba" in loaded


def test_a_kernel_agrees_with_its_python_function() -> None:
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(50, 3)) * 100, rng.normal(size=(50, 3)) * 100
    p = np.repeat(rng.normal(size=(1, 3)) * 100, 50, axis=0)
    fast = kernels.segments_to_point(a, b, p)
    plain = kernels.segments_to_point.py_func(a, b, p)
    assert np.allclose(fast, plain, rtol=0, atol=1e-9)
    # the brute force: the closest of 20,001 points along each segment
    t = np.linspace(0.0, 1.0, 20001)[:, None, None]
    brute = np.linalg.norm(a + t * (b - a) - p, axis=-1).min(axis=0)
    assert np.all(fast <= brute + 1e-9) and np.allclose(fast, brute, atol=0.05)


def test_the_numpy_landmarks_of_a_few_poses_equal_the_compiled_ones() -> None:
    """A fresh process (numba not loaded) takes the numpy path for up to 8 poses; this one
    runs the compiled kernel; both equal each frame's landmark offset carried by the frame."""
    import json

    from armpath import jit
    from armpath.kinematics import forward_frames, landmark_positions

    rng = np.random.default_rng(5)
    for name in ("seed", "puma560", "ur5"):
        arm = resolve_model(name, None)
        q = rng.uniform(-2.0, 2.0, size=(3, arm.n_joints))
        code = (
            "import json, sys\n"
            "from armpath.kinematics import landmark_positions\n"
            "from armpath.model.catalog import resolve_model\n"
            f"pts = landmark_positions(resolve_model({name!r}, None), {q.tolist()!r})\n"
            "assert 'numba' not in sys.modules\n"
            "print(json.dumps(pts.tolist()))"
        )
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        numpy_path = np.array(json.loads(out.stdout))
        jit.load_numba()
        compiled = landmark_positions(arm, q)
        frames = forward_frames(arm, q)
        for k, lm in enumerate(arm.landmarks):
            rot, origin = frames[:, lm.frame, :3, :3], frames[:, lm.frame, :3, 3]
            expected = rot @ np.asarray(lm.offset, dtype=float) + origin
            assert np.allclose(compiled[:, k], expected, rtol=0, atol=1e-9)
            assert np.allclose(numpy_path[:, k], expected, rtol=0, atol=1e-9)


def test_threads_are_used_only_for_big_batches_on_a_machine_with_a_core_to_spare(monkeypatch):
    """The parallel kernels run only for batches of at least the threshold and only while no
    more than the cores less one are busy (this thread counted); otherwise the serial kernel
    (numba's threads stall when every core is busy). Never where numba may use one thread or
    in a child forked after numba's threads started."""
    import os

    from armpath import jit

    assert jit._busy_cores() >= 1.0  # this thread is running, so it is among the busy ones
    monkeypatch.setenv("NUMBA_NUM_THREADS", "1")
    monkeypatch.setattr(jit, "_numba", None)  # numba not loaded: the variable decides
    assert jit._one_thread()
    monkeypatch.setenv("NUMBA_NUM_THREADS", "4")
    assert not jit._one_thread()
    monkeypatch.undo()
    monkeypatch.setattr(jit, "_one_thread", lambda: False)
    monkeypatch.setattr(os, "cpu_count", lambda: 4)
    monkeypatch.setattr(jit, "_busy_cores", lambda: 1.0)
    assert jit.threads_pay_off(128, 128) and not jit.threads_pay_off(127, 128)
    monkeypatch.setattr(jit, "_busy_cores", lambda: 4.0)
    assert not jit.threads_pay_off(10_000, 128)
    monkeypatch.setattr(jit, "_busy_cores", lambda: 3.0)
    assert jit.threads_pay_off(10_000, 128)
    monkeypatch.setattr(jit, "_one_thread", lambda: True)
    assert not jit.threads_pay_off(10_000, 128)
    monkeypatch.setattr(jit, "_one_thread", lambda: False)
    monkeypatch.setattr(jit, "_forked_after_threads", True)
    assert not jit.threads_pay_off(10_000, 128)
    monkeypatch.setattr(jit, "_forked_after_threads", False)
    monkeypatch.setattr(os, "cpu_count", lambda: 1)
    monkeypatch.setattr(jit, "_busy_cores", lambda: 0.0)
    assert not jit.threads_pay_off(10_000, 128)


def test_in_slices_covers_the_batch_once_in_order_one_slice_per_core(monkeypatch):
    """Where threads pay, one slice per core, together every item once and in order, run
    on the pool's threads; otherwise one call over the whole batch on the caller's thread."""
    import threading

    from armpath import jit

    def run(a: int, b: int) -> tuple[int, int, int]:
        return a, b, threading.get_ident()

    monkeypatch.setattr(os, "cpu_count", lambda: 3)
    monkeypatch.setattr(jit, "threads_pay_off", lambda n, threshold: n >= threshold)
    slices = jit.in_slices(run, 10, 5)
    assert [s[:2] for s in slices] == [(0, 3), (3, 6), (6, 10)]
    assert threading.get_ident() not in {s[2] for s in slices}
    assert jit.in_slices(run, 4, 5) == [(0, 4, threading.get_ident())]
    monkeypatch.setattr(os, "cpu_count", lambda: 1)
    assert jit.in_slices(run, 10, 5) == [(0, 10, threading.get_ident())]


def _prints_ok_with_two_threads(code: str, layer: str | None = None) -> None:
    """Run ``code`` in a fresh interpreter with two numba threads and the threading ``layer``
    (numba's default when None); it must print ``ok``."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_THREADING_LAYER"}
    env["NUMBA_NUM_THREADS"] = "2"
    if layer is not None:
        env["NUMBA_THREADING_LAYER"] = layer
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr[-2000:]


def test_a_forked_child_runs_a_parallel_kernel_its_parent_ran() -> None:
    """Users' multiprocessing pools fork (Linux's default): a child running the bound's step
    after its parent ran it on numba's threads must give the same numbers, not be killed (GNU
    OpenMP kills a child that runs a parallel region: the child takes the serial kernel)."""
    code = (
        "import multiprocessing as mp, types, numpy as np\n"
        "from armpath import jit\n"
        "from armpath.planning.bounds import FamilySampler, Layer\n"
        "jit._busy_cores = lambda: 1.0  # a core to spare, whatever else this machine runs\n"
        "rng = np.random.default_rng(3)\n"
        "pu, u = rng.normal(size=(2000, 6)), rng.normal(size=(1500, 6))\n"
        "a = Layer(pu, np.zeros_like(pu), np.zeros_like(pu), np.zeros((2000, 3)))\n"
        "b = Layer(u, np.zeros_like(u), np.zeros_like(u), np.zeros((1500, 3)))\n"
        "pc, metric = rng.uniform(0, 5, 2000), types.SimpleNamespace(period=np.zeros(6))\n"
        "assert jit.threads_pay_off(a.size * b.size, 1_000_000)\n"
        "run = lambda: FamilySampler.advance(metric, a, pc, b)[0]\n"
        "parent = run()\n"
        "import numba.np.ufunc.parallel as threads\n"
        "assert threads._is_initialized, 'the parent ran no parallel kernel'\n"
        "brute = (pc[:, None] + np.abs(pu[:, None, :] - u[None, :, :]).max(axis=2)).min(axis=0)\n"
        "assert np.allclose(parent, brute), 'kernel differs from brute force'\n"
        "ctx = mp.get_context('fork')\n"
        "q = ctx.Queue()\n"
        "p = ctx.Process(target=lambda: q.put(run().tolist()))\n"
        "p.start(); child = q.get(timeout=60); p.join()\n"
        "assert p.exitcode == 0 and np.array_equal(child, parent), p.exitcode\n"
        "print('ok')\n"
    )
    _prints_ok_with_two_threads(code)


def test_threads_take_turns_at_the_parallel_kernel() -> None:
    """numba's work queue (its threading layer where OpenMP is missing) aborts the process when
    two threads run parallel kernels at once; the bound's step holds
    :data:`armpath.jit.parallel_kernel_lock`, so threads (a user's thread pool) get the numbers
    one thread gets."""
    code = (
        "import threading, types, numpy as np\n"
        "from armpath import jit\n"
        "from armpath.planning.bounds import FamilySampler, Layer\n"
        "jit._busy_cores = lambda: 1.0  # a core to spare: the parallel kernel runs\n"
        "rng = np.random.default_rng(5)\n"
        "def layer(m):\n"
        "    return Layer(rng.normal(size=(m, 6)), np.zeros((m, 6)), np.zeros((m, 6)),"
        " np.zeros((m, 3)))\n"
        "a, b = layer(2500), layer(2000)\n"
        "metric = types.SimpleNamespace(period=np.zeros(6))\n"
        "cost = rng.uniform(0, 5, a.size)\n"
        "one = FamilySampler.advance(metric, a, cost, b)[0]\n"
        "out = []\n"
        "def run():\n"
        "    for _ in range(10):\n"
        "        out.append(FamilySampler.advance(metric, a, cost, b)[0])\n"
        "ts = [threading.Thread(target=run) for _ in range(3)]\n"
        "[t.start() for t in ts]; [t.join() for t in ts]\n"
        "assert len(out) == 30 and all(np.array_equal(c, one) for c in out)\n"
        "import numba\n"
        "assert numba.threading_layer() == 'workqueue'\n"
        "print('ok')\n"
    )
    _prints_ok_with_two_threads(code, layer="workqueue")
