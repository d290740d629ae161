"""Reading a run folder back for the dive report: time series, events, plan, targets, truth.

The run folder's files and columns (written by the mission executor, see
:mod:`planner.mission.run_folder`):

``events.jsonl``
    One JSON object a line: ``t_s``, ``kind``, ``message`` and extra fields; ``kind``
    ``"state"`` carries ``state`` (CONNECT, ..., COMPLETED, ABORTED).
``nav.csv``
    ``t_s,north_m,east_m,depth_m,altitude_m,heading_deg,pitch_deg,roll_deg,mode,armed``.
``filter.csv``
    ``t_s,depth_est_m,altitude_est_m,altitude_std_m,seabed_depth_est_m,altimeter_m,rejected_total``.
``tilt.csv``
    ``t_s,tilt_cmd_deg,tilt_meas_deg,pitch_deg,min_margin_deg,n_tracked,altitude_target_m``.
``plan/plan.json``
    The survey plan (:meth:`planner.survey.plan.SurveyPlan.to_json`, or the short form
    ``{"passes": [{"name", "altitude_m", "tilt_deg", "waypoints_ne_m"}]}``).
``targets.csv``
    ``id,lat_deg,lon_deg,north_m,east_m,height_m,height_std_m,frames_used,reason``.
``truth.json``, ``truth_track.csv``, ``shadows.csv`` (simulation only)
    ``{"targets": [{"id", "north_m", "east_m", "height_m", "shape", ...}]}``;
    ``t_s,north_m,east_m,depth_m,altitude_m``; ``t_s,target_id,within_range,in_fov,settled``.
``summary.json``
    ``{"status", "reason", "sim_duration_s", ...}``.

Every file is optional: a missing one reads as ``None``. Extra columns and fields are
kept. Empty CSV cells read as NaN. A malformed file raises :class:`RunFolderError`
naming the file and line, except a malformed LAST line of a line-oriented file that does
not end in a newline: that is the line being written when the run stopped, and it is
dropped with a note (:attr:`Series.notes`).
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


class RunFolderError(ValueError):
    """A run-folder file is malformed; ``path`` names it, ``line`` the line (1-based) if known."""

    def __init__(self, path: Path, message: str, *, line: int | None = None):
        where = f"{path}:{line}" if line is not None else str(path)
        super().__init__(f"{where}: {message}")
        self.path = path
        self.line = line


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


@dataclass(frozen=True)
class PlannedPass:
    """One pass of the plan: its path and, when the plan says, its lane runs.

    Attributes
    ----------
    path_ne_m : ndarray, shape (n, 2)
        Waypoints in flying order, local NED ``(north_m, east_m)``.
    lanes_ne_m : ndarray, shape (k, 2, 2)
        Lane runs ``[[start_n, start_e], [end_n, end_e]]``; k = 0 when unknown.
    """

    name: str
    altitude_m: float
    tilt_rad: float
    path_ne_m: np.ndarray
    lanes_ne_m: np.ndarray


@dataclass(frozen=True)
class TargetRecord:
    """An estimated target (``targets.csv``) or a true one (``truth.json``).

    ``height_m``/``height_std_m`` are NaN when unknown; ``note`` is the ``reason`` of an
    estimate without a height, or the ``shape`` of a true target.
    """

    target_id: str
    north_m: float
    east_m: float
    height_m: float
    height_std_m: float = math.nan
    frames_used: int = 0
    note: str = ""


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


def _number(path: Path, where: str, value: Any) -> float:
    if value is None:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise RunFolderError(path, f"{where} must be a number, got {value!r}")
    return float(value)


def parse_plan(path: Path, doc: Mapping[str, Any]) -> tuple[PlannedPass, ...]:
    """The passes of a plan document (full ``SurveyPlan`` JSON or the short form).

    Raises
    ------
    RunFolderError
        When ``passes`` is missing or a pass has no readable waypoints.
    """
    passes = doc.get("passes")
    if not isinstance(passes, list):
        raise RunFolderError(path, "plan has no 'passes' list")
    out = []
    for k, p in enumerate(passes):
        where = f"passes[{k}]"
        if not isinstance(p, dict):
            raise RunFolderError(path, f"{where} is not an object")
        try:
            if "waypoints_ne_m" in p:
                path_ne = np.asarray(p["waypoints_ne_m"], dtype=float).reshape(-1, 2)
            else:
                path_ne = np.asarray([[w["north_m"], w["east_m"]] for w in p["waypoints"]],
                                     dtype=float).reshape(-1, 2)
            lanes = np.asarray([[[r["start_north_m"], r["start_east_m"]], [r["end_north_m"], r["end_east_m"]]]
                                for r in p.get("runs", [])], dtype=float).reshape(-1, 2, 2)
        except (KeyError, TypeError, ValueError) as exc:
            raise RunFolderError(path, f"{where}: unreadable waypoints or runs ({exc!r})") from None
        if "tilt_rad" in p:
            tilt_rad = _number(path, f"{where}.tilt_rad", p["tilt_rad"])
        else:
            tilt_rad = math.radians(_number(path, f"{where}.tilt_deg", p.get("tilt_deg")))
        out.append(PlannedPass(str(p.get("name", f"pass {k + 1}")),
                               _number(path, f"{where}.altitude_m", p.get("altitude_m")),
                               tilt_rad, path_ne, lanes))
    return tuple(out)


def estimated_targets(series: Series) -> tuple[TargetRecord, ...]:
    """The estimated targets of ``targets.csv`` (height NaN where none was solved)."""
    ids = series.text.get("id", ())
    reasons = series.text.get("reason", ("",) * series.n_rows)
    n, e, h, s, f = (series.col(c) for c in ("north_m", "east_m", "height_m", "height_std_m", "frames_used"))
    return tuple(
        TargetRecord(ids[i], float(n[i]), float(e[i]), float(h[i]), float(s[i]),
                     int(f[i]) if math.isfinite(f[i]) else 0, reasons[i])
        for i in range(series.n_rows)
    )


def true_targets(path: Path, doc: Mapping[str, Any]) -> tuple[TargetRecord, ...]:
    """The true targets of ``truth.json``.

    Raises
    ------
    RunFolderError
        When ``targets`` is missing or a target lacks ``north_m``/``east_m``/``height_m``.
    """
    targets = doc.get("targets")
    if not isinstance(targets, list):
        raise RunFolderError(path, "no 'targets' list")
    out = []
    for k, t in enumerate(targets):
        if not isinstance(t, dict):
            raise RunFolderError(path, f"targets[{k}] is not an object")
        for key in ("north_m", "east_m", "height_m"):
            if key not in t:
                raise RunFolderError(path, f"targets[{k}] lacks {key!r}")
        out.append(TargetRecord(str(t.get("id", k)),
                                _number(path, f"targets[{k}].north_m", t["north_m"]),
                                _number(path, f"targets[{k}].east_m", t["east_m"]),
                                _number(path, f"targets[{k}].height_m", t["height_m"]),
                                note=str(t.get("shape", ""))))
    return tuple(out)


@dataclass(frozen=True)
class RunData:
    """Everything the report reads from one run folder; ``None`` = file absent."""

    root: Path
    events: tuple[Event, ...] | None
    nav: Series | None
    filter: Series | None
    tilt: Series | None
    plan: tuple[PlannedPass, ...] | None
    targets: tuple[TargetRecord, ...] | None
    truth: tuple[TargetRecord, ...] | None
    truth_track: Series | None
    shadows: Series | None
    summary: Mapping[str, Any] | None
    notes: tuple[str, ...]

    @property
    def simulated(self) -> bool:
        """Whether simulator truth is present."""
        return self.truth is not None or self.truth_track is not None or self.shadows is not None

    def start_s(self) -> float:
        """The first time any series or event holds, s (0 for an empty run)."""
        starts = []
        for s in (self.nav, self.filter, self.tilt, self.truth_track):
            if s is not None and s.has("t_s"):
                starts.append(float(np.nanmin(s.col("t_s"))))
        if self.events:
            starts.append(min(e.t_s for e in self.events))
        return min(starts, default=0.0)

    def end_s(self) -> float:
        """The last time any series or event reaches, s (0 for an empty run)."""
        ends = [0.0]
        for s in (self.nav, self.filter, self.tilt, self.truth_track):
            if s is not None and s.has("t_s"):
                ends.append(float(np.nanmax(s.col("t_s"))))
        if self.events:
            ends.append(max(e.t_s for e in self.events))
        return max(ends)


def load_run(root: Path) -> RunData:
    """Read a run folder.

    Raises
    ------
    NotADirectoryError
        When ``root`` is not a folder.
    RunFolderError
        When a file is malformed (the message names it).
    """
    root = Path(root)
    if not root.is_dir():
        raise NotADirectoryError(f"{root}: not a run folder (no such directory)")
    notes: list[str] = []
    series = {}
    for name in ("nav.csv", "filter.csv", "tilt.csv", "truth_track.csv", "shadows.csv", "targets.csv"):
        s = read_series(root / name)
        if s is not None:
            notes.extend(s.notes)
        series[name] = s
    ev = read_events(root / "events.jsonl")
    if ev is not None:
        notes.extend(ev[1])
    plan_path = next((p for p in (root / "plan" / "plan.json", root / "plan.json") if p.is_file()), None)
    plan_doc = read_json(plan_path) if plan_path is not None else None
    truth_doc = read_json(root / "truth.json")
    targets = series["targets.csv"]
    return RunData(
        root=root,
        events=None if ev is None else ev[0],
        nav=series["nav.csv"],
        filter=series["filter.csv"],
        tilt=series["tilt.csv"],
        plan=None if plan_doc is None or plan_path is None else parse_plan(plan_path, plan_doc),
        targets=None if targets is None else estimated_targets(targets),
        truth=None if truth_doc is None else true_targets(root / "truth.json", truth_doc),
        truth_track=series["truth_track.csv"],
        shadows=series["shadows.csv"],
        summary=read_json(root / "summary.json"),
        notes=tuple(notes),
    )
