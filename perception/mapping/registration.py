"""Navigation-drift correction by phase correlation of projected frames on the mosaic.

Where a new frame overlaps what the mosaic already holds, the frame's projection (the
newest ``stack_frames`` pings averaged, to beat their speckle down) and the mosaic are
correlated in the Fourier domain: phase correlation as Hurtos et al. did for
forward-looking sonar, with the spectrum only partly whitened (``whitening``), since at
fine scales a sonar image is mostly speckle. Only cells that show the seabed itself take
part: raised targets' echoes and shadows move with the view (layover) and would pull the
frame by up to ``2 H h / g``. They are left out twice over: the cells the height
pipeline's masks mark (:attr:`~perception.mapping.mosaic.ProjectedFrame.reliable`; the reference
mosaic holds only such cells), and any deep dark patch (a shadow, ``outlier_sigmas``) with
``outlier_margin_m`` around it, which takes its target's echo along.

The navigation is the prior, and a correction must earn its acceptance:

1. the overlap is large enough and the correlation peak strong (``min_response``);
2. the shift is within one step's plausible drift (``max_shift_m``);
3. the correlation is real, not a speckle peak: the normalised cross-correlation of the
   band-passed overlaps at the shift reaches ``min_ncc``, and beats the unshifted
   (navigation's) alignment by ``min_ncc_gain`` when the shift exceeds ``2`` cells;
4. the match is spread over the overlap, not one object's: its two halves, registered
   alone, agree within ``half_agreement_m``;
5. the drift it implies stays within what the navigation makes plausible after the
   distance travelled: ``drift_floor_m + drift_per_m * distance`` (checked by
   :class:`DriftEstimator`).

Accepted shifts update a running estimate of the drift, applied to every later frame: a
Kalman filter per axis whose drift is a random walk in the distance travelled
(``drift_walk_m`` per square-root metre) and whose measurements have a standard deviation
of ``measurement_std_m``; so the first match after a long stretch is taken almost whole,
and later ones are averaged. The estimate is RELATIVE to what the mosaic held:
registration puts a later pass back onto the earlier one, so the map's absolute error is
the drift of the pass that first mapped a place."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from perception import imaging
from perception.mapping.mosaic import ProjectedFrame, TiledMosaic
from perception.mapping.registration_config import RegistrationConfig, RegistrationResult


def _high_pass(images: tuple[np.ndarray, ...], mask: np.ndarray, sigma_cells: float) -> tuple[np.ndarray, ...]:
    """Each of ``images`` minus its local mean inside ``mask`` (normalised convolution), 0
    outside; the mask's own blur, shared by all, is done once."""
    m = mask.astype(np.float32)
    norm = imaging.gaussian_blur(m, sigma_cells)
    where = norm > 1e-3
    out = []
    for image in images:
        local = imaging.gaussian_blur(image * m, sigma_cells)
        mean = np.zeros_like(image)
        np.divide(local, norm, out=mean, where=where)
        out.append((image - mean) * m)
    return tuple(out)


def _robust_spread(values: np.ndarray, median: float) -> float:
    """1.4826 x the median absolute deviation of ``values`` (their ``median`` given)."""
    if values.size == 0:
        return 0.0
    return 1.4826 * float(np.median(np.abs(values - median)))


def _outliers(smooth: np.ndarray, mask: np.ndarray, sigmas: float, spread: float,
              values: np.ndarray | None = None, median: float | None = None) -> np.ndarray:
    """Cells of ``mask`` darker than their median by ``sigmas * spread``, bool.

    ``smooth`` is the image smoothed over 2 cells (:func:`_smoothed`), so single dark
    speckle cells do not count; a shadow, many cells long, does. ``values`` (its ``mask``
    cells) and their ``median`` when already known.
    """
    if values is None:
        values = smooth[mask]
    if values.size == 0 or spread <= 0:
        return np.zeros(smooth.shape, dtype=bool)
    if median is None:
        median = float(np.median(values))
    return mask & (smooth < median - sigmas * spread)


def _smoothed(image: np.ndarray) -> np.ndarray:
    """The image smoothed over 2 cells, as the outlier test reads it."""
    return imaging.gaussian_blur(image, 2.0)


def _correlate(
    a: np.ndarray, b: np.ndarray, *, max_shift_cells: int, whitening: float
) -> tuple[tuple[float, float], float]:
    """Generalised phase correlation of two equal-shape float32 images.

    The cross-power spectrum ``A* B`` is divided by ``|A* B| ** whitening`` (1: phase
    correlation, every frequency weighted alike; 0: plain cross-correlation, frequencies
    weighted by their power, robust where fine detail is mostly speckle). The peak is
    sought within ``max_shift_cells`` of zero shift and refined to sub-cell by a parabola
    through its neighbours along each axis.

    Returns
    -------
    ((dx, dy), response)
        Shift of ``b`` relative to ``a`` in cells (columns, rows), and the peak's height
        over the surface's RMS divided by ``sqrt(number of cells)`` (about 1 for two
        identical images, about 0 for unrelated ones).
    """
    fa = np.fft.rfft2(a)
    fb = np.fft.rfft2(b)
    cross = np.conj(fa) * fb
    if whitening > 0:
        cross /= np.maximum(np.abs(cross), 1e-12) ** whitening
    surface = np.fft.irfft2(cross, s=a.shape)
    m = max_shift_cells
    # shifts -m..m along each axis, wrapped: rows [-m:] then [:m+1]
    rows = np.r_[np.arange(-m, 0) % a.shape[0], np.arange(0, m + 1)]
    cols = np.r_[np.arange(-m, 0) % a.shape[1], np.arange(0, m + 1)]
    local = surface[np.ix_(rows, cols)]
    i, j = np.unravel_index(int(np.argmax(local)), local.shape)

    def vertex(lo: float, mid: float, hi: float) -> float:
        den = lo - 2.0 * mid + hi
        return 0.0 if den >= 0 else float(np.clip(0.5 * (lo - hi) / den, -0.5, 0.5))

    di = vertex(local[i - 1, j], local[i, j], local[i + 1, j]) if 0 < i < local.shape[0] - 1 else 0.0
    dj = vertex(local[i, j - 1], local[i, j], local[i, j + 1]) if 0 < j < local.shape[1] - 1 else 0.0
    rms = float(np.sqrt(np.mean(surface * surface)))
    response = float(local[i, j]) / (rms * math.sqrt(surface.size)) if rms > 0 else 0.0
    return (float(j - m) + dj, float(i - m) + di), response


def _ncc(a: np.ndarray, b: np.ndarray) -> float:
    """Normalised cross-correlation of two zero-mean-ish arrays of one shape."""
    den = math.sqrt(float(np.vdot(a, a)) * float(np.vdot(b, b)))
    return float(np.vdot(a, b)) / den if den > 0 else 0.0


def measure_shift(
    projected: ProjectedFrame, mosaic: TiledMosaic, *, config: RegistrationConfig
) -> RegistrationResult:
    """Shift that moves ``projected`` onto what ``mosaic`` holds, with the acceptance test.

    Parameters
    ----------
    projected : ProjectedFrame
        The new frame on the grid; only its :attr:`~ProjectedFrame.reliable` cells are used.
    mosaic : TiledMosaic
        The reference (hold only seabed cells in it: see :class:`MosaicBuilder`).
    config : RegistrationConfig

    Returns
    -------
    RegistrationResult
        The shift (north, east, m) that must be ADDED to the frame's position to align it,
        and whether tests 1-4 of the module docstring accept it.
    """
    res = mosaic.config.resolution_m
    n_rows, n_cols = projected.shape
    ref, ref_w = mosaic.window(projected.row0, projected.col0, n_rows, n_cols)
    frame_cov = projected.reliable
    both = frame_cov & (ref_w >= config.min_weight)
    footprint = int(np.count_nonzero(projected.weight > 0))
    overlap = float(np.count_nonzero(both)) / footprint if footprint else 0.0
    if overlap < config.min_overlap_fraction:
        return RegistrationResult(False, 0.0, 0.0, 0.0, overlap, "overlap too small")
    # Compare only where both hold data, band-passed so that the seabed's texture and not
    # the outline of the footprint drives the peak; the overlap is apodised (eroded, then
    # blurred) because a sharp common outline would pull the peak towards zero shift.
    margin = max(3, int(round(config.max_shift_m / res)))
    kernel = np.ones((2 * margin + 1, 2 * margin + 1), np.uint8)
    core = imaging.erode(both.astype(np.uint8), kernel)
    if not np.any(core):
        return RegistrationResult(False, 0.0, 0.0, 0.0, overlap, "overlap too thin")
    sigma_hp = 4.0 * max(1.0, config.texture_scale_m / res)
    a, b = _high_pass((np.where(both, projected.intensity, 0).astype(np.float32),
                       np.where(both, ref, 0).astype(np.float32)), both, sigma_hp)
    if config.outlier_sigmas > 0:
        # Strong isolated echoes and deep shadows are objects, not seabed texture: their
        # place depends on the view (layover), so they and a margin around them go.
        # One scale for both, the new frame's (speckle-dominated) spread: the reference,
        # averaged over many pings, is much smoother, and a bright marker's halo in it
        # would count as dark by its own spread.
        a_smooth = _smoothed(a)
        a_values = a_smooth[both]
        a_median = float(np.median(a_values)) if a_values.size else math.nan
        scale = _robust_spread(a_values, a_median)
        odd = (_outliers(a_smooth, both, config.outlier_sigmas, scale, a_values, a_median)
               | _outliers(_smoothed(b), both, config.outlier_sigmas, scale))
        if np.any(odd):
            grow = max(1, int(round(config.outlier_margin_m / res)))
            odd = imaging.dilate(odd.astype(np.uint8), np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)) > 0
            both &= ~odd
            core = imaging.erode(both.astype(np.uint8), kernel)
            if np.count_nonzero(both) < config.min_overlap_fraction * footprint or not np.any(core):
                return RegistrationResult(False, 0.0, 0.0, 0.0, overlap, "overlap is mostly objects")
            a, b = _high_pass((np.where(both, projected.intensity, 0).astype(np.float32),
                               np.where(both, ref, 0).astype(np.float32)), both, sigma_hp)
    apod = imaging.gaussian_blur(core.astype(np.float32), margin / 2.0)
    a *= apod
    b *= apod
    rows = imaging.optimal_dft_size(n_rows + margin)
    cols = imaging.optimal_dft_size(n_cols + margin)
    a = imaging.pad_bottom_right(a, rows, cols)
    b = imaging.pad_bottom_right(b, rows, cols)
    (dx, dy), response = _correlate(a, b, max_shift_cells=margin, whitening=config.whitening)
    # the shift of b relative to a: b(x) = a(x - d). The frame content sits at ``a``;
    # moving it by +d aligns it with the mosaic.
    shift_north = float(dy) * res
    shift_east = float(dx) * res
    magnitude = math.hypot(shift_north, shift_east)
    measured = RegistrationResult(False, shift_north, shift_east, float(response), overlap, "")
    if response < config.min_response:
        return measured.refused("weak correlation")
    if magnitude > config.max_shift_m:
        return measured.refused("shift beyond prior")
    moved = imaging.translate(a, dx, dy)
    measured = replace(measured, ncc=_ncc(moved, b), ncc_zero=_ncc(a, b))
    if measured.ncc < config.min_ncc:
        return measured.refused("no seabed match")
    if math.hypot(dx, dy) > 2.0 and measured.ncc < measured.ncc_zero + config.min_ncc_gain:
        return measured.refused("no better than the navigation")
    if config.half_agreement_m > 0:
        half_shifts = []
        for half in _halves(core):
            window = imaging.gaussian_blur(half.astype(np.float32), margin / 2.0)
            window = imaging.pad_bottom_right(window, rows, cols)
            half_shifts.append(_correlate(a * window, b * window, max_shift_cells=margin,
                                          whitening=config.whitening)[0])
        (x0, y0), (x1, y1) = half_shifts
        if math.hypot(x1 - x0, y1 - y0) * res > config.half_agreement_m:
            return measured.refused("halves disagree")
    return replace(measured, accepted=True, reason="accepted")


def _halves(core: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``core`` (uint8 0/1) split in two at the median of its cells along its longer extent."""
    rows, cols = np.nonzero(core)
    axis = 0 if np.ptp(rows) >= np.ptp(cols) else 1
    coord = rows if axis == 0 else cols
    cut = int(np.median(coord))
    index = np.arange(core.shape[axis])
    first = (index <= cut)[:, None] if axis == 0 else (index <= cut)[None, :]
    return core * first, core * ~first


class DriftEstimator:
    """Running estimate of the navigation drift (module docstring: a Kalman filter per axis).

    ``north_m``/``east_m`` is the correction ADDED to navigation positions; ``std_m`` its
    1-sigma per axis.
    """

    def __init__(self, config: RegistrationConfig | None = None):
        self.config = config or RegistrationConfig()
        self.north_m = 0.0
        self.east_m = 0.0
        self._variance = self.config.initial_drift_std_m**2
        self._travelled_m = 0.0
        self.accepted = 0
        self.rejected = 0
        self.refused_in_a_row = 0

    @property
    def interval_frames(self) -> int:
        """Frames between registrations now: ``every_n_frames``, or ``backoff_factor`` times
        that after ``backoff_after_refusals`` refusals in a row."""
        cfg = self.config
        backoff = self.refused_in_a_row >= cfg.backoff_after_refusals
        return cfg.every_n_frames * (cfg.backoff_factor if backoff else 1)

    @property
    def std_m(self) -> float:
        """1-sigma of the estimate per axis, m."""
        return math.sqrt(self._variance)

    @property
    def travelled_m(self) -> float:
        """Horizontal distance travelled since the mosaic began, as last reported, m."""
        return self._travelled_m

    def plausible_drift_m(self, travelled_m: float) -> float:
        """Largest total drift the navigation prior allows after ``travelled_m`` of track, m."""
        return self.config.drift_floor_m + self.config.drift_per_m * max(travelled_m, 0.0)

    def update(self, result: RegistrationResult, *, travelled_m: float) -> RegistrationResult:
        """Fold one registration result in (test 5 of the module docstring first).

        Parameters
        ----------
        result : RegistrationResult
            Its shift is measured on a frame already moved by the current estimate.
        travelled_m : float
            Horizontal distance travelled since the mosaic began, m (non-decreasing).

        Returns
        -------
        RegistrationResult
            ``result``, or a refused copy when the drift it implies is implausible (test 5).
        """
        cfg = self.config
        step = max(travelled_m - self._travelled_m, 0.0)
        self._travelled_m = max(travelled_m, self._travelled_m)
        self._variance += cfg.drift_walk_m**2 * step
        if result.accepted:
            gain = self._variance / (self._variance + cfg.measurement_std_m**2)
            north = self.north_m + gain * result.shift_north_m
            east = self.east_m + gain * result.shift_east_m
            if math.hypot(self.north_m + result.shift_north_m,
                          self.east_m + result.shift_east_m) > self.plausible_drift_m(travelled_m):
                result = result.refused("drift beyond prior")
        if not result.accepted:
            self.rejected += 1
            self.refused_in_a_row += 1
            return result
        self.north_m, self.east_m = north, east
        self._variance *= 1.0 - gain
        self.accepted += 1
        self.refused_in_a_row = 0
        return result
