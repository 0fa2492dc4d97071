import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))


@pytest.fixture(scope="session")
def seed_run(tmp_path_factory):
    """``armpath run`` once per test session, as a user runs it: (output folder, stdout)."""
    cwd = tmp_path_factory.mktemp("seed_run")
    proc = subprocess.run(
        [sys.executable, "-m", "armpath", "run"],
        capture_output=True,
        text=True,
        cwd=cwd,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr
    return cwd / "armpath-out", proc.stdout
