"""The frame-to-map chain as on-board processing holds it: in the executor's thread, or in
its own process (:mod:`perception.mapping.map_process`) with every result one call later.

:meth:`OnboardMap.add` takes one control cycle's stamped frames and returns the batches
whose results are in: in thread, this batch's; with the process, the one sent at the
previous call (the child measured it while the controller worked). The counters and the
control loop's targets (:meth:`OnboardMap.tracked_targets`) are those of the newest batch
returned (the mosaic's counters, :attr:`OnboardMap.frames_mapped` and :attr:`OnboardMap.drift`,
without its last frame's blend, which the child does after answering:
:func:`perception.mapping.map_process.apply_batch`; exact again once a product is read); the
products (targets, mapped targets, raster) take every batch back first
(returned by the next :meth:`OnboardMap.add`, or :meth:`OnboardMap.take_ready`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from perception.heights.pipeline import TargetHeight
from perception.mapping.heights_layer import MappedTarget
from perception.mapping.map_process import BatchResult, SurveyMapProcess, TrackedTarget, apply_batch, tracked_targets
from perception.mapping.products import MapRaster
from perception.mapping.survey_map import Drift, SurveyMap
from perception.sonar_io.frame import SonarFrame


class OnboardMap:
    """A :class:`SurveyMap` in thread (``process=False``) or in a child process; with the
    process the targets come back with a batch every ``tracked_targets_every_s`` of frame
    time. Close it (:meth:`close`) when done."""

    def __init__(self, survey_map: SurveyMap, *, process: bool, tracked_targets_every_s: float = 0.5) -> None:
        self._map = survey_map
        self._worker = SurveyMapProcess(survey_map) if process else None
        self._every_s = tracked_targets_every_s
        self._asked_s = -math.inf
        self._counters: tuple[Drift | None, int, int] = (None, 0, 0)  # drift, frames mapped, measured
        self._targets: tuple[TrackedTarget, ...] = ()
        self._ready: list[BatchResult] = []  # taken back by a query, not yet returned by add

    def add(self, batch: Sequence[tuple[SonarFrame, bool]]) -> list[BatchResult]:
        """Send ``(frame, mosaic)`` pairs; the batches whose results are in (module docstring)."""
        self._collect()
        done, self._ready = self._ready, []
        if batch:
            if self._worker is None:
                done.append(self._keep(apply_batch(self._map, batch)))
            else:
                newest_s = batch[-1][0].timestamp_s
                with_targets = not newest_s - self._asked_s < self._every_s
                if with_targets:
                    self._asked_s = newest_s
                self._worker.submit(batch, with_targets=with_targets)
        return done

    def _collect(self) -> None:
        while self._worker is not None and self._worker.pending:
            self._ready.append(self._keep(self._worker.collect()))

    def take_ready(self) -> list[BatchResult]:
        """The batches a query took back that :meth:`add` has not returned yet."""
        done, self._ready = self._ready, []
        return done

    def _keep(self, batch: BatchResult) -> BatchResult:
        self._counters = (batch.drift, batch.frames_mapped, batch.frames_measured)
        if batch.targets is not None:
            self._targets = batch.targets
        return batch

    @property
    def process(self) -> object | None:
        """The child process (``subprocess.Popen``), None in thread."""
        return None if self._worker is None else self._worker.process

    @property
    def drift(self) -> Drift | None:
        """The drift correction as of the newest batch returned (but its last blend) or product read."""
        return self._counters[0]

    @property
    def frames_mapped(self) -> int:
        """Frames blended into the mosaic, as of the newest batch returned (but its last blend) or product read."""
        return self._counters[1]

    @property
    def frames_measured(self) -> int:
        """Frames the height pipeline has taken, as of the newest batch returned."""
        return self._counters[2]

    def tracked_targets(self) -> tuple[TrackedTarget, ...]:
        """The control loop's view of every target (``TrackedTarget``): in thread, now;
        with the process, as last sent back (never waiting for the child)."""
        if self._worker is None:
            return tracked_targets(self._map.targets())
        return self._targets

    def targets(self) -> list[TargetHeight]:
        """Every target with its height, after every frame sent."""
        return self._query("targets")

    def mapped_targets(self) -> list[MappedTarget]:
        """Targets placed on the map, fragments folded, after every frame sent."""
        return self._query("mapped_targets")

    def raster(self, targets: list[MappedTarget] | None = None) -> MapRaster | None:
        """The map raster with ``targets`` (default: the mapped ones), after every frame sent."""
        return self._query("raster", targets)

    def _query(self, name: str, *args: Any) -> Any:
        """``SurveyMap.<name>(*args)``: here, or in the child once every batch is back."""
        if self._worker is None:
            answer = getattr(self._map, name)(*args)
            self._counters = self._map.counters()
            return answer
        self._collect()
        answer = self._worker.query(name, *args)
        self._counters = self._worker.query("counters")
        return answer

    def close(self) -> None:
        """Stop the map process, if any."""
        if self._worker is not None:
            self._worker.close()
