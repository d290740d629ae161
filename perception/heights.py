"""From sonar frames to seabed targets with heights: the whole perception chain.

Per frame: segmentation (:mod:`perception.segmentation`), Algorithm 1's pairing
(:mod:`perception.pairing`), the shadow edges (:mod:`perception.measure`); across frames:
association (:mod:`perception.tracking`); per target: the N-frame height solver
(:func:`perception.solver.solve_height`).

:class:`HeightPipeline` is incremental, for use on board during a dive: add one frame at a
time (cost: one segmentation and a few targets' measurements) and ask for the targets at
any time. It keeps only the measurements, never the images.

Altitude information of a frame, first found wins: the ``altitude_m``/``delta_h_m``
passed to :meth:`HeightPipeline.add_frame` (e.g. from the altitude filter), the frame's
``altitude_m``, its ``sonar_depth_m`` (``delta_h = depth_first - depth``). A target's
height uses the absolute altitudes when all its frames have one, else the altitude
changes (solving the reference altitude too).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from perception.errors import SolverError
from perception.frame import SonarFrame
from perception.measure import MeasureConfig, ShadowMeasurement, measure_pairs
from perception.pairing import PairingConfig, pair_regions
from perception.segmentation import SegmentationConfig, segment
from perception.solver import HeightEstimate, ShadowObservation, solve_height
from perception.tracking import Detection, TargetTracker, TrackingConfig, seabed_centre, seabed_position


@dataclass(frozen=True)
class HeightsConfig:
    """Settings of the whole chain.

    Attributes
    ----------
    segmentation, pairing, measure, tracking : the stages' configs
    min_frames : int
        Fewest frames with a complete shadow for a height (>= 1).
    altitude_std_m : float or None
        1-sigma of given absolute altitudes, m (solver input).
    delta_h_std_m : float or None
        1-sigma of each frame's altitude change, m (solver input, independent frames).
    shared_altitude : bool
        When the frames' absolute altitude is unknown, solve the reference (first
        frame's) altitude once from all targets together, then each target's height with
        it. Right when the sonar moves vertically over a flat seabed (the ``heights``
        command's setting): one altitude is then common to all targets, and Eq. 2's
        poor conditioning is paid once, averaged over the targets, instead of per target.
    outlier_sigmas, outlier_floor_m, outlier_floor_fraction : float
        When at least four of a target's complete shadows carry a one-frame height
        (frames with an absolute altitude, :func:`perception.tracking.seabed_centre`),
        those farther from their median than ``max(outlier_sigmas * 1.4826 * MAD,
        outlier_floor_m + outlier_floor_fraction * median)`` are left out of the solve
        (a shadow measured on one or two beams of a target split in that frame).
    """

    segmentation: SegmentationConfig = field(default_factory=SegmentationConfig)
    pairing: PairingConfig = field(default_factory=PairingConfig)
    measure: MeasureConfig = field(default_factory=MeasureConfig)
    tracking: TrackingConfig = field(default_factory=TrackingConfig)
    min_frames: int = 2
    altitude_std_m: float | None = None
    delta_h_std_m: float | None = None
    shared_altitude: bool = True
    outlier_sigmas: float = 4.0
    outlier_floor_m: float = 0.002
    outlier_floor_fraction: float = 0.05

    def __post_init__(self) -> None:
        if self.min_frames < 1:
            raise ValueError(f"min_frames must be >= 1, got {self.min_frames}")
        for name in ("outlier_sigmas", "outlier_floor_m", "outlier_floor_fraction"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")


def detect_shadows(
    image: NDArray[np.generic],
    *,
    range_m: NDArray[np.float64],
    beam_azimuth_rad: NDArray[np.float64],
    config: HeightsConfig | None = None,
) -> tuple[ShadowMeasurement, ...]:
    """Segment, pair and measure one polar image.

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8, uint16 or float32
        Echo intensity (not modified).
    range_m : ndarray, shape (n_samples,)
        Slant range of each row from range zero, m.
    beam_azimuth_rad : ndarray, shape (n_beams,)
        Beam azimuths, rad.
    config : HeightsConfig, optional

    Returns
    -------
    tuple of ShadowMeasurement
        One per highlight-shadow pair, truncated ones included (flagged).
    """
    cfg = config or HeightsConfig()
    seg = segment(image, config=cfg.segmentation)
    pairs = pair_regions(seg, config=cfg.pairing)
    return tuple(
        measure_pairs(seg, pairs, range_m=range_m, beam_azimuth_rad=beam_azimuth_rad, config=cfg.measure)
    )


@dataclass(frozen=True)
class FrameResult:
    """What one frame added.

    Attributes
    ----------
    frame_index : int
    timestamp_s : float
    altitude_m, delta_h_m : float
        The altitude information used for the frame (NaN when unknown).
    measurements : tuple of ShadowMeasurement
    target_ids : tuple of int
        The target each measurement was associated with.
    """

    frame_index: int
    timestamp_s: float
    altitude_m: float
    delta_h_m: float
    measurements: tuple[ShadowMeasurement, ...]
    target_ids: tuple[int, ...]


@dataclass(frozen=True)
class TargetHeight:
    """One target and its height.

    Attributes
    ----------
    target_id : int
    first_frame_index : int
        The first frame the target was seen in; the location fields refer to it.
    azimuth_rad : float
        Mean azimuth of the beams measured through the shadow, rad.
    range_m, shadow_end_m : float
        Slant ranges of the shadow start (far top edge) and end in that frame, m (NaN
        when that frame's shadow was truncated).
    north_m, east_m : float
        Estimated seabed position of the target's centre, m: the weighted mean over all
        its frames (:mod:`perception.tracking`); NaN without pose.
    height_m, height_std_m : float or None
        Height above the seabed and its 1-sigma, m; None when not solvable (``reason``).
        The sigma combines the solver's (from the range noise) with the RMS of the
        per-frame residuals, so frames that disagree (a rounded target) widen it.
    ref_altitude_m : float or None
        The reference (first frame's) altitude used or solved, m.
    residual_rms_m : float or None
        RMS of the per-frame residuals of the height fit, m.
    frames_seen, frames_used : int
        Frames the target was detected in; frames whose shadow gave the height.
    reason : str or None
        Why ``height_m`` is None.
    detections : tuple of Detection
    """

    target_id: int
    first_frame_index: int
    azimuth_rad: float
    range_m: float
    shadow_end_m: float
    north_m: float
    east_m: float
    height_m: float | None
    height_std_m: float | None
    ref_altitude_m: float | None
    residual_rms_m: float | None
    frames_seen: int
    frames_used: int
    reason: str | None
    detections: tuple[Detection, ...]


class HeightPipeline:
    """Incremental frames-to-heights pipeline; see the module docstring.

    Parameters
    ----------
    config : HeightsConfig, optional
    """

    def __init__(self, config: HeightsConfig | None = None):
        self.config = config or HeightsConfig()
        self._tracker = TargetTracker(self.config.tracking)
        self._n_frames = 0
        self._first_altitude_m = math.nan
        self._first_depth_m = math.nan

    @property
    def n_frames(self) -> int:
        """Frames added so far."""
        return self._n_frames

    def _altitude_info(
        self, frame: SonarFrame, altitude_m: float | None, delta_h_m: float | None
    ) -> tuple[float, float]:
        altitude = frame.altitude_m if altitude_m is None else float(altitude_m)
        first = self._n_frames == 0
        if first:
            self._first_altitude_m = altitude
            self._first_depth_m = frame.sonar_depth_m
        if delta_h_m is not None:
            delta = float(delta_h_m)
        elif first:
            delta = 0.0
        elif math.isfinite(altitude) and math.isfinite(self._first_altitude_m):
            delta = altitude - self._first_altitude_m
        elif math.isfinite(frame.sonar_depth_m) and math.isfinite(self._first_depth_m):
            delta = self._first_depth_m - frame.sonar_depth_m
        else:
            delta = math.nan
        return altitude, delta

    def add_frame(
        self,
        frame: SonarFrame,
        *,
        altitude_m: float | None = None,
        delta_h_m: float | None = None,
    ) -> FrameResult:
        """Process one frame and associate its shadows with the targets.

        Parameters
        ----------
        frame : SonarFrame
        altitude_m : float, optional
            The frame's altitude above the seabed, m (overrides ``frame.altitude_m``).
        delta_h_m : float, optional
            The frame's altitude minus the first frame's, m (overrides what the frame
            fields give).
        """
        altitude, delta = self._altitude_info(frame, altitude_m, delta_h_m)
        measurements = detect_shadows(
            frame.image,
            range_m=frame.range_m,
            beam_azimuth_rad=frame.beam_azimuth_rad,
            config=self.config,
        )
        detections = []
        for m in measurements:
            north, east = seabed_position(
                m,
                altitude_m=altitude,
                north_m=frame.north_m,
                east_m=frame.east_m,
                heading_rad=frame.heading_rad,
            )
            centre = seabed_centre(
                m,
                altitude_m=altitude,
                north_m=frame.north_m,
                east_m=frame.east_m,
                heading_rad=frame.heading_rad,
                config=self.config.tracking,
            )
            detections.append(
                Detection(
                    frame_index=self._n_frames,
                    measurement=m,
                    altitude_m=altitude,
                    delta_h_m=delta,
                    north_m=north,
                    east_m=east,
                    centre_north_m=centre.north_m,
                    centre_east_m=centre.east_m,
                    gate_m=centre.gate_m,
                    height_guess_m=centre.height_guess_m,
                )
            )
        ids = self._tracker.update(detections)
        result = FrameResult(
            frame_index=self._n_frames,
            timestamp_s=frame.timestamp_s,
            altitude_m=altitude,
            delta_h_m=delta,
            measurements=measurements,
            target_ids=tuple(ids),
        )
        self._n_frames += 1
        return result

    def targets(self) -> list[TargetHeight]:
        """Every target so far with its height (or the reason there is none)."""
        tracks = self._tracker.tracks
        shared = self.shared_reference_altitude() if self.config.shared_altitude else None
        return [
            self._solve(track.track_id, track.detections, shared, track.position_m()[:2])
            for track in tracks
        ]

    def shared_reference_altitude(self) -> tuple[float, float] | None:
        """The first frame's altitude and its 1-sigma, m, solved from all targets together.

        Each target seen at two or more altitudes without absolute altitudes gives its own
        reference altitude (:func:`solve_height`); their inverse-variance mean, after
        dropping those more than 3 sigma from the median, is returned with its sigma
        (widened by the scatter). None when fewer than two targets give one.
        """
        values, sigmas = [], []
        for track in self._tracker.tracks:
            usable = [d for d in track.detections if d.measurement.usable]
            if len(usable) < max(2, self.config.min_frames):
                continue
            if all(math.isfinite(d.altitude_m) for d in usable):
                continue
            try:
                estimate = self._height_of(usable, None)
            except SolverError:
                continue
            if math.isfinite(estimate.ref_altitude_m) and estimate.ref_altitude_std_m > 0:
                values.append(estimate.ref_altitude_m)
                sigmas.append(estimate.ref_altitude_std_m)
        if len(values) < 2:
            return None
        h0, sig = np.array(values), np.array(sigmas)
        keep = np.abs(h0 - np.median(h0)) <= 3 * np.maximum(sig, 1e-6)
        if np.count_nonzero(keep) < 2:
            return None
        h0, sig = h0[keep], sig[keep]
        w = 1.0 / sig**2
        mean = float(np.sum(w * h0) / np.sum(w))
        chi2 = float(np.sum(w * (h0 - mean) ** 2)) / (h0.size - 1)
        std = math.sqrt(max(1.0, chi2) / float(np.sum(w)))
        return mean, std

    def _solve(
        self,
        target_id: int,
        detections: list[Detection],
        shared: tuple[float, float] | None,
        position_m: tuple[float, float] = (math.nan, math.nan),
    ) -> TargetHeight:
        cfg = self.config
        first = min(detections, key=lambda d: d.frame_index)
        usable = self._without_outliers([d for d in detections if d.measurement.usable])
        height: float | None = None
        std: float | None = None
        ref: float | None = None
        rms: float | None = None
        reason: str | None = None
        if len(usable) < cfg.min_frames:
            cut = [d.measurement.reason for d in detections if not d.measurement.usable]
            reason = (
                f"complete shadow in {len(usable)} frame(s), {cfg.min_frames} needed"
                + (f" ({cut[0]})" if cut and cut[0] else "")
            )
        else:
            try:
                estimate = self._height_of(usable, shared)
            except SolverError as exc:
                reason = str(exc)
            else:
                height = estimate.height_m
                ref, rms = estimate.ref_altitude_m, estimate.residual_rms_m
                # Model error: frames that disagree beyond their range noise (a rounded
                # target's shadow-casting point moves with the viewpoint) widen the sigma.
                std = math.hypot(estimate.height_std_m, rms)
        m = first.measurement
        if not all(math.isfinite(v) for v in position_m):
            position_m = (first.north_m, first.east_m)
        return TargetHeight(
            target_id=target_id,
            first_frame_index=first.frame_index,
            azimuth_rad=m.azimuth_rad,
            range_m=m.r_top_m,
            shadow_end_m=m.r_end_m,
            north_m=position_m[0],
            east_m=position_m[1],
            height_m=height,
            height_std_m=std,
            ref_altitude_m=ref,
            residual_rms_m=rms,
            frames_seen=len(detections),
            frames_used=len(usable) if height is not None else 0,
            reason=reason,
            detections=tuple(detections),
        )

    def _without_outliers(self, usable: list[Detection]) -> list[Detection]:
        """``usable`` without the frames whose one-frame height is an outlier (config)."""
        cfg = self.config
        guesses = np.array([d.height_guess_m for d in usable])
        finite = np.isfinite(guesses)
        if np.count_nonzero(finite) < 4:
            return usable
        median = float(np.median(guesses[finite]))
        mad = float(np.median(np.abs(guesses[finite] - median)))
        limit = max(cfg.outlier_sigmas * 1.4826 * mad, cfg.outlier_floor_m + cfg.outlier_floor_fraction * median)
        return [d for d, g in zip(usable, guesses, strict=True) if not abs(g - median) > limit]

    def _height_of(
        self, usable: list[Detection], shared: tuple[float, float] | None
    ) -> HeightEstimate:
        cfg = self.config
        known_altitude = all(math.isfinite(d.altitude_m) for d in usable)
        if not known_altitude and not all(math.isfinite(d.delta_h_m) for d in usable):
            raise SolverError(
                "no altitude information: frames have neither altitude_m nor an altitude "
                "change (sonar_depth_m or a given delta_h)"
            )
        if not known_altitude and shared is not None:
            return self._height_with_shared_altitude(usable, shared)
        observations = [
            ShadowObservation(
                r_top_m=d.measurement.r_top_m,
                r_end_m=d.measurement.r_end_m,
                sigma_r_m=d.measurement.sigma_r_m,
                delta_h_m=d.delta_h_m if math.isfinite(d.delta_h_m) else 0.0,
                altitude_m=d.altitude_m if known_altitude else math.nan,
            )
            for d in usable
        ]
        cov = None
        if cfg.delta_h_std_m is not None and not known_altitude:
            cov = np.full(len(observations), cfg.delta_h_std_m**2)
        return solve_height(observations, delta_h_cov_m2=cov, altitude_std_m=cfg.altitude_std_m)

    def _height_with_shared_altitude(
        self, usable: list[Detection], shared: tuple[float, float]
    ) -> HeightEstimate:
        """Height with altitudes ``H0 + dH_i`` from the shared reference altitude ``H0``."""
        h0, h0_std = shared
        observations = [
            ShadowObservation(
                r_top_m=d.measurement.r_top_m,
                r_end_m=d.measurement.r_end_m,
                sigma_r_m=d.measurement.sigma_r_m,
                delta_h_m=d.delta_h_m,
                altitude_m=h0 + d.delta_h_m,
            )
            for d in usable
        ]
        estimate = solve_height(observations)
        # An error of H0 is common to all frames: it shifts the height by u * dH0.
        u = float(np.mean([(o.r_end_m - o.r_top_m) / o.r_end_m for o in observations]))
        return replace(
            estimate,
            height_std_m=math.hypot(estimate.height_std_m, u * h0_std),
            ref_altitude_m=h0,
            ref_altitude_std_m=h0_std,
        )
