"""The fixed-tilt baseline: the loop's interface, always the nominal tilt; and the tilt that
centres the tracking zone (what a fixed tilt should be)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from perception.geometry.mount import slew_toward
from planner.pitch.config import MountLimits, PitchLoopConfig
from planner.pitch.selection import select_shadows, served_margins
from planner.pitch.types import PitchCommand, PitchState, TrackedShadow


class NominalTilt:
    """The baseline: the same interface, always the nominal tilt (within the limits)."""

    def __init__(self, config: PitchLoopConfig, limits: MountLimits):
        self.config = config
        self.limits = limits

    def step(self, state: PitchState, shadows: Sequence[TrackedShadow]) -> PitchCommand:
        """Return the nominal tilt, with the margins and drops it implies."""
        cfg, lim = self.config, self.limits
        target = lim.clip(cfg.nominal_tilt_rad)
        tilt = slew_toward(lim.clip(state.current_tilt_rad), target, max_rate_rad_s=lim.max_rate_rad_s,
                           dt_s=cfg.dt_s)
        served, dropped, low, up, _, pred = select_shadows(state, shadows, cfg, lim, 0.0)
        idx = [i for i, _ in served]
        slack = float(np.sum(np.fmax(0.0, low[idx, 1] - tilt)) + np.sum(np.fmax(0.0, tilt - up[idx, 1])))
        return PitchCommand(tilt, (target,) * cfg.horizon_steps, served_margins(pred, shadows, served, tilt, cfg),
                            tuple(dropped), slack, True)


def nominal_tilt_for(altitude_m: float, config: PitchLoopConfig) -> float:
    """A fixed tilt for an altitude: the beam axis midway, in depression, across the
    tracking zone (from the far end of the range window to the zone's near edge,
    :meth:`PitchLoopConfig.zone_start_m`), rad."""
    far = math.sqrt(max(config.window_m[1] ** 2 - altitude_m**2, 1e-9))
    near = float(config.zone_start_m(altitude_m))
    return 0.5 * (math.atan2(altitude_m, far) + math.atan2(altitude_m, max(near, 1e-9)))
