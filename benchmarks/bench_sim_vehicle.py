"""Benchmark: simulated seconds per wall second of the software ROV.

Case "vehicle": MAVLink on a UDP socket with a ground station peer receiving telemetry at
ArduSub's default stream rates, GUIDED flight between two points, sonar poses captured at
10 frames/s (frames rendered by the consumer). Case "vehicle + rendering": the same with
every frame rendered by the real renderer in the same thread (open-seabed scene), if the
renderer is available. One core; run with ``python -m benchmarks.bench_sim_vehicle``.
"""

from __future__ import annotations

import socket
import time
from typing import Any

from sim_harness.autopilot.autopilot import AutopilotConfig, Mode
from sim_harness.simulator import VehicleConfig, VehicleSimulator

SIM_SECONDS = 120.0
GCS_DRAIN_EVERY_STEPS = 10


def _run(render: bool) -> tuple[float, float, int, int]:
    renderer: Any = None
    world: Any = None
    if render:
        from sim_harness.sonar.renderer import SonarRenderer
        from sim_harness.sonar.scene import load_scene

        scene = load_scene("open-seabed")
        world = scene.world
        renderer = SonarRenderer(world)
    else:
        class _PoseOnly:
            def render(self, pose, timestamp_s):  # noqa: ANN001, ANN202
                return pose, None

        renderer = _PoseOnly()
    no_joystick = AutopilotConfig(params={"FS_PILOT_INPUT": 0})  # a bench: the pilot-input failsafe off
    sim = VehicleSimulator(world, config=VehicleConfig(start_depth_m=5.0, autopilot=no_joystick),
                           listen="udp:127.0.0.1:0", sonar_renderer=renderer,
                           pose_factory=None if render else dict)
    gcs = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    gcs.bind(("127.0.0.1", 0))
    gcs.setblocking(False)
    gcs.sendto(b"\xfd\x09\x00\x00\x00\xff\xbe\x00\x00\x00" + bytes(11), sim.address)
    sim.run_for(0.1)
    ap = sim.autopilot
    ap.arm(force=True)
    ap.set_mode(Mode.GUIDED)
    ap.set_guided_target(60.0, 20.0, 8.0)
    received = 0
    frames = 0
    steps = int(SIM_SECONDS / sim.config.step_s)
    t0 = time.perf_counter()
    c0 = time.process_time()
    for k in range(steps):
        sim.step()
        if k % GCS_DRAIN_EVERY_STEPS == 0:
            while True:
                try:
                    gcs.recv(65535)
                except BlockingIOError:
                    break
                received += 1
            assert sim.sonar is not None
            frames += len(sim.sonar.poll(sim.clock.now_s()))
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    sim.close()
    gcs.close()
    return SIM_SECONDS / wall, SIM_SECONDS / cpu, received, frames


def _run_lockstep() -> tuple[float, float]:
    """Simulator thread + a controller thread in lockstep, waking at 10 Hz to poll sonar."""
    from sim_harness.clock import SimClock

    class _PoseOnly:
        def render(self, pose, timestamp_s):  # noqa: ANN001, ANN202
            return pose, None

    clock = SimClock()
    sim = VehicleSimulator(config=VehicleConfig(start_depth_m=5.0), clock=clock,
                           listen="udp:127.0.0.1:0", sonar_renderer=_PoseOnly(),
                           pose_factory=dict)
    frames = 0
    with clock.participant("controller"):
        sim.start()
        t0 = time.perf_counter()
        c0 = time.process_time()
        while clock.now_s() < SIM_SECONDS:
            clock.sleep_s(0.1)
            assert sim.sonar is not None
            frames += len(sim.sonar.poll(clock.now_s()))
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0
    sim.stop()
    return clock.now_s() / wall, clock.now_s() / cpu


def main() -> None:
    """Print the Markdown section of figures."""
    print("## sim_harness vehicle (bench_sim_vehicle)\n")
    print(f"{SIM_SECONDS:.0f} simulated s, step 20 ms, telemetry at ArduSub default rates to "
          "a UDP peer, sonar 10 frames/s.\n")
    print("| case | sim s per wall s | sim s per CPU s | telemetry packets | sonar frames |")
    print("| --- | ---: | ---: | ---: | ---: |")
    speed, cpu_speed, pkts, frames = _run(render=False)
    print(f"| vehicle (frames rendered by the consumer) | {speed:.0f}x | {cpu_speed:.0f}x | "
          f"{pkts} | {frames} |")
    speed, cpu_speed = _run_lockstep()
    print(f"| vehicle + controller thread in lockstep, waking at 10 Hz | {speed:.0f}x | "
          f"{cpu_speed:.0f}x | | |")
    try:
        speed, cpu_speed, pkts, frames = _run(render=True)
    except ImportError as exc:  # renderer not available
        print(f"| vehicle + rendering | n/a ({exc}) | | | |")
    else:
        print(f"| vehicle + rendering every frame in the same thread | {speed:.0f}x | "
              f"{cpu_speed:.0f}x | {pkts} | {frames} |")


if __name__ == "__main__":
    main()
