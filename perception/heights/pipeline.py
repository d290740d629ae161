"""From sonar frames to seabed targets with heights: the whole perception chain.

Per frame: segmentation (:mod:`perception.shadows.segmentation.segment`), Algorithm 1's pairing
(:mod:`perception.shadows.pairing.pair`), the shadow edges
(:mod:`perception.shadows.measurement.measure`); across frames:
association (:mod:`perception.tracking.tracker`); per target: the N-frame height solver
(:func:`perception.heights.solver.solve_height`).

:class:`HeightPipeline` is incremental, for use on board during a dive: add one frame at a
time (cost: one segmentation and a few targets' measurements) and ask for the targets at
any time. It keeps only the measurements, never the images.

Altitude information of a frame, first found wins: the ``altitude_m``/``delta_h_m``
passed to :meth:`HeightPipeline.add_frame` (e.g. from the altitude filter), the frame's
``altitude_m``, its ``sonar_depth_m`` (``delta_h = depth_first - depth``). A target's
height uses the absolute altitudes when all its frames have one, else the altitude
changes with one reference altitude shared by all targets, solved from their shadows
together with the seabed onset of each frame (where the steepest ray of the vertical
aperture meets the seabed, :mod:`perception.navigation.seabed_start`), which fixes it far better
than Eq. 2's conditioning lets the shadows do.

Each height's sigma holds the range noise, the frames' disagreement, a systematic
offset of the edges per altitude (``HeightsConfig.edge_bias_samples``) and, for a
target whose echo fades towards its far top edge (a rounded top, whose shadow is cast
from a grazing point below the summit), the rounded-top model's gap
(``HeightsConfig.rounded_targets``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from perception.errors import SolverError
from perception.heights.config import HeightsConfig
from perception.heights.models import (
    OnsetAltitude,
    altitude_groups,
    inverse_variance_mean,
    onset_altitude,
    top_echo_slope_db_per_m,
)
from perception.heights.solver import (
    HeightEstimate,
    RoundedTopFit,
    ShadowObservation,
    fit_rounded_top,
    grazing_tan2,
    solve_height,
)
from perception.shadows.measurement.measure import ShadowMeasurement, measure_pairs
from perception.shadows.pairing.pair import pair_regions
from perception.shadows.segmentation.segment import segment
from perception.sonar_io.frame import SonarFrame
from perception.tracking.tracker import Detection, TargetTracker, seabed_centre, seabed_position

__all__ = [
    "FrameResult",
    "HeightPipeline",
    "HeightsConfig",
    "OnsetAltitude",
    "TargetHeight",
    "altitude_groups",
    "detect_shadows",
    "onset_altitude",
    "top_echo_slope_db_per_m",
]


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
    return tuple(measure_pairs(seg, pairs, range_m=range_m, beam_azimuth_rad=beam_azimuth_rad, config=cfg.measure))


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
    onset_altitude_m : float
        The altitude measured from the seabed onset (``HeightsConfig.seabed_onset_altitude``),
        m; NaN when not measured (altitude given, no onset in the frame, unknown tilt).
    """

    frame_index: int
    timestamp_s: float
    altitude_m: float
    delta_h_m: float
    measurements: tuple[ShadowMeasurement, ...]
    target_ids: tuple[int, ...]
    onset_altitude_m: float = math.nan


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
        its frames (:mod:`perception.tracking.tracker`); NaN without pose.
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
    rounded : bool
        True when the height is a rounded top's summit
        (``HeightsConfig.rounded_summit``), not the sharp-edge solution.
    top_slope_db_per_m : float
        Mean over the used frames of the echo's slope just before the shadow start, dB/m
        (``HeightsConfig.rounded_targets``); NaN when not measured.
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
    rounded: bool = False
    top_slope_db_per_m: float = math.nan


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
        self._onsets: list[OnsetAltitude] = []
        self._sample_m: dict[int, float] = {}
        self._targets_cache: tuple[int, list[TargetHeight]] | None = None

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
        r = frame.range_m
        self._sample_m[self._n_frames] = float(r[-1] - r[0]) / max(r.size - 1, 1)
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
                    top_slope_db_per_m=top_echo_slope_db_per_m(
                        frame.image,
                        m,
                        range_m=frame.range_m,
                        window_m=self.config.rounded_window_m,
                        uint8_db_range=self.config.segmentation.uint8_db_range,
                    )
                    if self.config.rounded_targets
                    else math.nan,
                )
            )
        ids = self._tracker.update(detections)
        onset = None
        if self.config.seabed_onset_altitude and not math.isfinite(altitude) and math.isfinite(delta):
            onset = onset_altitude(frame, frame_index=self._n_frames, delta_h_m=delta, config=self.config)
            if onset is not None:
                self._onsets.append(onset)
        result = FrameResult(
            frame_index=self._n_frames,
            timestamp_s=frame.timestamp_s,
            altitude_m=altitude,
            delta_h_m=delta,
            measurements=measurements,
            target_ids=tuple(ids),
            onset_altitude_m=math.nan if onset is None else onset.altitude_m,
        )
        self._n_frames += 1
        return result

    def targets(self) -> list[TargetHeight]:
        """Every target so far with its height (or the reason there is none).

        Solved once per frame added: a second call before the next frame returns the same
        estimates without solving again (the pitch loop asks several times a second).
        """
        if self._targets_cache is not None and self._targets_cache[0] == self._n_frames:
            return list(self._targets_cache[1])
        tracks = self._tracker.tracks
        shared = self.shared_reference_altitude() if self.config.shared_altitude else None
        solved = [self._solve(track.track_id, track.detections, shared, track.position_m()[:2]) for track in tracks]
        self._targets_cache = (self._n_frames, solved)
        return list(solved)

    def onset_reference_altitude(self) -> tuple[float, float] | None:
        """The first frame's altitude and its 1-sigma from the seabed onsets, m.

        Each frame with an onset gives ``altitude_i - dH_i``; their mean has the range
        noise averaged over the frames and the common (tilt, beam-edge model) error in
        full. None when no frame gave an onset.
        """
        if not self._onsets:
            return None
        refs = np.array([o.altitude_m - o.delta_h_m for o in self._onsets])
        noise = np.array([o.noise_std_m for o in self._onsets])
        common = float(np.mean([o.common_std_m for o in self._onsets]))
        mean = float(np.mean(refs))
        scatter = float(np.std(refs, ddof=1)) if refs.size > 1 else 0.0
        noise_std = max(float(np.sqrt(np.mean(noise**2))), scatter) / math.sqrt(refs.size)
        return mean, math.hypot(common, noise_std)

    def shared_reference_altitude(self) -> tuple[float, float] | None:
        """The first frame's altitude and its 1-sigma, m, solved from all targets together.

        Each target seen at two or more altitudes without absolute altitudes gives its own
        reference altitude (:func:`solve_height`); their inverse-variance mean, after
        dropping those more than 3 sigma from the median, is the shadows' estimate (needs
        two targets). This is the joint least-squares solution of one common altitude
        with every target's height free. The seabed onset's estimate
        (:meth:`onset_reference_altitude`, when ``config.seabed_onset_altitude``) joins
        as one more independent measurement; targets whose own altitude disagrees with it
        by more than 3 sigma are then left out, unless two or more and more than half of
        them disagree (then the onset is left out: a wrong tilt, or a seabed near the
        sonar at another level than under the targets). The sigma is widened by the
        scatter. None when neither source gives an estimate.
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
                bias = self._edge_bias(usable, None)
            except SolverError:
                continue
            if math.isfinite(estimate.ref_altitude_m) and estimate.ref_altitude_std_m > 0:
                values.append(estimate.ref_altitude_m)
                sigmas.append(math.hypot(estimate.ref_altitude_std_m, bias.ref_altitude_std_m))
        h0, sig = np.array(values), np.array(sigmas)
        onset = self.onset_reference_altitude() if self.config.seabed_onset_altitude else None
        if onset is not None:
            agree = np.abs(h0 - onset[0]) <= 3 * np.hypot(sig, onset[1])
            # The onset is well conditioned, a target's own H0 is not (Eq. 2): targets that
            # contradict the onset are the outliers, unless most do (two or more): then the
            # onset is (wrong tilt, a different seabed level near the sonar) and is dropped.
            disagree = int(np.count_nonzero(~agree))
            if not (disagree >= 2 and disagree > h0.size / 2):
                return inverse_variance_mean(np.append(h0[agree], onset[0]), np.append(sig[agree], onset[1]))
        if h0.size < 2:
            return None
        keep = np.abs(h0 - np.median(h0)) <= 3 * np.maximum(sig, 1e-6)
        if np.count_nonzero(keep) < 2:
            return None
        return inverse_variance_mean(h0[keep], sig[keep])

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
        rounded = False
        slopes = [d.top_slope_db_per_m for d in usable if math.isfinite(d.top_slope_db_per_m)]
        slope = float(np.mean(slopes)) if slopes else math.nan
        if len(usable) < cfg.min_frames:
            cut = [d.measurement.reason for d in detections if not d.measurement.usable]
            reason = f"complete shadow in {len(usable)} frame(s), {cfg.min_frames} needed" + (
                f" ({cut[0]})" if cut and cut[0] else ""
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
                # target's shadow-casting point moves with the viewpoint) widen the sigma,
                # as does the edges' systematic offset per altitude.
                altitudes = self._altitudes(usable, estimate, shared)
                try:
                    bias_std = self._edge_bias(usable, altitudes).height_std_m
                except SolverError:
                    bias_std = 0.0
                std = math.hypot(estimate.height_std_m, rms, bias_std)
                fit = None
                if cfg.rounded_targets and altitudes is not None:
                    fit = self._rounded(usable, altitudes, estimate.ref_altitude_std_m)
                rounded_top = cfg.rounded_targets and slope < -cfg.rounded_slope_db_per_m
                significant = fit is not None and (
                    fit.curvature_per_m2 > cfg.rounded_min_sigmas * fit.curvature_std_per_m2
                )
                if fit is not None and cfg.rounded_summit and (rounded_top or significant):
                    height, std = fit.height_m, math.hypot(fit.height_std_m, bias_std)
                    rounded = True
                elif fit is not None and rounded_top:
                    # The far top edge is a grazing point below the summit: about the
                    # rounded fit's summit (when above) and within its sigma; their RMS
                    # is the sharp-edge height's model error.
                    std = math.hypot(std, max(0.0, fit.height_m - height), fit.height_std_m)
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
            rounded=rounded,
            top_slope_db_per_m=slope,
        )

    @staticmethod
    def _altitudes(
        usable: list[Detection], estimate: HeightEstimate, shared: tuple[float, float] | None
    ) -> NDArray[np.float64] | None:
        """Each frame's altitude, m: known, or the shared reference plus dH; None when the
        target's own solve fixed the reference (its altitude and shape are confounded)."""
        if all(math.isfinite(d.altitude_m) for d in usable):
            return np.array([d.altitude_m for d in usable])
        if shared is None:
            return None
        return np.array([estimate.ref_altitude_m + d.delta_h_m for d in usable])

    def _edge_bias(self, usable: list[Detection], altitudes: NDArray[np.float64] | None) -> HeightEstimate:
        """Sigmas of the height and reference altitude from the edges' systematic offset
        (``config.edge_bias_samples``, once per altitude group): the solve of the
        per-altitude mean edges with that range sigma. ``altitudes`` None: dH only."""
        key = np.array([d.delta_h_m for d in usable]) if altitudes is None else altitudes
        sample_m = float(np.mean([self._sample_m.get(d.frame_index, math.nan) for d in usable]))
        sigma = self.config.edge_bias_samples * sample_m
        if not (math.isfinite(sigma) and sigma > 0):
            return HeightEstimate(0.0, 0.0, math.nan, 0.0, len(usable), 0.0)
        observations = []
        for group in altitude_groups(key):
            members = [usable[i] for i in group]
            observations.append(
                ShadowObservation(
                    r_top_m=float(np.mean([d.measurement.r_top_m for d in members])),
                    r_end_m=float(np.mean([d.measurement.r_end_m for d in members])),
                    sigma_r_m=sigma,
                    delta_h_m=float(np.mean([d.delta_h_m for d in members])) if altitudes is None else 0.0,
                    altitude_m=math.nan if altitudes is None else float(np.mean(altitudes[group])),
                )
            )
        return solve_height(observations)

    def _rounded(
        self, usable: list[Detection], altitudes: NDArray[np.float64], altitude_std_m: float
    ) -> RoundedTopFit | None:
        """The rounded-top fit of the target's grazing heights (None when not possible:
        one altitude, or no summit). Per altitude group: the mean grazing height ``H u``
        with the range noise and the edge offset as its sigma; the sigma of the summit
        includes the shift by a 1-sigma change of the reference altitude."""
        groups = altitude_groups(altitudes)
        if len(groups) < 2:
            return None
        top = np.array([d.measurement.r_top_m for d in usable])
        end = np.array([d.measurement.r_end_m for d in usable])
        sigma_r = np.array([d.measurement.sigma_r_m for d in usable])
        sample_m = np.array([self._sample_m.get(d.frame_index, math.nan) for d in usable])
        bias_r = self.config.edge_bias_samples * np.nan_to_num(sample_m)

        def fit(alt: NDArray[np.float64]) -> RoundedTopFit:
            z, sz, t2 = [], [], []
            for g in groups:
                u = (end[g] - top[g]) / end[g]
                noise = alt[g] * np.sqrt(sigma_r[g] ** 2 * (end[g] ** 2 + top[g] ** 2)) / end[g] ** 2
                bias = float(np.mean(alt[g] * bias_r[g] * np.sqrt(end[g] ** 2 + top[g] ** 2) / end[g] ** 2))
                z.append(float(np.mean(alt[g] * u)))
                sz.append(math.hypot(float(np.sqrt(np.mean(noise**2))) / math.sqrt(g.size), bias))
                t2.append(float(np.mean(grazing_tan2(alt[g], end[g]))))
            return fit_rounded_top(z, sz, t2)

        try:
            result = fit(altitudes)
            shift = 0.0
            if altitude_std_m > 0:
                shift = abs(fit(altitudes + altitude_std_m).height_m - result.height_m)
        except SolverError:
            return None
        return replace(result, height_std_m=math.hypot(result.height_std_m, shift))

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

    def _height_of(self, usable: list[Detection], shared: tuple[float, float] | None) -> HeightEstimate:
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

    def _height_with_shared_altitude(self, usable: list[Detection], shared: tuple[float, float]) -> HeightEstimate:
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
