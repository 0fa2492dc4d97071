"""``armpath`` command lines run in the test's own process.

Starting an interpreter, importing numpy and loading the compiled kernels cost about a second
per run; the refusal tests run the CLI a hundred times. :func:`run_in_process` calls the same
console entry point (:func:`armpath.cli.main`: the parser, the commands, the one-line error
handling) with ``sys.argv`` set, in ``cwd``, with stdout and stderr captured, and takes the exit
status from its ``SystemExit`` as the interpreter would. An exception that escapes ``main`` (what
would print a traceback) is raised into the test. Runs that start worker processes or must
be stopped by a time limit are run as real processes (``subprocess``) by their tests.
"""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys
from pathlib import Path

from armpath.cli import main


def run_in_process(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """``python -m armpath *args`` in ``cwd``, in this process: exit status, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    saved_argv = sys.argv
    sys.argv = ["armpath", *args]
    code = 0
    try:
        with (
            contextlib.chdir(cwd),
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
        ):
            try:
                main()
            except SystemExit as exc:
                if exc.code is None or isinstance(exc.code, int):
                    code = exc.code or 0
                else:  # the interpreter prints a message given to sys.exit and exits with 1
                    err.write(f"{exc.code}\n")
                    code = 1
    finally:
        sys.argv = saved_argv
    return subprocess.CompletedProcess(["armpath", *args], code, out.getvalue(), err.getvalue())
