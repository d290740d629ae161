"""Other systems on the vehicle's MAVLink network: BlueOS's own services, a topside pilot.

On a BlueOS sub a MAVLink router joins the autopilot, BlueOS's services (mavlink2rest as
system 1 component 194, the camera manager 100-105, ...) and the topside ground station
(QGroundControl or Cockpit, system 255) on one network; every endpoint sees every
message (``bluerobotics/BlueOS`` 1.4.3 ``core/start-blueos-core``, the router). The
simulator's peers stand for them: each step their messages go to the autopilot, as the
router would deliver them, and out of the simulator's socket too, so the companion sees
the topside's HEARTBEAT and MANUAL_CONTROL as it would on a real vehicle. What the
vehicle answers them is not delivered back (the peers do not listen).

- :class:`BlueOsServices`: mavlink2rest's 1 Hz HEARTBEAT as system 1, component 194
  (``--system-id 1 --component-id 194``). With SYSID_MYGCS set to 1 these would keep the
  GCS failsafe quiet forever; with the default 255 they do not count.
- :class:`TopsidePilot`: a ground station with a joystick: HEARTBEAT (MAV_TYPE_GCS) at
  1 Hz and MANUAL_CONTROL at ``manual_control_hz`` (sticks neutral) from ``start_s`` until
  ``stop_s`` (the topside dies or the tether is cut), pressing joystick buttons at given
  times (1 MANUAL, 2 ALT_HOLD, 3 STABILIZE: ArduSub's default buttons).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

M = mavlink


@dataclass(frozen=True)
class BlueOsServices:
    """BlueOS's own MAVLink services on the vehicle (system 1)."""

    system_id: int = 1
    component_id: int = 194  # mavlink2rest
    heartbeat_hz: float = 1.0


@dataclass(frozen=True)
class TopsidePilot:
    """A topside ground station with a joystick (see the module docstring).

    ``buttons`` are (time_s, button) presses held for one MANUAL_CONTROL message.
    """

    system_id: int = 255
    component_id: int = 190  # MAV_COMP_ID_MISSIONPLANNER, as QGroundControl sends
    target_system: int = 1
    start_s: float = 0.0
    stop_s: float = math.inf
    heartbeat_hz: float = 1.0
    manual_control_hz: float = 10.0
    buttons: tuple[tuple[float, int], ...] = ()


PeerConfig = BlueOsServices | TopsidePilot


class LocalPeer:
    """One peer's message schedule and its own MAVLink identity."""

    def __init__(self, config: PeerConfig) -> None:
        self.config = config
        self.codec = mavlink.MAVLink(None, srcSystem=config.system_id, srcComponent=config.component_id)
        self._next_heartbeat_s = 0.0
        self._next_manual_s = 0.0
        self._pending_buttons = sorted(config.buttons) if isinstance(config, TopsidePilot) else []

    def messages(self, now_s: float) -> list[mavlink.MAVLink_message]:
        """The messages this peer sends at ``now_s`` (headers carry its ids once packed)."""
        cfg = self.config
        out: list[mavlink.MAVLink_message] = []
        if isinstance(cfg, TopsidePilot) and not cfg.start_s <= now_s < cfg.stop_s:
            return out
        if now_s + 1e-9 >= self._next_heartbeat_s:
            self._next_heartbeat_s = now_s + 1.0 / cfg.heartbeat_hz
            if isinstance(cfg, TopsidePilot):
                out.append(M.MAVLink_heartbeat_message(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                                       M.MAV_STATE_ACTIVE, 3))
            else:
                out.append(M.MAVLink_heartbeat_message(M.MAV_TYPE_ONBOARD_CONTROLLER, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                                       M.MAV_STATE_ACTIVE, 3))
        if isinstance(cfg, TopsidePilot) and now_s + 1e-9 >= self._next_manual_s:
            self._next_manual_s = now_s + 1.0 / cfg.manual_control_hz
            buttons = 0
            while self._pending_buttons and self._pending_buttons[0][0] <= now_s + 1e-9:
                buttons |= 1 << self._pending_buttons.pop(0)[1]
            out.append(M.MAVLink_manual_control_message(cfg.target_system, 0, 0, 500, 0, buttons))
        return out

    def pack(self, msg: mavlink.MAVLink_message) -> bytes:
        """``msg`` as bytes with this peer's system and component ids."""
        data = msg.pack(self.codec)
        self.codec.seq = (self.codec.seq + 1) % 256
        return bytes(data)
