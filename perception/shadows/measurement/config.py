"""Settings of the shadow-edge measurement (:mod:`perception.shadows.measurement.measure`).

Lengths are metres of slant range, converted to samples per frame; contrasts are in units
of the frame's seabed spread (:attr:`perception.shadows.segmentation.result.Segmentation.sigma`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class MeasureConfig:
    """Settings of :func:`measure_pairs`.

    Attributes
    ----------
    central_fraction : float
        Fraction of the pair's beams, around the middle, used for the edges (the outer ones
        cross the target's rounded or sloping sides).
    min_beams : int
        Fewest beams with both edges found for a measurement.
    smooth_m : float
        Range smoothing (box) of the profiles in which each beam's rough edges are found, m.
    level_m : float
        Range over which the levels beside an edge (echo before the shadow, the shadow,
        the seabed after it) are taken for the rough edges, m.
    fit_half_window_m : float
        Half the window of the fitted step about the rough edge, m (at least 4 samples):
        wider than the blur of an edge (pulse, beam width across an oblique edge).
    cut_contrast_sigmas : float
        The seabed after a shadow must stand this many spreads above the shadow; where it
        does not, the shadow runs on into the dark beyond the band's far edge (or the
        window's end) in that beam. Likewise the echo before the shadow's start (else the
        shadow begins in the dark before the band).
    """

    central_fraction: float = 0.6
    min_beams: int = 1
    smooth_m: float = 0.003
    level_m: float = 0.008
    fit_half_window_m: float = 0.015
    cut_contrast_sigmas: float = 2.0

    def __post_init__(self) -> None:
        if not 0 < self.central_fraction <= 1:
            raise ValueError(f"central_fraction must be in (0, 1], got {self.central_fraction}")
        if self.min_beams < 1:
            raise ValueError(f"min_beams must be >= 1, got {self.min_beams}")
        for name in ("smooth_m", "level_m", "fit_half_window_m", "cut_contrast_sigmas"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
