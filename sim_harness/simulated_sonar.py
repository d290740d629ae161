"""The simulated sonar as the controller's sonar source: frames pinged in the simulator,
rendered in the caller's thread or ahead in a child process
(:mod:`sim_harness.render_worker`), delivered a fixed latency after the ping,
carrying what the vehicle knew at the ping (never truth)."""

from __future__ import annotations

import collections
import dataclasses
import threading
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from sim_harness.faults import FaultConfig


class SonarRendererLike(Protocol):
    """What the simulator needs from ``sim_harness.sonar.renderer.SonarRenderer``."""

    def render(self, pose: Any, timestamp_s: float) -> tuple[Any, Any]:
        """Render (SonarFrame, FrameTruth) for a sonar pose at a time."""
        ...


def default_pose_factory(**fields: float) -> Any:
    """Build a ``sim_harness.sonar.renderer.SonarPose`` (imported on first use)."""
    from sim_harness.sonar.renderer import SonarPose  # the renderer's module; optional at import time

    return SonarPose(**fields)


class SimulatedSonar:
    """The forward-looking sonar on the tilt mount, as a sonar source.

    The simulator records the true sonar pose at each frame time; :meth:`poll` returns the
    frames pinged at least ``latency_s`` before ``now_s``, oldest first, exactly what a
    sonar driver's ``poll(now_s)`` would give. Without a ``worker`` they are rendered in
    the caller's thread when polled (so rendering cost never slows the simulated vehicle);
    with one (:class:`sim_harness.render_worker.RenderWorker`) each is queued there
    at its ping and rendered while the controller works, which pays when ``latency_s`` is
    longer than the controller's cycle. The frames are the same either way. Up to
    ``max_pending`` frames are buffered; older ones are lost (counted in
    ``frames_overrun``), as with a real driver's buffer.

    ``latency_s`` is the time from the ping to its frame in the driver: a real ARIS frame
    is complete only after its last beam group has fired (about one ping period), then
    crosses the tether's Ethernet and the SDK; the controller sees it that much later and
    stamps it with the ping time.
    """

    def __init__(
        self,
        renderer: SonarRendererLike,
        *,
        frame_rate_hz: float,
        pose_factory: Callable[..., Any],
        faults: FaultConfig,
        rng: np.random.Generator,
        max_pending: int,
        on_truth: Callable[[float, Any], None],
        latency_s: float = 0.0,
        worker: Any | None = None,
    ) -> None:
        self._renderer = renderer
        self._worker = worker
        self.latency_s = float(latency_s)
        self.frame_interval_s = 1.0 / frame_rate_hz
        self._pose_factory = pose_factory
        self._faults = faults
        self._rng = rng
        # (ping time, true pose, known pose, the worker's job number or -1)
        self._pending: collections.deque[
            tuple[float, dict[str, float], dict[str, float], int]
        ] = collections.deque()
        self._max_pending = max_pending
        self._lock = threading.Lock()
        self._next_s: float | None = None
        self._on_truth = on_truth
        self.frames_dropped = 0
        self.frames_overrun = 0
        self.frames_delivered = 0

    def capture(
        self, t_s: float, pose_fields: dict[str, float], known_fields: dict[str, float]
    ) -> None:
        """Simulator side: record a frame if one is due at ``t_s``.

        ``pose_fields`` is the true sonar pose (for the renderer); ``known_fields`` is what
        the vehicle knows at the ping (its estimates), which the delivered frame carries.
        """
        if self._next_s is None:
            self._next_s = t_s
        if t_s + 1e-9 < self._next_s:
            return
        self._next_s += self.frame_interval_s
        if self._faults.sonar_drop and self._rng.random() < self._faults.sonar_drop:
            self.frames_dropped += 1
            return
        seq = self._worker.submit(t_s, pose_fields) if self._worker is not None else -1
        with self._lock:
            self._pending.append((t_s, pose_fields, known_fields, seq))
            while len(self._pending) > self._max_pending:
                self._pending.popleft()
                self.frames_overrun += 1

    def poll(self, now_s: float) -> list[Any]:
        """Frames pinged at or before ``now_s - latency_s`` not yet returned, oldest first."""
        with self._lock:
            due = []
            while self._pending and self._pending[0][0] + self.latency_s <= now_s + 1e-9:
                due.append(self._pending.popleft())
        frames = []
        for t_s, pose_fields, known_fields, seq in due:
            if self._worker is not None:
                frame, truth = self._worker.result(seq)
            else:
                frame, truth = self._renderer.render(self._pose_factory(**pose_fields), t_s)
            self._on_truth(t_s, truth)
            frames.append(_stamp_known(frame, known_fields))
        self.frames_delivered += len(frames)
        return frames

    def close(self) -> None:
        """Stop the render process, if there is one."""
        if self._worker is not None:
            self._worker.close()


def _stamp_known(frame: Any, known: dict[str, float]) -> Any:
    """Replace the pose a rendered frame carries by what the vehicle knew (never truth)."""
    if not dataclasses.is_dataclass(frame) or isinstance(frame, type):
        return frame
    names = {f.name for f in dataclasses.fields(frame)}
    changes = {k: v for k, v in known.items() if k in names}
    with_fields = getattr(frame, "with_fields", None)  # a SonarFrame's, which spares its arrays the checks
    return with_fields(**changes) if with_fields is not None else dataclasses.replace(frame, **changes)
