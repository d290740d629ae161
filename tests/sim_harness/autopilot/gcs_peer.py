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

from sim_harness.autopilot.autopilot import AutopilotConfig
from sim_harness.clock import SimClock
from sim_harness.simulator import VehicleConfig, VehicleSimulator

#: The EKF origin most tests give the vehicle (as the BlueOS DVL extension would set it).
ORIGIN = (47.0, 8.0, 0.0)
STEP_S = 0.02
HEARTBEAT_PERIOD_S = 1.0
MANUAL_CONTROL_PERIOD_S = 0.1  # a ground station with a joystick, as QGroundControl or Cockpit


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
        #: Neutral MANUAL_CONTROL with every tick while heartbeats go (the pilot's joystick):
        #: ArduSub 4.5 on real hardware disarms 3 s after the last one (FS_PILOT_INPUT).
        self.auto_manual_control = True
        self._last_hb_s = -1e9
        self._last_mc_s = -1e9
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

    def manual_control(self, x: int = 0, y: int = 0, z: int = 500, r: int = 0, buttons: int = 0,
                       target: int = 1) -> None:
        """Send one MANUAL_CONTROL (sticks neutral by default)."""
        self.conn.mav.manual_control_send(target, x, y, z, r, buttons)
        self._last_mc_s = self.clock.now_s()

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
        if (self.auto_heartbeat and self.auto_manual_control
                and self.clock.now_s() - self._last_mc_s >= MANUAL_CONTROL_PERIOD_S):
            self.manual_control()
        self.clock.sleep_s(STEP_S)
        return self.pump()

    def discard(self) -> None:
        """Forget the messages received so far (later waits look at newer ones only)."""
        self._unseen.clear()

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
                 condition: Callable[[Any], bool] | None = None, *, from_autopilot: bool = True) -> Any | None:
        """First message of ``kind`` (and matching ``condition``) within ``timeout_s``; only
        the autopilot's (system 1, component 1) unless ``from_autopilot`` is False (the
        router also forwards BlueOS's own heartbeats)."""
        kinds = (kind,) if isinstance(kind, str) else kind
        end = self.clock.now_s() + timeout_s
        while True:
            while self._unseen:
                msg = self._unseen.popleft()
                if from_autopilot and (msg.get_srcSystem(), msg.get_srcComponent()) != (1, 1):
                    continue
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
        """Arm (force: ArduPilot's magic 2989); returns the COMMAND_ACK."""
        return self.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, 2989 if force else 0)

    def param(self, name: str, timeout_s: float = 2.0) -> Any | None:
        """PARAM_REQUEST_READ by name; returns the PARAM_VALUE."""
        self._unseen.clear()
        self.conn.mav.param_request_read_send(1, 1, name.encode(), -1)
        return self.wait_for("PARAM_VALUE", timeout_s, lambda m: m.param_id == name)

    def close(self) -> None:
        """Close the mavutil connection."""
        self.conn.close()


def vehicle_config(*, origin: tuple[float, float, float] | None = ORIGIN, params: dict[str, float] | None = None,
                   autopilot: dict[str, Any] | None = None, **kwargs: Any) -> VehicleConfig:
    """A VehicleConfig whose autopilot has an EKF origin (None: none) and parameter overrides."""
    ap = AutopilotConfig(origin=origin, params=dict(params or {}), **(autopilot or {}))
    return VehicleConfig(autopilot=ap, **kwargs)


@contextmanager
def running_vehicle(world: Any = None, **kwargs: Any) -> Iterator[tuple[VehicleSimulator, GcsPeer]]:
    """A started simulator on a free UDP port and a GCS peer that has said hello
    (default config: :func:`vehicle_config`, with an EKF origin)."""
    clock = SimClock(stall_timeout_s=30.0)
    listen = kwargs.pop("listen", "udp:127.0.0.1:0")
    kwargs.setdefault("config", vehicle_config())
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

