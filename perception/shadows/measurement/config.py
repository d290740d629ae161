"""Settings of the shadow-edge measurement (:mod:`perception.shadows.measurement.measure`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class MeasureConfig:
    """Settings of :func:`measure_pair`.

    Attributes
    ----------
    central_fraction : float
        Fraction of the pair's beams, around the middle, used for the edges.
    min_beams : int
        Fewest beams with both edges found for a measurement.
    level_samples : int
        Samples averaged (median) for the highlight, shadow and seabed levels.
    smooth_samples : int
        Range smoothing (box, samples) of the linear power profiles; edges are also
        searched this far around the region boundaries.
    smooth_beams : int
        Beams averaged (centred, odd) into each beam's power profile.
    end_contrast_db : float
        The seabed just after a shadow must be this much brighter than the shadow, dB;
        where it is not, the shadow runs on into the dark beyond the band's far edge and
        that beam is cut (most beams cut: the shadow is truncated).
    """

    central_fraction: float = 0.6
    min_beams: int = 1
    level_samples: int = 6
    smooth_samples: int = 5
    smooth_beams: int = 3
    end_contrast_db: float = 6.0

    def __post_init__(self) -> None:
        if not 0 < self.central_fraction <= 1:
            raise ValueError(f"central_fraction must be in (0, 1], got {self.central_fraction}")
        if self.min_beams < 1 or self.level_samples < 1 or self.smooth_samples < 1:
            raise ValueError("min_beams, level_samples and smooth_samples must be >= 1")
        if self.smooth_beams < 1 or self.smooth_beams % 2 == 0:
            raise ValueError(f"smooth_beams must be an odd integer >= 1, got {self.smooth_beams}")
        if not self.end_contrast_db > 0:
            raise ValueError(f"end_contrast_db must be > 0 dB, got {self.end_contrast_db}")
