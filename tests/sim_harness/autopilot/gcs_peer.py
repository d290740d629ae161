"""A ground station made of plain pymavlink (mavutil), stepping with the simulation clock.

The GCS side uses no shadowsurvey code: only ``mavutil`` and a clock with ``sleep_s``.
:func:`running_vehicle` starts a simulator on a free UDP port with the test thread as a
lockstep participant, so simulated time passes only while the test waits.
"""

from __future__ import annotations

import collections
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as M  # MAVLink 2 messages

from sim_harness.clock import SimClock
from sim_harness.simulator import VehicleSimulator

STEP_S = 0.02
HEARTBEAT_PERIOD_S = 1.0


class GcsPeer:
    """A mavutil ground station whose waits are measured in simulated time."""

    def __init__(self, clock: Any, address: tuple[str, int], *, kind: str = "udp",
                 system_id: int = 255, component_id: int = 190) -> None:
        host, port = address
        url = f"udpout:{host}:{port}" if kind == "udp" else f"tcp:{host}:{port}"
        self.conn = mavutil.mavlink_connection(
            url, source_system=system_id, source_component=component_id,
            dialect="ardupilotmega", autoreconnect=False,
        )
        self.clock = clock
        self.auto_heartbeat = True
        self._last_hb_s = -1e9
        self.log: list[Any] = []
        self._unseen: collections.deque[Any] = collections.deque()

    @property
    def mav(self) -> Any:
        """The mavutil MAVLink object (``*_send`` methods)."""
        return self.conn.mav

    def heartbeat(self) -> None:
        """Send one GCS heartbeat."""
        self.conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        self._last_hb_s = self.clock.now_s()

    def pump(self) -> list[Any]:
        """Read everything that has arrived (non-blocking)."""
        out = []
        while True:
            msg = self.conn.recv_match(blocking=False)
            if msg is None:
                break
            if msg.get_type() == "BAD_DATA":
                continue
            out.append(msg)
        self.log.extend(out)
        self._unseen.extend(out)
        return out

    def tick(self) -> list[Any]:
        """Wait one simulator step, keep the heartbeat going, and read what arrived."""
        if self.auto_heartbeat and self.clock.now_s() - self._last_hb_s >= HEARTBEAT_PERIOD_S:
            self.heartbeat()
        self.clock.sleep_s(STEP_S)
        return self.pump()

    def run_for(self, duration_s: float) -> list[Any]:
        """Wait ``duration_s`` simulated seconds; returns every message received."""
        end = self.clock.now_s() + duration_s
        self._unseen.clear()
        out = []
        while self.clock.now_s() < end - 1e-9:
            out.extend(self.tick())
        self._unseen.clear()  # returned here: later waits look at newer messages only
        return out

    def wait_for(self, kind: str | tuple[str, ...], timeout_s: float,
                 condition: Callable[[Any], bool] | None = None) -> Any | None:
        """First message of ``kind`` (and matching ``condition``) within ``timeout_s``."""
        kinds = (kind,) if isinstance(kind, str) else kind
        end = self.clock.now_s() + timeout_s
        while True:
            while self._unseen:
                msg = self._unseen.popleft()
                if msg.get_type() in kinds and (condition is None or condition(msg)):
                    return msg
            if self.clock.now_s() >= end:
                return None
            self.tick()

    def command(self, command: int, *params: float, timeout_s: float = 3.0) -> Any | None:
        """COMMAND_LONG to the vehicle; returns its COMMAND_ACK (or None)."""
        p = list(params) + [0.0] * (7 - len(params))
        self._unseen.clear()
        self.conn.mav.command_long_send(1, 1, command, 0, *p)
        return self.wait_for("COMMAND_ACK", timeout_s, lambda m: m.command == command)

    def set_mode(self, mode: int, timeout_s: float = 3.0) -> Any | None:
        """MAV_CMD_DO_SET_MODE with a custom mode; returns the COMMAND_ACK."""
        return self.command(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode,
                            timeout_s=timeout_s)

    def arm(self, force: bool = False) -> Any | None:
        """Arm; returns the COMMAND_ACK."""
        return self.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196 if force else 0)

    def close(self) -> None:
        """Close the mavutil connection."""
        self.conn.close()


@contextmanager
def running_vehicle(world: Any = None, **kwargs: Any) -> Iterator[tuple[VehicleSimulator, GcsPeer]]:
    """A started simulator on a free UDP port and a GCS peer that has said hello."""
    clock = SimClock(stall_timeout_s=30.0)
    listen = kwargs.pop("listen", "udp:127.0.0.1:0")
    sim = VehicleSimulator(world, clock=clock, listen=listen, **kwargs)
    kind = listen.split(":", 1)[0]
    peer: GcsPeer | None = None
    try:
        with clock.participant("gcs-test"):
            sim.start()
            peer = GcsPeer(clock, sim.address, kind=kind)
            peer.heartbeat()
            peer.wait_for("HEARTBEAT", 3.0)
            yield sim, peer
    finally:
        sim.stop()
        if peer is not None:
            peer.close()
    if sim.error is not None:
        raise sim.error

