"""A scenario's files agree with one another: the area near the vehicle, every target inside it.

Each file of a scenario is checked by its own reader (the scene, the area, the settings,
scenario.toml); what no single reader can see is checked here, once they are loaded and
before anything is flown or written (``shadowsurvey sim``):

- the survey area lies within :data:`MAX_TRANSIT_M` of the vehicle's start (which lies
  within 1 km of the scene's origin): an area farther away is a wrong ``[origin]`` or
  wrong coordinates in the area, not a site (a dry run would transit for hours at the
  survey speed);
- every target of the scene lies inside the area's boundary (a hole or keep-out is
  inside: a modelled obstacle stands in one): a target outside is never surveyed.

Each refusal is a :class:`~planner.errors.ConfigError` naming the scene file and its key.
"""

from __future__ import annotations

import math

import shapely

from planner.dryrun.dive import PreparedDive
from planner.errors import ConfigError

#: Farthest the survey area may lie from the vehicle's start, m (1 km: over half an hour's
#: transit at 0.5 m/s).
MAX_TRANSIT_M = 1000.0
#: A target this close outside the boundary counts as on it, m (rounding of coordinates).
ON_BOUNDARY_M = 1e-3


def check_consistent(prepared: PreparedDive) -> None:
    """Refuse a scenario whose area and scene do not agree (see the module docstring).

    Raises
    ------
    ConfigError
        Naming the scene file and ``origin`` (the area far from the start) or
        ``targets[i]`` (a target outside the area).
    """
    scenario, area = prepared.scenario, prepared.area
    scene_path, area_path = str(scenario.scene_path), str(scenario.area_path)
    outer = area.outer
    start = shapely.Point(scenario.start_east_m, scenario.start_north_m)
    far = outer.distance(start)
    if far > MAX_TRANSIT_M:
        raise ConfigError(f"the survey area {area_path} lies {far / 1000:.1f} km from the vehicle's start, about this "
                          f"origin ({prepared.origin.lat_deg:.7f}, {prepared.origin.lon_deg:.7f}); a dry-run site "
                          f"lies within {MAX_TRANSIT_M / 1000:g} km of it: check [origin] against the area's "
                          "coordinates", key="origin", path=scene_path)
    for i, target in enumerate(prepared.scene.world.targets):
        off = outer.distance(shapely.Point(target.east_m, target.north_m))
        if off > ON_BOUNDARY_M:
            raise ConfigError(f"target {target.target_id!r} at north {target.north_m:.2f} m, east {target.east_m:.2f} "
                              f"m lies {_distance_text(off)} outside the survey area {area_path}; the survey never "
                              "sees it: move it inside or widen the area", key=f"targets[{i}]", path=scene_path)


def _distance_text(metres: float) -> str:
    return f"{metres / 1000:.1f} km" if metres >= 1000 else f"{metres:.2f} m" if math.isfinite(metres) else "far"
