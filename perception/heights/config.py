"""Settings of the height pipeline (:class:`perception.heights.pipeline.HeightPipeline`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from perception.shadows.measurement.config import MeasureConfig
from perception.shadows.pairing.pair import PairingConfig
from perception.shadows.segmentation.config import SegmentationConfig
from perception.tracking.tracker import TrackingConfig


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
        (frames with an absolute altitude, :func:`perception.tracking.tracker.seabed_centre`),
        those farther from their median than ``max(outlier_sigmas * 1.4826 * MAD,
        outlier_floor_m + outlier_floor_fraction * median)`` are left out of the solve
        (a shadow measured on one or two beams of a target split in that frame).
    seabed_onset_altitude : bool
        When a frame's absolute altitude is unknown, measure it from where the insonified
        seabed starts in the frame (:func:`perception.navigation.seabed_start.sonar_altitude`: the
        steepest ray of the vertical aperture, from the frame's tilt and attitude) and
        use it, shifted by the frame's altitude change, as one more measurement of the
        shared reference altitude (see :meth:`HeightPipeline.shared_reference_altitude`).
        The shadows alone fix that altitude only through Eq. 2's poor conditioning
        (``H^2 / dH``); the onset fixes it to about 1 %, independent of the shadows.
    onset_angle_std_rad, onset_model_relative_std : float
        1-sigma of the steepest ray's depression (tilt, attitude), rad, and relative
        error of the sharp-beam-edge onset model; both are COMMON to all frames (the same
        mount and beam), so they do not average out over frames.
    edge_bias_samples : float
        1-sigma of the systematic offset of each shadow edge, range samples: the
        sub-sample edges of :mod:`perception.shadows.measurement.measure` are unbiased only for a step between
        flat levels, and speckle texture, the pulse blur of a sloping echo and the
        target's own echo shift them by 0.1-0.4 samples in rendered frames, differently at
        each altitude (the viewing geometry changes). It does not average out over pings
        at one altitude, so it is applied once per ALTITUDE (frames within 10 % of the
        altitude-change spread count as one) and added to every height's and every
        solved reference altitude's sigma. Eq. 2's conditioning makes it the largest term
        of a dH-only solution.
    rounded_targets : bool
        Tell rounded tops from sharp far top edges and make a rounded target's sigma
        honest. A target is ROUNDED when the echo just before its shadow start fades
        towards the edge (mean ``top_slope_db_per_m`` over its frames below
        ``-rounded_slope_db_per_m``): a sharp edge's top echoes at one incidence up to the
        pulse blur, a rounded top's incidence runs to grazing at the tangent point, so its
        backscatter falls continuously. Such a target's far top edge is the ray's grazing
        point, below the summit; its frames are also fitted as grazing points of a
        half-ellipsoid (:func:`perception.heights.solver.fit_rounded_top`: the one-frame heights
        ``H_i u_i`` fall as the ray steepens), which needs two or more altitudes and the
        altitudes (known, or a shared reference altitude), and the fit's summit gap and
        sigma (``hypot(max(0, summit - height), summit sigma)``) join the height's sigma:
        the height stays the sharp-edge one (a lower bound of the summit).
    rounded_summit : bool
        Report the fitted summit instead (``TargetHeight.rounded``) for a rounded target,
        or any target whose curvature exceeds ``rounded_min_sigmas`` sigma. Off by
        default: with two altitudes 0.1 m apart the summit's extrapolation has a sigma of
        0.1-0.6 cm (more than the bias it removes), and in the random scenes (dH up to
        0.3 m) 3 of 164 boxes and cylinders had a significant curvature and were made
        worse. Worth it with a large spread of ``tan^2`` of the grazing angle.
    rounded_near_echo : bool
        For a ROUNDED target (its echo fades towards the edge), report the summit of the
        half-ellipsoid on the seabed that grazes the ray to the shadow's end at the far top
        edge and whose nearest point to the sonar is where the target's echo starts
        (:func:`perception.heights.rounded.summit_from_near_echo`, per altitude on the
        mean ranges): one frame fixes it, so it needs no spread of grazing angles. Used when
        above the sharp-edge height (which the grazing point's is), the gap added to the
        sigma; ``TargetHeight.rounded`` is then True and ``shadow_start`` ``"rounded top"``.
        Needs the altitudes (known, or a shared reference altitude). Off by default: on the
        second forward model's domes, spheres and rocks (held-out seeds) it takes the
        median error from 6.8 % to 2.7 %, but blocks whose echo fades read high with it
        (boxes and cylinders: 95th percentile 11.8 to 18.7 %; the paper's 5 x 4 x 4.7 cm
        block at 60-90 deg to the beams 0.4-0.5 cm high); for sites known to hold rocks,
        stones and tyres (``shadowsurvey heights --rounded-targets``).
    rounded_max_length_over_width : float
        Largest length along the ray over the width across it (from the shadow's beams) of
        the half-ellipsoid ``rounded_near_echo`` finds: a rounded body (stone, rock, dome,
        tyre's tread) is about as long as it is wide; a short, tall block whose echo fades
        (seen corner-on) makes a longer one, its front face's echo starting early.
    rounded_min_sigmas : float
        Significance of the curvature needed to call a target rounded from its heights.
    rounded_slope_db_per_m : float
        Fade of the echo towards the edge (dB per metre, > 0) that marks a rounded top.
        In rendered frames (ARIS, 8 us pulse) sharp edges gave -100..+50 dB/m and the
        3-8 cm stones -400..-500 dB/m (about 1 dB per 2.3 mm sample).
    rounded_window_m : (float, float)
        Range window before the shadow start over which that slope is fitted, m: from
        ``window[0]`` (beyond the pulse blur of the edge) to ``window[1]`` before it.
    check_start_with_ends : bool
        Check the shadow's start against its ends over the altitudes, and take the ends'
        height where they show the start was not the far top edge
        (:mod:`perception.heights.near_foot`).
    ends_range_std_m, ends_range_std_samples : float
        1-sigma of a shadow end's systematic error per frame, m and range samples (added in
        quadrature to its noise), in the ends' triangulation that checks the shadow's start
        (:mod:`perception.heights.near_foot`): it rests on the ends' change with altitude,
        which an end's error of a millimetre (the blur and the edge's slope across the beams
        change with the viewpoint) moves by several per cent of a small target's height.
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
    seabed_onset_altitude: bool = True
    onset_angle_std_rad: float = math.radians(0.5)
    onset_model_relative_std: float = 0.015
    edge_bias_samples: float = 0.3
    rounded_targets: bool = True
    rounded_summit: bool = False
    rounded_near_echo: bool = False
    rounded_max_length_over_width: float = 1.6
    rounded_min_sigmas: float = 3.0
    rounded_slope_db_per_m: float = 250.0
    rounded_window_m: tuple[float, float] = (0.006, 0.020)
    check_start_with_ends: bool = True
    ends_range_std_m: float = 0.0015
    ends_range_std_samples: float = 0.5

    def __post_init__(self) -> None:
        if self.min_frames < 1:
            raise ValueError(f"min_frames must be >= 1, got {self.min_frames}")
        for name in (
            "outlier_sigmas",
            "outlier_floor_m",
            "outlier_floor_fraction",
            "onset_angle_std_rad",
            "onset_model_relative_std",
            "rounded_min_sigmas",
            "rounded_slope_db_per_m",
            "rounded_max_length_over_width",
        ):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        near, far = self.rounded_window_m
        if not (0 <= near < far and math.isfinite(far)):
            raise ValueError(f"rounded_window_m must be (near, far) with 0 <= near < far, got {self.rounded_window_m}")
        if not (math.isfinite(self.edge_bias_samples) and self.edge_bias_samples >= 0):
            raise ValueError(f"edge_bias_samples must be finite and >= 0, got {self.edge_bias_samples}")
