"""Settings of the drift registration and what one attempt found (:mod:`perception.mapping.registration`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace


@dataclass(frozen=True)
class RegistrationConfig:
    """Acceptance test and drift filter of the correction.

    Attributes
    ----------
    min_response : float
        Smallest correlation peak accepted, as :func:`_correlate` scores it (about 1 for
        identical images, about 0 for unrelated ones).
    min_overlap_fraction : float
        Smallest fraction of the frame's footprint already covered by the mosaic.
    max_shift_m : float
        Largest correction accepted in one step, m (the prior on the drift rate).
    initial_drift_std_m : float
        1-sigma of the drift where the mosaic begins, m.
    drift_walk_m : float
        Growth of the drift's 1-sigma per square-root metre travelled, m / sqrt(m).
    measurement_std_m : float
        1-sigma of one accepted registration, m.
    min_weight : float
        Mosaic cells with less accumulated weight count as uncovered.
    every_n_frames : int
        Register one frame in this many (drift grows slowly; the others take the
        current estimate).
    backoff_after_refusals, backoff_factor : int
        After this many registrations refused in a row (a seabed without texture the
        correlation can hold: 60 are 18 s of a 10 Hz sonar), register only one frame in
        ``backoff_factor * every_n_frames`` until one is accepted: the refused ones cost a
        fifth of a field dive's time and correct nothing.
    whitening : float
        0..1: how far the correlation whitens the spectrum (1 = classic phase correlation,
        0 = plain cross-correlation); see :func:`_correlate`.
    stack_frames : int
        The frame registered is the weighted mean of the newest this-many frames (they
        share the drift; stacking averages their speckle down by ``sqrt(stack_frames)``).
    reference_lag_frames : int
        Frames are registered against the mosaic of the frames at least this many frames
        older, so that a lane's newest frames, which share its drift, do not hide it.
    texture_scale_m : float
        Scale of the seabed texture correlated; structure much larger than this (the
        footprint's outline, range-dependent gain) is filtered out first.
    min_ncc : float
        Smallest normalised cross-correlation (-1..1) of the band-passed overlaps at the
        measured shift.
    min_ncc_gain : float
        How much the shift must raise that correlation over the navigation's alignment
        (zero shift) when it moves the frame by more than 2 cells.
    outlier_sigmas, outlier_margin_m : float
        Cells whose band-passed value, smoothed over 2 cells, lies more than
        ``outlier_sigmas`` robust standard deviations (of the new frame's) below the
        median -- shadows -- and ``outlier_margin_m`` around them (their targets' echoes)
        are left out of the correlation (``outlier_sigmas`` 0: none), so that the seabed's
        texture, not objects placed by layover, carries the match. Bright low features
        (shells, stones, with no shadow) stay: their layover is small.
    half_agreement_m : float
        The overlap is split in two halves, each registered alone: their shifts must agree
        within this, m (0 turns the test off). One raised target's echo, displaced by its
        layover, can dominate a correlation on an otherwise featureless seabed; it cannot
        move both halves.
    drift_floor_m, drift_per_m : float
        The navigation's prior: the total drift may reach ``drift_floor_m + drift_per_m *
        distance travelled`` (m; m per m); a correction implying more is refused.
    """

    min_response: float = 0.08
    min_overlap_fraction: float = 0.3
    max_shift_m: float = 0.15
    initial_drift_std_m: float = 0.02
    drift_walk_m: float = 0.01
    measurement_std_m: float = 0.015
    min_weight: float = 0.5
    texture_scale_m: float = 0.02
    reference_lag_frames: int = 30
    every_n_frames: int = 3
    backoff_after_refusals: int = 60
    backoff_factor: int = 4
    stack_frames: int = 8
    whitening: float = 0.5
    min_ncc: float = 0.2
    min_ncc_gain: float = 0.05
    half_agreement_m: float = 0.03
    outlier_sigmas: float = 3.5
    outlier_margin_m: float = 0.1
    drift_floor_m: float = 0.05
    drift_per_m: float = 0.02

    def __post_init__(self) -> None:
        for name in ("initial_drift_std_m", "drift_walk_m", "measurement_std_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
        if self.measurement_std_m <= 0:
            raise ValueError(f"measurement_std_m must be > 0, got {self.measurement_std_m!r}")
        if self.backoff_after_refusals < 1 or self.backoff_factor < 1:
            raise ValueError("backoff_after_refusals and backoff_factor must be >= 1")
        if self.every_n_frames < 1 or self.reference_lag_frames < 0:
            raise ValueError("every_n_frames must be >= 1 and reference_lag_frames >= 0")
        if not 1 <= self.stack_frames <= max(1, self.reference_lag_frames):
            raise ValueError(f"stack_frames must be in 1..max(1, reference_lag_frames), got {self.stack_frames!r}")
        if self.max_shift_m <= 0:
            raise ValueError(f"max_shift_m must be > 0, got {self.max_shift_m!r}")
        if not 0 <= self.whitening <= 1:
            raise ValueError(f"whitening must be in [0, 1], got {self.whitening!r}")
        if self.outlier_sigmas < 0 or self.outlier_margin_m < 0 or self.half_agreement_m < 0:
            raise ValueError("outlier_sigmas, outlier_margin_m and half_agreement_m must be >= 0")
        if not -1 <= self.min_ncc <= 1 or self.min_ncc_gain < 0:
            raise ValueError(f"min_ncc must be in [-1, 1] and min_ncc_gain >= 0, got "
                             f"{self.min_ncc!r}, {self.min_ncc_gain!r}")
        if self.drift_floor_m < 0 or self.drift_per_m < 0:
            raise ValueError(f"drift_floor_m and drift_per_m must be >= 0, got "
                             f"{self.drift_floor_m!r}, {self.drift_per_m!r}")


@dataclass(frozen=True)
class RegistrationResult:
    """One correlation attempt: the measured shift (north, east) in m and whether it was taken.

    ``ncc``/``ncc_zero``: normalised cross-correlation of the band-passed overlaps at the
    measured shift and at zero shift (NaN when not computed).
    """

    accepted: bool
    shift_north_m: float
    shift_east_m: float
    response: float
    overlap_fraction: float
    reason: str
    ncc: float = math.nan
    ncc_zero: float = math.nan

    def refused(self, reason: str) -> RegistrationResult:
        """The same measurement, not accepted, for ``reason``."""
        return replace(self, accepted=False, reason=reason)
