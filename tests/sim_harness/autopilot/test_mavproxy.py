"""MAVProxy 1.8.75, a real and independent ground station, flies ``shadowsurvey sim-vehicle``.

The vehicle boots as a BlueOS sub at the plan's origin (``--origin``, as the DVL extension
sets it) with ArduSub 4.5's hardware behaviour: no joystick, so the pilot-input failsafe
latches 3 s after boot ("Lost manual control", ArduSub/failsafe.cpp
``Sub::failsafe_pilot_input_check``) and acts once; arming after that holds. MAVProxy is
system 255 = SYSID_MYGCS, so it is the vehicle's GCS. Fails (not skips) without MAVProxy:
install it with ``pip install --no-deps MAVProxy==1.8.75``.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from planner.cli import main
from tests.sim_harness.autopilot.mavproxy_driver import SUB_MODES, MAVProxy, SimVehicle, read_waypoints

COMPACT = "tests/whole_loop/data/compact"
MAV_PARAM_TYPE_INT8, MAV_PARAM_TYPE_INT16, MAV_PARAM_TYPE_INT32, MAV_PARAM_TYPE_REAL32 = 2, 4, 6, 9


@pytest.fixture(scope="module")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("mavproxy")


@pytest.fixture(scope="module")
def plan_dir(workdir: Path) -> Path:
    out = workdir / "plan"
    assert main(["plan", f"{COMPACT}/area.geojson", "--config", f"{COMPACT}/survey.toml", "--out", str(out),
                 "--no-plot"]) == 0
    return out


@pytest.fixture(scope="module")
def origin(plan_dir: Path) -> tuple[float, float]:
    doc = json.loads((plan_dir / "plan.json").read_text())
    return doc["origin_lat_deg"], doc["origin_lon_deg"]


@pytest.fixture(scope="module")
def gcs(workdir: Path, origin: tuple[float, float]) -> Iterator[MAVProxy]:
    vehicle = SimVehicle(["--origin", f"{origin[0]:.8f}", f"{origin[1]:.8f}"])
    mavproxy = None
    try:
        mavproxy = MAVProxy(vehicle.master, workdir)
        mavproxy.wait_ready()
        yield mavproxy
    finally:
        if mavproxy is not None:
            mavproxy.close()
        vehicle.close()


def test_connects_as_an_ardusub_with_no_false_alarms(gcs: MAVProxy) -> None:
    """Parameters by PARAM_REQUEST_LIST (MAVFTP answered with a NAK), no fence breach
    (SYS_STATUS has the geofence bits, present, enabled and healthy, as 4.5 by default)."""
    text = gcs.out.text_since(0)
    assert "fence breach" not in text
    assert "FTP: request timed out" not in text


def test_reads_typed_parameters(gcs: MAVProxy) -> None:
    """PARAM_VALUE carries each parameter's ArduSub 4.5 type (ArduSub/Parameters.cpp,
    libraries/AP_Mount/AP_Mount_Params.cpp, libraries/AP_Arming/AP_Arming.cpp)."""
    assert gcs.param("SYSID_MYGCS") == (255.0, MAV_PARAM_TYPE_INT16)
    assert gcs.param("FS_GCS_ENABLE") == (2.0, MAV_PARAM_TYPE_INT8)  # disarm: 4.5's default
    assert gcs.param("FS_PILOT_INPUT") == (2.0, MAV_PARAM_TYPE_INT8)
    assert gcs.param("FS_PILOT_TIMEOUT") == (3.0, MAV_PARAM_TYPE_REAL32)
    assert gcs.param("MNT1_TYPE") == (1.0, MAV_PARAM_TYPE_INT8)  # the Sub default: servo, stabilised
    assert gcs.param("ARMING_CHECK") == (448.0, MAV_PARAM_TYPE_INT32)  # RC | voltage | battery (Sub defaults)


def test_mode_changes_and_arming(gcs: MAVProxy) -> None:
    """Modes by MAV_CMD_DO_SET_MODE; arming in GUIDED (the vehicle has a position), plain
    and forced (MAVProxy's ``force`` sends 2989 to arm, 21196 to disarm: AP_Arming's magics)."""
    gcs.expect(r"AP: Lost manual control", 10.0)  # 3 s after boot without a joystick, once
    for name in ("ALT_HOLD", "GUIDED"):
        gcs.set_mode(name)
    assert gcs.heartbeat()[1] == SUB_MODES["GUIDED"]
    gcs.arm()
    gcs.disarm()
    gcs.arm(force=True)
    gcs.disarm(force=True)
    gcs.set_mode("MANUAL")


def test_wp_load_of_the_products_mission_round_trips(gcs: MAVProxy, plan_dir: Path, workdir: Path,
                                                      origin: tuple[float, float]) -> None:
    """``wp load`` of the plan's survey.waypoints (frame 10 waypoints, gimbal pitch items),
    then ``wp save``: the vehicle keeps every value the file holds (whole 1e-7 degrees and
    centimetres, AP_Mission ``mavlink_int_to_mission_cmd``), and item 0 is its home, the origin.
    The gimbal items go up in frame 2 (MAV_FRAME_MISSION) and come back in frame 0."""
    src = plan_dir / "survey.waypoints"
    n = gcs.wp_load(src)
    back = workdir / "readback.waypoints"
    assert gcs.wp_save(back) == n
    sent, got = read_waypoints(src), read_waypoints(back)
    assert len(sent) == len(got) == n
    assert got[0][8:10] == pytest.approx(origin, abs=1.5e-6)
    for a, b in zip(sent[1:], got[1:], strict=True):
        # seq, current, frame, command: a command without a location comes back in frame 0
        # whatever it was sent in (AP_Mission::mission_cmd_to_mavlink_int)
        assert a[:4] == (b[:2] + [2.0] + b[3:4] if a[3] == 1000 and b[2] == 0 else b[:4])
        assert a[4:8] == pytest.approx(b[4:8], abs=1e-6)  # params 1-4
        assert a[8:10] == pytest.approx(b[8:10], abs=1.5e-6)  # MAVProxy writes %f (1e-6 degrees)
        assert a[10] == pytest.approx(b[10], abs=1e-6)  # whole centimetres come back whole
        assert a[11] == b[11]


def test_wp_load_of_a_hand_written_file_with_jumps_servos_and_cameras(gcs: MAVProxy, workdir: Path,
                                                                      origin: tuple[float, float]) -> None:
    """A Mission Planner file as users write them (a DO_JUMP, a servo for the lights, a
    camera trigger, a condition, a NAV_LAND): MAVProxy's ``wp load`` uploads it whole (the
    vehicle stores every one of these, AP_Mission ``mavlink_int_to_mission_cmd``) and ``wp
    save`` reads back each field in its C type: the PWM and channel as integers, the jump's
    repeat count as int16, the command without a location in frame 0, NAV_LAND's param4 as
    its sign."""
    lat, lon = origin
    rows = [
        (0, 1, 0, 16, 0, 0, 0, 0, lat, lon, 0.0),
        (1, 0, 3, 16, 0, 0, 0, 0, lat + 1e-5, lon, -2.0),
        (2, 0, 2, 183, 9, 1900.6, 0, 0, 0, 0, 0),  # DO_SET_SERVO: lights on
        (3, 0, 2, 203, 1, 0, -1, 0, 1, 0, 0),  # DO_DIGICAM_CONTROL, shoot (x = 1)
        (4, 0, 3, 16, 0, 0, 0, 0, lat + 2e-5, lon, -2.0),
        (5, 0, 2, 177, 1.7, 3, 0, 0, 0, 0, 0),  # DO_JUMP to 1, 3 times
        (6, 0, 2, 114, 2.5, 0, 0, 0, 0, 0, 0),  # CONDITION_DISTANCE 2.5 m
        (7, 0, 3, 21, 0, 0, 0, -1, lat + 2e-5, lon, 0.0),  # NAV_LAND (surface) there
    ]
    src = workdir / "hand.waypoints"
    src.write_text("QGC WPL 110\n" + "".join(
        "\t".join(str(v) for v in (*r[:8], f"{r[8]:.8f}", f"{r[9]:.8f}", r[10], 1)) + "\n" for r in rows))
    assert gcs.wp_load(src) == len(rows)
    back = workdir / "hand_back.waypoints"
    assert gcs.wp_save(back) == len(rows)
    got = read_waypoints(back)
    commands_and_params = [(int(g[3]), *g[4:8]) for g in got[1:]]
    assert commands_and_params == [
        (16, 0.0, 0.0, 0.0, 0.0), (183, 9.0, 1900.0, 0.0, 0.0), (203, 1.0, 0.0, -1.0, 0.0),
        (16, 0.0, 0.0, 0.0, 0.0), (177, 1.0, 3.0, 0.0, 0.0), (114, 2.5, 0.0, 0.0, 0.0), (21, 0.0, 0.0, 0.0, -1.0)]
    assert [int(g[2]) for g in got[1:]] == [3, 0, 0, 3, 0, 0, 3]
    assert got[3][8] == 1.0  # the camera's shooting command kept in x
    assert got[7][8:10] == pytest.approx((lat + 2e-5, lon), abs=1.5e-6)
