"""The sonar rendered in a child process gives the frames an in-thread render gives, in
order, a fixed latency after each ping; its errors and its death reach the controller."""

from __future__ import annotations

import numpy as np
import pytest

from sim_harness.errors import SimConfigError
from sim_harness.faults import FaultConfig
from sim_harness.render_worker import RenderWorker, RenderWorkerError
from sim_harness.simulated_sonar import SimulatedSonar, default_pose_factory
from sim_harness.simulator import VehicleConfig
from sim_harness.sonar.renderer import SonarConfig, SonarRenderer
from sim_harness.sonar.scene import load_scene
from sim_harness.world.errors import PoseError


@pytest.fixture(scope="module")
def renderer() -> SonarRenderer:
    from planner.dryrun.scenario import load_scenario

    scene = load_scene(load_scenario("paper-targets").scene_path)
    return SonarRenderer(scene.world, SonarConfig(seed=7, fill_altitude=False, samples_per_beam=400))


def _pose(renderer: SonarRenderer, i: int) -> dict[str, float]:
    north, east = -1.0 + 0.05 * i, 0.4
    depth = float(renderer.world.seabed_depth_m(north, east)) - 1.2
    return {"north_m": north, "east_m": east, "depth_m": depth, "heading_rad": 0.0, "pitch_rad": 0.01,
            "roll_rad": 0.0, "tilt_rad": 0.45}


def _sonar(renderer: SonarRenderer, *, worker: bool, latency_s: float, truths: list) -> SimulatedSonar:
    return SimulatedSonar(renderer, frame_rate_hz=10.0, pose_factory=default_pose_factory, faults=FaultConfig(),
                          rng=np.random.default_rng(0), max_pending=32, latency_s=latency_s,
                          on_truth=lambda t, truth: truths.append((t, truth)),
                          worker=RenderWorker(renderer, default_pose_factory, keep_label_images=False)
                          if worker else None)


def test_frames_from_the_worker_equal_the_in_thread_ones_and_come_after_the_latency(renderer) -> None:
    truths_a: list = []
    truths_b: list = []
    inline = _sonar(renderer, worker=False, latency_s=0.0, truths=truths_a)
    ahead = _sonar(renderer, worker=True, latency_s=0.25, truths=truths_b)
    try:
        for i in range(12):
            t_s = 0.1 * i
            known = {"sonar_depth_m": 5.0, "altitude_m": 1.2, "tilt_rad": 0.45}
            inline.capture(t_s, _pose(renderer, i), known)
            ahead.capture(t_s, _pose(renderer, i), known)
        late = ahead.poll(0.1 * 11)  # pings up to 0.85 s: the last two are not due yet
        assert [f.timestamp_s for f in late] == pytest.approx([0.1 * i for i in range(9)])
        rest = ahead.poll(10.0)
        assert [f.timestamp_s for f in rest] == pytest.approx([0.9, 1.0, 1.1])
        frames = inline.poll(10.0)
        assert len(frames) == 12
        for a, b in zip(frames, late + rest, strict=True):
            assert np.array_equal(a.image, b.image)
            assert a.timestamp_s == b.timestamp_s and a.altitude_m == b.altitude_m == 1.2
        # Truth arrives with each frame, its label images left behind in the child
        assert [t for t, _ in truths_b] == [t for t, _ in truths_a]
        assert all(truth.labels.size == 0 for _, truth in truths_b)
        assert [len(a.targets) for _, a in truths_a] == [len(b.targets) for _, b in truths_b]
    finally:
        ahead.close()


def test_a_render_error_is_raised_where_the_frame_is_asked_for(renderer) -> None:
    worker = RenderWorker(renderer, default_pose_factory, keep_label_images=False)
    try:
        below = dict(_pose(renderer, 0), depth_m=1e4)
        bad = worker.submit(0.0, below)
        good = worker.submit(0.1, _pose(renderer, 1))
        with pytest.raises(PoseError, match="below the seabed"):
            worker.result(bad)
        frame, _ = worker.result(good)  # the worker renders on after an error
        assert frame.image.shape == (400, renderer.config.n_beams)
    finally:
        worker.close()


def test_a_dead_render_process_is_reported_not_waited_for(renderer) -> None:
    worker = RenderWorker(renderer, default_pose_factory, keep_label_images=False)
    seq = worker.submit(0.0, _pose(renderer, 0))
    worker.result(seq)
    worker.process.kill()
    worker.process.wait()
    with pytest.raises(RenderWorkerError, match="render process"):  # on the send or on the wait
        worker.result(worker.submit(0.1, _pose(renderer, 1)))
    worker.close()


def test_the_latency_is_checked() -> None:
    with pytest.raises(SimConfigError, match="sonar_latency_s"):
        VehicleConfig(sonar_latency_s=-0.1)
