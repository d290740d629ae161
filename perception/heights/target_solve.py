"""One target's height from its detections: Eq. 2's solve, its honest sigma, and the shadow-start model.

:class:`TargetSolver` solves a target from its detections over frames (split from
:class:`perception.heights.pipeline.HeightPipeline`):

- frames whose one-frame height is an outlier are left out (``HeightsConfig.outlier_*``);
- the N-frame least squares (:func:`perception.heights.least_squares.solve_height`) with
  the frames' altitudes (known, or the shared reference altitude plus each frame's change);
- the sigma holds the range noise, the frames' disagreement, a systematic offset of the
  edges per altitude (``HeightsConfig.edge_bias_samples``) and, for a rounded top, the
  rounded-top model's gap (``HeightsConfig.rounded_targets``);
- with altitudes and two or more of them, whether the shadow starts at the far top edge
  or at the near foot (:mod:`perception.heights.near_foot`).

A target without a height says why, frame by frame (``TargetHeight.frame_reasons``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from perception.errors import SolverError
from perception.heights.config import HeightsConfig
from perception.heights.least_squares import HeightEstimate, ShadowObservation, solve_height
from perception.heights.models import altitude_groups
from perception.heights.near_foot import EndFrame, StartCheck, check_start
from perception.heights.results import TargetHeight
from perception.heights.rounded import RoundedTopFit, fit_rounded_top, grazing_tan2, summit_from_near_echo
from perception.tracking.tracker import Detection

#: Recordings up to this many frames have a reason for every frame a target is missing from.
EVERY_FRAME_UP_TO = 20
#: ``TargetHeight.shadow_start`` of a rounded top whose summit came from its echo's start.
ROUNDED_TOP = "rounded top"


class TargetSolver:
    """Solves targets' heights (module docstring).

    Parameters
    ----------
    config : HeightsConfig
    sample_m : mapping of int to float
        Range sample spacing of each frame by frame index, m (read when solving; the
        pipeline adds frames to it).
    beam_rad : mapping of int to float, optional
        Mean beam spacing of each frame by frame index, rad (as ``sample_m``; without it
        no rounded top's summit comes from its echo's start).
    """

    def __init__(self, config: HeightsConfig, sample_m: Mapping[int, float],
                 beam_rad: Mapping[int, float] | None = None):
        self.config = config
        self._sample_m = sample_m
        self._beam_rad = {} if beam_rad is None else beam_rad

    def solve(
        self,
        target_id: int,
        detections: list[Detection],
        shared: tuple[float, float] | None,
        position_m: tuple[float, float] = (math.nan, math.nan),
        *,
        n_frames: int | None = None,
    ) -> TargetHeight:
        """The target's height from its ``detections`` (or why there is none).

        Parameters
        ----------
        target_id : int
        detections : list of Detection
            The target's detections, one per frame it was seen in.
        shared : (float, float) or None
            The shared reference (first frame's) altitude and its 1-sigma, m, for frames
            without absolute altitudes.
        position_m : (float, float)
            The target's seabed (north, east), m (NaN: from its first detection).
        n_frames : int, optional
            Frames processed so far (for the reason of a target missing from some).
        """
        cfg = self.config
        start_label = "far top edge"
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
        frame_reasons = self._frame_reasons(detections, usable, n_frames)
        if len(usable) < cfg.min_frames:
            seen = len({d.frame_index for d in detections})
            # "of N" in a short recording only: in a dive the frames before and after the
            # target was in view say nothing about it ("seen in" counts those it was in).
            total = f" of {n_frames}" if n_frames is not None and n_frames <= EVERY_FRAME_UP_TO else ""
            reason = (f"complete shadow in {len(usable)}{total} frame(s), {cfg.min_frames} needed (seen in {seen}): "
                      + summarise_frame_reasons(frame_reasons))
        else:
            try:
                estimate = self.height_of(usable, shared)
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
                    bias_std = self.edge_bias(usable, altitudes).height_std_m
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
                if altitudes is not None and not rounded and cfg.check_start_with_ends:
                    known = all(math.isfinite(d.altitude_m) for d in usable)
                    h_std = (cfg.altitude_std_m or 0.0) if known else (shared[1] if shared is not None else 0.0)
                    check = self._check_start(usable, altitudes, h_std)
                    if check is not None and check.use_ends:
                        height, std, start_label = check.fit.height_m, check.fit.height_std_m, check.label
                if rounded_top and cfg.rounded_near_echo and altitudes is not None and not rounded \
                        and start_label == "far top edge":
                    summit = self._near_echo_summit(usable, altitudes)
                    if summit > height:
                        # The sharp-edge height is the grazing point's: a lower bound, and the
                        # other reading of a fading echo; the gap joins the sigma.
                        std = math.hypot(std, summit - height)
                        height, rounded, start_label = summit, True, ROUNDED_TOP
        m = first.measurement
        if not all(math.isfinite(v) for v in position_m):
            position_m = (first.north_m, first.east_m)
        return TargetHeight(
            target_id=target_id,
            first_frame_index=first.frame_index,
            azimuth_rad=m.azimuth_rad,
            range_m=m.r_top_m if math.isfinite(m.r_top_m) else m.highlight_range_m,
            shadow_end_m=m.r_end_m if m.usable else math.nan,
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
            shadow_start=start_label,
            frame_reasons=tuple(frame_reasons),
        )

    @staticmethod
    def _frame_reasons(
        detections: list[Detection], usable: list[Detection], n_frames: int | None
    ) -> list[tuple[int, str]]:
        """Per frame without a usable shadow of the target: (frame index, why).

        Every frame of a short recording (up to ``EVERY_FRAME_UP_TO``: the ``heights``
        command's few files); in a long one (a dive) only the frames from the target's
        first detection to its last: the thousands of frames before and after, where it
        was out of view, say nothing about it.
        """
        by_frame = {d.frame_index: d for d in detections}
        kept = {d.frame_index for d in usable}
        if n_frames is not None and n_frames <= EVERY_FRAME_UP_TO:
            frames: range | list[int] = range(n_frames)
        elif by_frame:
            frames = range(min(by_frame), max(by_frame) + 1)
        else:
            frames = []
        out = []
        for i in frames:
            if i in kept:
                continue
            det = by_frame.get(i)
            if det is None:
                out.append((i, "not found there (no shadow at this target's place)"))
            elif not det.measurement.usable:
                out.append((i, det.measurement.reason or "its shadow gave no edges"))
            else:
                out.append((i, "its one-frame height disagrees with the others' (left out as an outlier)"))
        return out

    def _check_start(
        self, usable: list[Detection], altitudes: NDArray[np.float64], altitude_std_m: float
    ) -> StartCheck | None:
        """Whether the shadow starts at the near foot (:func:`check_start`); None with one
        altitude or when the ends give no height."""
        if len(altitude_groups(altitudes)) < 2:
            return None
        cfg = self.config
        ref = usable[0]
        frames, eq2 = [], []
        for d, alt in zip(usable, altitudes.tolist(), strict=True):
            m = d.measurement
            sample = self._sample_m.get(d.frame_index, math.nan)
            per_sample = cfg.ends_range_std_samples * sample if math.isfinite(sample) else 0.0
            sigma_r = math.sqrt(m.sigma_r_m**2 + per_sample**2 + cfg.ends_range_std_m**2)
            offset = 0.0
            moved = (d.sonar_north_m - ref.sonar_north_m, d.sonar_east_m - ref.sonar_east_m)
            bearing = d.heading_rad + m.azimuth_rad
            if all(math.isfinite(v) for v in (*moved, bearing)):
                offset = -(moved[0] * math.cos(bearing) + moved[1] * math.sin(bearing))
            frames.append(EndFrame(m.r_top_m, m.r_end_m, sigma_r, alt, altitude_std_m, offset))
            t, e = m.r_top_m, m.r_end_m
            eq2.append((alt * (e - t) / e, alt * sigma_r * math.sqrt(t * t + e * e) / (e * e)))
        return check_start(frames, eq2)

    def _near_echo_summit(self, usable: list[Detection], altitudes: NDArray[np.float64]) -> float:
        """The half-ellipsoid's summit from the echo's start, the far top edge and the
        shadow's end (:func:`summit_from_near_echo`), per altitude group on its mean ranges,
        averaged over the groups. NaN when a group gives none (its ranges fit no
        half-ellipsoid: the other groups' are not trusted alone either), or when the body a
        group makes is longer along the ray than ``rounded_max_length_over_width`` times the
        target's width across it (from the shadow's beams): no rounded body, but a short,
        tall block whose front face's echo starts early."""
        ranges = np.array([(d.measurement.highlight_range_m, d.measurement.r_top_m, d.measurement.r_end_m,
                            d.measurement.shadow_width_beams * self._beam_rad.get(d.frame_index, math.nan))
                           for d in usable])
        summits = []
        for g in altitude_groups(altitudes):
            near, top, end, width_rad = np.mean(ranges[g], axis=0)
            body = summit_from_near_echo(float(np.mean(altitudes[g])), near, top, end)
            half_width = 0.5 * width_rad * top
            if not body.half_length_m <= self.config.rounded_max_length_over_width * half_width:
                return math.nan
            summits.append(body.height_m)
        return float(np.mean(summits)) if summits else math.nan

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

    def edge_bias(self, usable: list[Detection], altitudes: NDArray[np.float64] | None) -> HeightEstimate:
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

    def height_of(self, usable: list[Detection], shared: tuple[float, float] | None) -> HeightEstimate:
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


def summarise_frame_reasons(frame_reasons: list[tuple[int, str]], *, max_groups: int = 6) -> str:
    """One line for a target's per-frame reasons: runs of frames with the same reason
    joined (``frames 3-7: ...``), at most ``max_groups`` of them, then how many more."""
    groups: list[tuple[int, int, str]] = []
    for i, why in frame_reasons:
        if groups and groups[-1][2] == why and groups[-1][1] == i - 1:
            groups[-1] = (groups[-1][0], i, why)
        else:
            groups.append((i, i, why))
    parts = [f"frame {a}: {why}" if a == b else f"frames {a}-{b}: {why}" for a, b, why in groups[:max_groups]]
    if len(groups) > max_groups:
        rest = sum(b - a + 1 for a, b, _ in groups[max_groups:])
        parts.append(f"and {rest} more frame(s)")
    return "; ".join(parts)
