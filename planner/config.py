"""Survey settings: one TOML file, validated once, returned as frozen dataclasses.

The file has a ``version`` and the tables ``[sonar]``, ``[vehicle]``, ``[site]``,
``[survey]``, ``[altitudes]`` and ``[mission]``; the shipped defaults are
``planner/data/survey.toml`` and every key is described there. Degrees appear only in
the file (keys ending in ``_deg``); the dataclasses hold radians. Unknown keys, missing
keys, wrong types and out-of-range values raise :class:`planner.errors.ConfigError`
naming the key (``"vehicle.speed_m_s"``) and the file.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from perception.sonar_io.beams import TABLES, load_beam_table
from planner.errors import ConfigError
from planner.settings_table import SettingsTable as _Table

SETTINGS_VERSION = 1
#: Largest slant range, altitude or range window a setting may give, m (forward-looking
#: sonars see tens of metres; this catches unit slips).
MAX_RANGE_M = 1000.0
#: Deepest depth a setting may give, m (the deepest ocean).
MAX_DEPTH_M = 11_000.0


@dataclass(frozen=True)
class SonarSettings:
    """The forward-looking sonar: fan, vertical aperture, range window and sampling."""

    fan_width_rad: float
    elevation_aperture_rad: float
    window_start_m: float
    window_end_m: float
    samples_per_beam: int
    beam_table: str | None

    @property
    def range_resolution_m(self) -> float:
        """Slant-range length of one sample, m."""
        return (self.window_end_m - self.window_start_m) / self.samples_per_beam


@dataclass(frozen=True)
class VehicleSettings:
    """The ROV: speed, turning, depth limit, clearance and mount tilt limits.

    ``depth_hold_m`` is how closely the vehicle holds a commanded depth (its depth
    controller's error in waves and turns, m): the planner keeps the lower pass this far
    above the lowest allowed altitude (:attr:`Settings.min_altitude_m`), so holding the
    pass never takes it below the clearance.
    """

    speed_m_s: float
    turn_radius_m: float
    yaw_rate_rad_s: float
    max_depth_m: float
    min_depth_m: float
    min_clearance_m: float
    tilt_min_rad: float
    tilt_max_rad: float
    depth_hold_m: float = 0.05


@dataclass(frozen=True)
class SiteSettings:
    """What is expected on site: water depth and the target heights to resolve."""

    water_depth_m: float
    target_height_min_m: float
    target_height_max_m: float


@dataclass(frozen=True)
class SurveySettings:
    """Lane layout: overlap between neighbouring swaths and the lane heading.

    ``lane_heading_rad`` is ``None`` when the heading is to be chosen for the shortest
    survey. ``obstacle_margin_m`` is the distance runs and transits keep from holes and
    keep-outs. ``edge_loss_budget`` is the fraction of the area that may be left unseen
    along obstacle edges to save transits (a run leaving an obstacle cannot see the
    ground just past it).
    """

    overlap: float
    lane_heading_rad: float | None
    obstacle_margin_m: float
    edge_loss_budget: float


@dataclass(frozen=True)
class AltitudeSettings:
    """Bounds and margins for the choice of the two altitudes and tilts."""

    altitude_min_m: float
    altitude_max_m: float
    filter_dh_std_m: float
    dh_min_over_std: float
    shadow_margin_m: float
    min_pass_samples_per_cm: float


@dataclass(frozen=True)
class MissionSettings:
    """How mission files express altitude: ``"seabed"`` (terrain frame) or ``"depth"``."""

    altitude_reference: str
    acceptance_radius_m: float


@dataclass(frozen=True)
class Settings:
    """All survey settings, validated."""

    sonar: SonarSettings
    vehicle: VehicleSettings
    site: SiteSettings
    survey: SurveySettings
    altitudes: AltitudeSettings
    mission: MissionSettings
    source: str = "<defaults>"

    @property
    def min_altitude_m(self) -> float:
        """The lowest altitude above the seabed the vehicle may fly, m: ``vehicle.min_clearance_m``
        above the tallest expected target (``site.target_height_max_m``).

        The clearance means this one thing everywhere: the planner keeps the lower pass at
        or above it, the safety envelope (:mod:`planner.mission.safety`) never commands a
        depth below it (plus 3 sigma of the seabed estimate), the altitude warnings
        (:mod:`planner.mission.altitude_watch`) flag any excursion below it.
        """
        return self.site.target_height_max_m + self.vehicle.min_clearance_m


def _table(root: dict[str, Any], name: str, path: str | None) -> _Table:
    value = root.get(name)
    if value is None:
        raise ConfigError("missing table", key=name, path=path)
    return _Table(value, name, path)


def _sonar(t: _Table) -> SonarSettings:
    table_name: str | None = None
    if t.has("beam_table") and t.has("fan_width_deg"):
        raise t.error("fan_width_deg", "give either beam_table or fan_width_deg, not both")
    if t.has("fan_width_deg"):
        fan = math.radians(t.number("fan_width_deg", lo=0.0, hi=120.0, lo_open=True))
    else:
        table_name = t.string("beam_table", TABLES)
        fan = load_beam_table(table_name).fan_width_rad
    aperture = math.radians(t.number("elevation_aperture_deg", lo=0.0, hi=90.0, lo_open=True))
    start = t.number("window_start_m", lo=0.0, hi=MAX_RANGE_M)
    end = t.number("window_end_m", lo=0.0, hi=MAX_RANGE_M, lo_open=True)
    if end <= start:
        raise t.error("window_end_m", f"must exceed window_start_m ({start:g} m), got {end:g}")
    samples = t.number("samples_per_beam", lo=2.0, hi=100000.0)
    if samples != int(samples):
        raise t.error("samples_per_beam", f"must be a whole number, got {samples:g}")
    t.finish()
    return SonarSettings(fan, aperture, start, end, int(samples), table_name)


def _vehicle(t: _Table) -> VehicleSettings:
    speed = t.number("speed_m_s", lo=0.0, hi=10.0, lo_open=True)
    radius = t.number("turn_radius_m", lo=0.0, hi=1000.0, default=0.0)
    yaw_rate = math.radians(t.number("yaw_rate_deg_s", lo=0.0, hi=360.0, lo_open=True,
                                     default=30.0))
    max_depth = t.number("max_depth_m", lo=0.0, hi=MAX_DEPTH_M, lo_open=True)
    min_depth = t.number("min_depth_m", lo=0.0, hi=MAX_DEPTH_M, default=0.5)
    if min_depth >= max_depth:
        raise t.error("min_depth_m", f"must be below max_depth_m ({max_depth:g}), got {min_depth:g}")
    clearance = t.number("min_clearance_m", lo=0.0, hi=100.0, lo_open=True)
    tilt_min = t.number("tilt_min_deg", lo=-90.0, hi=90.0, default=0.0)
    tilt_max = t.number("tilt_max_deg", lo=-90.0, hi=90.0, default=60.0)
    if tilt_max <= tilt_min:
        raise t.error("tilt_max_deg", f"must exceed tilt_min_deg ({tilt_min:g}), got {tilt_max:g}")
    hold = t.number("depth_hold_m", lo=0.0, hi=10.0, default=0.05)
    t.finish()
    return VehicleSettings(speed, radius, yaw_rate, max_depth, min_depth, clearance,
                           math.radians(tilt_min), math.radians(tilt_max), hold)


def _site(t: _Table) -> SiteSettings:
    depth = t.number("water_depth_m", lo=0.0, hi=MAX_DEPTH_M, lo_open=True)
    h_min = t.number("target_height_min_m", lo=0.0, hi=100.0, lo_open=True)
    h_max = t.number("target_height_max_m", lo=0.0, hi=100.0, lo_open=True)
    if h_max < h_min:
        raise t.error("target_height_max_m",
                      f"must be >= target_height_min_m ({h_min:g}), got {h_max:g}")
    if h_max >= depth:
        raise t.error("target_height_max_m", f"must be below water_depth_m ({depth:g}), got {h_max:g}")
    t.finish()
    return SiteSettings(depth, h_min, h_max)


def _survey(t: _Table) -> SurveySettings:
    overlap = t.number("overlap", lo=0.0, hi=0.9)
    heading: float | None = None
    t.used.add("lane_heading_deg")
    raw = t.data.get("lane_heading_deg", "auto")
    if raw != "auto":
        heading = math.radians(t.number("lane_heading_deg", lo=-360.0, hi=360.0)) % math.pi
    margin = t.number("obstacle_margin_m", lo=0.0, hi=1000.0, lo_open=True, default=1.0)
    budget = t.number("edge_loss_budget", lo=0.0, hi=0.5, default=0.004)
    t.finish()
    return SurveySettings(overlap, heading, margin, budget)


def _altitudes(t: _Table) -> AltitudeSettings:
    a_min = t.number("altitude_min_m", lo=0.0, hi=MAX_RANGE_M, lo_open=True, default=0.3)
    a_max = t.number("altitude_max_m", lo=0.0, hi=MAX_RANGE_M, lo_open=True)
    if a_max <= a_min:
        raise t.error("altitude_max_m", f"must exceed altitude_min_m ({a_min:g}), got {a_max:g}")
    std = t.number("filter_dh_std_m", lo=0.0, hi=10.0, lo_open=True)
    ratio = t.number("dh_min_over_std", lo=1.0, hi=1e6)
    margin = t.number("shadow_margin_m", lo=0.0, hi=100.0, default=0.05)
    min_samples = t.number("min_pass_samples_per_cm", lo=0.0, hi=1e4, default=1.0)
    t.finish()
    return AltitudeSettings(a_min, a_max, std, ratio, margin, min_samples)


def _mission(t: _Table) -> MissionSettings:
    ref = t.string("altitude_reference", ("seabed", "depth"), default="seabed")
    radius = t.number("acceptance_radius_m", lo=0.0, hi=1000.0, lo_open=True, default=1.0)
    t.finish()
    return MissionSettings(ref, radius)


def parse_settings(data: dict[str, Any], *, path: str | None = None) -> Settings:
    """Validate a parsed TOML document and build :class:`Settings`.

    Raises
    ------
    ConfigError
        Naming the first offending key, for any missing, unknown, mistyped or
        out-of-range setting.
    """
    version = data.get("version")
    if version != SETTINGS_VERSION:
        raise ConfigError(f"must be {SETTINGS_VERSION}, got {version!r}", key="version", path=path)
    known = {"version", "sonar", "vehicle", "site", "survey", "altitudes", "mission"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ConfigError("unknown table or key (check the spelling)", key=unknown[0], path=path)
    mission = data.get("mission", {})
    if not isinstance(mission, dict):
        raise ConfigError("must be a table", key="mission", path=path)
    return Settings(
        sonar=_sonar(_table(data, "sonar", path)),
        vehicle=_vehicle(_table(data, "vehicle", path)),
        site=_site(_table(data, "site", path)),
        survey=_survey(_table(data, "survey", path)),
        altitudes=_altitudes(_table(data, "altitudes", path)),
        mission=_mission(_Table(mission, "mission", path)),
        source=path or "<string>",
    )


def parse_settings_text(text: str, *, path: str | None = None) -> Settings:
    """Parse TOML text and validate it (see :func:`parse_settings`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", path=path) from exc
    except RecursionError:
        raise ConfigError("not valid TOML: nested too deeply", path=path) from None
    return parse_settings(data, path=path)


def load_settings(path: str | Path) -> Settings:
    """Read and validate a settings file.

    Raises
    ------
    ConfigError
        For a missing or unreadable file or any invalid setting.
    """
    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read settings file: {exc.strerror or exc}", path=str(p)) from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"not UTF-8 text ({exc.reason} at byte {exc.start})", path=str(p)) from None
    return parse_settings_text(text, path=str(p))


def default_settings_text() -> str:
    """The shipped ``survey.toml`` as text."""
    return resources.files("planner").joinpath("data", "survey.toml").read_text(encoding="utf-8")


def default_settings() -> Settings:
    """The shipped defaults, validated."""
    return parse_settings_text(default_settings_text(), path="planner/data/survey.toml")
