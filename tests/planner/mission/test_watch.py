"""A mode change right after one of ArduSub 4.5's failsafe texts is the vehicle's own
(ArduSub/failsafe.cpp: "MYGCS: N, heartbeat lost", "Lost manual control", ...); any
other is the pilot's."""

from __future__ import annotations

from planner.mission.watch import FAILSAFE_TEXT_WINDOW_S, VehicleWatch
from vehicle_link.telemetry import StatusText


def _text(t_s: float, text: str) -> StatusText:
    return StatusText(time_s=t_s, severity=2, text=text, text_id=0, chunk_seq=0)


def test_failsafe_texts_are_recognised_within_the_window():
    watch = VehicleWatch()
    watch.listener(_text(10.0, "PreArm: Leak Detected"))
    watch.listener(_text(20.0, "MYGCS: 255, heartbeat lost"))
    watch.listener(_text(20.5, "Mode change failed: SURFACE requires position"))
    assert watch.failsafe_text(21.0) == "MYGCS: 255, heartbeat lost"
    assert watch.failsafe_text(20.0 + FAILSAFE_TEXT_WINDOW_S + 0.1) is None


def test_other_texts_are_not_failsafes():
    watch = VehicleWatch()
    watch.listener(_text(5.0, "Using backup location"))
    watch.listener(object())  # not a STATUSTEXT: ignored
    assert watch.failsafe_text(5.5) is None
    assert watch.texts_since(0.0) == ["Using backup location"]
