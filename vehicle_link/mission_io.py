"""Mission transfers over a :class:`~vehicle_link.link.MissionChannel`: the thin I/O
around the pure state machines of :mod:`vehicle_link.mission`."""

from __future__ import annotations

from typing import Any

from vehicle_link.dialect import mavlink2
from vehicle_link.errors import MissionError
from vehicle_link.link import MissionChannel
from vehicle_link.mission import MissionItem, item_from_message, item_to_message, mission_result_name
from vehicle_link.mission_protocol import (
    Action,
    MissionDownload,
    MissionUpload,
    SendAck,
    SendCount,
    SendItem,
    SendRequest,
    SendRequestList,
)


def _feed(machine: MissionUpload | MissionDownload, msg: Any) -> list[Action]:
    mtype = msg.get_type()
    if mtype == "MISSION_ACK":
        return machine.on_ack(int(msg.type))
    if isinstance(machine, MissionUpload):
        if mtype in ("MISSION_REQUEST", "MISSION_REQUEST_INT"):
            return machine.on_request(int(msg.seq))
        return []
    if mtype == "MISSION_COUNT":
        return machine.on_count(int(msg.count))
    if mtype in ("MISSION_ITEM_INT", "MISSION_ITEM"):
        seq, item = item_from_message(msg)
        return machine.on_item(seq, item)
    return []


def _perform(
    channel: MissionChannel, actions: list[Action], target: int, comp: int, mission_type: int
) -> None:
    for action in actions:
        if isinstance(action, SendCount):
            channel.send(
                mavlink2.MAVLink_mission_count_message(target, comp, action.count, mission_type)
            )
        elif isinstance(action, SendItem):
            channel.send(item_to_message(action.item, action.seq, target, comp, mission_type))
        elif isinstance(action, SendRequestList):
            channel.send(mavlink2.MAVLink_mission_request_list_message(target, comp, mission_type))
        elif isinstance(action, SendRequest):
            channel.send(
                mavlink2.MAVLink_mission_request_int_message(target, comp, action.seq, mission_type)
            )
        elif isinstance(action, SendAck):
            channel.send(
                mavlink2.MAVLink_mission_ack_message(target, comp, action.result, mission_type)
            )


def run_transfer(
    channel: MissionChannel,
    machine: MissionUpload | MissionDownload,
    *,
    target_system: int,
    target_component: int,
    mission_type: int,
    item_timeout_s: float,
) -> None:
    """Drive ``machine`` until done; raises what it raises (MissionError, MissionTimeout)."""
    _perform(channel, machine.start(), target_system, target_component, mission_type)
    while not machine.done:
        msg = channel.next_message(item_timeout_s)
        actions = machine.on_timeout() if msg is None else _feed(machine, msg)
        _perform(channel, actions, target_system, target_component, mission_type)


def upload(
    channel: MissionChannel,
    items: list[MissionItem],
    *,
    target_system: int,
    target_component: int,
    mission_type: int,
    item_timeout_s: float,
    retries: int,
) -> MissionUpload:
    """Upload ``items`` (the full wire list); return the finished state machine."""
    machine = MissionUpload(items, max_retries=retries)
    run_transfer(
        channel,
        machine,
        target_system=target_system,
        target_component=target_component,
        mission_type=mission_type,
        item_timeout_s=item_timeout_s,
    )
    return machine


def download(
    channel: MissionChannel,
    *,
    target_system: int,
    target_component: int,
    mission_type: int,
    item_timeout_s: float,
    retries: int,
) -> list[MissionItem]:
    """Download the whole list (home included for ArduPilot)."""
    machine = MissionDownload(max_retries=retries)
    run_transfer(
        channel,
        machine,
        target_system=target_system,
        target_component=target_component,
        mission_type=mission_type,
        item_timeout_s=item_timeout_s,
    )
    return list(machine.received)


def clear_all(
    channel: MissionChannel,
    *,
    target_system: int,
    target_component: int,
    mission_type: int,
    item_timeout_s: float,
    retries: int,
) -> None:
    """MISSION_CLEAR_ALL until a MISSION_ACK; raise MissionError on refusal or silence."""
    for _ in range(retries + 1):
        channel.send(
            mavlink2.MAVLink_mission_clear_all_message(
                target_system, target_component, mission_type
            )
        )
        msg = channel.next_message(item_timeout_s)
        while msg is not None and msg.get_type() != "MISSION_ACK":
            msg = channel.next_message(item_timeout_s)
        if msg is None:
            continue
        if msg.type == mavlink2.MAV_MISSION_ACCEPTED:
            return
        raise MissionError(
            f"vehicle refused MISSION_CLEAR_ALL: {mission_result_name(msg.type)}", int(msg.type)
        )
    raise MissionError(f"no MISSION_ACK for MISSION_CLEAR_ALL after {retries + 1} attempts")
