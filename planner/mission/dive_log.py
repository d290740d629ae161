"""The dive's time series in the run folder: ``nav.csv``, ``filter.csv``, ``tilt.csv``."""

from __future__ import annotations

import math

from planner.mission.onboard import OnboardPerception
from planner.mission.run_folder import RunFolder


class DiveLog:
    """One row of each series per control cycle."""

    def __init__(self, run: RunFolder) -> None:
        self._nav = run.series("nav.csv", ("t_s", "north_m", "east_m", "depth_m", "altitude_m", "heading_deg",
                                           "pitch_deg", "roll_deg", "mode", "armed"))
        self._filter = run.series("filter.csv", ("t_s", "depth_est_m", "altitude_est_m", "altitude_std_m",
                                                 "seabed_depth_est_m", "altimeter_m", "rejected_total"))
        self._tilt = run.series("tilt.csv", ("t_s", "tilt_cmd_deg", "tilt_meas_deg", "pitch_deg", "min_margin_deg",
                                             "n_tracked", "altitude_target_m"))

    def record(self, now: float, onboard: OnboardPerception, *, mode: int | None, armed: bool | None,
               tilt_cmd_rad: float, margin_rad: float, altitude_target_m: float) -> None:
        """Append the rows for ``now`` (``tilt_cmd_rad`` in the mount's frame; the measured
        tilt as the mount reports it)."""
        status = onboard.status()
        nav = status.nav
        alt, alt_std = onboard.altitude(now)
        depth, _ = onboard.depth(now)
        seabed, _ = onboard.seabed_depth(now)
        if nav is not None:
            self._nav.append(t_s=now, north_m=nav.north_m, east_m=nav.east_m, depth_m=depth,
                             altitude_m=status.last_altimeter_m, heading_deg=math.degrees(nav.heading_rad),
                             pitch_deg=math.degrees(nav.pitch_rad), roll_deg=math.degrees(nav.roll_rad),
                             mode=None if mode is None else int(mode), armed=None if armed is None else int(armed))
        self._filter.append(t_s=now, depth_est_m=depth, altitude_est_m=alt, altitude_std_m=alt_std,
                            seabed_depth_est_m=seabed, altimeter_m=status.last_altimeter_m,
                            rejected_total=status.filter_rejected)
        self._tilt.append(t_s=now, tilt_cmd_deg=math.degrees(tilt_cmd_rad),
                          tilt_meas_deg=math.degrees(nav.tilt_rad) if nav else None,
                          pitch_deg=math.degrees(nav.pitch_rad) if nav else None,
                          min_margin_deg=math.degrees(margin_rad), n_tracked=status.measured_last_frame,
                          altitude_target_m=altitude_target_m)
