"""What every test of the command line checks on stderr."""

from __future__ import annotations


def error_lines(stderr: str) -> list[str]:
    """stderr without the progress lines (``armpath: [12.3 s] ...``) that long commands print
    when stderr is not a terminal: what is left of a failed command must be one ``error:``
    line."""
    return [line for line in stderr.strip().splitlines() if not line.startswith("armpath: [")]
