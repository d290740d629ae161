"""Parameters as ArduSub 4.5 declares and serves them (typed PARAM_VALUE, 4.5 names)."""

from __future__ import annotations

from sim_harness.autopilot.params import ARDUSUB_4_5, ParamTable, stored_value
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle


def test_param_values_carry_ardusub_storage_types():
    """GCS_MAVLINK::mav_param_type: AP_Int8 -> INT8, AP_Int16 -> INT16, AP_Int32 -> INT32,
    AP_Float -> REAL32 (ArduSub/Parameters.cpp types)."""
    with running_vehicle() as (_sim, gcs):
        expected = {"SYSID_MYGCS": (M.MAV_PARAM_TYPE_INT16, 255.0), "FS_GCS_ENABLE": (M.MAV_PARAM_TYPE_INT8, 2.0),
                    "FS_PILOT_INPUT": (M.MAV_PARAM_TYPE_INT8, 2.0), "FS_PILOT_TIMEOUT": (M.MAV_PARAM_TYPE_REAL32, 3.0),
                    "ARMING_CHECK": (M.MAV_PARAM_TYPE_INT32, 448.0), "MNT1_TYPE": (M.MAV_PARAM_TYPE_INT8, 1.0),
                    "RNGFND1_MAX_CM": (M.MAV_PARAM_TYPE_INT16, 5000.0),  # the DVL set-up (firmware: 700)
                    "WPNAV_SPEED": (M.MAV_PARAM_TYPE_REAL32, 100.0)}
        for name, (ptype, value) in expected.items():
            msg = gcs.param(name)
            assert msg is not None, name
            assert (msg.param_type, msg.param_value) == (ptype, value), name


def test_4_6_names_are_absent_and_unknown_names_get_no_reply():
    """4.5 has no FS_GCS_TIMEOUT (fixed 2.5 s), no PILOT_SPEED, and RNGFND1_MIN/MAX are
    RNGFND1_MIN_CM/MAX_CM (AP_RangeFinder_Params.cpp); handle_param_request_read answers
    nothing for an unknown name."""
    assert {"FS_GCS_TIMEOUT", "PILOT_SPEED", "RNGFND1_MIN", "RNGFND1_MAX"}.isdisjoint(ARDUSUB_4_5)
    assert {"RNGFND1_MIN_CM", "RNGFND1_MAX_CM", "PILOT_SPEED_UP", "PILOT_SPEED_DN"} <= set(ARDUSUB_4_5)
    with running_vehicle() as (_sim, gcs):
        assert gcs.param("FS_GCS_TIMEOUT") is None
        gcs.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", 5.0, M.MAV_PARAM_TYPE_REAL32)
        assert gcs.wait_for("PARAM_VALUE", 1.0) is None  # handle_param_set: unknown -> silence


def test_param_set_ignores_the_type_field_and_stores_the_parameters_own_type():
    """GCS_Param.cpp handle_param_set ignores param_type; AP_Param::set_float adds 0.01
    away from zero and truncates for integer types; the echo has index -1 (65535)."""
    with running_vehicle() as (_sim, gcs):
        gcs.mav.param_set_send(1, 1, b"SYSID_MYGCS", 253.995, M.MAV_PARAM_TYPE_UINT8)
        echo = gcs.wait_for("PARAM_VALUE", 1.0, lambda m: m.param_id == "SYSID_MYGCS")
        assert echo.param_value == 254.0 and echo.param_type == M.MAV_PARAM_TYPE_INT16
        assert echo.param_index == 65535
        gcs.mav.param_set_send(1, 1, b"FS_GCS_ENABLE", 300.0, M.MAV_PARAM_TYPE_REAL32)
        assert gcs.wait_for("PARAM_VALUE", 1.0).param_value == 127.0  # clamped to int8
        gcs.mav.param_request_list_send(1, 1)
        gcs.run_for(0.1)
        values = [m for m in gcs.log if m.get_type() == "PARAM_VALUE" and m.param_index != 65535]
        assert len({m.param_id for m in values}) == values[0].param_count == len(ARDUSUB_4_5)


def test_stored_value_rounding_and_defaults():
    assert stored_value(M.MAV_PARAM_TYPE_INT8, 2.995) == 3.0
    assert stored_value(M.MAV_PARAM_TYPE_INT8, 2.5) == 2.0
    assert stored_value(M.MAV_PARAM_TYPE_INT16, -1.995) == -2.0
    assert stored_value(M.MAV_PARAM_TYPE_REAL32, 0.1) != 0.1  # float32
    table = ParamTable()
    assert table["RNGFND1_TYPE"] == 0.0 and table["RNGFND1_MAX_CM"] == 700.0  # firmware defaults
    assert table["FENCE_TYPE"] == 7.0 and table["FS_TERRAIN_ENAB"] == 0.0
