"""The pre-flight judgement (pure): arming is refused wherever ArduSub 4.5 would disarm, or
lose its failsafe, because of the companion; each refusal says why.

Sources: ArduSub 4.5 GCS_Mavlink.cpp ``GCS_MAVLINK::handle_heartbeat`` (GCS heartbeats
and MANUAL_CONTROL only from SYSID_MYGCS), failsafe.cpp ``Sub::failsafe_gcs_check`` and
``Sub::failsafe_pilot_input_check`` (acts once, latched), GCS_Mavlink.cpp
``vehicle_system_status`` (CRITICAL while a failsafe is latched).
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from planner.mission.preflight import MAV_STATE_CRITICAL, PreflightFacts, judge

MAV_STATE_STANDBY = 3

#: A BlueOS sub with the topside connected: QGC (255) heartbeating, its joystick on.
FIELD = PreflightFacts(our_system_id=1, vehicle_system_id=1, sysid_my_gcs=255, fs_gcs_enable=2, fs_pilot_input=2,
                       fs_pilot_timeout_s=3.0, topside_heartbeat=True, topside_joystick=True,
                       system_status=MAV_STATE_STANDBY, position_ok=True, mount_frame="earth")


def test_the_field_set_up_may_arm_with_the_pilot_failsafe_named():
    report = judge(FIELD, topside_required=True)
    assert report.ok, report.refusal
    assert any("FS_PILOT_INPUT disarms the vehicle 3 s after" in w for w in report.warnings)
    assert "SYSID_MYGCS 255" in report.lines()[-1] or any("SYSID_MYGCS 255" in n for n in report.notes)


@pytest.mark.parametrize(("change", "words"), [
    ({"sysid_my_gcs": 1, "our_system_id": 1}, "this computer's system id"),
    ({"sysid_my_gcs": 1, "our_system_id": 2}, "the vehicle's own system id"),
    ({"topside_heartbeat": False}, "no heartbeat from the topside (system 255)"),
    ({"topside_joystick": False}, "no joystick input (MANUAL_CONTROL)"),
    ({"system_status": MAV_STATE_CRITICAL}, "reports a failsafe"),
    ({"position_ok": False}, "no horizontal position"),
    ({"mount_frame": None}, "MNT1_TYPE gives no known mount"),
])
def test_each_refusal_says_why(change, words):
    report = judge(replace(FIELD, **change), topside_required=True)
    assert not report.ok
    assert words in report.refusal
    assert report.lines()[0].startswith("REFUSED: ")


def test_a_bench_without_a_topside_may_arm_once_the_pilot_failsafe_has_latched():
    """No joystick since boot: 4.5's pilot-input failsafe fired once, 3 s after boot, and
    does not act again at arming (``failsafe.pilot_input`` stays latched)."""
    bench = replace(FIELD, topside_heartbeat=False, topside_joystick=False, system_status=MAV_STATE_CRITICAL)
    report = judge(bench, topside_required=False)
    assert report.ok, report.refusal
    assert any("nobody can take over" in w for w in report.warnings)
    assert any("has latched" in n for n in report.notes)
    assert not judge(bench, topside_required=True).ok


def test_with_the_pilot_failsafe_off_a_critical_status_is_another_failsafe():
    """FS_PILOT_INPUT 0: the pilot-input failsafe never fires, so it cannot have latched;
    a CRITICAL system status with no joystick is some other failsafe, and arming is refused."""
    bench = replace(FIELD, topside_heartbeat=False, topside_joystick=False, system_status=MAV_STATE_CRITICAL,
                    fs_pilot_input=0)
    report = judge(bench, topside_required=False)
    assert not report.ok
    assert "reports a failsafe (HEARTBEAT system_status CRITICAL)" in report.refusal
    assert not any("has latched" in n for n in report.notes)
    assert report.lines()[0].startswith("REFUSED: ")
