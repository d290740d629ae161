"""Faults behave as configured: link loss/dup/corruption/cuts/latency, sensor faults, sonar."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from sim_harness.errors import SimConfigError
from sim_harness.faults import FaultConfig, LinkFaults, TimeWindow
from sim_harness.simulator import VehicleConfig, VehicleSimulator
from sim_harness.vehicle.sensors import FlatSeabed, SensorConfig, SensorSuite
from tests.sim_harness.autopilot.gcs_peer import running_vehicle


def _link(cfg: FaultConfig) -> LinkFaults:
    return LinkFaults(cfg, np.random.default_rng(cfg.seed))


def test_packet_loss_rate_and_duplication_rate():
    link = _link(FaultConfig(packet_loss=0.3, duplicate=0.2, seed=1))
    for i in range(10_000):
        link.push(i * 0.01, b"x" * 10)
    delivered = link.pop_due(1e9)
    assert 0.27 < link.dropped / 10_000 < 0.33
    assert len(delivered) == 10_000 - link.dropped + link.duplicated
    assert 0.17 < link.duplicated / (10_000 - link.dropped) < 0.23


def test_latency_delays_and_cut_windows_drop():
    link = _link(FaultConfig(latency_s=0.5, link_cuts=(TimeWindow(10.0, 12.0),)))
    link.push(1.0, b"a")
    assert link.pop_due(1.4) == []
    assert link.pop_due(1.5) == [b"a"]
    link.push(9.8, b"b")  # sent before the cut, due inside it: lost
    link.push(11.0, b"c")  # sent inside: lost
    link.push(12.6, b"d")
    assert link.pop_due(20.0) == [b"d"]
    assert link.dropped == 2


def test_corruption_flips_a_byte():
    link = _link(FaultConfig(corrupt_bytes=1.0))
    link.push(0.0, bytes(range(20)))
    (out,) = link.pop_due(0.0)
    assert out != bytes(range(20)) and len(out) == 20
    assert sum(a != b for a, b in zip(out, bytes(range(20)), strict=True)) == 1


def test_fault_config_is_validated():
    with pytest.raises(SimConfigError, match="packet_loss"):
        FaultConfig(packet_loss=1.5)
    with pytest.raises(SimConfigError):
        TimeWindow(5.0, 1.0)


def test_a_cut_link_goes_silent_for_its_window_over_mavlink():
    faults = FaultConfig(link_cuts=(TimeWindow(3.0, 6.0),))
    with running_vehicle(faults=faults) as (_sim, gcs):
        gcs.run_for(3.0 - gcs.clock.now_s())
        assert gcs.run_for(2.9) == []  # nothing passes during the cut
        assert any(m.get_type() == "ATTITUDE" for m in gcs.run_for(1.5))


def test_lossy_corrupt_link_still_carries_telemetry_and_counts_bad_packets():
    faults = FaultConfig(packet_loss=0.2, corrupt_bytes=0.2, duplicate=0.1, seed=3)
    with running_vehicle(faults=faults) as (sim, gcs):
        msgs = gcs.run_for(10.0)
        att = sum(m.get_type() == "ATTITUDE" for m in msgs)
        assert 45 < att < 85  # 100 sent, about 64 arrive intact (+ duplicates)
        assert sim.port is not None
        for _ in range(20):
            gcs.heartbeat()
        gcs.run_for(1.0)
        assert sim.port.bad_packets > 0  # corrupted uplink packets fail their CRC


def _suite(faults: FaultConfig, config: SensorConfig | None = None, seed: int = 0) -> SensorSuite:
    return SensorSuite(FlatSeabed(10.0), config or SensorConfig(), faults,
                       np.random.default_rng(seed), start_north_m=0.0, start_east_m=0.0)


STATE = (0.0, 0.0, 4.0, 0.0, 0.5, 0.0, 0.0, 0.0)
ATT = (0.0, 0.0, 0.0, 0.0)


def test_depth_spikes_and_altimeter_dropouts():
    suite = _suite(FaultConfig(depth_spike_prob=0.1, depth_spike_m=3.0,
                               altimeter_dropouts=(TimeWindow(5.0, 6.0),)))
    readings = [suite.sample(k * 0.02, STATE, ATT) for k in range(500)]
    spikes = [r for r in readings if abs(r.depth_m - 4.0) > 2.0]
    assert 25 < len(spikes) < 80
    assert all(abs(abs(r.depth_m - 4.0) - 3.0) < 0.1 for r in spikes)
    for r in readings:
        assert (r.altitude_m is None) == (5.0 <= r.time_s <= 6.0)
        if r.altitude_m is not None:
            assert abs(r.altitude_m - 6.0) < 0.2


def test_altimeter_range_limit() -> None:
    suite = _suite(FaultConfig(), SensorConfig(altimeter_max_range_m=5.0))
    assert suite.sample(0.0, STATE, ATT).altitude_m is None  # 6 m above the seabed, beyond the 5 m range
    near = (*STATE[:2], 6.0, *STATE[3:])  # 4 m above it
    assert suite.sample(0.02, near, ATT).altitude_m == pytest.approx(4.0, abs=0.2)


def _dead_reckoning_error_m(walk_m_s: float, seed: int, duration_s: float = 60.0) -> float:
    """Radial error of the DVL's dead-reckoned position after ``duration_s`` at 0.5 m/s north."""
    suite = _suite(FaultConfig(), SensorConfig(dvl_bias_walk_m_s=walk_m_s), seed=seed)
    x = list(STATE)
    steps = int(round(duration_s / 0.02))
    for k in range(1, steps + 1):
        x[0] = 0.5 * k * 0.02  # true north position, moving at 0.5 m/s
        r = suite.sample(k * 0.02, tuple(x), ATT)
    return math.hypot(r.north_m - x[0], r.east_m)


def test_dvl_bias_walk_drifts_as_integrated_brownian_motion() -> None:
    """A velocity bias that random-walks at q m/s per sqrt(s) on each axis integrates to a
    position error of variance q^2 t^3 / 3 per axis: RMS radial error q sqrt(2 t^3 / 3),
    3.79 m after 60 s at q = 0.01. Over 20 seeds the RMS is within 35 % of it (its own
    spread is about 11 %), and without the walk (velocity noise only) the error is a
    hundredth of that."""
    walk, t = 0.01, 60.0
    errors = np.array([_dead_reckoning_error_m(walk, seed, t) for seed in range(20)])
    expected = walk * math.sqrt(2.0 * t**3 / 3.0)
    assert float(np.sqrt(np.mean(errors**2))) == pytest.approx(expected, rel=0.35)
    quiet = np.array([_dead_reckoning_error_m(0.0, seed, t) for seed in range(5)])
    assert float(np.max(quiet)) < 0.01 * expected


@dataclass(frozen=True)
class _Pose:
    north_m: float
    east_m: float
    depth_m: float
    heading_rad: float
    pitch_rad: float
    roll_rad: float
    tilt_rad: float


class _EchoRenderer:
    """Stand-in renderer: the 'frame' is (timestamp, tilt); truth is the pose."""

    def render(self, pose, timestamp_s):
        return (timestamp_s, pose.tilt_rad), pose


def test_sonar_frames_at_the_frame_rate_with_drops_and_truth_kept_apart():
    def run(drop: float) -> tuple[list, VehicleSimulator]:
        sim = VehicleSimulator(config=VehicleConfig(sonar_frame_rate_hz=10.0,
                                                    max_pending_frames=1000),
                               faults=FaultConfig(sonar_drop=drop, seed=2),
                               sonar_renderer=_EchoRenderer(), pose_factory=_Pose)
        sim.run_for(20.0)
        assert sim.sonar is not None
        return sim.sonar.poll(sim.clock.now_s()), sim

    frames, sim = run(0.0)
    times = [f[0] for f in frames]
    assert len(frames) == 200
    assert np.allclose(np.diff(times), 0.1)
    assert len(sim.sonar_truths()) == 200  # truth goes to the truth API, not the frames
    assert all(isinstance(tr, _Pose) for _, tr in sim.sonar_truths())
    dropped, sim2 = run(0.25)
    assert sim2.sonar is not None
    assert len(dropped) + sim2.sonar.frames_dropped == 200
    assert 30 < sim2.sonar.frames_dropped < 70


@dataclass(frozen=True)
class _Frame:
    timestamp_s: float
    north_m: float
    altitude_m: float
    tilt_rad: float


class _TruthStampingRenderer:
    """Stand-in that stamps the TRUE pose into its frame, as a renderer does."""

    def render(self, pose, timestamp_s):
        return _Frame(timestamp_s, pose.north_m, 1.0, pose.tilt_rad), pose


def test_sonar_frames_carry_the_vehicle_estimates_never_truth():
    faults = FaultConfig(position_loss=(TimeWindow(0.0, 2.0),),
                         altimeter_dropouts=(TimeWindow(0.0, 1.0),))
    sim = VehicleSimulator(FlatSeabed(10.0), config=VehicleConfig(start_north_m=3.0,
                                                                  start_depth_m=4.0),
                           faults=faults, sonar_renderer=_TruthStampingRenderer(),
                           pose_factory=_Pose)
    sim.run_for(3.0)
    assert sim.sonar is not None
    frames = sim.sonar.poll(sim.clock.now_s())
    truths = dict(sim.sonar_truths())
    assert len(frames) == 30
    for f in frames:
        true_pose = truths[f.timestamp_s]
        assert true_pose.north_m == pytest.approx(3.0, abs=0.01)
        # Without a position estimate the frame does not know where it is ...
        assert math.isnan(f.north_m) == (f.timestamp_s <= 2.0)
        # ... and without the altimeter it does not know its altitude.
        assert math.isnan(f.altitude_m) == (f.timestamp_s <= 1.0)
        if not math.isnan(f.altitude_m):
            assert f.altitude_m == pytest.approx(10.0 - true_pose.depth_m, abs=0.2)
        assert f.tilt_rad == true_pose.tilt_rad  # the mount reports its own angle
