"""On-board processing during the dive: telemetry into the altitude filter and the
navigation history, sonar frames stamped with the vehicle's own navigation, then into the
frame-to-map chain (:class:`perception.mapping.survey_map.SurveyMap`: heights, tracking,
mosaic).

Callers use a few verbs (:meth:`OnboardPerception.listener`, ``drain``,
``process_frames``, ``set_mapping``, ``expect_vertical_motion``, ``set_mount_frame``), the estimates at a time
(``altitude``, ``depth``, ``seabed_depth``, ``nav_at``), the products (``targets``,
``mapped_targets``, ``map_raster``) and a frozen :class:`OnboardStatus` snapshot; they
never reach into its parts.

Only what a real vehicle knows enters here: MAVLink telemetry records (from
:mod:`vehicle_link`) and sonar frames from a sonar source. A simulator's frame may carry
true pose fields; they are overwritten with the navigation the controller received.
Everything runs in the executor's thread; telemetry arrives from the link's I/O thread
through a queue. With ``OnboardConfig.map_process`` the frame-to-map chain runs in a child
process instead (:mod:`perception.mapping.map_process`): the frames of one control cycle are
measured while the controller works, and their results (``last_frame``, the counters,
``tracked_targets``) reach it at the next cycle: always exactly one cycle later, however
busy the machine (the controller waits for them rather than fly on without them).

Mount frame: the mount reports its angle in its own frame (GIMBAL_DEVICE_ATTITUDE_STATUS:
ArduSub's stabilised servo mount, MNT1_TYPE 1, reports its earth-frame target); a frame's
``tilt_rad`` is the body-frame mount angle (frame-format.md). Stamping converts once,
here, with the vehicle's pitch at the ping: body tilt = earth tilt + pitch (tilt positive
down, pitch positive nose up). The executor says which frame the mount uses
(:meth:`OnboardPerception.set_mount_frame`, from MNT1_TYPE); "body" until it does.
"""

from __future__ import annotations

import math
import queue
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from perception.heights.pipeline import FrameResult, TargetHeight
from perception.mapping.heights_layer import MappedTarget
from perception.mapping.map_process import BatchResult, TrackedTarget
from perception.mapping.mosaic import MosaicConfig
from perception.mapping.products import MapRaster
from perception.mapping.registration import RegistrationConfig
from perception.mapping.survey_map import Drift, SurveyMap
from perception.navigation.altitude_filter import AltitudeFilter, AltitudeFilterConfig
from perception.navigation.history import NavigationHistory, NavSample
from perception.sonar_io.frame import SonarFrame
from planner.mission.frame_depth import MAX_DEPTH_STD_M, frame_depth_m
from planner.mission.onboard_map import OnboardMap
from vehicle_link.telemetry import Attitude, GlobalPosition, LocalPositionNed, MountStatus, Rangefinder

_T = TypeVar("_T")


@dataclass(frozen=True)
class OnboardConfig:
    """Sensor noise assumed by the filter and the products' settings.

    Attributes
    ----------
    depth_std_m, altimeter_std_m : float
        1-sigma noise of the depth sensor and of the altimeter, m.
    specific_gravity : float
        Water specific gravity (ArduSub BARO_SPEC_GRAV).
    mosaic_resolution_m : float
        Mosaic cell size, m.
    registration : bool
        Correct navigation drift by registering frames on the mosaic
        (:mod:`perception.mapping.registration`); the height pipeline then places its targets
        with the same correction (:meth:`OnboardPerception.drift_corrected`), so a target
        seen again on the second pass joins its first track. It needs a seabed with
        persistent texture (sand ripples, gravel) and corrects only what drifted since a
        place was first mapped. Its quality test refuses matches on featureless seabed and
        on raised targets' echoes (placed by layover; the measured shadows and targets are
        masked out of it): ``tests/perception/mapping/test_mosaic_render.py``; on a featureless
        seabed it changes nothing. In the default dry-run dive (textured seabed) it found
        (+0.27, +0.18) m where the DVL had drifted by (-0.29, -0.19) m.
    nav_history_s : float
        How much navigation history is kept to stamp frames, s.
    seabed_rate_psd_m2_s3 : float or None
        With a value, the altitude filter's seabed-rate state (``AltitudeFilterConfig``),
        released at every change of ground track
        (:meth:`OnboardPerception.ground_track_changed`). None (default): the seabed a
        random walk in time. On a 3 deg slope the random walk falls behind the rising
        seabed, is gated against and catches up in resets (steps of up to 12 cm), which
        the rate state avoids; but over the default dive's targets it took a target
        passing under the altimeter for the seabed rising (the filter's altitude dipped
        below the pass altitude's band 4-5 times in 240 s), so it stays off until it can tell
        the two apart. The helm's slope lead (``ExecutorConfig.slope_lead_s``) works on
        either.
    seabed_rate_release_std_m_s : float
        The rate's 1-sigma when released, m/s: the steepest slope expected (about 3.4
        deg) at the survey speed (0.5 m/s).
    mosaic_looks : int or None
        Frames blended into the mosaic per seabed cell, about (the others are measured
        but not blended: :mod:`perception.mapping.look_spacing`); None blends every frame.
        At 10 pings/s a cell is in 100-200 pings; projecting all of them at 1 cm was
        two-thirds of the map's work on the harbour-field dive.
    map_process : bool
        Run the frame-to-map chain in a child process (module docstring); close the
        perception with :meth:`OnboardPerception.close`.
    tracked_targets_every_s : float
        With the map process: how often (in frame time) the targets come back with a
        batch for :meth:`OnboardPerception.tracked_targets`, s (the pitch loop reads them
        every 0.5 s: ``ShadowPitchLoop.targets_refresh_s``).
    """

    depth_std_m: float = 0.01
    altimeter_std_m: float = 0.02
    specific_gravity: float = 1.0
    mosaic_resolution_m: float = 0.01
    registration: bool = True
    nav_history_s: float = 30.0
    seabed_rate_psd_m2_s3: float | None = None
    seabed_rate_release_std_m_s: float = 0.03
    mosaic_looks: int | None = 40
    map_process: bool = False
    tracked_targets_every_s: float = 0.5


@dataclass(frozen=True)
class OnboardStatus:
    """What on-board processing has seen so far, at one moment (frozen snapshot).

    Attributes
    ----------
    nav : NavSample or None
        The newest navigation (:meth:`NavigationHistory.latest`).
    last_depth_s, last_altimeter_s : float
        Times of the newest depth and accepted altimeter readings, s (-inf before any).
    last_altimeter_m : float
        The newest accepted altimeter reading, m (NaN before any).
    filter_counters : dict
        Per altitude-filter input: ``{"accepted": n, "rejected": n}``.
    filter_rejected : int
        All rejected filter inputs.
    rejected_records : int
        Telemetry records refused outright (NaN or impossible values).
    frames_used, frames_skipped, frames_mapped : int
        Frames measured, frames skipped (no navigation yet, or unusable), frames blended
        into the mosaic.
    measured_last_frame : int
        Shadows measured in the newest frame.
    drift : Drift or None
        The mosaic's navigation-drift correction so far.
    """

    nav: NavSample | None
    last_depth_s: float
    last_altimeter_s: float
    last_altimeter_m: float
    filter_counters: dict[str, dict[str, int]]
    filter_rejected: int
    rejected_records: int
    frames_used: int
    frames_skipped: int
    frames_mapped: int
    measured_last_frame: int
    drift: Drift | None


class OnboardPerception:
    """Filter, navigation and the frame-to-map chain, fed from telemetry and frames."""

    def __init__(self, config: OnboardConfig | None = None):
        self.config = cfg = config or OnboardConfig()
        self._filter = AltitudeFilter(AltitudeFilterConfig(specific_gravity=cfg.specific_gravity,
                                                           seabed_rate_psd_m2_s3=cfg.seabed_rate_psd_m2_s3,
                                                           initial_seabed_rate_std_m_s=cfg.seabed_rate_release_std_m_s))
        self._nav = NavigationHistory(cfg.nav_history_s)
        self._map = OnboardMap(SurveyMap(mosaic=MosaicConfig(resolution_m=cfg.mosaic_resolution_m),
                                         registration=RegistrationConfig() if cfg.registration else None,
                                         mosaic_looks=cfg.mosaic_looks),
                               process=cfg.map_process, tracked_targets_every_s=cfg.tracked_targets_every_s)
        self._inbox: queue.SimpleQueue[object] = queue.SimpleQueue()
        self._estimates: dict[tuple[str, float], Any] = {}  # _ask's answers (a cycle asks several times)
        self._last_altimeter_s = -math.inf
        self._last_depth_s = -math.inf
        self._last_altimeter_m = math.nan
        #: The executor turns mapping on along the lane runs only: frames from descents,
        #: turns and transits (sonar sweeping sideways, altitude changing) would smear it.
        self._mapping = True
        self._frames_used = 0
        self._frames_skipped = 0
        self._rejected_records = 0
        self._seen_distance_sensor = False
        self._last_frame: FrameResult | None = None
        self._mount_frame = "body"

    # ------------------------------------------------------------------- verbs
    def listener(self, record: object) -> None:
        """Link listener (runs on the I/O thread): only queues the record."""
        self._inbox.put(record)

    def drain(self) -> int:
        """Take every queued telemetry record into the filter and the navigation."""
        n = 0
        while True:
            try:
                record = self._inbox.get_nowait()
            except queue.Empty:
                return n
            self._take_record(record)
            n += 1

    def set_mapping(self, enabled: bool) -> None:
        """Blend frames into the mosaic (lane runs) or not (descents, turns, transits)."""
        self._mapping = bool(enabled)

    def set_mount_frame(self, frame: str) -> None:
        """The frame of the mount's reported angle: "earth" (stabilised) or "body"."""
        if frame not in ("earth", "body"):
            raise ValueError(f"mount frame must be 'earth' or 'body', got {frame!r}")
        self._mount_frame = frame

    def ground_track_changed(self) -> None:
        """Tell the altitude filter that the vehicle starts a new leg, turn or stop: the
        seabed's rate under it is learnt again (:meth:`AltitudeFilter.release_seabed_rate`)."""
        self._estimates.clear()
        self._filter.release_seabed_rate()

    def expect_vertical_motion(self, moving: bool) -> None:
        """Tell the altitude filter that a commanded depth change is (or is no longer) under way."""
        self._estimates.clear()
        self._filter.set_maneuvering(moving)

    def process_frames(self, frames: Sequence[SonarFrame]) -> list[FrameResult]:
        """Stamp, measure and map frames; frames without navigation yet are skipped.

        In thread: the results of ``frames``. With the map process: ``frames`` are sent
        and the results of those sent at the previous call are returned."""
        batch = []
        for raw in frames:
            frame = self.stamp(raw)
            if frame is None:
                self._frames_skipped += 1
                continue
            batch.append((frame, self._mapping))
        return self._account(self._map.add(batch))

    def _account(self, batches: list[BatchResult]) -> list[FrameResult]:
        results = []
        for done in batches:
            for result in done.results:
                if result is None:  # refused by the map (its frame format or geometry)
                    self._frames_skipped += 1
                    continue
                self._frames_used += 1
                self._last_frame = result
                results.append(result)
        return results

    def close(self) -> None:
        """Stop the map process, if any (the products are read before)."""
        self._map.close()

    # ---------------------------------------------------------------- telemetry
    def _in_order(self, time_s: float) -> bool:
        last = self._filter.last_time_s
        return math.isnan(last) or time_s >= last

    def _take_record(self, record: object) -> None:
        self._estimates.clear()  # what the filter said before no longer holds
        try:
            self._take_checked(record, self.config)
        except ValueError:  # NaN or impossible values: the filter refused them, state intact
            self._rejected_records += 1

    def _take_checked(self, record: object, cfg: OnboardConfig) -> None:
        if isinstance(record, GlobalPosition):
            if math.isfinite(record.depth_m) and self._in_order(record.time_s):
                self._filter.update_depth(record.time_s, record.depth_m, cfg.depth_std_m)
                self._last_depth_s = record.time_s
        elif isinstance(record, Rangefinder) and record.is_downward:
            # ArduSub reports one altimeter both as DISTANCE_SENSOR and RANGEFINDER: use one.
            if record.source == "RANGEFINDER" and self._seen_distance_sensor:
                return
            self._seen_distance_sensor |= record.source != "RANGEFINDER"
            if record.in_range and math.isfinite(record.distance_m) and self._in_order(record.time_s):
                result = self._filter.update_altimeter(
                    record.time_s, record.distance_m, cfg.altimeter_std_m, signal_quality=record.signal_quality_pct,
                    min_distance_m=record.min_distance_m, max_distance_m=record.max_distance_m)
                if result.accepted:
                    self._last_altimeter_s = record.time_s
                    self._last_altimeter_m = record.distance_m
        elif isinstance(record, LocalPositionNed):  # frames are placed from these, never an attitude's position
            r = record
            self._nav.add_position(r.time_s, r.north_m, r.east_m, velocity_north_m_s=r.velocity_north_m_s,
                                   velocity_east_m_s=r.velocity_east_m_s)
        elif isinstance(record, Attitude):
            self._nav.add_attitude(record.time_s, record.yaw_rad, record.pitch_rad, record.roll_rad)
        elif isinstance(record, MountStatus):
            self._nav.add_tilt(record.time_s, record.tilt_rad)

    # ---------------------------------------------------------------- estimates
    def status(self) -> OnboardStatus:
        """A frozen snapshot of what has been seen so far."""
        counters = {name: {"accepted": c.accepted, "rejected": c.rejected}
                    for name, c in self._filter.counters.items()}
        last = self._last_frame
        return OnboardStatus(
            nav=self._nav.latest(), last_depth_s=self._last_depth_s, last_altimeter_s=self._last_altimeter_s,
            last_altimeter_m=self._last_altimeter_m, filter_counters=counters,
            filter_rejected=sum(c["rejected"] for c in counters.values()), rejected_records=self._rejected_records,
            frames_used=self._frames_used, frames_skipped=self._frames_skipped,
            frames_mapped=self._map.frames_mapped,
            measured_last_frame=0 if last is None else len(last.measurements), drift=self._map.drift,
        )

    @property
    def nav(self) -> NavSample | None:
        """The newest navigation (the last position reported, attitude and tilt)."""
        return self._nav.latest()

    def nav_at(self, time_s: float) -> NavSample | None:
        """Navigation at ``time_s``: position interpolated, attitude and tilt of the nearest sample."""
        return self._nav.at(time_s)

    def altitude(self, time_s: float) -> tuple[float, float]:
        """(altitude, std) from the filter at ``time_s``; NaN when it cannot say."""
        est = self._ask("altitude_at", time_s)
        return (math.nan, math.nan) if est is None else (float(est.mean), float(est.std))

    def seabed_depth(self, time_s: float) -> tuple[float, float]:
        """(seabed depth, std) from the filter at ``time_s``; NaN when it cannot say."""
        x_p = self._ask("state_at", time_s)
        return (math.nan, math.nan) if x_p is None else (float(x_p[0][2]), float(math.sqrt(max(x_p[1][2, 2], 0.0))))

    def depth(self, time_s: float) -> tuple[float, float]:
        """(vehicle depth, std) from the filter; NaN when it cannot say: outside its window,
        or sure to no better than :data:`~planner.mission.frame_depth.MAX_DEPTH_STD_M` (before
        the first depth reading its prior, split by a first altimeter reading, says -1 m
        +- 70 m for an altitude of 2 m: no depth to hold, to surface from or to stamp)."""
        est = self._ask("depth_at", time_s)
        if est is None or not est.std <= MAX_DEPTH_STD_M:
            return math.nan, (math.nan if est is None else float(est.std))
        return float(est.mean), float(est.std)

    def _ask(self, query: str, time_s: float) -> Any:
        """The filter's ``query(time_s)`` (None if it cannot say), asked once until it changes."""
        key, known = (query, time_s), self._estimates if len(self._estimates) < 64 else {}
        if key not in known:
            try:
                known[key] = getattr(self._filter, query)(time_s)
            except (ValueError, LookupError):
                known[key] = None
            self._estimates = known
        return known[key]

    # ------------------------------------------------------------------ frames
    def stamp(self, frame: SonarFrame) -> SonarFrame | None:
        """The frame with the controller's own navigation and altitude (None: not yet known)."""
        nav = self._nav.at(frame.timestamp_s)
        altitude, _ = self.altitude(frame.timestamp_s)
        depth = frame_depth_m(*self.depth(frame.timestamp_s))
        if nav is None or not (math.isfinite(nav.north_m) and math.isfinite(altitude) and altitude > 0):
            return None
        tilt = frame.tilt_rad
        if math.isfinite(nav.tilt_rad):
            pitch = nav.pitch_rad if math.isfinite(nav.pitch_rad) else 0.0
            tilt = nav.tilt_rad + pitch if self._mount_frame == "earth" else nav.tilt_rad
        return frame.with_fields(
            north_m=nav.north_m, east_m=nav.east_m, heading_rad=nav.heading_rad,
            vehicle_pitch_rad=nav.pitch_rad, vehicle_roll_rad=nav.roll_rad, tilt_rad=tilt,
            altitude_m=altitude, sonar_depth_m=depth,
        )

    @property
    def last_frame(self) -> FrameResult | None:
        """What the newest measured frame showed (None before any)."""
        return self._last_frame

    @property
    def frames_measured(self) -> int:
        """Frames the height pipeline has taken (as of the newest results taken back)."""
        return self._map.frames_measured

    def tracked_targets(self) -> tuple[TrackedTarget, ...]:
        """Every target's height and where it was last seen, as of the newest results
        taken back: what the control loop reads (with the map process, without waiting
        for it)."""
        return self._map.tracked_targets()

    def targets(self) -> list[TargetHeight]:
        """Every target so far with its height (every frame sent taken back first)."""
        return self._after_every_frame(self._map.targets())

    def mapped_targets(self) -> list[MappedTarget]:
        """Targets placed on the map, fragments folded (:meth:`SurveyMap.mapped_targets`)."""
        return self._after_every_frame(self._map.mapped_targets())

    def map_raster(self, targets: list[MappedTarget] | None = None) -> MapRaster | None:
        """The map raster with ``targets`` (default: the mapped ones); None before any frame is mapped."""
        return self._after_every_frame(self._map.raster(targets))

    def _after_every_frame(self, answer: _T) -> _T:
        """``answer`` of a query, with the batches it took back counted (last frame, frames used)."""
        self._account(self._map.take_ready())
        return answer

