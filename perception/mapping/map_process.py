"""The frame-to-map chain (:class:`perception.mapping.survey_map.SurveyMap`: heights,
tracking, mosaic) in its own process, so that it works on one core while the controller
works on another.

The parent sends batches of stamped frames (:meth:`SurveyMapProcess.submit`) and takes
each batch's results back later (:meth:`SurveyMapProcess.collect`); queries (the targets,
the map) are answered after every batch sent before them. The child applies everything in
the order sent, so its answers depend only on the frames sent and never on timing: a
caller that collects each batch one control cycle after sending it sees every result one
cycle late, never sometimes two. A frame the map refuses (:class:`~perception.errors.FrameFormatError`,
:class:`~perception.errors.GeometryError`) comes back as ``None``; any other error comes
back and is raised in the parent, as it would be in thread.

The child is ``python -m perception.mapping.map_process``
(:class:`perception.child_process.ChildProcess`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import IO, Any

from perception.child_process import ChildProcess, answer_each, child_streams, read_message
from perception.errors import FrameFormatError, GeometryError
from perception.heights.pipeline import FrameResult, TargetHeight
from perception.mapping.survey_map import Drift, SurveyMap
from perception.sonar_io.frame import SonarFrame

#: What the parent may ask of the map (read-only methods of SurveyMap).
QUERIES = ("targets", "mapped_targets", "raster", "counters")


class MapProcessError(RuntimeError):
    """The map process died or sent something it should not."""


@dataclass(frozen=True)
class BatchResult:
    """One batch's results and the map's counters after it.

    Attributes
    ----------
    results : tuple
        Per frame sent, its :class:`FrameResult`, or None where the map refused the frame.
    drift : Drift or None
        The drift correction after the batch.
    frames_mapped, frames_measured : int
        Frames blended into the mosaic and frames measured, after the batch.
    targets : tuple of TrackedTarget or None
        When asked for: every target after the batch (:func:`tracked_targets`); None when
        not asked for.
    """

    results: tuple[FrameResult | None, ...]
    drift: Drift | None
    frames_mapped: int
    frames_measured: int
    targets: tuple[TrackedTarget, ...] | None = None


@dataclass(frozen=True)
class TrackedTarget:
    """What a control loop reads of a target (the pitch loop: where its shadow will be):
    its height and where it was last seen, none of what grows with every frame a track
    has (its measurements, the reasons of the frames it missed).

    Attributes
    ----------
    target_id : int
    height_m : float or None
        As :attr:`TargetHeight.height_m`.
    last_frame_index : int
        The frame of its newest detection.
    last_north_m, last_east_m : float
        Seabed place of that detection, m (NaN without pose).
    """

    target_id: int
    height_m: float | None
    last_frame_index: int
    last_north_m: float
    last_east_m: float

    @property
    def has_position(self) -> bool:
        """Whether the newest detection has a seabed place."""
        return math.isfinite(self.last_north_m) and math.isfinite(self.last_east_m)


def tracked_targets(targets: Sequence[TargetHeight]) -> tuple[TrackedTarget, ...]:
    """The control loop's view of every target that has a detection."""
    out = []
    for t in targets:
        if not t.detections:
            continue
        last = t.detections[-1]
        north, east = (last.north_m, last.east_m) if last.has_position else (math.nan, math.nan)
        out.append(TrackedTarget(t.target_id, t.height_m, last.frame_index, north, east))
    return tuple(out)


def apply_batch(survey_map: SurveyMap, batch: Sequence[tuple[SonarFrame, bool]], *,
                with_targets: bool = False) -> BatchResult:
    """Add each ``(frame, mosaic)`` of ``batch`` to ``survey_map`` (in-thread and in the child
    alike) but for the last frame's blend, which waits (:meth:`SurveyMap.measure_frame`) so
    that the child can answer first and blend after: the counters are those before that
    blend, in thread too, so that both give the same; ``with_targets``: the targets after
    the batch too (:func:`tracked_targets`)."""
    results: list[FrameResult | None] = []
    for frame, mosaic in batch:
        try:
            results.append(survey_map.measure_frame(frame, mosaic=mosaic))
        except (FrameFormatError, GeometryError):
            results.append(None)
    return BatchResult(tuple(results), survey_map.drift, survey_map.frames_mapped, survey_map.frames_measured,
                       tracked_targets(survey_map.targets()) if with_targets else None)


def serve(messages: IO[bytes], replies: IO[bytes]) -> None:
    """The child's loop: the (empty) map, then batches and queries in order until ``None``.

    A batch is answered before its last frame is blended into the mosaic
    (:func:`apply_batch`), so the parent, which waits for the answer, does not wait for the
    blend too; the blend is done before the next message is read."""
    try:
        survey_map: SurveyMap = read_message(messages)
    except EOFError:  # a child started ahead and never used
        return
    blend_error: list[Exception] = []  # the last blend's, answered to the next message

    def answer(message: tuple[str, Any]) -> tuple[str, Any]:
        kind, payload = message
        if blend_error:
            return "error", blend_error.pop()
        try:
            if kind == "batch":
                frames, with_targets = payload
                return "ok", apply_batch(survey_map, frames, with_targets=with_targets)
            if kind in QUERIES:
                return "ok", getattr(survey_map, kind)(*payload)
            return "error", MapProcessError(f"unknown message {kind!r}")
        except Exception as exc:  # sent back and raised in the parent, where it belongs
            return "error", exc

    def blend() -> None:
        try:
            survey_map.finish_frame()
        except Exception as exc:  # raised in the parent at its next answer
            blend_error.append(exc)

    answer_each(messages, replies, answer, after=blend)


class SurveyMapProcess:
    """A :class:`SurveyMap` in a child process; one caller thread."""

    def __init__(self, survey_map: SurveyMap) -> None:
        self._child = ChildProcess("perception.mapping.map_process", what="the on-board map process",
                                   error=MapProcessError)
        self._child.send(survey_map)
        self._pending = 0  # batches sent, not yet collected

    @property
    def process(self) -> Any:
        """The child process (:attr:`perception.child_process.ChildProcess.process`)."""
        return self._child.process

    @property
    def pending(self) -> int:
        """Batches sent whose results have not been collected."""
        return self._pending

    def submit(self, batch: Sequence[tuple[SonarFrame, bool]], *, with_targets: bool = False) -> None:
        """Send ``(frame, mosaic)`` pairs to be added in order; collect them later
        (``with_targets``: with the targets after them, :func:`apply_batch`)."""
        self._child.send(("batch", (list(batch), bool(with_targets))))
        self._pending += 1

    def collect(self) -> BatchResult:
        """The oldest sent batch's results, waiting for them."""
        if self._pending == 0:
            raise MapProcessError("no batch to collect")
        self._pending -= 1
        return self._answer()

    def query(self, name: str, *args: Any) -> Any:
        """``SurveyMap.<name>(*args)`` after every batch sent so far; collect those first."""
        if name not in QUERIES:
            raise ValueError(f"unknown query {name!r} (one of {', '.join(QUERIES)})")
        if self._pending:
            raise MapProcessError("collect the batches sent before asking the map")
        self._child.send((name, args))
        return self._answer()

    def _answer(self) -> Any:
        kind, value = self._child.receive()
        if kind == "error":
            raise value
        return value

    def close(self) -> None:
        """Stop the child (it finishes what it is on)."""
        self._child.close()


#: OpenCV threads in the map process. The process is the parallelism (it measures and maps
#: while the controller flies and the next pings render); OpenCV's pool splitting one
#: frame's small remaps and blurs over the cores wakes and syncs threads for each call,
#: about 0.7 s of system CPU on the default dive, CPU the other two processes then lack.
#: Answers are the same with any number of threads
#: (tests/perception/mapping/test_shortcuts.py).
MAP_OPENCV_THREADS = 1


def main() -> None:
    """The child process (:func:`perception.child_process.child_streams`)."""
    from perception import imaging  # this process's own OpenCV; the parent's is left as it is

    imaging.set_threads(MAP_OPENCV_THREADS)
    serve(*child_streams())


if __name__ == "__main__":
    # Through the module's own name, so that what it pickles names its classes there, not
    # in ``__main__``.
    from perception.mapping.map_process import main as _main

    _main()
