"""Frames in, mosaic out: projection, drift correction and blending in one incremental step."""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from perception import imaging
from perception.mapping.mosaic import (
    MosaicConfig,
    ProjectedFrame,
    SonarPlacement,
    TiledMosaic,
    placement_from_frame,
)
from perception.mapping.projection import check_altitude, frame_samples, project_samples
from perception.mapping.registration import (
    DriftEstimator,
    RegistrationConfig,
    RegistrationResult,
    measure_shift,
)
from perception.shadows.measurement.measure import ShadowMeasurement
from perception.sonar_io.frame import SonarFrame


@dataclass(frozen=True)
class FrameAdded:
    """What :meth:`MosaicBuilder.add_frame` did with one frame.

    ``correction_north_m``/``correction_east_m`` is the drift correction applied to the
    frame's navigation position; ``registration`` the correlation attempt (None when
    registration is off or the mosaic was still empty there).
    """

    used: bool
    correction_north_m: float
    correction_east_m: float
    registration: RegistrationResult | None


def _dark_count(image: np.ndarray, start: int, stop: int, cols: slice, drop_levels: float) -> int:
    """Samples of ``image[start:stop, cols]`` (3 x 3 mean) below their row's mean by ``drop_levels``."""
    if stop <= start:
        return 0
    level = np.asarray(image[start:stop], dtype=np.float32).mean(axis=1)
    # blur with one sample of the image's own context around the box, then crop
    r0, r1 = max(start - 1, 0), min(stop + 1, image.shape[0])
    c0, c1 = max(int(cols.start) - 1, 0), min(int(cols.stop) + 1, image.shape[1])
    blurred = imaging.box_mean(np.asarray(image[r0:r1, c0:c1], dtype=np.float32), 3, 3)
    box = blurred[start - r0 : stop - r0, int(cols.start) - c0 : int(cols.stop) - c0]
    return int(np.count_nonzero(box < (level - np.float32(drop_levels))[:, None]))


@dataclass(frozen=True, eq=False)
class ShadowMasks:
    """Polar masks of one frame, shape (n_samples, n_beams), bool.

    ``shadow``: samples inside targets' shadows (left out of the blend); ``target``: the
    whole highlight-to-shadow-end stretch of each raised target (left out of registration).
    """

    shadow: np.ndarray
    target: np.ndarray


def masks_from_shadows(
    measurements: Sequence[ShadowMeasurement],
    *,
    range_m: np.ndarray,
    n_beams: int,
    beam_azimuth_rad: np.ndarray | None = None,
    image: np.ndarray | None = None,
    min_depth_db: float = 10.0,
    min_dark_samples: int = 20,
    db_per_level: float = 80.0 / 255.0,
    pad_m: float = 0.02,
    pad_beams: int = 1,
) -> ShadowMasks:
    """Polar masks of the shadows and targets that the height pipeline measured.

    Each measurement gives a box in the polar image: its beams (widened to the shadow's
    width, plus ``pad_beams`` either side) by its ranges (``pad_m`` either side). A shadow
    whose edges were not measured (truncated by the band or the window) runs from its
    highlight to the end of the window, across the beams about its mean azimuth. Building
    the masks costs a few slice assignments per target, so it adds nothing measurable to
    a frame.

    Parameters
    ----------
    measurements : sequence of ShadowMeasurement
        From :func:`perception.heights.pipeline.detect_shadows` (or a ``FrameResult``).
    range_m : ndarray, shape (n_samples,)
        Slant range of each row, m, increasing.
    n_beams : int
    beam_azimuth_rad : ndarray, shape (n_beams,), optional
        Beam azimuths, rad; needed to place measurements that located no beam (without
        it they are skipped).
    image : ndarray, shape (n_samples, n_beams), optional
        The frame's image. When given, a box is kept only if at least
        ``min_dark_samples`` of its samples (smoothed over 3 x 3) lie ``min_depth_db``
        below their row's mean level: a raised target's shadow falls 20-30 dB to the noise
        floor, while a dark patch of seabed texture, which the segmentation may pair with
        a bright one, is a few dB down. (A count, not a fraction: a shadow cut by the band's
        far edge has a box running to the window's end, mostly past the seabed.)
    min_depth_db : float
    min_dark_samples : int
        See ``image``.
    db_per_level : float
        dB per image level (80 / 255 for the ARIS uint8 scale).
    pad_m : float
        Range margin, m.
    pad_beams : int
        Beam margin.

    Returns
    -------
    ShadowMasks
    """
    r = np.asarray(range_m, dtype=np.float64)
    if r.ndim != 1 or r.size < 2 or not np.all(np.diff(r) > 0):
        raise ValueError("range_m must be 1-D and increasing")
    if n_beams < 1 or pad_beams < 0 or not pad_m >= 0:
        raise ValueError(f"need n_beams >= 1, pad_beams >= 0, pad_m >= 0; got {n_beams}, {pad_beams}, {pad_m}")
    shadow = np.zeros((r.size, n_beams), dtype=bool)
    target = np.zeros((r.size, n_beams), dtype=bool)
    for m in measurements:
        if m.columns:
            lo_col, hi_col = min(m.columns), max(m.columns)
        elif math.isfinite(m.azimuth_rad) and beam_azimuth_rad is not None:
            # truncated, no beam with both edges: centred on the pair's mean azimuth
            lo_col = hi_col = int(np.argmin(np.abs(np.asarray(beam_azimuth_rad) - m.azimuth_rad)))
        else:
            continue
        missing = max(0, m.shadow_width_beams - (hi_col - lo_col + 1))
        lo_col = max(0, lo_col - missing // 2 - pad_beams)
        hi_col = min(n_beams - 1, hi_col + (missing - missing // 2) + pad_beams)
        tops = [v for v in m.r_top_per_beam_m if math.isfinite(v)]
        ends = [v for v in m.r_end_per_beam_m if math.isfinite(v)]
        near = m.highlight_range_m if math.isfinite(m.highlight_range_m) else (min(tops) if tops else math.nan)
        if not math.isfinite(near):
            continue
        # unmeasured edges: the shadow lies somewhere behind the highlight, up to the window's end
        top = min(tops) if tops else near
        end = max(ends) if ends else float(r[-1])
        # rows whose range lies in [near - pad, end + pad] (1e-9 m: rounding of the grid)
        first_near, first_top = np.searchsorted(r, [near - pad_m - 1e-9, top - pad_m - 1e-9])
        stop = int(np.searchsorted(r, end + pad_m + 1e-9, side="right"))
        cols = slice(lo_col, hi_col + 1)
        if image is not None and _dark_count(image, first_top, stop, cols,
                                              min_depth_db / db_per_level) < min_dark_samples:
            continue  # no real shadow there: a dark patch of seabed paired by chance
        shadow[first_top:stop, cols] = True
        target[first_near:stop, cols] = True
    return ShadowMasks(shadow, target)


class MosaicBuilder:
    """Adds frames to a :class:`~perception.mapping.mosaic.TiledMosaic`, correcting navigation drift.

    Parameters
    ----------
    config : MosaicConfig, optional
    registration : RegistrationConfig or None
        None turns the drift correction off.

    Notes
    -----
    Frames are registered against a LAGGED reference mosaic, which holds only frames at
    least ``reference_lag_frames`` old (against the newest frames a frame would only
    confirm the drift it shares with them) and only their seabed cells (no raised targets'
    echoes, no shadows: see :func:`~perception.mapping.projection.project_frame`).
    """

    def __init__(self, config: MosaicConfig | None = None, registration: RegistrationConfig | None = None):
        self.mosaic = TiledMosaic(config or MosaicConfig())
        self.registration = registration
        self.drift = DriftEstimator(registration) if registration is not None else None
        self._reference = TiledMosaic(self.mosaic.config) if registration is not None else None
        self._pending: deque[_SeabedCells] = deque()
        self._last_position: tuple[float, float] | None = None
        #: Horizontal distance between the navigation positions of successive frames, summed, m.
        self.travelled_m = 0.0

    def add_frame(
        self,
        frame: SonarFrame,
        *,
        placement: SonarPlacement | None = None,
        altitude_m: float | None = None,
        exclude_mask: np.ndarray | None = None,
        unreliable_mask: np.ndarray | None = None,
        weight_scale: float = 1.0,
    ) -> FrameAdded:
        """Project ``frame``, register it against the mosaic if enabled, and blend it in.

        Parameters
        ----------
        frame : SonarFrame
        placement : SonarPlacement, optional
            The pose to use; by default the frame's own metadata (see
            :func:`~perception.mapping.mosaic.placement_from_frame`), with ``altitude_m`` from the
            altitude filter when given.
        exclude_mask : ndarray of bool, shape (n_samples, n_beams), optional
            Polar samples left out of the blend (shadows).
        unreliable_mask : ndarray of bool, shape (n_samples, n_beams), optional
            Polar samples blended but not registered (raised targets' echoes).
        weight_scale : float, optional
            Factor on the frame's weights: the number of frames it stands for when only
            some are blended (:mod:`perception.mapping.look_spacing`).
        """
        if not (math.isfinite(weight_scale) and weight_scale > 0):
            raise ValueError(f"weight_scale must be finite and > 0, got {weight_scale!r}")
        if placement is None:
            placement = placement_from_frame(frame, altitude_m=altitude_m)
        if self._last_position is not None:
            self.travelled_m += math.hypot(placement.north_m - self._last_position[0],
                                           placement.east_m - self._last_position[1])
        self._last_position = (placement.north_m, placement.east_m)
        d_n = self.drift.north_m if self.drift else 0.0
        d_e = self.drift.east_m if self.drift else 0.0
        cfg = self.mosaic.config
        check_altitude(placement)
        samples = frame_samples(frame, exclude_mask=exclude_mask, unreliable_mask=unreliable_mask)
        projected = _scaled(project_samples(samples, placement.shifted(d_n, d_e), config=cfg), weight_scale)
        if projected is None:
            return FrameAdded(False, d_n, d_e, None)
        result: RegistrationResult | None = None
        reg = self.registration
        if (self.drift is not None and reg is not None and self._reference is not None
                and self.mosaic.frames_added % self.drift.interval_frames == 0):
            stacked = _stack(projected, list(self._pending)[len(self._pending) - (reg.stack_frames - 1):])
            result = self.drift.update(measure_shift(stacked, self._reference, config=reg),
                                       travelled_m=self.travelled_m)
            if result.accepted:
                d_n, d_e = self.drift.north_m, self.drift.east_m
                projected = _scaled(project_samples(samples, placement.shifted(d_n, d_e), config=cfg), weight_scale)
                if projected is None:
                    return FrameAdded(False, d_n, d_e, result)
        self.mosaic.add(projected)
        if self._reference is not None and reg is not None:
            self._pending.append(_SeabedCells.of(projected))
            while len(self._pending) > reg.reference_lag_frames:
                old = self._pending.popleft()
                self._reference.add_sums(old.row0, old.col0, old.weight, old.weighted_intensity)
        return FrameAdded(True, d_n, d_e, result)


@dataclass(frozen=True, eq=False)
class _SeabedCells:
    """A blended frame's seabed cells, as the registration reads them (made once per frame,
    read by every stack it joins and by the reference mosaic): ``weight`` zero off the
    reliable cells, ``weighted_intensity`` = intensity x that weight."""

    row0: int
    col0: int
    weight: np.ndarray
    weighted_intensity: np.ndarray

    @classmethod
    def of(cls, projected: ProjectedFrame) -> _SeabedCells:
        weight = np.where(projected.reliable, projected.weight, np.float32(0))
        return cls(projected.row0, projected.col0, weight, projected.intensity * weight)

    @property
    def shape(self) -> tuple[int, int]:
        return (int(self.weight.shape[0]), int(self.weight.shape[1]))


def _scaled(projected: ProjectedFrame | None, factor: float) -> ProjectedFrame | None:
    """``projected`` with its weights times ``factor``, in place (it was just made, nobody else holds it)."""
    if projected is None or factor == 1.0:
        return projected
    np.multiply(projected.weight, np.float32(factor), out=projected.weight)
    return projected


def _stack(newest: ProjectedFrame, older: list[_SeabedCells]) -> ProjectedFrame:
    """The weighted mean of ``newest`` and the seabed cells of ``older`` over ``newest``'s window.

    Cells count as reliable where ``newest`` covers the seabed (the window's footprint).
    """
    if not older:
        return newest
    n_rows, n_cols = newest.shape
    sum_w = np.where(newest.reliable, newest.weight, np.float32(0))
    sum_wi = sum_w * newest.intensity
    for p in older:
        r0, c0 = max(newest.row0, p.row0), max(newest.col0, p.col0)
        r1 = min(newest.row0 + n_rows, p.row0 + p.shape[0])
        c1 = min(newest.col0 + n_cols, p.col0 + p.shape[1])
        if r1 <= r0 or c1 <= c0:
            continue
        src = (slice(r0 - p.row0, r1 - p.row0), slice(c0 - p.col0, c1 - p.col0))
        dst = (slice(r0 - newest.row0, r1 - newest.row0), slice(c0 - newest.col0, c1 - newest.col0))
        sum_w[dst] += p.weight[src]
        sum_wi[dst] += p.weighted_intensity[src]
    mean = np.zeros_like(sum_wi)
    np.divide(sum_wi, sum_w, out=mean, where=sum_w > 0)
    return ProjectedFrame(newest.row0, newest.col0, mean, sum_w, newest.reliable & (sum_w > 0))
