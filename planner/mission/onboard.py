"""On-board processing during the dive: telemetry into the altitude filter, sonar frames
stamped with the vehicle's own navigation, shadows into the height pipeline, frames into
the mosaic.

Only what a real vehicle knows enters here: MAVLink telemetry records (from
:mod:`vehicle_link`) and sonar frames from a sonar source. A simulator's frame may carry
true pose fields; they are overwritten with the navigation the controller received.
Everything runs in the executor's thread; telemetry arrives from the link's I/O thread
through a queue.
"""

from __future__ import annotations

import bisect
import math
import queue
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from perception.errors import FrameFormatError, GeometryError
from perception.heights.pipeline import FrameResult, HeightPipeline, HeightsConfig, TargetHeight
from perception.mapping.builder import MosaicBuilder, masks_from_shadows
from perception.mapping.heights_layer import MappedTarget
from perception.mapping.mosaic import MosaicConfig
from perception.mapping.registration import RegistrationConfig
from perception.navigation.altitude_filter import AltitudeFilter, AltitudeFilterConfig
from perception.sonar_io.frame import SonarFrame
from vehicle_link.telemetry import Attitude, GlobalPosition, LocalPositionNed, MountStatus, Rangefinder

#: Longest a frame's position is extrapolated past the newest position report, s.
MAX_EXTRAPOLATION_S = 0.5


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
    """

    depth_std_m: float = 0.01
    altimeter_std_m: float = 0.02
    specific_gravity: float = 1.0
    mosaic_resolution_m: float = 0.01
    registration: bool = True
    nav_history_s: float = 30.0


@dataclass(frozen=True)
class NavSample:
    """The vehicle's navigation at one time, as telemetry gave it (NaN = not yet known)."""

    time_s: float
    north_m: float
    east_m: float
    heading_rad: float
    pitch_rad: float
    roll_rad: float
    tilt_rad: float


class OnboardPerception:
    """Filter, heights and mosaic fed from telemetry and frames (see module docstring)."""

    def __init__(self, config: OnboardConfig | None = None):
        self.config = cfg = config or OnboardConfig()
        self.filter = AltitudeFilter(AltitudeFilterConfig(specific_gravity=cfg.specific_gravity))
        # Every frame carries the filter's altitude: no shared unknown reference to solve.
        self.heights = HeightPipeline(HeightsConfig(shared_altitude=False))
        self.mosaic = MosaicBuilder(
            MosaicConfig(resolution_m=cfg.mosaic_resolution_m),
            RegistrationConfig() if cfg.registration else None,
        )
        self.inbox: queue.SimpleQueue[object] = queue.SimpleQueue()
        self._nav: deque[NavSample] = deque()
        #: LOCAL_POSITION_NED samples alone, (time, north, east, v_north, v_east): frames are
        #: placed from these, never from the position an attitude sample carried along.
        self._positions: deque[tuple[float, float, float, float, float]] = deque()
        self._north = self._east = math.nan
        self._heading = self._pitch = self._roll = math.nan
        self._tilt = math.nan
        self.last_altimeter_s = -math.inf
        self.last_depth_s = -math.inf
        self.last_altimeter_m = math.nan
        #: The executor turns the mosaic on along the lane runs only: frames from descents,
        #: turns and transits (sonar sweeping sideways, altitude changing) would smear it.
        self.mosaic_enabled = True
        self.frames_used = 0
        self.frames_skipped = 0
        self.rejected_records = 0
        self._seen_distance_sensor = False
        self.last_frame_result: FrameResult | None = None

    # -------------------------------------------------------------- telemetry
    def listener(self, record: object) -> None:
        """Link listener (runs on the I/O thread): only queues the record."""
        self.inbox.put(record)

    def drain(self) -> int:
        """Take every queued telemetry record into the filter and the navigation."""
        n = 0
        while True:
            try:
                record = self.inbox.get_nowait()
            except queue.Empty:
                return n
            self._take(record)
            n += 1

    def _in_order(self, time_s: float) -> bool:
        last = self.filter.last_time_s
        return math.isnan(last) or time_s >= last

    def _take(self, record: object) -> None:
        cfg = self.config
        try:
            self._take_checked(record, cfg)
        except ValueError:  # NaN or impossible values: the filter refused them, state intact
            self.rejected_records += 1

    def _take_checked(self, record: object, cfg: OnboardConfig) -> None:
        if isinstance(record, GlobalPosition):
            if math.isfinite(record.depth_m) and self._in_order(record.time_s):
                self.filter.update_depth(record.time_s, record.depth_m, cfg.depth_std_m)
                self.last_depth_s = record.time_s
        elif isinstance(record, Rangefinder) and record.is_downward:
            # ArduSub reports one altimeter both as DISTANCE_SENSOR and RANGEFINDER: use one.
            if record.source == "RANGEFINDER" and self._seen_distance_sensor:
                return
            self._seen_distance_sensor |= record.source != "RANGEFINDER"
            if record.in_range and math.isfinite(record.distance_m) and self._in_order(record.time_s):
                result = self.filter.update_altimeter(
                    record.time_s, record.distance_m, cfg.altimeter_std_m,
                    signal_quality=record.signal_quality_pct,
                    min_distance_m=record.min_distance_m, max_distance_m=record.max_distance_m,
                )
                if result.accepted:
                    self.last_altimeter_s = record.time_s
                    self.last_altimeter_m = record.distance_m
        elif isinstance(record, LocalPositionNed):
            self._north, self._east = record.north_m, record.east_m
            self._push_position(record)
            self._push_nav(record.time_s)
        elif isinstance(record, Attitude):
            self._heading = record.yaw_rad % (2 * math.pi)
            self._pitch, self._roll = record.pitch_rad, record.roll_rad
            self._push_nav(record.time_s)
        elif isinstance(record, MountStatus):
            self._tilt = record.tilt_rad

    def _push_nav(self, time_s: float) -> None:
        sample = NavSample(time_s, self._north, self._east, self._heading, self._pitch, self._roll, self._tilt)
        if self._nav and time_s < self._nav[-1].time_s:
            return
        self._nav.append(sample)
        while self._nav and self._nav[0].time_s < time_s - self.config.nav_history_s:
            self._nav.popleft()

    def _push_position(self, record: LocalPositionNed) -> None:
        if not (math.isfinite(record.north_m) and math.isfinite(record.east_m)):
            return
        if self._positions and record.time_s <= self._positions[-1][0]:
            return
        vn = record.velocity_north_m_s if math.isfinite(record.velocity_north_m_s) else 0.0
        ve = record.velocity_east_m_s if math.isfinite(record.velocity_east_m_s) else 0.0
        self._positions.append((record.time_s, record.north_m, record.east_m, vn, ve))
        while self._positions and self._positions[0][0] < record.time_s - self.config.nav_history_s:
            self._positions.popleft()

    def position_at(self, time_s: float) -> tuple[float, float] | None:
        """(north, east) at ``time_s``, m, from the position reports alone.

        Interpolated between the two reports around ``time_s``; past the newest one,
        extrapolated with its velocity for at most ``MAX_EXTRAPOLATION_S``; before the
        oldest, the oldest. None before any report.

        (:meth:`nav_at` interpolates between navigation samples of either kind, and an
        attitude sample carries the last position reported before it: between two
        position reports its position lags by up to one report interval times the speed.)
        """
        if not self._positions:
            return None
        times = [p[0] for p in self._positions]
        i = bisect.bisect_left(times, time_s)
        if i >= len(times):
            t, n, e, vn, ve = self._positions[-1]
            dt = min(time_s - t, MAX_EXTRAPOLATION_S)
            return n + vn * dt, e + ve * dt
        if i == 0 or times[i] == time_s:
            return self._positions[i][1], self._positions[i][2]
        a, b = self._positions[i - 1], self._positions[i]
        w = (time_s - a[0]) / (b[0] - a[0])
        return a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2])

    @property
    def nav(self) -> NavSample | None:
        """The newest navigation sample."""
        return self._nav[-1] if self._nav else None

    def nav_at(self, time_s: float) -> NavSample | None:
        """Navigation at ``time_s``: positions interpolated, attitude of the nearest sample."""
        if not self._nav:
            return None
        times = [s.time_s for s in self._nav]
        i = bisect.bisect_left(times, time_s)
        if i <= 0:
            return self._nav[0]
        if i >= len(times):
            return self._nav[-1]
        a, b = self._nav[i - 1], self._nav[i]
        w = (time_s - a.time_s) / max(b.time_s - a.time_s, 1e-9)
        near = a if w < 0.5 else b
        return NavSample(
            time_s, a.north_m + w * (b.north_m - a.north_m), a.east_m + w * (b.east_m - a.east_m),
            near.heading_rad, near.pitch_rad, near.roll_rad, near.tilt_rad,
        )

    # ---------------------------------------------------------------- estimates
    def altitude(self, time_s: float) -> tuple[float, float]:
        """(altitude, std) from the filter at ``time_s``; NaN when it cannot say."""
        try:
            est = self.filter.altitude_at(time_s)
        except (ValueError, LookupError):
            return math.nan, math.nan
        return float(est.mean), float(est.std)

    def seabed_depth(self, time_s: float) -> tuple[float, float]:
        """(seabed depth, std) from the filter at ``time_s``; NaN when it cannot say."""
        try:
            x, p = self.filter.state_at(time_s)
        except (ValueError, LookupError):
            return math.nan, math.nan
        return float(x[2]), float(math.sqrt(max(p[2, 2], 0.0)))

    def depth(self, time_s: float) -> tuple[float, float]:
        """(vehicle depth, std) from the filter; NaN when it cannot say."""
        try:
            est = self.filter.depth_at(time_s)
        except (ValueError, LookupError):
            return math.nan, math.nan
        return float(est.mean), float(est.std)

    # ------------------------------------------------------------------ frames
    def stamp(self, frame: SonarFrame) -> SonarFrame | None:
        """The frame with the controller's own navigation and altitude (None: not yet known)."""
        nav = self.nav_at(frame.timestamp_s)
        position = self.position_at(frame.timestamp_s)
        altitude, _ = self.altitude(frame.timestamp_s)
        depth, _ = self.depth(frame.timestamp_s)
        if nav is None or position is None or not (math.isfinite(altitude) and altitude > 0):
            return None
        tilt = nav.tilt_rad if math.isfinite(nav.tilt_rad) else frame.tilt_rad
        return frame.with_fields(
            north_m=position[0], east_m=position[1], heading_rad=nav.heading_rad,
            vehicle_pitch_rad=nav.pitch_rad, vehicle_roll_rad=nav.roll_rad, tilt_rad=tilt,
            altitude_m=altitude, sonar_depth_m=depth,
        )

    def process_frames(self, frames: Sequence[SonarFrame]) -> list[FrameResult]:
        """Stamp, measure and mosaic frames; frames without navigation yet are skipped."""
        results = []
        for raw in frames:
            frame = self.stamp(raw)
            if frame is None:
                self.frames_skipped += 1
                continue
            try:
                result = self.heights.add_frame(self.drift_corrected(frame), altitude_m=frame.altitude_m)
                if self.mosaic_enabled:
                    self._mosaic_frame(frame, result)
            except (FrameFormatError, GeometryError):
                self.frames_skipped += 1
                continue
            self.frames_used += 1
            self.last_frame_result = result
            results.append(result)
        return results

    def drift_corrected(self, frame: SonarFrame) -> SonarFrame:
        """``frame`` moved by the navigation drift registration has found so far.

        The height pipeline places and associates targets with it, so a target seen again
        after the navigation drifted (a second pass) joins its first track instead of
        becoming a second one, and the targets stay on the map where the mosaic puts them.
        Without registration (or before its first accepted match) the frame as it is.
        """
        drift = self.mosaic.drift
        if drift is None or (drift.north_m == 0.0 and drift.east_m == 0.0):
            return frame
        return frame.with_fields(north_m=frame.north_m + drift.north_m, east_m=frame.east_m + drift.east_m)

    def _mosaic_frame(self, frame: SonarFrame, result: FrameResult) -> None:
        """Blend ``frame`` in, its measured shadows left out and its targets not registered.

        The masks come from the shadows the height pipeline has just measured (no second
        segmentation); a frame without any costs nothing extra.
        """
        shadow: np.ndarray | None = None
        target: np.ndarray | None = None
        if result.measurements:
            found = masks_from_shadows(result.measurements, range_m=frame.range_m, n_beams=frame.n_beams,
                                       beam_azimuth_rad=frame.beam_azimuth_rad, image=frame.image)
            shadow, target = found.shadow, found.target
        self.mosaic.add_frame(frame, altitude_m=frame.altitude_m, exclude_mask=shadow, unreliable_mask=target)

    def targets(self) -> list[TargetHeight]:
        """Every target so far with its height."""
        return self.heights.targets()

    def mapped_targets(self, *, fragment_radius_m: float = 0.08) -> list[MappedTarget]:
        """Targets placed on the map (at their estimated centres).

        A track within ``fragment_radius_m`` of a track solved from more frames is a
        fragment of that target (a few frames the tracker could not join): it is folded
        into the stronger one (its id listed in ``fragments``) rather than reported as a
        second target with a weaker height.
        """
        placed = [t for t in self.targets() if math.isfinite(t.north_m) and math.isfinite(t.east_m)]
        placed.sort(key=lambda t: (t.frames_used, t.frames_seen), reverse=True)
        kept: list[tuple[TargetHeight, list[int]]] = []
        for t in placed:
            host = next((k for k in kept if math.hypot(k[0].north_m - t.north_m, k[0].east_m - t.east_m)
                         <= fragment_radius_m), None)
            if host is not None:
                host[1].append(t.target_id)
                continue
            kept.append((t, []))
        return [
            MappedTarget(
                target_id=t.target_id, north_m=t.north_m, east_m=t.east_m,
                height_m=math.nan if t.height_m is None else t.height_m,
                height_std_m=math.nan if t.height_std_m is None else t.height_std_m,
                frames_used=t.frames_used,
                properties={"frames_seen": t.frames_seen, "reason": t.reason, "fragments": fragments},
            )
            for t, fragments in kept
        ]
