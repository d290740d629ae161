"""Reading the files of a run folder: CSV series, the event log, JSON documents.

Every reader returns ``None`` for a file that does not exist and raises
:class:`RunFolderError` naming the file and line for a malformed one, except a malformed
LAST line of a line-oriented file that does not end in a newline: that is the line being
written when the run stopped, and it is dropped with a note (:attr:`Series.notes`).
Which files and columns a run folder holds: :mod:`planner.report.data`.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

#: Columns kept as text (every other column must be a number or empty).
TEXT_COLUMNS = frozenset({"mode", "id", "target_id", "reason", "shape", "state", "kind"})
#: Values of boolean columns (``armed``) read as 1 / 0.
_TRUE = frozenset({"1", "true", "yes", "armed"})
_FALSE = frozenset({"0", "false", "no", "disarmed"})

#: Required columns of each CSV file of the run folder.
REQUIRED_COLUMNS: Mapping[str, tuple[str, ...]] = {
    "nav.csv": ("t_s",),
    "filter.csv": ("t_s",),
    "tilt.csv": ("t_s",),
    "truth_track.csv": ("t_s", "north_m", "east_m"),
    "shadows.csv": ("t_s", "target_id", "in_fov"),
    "targets.csv": ("id", "north_m", "east_m", "height_m"),
}

#: A run folder's CSV fields may be long (a target's reason), up to this many characters.
MAX_CSV_FIELD = 16 * 1024 * 1024


class RunFolderError(ValueError):
    """A run-folder file is malformed; ``path`` names it, ``line`` the line (1-based) if known."""

    def __init__(self, path: Path, message: str, *, line: int | None = None):
        where = f"{path}:{line}" if line is not None else str(path)
        super().__init__(f"{where}: {message}")
        self.path = path
        self.line = line
        self._message = message

    def __reduce__(self) -> tuple[object, ...]:
        # Rebuilt from its own arguments (a figure process sends it back to the dive's).
        return _rebuild_run_folder_error, (self.path, self._message, self.line)


def _rebuild_run_folder_error(path: Path, message: str, line: int | None) -> RunFolderError:
    return RunFolderError(path, message, line=line)


@dataclass(frozen=True)
class Series:
    """One CSV time series (or table) of the run folder.

    Attributes
    ----------
    path : Path
    numbers : mapping of str to ndarray, shape (n_rows,), float64
        Numeric columns; NaN where the cell was empty.
    text : mapping of str to tuple of str
        Text columns (``mode``, ``id``, ...), as written.
    n_rows : int
    notes : tuple of str
        What was tolerated (a truncated last line).
    """

    path: Path
    numbers: Mapping[str, np.ndarray]
    text: Mapping[str, tuple[str, ...]]
    n_rows: int
    notes: tuple[str, ...] = ()

    def col(self, name: str) -> np.ndarray:
        """The numeric column ``name``, shape (n_rows,); all NaN when absent."""
        if name in self.numbers:
            return self.numbers[name]
        return np.full(self.n_rows, np.nan)

    def has(self, name: str) -> bool:
        """Whether the numeric column exists and holds at least one number."""
        return name in self.numbers and bool(np.isfinite(self.numbers[name]).any())


@dataclass(frozen=True)
class Event:
    """One line of ``events.jsonl``; ``fields`` holds every extra field."""

    t_s: float
    kind: str
    message: str
    fields: Mapping[str, Any] = field(default_factory=dict)

    @property
    def state(self) -> str:
        """The state a ``state`` event enters (its ``state`` field, else its message)."""
        return str(self.fields.get("state") or self.message).strip().upper()


def _float_cell(path: Path, line: int, column: str, cell: str) -> float:
    cell = cell.strip()
    if cell == "" or cell.lower() in ("nan", "none", "null"):
        return math.nan
    if column == "armed":
        if cell.lower() in _TRUE:
            return 1.0
        if cell.lower() in _FALSE:
            return 0.0
    try:
        return float(cell)
    except ValueError:
        raise RunFolderError(path, f"column {column!r}: {cell!r} is not a number", line=line) from None


def read_series(path: Path) -> Series | None:
    """Read one CSV file of the run folder; ``None`` when it does not exist.

    Raises
    ------
    RunFolderError
        For a header without a required column (:data:`REQUIRED_COLUMNS`), a row with the
        wrong number of cells or a non-number in a numeric column (except a last line
        cut short by a stopped run, which is dropped with a note).
    """
    if not path.is_file():
        return None
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise RunFolderError(path, f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    if csv.field_size_limit() < MAX_CSV_FIELD:
        csv.field_size_limit(MAX_CSV_FIELD)
    rows = list(csv.reader(text.splitlines()))
    if not rows:
        return Series(path, {}, {}, 0, (f"{path.name} is empty (no header)",))
    header = [h.strip() for h in rows[0]]
    missing = [c for c in REQUIRED_COLUMNS.get(path.name, ()) if c not in header]
    if missing:
        raise RunFolderError(path, f"header lacks column(s) {missing} (header: {','.join(header)})", line=1)
    body = rows[1:]
    notes: list[str] = []
    cut_short = not text.endswith("\n")
    numbers: dict[str, list[float]] = {h: [] for h in header if h not in TEXT_COLUMNS}
    texts: dict[str, list[str]] = {h: [] for h in header if h in TEXT_COLUMNS}
    for i, row in enumerate(body):
        line = i + 2
        last = i == len(body) - 1
        try:
            if not row:
                continue
            if len(row) != len(header):
                raise RunFolderError(path, f"{len(row)} cells, header has {len(header)}", line=line)
            parsed = {h: _float_cell(path, line, h, c) for h, c in zip(header, row, strict=True)
                      if h in numbers}
        except RunFolderError:
            if last and cut_short:
                notes.append(f"{path.name}: dropped line {line}, cut short when the run stopped")
                break
            raise
        for h, v in parsed.items():
            numbers[h].append(v)
        for h, c in zip(header, row, strict=True):
            if h in texts:
                texts[h].append(c.strip())
    n_rows = len(next(iter(numbers.values()))) if numbers else len(next(iter(texts.values()), []))
    return Series(path, {h: np.asarray(v, dtype=float) for h, v in numbers.items()},
                  {h: tuple(v) for h, v in texts.items()}, n_rows, tuple(notes))


def read_events(path: Path) -> tuple[tuple[Event, ...], tuple[str, ...]] | None:
    """Read ``events.jsonl``: the events in file order and notes; ``None`` when absent.

    Raises
    ------
    RunFolderError
        For a line that is not a JSON object with a numeric ``t_s`` and a ``kind``.
    """
    if not path.is_file():
        return None
    text = path.read_text(encoding="utf-8", errors="replace")
    lines = text.splitlines()
    events: list[Event] = []
    notes: list[str] = []
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            try:
                doc = json.loads(line)
            except json.JSONDecodeError as exc:
                raise RunFolderError(path, f"not JSON: {exc.msg}", line=i + 1) from None
            if not isinstance(doc, dict):
                raise RunFolderError(path, "not a JSON object", line=i + 1)
            t_s = doc.get("t_s")
            if isinstance(t_s, bool) or not isinstance(t_s, int | float) or not math.isfinite(t_s):
                raise RunFolderError(path, f"'t_s' must be a finite number, got {t_s!r}", line=i + 1)
            if not isinstance(doc.get("kind"), str):
                raise RunFolderError(path, f"'kind' must be a string, got {doc.get('kind')!r}", line=i + 1)
        except RunFolderError:
            if i == len(lines) - 1 and not text.endswith("\n"):
                notes.append(f"{path.name}: dropped line {i + 1}, cut short when the run stopped")
                break
            raise
        extra = {k: v for k, v in doc.items() if k not in ("t_s", "kind", "message")}
        events.append(Event(float(t_s), doc["kind"], str(doc.get("message", "")), extra))
    return tuple(events), tuple(notes)


def read_json(path: Path) -> dict[str, Any] | None:
    """A JSON object file; ``None`` when absent. Raises :class:`RunFolderError` if malformed."""
    if not path.is_file():
        return None
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise RunFolderError(path, f"not JSON: {exc.msg}", line=exc.lineno) from None
    except UnicodeDecodeError as exc:
        raise RunFolderError(path, f"not UTF-8 text ({exc.reason})") from None
    if not isinstance(doc, dict):
        raise RunFolderError(path, f"must hold a JSON object, holds {type(doc).__name__}")
    return doc


