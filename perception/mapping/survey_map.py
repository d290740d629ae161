"""Frames in, 2.5D map out: the one chain from posed sonar frames to targets on a mosaic.

The same chain runs on board during a dive (:class:`planner.mission.onboard.OnboardPerception`
feeds it frames stamped with the vehicle's navigation) and offline (``shadowsurvey
mosaic`` feeds it recorded frames with their pose). Per frame:

1. the frame is moved by the navigation drift that registration has found so far, and
   its shadows are measured and tracked into targets with heights
   (:class:`~perception.heights.pipeline.HeightPipeline`), so that a target seen again
   after the navigation drifted (a second pass) joins its first track;
2. when mapping is on, the frame is blended into the mosaic
   (:class:`~perception.mapping.builder.MosaicBuilder`) with its measured shadows left
   out of the blend and its targets' echoes out of the registration.

Targets go on the map at their estimated centres; a track within
:data:`SAME_TARGET_RADIUS_M` of a track solved from more frames is a fragment of the
same target (a few frames the tracker could not join) and is folded into it.

A frame must carry its pose (``north_m``, ``east_m``, ``heading_rad``, ``tilt_rad``) and
its altitude (``altitude_m``); the caller says where they come from.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from perception.heights.config import HeightsConfig
from perception.heights.pipeline import FrameResult, HeightPipeline, TargetHeight
from perception.mapping.builder import MosaicBuilder, masks_from_shadows
from perception.mapping.heights_layer import MappedTarget
from perception.mapping.look_spacing import LookSpacing
from perception.mapping.mosaic import MosaicConfig, SonarPlacement, TiledMosaic, placement_from_frame
from perception.mapping.products import MapRaster, map_raster
from perception.mapping.projection import check_altitude
from perception.mapping.registration import RegistrationConfig
from perception.sonar_io.frame import SonarFrame

#: Two tracks whose centres lie this close (horizontally, m) are one target: the map folds
#: the weaker into the stronger, and the pitch loop counts one shadow. A track split by
#: the tracker lands within a few centimetres of its twin; the closest distinct targets of
#: the paper's tank stand some 30 cm apart.
SAME_TARGET_RADIUS_M = 0.10


@dataclass(frozen=True)
class Drift:
    """The navigation drift registration has found, m (north, east): what is added to a
    frame's navigation position to put it where the mosaic shows it.

    ``std_m`` is its 1-sigma per axis; ``accepted``/``refused`` count the registrations
    folded in and turned down; ``travelled_m`` is the track length it rests on and
    ``plausible_m`` the largest drift the navigation prior allows after that track.
    """

    north_m: float
    east_m: float
    std_m: float = math.nan
    accepted: int = 0
    refused: int = 0
    travelled_m: float = math.nan
    plausible_m: float = math.nan


@dataclass(frozen=True)
class _WaitingBlend:
    """A frame measured by :meth:`SurveyMap.measure_frame`, to be blended by :meth:`SurveyMap.finish_frame`."""

    frame: SonarFrame
    placement: SonarPlacement
    result: FrameResult
    weight_scale: float


class SurveyMap:
    """The frame-to-map chain (see the module docstring).

    Parameters
    ----------
    heights : HeightsConfig, optional
        The height pipeline's settings; by default every frame's own altitude is used
        (``shared_altitude=False``): on board and in recordings with a pose, each frame
        carries its altitude, so there is no shared unknown reference to solve for.
    mosaic : MosaicConfig, optional
    registration : RegistrationConfig or None
        Drift correction by registering frames on the mosaic; None trusts the navigation.
    mosaic_looks : int or None
        Blend only enough frames for about this many per seabed cell
        (:mod:`perception.mapping.look_spacing`); None (default) blends every frame.
    """

    def __init__(self, *, heights: HeightsConfig | None = None, mosaic: MosaicConfig | None = None,
                 registration: RegistrationConfig | None = None, mosaic_looks: int | None = None):
        self._heights = HeightPipeline(heights or HeightsConfig(shared_altitude=False))
        self._builder = MosaicBuilder(mosaic or MosaicConfig(), registration)
        self._spacing = LookSpacing(mosaic_looks) if mosaic_looks is not None else None
        self._waiting: _WaitingBlend | None = None  # measured, not yet blended (measure_frame)

    # ------------------------------------------------------------------ verbs
    def add_frame(self, frame: SonarFrame, *, mosaic: bool = True) -> FrameResult:
        """Measure and track ``frame``'s shadows; blend it into the mosaic when ``mosaic``
        (and, with ``mosaic_looks``, when its footprint has moved on enough).

        Raises what the height pipeline and the mosaic raise for a frame they cannot use
        (:class:`~perception.errors.FrameFormatError`, :class:`~perception.errors.GeometryError`).
        """
        result = self.measure_frame(frame, mosaic=mosaic)
        self.finish_frame()
        return result

    def measure_frame(self, frame: SonarFrame, *, mosaic: bool = True) -> FrameResult:
        """:meth:`add_frame` but for the blend, which waits for :meth:`finish_frame` (or the
        next frame, or a reading of the mosaic, which finish it first): a caller that must
        answer quickly answers between the two (the map process:
        :func:`perception.mapping.map_process.serve`). The map and every result are those of
        :meth:`add_frame`; only :attr:`drift` and :attr:`frames_mapped` leave the waiting
        blend out until it is done.

        A frame the mosaic cannot place (no pose, altitude not above 0) is refused here,
        before anything of the mosaic's changes.
        """
        self.finish_frame()
        result = self._heights.add_frame(self._drift_corrected(frame), altitude_m=frame.altitude_m)
        stands_for = 1
        if self._spacing is not None:
            if mosaic:
                stands_for = self._spacing.offer(frame, altitude_m=frame.altitude_m)
                mosaic = stands_for > 0
            else:
                self._spacing.interrupt()
        if mosaic:
            placement = placement_from_frame(frame, altitude_m=frame.altitude_m)
            check_altitude(placement)
            self._waiting = _WaitingBlend(frame, placement, result, float(stands_for))
        return result

    def finish_frame(self) -> None:
        """Blend the frame :meth:`measure_frame` measured, if it waits (a no-op otherwise)."""
        waiting, self._waiting = self._waiting, None
        if waiting is None:
            return
        frame, result = waiting.frame, waiting.result
        shadow = target = None
        if result.measurements:
            # The masks come from the shadows just measured (no second segmentation).
            found = masks_from_shadows(result.measurements, range_m=frame.range_m, n_beams=frame.n_beams,
                                       beam_azimuth_rad=frame.beam_azimuth_rad, image=frame.image)
            shadow, target = found.shadow, found.target
        self._builder.add_frame(frame, placement=waiting.placement, exclude_mask=shadow, unreliable_mask=target,
                                weight_scale=waiting.weight_scale)

    def _drift_corrected(self, frame: SonarFrame) -> SonarFrame:
        d = self._builder.drift
        if d is None or (float(d.north_m) == 0.0 and float(d.east_m) == 0.0):
            return frame
        return moved_frame(frame, frame.north_m + float(d.north_m), frame.east_m + float(d.east_m))

    # --------------------------------------------------------------- reading
    @property
    def drift(self) -> Drift | None:
        """The drift correction so far (None without registration); a blend waiting
        (:meth:`measure_frame`) is not in it yet."""
        d = self._builder.drift
        if d is None:
            return None
        return Drift(float(d.north_m), float(d.east_m), std_m=d.std_m, accepted=d.accepted, refused=d.rejected,
                     travelled_m=d.travelled_m, plausible_m=d.plausible_drift_m(d.travelled_m))

    @property
    def frames_measured(self) -> int:
        """Frames the height pipeline has taken."""
        return self._heights.n_frames

    @property
    def frames_mapped(self) -> int:
        """Frames blended into the mosaic (a blend waiting, :meth:`measure_frame`, not yet)."""
        return self._builder.mosaic.frames_added

    def counters(self) -> tuple[Drift | None, int, int]:
        """(:attr:`drift`, :attr:`frames_mapped`, :attr:`frames_measured`), a waiting blend done."""
        self.finish_frame()
        return self.drift, self.frames_mapped, self.frames_measured

    @property
    def mosaic(self) -> TiledMosaic:
        """The mosaic (read it; add frames only through :meth:`add_frame`), a waiting blend done."""
        self.finish_frame()
        return self._builder.mosaic

    def targets(self) -> list[TargetHeight]:
        """Every track so far with its height (solved once per new frame)."""
        return self._heights.targets()

    def mapped_targets(self) -> list[MappedTarget]:
        """Targets placed on the map, fragments folded (see the module docstring)."""
        placed = [t for t in self.targets() if math.isfinite(t.north_m) and math.isfinite(t.east_m)]
        placed.sort(key=lambda t: (t.frames_used, t.frames_seen), reverse=True)
        kept: list[tuple[TargetHeight, list[int]]] = []
        for t in placed:
            host = next((k for k in kept if math.hypot(k[0].north_m - t.north_m, k[0].east_m - t.east_m)
                         <= SAME_TARGET_RADIUS_M), None)
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

    def raster(self, targets: list[MappedTarget] | None = None) -> MapRaster | None:
        """The map raster (echo and heights layers) of ``targets`` (default: the mapped
        targets); None while no frame has been blended in."""
        self.finish_frame()
        if not self.frames_mapped:
            return None
        try:
            return map_raster(self._builder.mosaic, self.mapped_targets() if targets is None else targets)
        except ValueError:  # frames were added, but none left a cell with weight
            return None


def moved_frame(frame: SonarFrame, north_m: float, east_m: float) -> SonarFrame:
    """``frame`` moved to (``north_m``, ``east_m``): :meth:`SonarFrame.with_fields`, whose
    pose-only path checks the new position without checking the frame's arrays again."""
    return frame.with_fields(north_m=float(north_m), east_m=float(east_m))
