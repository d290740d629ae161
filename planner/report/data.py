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

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planner.report.run_files import (
    REQUIRED_COLUMNS,
    Event,
    RunFolderError,
    Series,
    read_events,
    read_json,
    read_series,
)

__all__ = ["REQUIRED_COLUMNS", "Event", "PlannedPass", "RunData", "RunFolderError", "Series", "TargetRecord",
           "estimated_targets", "load_run", "parse_plan", "read_events", "read_json", "read_series", "true_targets"]

#: The files a run folder may hold; a folder with none of them is not a run folder.
RUN_FILES = ("events.jsonl", "nav.csv", "filter.csv", "tilt.csv", "plan/plan.json", "targets.csv", "summary.json",
             "truth.json", "truth_track.csv", "shadows.csv")


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
    def empty(self) -> bool:
        """Whether the folder holds none of the run files (:data:`RUN_FILES`): not a run folder."""
        return all(v is None for v in (self.events, self.nav, self.filter, self.tilt, self.plan, self.targets,
                                       self.truth, self.truth_track, self.shadows, self.summary))

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
