"""One frame's detection of a target and where it lies on the seabed (one frame's geometry).

With pose (the frame's ``north_m``, ``east_m``, ``heading_rad`` and altitude), a target's
seabed CENTRE is estimated from one frame (flat seabed, bearing ``heading + azimuth``):

- the far top edge lies at ground distance ``g_top = r_top * g_end / r_end`` with
  ``g_end = sqrt(r_end^2 - H^2)`` (the top edge and the shadow end share a ray), and the
  frame's own height guess is ``h = H (1 - g_top / g_end)``;
- the near face (the highlight's start, slant range ``r_hl``) lies at
  ``g_near = sqrt(r_hl^2 - (H - h)^2)``;
- the centre is ``(g_near + g_top) / 2``. Without a shadow edge (a cut shadow), the centre
  is guessed ``default_half_length_m`` beyond the near face and the gate is widened.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from perception.shadows.measurement.measure import ShadowMeasurement
from perception.tracking.config import TrackingConfig


@dataclass(frozen=True)
class Detection:
    """One measured shadow in one frame, with what the frame knew about its pose.

    Attributes
    ----------
    frame_index : int
        Order of the frame in the pipeline (0 = first).
    measurement : ShadowMeasurement
    altitude_m : float
        The frame's altitude above the seabed, m; NaN when unknown.
    delta_h_m : float
        The frame's altitude minus the first frame's, m; NaN when unknown.
    north_m, east_m : float
        Seabed position of the target's far top edge in local NED, m; NaN without pose.
        For a cut shadow it may be carried over from an earlier frame (``top_frame_index``).
    centre_north_m, centre_east_m : float
        Estimated seabed position of the target's centre in local NED, m; NaN when not
        estimated (the tracker then uses ``north_m``, ``east_m``).
    gate_m : float
        Position gate of this detection, m; NaN: from the config's ``position_gate_m``.
    height_guess_m : float
        The target's height from this frame alone, m; NaN when unknown.
    top_frame_index : int
        The frame whose measurement gave ``north_m``, ``east_m`` (-1: this frame's own).
    top_slope_db_per_m : float
        Slope of the echo (dB per metre of range) just before the shadow start, over the
        measured beams; NaN when not measured. Near 0 for a sharp far top edge, clearly
        negative for a rounded top whose echo fades towards its grazing point
        (:func:`perception.heights.pipeline.top_echo_slope_db_per_m`).
    depression_rad : float
        Depression of the sonar's axis below the horizontal (tilt minus pitch) as the frame
        reports it, rad; NaN when unknown.
    sonar_north_m, sonar_east_m, heading_rad : float
        The frame's sonar position (local NED, m) and heading (rad); NaN when unknown.
    """

    frame_index: int
    measurement: ShadowMeasurement
    altitude_m: float = math.nan
    delta_h_m: float = math.nan
    north_m: float = math.nan
    east_m: float = math.nan
    centre_north_m: float = math.nan
    centre_east_m: float = math.nan
    gate_m: float = math.nan
    height_guess_m: float = math.nan
    top_frame_index: int = -1
    top_slope_db_per_m: float = math.nan
    depression_rad: float = math.nan
    sonar_north_m: float = math.nan
    sonar_east_m: float = math.nan
    heading_rad: float = math.nan

    @property
    def has_position(self) -> bool:
        """True when the seabed position of the far top edge (``north_m``, ``east_m``) is known."""
        return math.isfinite(self.north_m) and math.isfinite(self.east_m)

    @property
    def is_placed(self) -> bool:
        """True when :attr:`position_m` (centre or far top edge) is known."""
        return all(math.isfinite(v) for v in self.position_m)

    @property
    def position_m(self) -> tuple[float, float]:
        """(north, east) used for association, m: the centre when known, else the top edge."""
        if math.isfinite(self.centre_north_m) and math.isfinite(self.centre_east_m):
            return self.centre_north_m, self.centre_east_m
        return self.north_m, self.east_m


def seabed_position(
    measurement: ShadowMeasurement,
    *,
    altitude_m: float,
    north_m: float,
    east_m: float,
    heading_rad: float,
) -> tuple[float, float]:
    """Local NED (north, east) of a target's far top edge, m; NaNs when not computable.

    Uses one frame's geometry (flat seabed): ``g_top = r_top sqrt(r_end^2 - H^2) / r_end``
    along the bearing ``heading + azimuth`` (the small change of bearing with tilt is
    neglected; the tracker's gate absorbs it).
    """
    values = (measurement.r_top_m, measurement.r_end_m, altitude_m, north_m, east_m, heading_rad)
    if not all(math.isfinite(v) for v in values) or measurement.r_end_m <= altitude_m:
        return math.nan, math.nan
    ground_end = math.sqrt(measurement.r_end_m**2 - altitude_m**2)
    ground_top = measurement.r_top_m * ground_end / measurement.r_end_m
    bearing = heading_rad + measurement.azimuth_rad
    return north_m + ground_top * math.cos(bearing), east_m + ground_top * math.sin(bearing)


@dataclass(frozen=True)
class CentreEstimate:
    """A target's centre from one frame (see the module docstring).

    Attributes
    ----------
    north_m, east_m : float
        Local NED position of the centre, m; NaN when not computable.
    height_guess_m : float
        Height from this frame alone, m; NaN unless the shadow is complete (``usable``).
    gate_m : float
        Position gate for this detection, m.
    """

    north_m: float
    east_m: float
    height_guess_m: float
    gate_m: float


def seabed_centre(
    measurement: ShadowMeasurement,
    *,
    altitude_m: float,
    north_m: float,
    east_m: float,
    heading_rad: float,
    config: TrackingConfig | None = None,
) -> CentreEstimate:
    """The target's seabed centre, its one-frame height and its gate (module docstring)."""
    cfg = config or TrackingConfig()
    m, alt = measurement, altitude_m
    nan = CentreEstimate(math.nan, math.nan, math.nan, math.nan)
    if not all(math.isfinite(v) for v in (alt, north_m, east_m, heading_rad)) or alt <= 0:
        return nan
    height = math.nan
    ground_top = math.nan
    if math.isfinite(m.r_top_m) and math.isfinite(m.r_end_m) and m.r_end_m > alt:
        ground_end = math.sqrt(m.r_end_m**2 - alt**2)
        ground_top = m.r_top_m * ground_end / m.r_end_m
        height = min(max(alt * (1.0 - ground_top / ground_end), 0.0), alt)
    lift = height if math.isfinite(height) else 0.0
    if not m.usable:  # a cut shadow's edges place the target but do not give its height
        height = math.nan
    slant = m.highlight_range_m if math.isfinite(m.highlight_range_m) else m.r_top_m
    ground_near = math.nan
    if math.isfinite(m.highlight_range_m) and m.highlight_range_m > alt - lift:
        ground_near = math.sqrt(m.highlight_range_m**2 - (alt - lift) ** 2)
    gate = cfg.position_gate_m + cfg.position_gate_per_range * slant + cfg.position_gate_per_altitude * alt
    if math.isfinite(ground_top) and math.isfinite(ground_near) and ground_near <= ground_top:
        ground = 0.5 * (ground_near + ground_top)
    elif math.isfinite(ground_near):
        ground = ground_near + cfg.default_half_length_m
        gate += cfg.highlight_only_extra_gate_m
    elif math.isfinite(ground_top):
        ground = ground_top - cfg.default_half_length_m
        gate += cfg.highlight_only_extra_gate_m
    else:
        return nan
    bearing = heading_rad + m.azimuth_rad
    return CentreEstimate(
        north_m + ground * math.cos(bearing), east_m + ground * math.sin(bearing), height, gate
    )
