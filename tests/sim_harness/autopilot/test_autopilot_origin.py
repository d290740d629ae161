"""EKF origin, home and SYS_STATUS bits as a BlueOS sub with a DVL reports them."""

from __future__ import annotations

from sim_harness.faults import FaultConfig, TimeWindow
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle, vehicle_config


def test_no_origin_until_set_then_home_once_the_ekf_has_a_position():
    """set_ekf_origin: once, then ignored; GPS_GLOBAL_ORIGIN on the link; update_home_from_EKF
    sets home and sends HOME_POSITION; without an origin GLOBAL_POSITION_INT is at 0, 0."""
    with running_vehicle(config=vehicle_config(origin=None, start_depth_m=2.0)) as (_sim, gcs):
        pos = gcs.wait_for("GLOBAL_POSITION_INT", 1.0)
        assert (pos.lat, pos.lon) == (0, 0)
        assert abs(pos.relative_alt / 1000.0 + 2.0) < 0.2  # depth is still there
        assert gcs.command(M.MAV_CMD_GET_HOME_POSITION).result == M.MAV_RESULT_FAILED
        gcs.mav.set_gps_global_origin_send(1, 432950000, 53600000, 0)
        origin = gcs.wait_for("GPS_GLOBAL_ORIGIN", 1.0)
        assert (origin.latitude, origin.longitude) == (432950000, 53600000)
        home = gcs.wait_for("HOME_POSITION", 1.0)
        assert abs(home.latitude - 432950000) < 5 and abs(home.longitude - 53600000) < 5
        gcs.run_for(0.5)
        gcs.mav.set_gps_global_origin_send(1, 470000000, 80000000, 0)  # ignored: already set
        assert gcs.wait_for("GPS_GLOBAL_ORIGIN", 1.0) is None
        pos = gcs.wait_for("GLOBAL_POSITION_INT", 1.0)
        assert abs(pos.lat - 432950000) < 50 and abs(pos.lon - 53600000) < 50


def test_backup_origin_parameters_are_used_at_arming():
    cfg = vehicle_config(origin=None, params={"ORIGIN_LAT": 43.295, "ORIGIN_LON": 5.36})
    with running_vehicle(config=cfg) as (_sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        origin = gcs.wait_for("GPS_GLOBAL_ORIGIN", 1.0)
        # ORIGIN_LAT is an AP_Float: float32 carries 43.295 to about 2e-6 deg
        assert origin is not None and abs(origin.latitude - 432950000) < 30
        assert any(m.text == "Using backup location" for m in gcs.log if m.get_type() == "STATUSTEXT")


def test_sys_status_bits_and_ekf_flags():
    """GCS.cpp / GCS_Sub.cpp: pre-arm check healthy, geofence present (FENCE_TYPE 7) but not
    enabled, rangefinder and DVL (vision) present; losing the DVL clears their health and
    EKF_STATUS_REPORT goes to constant-position mode."""
    faults = FaultConfig(position_loss=(TimeWindow(3.0, 100.0),))
    with running_vehicle(config=vehicle_config(start_depth_m=3.0), faults=faults) as (_sim, gcs):
        s = gcs.wait_for("SYS_STATUS", 1.0)
        for bit in (M.MAV_SYS_STATUS_PREARM_CHECK, M.MAV_SYS_STATUS_GEOFENCE, M.MAV_SYS_STATUS_SENSOR_LASER_POSITION,
                    M.MAV_SYS_STATUS_SENSOR_VISION_POSITION, M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE):
            assert s.onboard_control_sensors_present & bit and s.onboard_control_sensors_health & bit, bit
        assert not s.onboard_control_sensors_enabled & M.MAV_SYS_STATUS_GEOFENCE
        assert not s.onboard_control_sensors_enabled & M.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL  # MANUAL
        ekf = gcs.wait_for("EKF_STATUS_REPORT", 1.0)
        assert ekf.flags & 16 and not ekf.flags & 128  # POS_HORIZ_ABS, not CONST_POS_MODE
        gcs.run_for(3.5)
        s = gcs.wait_for("SYS_STATUS", 1.0)
        assert not s.onboard_control_sensors_health & M.MAV_SYS_STATUS_SENSOR_VISION_POSITION
        ekf = gcs.wait_for("EKF_STATUS_REPORT", 1.0)
        assert ekf.flags & 128 and not ekf.flags & 8
