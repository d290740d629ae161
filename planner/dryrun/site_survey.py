"""Survey settings that suit a site's depth: the ``survey.toml`` that ``shadowsurvey site`` writes.

Two presets, each the settings of a shipped scenario that plans and flies, chosen by the
shallowest seabed of the area (docs/own-site.md):

- :data:`NEAR_BOTTOM` below :data:`FIELD_DEPTH_M`: ``paper-targets``' settings, an ARIS
  3000 window of 0.7-3 m, altitudes 0.3-1 m, targets 2-20 cm high: small targets seen
  close to the seabed, narrow swaths. It fits under the surface in water
  :data:`MIN_SITE_DEPTH_M` deep (the upper pass at most 1 m up, 0.5 m below the surface).
- :data:`FIELD` from :data:`FIELD_DEPTH_M` down: ``harbour-field``'s, a 1-8 m window,
  altitudes 1-3 m, targets 2.5-50 cm high: wider swaths for a field-scale site.

The depth itself goes into ``site.water_depth_m`` (the seabed at the origin) and the
vehicle's depth limit (``vehicle.max_depth_m``): the deepest seabed of the area plus
:data:`DEPTH_LIMIT_MARGIN_M`, to be replaced by the vehicle's own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Shallowest seabed a site may have anywhere in its area, m: two passes (the upper at
#: most 1 m up) fit under 0.5 m of water (``vehicle.min_depth_m``) with 0.5 m to spare.
MIN_SITE_DEPTH_M = 2.0
#: Deepest seabed a site may have, m (ArduSub ROVs: a BlueROV2 is rated to 100 m, its
#: deep-rated builds to 300 m).
MAX_SITE_DEPTH_M = 300.0
#: From this shallowest depth on, the field preset, m (harbour-field's floor is at 11.6-12.4 m).
FIELD_DEPTH_M = 8.0
#: The written depth limit lies this far below the area's deepest seabed, m.
DEPTH_LIMIT_MARGIN_M = 3.0


@dataclass(frozen=True)
class SurveyPreset:
    """The depth-independent part of a site's survey settings (lengths in m)."""

    name: str
    based_on: str
    window_start_m: float
    window_end_m: float
    samples_per_beam: int
    min_clearance_m: float
    target_height_min_m: float
    target_height_max_m: float
    altitude_min_m: float
    altitude_max_m: float


NEAR_BOTTOM = SurveyPreset("near-bottom", "paper-targets", window_start_m=0.7, window_end_m=3.0,
                           samples_per_beam=1000, min_clearance_m=0.3, target_height_min_m=0.02,
                           target_height_max_m=0.2, altitude_min_m=0.3, altitude_max_m=1.0)
FIELD = SurveyPreset("field", "harbour-field", window_start_m=1.0, window_end_m=8.0,
                     samples_per_beam=1000, min_clearance_m=0.5, target_height_min_m=0.025,
                     target_height_max_m=0.5, altitude_min_m=1.0, altitude_max_m=3.0)


def toml_line(key: str, value: object, comment: str = "", *, column: int = 34) -> str:
    """``key = value`` (``value`` as TOML: a string is taken as TOML text) with its comment at ``column``."""
    text = value if isinstance(value, str) else repr(value)
    line = f"{key} = {text}"
    return f"{line:<{column - 1}} # {comment}" if comment else line


#: How far the vehicle falls behind a rising seabed in time, s: its altitude filter (whose
#: seabed estimate climbs a slope in steps, planner.mission.onboard) and its depth loop
#: together, with the helm's slope lead. Measured worst: 4.5 s of the rise on a 3 deg test
#: site (11.7 cm below the pass; 5.2 s without the lead), 3 s on harbour-field (2 deg).
SLOPE_FOLLOW_LAG_S = 6.0
#: How closely the vehicle holds a depth on level ground, m (waves, turns).
LEVEL_DEPTH_HOLD_M = 0.05


def depth_hold_for_slope(slope_deg: float, speed_m_s: float) -> float:
    """``vehicle.depth_hold_m`` for a seabed of ``slope_deg`` flown at ``speed_m_s``, m: the
    level hold plus the rise of the seabed over :data:`SLOPE_FOLLOW_LAG_S` (lanes may run
    up the slope), rounded up to the centimetre."""
    rise_m = speed_m_s * math.tan(math.radians(abs(slope_deg))) * SLOPE_FOLLOW_LAG_S
    return math.ceil(100.0 * (LEVEL_DEPTH_HOLD_M + rise_m) - 1e-9) / 100.0


def preset_for(shallowest_m: float) -> SurveyPreset:
    """The preset for a site whose shallowest seabed is ``shallowest_m`` deep."""
    return FIELD if shallowest_m >= FIELD_DEPTH_M else NEAR_BOTTOM


def depth_limit_m(deepest_m: float) -> float:
    """The depth limit written for a site whose deepest seabed is ``deepest_m``, whole metres."""
    return float(math.ceil(deepest_m + DEPTH_LIMIT_MARGIN_M))


def survey_text(preset: SurveyPreset, *, depth_m: float, shallowest_m: float, deepest_m: float,
                slope_deg: float = 0.0) -> str:
    """``survey.toml`` for a site ``depth_m`` deep at its origin (``shallowest_m``..``deepest_m`` over the area)."""
    p = preset
    spread = "flat" if math.isclose(shallowest_m, deepest_m, abs_tol=1e-3) else \
        f"{shallowest_m:.2f}-{deepest_m:.2f} m over the area"
    sample_mm = 1000 * (p.window_end_m - p.window_start_m) / p.samples_per_beam
    limit_note = f"depth limit: the deepest seabed + {DEPTH_LIMIT_MARGIN_M:g} m; give your vehicle's"
    hold_note = "how closely the vehicle holds its altitude" + (
        f" (with a {slope_deg:g} deg slope it trails the rising seabed)" if slope_deg > 0 else "")
    return f"""\
# Survey settings written by `shadowsurvey site` for a site {depth_m:g} m deep ({spread}):
# the {p.name} preset, the settings of the shipped {p.based_on} scenario (docs/own-site.md).
# planner/data/survey.toml documents every key. Degrees only in keys ending in _deg.
version = 1

[sonar]
beam_table = "ARIS3000_128"       # or fan_width_deg = 30.0 for another sonar (not both)
elevation_aperture_deg = 14.0     # full vertical opening
{toml_line("window_start_m", p.window_start_m, "first slant range of the range window")}
{toml_line("window_end_m", p.window_end_m, "last slant range of the range window")}
{toml_line("samples_per_beam", p.samples_per_beam, f"samples over the window ({sample_mm:.1f} mm each)")}

[vehicle]
speed_m_s = 0.5                   # survey speed through the water
turn_radius_m = 0.0               # 0 = the ROV stops and turns in place
yaw_rate_deg_s = 30.0
{toml_line("max_depth_m", depth_limit_m(deepest_m), limit_note)}
min_depth_m = 0.5                 # keep at least this far below the surface
{toml_line("min_clearance_m", p.min_clearance_m, "kept above the tallest expected target")}
{toml_line("depth_hold_m", depth_hold_for_slope(slope_deg, 0.5), hold_note)}

[site]
{toml_line("water_depth_m", depth_m, "expected seabed depth (at the scene's origin)")}
{toml_line("target_height_min_m", p.target_height_min_m, "smallest target height to resolve")}
{toml_line("target_height_max_m", p.target_height_max_m, "tallest expected target")}

[survey]
overlap = 0.2                     # fraction of the narrower swath shared by neighbours
lane_heading_deg = "auto"         # compass heading of the lanes, or "auto" (shortest)
obstacle_margin_m = 0.5           # runs and transits keep this far from holes and keep-outs
edge_loss_budget = 0.004          # area fraction that may go unseen at obstacle edges

[altitudes]
{toml_line("altitude_min_m", p.altitude_min_m, "lowest altitude above the seabed to consider")}
{toml_line("altitude_max_m", p.altitude_max_m, "highest altitude above the seabed to consider")}
filter_dh_std_m = 0.003           # altitude filter's standard deviation of dH
dh_min_over_std = 30.0            # dH must be at least this many filter std
shadow_margin_m = 0.05            # slant margin keeping the shadow inside beam and window
min_pass_samples_per_cm = 1.0     # each pass alone: shadow length change per cm of height

[mission]
altitude_reference = "seabed"     # "seabed": terrain-frame items; "depth": depth items
acceptance_radius_m = 0.25
"""
