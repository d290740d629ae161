"""A dry-run scenario for a user's own site: the files ``shadowsurvey site`` writes.

From a survey area and the seabed's depth (and slope) this builds the text of a scenario
folder (docs/own-site.md) that plans and flies as written: ``scene.toml`` (the origin, the
seabed with a sediment texture, example targets commented out, a viewpoint and the sonar
window), ``survey.toml`` (:mod:`planner.dryrun.site_survey`) and ``scenario.toml`` (the
vehicle starting :data:`START_OFFSET_M` south of the area); ``area.geojson`` is the
user's own file, copied as it is.

The origin of the local frame is the area's own: the centre of the boundary's bounding
box for a WGS84 area (the origin ``shadowsurvey plan`` picks for it), its
``local_origin`` for an area in local metres, so plans made with and without the scenario
share one frame. Everything is computed here; nothing is written (the command writes).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import shapely

from planner.dryrun.scenario import MAX_START_OFFSET_M
from planner.dryrun.site_survey import (
    MAX_SITE_DEPTH_M,
    MIN_SITE_DEPTH_M,
    NEAR_BOTTOM,
    SurveyPreset,
    preset_for,
    survey_text,
    toml_line,
)
from planner.errors import UsageError
from planner.survey.area import SurveyArea
from sim_harness.world.world import Seabed

#: The vehicle starts this far south of the area's southernmost point, m.
START_OFFSET_M = 2.0
#: Steepest seabed slope a site may have, deg: the altitude and tilt choice assumes a flat
#: seabed (harbour-field flies 2 deg; the simulator itself takes up to 45).
MAX_SITE_SLOPE_DEG = 10.0

#: Example targets by preset, written commented out: (id, shape, sizes, yaw_deg, material).
_EXAMPLES: dict[str, tuple[tuple[str, str, dict[str, float], float, str], ...]] = {
    "near-bottom": (
        ("BLOCK", "box", {"length_m": 0.19, "width_m": 0.19, "height_m": 0.028}, 45.0, "concrete"),
        ("CAN", "cylinder", {"diameter_m": 0.15, "height_m": 0.20}, 0.0, "metal"),
        ("STONE", "stone", {"length_m": 0.30, "width_m": 0.25, "height_m": 0.15}, -20.0, "rock"),
        ("PIPE", "pipe", {"length_m": 0.80, "diameter_m": 0.10}, 70.0, "metal"),
    ),
    "field": (
        ("BLOCK", "box", {"length_m": 0.80, "width_m": 0.80, "height_m": 0.40}, 15.0, "concrete"),
        ("TYRE", "cylinder", {"diameter_m": 0.62, "height_m": 0.20}, 0.0, "rubber"),
        ("ROCK", "rock", {"length_m": 0.60, "width_m": 0.45, "height_m": 0.35}, 0.0, "rock"),
        ("PIPE", "pipe", {"length_m": 2.40, "diameter_m": 0.30}, 70.0, "metal"),
    ),
}
#: The lines that open and close the commented example targets in scene.toml.
EXAMPLES_BEGIN = "# --- example targets: uncomment, move and resize them (one [[targets]] table each)"
EXAMPLES_END = "# --- end of the example targets"


@dataclass(frozen=True)
class SiteSpec:
    """A user's site: the area, the seabed depth at the origin and its slope (degrees at this edge)."""

    name: str
    area: SurveyArea
    depth_m: float
    slope_deg: float = 0.0
    slope_direction_deg: float = 0.0

    @property
    def seabed(self) -> Seabed:
        """The seabed plane as the simulator builds it from the scene."""
        return Seabed(self.depth_m, math.radians(self.slope_deg), math.radians(self.slope_direction_deg))

    def seabed_range_m(self) -> tuple[float, float]:
        """Shallowest and deepest seabed over the area, m (a plane: at the boundary's vertices)."""
        east, north = np.asarray(self.area.outer.exterior.coords).T
        depths = [self.seabed.plane_depth_m(float(n), float(e)) for n, e in zip(north, east, strict=True)]
        return min(depths), max(depths)

    @property
    def preset(self) -> SurveyPreset:
        """The survey preset suiting the site's shallowest seabed."""
        return preset_for(self.seabed_range_m()[0])

    def start_m(self) -> tuple[float, float]:
        """The vehicle's start (north, east), m: :data:`START_OFFSET_M` south of the area, mid-way across."""
        west, south, east, _ = self.area.outer.bounds
        return south - START_OFFSET_M, (west + east) / 2


def check_site(spec: SiteSpec) -> None:
    """Refuse a site the dry run cannot fly, naming the option to change.

    Raises
    ------
    UsageError
        When the seabed leaves :data:`MIN_SITE_DEPTH_M`..:data:`MAX_SITE_DEPTH_M` somewhere
        in the area (a slope too steep for its size), or the vehicle's start would lie
        beyond ``MAX_START_OFFSET_M`` north or east of the origin (an area too large).
    """
    shallowest, deepest = spec.seabed_range_m()
    if shallowest < MIN_SITE_DEPTH_M or deepest > MAX_SITE_DEPTH_M:
        option = "--slope-deg" if spec.slope_deg > 0 else "--depth-m"
        raise UsageError(f"{option}: a {spec.slope_deg:g} deg slope deepening toward {spec.slope_direction_deg:g} deg "
                         f"puts the seabed {shallowest:.2f} m to {deepest:.2f} m deep over the area; a dry-run site "
                         f"must be {MIN_SITE_DEPTH_M:g}-{MAX_SITE_DEPTH_M:g} m deep everywhere (a gentler slope or a "
                         "smaller area)")
    north, east = spec.start_m()
    if max(abs(north), abs(east)) > MAX_START_OFFSET_M:
        raise UsageError(f"--area: the dry run's vehicle would start {START_OFFSET_M:g} m south of the area, at north "
                         f"{north:.0f} m, east {east:.0f} m of its origin; the start must lie within "
                         f"{MAX_START_OFFSET_M:g} m of the origin: survey a smaller site")


def _num(value: float, digits: int = 3) -> str:
    """A TOML float with at most ``digits`` decimals (never ``-0.0``)."""
    return repr(round(value, digits) + 0.0)


def _example_spots(area: SurveyArea, n: int) -> list[tuple[float, float]]:
    """``n`` (north, east) places inside the ground to cover, for the example targets."""
    region = area.coverage_region
    west, south, east, north = area.outer.bounds
    spots = []
    for fn, fe in ((0.25, 0.25), (0.5, 0.75), (0.75, 0.3), (0.6, 0.55), (0.3, 0.7), (0.5, 0.5)):
        n_m, e_m = south + fn * (north - south), west + fe * (east - west)
        if region.contains(shapely.Point(e_m, n_m)):
            spots.append((n_m, e_m))
    inside = region.representative_point()
    while len(spots) < n:
        spots.append((inside.y, inside.x))
    return spots[:n]


def _example_lines(spec: SiteSpec) -> list[str]:
    examples = _EXAMPLES.get(spec.preset.name, _EXAMPLES[NEAR_BOTTOM.name])
    lines = [EXAMPLES_BEGIN,
             "# Place each by north_m/east_m (metres from [origin]) or by lat_deg/lon_deg (WGS84), one pair,",
             "# inside the area. Shapes: box, cylinder (diameter_m), stone, rock (seed shapes it), pipe (lying",
             "# along yaw_deg: length_m, diameter_m). Materials: mud, sand, gravel, rock, concrete, brick,",
             "# wood, plastic, rubber, glass, metal."]
    for k, ((target_id, shape, sizes, yaw_deg, material), (north, east)) in enumerate(
            zip(examples, _example_spots(spec.area, len(examples)), strict=True)):
        lines += ["#", "# [[targets]]", f'# id = "{target_id}"', f'# shape = "{shape}"']
        if k == 1:  # one example placed geographically
            lat, lon = spec.area.origin.to_lat_lon(north, east)
            lines += [f"# lat_deg = {float(lat):.9f}", f"# lon_deg = {float(lon):.9f}"]
        else:
            lines += [f"# north_m = {_num(north, 2)}", f"# east_m = {_num(east, 2)}"]
        lines += [f"# {key} = {value!r}" for key, value in sizes.items()]
        if yaw_deg:
            lines.append(f"# yaw_deg = {yaw_deg!r}")
        if shape == "rock":
            lines.append("# seed = 1")
        lines.append(f'# material = "{material}"')
    return [*lines, EXAMPLES_END]


def scene_text(spec: SiteSpec) -> str:
    """``scene.toml``: the origin, the seabed, example targets (commented out), viewpoint, sonar window."""
    preset = spec.preset
    west, south, east, north = spec.area.outer.bounds
    shallowest, deepest = spec.seabed_range_m()
    start_north, start_east = spec.start_m()
    origin = spec.area.origin
    name = json.dumps(spec.name, ensure_ascii=False)
    lines = [
        f"# {spec.name}: the simulated world of your site, written by `shadowsurvey site` (docs/own-site.md).",
        "# Local frame: north_m/east_m are metres from [origin], the area's own origin; the area spans",
        f"# north {south:.1f}..{north:.1f} m and east {west:.1f}..{east:.1f} m of it. Add your targets below.",
        f"name = {name}",
        f'description = "{spec.depth_m:g} m deep, {shallowest:.2f}-{deepest:.2f} m over the area."',
        "",
        "[origin]                          # WGS84 degrees of the local origin (the area's, see above)",
        f"lat_deg = {origin.lat_deg:.9f}",
        f"lon_deg = {origin.lon_deg:.9f}",
        "",
        "[seabed]",
        toml_line("depth_m", spec.depth_m, "seabed depth at the origin, m"),
        toml_line("slope_deg", spec.slope_deg, f"0..45 deg (shadowsurvey site: 0..{MAX_SITE_SLOPE_DEG:g})"),
        toml_line("slope_direction_deg", spec.slope_direction_deg, "compass direction in which the seabed deepens"),
        'material = "sand"                 # mud, sand, gravel, rock, ... (see the example targets)',
        "texture_db = 3.0                  # persistent sediment texture, std in dB (0: a uniform seabed)",
        "texture_scale_m = 0.1             # its correlation length, m",
        "texture_seed = 1",
        "# relief = { amplitude_m = 0.03, wavelength_m = 6.0, seed = 1, components = 6 }   # low relief",
        "",
        *_example_lines(spec),
        "",
        "[viewpoint]                       # where `shadowsurvey render` looks from (the vehicle's start)",
        f"north_m = {_num(start_north, 2)}",
        f"east_m = {_num(start_east, 2)}",
        "heading_deg = 0.0",
        f"altitude_m = {_num((preset.altitude_min_m + preset.altitude_max_m) / 2, 2)}",
        "",
        "[sonar]                           # `render`'s window; the dry run takes survey.toml's",
        f"window_start_m = {preset.window_start_m!r}",
        f"window_length_m = {_num(preset.window_end_m - preset.window_start_m)}",
        f"samples_per_beam = {preset.samples_per_beam}",
        "sound_speed_m_s = 1500.0",
    ]
    return "\n".join(lines) + "\n"


def site_survey_text(spec: SiteSpec) -> str:
    """``survey.toml`` suiting the site's depth (:mod:`planner.dryrun.site_survey`)."""
    shallowest, deepest = spec.seabed_range_m()
    return survey_text(spec.preset, depth_m=spec.depth_m, shallowest_m=shallowest, deepest_m=deepest,
                       slope_deg=spec.slope_deg)


def scenario_text(spec: SiteSpec) -> str:
    """``scenario.toml``: the files, the vehicle's start south of the area, calm sea, no faults."""
    north, east = spec.start_m()
    name = json.dumps(spec.name, ensure_ascii=False)
    return f"""\
# {spec.name}: a dry run of your own site, written by `shadowsurvey site` (docs/own-site.md).
# Fly it with `shadowsurvey sim <this folder> --out runs/<name>`; docs/scenario-format.md has every key.
name = {name}
description = {json.dumps(f"A dry run of the site {spec.name}, {spec.depth_m:g} m deep.", ensure_ascii=False)}
scene = "scene.toml"       # the world: origin, seabed, targets
area = "area.geojson"      # the survey area (your file, as given)
survey = "survey.toml"     # the survey settings, chosen for the depth

[vehicle]
{toml_line("start_north_m", _num(north, 2), f"{START_OFFSET_M:g} m south of the area, local NED m about the origin",
           column=27)}
start_east_m = {_num(east, 2)}
start_heading_deg = 0.0
seed = 1

[executor]
pitch_loop = true          # closed pitch loop on the mount (false: the plan's fixed tilt)
link_lost_action = "surface"
finish_action = "surface"
abort_action = "hold"

[current]                  # a uniform water current, m/s
north_m_s = 0.0
east_m_s = 0.0

[attitude]                 # the vehicle's pitch and roll disturbance (the simulator's defaults)
pitch_bias_deg = 0.0
pitch_amplitude_deg = 1.5
pitch_period_s = 6.0
roll_amplitude_deg = 1.0
roll_period_s = 4.5

[faults]                   # none until the nominal dive completes

[sensors]
dvl_bias_walk_m_s = 0.0001 # DVL velocity-bias random walk per sqrt(s): navigation drift
"""
