"""A dry-run dive: plan, start the software vehicle, fly it over real MAVLink, score it.

This is the one planner module that imports :mod:`sim_harness` (architecture.md: the CLI
wiring the simulator in as the default vehicle). The controller side (executor,
vehicle_link client, on-board perception) sees only MAVLink bytes on a UDP socket and
sonar frames from the simulated sonar's ``poll``; simulator truth goes only to the
scorer, after the dive, into ``truth.json``, ``truth_track.csv`` and ``shadows.csv``.
"""

from __future__ import annotations

import math
import threading
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from perception.geometry import rot_x, rot_y
from perception.mapping.georef import LocalOrigin
from planner.config import Settings, load_settings
from planner.errors import ConfigError
from planner.mission.executor import DiveResult, ExecutorConfig, MissionExecutor, TiltSource
from planner.mission.onboard import OnboardConfig, OnboardPerception
from planner.mission.products import summary_document, write_products
from planner.mission.run_folder import RunFolder
from planner.mission.safety import SafetyLimits
from planner.report.height_score import score_heights
from planner.survey.area import load_area
from planner.survey.lawnmower import plan_survey
from planner.survey.mission_files import write_outputs
from planner.survey.plan import SurveyPlan
from sim_harness.clock import SimClock
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.simulator import VehicleConfig, VehicleSimulator
from sim_harness.sonar.renderer import SonarConfig, SonarRenderer
from sim_harness.sonar.scene import Scene, load_scene
from sim_harness.vehicle.dynamics import AttitudeDisturbance, UniformCurrent
from sim_harness.vehicle.sensors import SensorConfig
from vehicle_link.client import ArduSubClient
from vehicle_link.config import DEFAULT_MESSAGE_INTERVALS_S, LinkConfig

BUILTIN_SCENARIOS = ("paper-targets",)
#: The mount's angle report every 0.1 s (the link's default, 0.5 s, leaves the frames'
#: tilt stamp several degrees behind while the pitch loop slews the mount).
MOUNT_STATUS_PERIOD_S = 0.1
#: Shadow-in-view scoring (see :func:`score_against_truth`).
FOV_MIN_AHEAD_ALTITUDES = 2.0
FOV_SETTLE_S = 1.0
#: Tilts tried, rad, when asking whether some tilt within the mount's limits shows a shadow.
FOV_TILT_STEP_RAD = math.radians(0.1)
_SCENARIO_KEYS = {"name", "description", "scene", "area", "survey", "vehicle", "executor", "faults", "current",
                  "sensors", "attitude"}
#: ``[attitude]`` keys (degrees and seconds) and the AttitudeDisturbance field each sets.
_ATTITUDE_KEYS = {"pitch_bias_deg": "pitch_bias_rad", "pitch_amplitude_deg": "pitch_amplitude_rad",
                  "pitch_period_s": "pitch_period_s", "roll_amplitude_deg": "roll_amplitude_rad",
                  "roll_period_s": "roll_period_s"}


@dataclass(frozen=True)
class Scenario:
    """A dry-run dive: the world, the area and settings, the vehicle's start, faults."""

    name: str
    description: str
    scene_path: Path
    area_path: Path
    survey_path: Path
    start_north_m: float = 0.0
    start_east_m: float = 0.0
    start_heading_rad: float = 0.0
    executor: dict[str, Any] = field(default_factory=dict)
    faults: FaultConfig = field(default_factory=FaultConfig)
    current_north_m_s: float = 0.0
    current_east_m_s: float = 0.0
    pitch_loop: bool = True
    seed: int = 0
    sensors: SensorConfig = field(default_factory=SensorConfig)
    link_timeout_s: float = 5.0
    attitude: AttitudeDisturbance = field(default_factory=AttitudeDisturbance)


def _scenario_file(source: str | Path) -> Path:
    if str(source) in BUILTIN_SCENARIOS:
        ref = resources.files("planner").joinpath("data", "scenarios", str(source), "scenario.toml")
        return Path(str(ref))
    path = Path(source)
    if path.is_dir():
        path = path / "scenario.toml"
    if not path.is_file():
        raise FileNotFoundError(f"{source}: no scenario file (built-in scenarios: {', '.join(BUILTIN_SCENARIOS)})")
    return path


def _attitude(doc: Any, path: str) -> AttitudeDisturbance:
    """The ``[attitude]`` table: the vehicle's pitch and roll disturbance (waves, trim).

    Keys (all optional; the simulator's defaults otherwise): ``pitch_bias_deg`` (trim,
    positive nose up), ``pitch_amplitude_deg``, ``pitch_period_s``, ``roll_amplitude_deg``,
    ``roll_period_s``.
    """
    if not isinstance(doc, dict):
        raise ConfigError("must be a table", key="attitude", path=path)
    unknown = sorted(set(doc) - set(_ATTITUDE_KEYS))
    if unknown:
        raise ConfigError(f"unknown key; allowed: {', '.join(sorted(_ATTITUDE_KEYS))}", key=f"attitude.{unknown[0]}",
                          path=path)
    kwargs: dict[str, float] = {}
    for key, value in doc.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"must be a finite number, got {value!r}", key=f"attitude.{key}", path=path)
        if key.endswith("_period_s") and not value > 0:
            raise ConfigError(f"must be > 0 s, got {value!r}", key=f"attitude.{key}", path=path)
        if key.endswith("_amplitude_deg") and not 0 <= value <= 30:
            raise ConfigError(f"must be within 0-30 deg, got {value!r}", key=f"attitude.{key}", path=path)
        if key == "pitch_bias_deg" and not abs(value) <= 30:
            raise ConfigError(f"must be within +-30 deg, got {value!r}", key=f"attitude.{key}", path=path)
        field_name = _ATTITUDE_KEYS[key]
        kwargs[field_name] = math.radians(value) if key.endswith("_deg") else float(value)
    return AttitudeDisturbance(**kwargs)


def _windows(value: Any, key: str, path: str) -> tuple[TimeWindow, ...]:
    if not isinstance(value, list) or not all(isinstance(w, list) and len(w) == 2 for w in value):
        raise ConfigError("must be a list of [start_s, end_s] pairs", key=key, path=path)
    return tuple(TimeWindow(float(a), float(b)) for a, b in value)


def load_scenario(source: str | Path, **overrides: Any) -> Scenario:
    """Load a scenario by built-in name, folder or ``scenario.toml`` path.

    ``overrides`` replace fields of the loaded scenario (tests use this for faults).

    Raises
    ------
    FileNotFoundError, ConfigError
        Naming the file and the key that is wrong.
    """
    path = _scenario_file(source)
    where = str(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", path=where) from exc
    unknown = sorted(set(doc) - _SCENARIO_KEYS)
    if unknown:
        raise ConfigError(f"unknown key; allowed: {', '.join(sorted(_SCENARIO_KEYS))}", key=unknown[0], path=where)
    base = path.parent
    files = {}
    for key in ("scene", "area", "survey"):
        if not isinstance(doc.get(key), str):
            raise ConfigError("is required (a file name relative to the scenario)", key=key, path=where)
        files[key] = base / doc[key]
        if not files[key].is_file():
            raise ConfigError(f"file {files[key]} not found", key=key, path=where)
    vehicle = doc.get("vehicle", {})
    faults_doc = dict(doc.get("faults", {}))
    fault_kwargs: dict[str, Any] = {}
    for key, value in faults_doc.items():
        if key in ("link_cuts", "altimeter_dropouts", "position_loss"):
            fault_kwargs[key] = _windows(value, f"faults.{key}", where)
        elif key == "refuse_commands":
            fault_kwargs[key] = frozenset(int(v) for v in value)
        else:
            fault_kwargs[key] = value
    try:
        faults = FaultConfig(**fault_kwargs)
    except TypeError as exc:
        raise ConfigError(f"bad fault setting: {exc}", key="faults", path=where) from exc
    try:
        sensors = SensorConfig(**doc.get("sensors", {}))
    except TypeError as exc:
        raise ConfigError(f"bad sensor setting: {exc}", key="sensors", path=where) from exc
    current = doc.get("current", {})
    attitude = _attitude(doc.get("attitude", {}), where)
    executor = dict(doc.get("executor", {}))
    pitch_loop = bool(executor.pop("pitch_loop", True))
    link_timeout_s = float(executor.pop("link_timeout_s", 5.0))
    scenario = Scenario(
        name=str(doc.get("name", path.parent.name)),
        description=str(doc.get("description", "")),
        scene_path=files["scene"], area_path=files["area"], survey_path=files["survey"],
        start_north_m=float(vehicle.get("start_north_m", 0.0)),
        start_east_m=float(vehicle.get("start_east_m", 0.0)),
        start_heading_rad=math.radians(float(vehicle.get("start_heading_deg", 0.0))),
        executor=executor, faults=faults,
        current_north_m_s=float(current.get("north_m_s", 0.0)),
        current_east_m_s=float(current.get("east_m_s", 0.0)),
        pitch_loop=pitch_loop, seed=int(vehicle.get("seed", 0)), sensors=sensors, link_timeout_s=link_timeout_s,
        attitude=attitude,
    )
    return replace(scenario, **overrides) if overrides else scenario


@dataclass
class DryRun:
    """What a dry run produced (paths and figures); ``summary`` is ``summary.json``."""

    out_dir: Path
    plan: SurveyPlan
    result: DiveResult
    summary: dict[str, Any]
    simulator: VehicleSimulator


def _sonar_config(scene: Scene, settings: Settings, seed: int) -> SonarConfig:
    sonar = settings.sonar
    return SonarConfig(
        window_start_m=sonar.window_start_m,
        window_length_m=sonar.window_end_m - sonar.window_start_m,
        samples_per_beam=sonar.samples_per_beam,
        seed=seed,
        fill_altitude=False,
        **{k: v for k, v in scene.sonar.items() if k == "sound_speed_m_s"},
    )


def _executor_config(scenario: Scenario, settings: Settings) -> ExecutorConfig:
    safety = SafetyLimits(min_clearance_m=settings.vehicle.min_clearance_m, depth_limit_m=settings.vehicle.max_depth_m)
    try:
        return ExecutorConfig(safety=safety, speed_m_s=settings.vehicle.speed_m_s,
                              acceptance_radius_m=settings.mission.acceptance_radius_m, **scenario.executor)
    except TypeError as exc:
        raise ConfigError(f"unknown executor setting: {exc}", key="executor") from exc


def make_tilt_controller(plan: SurveyPlan, settings: Settings, *, closed_loop: bool) -> TiltSource:
    """The pitch loop (closed on the sonar) or, for the comparison, the fixed tilt that
    centres the same tracking zone (:class:`planner.pitch.control.ZoneCentredTilt`)."""
    from planner.pitch.control import ShadowPitchLoop, ZoneCentredTilt  # the casadi MPC, built once

    if not closed_loop:
        return ZoneCentredTilt(plan, settings)
    return ShadowPitchLoop(plan, settings)


def run_dry_dive(
    scenario: Scenario,
    out_dir: Path,
    *,
    progress: Callable[[float, float, str], None] | None = None,
    write_frames: bool = False,
) -> DryRun:
    """Plan the scenario's survey, dry-run it against the software vehicle, write the run folder.

    ``progress(sim_s, planned_s, state)`` is called every control cycle.
    """
    del write_frames
    wall0 = time.perf_counter()
    scene = load_scene(scenario.scene_path)
    if not (math.isfinite(scene.world.origin_lat_deg) and math.isfinite(scene.world.origin_lon_deg)):
        raise ConfigError("the scene must give an [origin] (lat_deg, lon_deg)", key="origin",
                          path=str(scenario.scene_path))
    origin = LocalOrigin(scene.world.origin_lat_deg, scene.world.origin_lon_deg)
    settings = load_settings(scenario.survey_path)
    area = load_area(scenario.area_path, origin=(origin.lat_deg, origin.lon_deg))
    plan = plan_survey(area, settings)
    run = RunFolder(out_dir)
    write_outputs(plan, area, run.path("plan"))
    run.write_json("truth.json", _truth_document(scene, origin))

    clock = SimClock()
    renderer = SonarRenderer(scene.world, _sonar_config(scene, settings, scenario.seed))
    sim = VehicleSimulator(
        scene.world,
        config=VehicleConfig(start_north_m=scenario.start_north_m, start_east_m=scenario.start_east_m,
                             start_yaw_rad=scenario.start_heading_rad, seed=scenario.seed,
                             sensors=scenario.sensors, disturbance=scenario.attitude),
        faults=scenario.faults, clock=clock, listen="udp:127.0.0.1:0", sonar_renderer=renderer,
        current=UniformCurrent(scenario.current_north_m_s, scenario.current_east_m_s),
    )
    host, port = sim.address
    exec_config = _executor_config(scenario, settings)
    link_config = LinkConfig(f"udpout:{host}:{port}", max_depth_m=settings.vehicle.max_depth_m,
                             min_clearance_m=settings.vehicle.min_clearance_m,
                             tlog_path=str(run.path("dive.tlog")), link_timeout_s=scenario.link_timeout_s,
                             message_intervals_s=tuple(
                                 (name, MOUNT_STATUS_PERIOD_S if name == "GIMBAL_DEVICE_ATTITUDE_STATUS" else period)
                                 for name, period in DEFAULT_MESSAGE_INTERVALS_S),
                             heartbeat_period_s=0.5)
    onboard = OnboardPerception(OnboardConfig(specific_gravity=1.0))
    tilt = make_tilt_controller(plan, settings, closed_loop=scenario.pitch_loop)
    planned_s = sum(p.duration_s for p in plan.passes) + 60.0
    holder: dict[str, Any] = {}

    def cycle(executor: MissionExecutor) -> None:
        now = clock.now_s()
        if progress is not None:
            progress(now, planned_s, executor.result.state)
        if now - holder.get("products_s", now) > 60.0:
            write_products(run, executor.onboard, origin)
            holder["products_s"] = now

    def fly() -> None:
        with clock.participant("executor"):
            client = ArduSubClient(link_config, clock=clock, on_link_lost=lambda h: executor.on_link_lost(h),
                                   on_link_restored=lambda h: executor.on_link_restored(h))
            executor = MissionExecutor(client, sim.sonar, plan, exec_config, run, clock, onboard, tilt=tilt,
                                       on_cycle=cycle)
            holder["executor"] = executor
            client.add_listener(onboard.listener)
            try:
                holder["result"] = executor.run_dive()
            finally:
                client.close()

    sim.start()
    try:
        pilot = threading.Thread(target=fly, name="executor")
        pilot.start()
        pilot.join()
    finally:
        sim.stop()
    if "result" not in holder:
        run.close()
        raise RuntimeError("the executor thread ended without a result (see the log above)")
    result: DiveResult = holder["result"]
    executor = holder["executor"]
    products = write_products(run, executor.onboard, origin, final=True,
                              truth_points=tuple((t.north_m, t.east_m, t.height_m) for t in scene.world.targets))
    truth_extra = score_against_truth(run, sim, settings, result, products.targets,
                                      n_beams=renderer.config.n_beams, truth_targets=scene.world.targets,
                                      beam_azimuth_rad=renderer.config.beam_azimuth_rad, plan=plan)
    summary = summary_document(result, executor.onboard, wall_s=time.perf_counter() - wall0,
                               extra={"scenario": scenario.name, **truth_extra})
    run.write_json("summary.json", summary)
    run.close()
    return DryRun(Path(out_dir), plan, result, summary, sim)


def _height_summary(estimated: Any, truth_targets: Any, *, radius_m: float = 0.25) -> dict[str, Any]:
    """Heights against truth for summary.json (one-to-one matching by seabed position:
    each estimate sits at the target's estimated centre, within ``radius_m`` of the true one)."""
    score = score_heights(list(estimated), list(truth_targets), radius_m=radius_m)
    per_target = []
    for k, t in enumerate(truth_targets):
        e = next((x for x in score.errors if x.truth == k), None)
        entry: dict[str, Any] = {"id": t.target_id, "true_height_m": t.height_m, "matched": e is not None}
        if e is not None:
            est = list(estimated)[e.estimated]
            entry.update(estimate_id=est.target_id, height_m=e.height_m, height_std_m=e.height_std_m,
                         frames_used=est.frames_used, error_m=e.error_m, distance_m=e.distance_m)
        per_target.append(entry)
    n = len(score.errors)
    return {
        "n_matched": n,
        "n_truth_targets": len(per_target),
        "height_mean_abs_error_m": score.mean_abs_error_m if n else None,
        "height_max_abs_error_m": score.max_abs_error_m if n else None,
        "heights_vs_truth": per_target,
    }


def _truth_document(scene: Scene, origin: LocalOrigin) -> dict[str, Any]:
    targets = []
    for t in scene.world.targets:
        lat, lon = origin.to_lat_lon(t.north_m, t.east_m)
        targets.append({"id": t.target_id, "lat": round(float(lat), 9), "lon": round(float(lon), 9),
                         "north_m": t.north_m, "east_m": t.east_m, "height_m": t.height_m, "shape": t.shape})
    return {"scene": scene.name, "origin": {"lat_deg": origin.lat_deg, "lon_deg": origin.lon_deg},
            "targets": targets}


def shadow_visible_at_tilts(
    beam_azimuth_rad: np.ndarray,
    start_slant_m: np.ndarray,
    end_slant_m: np.ndarray,
    *,
    altitude_m: float,
    pitch_rad: float,
    roll_rad: float,
    tilt_rad: np.ndarray,
    elevation_aperture_rad: float,
) -> np.ndarray:
    """Truth side: for each tilt, is a target's whole shadow on insonified seabed?

    The simulator's definition (``sim_harness.sonar.truth``, ``in_band``), evaluated at other
    tilts: on every beam the target's shadow covers, the seabed at the shadow's start
    and end slant ranges lies inside the vertical aperture. A seabed point at slant ``r``
    on a beam of azimuth ``az`` has the elevation ``e`` (nearest the beam axis) with
    ``r (A cos e + B sin e) = H``, ``(A, B)`` from the sonar-to-level rotation's third
    row. The per-beam ranges are the frame's (the beam planes move little with the tilt).

    Parameters
    ----------
    beam_azimuth_rad, start_slant_m, end_slant_m : ndarray, shape (n_beams,)
        The shadow's beams (sonar frame, rad) and slant ranges, m.
    altitude_m, pitch_rad, roll_rad : float
        The sonar's altitude (m) and the vehicle's attitude (rad) at the frame.
    tilt_rad : ndarray, shape (n_tilts,)
        Tilts to try, rad (positive down).

    Returns
    -------
    ndarray of bool, shape (n_tilts,)
    """
    tilts = np.asarray(tilt_rad, dtype=np.float64)
    attitude_row = (rot_y(pitch_rad) @ rot_x(roll_rad))[2]
    # third row of attitude @ rot_y(-tilt), for every tilt: shape (n_tilts, 3)
    c, s = np.cos(-tilts), np.sin(-tilts)
    row = np.stack([attitude_row[0] * c - attitude_row[2] * s, np.full_like(c, attitude_row[1]),
                    attitude_row[0] * s + attitude_row[2] * c], axis=-1)
    az = np.asarray(beam_azimuth_rad, dtype=np.float64)[None, :]
    a = row[:, 0:1] * np.cos(az) + row[:, 1:2] * np.sin(az)
    b = np.broadcast_to(row[:, 2:3], a.shape)
    amp = np.hypot(a, b)
    phi = np.arctan2(b, a)
    half = elevation_aperture_rad / 2.0
    ok = np.ones(tilts.shape, dtype=bool)
    for slant in (start_slant_m, end_slant_m):
        ratio = altitude_m / (np.asarray(slant, dtype=np.float64)[None, :] * amp)
        spread = np.arccos(np.clip(ratio, -1.0, 1.0))
        e1 = np.mod(phi - spread + math.pi, 2 * math.pi) - math.pi
        e2 = np.mod(phi + spread + math.pi, 2 * math.pi) - math.pi
        e = np.where(np.abs(e1) <= np.abs(e2), e1, e2)
        ok &= np.all((ratio <= 1.0) & (np.abs(e) <= half), axis=1)
    return ok


def score_against_truth(run: RunFolder, sim: VehicleSimulator, settings: Settings, result: DiveResult,
                        estimated: Any, *, n_beams: int, truth_targets: Any,
                        beam_azimuth_rad: Any = None, mount: Any = None,
                        plan: SurveyPlan | None = None) -> dict[str, Any]:
    """Simulation-only figures from the truth: clearance, depth limit, shadows in view.

    The shadow-in-view ratio counts, over the frames of the survey passes, the targets
    *within range*: the whole shadow inside the range window, the target inside the fan
    (not on its first or last beam), its centre inside the *tracking zone* at that frame's
    true altitude (:func:`planner.pitch.aperture.tracking_zone_start_m`, the very function the
    pitch loop serves targets by, with the loop's own settings: at least
    ``min_ground_range_over_altitude`` altitudes ahead, and near enough to the window's
    end that one tilt holds every shadow in the zone with the loop's margins), and some
    tilt within the mount's limits showing the whole shadow at that frame's true attitude
    (:func:`shadow_visible_at_tilts`; as the kinematic benchmark does). Frames in the
    first ``FOV_SETTLE_S`` of a pass or of a target coming into range are left out (the
    loop settling). In a frame where no one tilt shows all the targets within range (they
    conflict), only as many count as the best single tilt could show: the ratio is the
    shadows shown whole over the most that any tilt could have shown, frame by frame.

    Second figures, for comparison: ``shadow_in_fov_ratio_2alt`` with the plain zone
    (``FOV_MIN_AHEAD_ALTITUDES`` altitudes ahead, the same exclusions otherwise) and
    ``shadow_in_fov_ratio_all`` (tracking zone, neither exclusion). ``tracking_zone``
    gives the zone per pass at its planned altitude.
    """
    from planner.pitch.control import DEFAULT_MOUNT, describe_zone, loop_config

    if mount is None:
        mount = DEFAULT_MOUNT  # the mount the executor commands
    zone_config = loop_config(settings, nominal_tilt_rad=0.0)  # the zone does not depend on the tilt
    tilt_grid = np.arange(mount.min_tilt_rad, mount.max_tilt_rad + 0.5 * FOV_TILT_STEP_RAD, FOV_TILT_STEP_RAD)
    azimuths = np.asarray(beam_azimuth_rad if beam_azimuth_rad is not None else
                          np.linspace(-settings.sonar.fan_width_rad / 2, settings.sonar.fan_width_rad / 2, n_beams))
    aperture = settings.sonar.elevation_aperture_rad
    history = sim.truth_history()
    run.write_csv("truth_track.csv", ("t_s", "north_m", "east_m", "depth_m", "altitude_m", "tilt_deg", "armed"),
                  [[f"{h.time_s:.2f}", f"{h.north_m:.3f}", f"{h.east_m:.3f}", f"{h.depth_m:.3f}", f"{h.altitude_m:.3f}",
                    f"{math.degrees(h.tilt_rad):.2f}", int(h.armed)] for h in history])
    armed = [h for h in history if h.armed]
    min_clear = min((h.altitude_m for h in armed), default=math.nan)
    depth_violations = sum(1 for h in history if h.depth_m > settings.vehicle.max_depth_m)
    rows = []
    zones = ("zone", "2alt")
    within = dict.fromkeys(zones, 0)
    inside = dict.fromkeys(zones, 0)
    conflict_frames = dict.fromkeys(zones, 0)
    unshowable = dict.fromkeys(zones, 0)
    plain_within = plain_inside = 0
    model_checked = model_agrees = 0
    pass_starts = [t for t, state in result.states if state.startswith("PASS_")]
    entered: dict[str, dict[str, float]] = {z: {} for z in zones}
    for t_s, truth in sim.sonar_truths():
        pose, altitude = truth.pose, truth.altitude_m
        zone_start_m = float(zone_config.zone_start_m(altitude))
        scored: dict[str, list[tuple[bool, np.ndarray]]] = {z: [] for z in zones}
        in_pass = any(0.0 <= t_s - start for start in pass_starts) and all(
            not 0.0 <= t_s - start < FOV_SETTLE_S for start in pass_starts)
        for tt in truth.targets:
            in_fov = bool(tt.whole_shadow_in_band) and bool(tt.whole_shadow_in_window)
            ahead = (tt.north_m - pose.north_m) * math.cos(pose.heading_rad) + \
                (tt.east_m - pose.east_m) * math.sin(pose.heading_rad)
            in_fan = len(tt.beams) > 0 and int(min(tt.beams)) > 0 and int(max(tt.beams)) < n_beams - 1
            base = bool(tt.whole_shadow_in_window) and in_fan
            in_range = {"zone": base and ahead >= zone_start_m,
                        "2alt": base and ahead >= FOV_MIN_AHEAD_ALTITUDES * altitude}
            settled: dict[str, bool] = {}
            for z in zones:
                if not in_range[z]:
                    entered[z].pop(tt.target_id, None)
                else:
                    entered[z].setdefault(tt.target_id, t_s)
                settled[z] = in_range[z] and t_s - entered[z].get(tt.target_id, t_s) >= FOV_SETTLE_S and in_pass
            showable = False
            if settled["zone"] or settled["2alt"]:
                visible = _visible_tilts(tt, azimuths, tilt_grid, altitude_m=altitude, pitch_rad=pose.pitch_rad,
                                         roll_rad=pose.roll_rad, aperture_rad=aperture)
                here = shadow_visible_at_tilts(
                    azimuths[np.asarray(tt.beams, dtype=int)], np.asarray(tt.shadow_start_m),
                    np.asarray(tt.shadow_end_m), altitude_m=altitude, pitch_rad=pose.pitch_rad,
                    roll_rad=pose.roll_rad, tilt_rad=np.array([pose.tilt_rad]), elevation_aperture_rad=aperture)
                model_checked += 1
                model_agrees += int(bool(here[0]) == bool(tt.whole_shadow_in_band))
                showable = bool(visible.any()) or in_fov
                for z in zones:
                    if not settled[z]:
                        continue
                    if showable:
                        scored[z].append((in_fov, visible | in_fov))
                    else:
                        unshowable[z] += 1
                if settled["zone"]:
                    plain_within += 1
                    plain_inside += int(in_fov)
            rows.append([f"{t_s:.2f}", tt.target_id, int(in_range["zone"]), int(in_range["2alt"]), int(in_fov),
                         int(settled["zone"]), int(showable)])
        for z in zones:
            if scored[z]:
                shown = sum(int(v) for v, _ in scored[z])
                best = max(int(np.max(np.sum([m for _, m in scored[z]], axis=0))), shown)
                conflict_frames[z] += int(best < len(scored[z]))
                within[z] += best
                inside[z] += shown
    run.write_csv("shadows.csv", ("t_s", "target_id", "within_range", "within_2alt", "in_fov", "settled", "showable"),
                  rows)
    heights = _height_summary(estimated, truth_targets)
    zone_doc = [{"pass": p.name, **describe_zone(zone_config, p.altitude_m)} for p in plan.passes] if plan else []
    return {
        **heights,
        "min_clearance_m": min_clear,
        "depth_limit_violations": depth_violations,
        "shadow_in_fov_ratio": inside["zone"] / within["zone"] if within["zone"] else None,
        "shadow_frames_within_range": within["zone"],
        "shadow_in_fov_ratio_2alt": inside["2alt"] / within["2alt"] if within["2alt"] else None,
        "shadow_frames_within_range_2alt": within["2alt"],
        "shadow_frames_in_conflict_2alt": conflict_frames["2alt"],
        "shadow_in_fov_ratio_all": plain_inside / plain_within if plain_within else None,
        "shadow_frames_unshowable": unshowable["zone"],
        "shadow_frames_in_conflict": conflict_frames["zone"],
        "shadow_fov_model_agreement": model_agrees / model_checked if model_checked else None,
        "tracking_zone": zone_doc,
        "shadow_in_fov_definition": (
            "whole shadow in window and fan, target centre inside the tracking zone at the frame's true altitude "
            "(planner.pitch.aperture.tracking_zone_start_m with the loop's settings: from max("
            f"{zone_config.min_ground_range_over_altitude} altitudes, the range at which the zone to the window's "
            "end spans the aperture less the loop's margin at both edges, for the tallest expected target) to the "
            f"window's end), {FOV_SETTLE_S} s settling excluded, some tilt within the mount's limits shows it "
            "whole; where targets conflict, counted up to the most one tilt could show. shadow_in_fov_ratio_2alt: "
            f"the same with the zone starting {FOV_MIN_AHEAD_ALTITUDES} altitudes ahead"),
    }


def _visible_tilts(tt: Any, azimuths: np.ndarray, tilt_grid: np.ndarray, *, altitude_m: float, pitch_rad: float,
                   roll_rad: float, aperture_rad: float) -> np.ndarray:
    """For each tilt of ``tilt_grid`` (rad), does it show the truth target ``tt``'s whole shadow?

    Only tilts whose beam axis is within the aperture (and a few degrees for the attitude
    and the fan's curvature) of the shadow can show it; the others are not computed.
    """
    near_dep = math.asin(min(1.0, altitude_m / max(float(np.min(tt.shadow_start_m)), altitude_m)))
    far_dep = math.asin(min(1.0, altitude_m / max(float(np.max(tt.shadow_end_m)), altitude_m)))
    slack = aperture_rad / 2 + abs(pitch_rad) + abs(roll_rad) + math.radians(3.0)
    near = (tilt_grid >= near_dep - slack) & (tilt_grid <= far_dep + slack)
    visible = np.zeros(tilt_grid.shape, dtype=bool)
    visible[near] = shadow_visible_at_tilts(
        azimuths[np.asarray(tt.beams, dtype=int)], np.asarray(tt.shadow_start_m), np.asarray(tt.shadow_end_m),
        altitude_m=altitude_m, pitch_rad=pitch_rad, roll_rad=roll_rad, tilt_rad=tilt_grid[near],
        elevation_aperture_rad=aperture_rad)
    return visible
