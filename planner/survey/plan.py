"""The planned survey as frozen data, with a JSON form (``plan.json``) that round-trips.

This is what the mission executor consumes. Positions are local NED about the plan's
origin (``north_m``, ``east_m``; the plan is on the horizontal plane, so ``down`` is the
depth) plus their WGS84 ``lat_deg``/``lon_deg``. Altitudes are above the seabed (m),
depths below the surface (m), tilts are mount depressions (rad, positive down).

A :class:`SurveyPass` is one complete lawnmower at one altitude and tilt: its
``waypoints`` are the path in flying order (transits, then each lane run from
``lane_start`` to ``lane_end``); its ``runs`` are the lane runs alone. Both passes cover
the same lanes.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

PLAN_FORMAT = "shadowsurvey-plan"
PLAN_FILE = "plan.json"
PLAN_VERSION = 1

#: Waypoint kinds.
KINDS = ("transit", "lane_start", "lane_end")


@dataclass(frozen=True)
class PlanWaypoint:
    """One point of a pass's path (local NED and WGS84)."""

    north_m: float
    east_m: float
    lat_deg: float
    lon_deg: float
    altitude_m: float
    depth_m: float
    kind: str
    lane: int


@dataclass(frozen=True)
class LaneRun:
    """One straight run along a lane, start to end, local NED ``(north_m, east_m)``."""

    lane: int
    start_north_m: float
    start_east_m: float
    end_north_m: float
    end_east_m: float

    @property
    def heading_rad(self) -> float:
        """Compass heading of the run, rad in [0, 2 pi)."""
        return math.atan2(self.end_east_m - self.start_east_m,
                          self.end_north_m - self.start_north_m) % (2 * math.pi)

    @property
    def length_m(self) -> float:
        """Run length, m."""
        return math.hypot(self.end_north_m - self.start_north_m, self.end_east_m - self.start_east_m)


@dataclass(frozen=True)
class SurveyPass:
    """One lawnmower at one altitude and tilt.

    ``near_ground_m``/``far_ground_m`` is the insonified band ahead of the vehicle;
    ``swath_m`` its conservative cross-track width; ``lead_in_m`` how far before the
    first ground to cover each run begins; ``excursion_limit_m`` how far outside the
    outer boundary the path may go (0 with ``--stay-inside``).
    """

    name: str
    altitude_m: float
    depth_m: float
    tilt_rad: float
    near_ground_m: float
    far_ground_m: float
    swath_m: float
    lead_in_m: float
    excursion_limit_m: float
    runs: tuple[LaneRun, ...]
    waypoints: tuple[PlanWaypoint, ...]
    length_m: float
    duration_s: float
    coverage_fraction: float
    uncovered_area_m2: float
    max_excursion_m: float


@dataclass(frozen=True)
class PlanSummary:
    """Figures of the whole survey (both passes)."""

    area_m2: float
    lane_heading_rad: float
    lane_spacing_m: float
    n_lanes: int
    n_runs: int
    total_length_m: float
    total_duration_s: float
    speed_m_s: float
    coverage_fraction: float
    stay_inside: bool
    max_excursion_m: float
    samples_per_cm: float
    height_resolution_m: float
    height_std_from_dh_m: float
    binding_constraints: tuple[str, ...]


@dataclass(frozen=True)
class SurveyPlan:
    """The planned dual-altitude survey. Figures not computed are NaN (null in JSON)."""

    origin_lat_deg: float
    origin_lon_deg: float
    water_depth_m: float
    passes: tuple[SurveyPass, ...]
    summary: PlanSummary

    def to_json(self) -> str:
        """Serialise to JSON text (see :meth:`from_json`)."""
        doc = {"format": PLAN_FORMAT, "version": PLAN_VERSION, **asdict(self)}
        return json.dumps(_nan_to_null(doc), indent=1, allow_nan=False)

    @classmethod
    def from_json(cls, text: str) -> SurveyPlan:
        """Rebuild a plan from :meth:`to_json` text.

        Raises
        ------
        ValueError
            For text that is not a shadowsurvey plan of a known version, or misses fields.
        """
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"plan is not valid JSON: {exc}") from exc
        if not isinstance(doc, dict) or doc.get("format") != PLAN_FORMAT:
            raise ValueError(f"not a shadowsurvey plan (format must be {PLAN_FORMAT!r})")
        if doc.get("version") != PLAN_VERSION:
            raise ValueError(f"unsupported plan version {doc.get('version')!r}; "
                             f"this reader knows {PLAN_VERSION}")
        try:
            passes = tuple(
                _build(SurveyPass, {
                    **p,
                    "runs": tuple(_build(LaneRun, r) for r in p["runs"]),
                    "waypoints": tuple(_build(PlanWaypoint, w) for w in p["waypoints"]),
                })
                for p in doc["passes"]
            )
            summary = _build(PlanSummary, {**doc["summary"], "binding_constraints":
                                           tuple(doc["summary"]["binding_constraints"])})
            return cls(float(doc["origin_lat_deg"]), float(doc["origin_lon_deg"]),
                       float(doc["water_depth_m"]), passes, summary)
        except (KeyError, TypeError) as exc:
            raise ValueError(f"plan JSON misses or mistypes a field: {exc}") from exc


def load_plan(path: str | Path) -> SurveyPlan:
    """Read ``plan.json`` from a file or from the folder ``shadowsurvey plan --out`` wrote.

    Raises
    ------
    ValueError
        For a file that is not a readable shadowsurvey plan (the message names it).
    """
    p = Path(path)
    if p.is_dir():
        p = p / PLAN_FILE
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"{p}: cannot read plan: {exc.strerror}") from exc
    try:
        return SurveyPlan.from_json(text)
    except ValueError as exc:
        raise ValueError(f"{p}: {exc}") from exc


def _nan_to_null(value: Any) -> Any:
    """NaN (a figure not computed) is written as JSON null."""
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, dict):
        return {k: _nan_to_null(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_nan_to_null(v) for v in value]
    return value


def _build(cls: Any, data: dict[str, Any]) -> Any:
    names = {f.name: f.type for f in fields(cls)}
    missing = set(names) - set(data)
    if missing:
        raise KeyError(f"{cls.__name__}.{sorted(missing)[0]}")
    return cls(**{k: math.nan if data[k] is None and t == "float" else data[k]
                  for k, t in names.items()})
