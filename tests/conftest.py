import fcntl
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture(scope="session")
def seed_run(tmp_path_factory):
    """``armpath run`` once per test session, as a user runs it: (output folder, stdout).

    With parallel workers (pytest-xdist) the first worker that needs it runs it in a folder all
    workers share; the others wait on a file lock and read the same output.
    """
    worker_tmp = tmp_path_factory.getbasetemp()
    shared = worker_tmp.parent if worker_tmp.name.startswith("popen-gw") else worker_tmp
    cwd = shared / "seed_run"
    stdout_file = cwd / "stdout.txt"
    with open(shared / "seed_run.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not stdout_file.exists():
            cwd.mkdir(exist_ok=True)
            proc = subprocess.run(
                [sys.executable, "-m", "armpath", "run"],
                capture_output=True,
                text=True,
                cwd=cwd,
                timeout=900,
            )
            assert proc.returncode == 0, proc.stderr
            stdout_file.write_text(proc.stdout)
    return cwd / "armpath-out", stdout_file.read_text()
