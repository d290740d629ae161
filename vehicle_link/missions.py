"""MissionLink: mission transfers and mission control over a :class:`VehicleLink`.

Upload (verified by download, see :func:`vehicle_link.mission.verify_items`), download,
clear, the current item, MISSION_START; the transfers themselves are
:mod:`vehicle_link.mission_io` driving :mod:`vehicle_link.mission_protocol`.
"""

from __future__ import annotations

from collections.abc import Sequence

from vehicle_link import commands, mission_io
from vehicle_link.dialect import mavlink2
from vehicle_link.errors import CommandRejected, CommandTimeout
from vehicle_link.link import VehicleLink
from vehicle_link.mission import MAV_MISSION_TYPE_MISSION, MissionItem, ardupilot_wire_items, verify_items
from vehicle_link.telemetry import MissionCurrent


class MissionLink(VehicleLink):
    """A vehicle link with missions (same constructor)."""

    # ---- mission -----------------------------------------------------------------------

    def _mission_kwargs(self) -> dict[str, int | float]:
        return {
            "target_system": self._target(),
            "target_component": self.config.target_component,
            "mission_type": MAV_MISSION_TYPE_MISSION,
            "item_timeout_s": self.config.mission_item_timeout_s,
            "retries": self.config.mission_retries,
        }

    def upload_mission(
        self, items: Sequence[MissionItem], *, verify: bool = True, home_slot: bool = True
    ) -> list[MissionItem]:
        """Upload a mission; return the wire list (home placeholder first when ``home_slot``).

        With ``verify`` the mission is downloaded again and compared item by item (always
        when the vehicle's final acknowledgement was lost).

        Raises
        ------
        MissionError
            The vehicle refused (``.result`` holds the MAV_MISSION_RESULT).
        MissionTimeout
            The transfer stalled after every retry.
        MissionVerifyError
            The mission read back differs.
        """
        wire = ardupilot_wire_items(items) if home_slot else list(items)
        with self.mission_channel() as channel:
            machine = mission_io.upload(channel, wire, **self._mission_kwargs())  # type: ignore[arg-type]
        if verify or machine.unconfirmed:
            verify_items(wire, self.download_mission(home_slot=False), skip_home=home_slot)
        return wire

    def download_mission(self, *, home_slot: bool = True) -> list[MissionItem]:
        """Download the mission; with ``home_slot`` item 0 (ArduPilot's home) is dropped."""
        with self.mission_channel() as channel:
            items = mission_io.download(channel, **self._mission_kwargs())  # type: ignore[arg-type]
        return items[1:] if home_slot and items else items

    def clear_mission(self) -> None:
        """MISSION_CLEAR_ALL, waiting for MISSION_ACK (retried on silence)."""
        with self.mission_channel() as channel:
            mission_io.clear_all(channel, **self._mission_kwargs())  # type: ignore[arg-type]

    def set_mission_current(self, seq: int) -> None:
        """Make item ``seq`` current.

        Sends MAV_CMD_DO_SET_MISSION_CURRENT (acknowledged); if the firmware answers
        UNSUPPORTED, falls back to the older MISSION_SET_CURRENT message and waits for a
        MISSION_CURRENT showing ``seq``.
        """
        try:
            self.send_command(commands.set_mission_current(seq))
            return
        except CommandRejected as exc:
            if exc.result != mavlink2.MAV_RESULT_UNSUPPORTED:
                raise
        target = self._target()
        for _ in range(self.config.command_attempts):
            self._send(
                mavlink2.MAVLink_mission_set_current_message(
                    target, self.config.target_component, seq
                )
            )
            if self._wait_until(
                lambda: (
                    isinstance(current := self._store.get("MissionCurrent"), MissionCurrent)
                    and current.seq == seq
                ),
                self.config.command_timeout_s,
            ):
                return
        raise CommandTimeout(
            mavlink2.MAVLINK_MSG_ID_MISSION_SET_CURRENT,
            "MISSION_SET_CURRENT",
            self.config.command_attempts,
            self.config.command_timeout_s,
        )

    def start_mission(self) -> None:
        """MAV_CMD_MISSION_START (ArduSub: must be armed; switches to AUTO)."""
        self.send_command(commands.mission_start())
