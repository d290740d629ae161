"""The assembled software ROV: dynamics, sensors, autopilot, MAVLink socket and sonar.

Typical use in a test (lockstep: simulated time passes only while the test waits)::

    clock = SimClock()                                   # lockstep, as fast as possible
    sim = VehicleSimulator(world, clock=clock, listen="udp:127.0.0.1:0",
                           sonar_renderer=SonarRenderer(world),
                           faults=FaultConfig(packet_loss=0.05, seed=1))
    with clock.participant("controller"):                # this thread holds the sim back
        sim.start()                                      # steps in a background thread
        host, port = sim.address                         # the bound UDP port
        ...  # MAVLink to (host, port); wait with clock.sleep_s / clock.wait_for
        frames = sim.sonar.poll(clock.now_s())           # the sonar source
    truth = sim.truth()                                  # ground truth, tests only
    sim.stop()                                           # also stops the clock

Each step (``VehicleConfig.step_s``, 20 ms): wait until every participant waits on the
clock, read MAVLink, sample the sensors (and record a sonar ping when one is due), run the
autopilot and send its messages, integrate the physics, slew the mount, log truth, advance
the clock. Without ``listen`` there is no socket (autopilot only, for unit tests and the
benchmark); :meth:`VehicleSimulator.step` and :meth:`VehicleSimulator.run_for` step in the
calling thread. Sonar frames carry what the vehicle knows at the ping (its estimates of
depth, altitude, attitude and position, and the mount angle); truth goes only to
:meth:`VehicleSimulator.truth`, :meth:`VehicleSimulator.truth_history` and
:meth:`VehicleSimulator.sonar_truths`.
"""

from __future__ import annotations

import collections
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.autopilot import Autopilot, AutopilotConfig
from sim_harness.autopilot.mavlink_endpoint import MavlinkPort, open_transport
from sim_harness.clock import SimClock
from sim_harness.errors import ClockStopped, SimConfigError
from sim_harness.faults import FaultConfig
from sim_harness.peers import BlueOsServices, LocalPeer, PeerConfig
from sim_harness.render_worker import RenderWorker, strip_label_images
from sim_harness.simulated_sonar import SimulatedSonar, SonarRendererLike, default_pose_factory
from sim_harness.vehicle.dynamics import (
    AttitudeDisturbance,
    MountMechanics,
    RovParams,
    UniformCurrent,
    slew_tilt,
    step_rk4,
)
from sim_harness.vehicle.sensors import (
    FlatSeabed,
    SeabedWorld,
    SensorConfig,
    SensorReadings,
    SensorSuite,
)


class CurrentField(Protocol):
    """A water current field (NED m/s)."""

    def velocity_ned_m_s(
        self, north_m: float, east_m: float, depth_m: float, t_s: float
    ) -> tuple[float, float, float]:
        """Water velocity at a point and time."""
        ...


@dataclass(frozen=True)
class VehicleConfig:
    """Everything about the simulated vehicle except the world, faults and socket."""

    step_s: float = 0.02
    start_north_m: float = 0.0
    start_east_m: float = 0.0
    start_depth_m: float = 0.0
    start_yaw_rad: float = 0.0
    rov: RovParams = field(default_factory=RovParams)
    mount: MountMechanics = field(default_factory=MountMechanics)
    sensors: SensorConfig = field(default_factory=SensorConfig)
    disturbance: AttitudeDisturbance = field(default_factory=AttitudeDisturbance)
    autopilot: AutopilotConfig = field(default_factory=AutopilotConfig)
    sonar_frame_rate_hz: float = 10.0
    max_pending_frames: int = 32  # sonar frames buffered for a slow consumer
    #: From a ping to its frame in the driver, s (:class:`SimulatedSonar`).
    sonar_latency_s: float = 0.0
    #: Render pings in a child process as they are pinged (:mod:`sim_harness.render_worker`).
    sonar_render_process: bool = False
    truth_log_interval_s: float = 0.1
    truth_log_length: int = 100_000
    keep_label_images: bool = False  # keep each sonar frame's label images in the truth log
    seed: int = 0
    #: Other systems on the vehicle's MAVLink network (:mod:`sim_harness.peers`): by
    #: default BlueOS's own services, heartbeating as system 1.
    peers: tuple[PeerConfig, ...] = (BlueOsServices(),)

    def __post_init__(self) -> None:
        if not 0.0 < self.step_s <= 0.1:
            raise SimConfigError(f"must be in (0, 0.1] s, got {self.step_s}", key="step_s")
        if not self.sonar_frame_rate_hz > 0.0:
            raise SimConfigError("must be positive", key="sonar_frame_rate_hz")
        if not 0.0 <= self.sonar_latency_s <= 2.0:
            raise SimConfigError(f"must be in [0, 2] s, got {self.sonar_latency_s}", key="sonar_latency_s")
        if self.max_pending_frames < 1:
            raise SimConfigError("must be >= 1", key="max_pending_frames")


@dataclass(frozen=True)
class VehicleTruth:
    """Ground truth at one instant (for scoring; never sent to the controller)."""

    time_s: float
    north_m: float
    east_m: float
    depth_m: float
    yaw_rad: float
    pitch_rad: float
    roll_rad: float
    tilt_rad: float
    altitude_m: float  # true height above the seabed
    surge_m_s: float
    sway_m_s: float
    heave_m_s: float
    yaw_rate_rad_s: float
    armed: bool
    mode: int


class VehicleSimulator:
    """The software ROV (see the module docstring for use).

    Parameters
    ----------
    world
        Seabed (``sim_harness.world.world.World`` or a stand-in such as ``FlatSeabed``).
    config, faults
        Vehicle settings and faults to inject.
    clock
        The simulation clock; a free-running lockstep ``SimClock()`` if omitted.
    listen
        ``udp:HOST:PORT`` or ``tcp:HOST:PORT`` to serve MAVLink on; None for no socket.
    sonar_renderer
        Something with ``render(pose, timestamp_s) -> (frame, truth)``; None for no sonar.
    pose_factory
        Builds the pose passed to the renderer from keyword fields (north_m, east_m,
        depth_m, heading_rad, pitch_rad, roll_rad, tilt_rad); default
        ``sim_harness.sonar.renderer.SonarPose``.
    current
        Water current field; still water if omitted.
    """

    def __init__(
        self,
        world: SeabedWorld | None = None,
        *,
        config: VehicleConfig | None = None,
        faults: FaultConfig | None = None,
        clock: SimClock | None = None,
        listen: str | None = None,
        sonar_renderer: SonarRendererLike | None = None,
        pose_factory: Callable[..., Any] | None = None,
        current: CurrentField | None = None,
    ) -> None:
        self.world: SeabedWorld = world if world is not None else FlatSeabed()
        self.config = cfg = config or VehicleConfig()
        self.faults = faults or FaultConfig()
        self.clock = clock or SimClock()
        self.current: CurrentField = current or UniformCurrent()
        seeds = np.random.SeedSequence([cfg.seed, self.faults.seed]).spawn(2)
        self.sensors = SensorSuite(
            self.world, cfg.sensors, self.faults, np.random.default_rng(seeds[0]),
            start_north_m=cfg.start_north_m, start_east_m=cfg.start_east_m,
        )
        self.autopilot = Autopilot(cfg.autopilot, cfg.rov, cfg.mount, self.faults)
        self._state: tuple[float, ...] = (
            cfg.start_north_m, cfg.start_east_m, cfg.start_depth_m, cfg.start_yaw_rad,
            0.0, 0.0, 0.0, 0.0,
        )
        self._thrust: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self._pitch_surge_n = 0.0  # the surge thrust through the pitch lag (AttitudeDisturbance)
        self._pitch_surge_rate_n_s = 0.0
        self._tilt_rad = cfg.mount.default_tilt_rad
        self._step_index = 0
        self._t0 = self.clock.now_s()
        self._truth_lock = threading.Lock()
        self._truth: VehicleTruth | None = None
        self._truth_log: collections.deque[VehicleTruth] = collections.deque(
            maxlen=cfg.truth_log_length)
        self._next_log_s = self._t0
        self._sonar_truths: collections.deque[tuple[float, Any]] = collections.deque(
            maxlen=cfg.truth_log_length)
        self.port: MavlinkPort | None = None
        if listen is not None:
            self.port = MavlinkPort(
                open_transport(listen), self.faults, system_id=cfg.autopilot.system_id,
                component_id=cfg.autopilot.component_id,
            )
        self._peers = [LocalPeer(peer) for peer in cfg.peers]
        self._peer_parser = mavlink.MAVLink(None)
        self._peer_parser.robust_parsing = True
        self.sonar: SimulatedSonar | None = None
        if sonar_renderer is not None:
            worker = None
            if cfg.sonar_render_process:
                worker = RenderWorker(sonar_renderer, pose_factory or default_pose_factory,
                                      keep_label_images=cfg.keep_label_images)
            self.sonar = SimulatedSonar(
                sonar_renderer, frame_rate_hz=cfg.sonar_frame_rate_hz,
                pose_factory=pose_factory or default_pose_factory, faults=self.faults,
                rng=np.random.default_rng(seeds[1]), max_pending=cfg.max_pending_frames,
                on_truth=self._record_sonar_truth, latency_s=cfg.sonar_latency_s, worker=worker,
            )
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self.error: BaseException | None = None
        self._update_truth(self._t0, (0.0, 0.0, 0.0, 0.0))

    # ------------------------------------------------------------------ public API
    @property
    def address(self) -> tuple[str, int]:
        """(host, port) the MAVLink socket is bound to."""
        if self.port is None:
            raise SimConfigError("the simulator was created without listen=", key="listen")
        return self.port.transport.bound_address

    def truth(self) -> VehicleTruth:
        """The latest ground truth (thread-safe)."""
        with self._truth_lock:
            assert self._truth is not None
            return self._truth

    def truth_history(self) -> list[VehicleTruth]:
        """Ground truth logged every ``truth_log_interval_s`` (oldest first)."""
        with self._truth_lock:
            return list(self._truth_log)

    def sonar_truths(self) -> list[tuple[float, Any]]:
        """(timestamp_s, FrameTruth) of every sonar frame rendered so far."""
        with self._truth_lock:
            return list(self._sonar_truths)

    def step(self) -> None:
        """Advance one fixed step: I/O, sensors, autopilot, physics, sonar, clock."""
        cfg = self.config
        dt = cfg.step_s
        t = self._t0 + self._step_index * dt
        ap = self.autopilot
        # Let every lockstep participant finish its turn at time t before reading input.
        self.clock.wait_until_idle()
        if self.port is not None:
            replies = []
            for msg in self.port.receive(t):
                replies.extend(ap.handle(msg, t))
            if replies:
                self.port.send(replies, t)
        self._serve_peers(t)
        north, east, down = self._state[0], self._state[1], self._state[2]
        attitude = cfg.disturbance.attitude(t, self._pitch_surge_n, self._pitch_surge_rate_n_s)
        readings = self.sensors.sample(t, self._state, attitude)
        if self.sonar is not None:
            self._capture_sonar(t, attitude, readings)
        thrust, servo_tilt, out = ap.update(t, dt, readings)
        if self.port is not None:
            self.port.send(out, t)
        self._thrust = (thrust[0], thrust[1], thrust[2], thrust[3])
        lagged = cfg.disturbance.lagged_surge_n(self._pitch_surge_n, thrust[0], dt)
        self._pitch_surge_rate_n_s = (lagged - self._pitch_surge_n) / dt
        self._pitch_surge_n = lagged
        current = self.current.velocity_ned_m_s(north, east, down, t)
        state = step_rk4(self._state, self._thrust, current, dt, cfg.rov)
        if state[2] < 0.0:  # the surface: the vehicle cannot fly out of the water
            state = (*state[:2], 0.0, state[3], state[4], state[5], min(state[6], 0.0), state[7])
        self._state = state
        # The tilt servo (its own slew rate and limits) follows the autopilot's output, a
        # body-frame angle: for a stabilised mount the earth-frame target less the pitch.
        self._tilt_rad = slew_tilt(self._tilt_rad, servo_tilt, dt, cfg.mount)
        self._step_index += 1
        t_next = self._t0 + self._step_index * dt
        self._update_truth(t_next, cfg.disturbance.attitude(t_next, self._pitch_surge_n, self._pitch_surge_rate_n_s))
        self.clock.advance_to(t_next)

    def run_for(self, duration_s: float) -> None:
        """Step in the calling thread for ``duration_s`` simulated seconds."""
        n = int(round(duration_s / self.config.step_s))
        for _ in range(n):
            self.step()

    def start(self) -> None:
        """Run the simulator in a background thread until :meth:`stop`."""
        if self._thread is not None:
            raise SimConfigError("already started", key="start")
        self._thread = threading.Thread(target=self._run, name="vehicle-sim", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                self.step()
        except ClockStopped:
            pass
        except BaseException as exc:  # kept for the test to re-raise; the thread ends
            self.error = exc
            self.clock.stop()

    def stop(self, timeout_s: float = 10.0) -> None:
        """Stop the background thread (stops the clock too) and close the socket."""
        self._stop.set()
        self.clock.stop()
        if self._thread is not None:
            self._thread.join(timeout_s)
        self.close()

    def close(self) -> None:
        """Close the socket (and stop the sonar's render process)."""
        if self.port is not None:
            self.port.close()
        if self.sonar is not None:
            self.sonar.close()

    def __enter__(self) -> VehicleSimulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ internals
    def _serve_peers(self, t_s: float) -> None:
        """Deliver the peers' messages to the autopilot and out of the socket, as the
        vehicle's MAVLink router would; the autopilot's answers go out of the socket."""
        ap = self.autopilot
        for peer in self._peers:
            for msg in peer.messages(t_s):
                data = peer.pack(msg)
                replies = []
                for parsed in self._peer_parser.parse_buffer(data) or ():
                    replies.extend(ap.handle(parsed, t_s))
                if self.port is not None:
                    self.port.send_raw(data, t_s)
                    if replies:
                        self.port.send(replies, t_s)

    def _update_truth(self, t_s: float, attitude: tuple[float, float, float, float]) -> None:
        n, e, d, yaw, u, v, w, r = self._state
        truth = VehicleTruth(
            time_s=t_s, north_m=n, east_m=e, depth_m=d, yaw_rad=yaw, pitch_rad=attitude[0],
            roll_rad=attitude[1], tilt_rad=self._tilt_rad,
            altitude_m=self.world.seabed_depth_m(n, e) - d, surge_m_s=u, sway_m_s=v,
            heave_m_s=w, yaw_rate_rad_s=r, armed=self.autopilot.armed,
            mode=int(self.autopilot.mode),
        )
        with self._truth_lock:
            self._truth = truth
            if t_s + 1e-9 >= self._next_log_s:
                self._truth_log.append(truth)
                self._next_log_s += self.config.truth_log_interval_s

    def _capture_sonar(
        self, t_s: float, attitude: tuple[float, float, float, float], r: SensorReadings
    ) -> None:
        assert self.sonar is not None
        n, e, d, yaw = self._state[0], self._state[1], self._state[2], self._state[3]
        pose = {"north_m": n, "east_m": e, "depth_m": d, "heading_rad": yaw,
                "pitch_rad": attitude[0], "roll_rad": attitude[1], "tilt_rad": self._tilt_rad}
        nan = math.nan
        known = {
            "sonar_depth_m": r.depth_m,
            "altitude_m": r.altitude_m if r.altitude_m is not None else nan,
            "tilt_rad": self._tilt_rad,  # the mount's own angle feedback
            "vehicle_pitch_rad": r.pitch_rad,
            "vehicle_roll_rad": r.roll_rad,
            "heading_rad": r.yaw_rad,
            "north_m": r.north_m if r.position_ok else nan,
            "east_m": r.east_m if r.position_ok else nan,
        }
        self.sonar.capture(t_s, pose, known)

    def _record_sonar_truth(self, t_s: float, truth: Any) -> None:
        if not self.config.keep_label_images:
            # Per-target truth is small; the label images (two n_samples x n_beams arrays a
            # frame) would grow to gigabytes over a dive: keep them only when asked.
            truth = strip_label_images(truth)
        with self._truth_lock:
            self._sonar_truths.append((t_s, truth))

