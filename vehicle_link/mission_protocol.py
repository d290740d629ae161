"""The MAVLink mission protocol's upload and download state machines (pure).

The state machines take the vehicle's messages as method calls and return the actions to
perform (send this, done, failed); :mod:`vehicle_link.mission_io` does the I/O. That is
what lets the tests drive them with a fake transport.

When a duplicate item crosses a re-request ArduPilot answers MISSION_ACK with
MAV_MISSION_INVALID_SEQUENCE and carries on (``MissionItemProtocol::handle_mission_item``):
that ack is ignored, not treated as failure. When the final MISSION_ACK is lost, the last
item is sent again, and ArduSub 4.5, no longer receiving, answers MAV_MISSION_ERROR
(``GCS_MAVLINK::handle_mission_item``): after every item was requested that means the
upload ended, not that it failed; the machine ends ``unconfirmed`` and the download that
verifies the mission decides.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from vehicle_link.dialect import mavlink2
from vehicle_link.errors import MissionError, MissionTimeout
from vehicle_link.mission import MissionItem, mission_result_name

MAV_MISSION_ACCEPTED = mavlink2.MAV_MISSION_ACCEPTED
MAV_MISSION_INVALID_SEQUENCE = mavlink2.MAV_MISSION_INVALID_SEQUENCE
MAV_MISSION_ERROR = mavlink2.MAV_MISSION_ERROR


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
    #: Ended without the vehicle's ACCEPTED (its final ack lost): verify by download.
    unconfirmed: bool = False
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
        if result == MAV_MISSION_ERROR and len(self.requested) == len(self.items) \
                and self.items_sent > len(self.items):
            self.done = self.unconfirmed = True  # the answer to our resend after the end
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
        self.items_sent += 1
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
