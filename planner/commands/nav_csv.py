"""The navigation CSV of ``shadowsurvey mosaic --nav``: the vehicle's pose by time.

Columns (a header row, then one row per sample, comma-separated, UTF-8):

``t_s,north_m,east_m,heading_deg,altitude_m,tilt_deg`` required, ``depth_m,pitch_deg,
roll_deg`` optional (empty cells there are unknown). Times on the frames' clock, strictly
increasing; every required cell a finite number; ``altitude_m`` > 0, ``tilt_deg`` and
``pitch_deg`` within +-90, ``roll_deg`` within +-180, ``depth_m`` not above the surface.
A frame takes the position and altitude interpolated at its timestamp, attitude and tilt
of the nearest row (the product's one navigation history,
:class:`perception.navigation.history.NavigationHistory`, as on board).

Any problem raises :class:`~planner.errors.UsageError` naming the file, the line and the
column.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from perception.errors import FrameFormatError
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.validate import DEPTH_ABOVE_SURFACE_TOLERANCE_M
from planner.errors import UsageError

NAV_COLUMNS = ("t_s", "north_m", "east_m", "heading_deg", "altitude_m", "tilt_deg")
OPTIONAL_COLUMNS = ("depth_m", "pitch_deg", "roll_deg")
#: (lowest, highest) value of a column where it is limited.
_LIMITS = {"altitude_m": (0.0, 1000.0), "tilt_deg": (-90.0, 90.0), "pitch_deg": (-90.0, 90.0),
           "roll_deg": (-180.0, 180.0), "depth_m": (-DEPTH_ABOVE_SURFACE_TOLERANCE_M, 11_000.0)}


def _cell(path: Path, line: int, column: str, text: str | None) -> float:
    text = (text or "").strip()
    if text == "":
        if column in NAV_COLUMNS:
            raise UsageError(f"{path}:{line}: column {column}: empty; every row needs {', '.join(NAV_COLUMNS)}")
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise UsageError(f"{path}:{line}: column {column}: {text[:40]!r} is not a number") from None
    if not math.isfinite(value):
        raise UsageError(f"{path}:{line}: column {column}: must be finite, got {text[:40]!r}")
    lo, hi = _LIMITS.get(column, (-math.inf, math.inf))
    if not (lo < value <= hi if column == "altitude_m" else lo <= value <= hi):
        raise UsageError(f"{path}:{line}: column {column}: {value:g} is outside {lo:g}..{hi:g}")
    return value


def _rows(path: Path) -> tuple[list[str], list[dict[str, str | None]], list[int]]:
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise UsageError(f"{path}: navigation CSV is not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    reader = csv.DictReader(text.splitlines())
    rows: list[dict[str, str | None]] = []
    lines: list[int] = []
    try:
        for row in reader:
            rows.append(row)
            lines.append(reader.line_num)
        header = [h.strip() for h in (reader.fieldnames or [])]
    except csv.Error as exc:
        raise UsageError(f"{path}:{reader.line_num}: not a readable CSV row ({exc})") from None
    return header, rows, lines


class NavTable:
    """Pose by time from a navigation CSV (see the module docstring)."""

    def __init__(self, path: Path):
        path = Path(path)
        header, rows, lines = _rows(path)
        missing = [c for c in NAV_COLUMNS if c not in header]
        if missing:
            raise UsageError(f"{path}: navigation CSV lacks columns {', '.join(missing)} (header: "
                             f"{','.join(header)[:120]})")
        if len(rows) < 2:
            raise UsageError(f"{path}: navigation CSV needs at least two rows")
        present = [c for c in (*NAV_COLUMNS, *OPTIONAL_COLUMNS) if c in header]
        stripped = [{(k or "").strip(): v for k, v in row.items()} for row in rows]
        self.columns = {c: np.array([_cell(path, line, c, row.get(c)) for row, line in zip(stripped, lines,
                                                                                          strict=True)])
                        for c in present}
        t = self.columns["t_s"]
        steps = np.diff(t)
        if not np.all(steps > 0):
            k = int(np.flatnonzero(steps <= 0)[0])
            raise UsageError(f"{path}:{lines[k + 1]}: column t_s: {t[k + 1]:g} does not come after {t[k]:g}; "
                             "times must be strictly increasing")
        self.path = path
        c = self.columns
        nan = np.full(t.shape, math.nan)
        from perception.navigation.history import NavigationHistory  # its package loads the altitude filter

        self.history = NavigationHistory(float(t[-1] - t[0]) + 1.0, max_extrapolation_s=0.0)
        for k, time_s in enumerate(t):
            self.history.add_position(float(time_s), float(c["north_m"][k]), float(c["east_m"][k]))
            self.history.add_attitude(float(time_s), math.radians(c["heading_deg"][k]),
                                      math.radians(c.get("pitch_deg", nan)[k]), math.radians(c.get("roll_deg", nan)[k]))
            self.history.add_tilt(float(time_s), math.radians(c["tilt_deg"][k]))

    def apply(self, frame: SonarFrame, label: str) -> SonarFrame:
        """``frame`` (named ``label`` in messages) with the pose at its timestamp."""
        t = self.columns["t_s"]
        if not t[0] <= frame.timestamp_s <= t[-1]:
            raise UsageError(f"{label}: frame at t={frame.timestamp_s:.3f} s lies outside {self.path} "
                             f"({t[0]:.3f} to {t[-1]:.3f} s): the frames and the CSV must share one clock")
        nav = self.history.at(frame.timestamp_s)
        if nav is None:  # pragma: no cover - the CSV has at least two rows
            raise UsageError(f"{label}: no navigation at t={frame.timestamp_s:.3f} s in {self.path}")

        def lin(name: str) -> float:
            return float(np.interp(frame.timestamp_s, t, self.columns[name]))

        try:
            return frame.with_fields(north_m=nav.north_m, east_m=nav.east_m, altitude_m=lin("altitude_m"),
                                     heading_rad=nav.heading_rad, tilt_rad=nav.tilt_rad,
                                     vehicle_pitch_rad=nav.pitch_rad, vehicle_roll_rad=nav.roll_rad,
                                     sonar_depth_m=lin("depth_m") if "depth_m" in self.columns
                                     else frame.sonar_depth_m)
        except FrameFormatError as exc:
            raise UsageError(f"{label}: the pose from {self.path} at t={frame.timestamp_s:.3f} s: {exc}") from None
