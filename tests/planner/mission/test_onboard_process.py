"""The frame-to-map chain in its own process (``OnboardConfig.map_process``) gives what it
gives in thread, one call of ``process_frames`` later; a dead map process is reported, not
waited for.

Frames: a lane over two raised targets (a 15 cm cylinder and an 8 cm box) on a textured
seabed at 1 m altitude, with the telemetry of their poses, fed to two
:class:`OnboardPerception` side by side in two-frame batches, as a control cycle does.
"""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from perception.child_process import read_message, write_message
from perception.mapping.map_process import MapProcessError, SurveyMapProcess, serve
from perception.mapping.mosaic import MosaicConfig
from perception.mapping.registration import RegistrationConfig
from perception.mapping.survey_map import SurveyMap
from planner.mission.onboard import OnboardConfig, OnboardPerception
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.world.materials import MATERIALS
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import Seabed, TargetSpec, World
from tests.perception.mapping.test_mosaic_render import ALTITUDE_M, PING_INTERVAL_S, RES_M, SEABED_DEPTH_M, TILT_RAD
from tests.planner.mission.test_onboard_mosaic import _telemetry

TARGETS = (TargetSpec("C", "cylinder", 3.0, -0.15, 0.2, 0.2, 0.15, material="metal"),
           TargetSpec("B", "box", 3.6, 0.2, 0.2, 0.2, 0.08, material="concrete"))
N_FRAMES = 36
SPEED_M_S = 0.5


@pytest.fixture(scope="module")
def frames():
    world = World(Seabed(SEABED_DEPTH_M, texture=SeabedTexture(std_db=3.0, correlation_m=0.1, seed=3)), TARGETS,
                  MATERIALS)
    renderer = SonarRenderer(world, SonarConfig(samples_per_beam=500))
    out = []
    for k in range(N_FRAMES):
        pose = SonarPose(0.6 + SPEED_M_S * PING_INTERVAL_S * k, 0.0, SEABED_DEPTH_M - ALTITUDE_M, heading_rad=0.0,
                         tilt_rad=TILT_RAD)
        out.append(renderer.render(pose, k * PING_INTERVAL_S)[0])
    return out


def _feed(onboard: OnboardPerception, batch) -> list:
    for frame in batch:
        for record in _telemetry(frame, SEABED_DEPTH_M - ALTITUDE_M):
            onboard.listener(record)
    onboard.drain()
    return onboard.process_frames(batch)


def _seen(results) -> str:
    """Each frame's measurements, exactly (repr: NaN equals NaN)."""
    return repr([(r.frame_index, r.target_ids, [(m.r_top_m, m.r_end_m, m.azimuth_rad) for m in r.measurements])
                 for r in results])


def _places(targets) -> str:
    return repr([(t.target_id, t.north_m, t.east_m, t.height_m, t.frames_seen) for t in targets])


def _tracked(targets) -> str:
    return repr([(t.target_id, t.height_m, t.last_frame_index, t.last_north_m, t.last_east_m) for t in targets])


@pytest.mark.slow
def test_the_map_process_answers_as_in_thread_one_cycle_later(frames) -> None:
    config = OnboardConfig(mosaic_resolution_m=RES_M)
    here = OnboardPerception(config)
    # Targets back with every batch here (0 s), to compare them cycle by cycle.
    there = OnboardPerception(OnboardConfig(mosaic_resolution_m=RES_M, map_process=True, tracked_targets_every_s=0.0))
    try:
        batches = [frames[i:i + 2] for i in range(0, len(frames), 2)]
        previous: list = []
        tracked_before = _tracked([])
        measured = 0
        for batch in batches:
            now_here = _feed(here, batch)
            now_there = _feed(there, batch)
            # What the process returns now is what the thread returned one call before.
            assert _seen(now_there) == _seen(previous)
            assert _tracked(there.tracked_targets()) == tracked_before
            assert there.frames_measured == (here.frames_measured - len(now_here))
            previous, tracked_before = now_here, _tracked(here.tracked_targets())
            measured += sum(len(r.measurements) for r in now_here)
        assert measured > 0, "the lane sees its targets"
        # Asking for the products takes the last batch back first: then all agree.
        assert _places(there.targets()) == _places(here.targets())
        # The control loop's view is each target's newest detection.
        last = {t.target_id: t.detections[-1] for t in here.targets()}
        assert {t.target_id: (t.last_frame_index, t.last_north_m) for t in here.tracked_targets()} == \
            {i: (d.frame_index, d.north_m) for i, d in last.items()}
        assert _seen([there.last_frame]) == _seen([here.last_frame])
        assert there.status().frames_used == here.status().frames_used == N_FRAMES
        assert there.status().frames_mapped == here.status().frames_mapped
        assert repr([(t.north_m, t.east_m, t.height_m) for t in there.mapped_targets()]) == \
            repr([(t.north_m, t.east_m, t.height_m) for t in here.mapped_targets()])
        heights = sorted(t.height_m for t in here.mapped_targets() if t.height_m is not None)
        assert heights and max(heights) == pytest.approx(0.15, abs=0.02), "the cylinder's height is measured"
        a, b = here.map_raster(), there.map_raster()
        assert a is not None and b is not None
        np.testing.assert_array_equal(a.intensity, b.intensity)
        assert (a.north_m, a.west_m) == (b.north_m, b.west_m)
    finally:
        there.close()


def test_a_dead_map_process_is_reported_not_waited_for(frames) -> None:
    onboard = OnboardPerception(OnboardConfig(mosaic_resolution_m=RES_M, map_process=True))
    try:
        _feed(onboard, frames[:2])
        child = onboard._map.process  # the child, to kill it as the OOM killer would
        assert child is not None
        child.kill()
        child.wait()
        with pytest.raises(MapProcessError, match="map process"):
            _feed(onboard, frames[2:4])  # the batch sent before the death cannot come back
    finally:
        onboard.close()


def test_the_map_process_refuses_what_the_map_cannot_answer() -> None:
    worker = SurveyMapProcess(SurveyMap())
    try:
        with pytest.raises(ValueError, match="unknown query 'add_frame'"):
            worker.query("add_frame")
        with pytest.raises(MapProcessError, match="no batch to collect"):
            worker.collect()
        assert worker.query("targets") == []
        assert worker.query("raster", None) is None  # no frame mapped yet
        assert math.isfinite(worker.process.pid)
    finally:
        worker.close()
    assert worker.process.wait(5.0) == 0


def test_the_targets_come_back_at_their_interval(frames) -> None:
    """With the default interval the control loop's targets change only every 0.5 s of frames."""
    onboard = OnboardPerception(OnboardConfig(mosaic_resolution_m=RES_M, map_process=True))
    try:
        changed_at = []
        last = onboard.tracked_targets()
        for i in range(0, len(frames), 2):
            _feed(onboard, frames[i:i + 2])
            now = onboard.tracked_targets()
            if now is not last:
                changed_at.append(frames[i].timestamp_s)
                last = now
        steps = np.diff(changed_at)
        assert len(changed_at) >= 5 and np.all(steps >= 0.5 - 1e-9), changed_at
    finally:
        onboard.close()


class _BlendFails(SurveyMap):
    """A map whose blends fail: the error must reach the parent, not vanish in the child."""

    def finish_frame(self) -> None:
        if self._waiting is not None:
            self._waiting = None
            raise RuntimeError("the blend failed")


def test_a_frame_measured_then_blended_makes_the_map_add_frame_makes(frames) -> None:
    """The map process answers between a frame's measurement and its blend; the map is the
    same, the counters leave the waiting blend out until it is done."""
    def new_map() -> SurveyMap:
        return SurveyMap(mosaic=MosaicConfig(resolution_m=RES_M), registration=RegistrationConfig())

    whole, halves = new_map(), new_map()
    for k, frame in enumerate(frames):
        drift_before = whole.drift
        a = whole.add_frame(frame)
        b = halves.measure_frame(frame)
        assert _seen([a]) == _seen([b])
        assert halves.frames_mapped == k and whole.frames_mapped == k + 1
        assert halves.drift == drift_before  # its registration waits with its blend
    assert halves.counters() == whole.counters()
    assert whole.drift is not None and whole.drift.accepted + whole.drift.refused > 0, "registration took part"
    np.testing.assert_array_equal(halves.raster().intensity, whole.raster().intensity)
    assert _places(halves.targets()) == _places(whole.targets())


def test_a_failed_blend_is_the_next_answer(frames) -> None:
    messages, replies = io.BytesIO(), io.BytesIO()
    write_message(messages, _BlendFails(mosaic=MosaicConfig(resolution_m=RES_M)))
    write_message(messages, ("batch", ([(frames[0], True)], False)))
    write_message(messages, ("counters", ()))
    write_message(messages, None)
    messages.seek(0)
    serve(messages, replies)
    replies.seek(0)
    kind, batch = read_message(replies)
    assert kind == "ok" and len(batch.results) == 1 and batch.frames_mapped == 0
    kind, error = read_message(replies)
    assert kind == "error" and "the blend failed" in str(error)
    with pytest.raises(EOFError):
        read_message(replies)
