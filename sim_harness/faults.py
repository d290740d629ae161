"""Fault injection by configuration: link faults, sensor faults, refused commands.

A :class:`FaultConfig` is a frozen description; the simulator applies it in its link layer
(:class:`LinkFaults`), its sensors and its autopilot, drawing from a generator seeded with
``FaultConfig.seed`` so a run is repeatable.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field

import numpy as np

from sim_harness.errors import SimConfigError


@dataclass(frozen=True)
class TimeWindow:
    """A closed interval of simulated time, seconds."""

    start_s: float
    end_s: float

    def __post_init__(self) -> None:
        if not self.end_s >= self.start_s:
            raise SimConfigError(
                f"end {self.end_s} s is before start {self.start_s} s", key="TimeWindow"
            )

    def contains(self, t_s: float) -> bool:
        """True if ``t_s`` lies in the window."""
        return self.start_s <= t_s <= self.end_s


def _in_any(windows: tuple[TimeWindow, ...], t_s: float) -> bool:
    return any(w.contains(t_s) for w in windows)


@dataclass(frozen=True)
class FaultConfig:
    """Faults to inject. Probabilities are per packet / per sample / per frame.

    Attributes
    ----------
    packet_loss : probability that a MAVLink packet is dropped (each direction).
    latency_s : extra one-way delay of every packet, simulated seconds.
    duplicate : probability that a packet is delivered twice.
    corrupt_bytes : probability that one byte of a packet is flipped (its CRC then fails).
    link_cuts : windows during which no packet passes either way.
    depth_spike_prob, depth_spike_m : probability per depth sample of a +-spike of that size.
    altimeter_dropouts : windows with no altimeter reading.
    position_loss : windows with no position estimate (DVL bottom lock lost).
    refuse_commands : MAV_CMD ids answered with MAV_RESULT_DENIED.
    sonar_drop : probability that a sonar frame is lost.
    """

    seed: int = 0
    packet_loss: float = 0.0
    latency_s: float = 0.0
    duplicate: float = 0.0
    corrupt_bytes: float = 0.0
    link_cuts: tuple[TimeWindow, ...] = ()
    depth_spike_prob: float = 0.0
    depth_spike_m: float = 5.0
    altimeter_dropouts: tuple[TimeWindow, ...] = ()
    position_loss: tuple[TimeWindow, ...] = ()
    refuse_commands: frozenset[int] = field(default_factory=frozenset)
    sonar_drop: float = 0.0

    def __post_init__(self) -> None:
        for name in ("packet_loss", "duplicate", "corrupt_bytes", "depth_spike_prob", "sonar_drop"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise SimConfigError(f"must be a probability in [0, 1], got {value}", key=name)
        if self.latency_s < 0.0:
            raise SimConfigError(f"must be >= 0, got {self.latency_s}", key="latency_s")
        if self.depth_spike_m < 0.0:
            raise SimConfigError(f"must be >= 0, got {self.depth_spike_m}", key="depth_spike_m")

    def link_cut(self, t_s: float) -> bool:
        """True while the link is cut."""
        return _in_any(self.link_cuts, t_s)

    def altimeter_out(self, t_s: float) -> bool:
        """True during an altimeter dropout window."""
        return _in_any(self.altimeter_dropouts, t_s)

    def position_out(self, t_s: float) -> bool:
        """True while the position estimate is lost."""
        return _in_any(self.position_loss, t_s)

    @property
    def affects_link(self) -> bool:
        """True if any link fault is configured."""
        return bool(
            self.packet_loss or self.latency_s or self.duplicate or self.corrupt_bytes
            or self.link_cuts
        )


class LinkFaults:
    """Applies loss, latency, duplication, corruption and cuts to one direction of a link.

    ``push(t_s, packet)`` offers a packet sent at ``t_s``; ``pop_due(t_s)`` returns the
    packets to deliver by ``t_s``, in order.
    """

    def __init__(self, config: FaultConfig, rng: np.random.Generator) -> None:
        self._cfg = config
        self._rng = rng
        self._queue: list[tuple[float, int, bytes]] = []
        self._counter = 0
        self.dropped = 0
        self.duplicated = 0
        self.corrupted = 0

    def push(self, t_s: float, packet: bytes) -> None:
        """Offer one packet sent at ``t_s``."""
        cfg = self._cfg
        if cfg.link_cut(t_s) or (cfg.packet_loss and self._rng.random() < cfg.packet_loss):
            self.dropped += 1
            return
        if cfg.corrupt_bytes and self._rng.random() < cfg.corrupt_bytes and packet:
            data = bytearray(packet)
            i = int(self._rng.integers(1, len(data))) if len(data) > 1 else 0
            data[i] ^= 0xFF
            packet = bytes(data)
            self.corrupted += 1
        copies = 1
        if cfg.duplicate and self._rng.random() < cfg.duplicate:
            copies = 2
            self.duplicated += 1
        for _ in range(copies):
            heapq.heappush(self._queue, (t_s + cfg.latency_s, self._counter, packet))
            self._counter += 1

    def pop_due(self, t_s: float) -> list[bytes]:
        """Packets due by ``t_s`` (those arriving inside a cut window are lost)."""
        out: list[bytes] = []
        while self._queue and self._queue[0][0] <= t_s:
            due_s, _, packet = heapq.heappop(self._queue)
            if self._cfg.link_cut(due_s):
                self.dropped += 1
                continue
            out.append(packet)
        return out
