"""The run folder: everything one dive writes, complete on disk at every moment.

Whole files (summary, GeoJSON, mosaic) are replaced atomically (temporary file, then
rename), so a crash leaves the previous complete version. Time series and the event log
are line-oriented (CSV, JSON lines), flushed line by line: a crash loses at most the line
being written.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any

from perception.atomic_file import atomic_write, atomic_write_text

#: ``summary.json``'s ``status`` of a run that stopped before it was complete.
PARTIAL_STATUS = "partial"


def _jsonable(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    return value


class CsvSeries:
    """An append-only CSV time series with a fixed header, flushed per row."""

    def __init__(self, path: Path, columns: Sequence[str]):
        self.path = path
        self.columns = tuple(columns)
        self._handle: IO[str] = path.open("w", newline="", encoding="utf-8")
        self._writer = csv.writer(self._handle)
        self._writer.writerow(self.columns)
        self._handle.flush()
        self.rows = 0

    def append(self, **values: float | int | str | None) -> None:
        """Write one row; unknown columns are an error, missing ones are empty."""
        extra = set(values) - set(self.columns)
        if extra:
            raise KeyError(f"{self.path.name}: unknown columns {sorted(extra)}")
        row = []
        for c in self.columns:
            v = values.get(c)
            if isinstance(v, float):
                row.append("" if not math.isfinite(v) else f"{v:.6g}")
            else:
                row.append("" if v is None else str(v))
        self._writer.writerow(row)
        self._handle.flush()
        self.rows += 1

    def close(self) -> None:
        """Close the file."""
        self._handle.close()


class RunFolder:
    """The folder of one run, with its event log and time series.

    Parameters
    ----------
    root : Path
        Created if missing. The commands give it a fresh staged folder
        (:mod:`planner.mission.output_folder`), so no earlier run is ever mixed in.
    """

    def __init__(self, root: Path):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self._events: IO[str] = (self.root / "events.jsonl").open("w", encoding="utf-8")
        self._series: dict[str, CsvSeries] = {}
        self._last: dict[str, str] = {}

    def last_message(self, kind: str) -> str | None:
        """The message of the newest event of ``kind`` written so far (None before any)."""
        return self._last.get(kind)

    def path(self, name: str) -> Path:
        """Path of a file in the run folder (sub-folders created)."""
        p = self.root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    def event(self, time_s: float, kind: str, message: str, **fields: Any) -> dict[str, Any]:
        """Append one event to ``events.jsonl`` (flushed) and return it."""
        record = {"t_s": round(float(time_s), 3), "kind": kind, "message": message, **_jsonable(fields)}
        self._events.write(json.dumps(record) + "\n")
        self._events.flush()
        self._last[kind] = message
        return record

    def series(self, name: str, columns: Sequence[str]) -> CsvSeries:
        """The CSV series ``name`` (created with ``columns`` on first use)."""
        if name not in self._series:
            self._series[name] = CsvSeries(self.path(name), columns)
        return self._series[name]

    def write_json(self, name: str, doc: Any) -> Path:
        """Write a JSON document atomically (non-finite floats become null)."""
        return atomic_write_text(self.path(name), json.dumps(_jsonable(doc), indent=2) + "\n")

    def write_text(self, name: str, text: str) -> Path:
        """Write a text file atomically."""
        return atomic_write_text(self.path(name), text)

    def write_csv(self, name: str, columns: Sequence[str], rows: Sequence[Sequence[Any]]) -> Path:
        """Write a whole CSV file atomically."""
        buffer = io.StringIO()
        writer = csv.writer(buffer)
        writer.writerow(columns)
        writer.writerows(rows)
        data = buffer.getvalue().encode("utf-8")
        return atomic_write(self.path(name), lambda h: h.write(data))

    def close(self) -> None:
        """Close the event log and every series."""
        for s in self._series.values():
            s.close()
        self._events.close()


def stop_reason(exc: BaseException) -> str:
    """Why a run stopped, for its summary: ``"interrupted (Ctrl-C)"`` or the error's type and text."""
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted (Ctrl-C)"
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def mark_partial(root: Path, exc: BaseException) -> Path:
    """Mark the run folder ``root`` partial: its ``summary.json`` says ``"status": "partial"``
    and why (``reason``); a summary already written is kept under ``"summary_before_stop"``.

    Used by :func:`planner.mission.output_folder.staged_folder` when a run stops early (a
    crash, Ctrl-C); the files already written stay as they were (each complete, see the
    module docstring).
    """
    path = Path(root) / "summary.json"
    before: Any = None
    if path.is_file():
        try:
            before = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            before = None
    doc = {
        "status": PARTIAL_STATUS,
        "reason": stop_reason(exc),
        "partial": "the run stopped before it was complete: events.jsonl and the CSV series hold what was "
                   "logged up to the stop; products (targets, mosaic, report) may be from an earlier moment "
                   "of the run or missing",
    }
    if before is not None:
        doc["summary_before_stop"] = before
    return atomic_write_text(path, json.dumps(_jsonable(doc), indent=2) + "\n")
