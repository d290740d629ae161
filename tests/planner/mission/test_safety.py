"""The safety envelope: no depth target below the clearance or beyond the depth limit."""

from __future__ import annotations

import json
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from planner.errors import SafetyViolation
from planner.mission.run_folder import RunFolder
from planner.mission.safety import SafetyLimits, clamp_depth, safe_depth_for_altitude

finite = st.floats(allow_nan=False, allow_infinity=False)


@given(
    clearance=st.floats(0.1, 5.0),
    depth_limit=st.floats(1.0, 300.0),
    seabed=st.floats(0.5, 400.0),
    seabed_std=st.floats(0.0, 0.5),
    altitude=st.floats(-10.0, 50.0),
)
def test_commanded_depth_never_leaves_the_envelope(clearance, depth_limit, seabed, seabed_std, altitude):
    limits = SafetyLimits(min_clearance_m=clearance, depth_limit_m=depth_limit)
    try:
        cmd = safe_depth_for_altitude(altitude, seabed_depth_m=seabed, seabed_std_m=seabed_std, limits=limits)
    except SafetyViolation as exc:
        # Refused only when no depth at all keeps the clearance.
        assert exc.reason == "no_safe_depth"
        assert seabed - clearance - 3 * seabed_std < 0
        return
    assert 0.0 <= cmd.depth_m <= depth_limit
    assert seabed - cmd.depth_m >= clearance + 3 * seabed_std - 1e-9
    if cmd.clamped_by is None:
        assert cmd.depth_m == pytest.approx(seabed - altitude)


def test_clamps_name_the_limit():
    limits = SafetyLimits(min_clearance_m=1.0, depth_limit_m=20.0)
    low = safe_depth_for_altitude(0.3, seabed_depth_m=10.0, seabed_std_m=0.0, limits=limits)
    assert low.clamped_by == "clearance" and low.depth_m == pytest.approx(9.0)
    deep = safe_depth_for_altitude(1.0, seabed_depth_m=40.0, seabed_std_m=0.0, limits=limits)
    assert deep.clamped_by == "depth limit" and deep.depth_m == pytest.approx(20.0)
    assert clamp_depth(-2.0, seabed_depth_m=None, limits=limits).clamped_by == "surface"
    ok = safe_depth_for_altitude(2.0, seabed_depth_m=10.0, seabed_std_m=0.01, limits=limits)
    assert ok.clamped_by is None and ok.depth_m == pytest.approx(8.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_estimates_are_refused(bad):
    limits = SafetyLimits(min_clearance_m=1.0, depth_limit_m=20.0)
    with pytest.raises(SafetyViolation, match="not finite"):
        safe_depth_for_altitude(2.0, seabed_depth_m=bad, seabed_std_m=0.0, limits=limits)
    with pytest.raises(SafetyViolation, match="not finite"):
        clamp_depth(bad, seabed_depth_m=10.0, limits=limits)


@pytest.mark.parametrize("kwargs", [dict(min_clearance_m=0.0, depth_limit_m=10.0),
                                    dict(min_clearance_m=1.0, depth_limit_m=math.nan)])
def test_limits_are_validated(kwargs):
    with pytest.raises(ValueError):
        SafetyLimits(**kwargs)


def test_run_folder_lines_survive_as_written(tmp_path):
    run = RunFolder(tmp_path / "run")
    run.event(1.25, "state", "enter PASS_1", state="PASS_1", value=math.nan)
    series = run.series("nav.csv", ("t_s", "north_m"))
    series.append(t_s=1.0, north_m=math.nan)
    series.append(t_s=2.0, north_m=3.5)
    # Readable before close (flushed per line), as after a crash.
    lines = (tmp_path / "run" / "events.jsonl").read_text().splitlines()
    assert json.loads(lines[0]) == {"t_s": 1.25, "kind": "state", "message": "enter PASS_1", "state": "PASS_1",
                                    "value": None}
    assert (tmp_path / "run" / "nav.csv").read_text().splitlines() == ["t_s,north_m", "1,", "2,3.5"]
    with pytest.raises(KeyError, match="unknown columns"):
        series.append(speed=1.0)
    run.write_json("summary.json", {"x": math.inf})
    assert json.loads((tmp_path / "run" / "summary.json").read_text()) == {"x": None}
    run.close()
