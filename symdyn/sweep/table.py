"""A sweep's results table: one CSV file, one line per finished task, appended as rows arrive.

Where it sits: the sweep driver (`symdyn.sweep.engine`) writes each row here the
moment its task finishes, so an interruption loses nothing; a resume reads the
table back and skips the tasks it holds.  CSV, not Parquet: a row is appended
with one `os.write` of one whole line to a file opened for appending (Parquet
cannot append a row, only rewrite a file or add row groups, and pyarrow would
be a ~100 MB dependency for tables of a few thousand rows); the standard
library reads and writes it, and so does every spreadsheet and `pandas`.

Every value is written on one line: numbers with `repr` (floats round-trip
exactly), arrays and lists as JSON, text with its line breaks replaced.  A
kill in the middle of a write can at worst leave a last line without its
newline: `Table.open` drops it (the task is simply run again), so a half row
never reaches a reader nor breaks a resume.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from ..derivation.cache import write_atomic

__all__ = ["Table", "encode", "decode_json", "TableError"]


class TableError(ValueError):
    """A results table that cannot be resumed (other columns, other inputs)."""


def encode(value: Any) -> str:
    """One cell: '' for None, repr for numbers (NaN as 'nan'), JSON for lists, tuples,
    dicts and arrays, text on one line.

    Raises:
        TypeError: a list, tuple, dict or array holding something JSON cannot write
            (not a number, text, list, dict or NumPy value).
    """
    if value is None:
        return ""
    if isinstance(value, (bool, np.bool_)):
        return "1" if value else "0"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value)) if math.isfinite(value) else str(float(value))
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple, dict)):
        return json.dumps(value, separators=(",", ":"), allow_nan=True, default=_plain)
    return str(value).replace("\r", " ").replace("\n", " | ")


def _plain(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} {value!r} into a results table")


def decode_json(cell: str) -> Any:
    """A list/dict cell back to Python (NaN kept), '' to None.

    Raises:
        json.JSONDecodeError: (a `ValueError`) a cell that is not JSON.
    """
    return None if cell == "" else json.loads(cell)


def _line(columns: tuple[str, ...], values: Iterable[str]) -> bytes:
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(list(values))
    text = buf.getvalue()
    if text.count("\n") != 1:  # encode() keeps every cell on one line; a quoted break would split a row
        raise ValueError(f"a row of {columns} spans several lines: {text!r}")
    return text.encode()


class Table:
    """The CSV file at `path` with `columns` (the first is the task id).

    `Table.open(path, columns, resume)`: a new file (header only), or with
    resume=True the existing one, its torn last line (if any) cut off.
    `append(row)` writes one row (a mapping of column → value) and returns
    its encoded cells; `rows` are the rows on disk as dicts of strings.

    Raises:
        TableError: (`Table.open`) a file that holds results without resume=True, or
            whose header is not `columns`, or a row with another number of cells.
        OSError: the file cannot be opened (`Table(...)` opens an existing file).
        ValueError: (`append`) a row with columns the table does not have.
    """

    def __init__(self, path: Path, columns: tuple[str, ...], rows: list[dict[str, str]]):
        self.path, self.columns, self.rows = Path(path), tuple(columns), rows
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)
        self.ids = {r[self.columns[0]] for r in rows}

    @classmethod
    def open(cls, path: Path, columns: tuple[str, ...], *, resume: bool) -> "Table":
        path = Path(path)
        held = path.exists() and path.read_bytes().count(b"\n") > 1  # a header and at least one row
        if held and not resume:
            raise TableError(
                f"{path} already holds results: pass --resume to finish that sweep, or choose another --out"
            )
        if not held:
            write_atomic(path, _line(columns, columns))
            return cls(path, columns, [])
        raw = path.read_bytes()
        if not raw.endswith(b"\n"):  # a row torn by a kill: drop it, its task runs again
            raw = raw[: raw.rfind(b"\n") + 1]
            write_atomic(path, raw)
        reader = csv.reader(io.StringIO(raw.decode()))
        header = tuple(next(reader, ()))
        if header != tuple(columns):
            raise TableError(
                f"{path}: its columns {list(header)} are not this sweep's {list(columns)}; choose another --out"
            )
        rows = []
        for lineno, cells in enumerate(reader, start=2):
            if len(cells) != len(columns):
                raise TableError(f"{path}:{lineno}: {len(cells)} cells, expected {len(columns)}")
            rows.append(dict(zip(columns, cells)))
        return cls(path, columns, rows)

    def drop(self, ids: set[str]) -> None:
        """Remove the rows of `ids` (a resume re-runs failed tasks): the file rewritten atomically."""
        keep = [r for r in self.rows if r[self.columns[0]] not in ids]
        if len(keep) == len(self.rows):
            return
        os.close(self._fd)
        text = b"".join(
            [_line(self.columns, self.columns)] + [_line(self.columns, (r[c] for c in self.columns)) for r in keep]
        )
        write_atomic(self.path, text)
        self.rows = keep
        self.ids = {r[self.columns[0]] for r in keep}
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND)

    def append(self, row: Mapping) -> dict[str, str] | None:
        """Write one row as one line (one write call); None if its task id is already in the table."""
        unknown = set(row) - set(self.columns)
        if unknown:
            raise ValueError(
                f"row has columns {sorted(unknown)} that {self.path.name} does not have ({list(self.columns)})"
            )
        cells = {c: encode(row.get(c)) for c in self.columns}
        if cells[self.columns[0]] in self.ids:
            return None
        data = _line(self.columns, cells.values())
        while data:  # one call for a row of a regular file; loop if it is short
            data = data[os.write(self._fd, data) :]
        self.ids.add(cells[self.columns[0]])
        self.rows.append(cells)
        return cells

    def close(self) -> None:
        if self._fd >= 0:
            os.fsync(self._fd)
            os.close(self._fd)
            self._fd = -1

    def __enter__(self) -> "Table":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
