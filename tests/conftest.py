import fcntl
import os
import subprocess
import sys
import time
from pathlib import Path

# One core per xdist worker: numba's and the BLAS's own thread pools in each of two workers
# would fight over two cores (the default run took 834 s that way, 546 s with these). Set
# before numpy and numba are imported; a value the caller set is kept.
if os.environ.get("PYTEST_XDIST_WORKER"):
    for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")

import pytest

sys.path.insert(0, str(Path(__file__).parent))

#: Longest wait for ``armpath run`` (s).
SEED_RUN_TIMEOUT_S = 1800.0

# What the background process runs: ``armpath run`` in the current folder, then its exit status
# into ``rc`` (written last, so its presence means the run is over).
_RUN_AND_RECORD = """
import subprocess, sys
with open("stdout.txt.part", "w") as out, open("stderr.txt", "w") as err:
    rc = subprocess.run([sys.executable, "-m", "armpath", "run"], stdout=out, stderr=err).returncode
import os
os.replace("stdout.txt.part", "stdout.txt")
with open("rc.part", "w") as f:
    f.write(str(rc))
os.replace("rc.part", "rc")
"""


def _shared_folder(config: pytest.Config) -> Path:
    """The session's base temporary folder, the same for every xdist worker."""
    base = config._tmp_path_factory.getbasetemp()  # the tmp_path_factory fixture's object
    return base.parent if base.name.startswith("popen-gw") else base


def _start_seed_run(config: pytest.Config) -> Path:
    """Start ``armpath run`` in the background, once per session (the first process to get
    here starts it; the others find it started)."""
    cwd = _shared_folder(config) / "seed_run"
    with open(_shared_folder(config) / "seed_run.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not cwd.exists():
            cwd.mkdir()
            subprocess.Popen(
                [sys.executable, "-c", _RUN_AND_RECORD],
                cwd=cwd,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
            )
    return cwd


@pytest.hookimpl(tryfirst=True)
def pytest_itemcollected(item):
    """A test that reads ``armpath run``'s output is ``slow``: the run takes minutes."""
    if "seed_run" in getattr(item, "fixturenames", ()):
        item.add_marker(pytest.mark.slow)


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(session, config, items):
    """Files that read ``armpath run``'s output go last, and the run starts in the background
    as soon as the tests are collected: no worker then sits idle waiting for it while other
    tests could run (``--dist worksteal`` hands the tests out from the front, an idle worker
    taking over the rest of another's)."""
    files = {item.path for item in items if "seed_run" in getattr(item, "fixturenames", ())}
    if not files:
        return
    items.sort(key=lambda item: item.path in files)  # stable: the order within stays
    _start_seed_run(config)


@pytest.fixture(scope="session")
def seed_run(pytestconfig):
    """``armpath run`` once per test session, as a user runs it: (output folder, stdout).

    It runs in the background from the start of the session in a folder all workers share;
    a test that needs it waits for it to end.
    """
    cwd = _start_seed_run(pytestconfig)
    rc_file = cwd / "rc"
    deadline = time.monotonic() + SEED_RUN_TIMEOUT_S
    while not rc_file.exists():
        assert time.monotonic() < deadline, "armpath run did not finish in time"
        time.sleep(0.5)
    rc = int(rc_file.read_text())
    assert rc == 0, (cwd / "stderr.txt").read_text()
    return cwd / "armpath-out", (cwd / "stdout.txt").read_text()
