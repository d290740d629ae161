"""What the simulated autopilot does with each message it receives.

``GCS_MAVLINK::packetReceived`` / ``handle_message`` (libraries/GCS_MAVLink) and
``GCS_MAVLINK_Sub::handle_message`` (ArduSub/GCS_Mavlink.cpp), Sub-4.5 @30257f0118:

- A message is processed only if addressed to us or broadcast, by system *and* component
  (``MAVLink_routing.cpp``).
- HEARTBEAT from system SYSID_MYGCS (any component, any type) feeds the GCS failsafe.
- PARAM_REQUEST_LIST / _READ / PARAM_SET (``GCS_Param.cpp``): unknown names get no reply,
  PARAM_SET's type field is ignored (the value is converted to the parameter's own type)
  and the echo carries index -1.
- SET_MODE (the message): the mode change of DO_SET_MODE, with no reply in 4.5
  (``GCS_MAVLINK::handle_set_mode``).
- GIMBAL_MANAGER_SET_PITCHYAW and MOUNT_CONTROL are dropped without a mount, the former
  also for a gimbal device id other than 0 or 1 (``AP_Mount::handle_gimbal_manager_set_pitchyaw``,
  ``handle_mount_control``).
- REQUEST_DATA_STREAM sets the SRn_* rates; SET_GPS_GLOBAL_ORIGIN sets the EKF origin
  once (and is answered with GPS_GLOBAL_ORIGIN); FILE_TRANSFER_PROTOCOL gets a NAK
  (:mod:`~sim_harness.autopilot.ftp`).
"""

from __future__ import annotations

import math
from typing import Any, Protocol

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.ftp import ftp_nak
from sim_harness.autopilot.navigation import GeoPoint
from sim_harness.autopilot.position_targets import TargetContext, apply_global_int, apply_local_ned
from sim_harness.autopilot.telemetry import DATA_STREAM_PARAMS, STREAMS

M = mavlink


class InboxTarget(Protocol):
    """The autopilot's parts a received message may act on."""

    cfg: Any
    params: Any
    failsafes: Any
    pilot: Any
    mount: Any
    mission: Any
    navigation: Any
    telemetry: Any
    targets: Any
    mode: Any
    readings: Any

    def command(self, command: int, p: tuple[float, ...], now_s: float) -> int: ...

    def set_mode(self, mode: int, *, reason: str = "GCS") -> bool: ...

    def arm(self, *, force: bool) -> bool: ...

    def disarm(self, reason: str = "GCS", *, force: bool = False) -> bool: ...

    def set_mission_current(self, seq: int) -> bool: ...

    def queue_message(self, msg_id: int) -> None: ...


def _ack(command: int, result: int, msg: mavlink.MAVLink_message) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_command_ack_message(command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent())


class Inbox:
    """Dispatches received messages to the autopilot's parts."""

    def __init__(self, ap: InboxTarget) -> None:
        self._ap = ap

    def handle(self, msg: mavlink.MAVLink_message, now_s: float) -> list[mavlink.MAVLink_message]:
        """Act on one message; returns the direct replies."""
        ap = self._ap
        kind = msg.get_type()
        target = getattr(msg, "target_system", None)
        target_comp = getattr(msg, "target_component", None)
        if target not in (None, 0, ap.cfg.system_id) or target_comp not in (None, 0, ap.cfg.component_id):
            return []
        my_gcs = int(ap.params["SYSID_MYGCS"])
        if kind == "HEARTBEAT":
            if msg.get_srcSystem() == my_gcs:
                ap.failsafes.gcs_seen(now_s)
        elif kind == "COMMAND_LONG":
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
            return [_ack(msg.command, ap.command(msg.command, params, now_s), msg)]
        elif kind == "COMMAND_INT":
            params = (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z)
            return [_ack(msg.command, ap.command(msg.command, params, now_s), msg)]
        elif kind == "SET_MODE":
            # GCS_MAVLINK::handle_set_mode: _set_mode_common, no reply (the COMMAND_ACK with
            # command 11 that older versions sent went in 3f2c82df12, before Sub-4.5 branched).
            if msg.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                ap.set_mode(msg.custom_mode)
        elif kind == "MANUAL_CONTROL":
            self._manual_control(msg, now_s, my_gcs)
        elif kind == "RC_CHANNELS_OVERRIDE":
            if ap.pilot.rc_override(msg, now_s, my_gcs=my_gcs):
                ap.failsafes.gcs_seen(now_s)
        elif kind in ("SET_POSITION_TARGET_LOCAL_NED", "SET_POSITION_TARGET_GLOBAL_INT"):
            if ap.readings is not None:
                ctx = TargetContext(ap.mode, ap.readings, now_s, ap.navigation, ap.params["WPNAV_ACCEL"] / 100.0)
                apply = apply_local_ned if kind == "SET_POSITION_TARGET_LOCAL_NED" else apply_global_int
                apply(msg, ap.targets, ctx)
        elif kind == "REQUEST_DATA_STREAM":
            self._request_data_stream(msg, now_s)
        elif kind == "MISSION_SET_CURRENT":
            ap.set_mission_current(int(msg.seq))
        elif kind.startswith("MISSION_"):
            return ap.mission.handle(msg, now_s)
        elif kind in ("PARAM_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_SET"):
            return self._param_message(msg, now_s)
        elif kind == "GIMBAL_MANAGER_SET_PITCHYAW":  # AP_Mount::handle_gimbal_manager_set_pitchyaw
            if ap.mount.reaches(int(msg.gimbal_device_id)):  # else no backend: dropped
                ap.mount.gimbal_manager_pitchyaw(math.degrees(msg.pitch), math.degrees(msg.yaw),
                                                 math.degrees(msg.pitch_rate), math.degrees(msg.yaw_rate),
                                                 int(msg.flags))
        elif kind == "MOUNT_CONTROL":
            ap.mount.mount_control_message(float(msg.input_a))
        elif kind == "FILE_TRANSFER_PROTOCOL":
            return [ftp_nak(msg)]
        elif kind == "SET_GPS_GLOBAL_ORIGIN":
            point = GeoPoint(msg.latitude * 1e-7, msg.longitude * 1e-7, msg.altitude / 1000.0)
            if ap.navigation.set_origin(point):
                ap.queue_message(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
        return []

    def _manual_control(self, msg: mavlink.MAVLink_message, now_s: float, my_gcs: int) -> None:
        ap = self._ap
        actions = ap.pilot.manual_control(msg, now_s, my_gcs=my_gcs, this_mav=int(ap.params["SYSID_THISMAV"]),
                                          gain=ap.params["JS_GAIN_DEFAULT"], throttle_gain=ap.params["JS_THR_GAIN"])
        if actions is None:
            return
        ap.failsafes.gcs_seen(now_s)  # "a RC override message is considered to be a 'heartbeat'"
        if actions.mode is not None:
            ap.set_mode(actions.mode, reason="RC command")
        if actions.arm:
            ap.arm(force=False)
        if actions.disarm:
            ap.disarm("joystick")
        if actions.mount_centre:
            ap.mount.centre()

    def _request_data_stream(self, msg: mavlink.MAVLink_message, now_s: float) -> None:
        ap = self._ap
        rate = float(msg.req_message_rate) if msg.start_stop == 1 else 0.0
        if msg.req_stream_id == M.MAV_DATA_STREAM_ALL:
            names = list(STREAMS)
        elif msg.req_stream_id in DATA_STREAM_PARAMS:
            names = [DATA_STREAM_PARAMS[msg.req_stream_id]]
        else:
            return
        for name in names:
            ap.params.set(name, rate)
            ap.telemetry.set_stream_rate(name, ap.params[name], now_s=now_s)

    def _param_message(self, msg: mavlink.MAVLink_message, now_s: float) -> list[mavlink.MAVLink_message]:
        ap = self._ap
        kind = msg.get_type()
        params = ap.params
        if kind == "PARAM_REQUEST_LIST":
            return [params.value_message(n, i) for i, n in enumerate(params)]
        if kind == "PARAM_REQUEST_READ":
            name = msg.param_id if msg.param_index < 0 else params.name_at(msg.param_index)
            if not name or name not in params:
                return []
            return [params.value_message(name, params.index_of(name))]
        name = msg.param_id
        if not params.set(name, msg.param_value):
            return []
        if name in STREAMS:
            ap.telemetry.set_stream_rate(name, params[name], now_s=now_s)
        return [params.value_message(name, -1)]
