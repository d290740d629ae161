"""Navigation-drift correction by phase correlation of projected frames on the mosaic.

Where a new frame overlaps what the mosaic already holds, the frame's projection and the
mosaic are correlated in the Fourier domain (``cv2.phaseCorrelate``, as Hurtos et al. did
for forward-looking sonar). The navigation is the prior: a correction is accepted only
when the correlation peak is strong, the overlap large enough and the shift within what
the navigation's drift makes plausible. Accepted shifts update a running estimate of the
drift (a scalar-gain filter), which is applied to every later frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from perception.mosaic import ProjectedFrame, TiledMosaic


@dataclass(frozen=True)
class RegistrationConfig:
    """Acceptance test and filter gain of the drift correction.

    Attributes
    ----------
    min_response : float
        Smallest phase-correlation peak (0..1) accepted.
    min_overlap_fraction : float
        Smallest fraction of the frame's footprint already covered by the mosaic.
    max_shift_m : float
        Largest correction accepted in one step, m (the prior on the drift rate).
    gain : float
        Fraction of an accepted shift added to the drift estimate (0..1].
    min_weight : float
        Mosaic cells with less accumulated weight count as uncovered.
    every_n_frames : int
        Register one frame in this many (drift grows slowly; the others take the
        current estimate).
    reference_lag_frames : int
        Frames are registered against the mosaic of the frames at least this many frames
        older, so that a lane's newest frames, which share its drift, do not hide it.
    texture_scale_m : float
        Scale of the seabed texture correlated; structure much larger than this (the
        footprint's outline, range-dependent gain) is filtered out first.
    """

    min_response: float = 0.08
    min_overlap_fraction: float = 0.3
    max_shift_m: float = 0.15
    gain: float = 1.0
    min_weight: float = 0.5
    texture_scale_m: float = 0.02
    reference_lag_frames: int = 30
    every_n_frames: int = 3

    def __post_init__(self) -> None:
        if not 0 < self.gain <= 1:
            raise ValueError(f"gain must be in (0, 1], got {self.gain!r}")
        if self.every_n_frames < 1 or self.reference_lag_frames < 0:
            raise ValueError("every_n_frames must be >= 1 and reference_lag_frames >= 0")
        if self.max_shift_m <= 0:
            raise ValueError(f"max_shift_m must be > 0, got {self.max_shift_m!r}")


@dataclass(frozen=True)
class RegistrationResult:
    """One correlation attempt: the measured shift (north, east) in m and whether it was taken."""

    accepted: bool
    shift_north_m: float
    shift_east_m: float
    response: float
    overlap_fraction: float
    reason: str


def _high_pass(image: np.ndarray, mask: np.ndarray, sigma_cells: float) -> np.ndarray:
    """``image`` minus its local mean inside ``mask`` (normalised convolution), 0 outside."""
    m = mask.astype(np.float32)
    local = cv2.GaussianBlur(image * m, (0, 0), sigma_cells)
    norm = cv2.GaussianBlur(m, (0, 0), sigma_cells)
    out = np.zeros_like(image)
    np.divide(local, norm, out=out, where=norm > 1e-3)
    return (image - out) * m


def measure_shift(
    projected: ProjectedFrame, mosaic: TiledMosaic, *, config: RegistrationConfig
) -> RegistrationResult:
    """Shift that moves ``projected`` onto what ``mosaic`` holds, with the acceptance test.

    The shift is what must be ADDED to the frame's position to align it.
    """
    res = mosaic.config.resolution_m
    n_rows, n_cols = projected.shape
    ref, ref_w = mosaic.window(projected.row0, projected.col0, n_rows, n_cols)
    frame_cov = projected.weight > 0
    both = frame_cov & (ref_w >= config.min_weight)
    footprint = int(np.count_nonzero(frame_cov))
    overlap = float(np.count_nonzero(both)) / footprint if footprint else 0.0
    if overlap < config.min_overlap_fraction:
        return RegistrationResult(False, 0.0, 0.0, 0.0, overlap, "overlap too small")
    # Compare only where both hold data, band-passed so that the seabed's texture and not
    # the outline of the footprint drives the peak; the overlap is apodised (eroded, then
    # blurred) because a sharp common outline would pull the peak towards zero shift.
    margin = max(3, int(round(config.max_shift_m / res)))
    kernel = np.ones((2 * margin + 1, 2 * margin + 1), np.uint8)
    core = cv2.erode(both.astype(np.uint8), kernel)
    if not np.any(core):
        return RegistrationResult(False, 0.0, 0.0, 0.0, overlap, "overlap too thin")
    apod = cv2.GaussianBlur(core.astype(np.float32), (0, 0), margin / 2.0)
    sigma_hp = 4.0 * max(1.0, config.texture_scale_m / res)
    a = _high_pass(np.where(both, projected.intensity, 0).astype(np.float32), both, sigma_hp) * apod
    b = _high_pass(np.where(both, ref, 0).astype(np.float32), both, sigma_hp) * apod
    rows = cv2.getOptimalDFTSize(n_rows)
    cols = cv2.getOptimalDFTSize(n_cols)
    a = cv2.copyMakeBorder(a, 0, rows - n_rows, 0, cols - n_cols, cv2.BORDER_CONSTANT, value=0)
    b = cv2.copyMakeBorder(b, 0, rows - n_rows, 0, cols - n_cols, cv2.BORDER_CONSTANT, value=0)
    (dx, dy), response = cv2.phaseCorrelate(a, b)
    # phaseCorrelate returns the shift of b relative to a: b(x) = a(x - d). The frame
    # content sits at ``a``; moving it by +d aligns it with the mosaic.
    shift_north = float(dy) * res
    shift_east = float(dx) * res
    magnitude = math.hypot(shift_north, shift_east)
    if response < config.min_response:
        return RegistrationResult(False, shift_north, shift_east, float(response), overlap, "weak correlation")
    if magnitude > config.max_shift_m:
        return RegistrationResult(False, shift_north, shift_east, float(response), overlap, "shift beyond prior")
    return RegistrationResult(True, shift_north, shift_east, float(response), overlap, "accepted")


class DriftEstimator:
    """Running estimate of the navigation drift, updated by accepted registrations."""

    def __init__(self, config: RegistrationConfig | None = None):
        self.config = config or RegistrationConfig()
        self.north_m = 0.0
        self.east_m = 0.0
        self.accepted = 0
        self.rejected = 0

    def update(self, result: RegistrationResult) -> None:
        """Fold one registration result in (rejected ones are only counted)."""
        if not result.accepted:
            self.rejected += 1
            return
        self.north_m += self.config.gain * result.shift_north_m
        self.east_m += self.config.gain * result.shift_east_m
        self.accepted += 1
