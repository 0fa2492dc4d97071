"""Numeric tables the CLI reads from files: joint waypoints (``armpath trajectory
--waypoints``) and curve points (``armpath trace --curve``).

A table is UTF-8 text (a byte-order mark is skipped), one row a line, the values separated by
commas or, in a line without commas, by spaces or tabs; a first line that is not all numbers
names the columns. It is read a line at a time and refused at the first line past a limit
(lines of at most ``MAX_LINE_BYTES`` bytes, the rows and columns the caller allows), every value
a finite number and every row as long as the first; each error names the line (and column).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from armpath.cli.common import is_number
from armpath.errors import InvalidInputError

#: Longest line of a table file (bytes).
MAX_LINE_BYTES = 65_536


def read_number_table(
    path: Path, option: str, rows_named: str, max_rows: int, max_columns: int, columns: str
) -> tuple[list[str] | None, np.ndarray]:
    """The column names (lower case; ``None`` without a header line) and the values
    ``(rows, columns)`` of the table at ``path``, given by ``option``. At most ``max_rows``
    rows (``rows_named``: what a row is, for the messages: "waypoints") and ``max_columns``
    columns (``columns`` says what they are)."""
    name = f"{option} {path}"
    header: list[str] | None = None
    rows: list[list[float]] = []
    width = 0
    try:
        with path.open("rb") as fh:
            for number, raw in enumerate(_lines(fh, name), start=1):
                line = _decoded(raw, number, name).strip()
                if not line:
                    continue
                cells = [c.strip() for c in line.split(",")] if "," in line else line.split()
                if len(cells) > max_columns:
                    raise InvalidInputError(
                        f"{name}: line {number} has {len(cells):,} values; a row holds at most "
                        f"{max_columns:,} ({columns})"
                    )
                if ";" in line and all(is_number(c) for c in line.split(";") if c.strip()):
                    raise InvalidInputError(
                        f"{name}: line {number} has values separated by ';'; separate them by "
                        "commas or spaces"
                    )
                if header is None and not rows and not all(is_number(c) for c in cells):
                    header = [c.lower() for c in cells]
                    width = len(cells)
                    continue
                if width and len(cells) != width:
                    raise InvalidInputError(
                        f"{name}: line {number} has {len(cells)} values, "
                        f"{'the header has' if header else 'the first row has'} {width}"
                    )
                width = len(cells)
                if len(rows) == max_rows:  # refused at the first row past the limit
                    raise InvalidInputError(
                        f"{name}: more than {max_rows:,} {rows_named} (rows; the limit is "
                        f"{max_rows:,}); change {option}"
                    )
                rows.append([_number(c, number, k + 1, name) for k, c in enumerate(cells)])
    except OSError as exc:
        raise InvalidInputError(
            f"cannot read {rows_named} file {path} ({option}): {exc.strerror or exc}"
        ) from None
    if not rows:
        raise InvalidInputError(
            f"{name} has no rows, only a header" if header else f"{name} is empty"
        )
    return header, np.array(rows, dtype=np.float64)


def _lines(fh: Any, name: str) -> Iterator[bytes]:
    """The lines of a binary file, refusing one longer than ``MAX_LINE_BYTES``."""
    number = 0
    while True:
        raw = fh.readline(MAX_LINE_BYTES + 2)
        if not raw:
            return
        number += 1
        if len(raw.rstrip(b"\r\n")) > MAX_LINE_BYTES:
            raise InvalidInputError(
                f"{name}: line {number} is longer than {MAX_LINE_BYTES:,} bytes"
            )
        yield raw


def _decoded(raw: bytes, number: int, name: str) -> str:
    try:
        return raw.decode("utf-8-sig" if number == 1 else "utf-8")
    except UnicodeDecodeError as exc:
        raise InvalidInputError(
            f"{name}: line {number} is not UTF-8 text (byte 0x{raw[exc.start]:02x} at "
            f"position {exc.start + 1}); save it as UTF-8 CSV"
        ) from None


def _number(text: str, line: int, column: int, name: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise InvalidInputError(
            f"{name}: line {line}, column {column}: {text!r} is not a number"
        ) from None
    if not math.isfinite(x):
        raise InvalidInputError(
            f"{name}: line {line}, column {column}: {text!r} is not a finite number"
        )
    return x
