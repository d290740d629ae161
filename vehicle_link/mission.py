"""Mission items and the upload/download state machines of the MAVLink mission protocol.

Everything here is pure: the state machines take the vehicle's messages as method calls
and return the actions to perform (send this, done, failed); the client does the I/O.
That is what lets the tests drive them with a fake transport.

ArduPilot specifics handled here:

* Item 0 of an ArduPilot mission is the home position. ``ardupilot_wire_items`` puts a
  home placeholder at 0 before the caller's items; ``verify_items`` skips it because the
  vehicle overwrites it with its real home.
* ArduPilot re-requests an item it has not received after about 1 s, so the same item can
  be requested twice; both MISSION_REQUEST and MISSION_REQUEST_INT are answered (always with
  MISSION_ITEM_INT, as ArduPilot accepts it either way and it keeps 1e-7 degree precision).
* When a duplicate item crosses a re-request ArduPilot answers MISSION_ACK with
  MAV_MISSION_INVALID_SEQUENCE and carries on: that ack is ignored, not treated as failure.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from vehicle_link import units
from vehicle_link.dialect import mavlink2
from vehicle_link.errors import MissionError, MissionTimeout, MissionVerifyError

MAV_MISSION_TYPE_MISSION = 0
MAV_MISSION_ACCEPTED = mavlink2.MAV_MISSION_ACCEPTED
MAV_MISSION_INVALID_SEQUENCE = mavlink2.MAV_MISSION_INVALID_SEQUENCE

# Frames whose x/y are latitude/longitude (int32 degE7 in MISSION_ITEM_INT).
_GLOBAL_FRAMES = frozenset(
    {
        mavlink2.MAV_FRAME_GLOBAL,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        mavlink2.MAV_FRAME_GLOBAL_INT,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)


def mission_result_name(result: int) -> str:
    """Name of a MAV_MISSION_RESULT."""
    entry = mavlink2.enums["MAV_MISSION_RESULT"].get(result)
    return entry.name if entry is not None else f"MAV_MISSION_RESULT({result})"


@dataclass(frozen=True)
class MissionItem:
    """One mission item, degrees and metres at the edge as MAVLink defines them.

    ``altitude_m`` is MAVLink's z: metres up from the frame's reference (for ArduSub's
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, up from the surface, so ``-depth``).
    """

    command: int
    frame: int = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    latitude_deg: float = 0.0
    longitude_deg: float = 0.0
    altitude_m: float = 0.0
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    autocontinue: bool = True

    @property
    def depth_m(self) -> float:
        """Depth of the item (positive down), for frames relative to the surface."""
        return -self.altitude_m


def waypoint(
    latitude_deg: float,
    longitude_deg: float,
    depth_m: float,
    *,
    hold_s: float = 0.0,
    acceptance_radius_m: float = 0.0,
) -> MissionItem:
    """A NAV_WAYPOINT at a depth below the surface (MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)."""
    if not (-90.0 <= latitude_deg <= 90.0 and -180.0 <= longitude_deg <= 180.0):
        raise ValueError(f"waypoint lat/lon out of range: {latitude_deg}, {longitude_deg}")
    if depth_m < 0.0:
        raise ValueError(f"waypoint depth must be >= 0 m (below the surface), got {depth_m}")
    return MissionItem(
        mavlink2.MAV_CMD_NAV_WAYPOINT,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        latitude_deg,
        longitude_deg,
        units.depth_m_to_alt_m(depth_m),
        param1=hold_s,
        param2=acceptance_radius_m,
    )


HOME_PLACEHOLDER = MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_FRAME_GLOBAL)


def ardupilot_wire_items(items: Sequence[MissionItem]) -> list[MissionItem]:
    """The list to upload to ArduPilot: a home placeholder at seq 0, then ``items``."""
    return [HOME_PLACEHOLDER, *items]


def item_to_message(
    item: MissionItem,
    seq: int,
    target_system: int,
    target_component: int,
    mission_type: int = MAV_MISSION_TYPE_MISSION,
) -> mavlink2.MAVLink_mission_item_int_message:
    """MISSION_ITEM_INT for ``item`` at ``seq``."""
    if item.frame in _GLOBAL_FRAMES:
        x = units.deg_to_dege7(item.latitude_deg)
        y = units.deg_to_dege7(item.longitude_deg)
    else:  # local frames carry metres * 1e4 in x/y of MISSION_ITEM_INT
        x = int(round(item.latitude_deg * 1.0e4))
        y = int(round(item.longitude_deg * 1.0e4))
    return mavlink2.MAVLink_mission_item_int_message(
        target_system,
        target_component,
        seq,
        item.frame,
        item.command,
        0,
        1 if item.autocontinue else 0,
        item.param1,
        item.param2,
        item.param3,
        item.param4,
        x,
        y,
        item.altitude_m,
        mission_type,
    )


def item_from_message(msg: Any) -> tuple[int, MissionItem]:
    """(seq, MissionItem) from a MISSION_ITEM_INT or a MISSION_ITEM."""
    is_int = msg.get_type() == "MISSION_ITEM_INT"
    frame = int(msg.frame)
    if is_int and frame in _GLOBAL_FRAMES:
        lat, lon = units.dege7_to_deg(msg.x), units.dege7_to_deg(msg.y)
    elif is_int:
        lat, lon = msg.x / 1.0e4, msg.y / 1.0e4
    else:
        lat, lon = float(msg.x), float(msg.y)
    item = MissionItem(
        int(msg.command),
        frame,
        lat,
        lon,
        float(msg.z),
        float(msg.param1),
        float(msg.param2),
        float(msg.param3),
        float(msg.param4),
        bool(msg.autocontinue),
    )
    return int(msg.seq), item


def _close(a: float, b: float, tol: float) -> bool:
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return abs(a - b) <= tol * max(1.0, abs(a), abs(b))


def items_match(sent: MissionItem, got: MissionItem) -> bool:
    """True if ``got`` is ``sent`` after a round trip through float32/int32 fields."""
    float32_tol = 1.0e-6
    return (
        sent.command == got.command
        and sent.frame == got.frame
        and sent.autocontinue == got.autocontinue
        and abs(sent.latitude_deg - got.latitude_deg) <= 1.5e-7
        and abs(sent.longitude_deg - got.longitude_deg) <= 1.5e-7
        and _close(sent.altitude_m, got.altitude_m, float32_tol)
        and all(
            _close(getattr(sent, p), getattr(got, p), float32_tol)
            for p in ("param1", "param2", "param3", "param4")
        )
    )


def verify_items(
    sent: Sequence[MissionItem], got: Sequence[MissionItem], *, skip_home: bool = True
) -> None:
    """Raise MissionVerifyError unless ``got`` equals ``sent`` (wire lists, home at 0)."""
    if len(sent) != len(got):
        raise MissionVerifyError(f"vehicle holds {len(got)} items, {len(sent)} were uploaded", -1)
    for seq, (a, b) in enumerate(zip(sent, got, strict=True)):
        if skip_home and seq == 0:
            continue
        if not items_match(a, b):
            raise MissionVerifyError(
                f"item {seq} differs after upload: sent {a}, read back {b}", seq
            )


# ---- actions the state machines ask for -------------------------------------------------


@dataclass(frozen=True)
class SendCount:
    """Send MISSION_COUNT."""

    count: int


@dataclass(frozen=True)
class SendItem:
    """Send MISSION_ITEM_INT for ``seq``."""

    seq: int
    item: MissionItem


@dataclass(frozen=True)
class SendRequestList:
    """Send MISSION_REQUEST_LIST."""


@dataclass(frozen=True)
class SendRequest:
    """Send MISSION_REQUEST_INT for ``seq``."""

    seq: int


@dataclass(frozen=True)
class SendAck:
    """Send MISSION_ACK with ``result``."""

    result: int


Action = SendCount | SendItem | SendRequestList | SendRequest | SendAck


@dataclass
class MissionUpload:
    """Upload state machine (we are the sender).

    Parameters
    ----------
    items : sequence of MissionItem
        The full wire list (for ArduPilot, home placeholder first).
    max_retries : int
        Consecutive timeouts without progress tolerated before failing.
    """

    items: Sequence[MissionItem]
    max_retries: int = 5
    done: bool = False
    requested: set[int] = field(default_factory=set)
    items_sent: int = 0
    ignored_acks: int = 0
    _retries: int = 0
    _last_sent: int | None = None

    def start(self) -> list[Action]:
        """Begin: announce the count."""
        return [SendCount(len(self.items))]

    def on_request(self, seq: int) -> list[Action]:
        """MISSION_REQUEST or MISSION_REQUEST_INT for ``seq`` (re-requests included)."""
        if self.done:
            return []
        if not 0 <= seq < len(self.items):
            raise MissionError(f"vehicle requested item {seq} of a {len(self.items)}-item mission")
        self.requested.add(seq)
        self._retries = 0
        self._last_sent = seq
        self.items_sent += 1
        return [SendItem(seq, self.items[seq])]

    def on_ack(self, result: int) -> list[Action]:
        """MISSION_ACK from the vehicle."""
        if self.done:
            return []
        if result == MAV_MISSION_INVALID_SEQUENCE:
            self.ignored_acks += 1  # ArduPilot's answer to a duplicate item: carry on
            return []
        if result == MAV_MISSION_ACCEPTED:
            if len(self.requested) == len(self.items):
                self.done = True
            else:  # a stale ack from an earlier transaction
                self.ignored_acks += 1
            return []
        raise MissionError(
            f"vehicle refused the mission upload: {mission_result_name(result)}", result
        )

    def on_timeout(self) -> list[Action]:
        """Nothing heard for one item timeout: resend what the vehicle may have lost."""
        if self.done:
            return []
        self._retries += 1
        if self._retries > self.max_retries:
            raise MissionTimeout(
                f"mission upload stalled: no answer after {self.max_retries} retries "
                f"({len(self.requested)}/{len(self.items)} items requested)"
            )
        if self._last_sent is None:
            return [SendCount(len(self.items))]
        return [SendItem(self._last_sent, self.items[self._last_sent])]


@dataclass
class MissionDownload:
    """Download state machine (we are the receiver)."""

    max_retries: int = 5
    done: bool = False
    count: int | None = None
    received: list[MissionItem] = field(default_factory=list)
    duplicates: int = 0
    _retries: int = 0

    def start(self) -> list[Action]:
        """Begin: ask for the list."""
        return [SendRequestList()]

    def on_count(self, count: int) -> list[Action]:
        """MISSION_COUNT from the vehicle."""
        if self.done:
            return []
        if self.count is not None:
            if count != self.count:
                raise MissionError(
                    f"vehicle changed the mission count from {self.count} to {count}"
                )
            self.duplicates += 1
            return [SendRequest(len(self.received))] if len(self.received) < count else []
        self.count = count
        self._retries = 0
        if count == 0:
            self.done = True
            return [SendAck(MAV_MISSION_ACCEPTED)]
        return [SendRequest(0)]

    def on_item(self, seq: int, item: MissionItem) -> list[Action]:
        """MISSION_ITEM_INT or MISSION_ITEM from the vehicle."""
        if self.done or self.count is None:
            return []
        expected = len(self.received)
        if seq != expected:
            self.duplicates += 1  # duplicate or out of order: wait for the one we asked
            return []
        self.received.append(item)
        self._retries = 0
        if len(self.received) == self.count:
            self.done = True
            return [SendAck(MAV_MISSION_ACCEPTED)]
        return [SendRequest(len(self.received))]

    def on_ack(self, result: int) -> list[Action]:
        """MISSION_ACK during a download means the vehicle gave up or refused."""
        if self.done or result in (MAV_MISSION_ACCEPTED, MAV_MISSION_INVALID_SEQUENCE):
            return []
        raise MissionError(
            f"vehicle refused the mission download: {mission_result_name(result)}", result
        )

    def on_timeout(self) -> list[Action]:
        """Nothing heard: ask again for what is missing."""
        if self.done:
            return []
        self._retries += 1
        if self._retries > self.max_retries:
            raise MissionTimeout(
                f"mission download stalled after {self.max_retries} retries "
                f"({len(self.received)}/{self.count} items)"
            )
        if self.count is None:
            return [SendRequestList()]
        return [SendRequest(len(self.received))]
