"""The mosaic of a simulated dive against the scene's truth (issue #9).

Frames come from the simulator's renderer (:class:`sim_harness.sonar.renderer.SonarRenderer`: beam
pattern, occlusion shadows, gamma speckle drawn anew every ping, a seabed reflectivity
texture fixed in the world), taken at true poses along a two-lane lawnmower at 1 m
altitude with the sonar tilted 25 deg down, and fed to :class:`MosaicBuilder` at 1 cm.

What "a target's position in the mosaic" means here. A forward-looking sonar does not know
the elevation of an echo: the mosaic puts every echo on the seabed plane, so a point at
height ``h`` lands ``~ H h / g`` nearer the sonar than it lies (layover; altitude ``H``,
ground range ``g``), and a raised target's echo is its near face and top, not its centre.
The markers are therefore low, strongly reflecting tiles (4 cm square, 5 mm high, -5 dB
backscatter against sand's -27 dB), whose layover is ~2 mm and whose echo covers the tile
itself. The measured position is the centroid of the tile's blob in the mosaic: the cells
within 15 cm of the truth brighter than their surroundings by more than half the blob's
peak excess, weighted by that excess. No height correction is applied.

Navigation drift is injected into the pose the frames REPORT (the renderer always sees
the truth), growing along the distance travelled in one fixed direction, as dead
reckoning does. Registration puts a later pass back onto what an earlier pass mapped, so
it cannot remove the drift the first pass already had: the map's error after registration
is that first pass's drift. Two drift profiles show both sides of that:

- a DVL with a slowly drifting heading reference: drift ~ distance squared, 1.2 cm by the
  end of the first pass over the markers, 10 cm at the end of the dive: the markers land
  within 3 cm with registration and beyond 3 cm without;
- drift proportional to distance (10 cm at the end): registration brings each marker back
  to where the first pass put it (within 1.5 cm), but not closer to the truth than that.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest

from perception.heights.pipeline import detect_shadows
from perception.mapping.builder import MosaicBuilder, masks_from_shadows
from perception.mapping.mosaic import MosaicConfig
from perception.mapping.registration import RegistrationConfig
from perception.sonar_io.frame import SonarFrame
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.world.materials import MATERIALS, Material
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import Seabed, TargetSpec, World

RES_M = 0.01
ALTITUDE_M = 1.0
TILT_RAD = math.radians(25.0)
SEABED_DEPTH_M = 10.0
PING_INTERVAL_S = 0.1
SPEED_M_S = 0.75
#: Lane 1 runs north along east -0.3 m, lane 2 back south along east +0.3 m (sonar positions).
LANE_EAST_M = (-0.3, 0.3)
LANE1_NORTH_M = (-1.0, 9.5)
LANE2_NORTH_M = (9.5, 3.5)
MARKER_NORTH_M = (2.0, 3.5, 5.0, 6.5)
MARKER_EAST_M = (-0.25, 0.0, 0.25)
MARKER_SIZE_M = 0.04
MARKER_HEIGHT_M = 0.005
MARKER = Material("marker", -5.0, 1.0)
#: Direction (north, east) of the injected drift.
DRIFT_DIRECTION = (0.8, -0.6)
DRIFT_END_M = 0.10
SEARCH_RADIUS_M = 0.15


@dataclass(frozen=True)
class Dive:
    """Frames rendered at true poses, the distance travelled at each, and the markers' truth."""

    frames: tuple[SonarFrame, ...]
    lane: tuple[int, ...]
    travelled_m: tuple[float, ...]
    markers: tuple[tuple[float, float], ...]

    @property
    def length_m(self) -> float:
        """Distance travelled by the end of the dive, m."""
        return self.travelled_m[-1]


def _lawnmower() -> list[tuple[int, float, float, float]]:
    """(lane, north, east, heading) of the sonar at each ping."""
    step = SPEED_M_S * PING_INTERVAL_S
    poses = []
    for lane, (start, stop), east, heading in ((0, LANE1_NORTH_M, LANE_EAST_M[0], 0.0),
                                                (1, LANE2_NORTH_M, LANE_EAST_M[1], math.pi)):
        n = round(abs(stop - start) / step) + 1
        poses += [(lane, float(north), east, heading) for north in np.linspace(start, stop, n)]
    return poses


def render_dive(*, texture: SeabedTexture | None, markers: bool = True,
                extra_targets: tuple[TargetSpec, ...] = ()) -> Dive:
    """Render the lawnmower over a flat sandy seabed with the low markers (see module docstring)."""
    spots = tuple((n, e) for n in MARKER_NORTH_M for e in MARKER_EAST_M) if markers else ()
    targets = tuple(
        TargetSpec(f"M{i}", "box", n, e, MARKER_SIZE_M, MARKER_SIZE_M, MARKER_HEIGHT_M, material="marker")
        for i, (n, e) in enumerate(spots)
    ) + extra_targets
    world = World(Seabed(SEABED_DEPTH_M, texture=texture), targets, {**MATERIALS, "marker": MARKER})
    renderer = SonarRenderer(world, SonarConfig(samples_per_beam=500))
    frames, lanes, travelled = [], [], []
    distance = 0.0
    last: tuple[float, float] | None = None
    for k, (lane, north, east, heading) in enumerate(_lawnmower()):
        if last is not None:
            distance += math.hypot(north - last[0], east - last[1])
        last = (north, east)
        pose = SonarPose(north, east, SEABED_DEPTH_M - ALTITUDE_M, heading_rad=heading, tilt_rad=TILT_RAD)
        frame, _ = renderer.render(pose, k * PING_INTERVAL_S)
        frames.append(frame)
        lanes.append(lane)
        travelled.append(distance)
    return Dive(tuple(frames), tuple(lanes), tuple(travelled), spots)


def drift_quadratic(travelled_m: float, length_m: float) -> float:
    """Drift of dead reckoning on a slowly drifting heading: ~ distance squared, m."""
    return DRIFT_END_M * (travelled_m / length_m) ** 2


def drift_linear(travelled_m: float, length_m: float) -> float:
    """Drift proportional to the distance travelled, m."""
    return DRIFT_END_M * travelled_m / length_m


def build(dive: Dive, *, registration: RegistrationConfig | None,
          drift: Callable[[float, float], float] | None = None, shadow_masks: bool = False) -> MosaicBuilder:
    """Mosaic the dive with the navigation drifted by ``drift(travelled, length)``."""
    builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M), registration)
    for frame, travelled in zip(dive.frames, dive.travelled_m, strict=True):
        d = drift(travelled, dive.length_m) if drift is not None else 0.0
        reported = frame.with_fields(north_m=frame.north_m + DRIFT_DIRECTION[0] * d,
                                     east_m=frame.east_m + DRIFT_DIRECTION[1] * d)
        masks = {}
        if shadow_masks:
            found = detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
            m = masks_from_shadows(found, range_m=frame.range_m, n_beams=frame.n_beams,
                                   beam_azimuth_rad=frame.beam_azimuth_rad, image=frame.image)
            masks = {"exclude_mask": m.shadow, "unreliable_mask": m.target}
        builder.add_frame(reported, **masks)
    return builder


def marker_positions(builder: MosaicBuilder, spots: tuple[tuple[float, float], ...]) -> np.ndarray:
    """(north, east) of each marker's blob in the mosaic, m, shape (n, 2) (module docstring)."""
    mean, weight, row0, col0 = builder.mosaic.raster()
    half = int(round(SEARCH_RADIUS_M / RES_M))
    out = []
    for north, east in spots:
        r = int(math.floor(north / RES_M)) - row0
        c = int(math.floor(east / RES_M)) - col0
        win = mean[r - half : r + half + 1, c - half : c + half + 1].astype(np.float64)
        covered = weight[r - half : r + half + 1, c - half : c + half + 1] > 0.2
        assert covered.mean() > 0.9, f"marker at ({north}, {east}) is not covered by the mosaic"
        excess = np.where(covered, win - np.median(win[covered]), 0.0)
        excess[excess < 0.5 * excess.max()] = 0.0
        rows, cols = np.nonzero(excess)
        w = excess[rows, cols]
        out.append(((np.sum(rows * w) / w.sum() + r - half + row0 + 0.5) * RES_M,
                    (np.sum(cols * w) / w.sum() + c - half + col0 + 0.5) * RES_M))
    return np.asarray(out)


def position_errors(builder: MosaicBuilder, dive: Dive) -> np.ndarray:
    """Horizontal distance of each marker's blob from its true place, m."""
    return np.hypot(*(marker_positions(builder, dive.markers) - np.asarray(dive.markers)).T)


def first_pass_drift(dive: Dive, drift: Callable[[float, float], float]) -> np.ndarray:
    """Per marker, the largest drift lane 1 had while the marker lay in its footprint, m."""
    out = []
    for north, east in dive.markers:
        seen = [drift(s, dive.length_m) for f, lane, s in zip(dive.frames, dive.lane, dive.travelled_m, strict=True)
                if lane == 0 and _in_footprint(f, north, east)]
        out.append(max(seen))
    return np.asarray(out)


def _in_footprint(frame: SonarFrame, north: float, east: float) -> bool:
    """Whether the seabed point lies inside the frame's beam (true pose, flat seabed)."""
    dn, de = north - frame.north_m, east - frame.east_m
    forward = dn * math.cos(frame.heading_rad) + de * math.sin(frame.heading_rad)
    side = -dn * math.sin(frame.heading_rad) + de * math.cos(frame.heading_rad)
    depression = math.atan2(ALTITUDE_M, math.hypot(forward, side))
    slant = math.sqrt(forward**2 + side**2 + ALTITUDE_M**2)
    return (forward > 0 and abs(math.atan2(side, forward)) < frame.beam_azimuth_rad[-1]
            and abs(depression - TILT_RAD) < frame.elevation_aperture_rad / 2 and slant < frame.window_m[1])


@pytest.fixture(scope="module")
def textured_dive() -> Dive:
    return render_dive(texture=SeabedTexture(std_db=3.0, correlation_m=0.1, seed=5))


@pytest.fixture(scope="module")
def bare_dive() -> Dive:
    """The same dive over a seabed with no texture: only speckle and the markers."""
    return render_dive(texture=None)


@pytest.mark.slow
def test_markers_land_on_their_truth_within_two_centimetres(textured_dive):
    """True navigation: every marker's blob within 2 cm of its place (and the mean bias small),
    with or without registration (which, with nothing to correct, must not add an error)."""
    errors = position_errors(build(textured_dive, registration=None), textured_dive)
    assert errors.max() <= 0.02, errors
    assert errors.mean() <= 0.01, errors
    registered = build(textured_dive, registration=RegistrationConfig())
    assert registered.drift is not None and math.hypot(registered.drift.north_m, registered.drift.east_m) <= 0.015
    assert position_errors(registered, textured_dive).max() <= 0.02


@pytest.mark.slow
def test_registration_brings_ten_centimetres_of_drift_back_within_three(textured_dive):
    """Drift ~ distance squared to 10 cm: registration <= 3 cm, without it some marker > 3 cm."""
    without = position_errors(build(textured_dive, registration=None, drift=drift_quadratic), textured_dive)
    builder = build(textured_dive, registration=RegistrationConfig(), drift=drift_quadratic)
    with_registration = position_errors(builder, textured_dive)
    assert builder.drift is not None and builder.drift.accepted >= 10
    # the correction found at the end is the drift accumulated since lane 1 mapped the place
    truth = drift_quadratic(textured_dive.length_m, textured_dive.length_m) * np.asarray(DRIFT_DIRECTION)
    assert math.hypot(-builder.drift.north_m - truth[0], -builder.drift.east_m - truth[1]) <= 0.03
    assert with_registration.max() <= 0.03, with_registration
    assert without.max() > 0.03, without
    assert with_registration.max() < 0.5 * without.max()


@pytest.mark.slow
def test_registration_puts_later_passes_back_onto_the_first(textured_dive):
    """Drift ~ distance: each marker ends no farther from its truth than lane 1's drift
    there plus the registration's own error (1.5 cm): the first pass is the anchor."""
    builder = build(textured_dive, registration=RegistrationConfig(), drift=drift_linear)
    errors = position_errors(builder, textured_dive)
    anchored = first_pass_drift(textured_dive, drift_linear)
    without = position_errors(build(textured_dive, registration=None, drift=drift_linear), textured_dive)
    assert np.all(errors <= anchored + 0.015), (errors, anchored)
    assert errors.mean() < without.mean() - 0.01, (errors, without)


@pytest.mark.slow
def test_markers_alone_are_enough_to_register(bare_dive):
    """Without seabed texture the low markers (layover ~2 mm, no shadow) carry the registration."""
    without = position_errors(build(bare_dive, registration=None, drift=drift_quadratic), bare_dive)
    builder = build(bare_dive, registration=RegistrationConfig(), drift=drift_quadratic)
    errors = position_errors(builder, bare_dive)
    assert builder.drift is not None and builder.drift.accepted >= 2
    assert errors.max() <= 0.03, errors
    assert without.max() > 0.03, without


#: Raised targets in the lanes' overlap, 8-20 cm high: seen from the two lanes their echoes
#: lie ``2 H h / g`` apart (up to ~18 cm), in the look direction.
RAISED = (
    TargetSpec("C", "cylinder", 3.0, 0.1, 0.2, 0.2, 0.15, material="metal"),
    TargetSpec("R", "rock", 4.5, -0.15, 0.4, 0.3, 0.2, material="rock", seed=4),
    TargetSpec("B", "box", 6.0, 0.2, 0.5, 0.3, 0.1, yaw_rad=0.35, material="concrete"),
    TargetSpec("S", "stone", 7.0, -0.1, 0.25, 0.2, 0.08, material="rock"),
)


@pytest.fixture(scope="module")
def raised_dive() -> Dive:
    """True navigation over a seabed with no texture and the raised targets only."""
    return render_dive(texture=None, markers=False, extra_targets=RAISED)


@pytest.mark.slow
def test_raised_targets_do_not_pull_the_registration(raised_dive):
    """The only features that correlate are the raised targets, displaced by layover: every
    correction they suggest is wrong, and the quality test refuses them (the estimate stays
    within 1 cm of the true zero drift), even without the segmentation's masks. Without its
    object screen (dark shadows and their surroundings left out) the same dive is pulled
    by more than 5 cm: the trap is real."""
    guarded = build(raised_dive, registration=RegistrationConfig())
    assert guarded.drift is not None
    assert math.hypot(guarded.drift.north_m, guarded.drift.east_m) <= 0.01
    unscreened = build(raised_dive, registration=RegistrationConfig(outlier_sigmas=0.0))
    assert unscreened.drift is not None
    assert math.hypot(unscreened.drift.north_m, unscreened.drift.east_m) > 0.05


@pytest.mark.slow
def test_shadow_masks_keep_shadows_out_and_registration_quiet(raised_dive):
    """With the masks the height pipeline's shadows give, the targets' shadows leave the
    blend (the seabed just beyond each target, which lane 1 saw in shadow and lane 2 lit,
    is brighter than without the masks) and the registration still refuses the layover."""
    masked = build(raised_dive, registration=RegistrationConfig(), shadow_masks=True)
    plain = build(raised_dive, registration=None)
    assert masked.drift is not None
    assert math.hypot(masked.drift.north_m, masked.drift.east_m) <= 0.01
    m_mean, m_weight, row0, col0 = masked.mosaic.raster()
    p_mean, p_weight, prow0, pcol0 = plain.mosaic.raster()
    assert (row0, col0) == (prow0, pcol0)
    brighter = []
    for target in RAISED:
        # the seabed a lane-1 (northbound) ping sees shadowed just north of the target
        r = int(math.floor((target.north_m + target.length_m) / RES_M)) - row0
        c = int(math.floor(target.east_m / RES_M)) - col0
        block = (slice(r, r + 10), slice(c - 3, c + 4))
        both = (m_weight[block] > 0) & (p_weight[block] > 0)
        brighter.append(float(np.mean(m_mean[block][both]) - np.mean(p_mean[block][both])))
    # the two tallest (15 and 20 cm) cast shadows long enough to matter: > 10 grey levels
    assert brighter[0] > 10 and brighter[1] > 10, brighter
    assert min(brighter) > -1.0, brighter
