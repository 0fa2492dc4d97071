"""Compiled kernels without paying for numba at start-up.

armpath's hot loops are numba kernels, but importing numba costs about a third of a second,
which every command (``--help`` and ``fk`` included) paid whether or not it ran a kernel.
:func:`njit` here takes the same options as :func:`numba.njit` and defers numba until the first
kernel is called: then numba is imported once, every kernel defined so far becomes a real numba
dispatcher (compiled on first use, cached on disk as before), and the names bound to them in
armpath's modules are rebound to the dispatchers, so a kernel compiling a call to another sees
a numba function and calls from Python cost nothing extra. :data:`prange` is ``range`` until
then and :func:`numba.prange` after, so a parallel loop compiles as one.

Kernels defined after numba is loaded are plain numba dispatchers.

Every parallel kernel has a serial twin (a separate function: numba's disk cache does not tell
a function's parallel and serial compilations apart), and :func:`threads_pay_off` picks one.
It picks the serial one in a process forked after numba's threads started (GNU OpenMP, numba's
threading layer where TBB is absent, kills a forked child that runs a parallel region; users'
``multiprocessing`` pools fork on Linux) and when numba may use one thread
(``NUMBA_NUM_THREADS=1``), where the parallel one would only cost its compilation. numba's
fork-safe work queue would avoid the first, but it ran the trace bound's step two to four
times slower than OpenMP, and at times slower than one thread. Where numba falls back to the
work queue (no OpenMP) it serves one caller at a time: call parallel kernels holding
:data:`parallel_kernel_lock` (threads then take turns).

A serial kernel compiled with ``nogil=True`` whose items are independent can instead run on
Python threads, a slice of its batch each (:func:`in_slices`, under the same rule).

Kernels copy arrays element by element (:func:`~armpath.kinematics.copy_into`,
:func:`~armpath.ik.kernels.copy_system`) rather than by slice assignment (``a[:, :] = b``,
``out[k] = row``): numba compiles slice assignment through its general broadcasting code, which
cost seconds of compilation per kernel using it (the UR5's IK solver 13.9 -> 8.9 s in an empty
cache).
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Callable
from typing import Any, TypeVar, overload

F = TypeVar("F", bound=Callable[..., Any])
R = TypeVar("R")

#: ``range`` until numba is loaded, then ``numba.prange``; a kernel's module imports it as
#: ``from armpath.jit import prange`` and is rebound before any of its kernels compiles.
prange: Any = range

#: Held while a ``parallel=True`` kernel runs (see the module's description).
parallel_kernel_lock = threading.Lock()

_pending: list[_DeferredKernel] = []
_numba: Any = None
_loading = threading.Lock()


class _DeferredKernel:
    """A kernel whose numba dispatcher is made when a kernel is first called."""

    def __init__(self, func: Callable[..., Any], options: dict[str, Any]) -> None:
        self.py_func = func
        self.options = options
        self.dispatcher: Any = None
        self.__name__ = func.__name__
        self.__qualname__ = func.__qualname__
        self.__module__ = func.__module__
        self.__doc__ = func.__doc__
        self.__wrapped__ = func

    def __call__(self, *args: Any) -> Any:
        if self.dispatcher is None:
            load_numba()
        return self.dispatcher(*args)

    def __repr__(self) -> str:
        return f"<kernel {self.__module__}.{self.__qualname__} (numba not loaded yet)>"


def load_numba() -> Any:
    """Import numba (once), make every deferred kernel a numba dispatcher and rebind the names
    armpath's modules hold for them (and their ``prange``). Returns the numba module."""
    global _numba, prange
    with _loading:
        if _numba is not None:
            return _numba
        import numba

        for kernel in _pending:
            kernel.dispatcher = numba.njit(**kernel.options)(kernel.py_func)
        prange = numba.prange
        for name, module in list(sys.modules.items()):
            if module is None or not (name == "armpath" or name.startswith("armpath.")):
                continue
            namespace = module.__dict__
            for key, value in list(namespace.items()):
                if isinstance(value, _DeferredKernel):
                    namespace[key] = value.dispatcher
                elif key == "prange" and value is range:
                    namespace[key] = numba.prange
        _pending.clear()
        _numba = numba
    return numba


def numba_loaded() -> bool:
    """Whether numba has been loaded (a kernel has run) in this process."""
    return _numba is not None


@overload
def njit(func: F, /) -> F: ...
@overload
def njit(**options: Any) -> Callable[[F], F]: ...
def njit(func: Any = None, /, **options: Any) -> Any:
    """:func:`numba.njit` (same options, e.g. ``cache=True``, ``parallel=True``), deferred
    until a kernel is first called (see the module's description)."""

    def wrap(f: Callable[..., Any]) -> Any:
        if _numba is not None:
            return _numba.njit(**options)(f)
        kernel = _DeferredKernel(f, dict(options))
        _pending.append(kernel)
        return kernel

    return wrap(func) if func is not None else wrap


def threads_pay_off(n_items: int, threshold: int) -> bool:
    """Whether a batch of ``n_items`` should run a kernel's parallel version: at least
    ``threshold`` items (below, starting the threads costs more than they save) and a core to
    spare: at most the cores less one in use now (Linux: the runnable threads of other processes
    and this one; elsewhere the one-minute load average).
    On a machine whose cores are all busy, numba's threads wait for each other and a batch runs
    several times slower than on one thread, so there the serial version is taken. Never in a
    process forked after numba's threads started, nor where numba may use one thread (see the
    module's description)."""
    if n_items < threshold or _forked_after_threads or _one_thread():
        return False
    cores = os.cpu_count() or 1
    if cores < 2:
        return False
    return _busy_cores() <= cores - 1.0


def in_slices(run: Callable[[int, int], R], n_items: int, threshold: int) -> list[R]:
    """``run(a, b)`` over the items ``[0, n_items)``: one call ``run(0, n_items)``, or, where
    :func:`threads_pay_off` says a batch of ``n_items`` pays (``threshold`` as there), one call
    per core on a slice each, in Python threads, the results in the slices' order. For serial
    kernels compiled with ``nogil=True`` whose items are independent: the threads run them
    side by side, and the values are those of one call."""
    cores = os.cpu_count() or 1
    if cores < 2 or not threads_pay_off(n_items, threshold):
        return [run(0, n_items)]
    from concurrent.futures import ThreadPoolExecutor

    ends = [n_items * k // cores for k in range(cores + 1)]
    with ThreadPoolExecutor(max_workers=cores) as pool:
        return list(pool.map(run, ends[:-1], ends[1:]))


#: Whether this process was forked from one whose numba threads had started (see the module's
#: description); set in the child at the fork.
_forked_after_threads = False


def _note_fork_in_child() -> None:
    global _forked_after_threads
    threads = sys.modules.get("numba.np.ufunc.parallel")
    if threads is not None and getattr(threads, "_is_initialized", False):
        _forked_after_threads = True


if hasattr(os, "register_at_fork"):  # not on Windows, which does not fork
    os.register_at_fork(after_in_child=_note_fork_in_child)


def _one_thread() -> bool:
    """Whether numba may use only one thread in this process (``NUMBA_NUM_THREADS``)."""
    if _numba is not None:
        return int(_numba.config.NUMBA_NUM_THREADS) < 2
    return os.environ.get("NUMBA_NUM_THREADS", "").strip() == "1"


def _busy_cores() -> float:
    """Cores in use now: the threads of other processes that are running or ready to run,
    plus this thread (this process's own threads, numba's workers among them, do not count)."""
    try:
        with open("/proc/loadavg") as f:
            runnable = float(f.read().split()[3].split("/")[0])
        own = 0
        for task in os.listdir("/proc/self/task"):
            with open(f"/proc/self/task/{task}/stat") as f:
                own += f.read().rsplit(")", 1)[1].split()[0] == "R"
        return runnable - own + 1.0
    except (OSError, IndexError, ValueError):
        pass
    try:
        return os.getloadavg()[0]
    except OSError:  # not available on this platform: trust the size alone
        return 0.0


__all__ = ["load_numba", "njit", "numba_loaded", "prange", "threads_pay_off"]
