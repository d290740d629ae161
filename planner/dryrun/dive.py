"""A dry-run dive: plan, start the software vehicle, fly it over real MAVLink, score it.

This package is the one part of :mod:`planner` that imports :mod:`sim_harness` (with the
CLI commands that serve the simulator: architecture.md). The controller side (executor,
vehicle_link client, on-board perception) sees only MAVLink bytes on a UDP socket and
sonar frames from the simulated sonar's ``poll``; simulator truth goes only to the
scorer (:mod:`planner.dryrun.scoring`), after the dive, into ``truth.json``,
``truth_track.csv`` and ``shadows.csv``.

The simulated sub boots as a real one does: no EKF origin (the executor gives it the
scene's, the one origin of the dive), BlueOS's own services heartbeating as system 1,
the pilot-input failsafe latched 3 s after boot when there is no topside joystick (the
executor then runs with ``topside="absent"``, as a bench test). A scenario may add a
topside pilot (``[topside]``) or kill the companion mid-dive (``companion_dies_at_s``):
its process then stops dead; ``run_on_s`` keeps the simulator running after the executor
stops, to show what the vehicle does on its own."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from perception.geodesy import LocalOrigin
from planner.config import Settings, load_settings
from planner.dryrun.anchored_faults import AnchoredFaults
from planner.dryrun.coverage import pass_coverage, pass_intervals
from planner.dryrun.scenario import Scenario
from planner.dryrun.scoring import score_against_truth, score_altitude
from planner.errors import ConfigError, InfeasibleError
from planner.mission.altitude_watch import AltitudeLimits, DiveWatch
from planner.mission.executor import DiveResult, ExecutorConfig, MissionExecutor, TiltSource
from planner.mission.onboard import OnboardConfig, OnboardPerception
from planner.mission.output_folder import staged_folder
from planner.mission.products import summary_document, write_products
from planner.mission.run_folder import RunFolder, mark_partial
from planner.mission.safety import SafetyLimits
from planner.report.figure_worker import REPORT_DRAWING_MODULES, FigureWorker
from planner.survey.area import SurveyArea, load_area
from planner.survey.lawnmower import plan_survey
from planner.survey.mission_files import write_outputs
from planner.survey.plan import SurveyPlan
from sim_harness.autopilot.autopilot import AutopilotConfig
from sim_harness.clock import SimClock
from sim_harness.errors import ClockStopped
from sim_harness.peers import BlueOsServices
from sim_harness.simulator import VehicleConfig, VehicleSimulator
from sim_harness.sonar.renderer import SonarConfig, SonarRenderer
from sim_harness.sonar.scene import Scene, load_scene
from sim_harness.vehicle.dynamics import UniformCurrent
from vehicle_link.client import ArduSubClient
from vehicle_link.config import DEFAULT_MESSAGE_INTERVALS_S, LinkConfig

#: From a ping to its frame on the companion, s: an ARIS frame is complete when its last
#: beam group has fired (about one ping period at 10 Hz), then crosses the tether's
#: Ethernet and the SDK. Longer than the controller's 0.2 s cycle, so the simulator's
#: render process (:mod:`sim_harness.render_worker`) draws the next pings while the
#: controller works on the last ones.
SONAR_LATENCY_S = 0.25

#: The mount's angle report every 0.1 s (the link's default, 0.5 s, leaves the frames'
#: tilt stamp several degrees behind while the pitch loop slews the mount).
MOUNT_STATUS_PERIOD_S = 0.1


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


class CompanionDied(BaseException):
    """The companion computer's process is killed (raised from the executor's own cycle hook)."""


def _executor_config(scenario: Scenario, settings: Settings) -> ExecutorConfig:
    safety = SafetyLimits(min_clearance_m=settings.min_altitude_m, depth_limit_m=settings.vehicle.max_depth_m)
    options: dict[str, Any] = {"topside": "required" if scenario.topside is not None else "absent",
                               "set_ekf_origin": True}  # the simulated EKF's zero is the scene's origin
    options.update(scenario.executor)
    try:
        return ExecutorConfig(safety=safety, speed_m_s=settings.vehicle.speed_m_s,
                              acceptance_radius_m=settings.mission.acceptance_radius_m, **options)
    except TypeError as exc:
        raise ConfigError(f"unknown executor setting: {exc}", key="executor") from exc


def make_tilt_controller(plan: SurveyPlan, settings: Settings, *, closed_loop: bool) -> TiltSource:
    """The pitch loop (closed on the sonar) or, for the comparison, the fixed tilt that
    centres the same tracking zone (:class:`planner.pitch.control.ZoneCentredTilt`)."""
    from planner.pitch.control import ShadowPitchLoop, ZoneCentredTilt  # the casadi MPC, built once

    if not closed_loop:
        return ZoneCentredTilt(plan, settings)
    return ShadowPitchLoop(plan, settings)


@dataclass(frozen=True)
class PreparedDive:
    """A scenario with everything it refers to loaded and checked, and its survey planned:
    what a dry run needs before it writes anything (a refusal leaves every folder alone)."""

    scenario: Scenario
    scene: Scene
    origin: LocalOrigin
    settings: Settings
    area: SurveyArea
    plan: SurveyPlan


def prepare_dry_dive(scenario: Scenario) -> PreparedDive:
    """Load the scenario's scene, settings and area, and plan its survey.

    Raises
    ------
    ConfigError, AreaError, SceneError, InfeasibleError
        Naming the file (and key) that is wrong; nothing has been written.
    """
    scene = load_scene(scenario.scene_path)
    if not (math.isfinite(scene.world.origin_lat_deg) and math.isfinite(scene.world.origin_lon_deg)):
        raise ConfigError("the scene must give an [origin] (lat_deg, lon_deg)", key="origin",
                          path=str(scenario.scene_path))
    origin = LocalOrigin(scene.world.origin_lat_deg, scene.world.origin_lon_deg)
    settings = load_settings(scenario.survey_path)
    area = load_area(scenario.area_path, origin=(origin.lat_deg, origin.lon_deg))
    try:
        plan = plan_survey(area, settings)
    except InfeasibleError as exc:
        raise InfeasibleError(f"scenario {scenario.source or scenario.name}: cannot plan {scenario.area_path} with "
                              f"{scenario.survey_path}: {exc.reason}") from exc
    return PreparedDive(scenario, scene, origin, settings, area, plan)


def run_dry_dive(
    scenario: Scenario | PreparedDive,
    out_dir: Path,
    *,
    progress: Callable[[float, float, str], None] | None = None,
    write_frames: bool = False,
    figures: FigureWorker | None = None,
) -> DryRun:
    """Plan the scenario's survey, dry-run it against the software vehicle, write the run folder.

    ``out_dir`` is written as it is (``shadowsurvey sim`` passes a staged folder,
    :mod:`planner.mission.output_folder`). ``progress(sim_s, planned_s, state)`` is called
    every control cycle, and once more with ``sim_s == planned_s`` when the dive is over
    and the run folder is being written; whatever it raises (a KeyboardInterrupt) ends
    the dive and is raised here. ``figures``: a figure process that draws the plan's and the
    map's pictures while this process flies and writes (:mod:`planner.report.figure_worker`).
    """
    del write_frames
    wall0 = time.perf_counter()
    prepared = scenario if isinstance(scenario, PreparedDive) else prepare_dry_dive(scenario)
    scenario, scene, origin = prepared.scenario, prepared.scene, prepared.origin
    settings, area, plan = prepared.settings, prepared.area, prepared.plan
    run = RunFolder(out_dir)
    write_outputs(plan, area, run.path("plan"))
    if figures is not None:
        figures.submit("plan", plan, area, run.path("plan/survey.png"))
    else:
        from planner.survey.plot import plot_plan  # matplotlib

        plot_plan(plan, area, run.path("plan/survey.png"))
    run.write_json("truth.json", truth_document(scene, origin))

    clock = SimClock()
    faults = AnchoredFaults.of(scenario.faults) if scenario.faults_from_state else scenario.faults
    renderer = SonarRenderer(scene.world, _sonar_config(scene, settings, scenario.seed))
    sim = VehicleSimulator(
        scene.world,
        config=VehicleConfig(start_north_m=scenario.start_north_m, start_east_m=scenario.start_east_m,
                             start_yaw_rad=scenario.start_heading_rad, seed=scenario.seed,
                             sensors=scenario.sensors, disturbance=scenario.attitude,
                             autopilot=AutopilotConfig(origin=None, params=dict(scenario.autopilot_params)),
                             peers=(BlueOsServices(),) + ((scenario.topside,) if scenario.topside else ()),
                             sonar_latency_s=SONAR_LATENCY_S, sonar_render_process=True),
        faults=faults, clock=clock, listen="udp:127.0.0.1:0", sonar_renderer=renderer,
        current=UniformCurrent(scenario.current_north_m_s, scenario.current_east_m_s),
    )
    host, port = sim.address
    exec_config = _executor_config(scenario, settings)
    link_config = LinkConfig(f"udpout:{host}:{port}", max_depth_m=settings.vehicle.max_depth_m,
                             min_clearance_m=settings.min_altitude_m,
                             tlog_path=str(run.path("dive.tlog")), link_timeout_s=scenario.link_timeout_s,
                             message_intervals_s=tuple(
                                 (name, MOUNT_STATUS_PERIOD_S if name == "GIMBAL_DEVICE_ATTITUDE_STATUS" else period)
                                 for name, period in DEFAULT_MESSAGE_INTERVALS_S),
                             heartbeat_period_s=0.5)
    # The frame-to-map chain in its own process: a frame's results reach the controller one
    # control cycle after it (planner.mission.onboard), while the next frames render.
    onboard = OnboardPerception(OnboardConfig(specific_gravity=1.0, map_process=True))
    try:
        tilt = make_tilt_controller(plan, settings, closed_loop=scenario.pitch_loop)
        planned_s = sum(p.duration_s for p in plan.passes) + 60.0
        holder: dict[str, Any] = {}
        limits = AltitudeLimits(tuple(p.altitude_m for p in plan.passes), settings.min_altitude_m)
        altitude_watch = DiveWatch(limits, run.event)

        def cycle(executor: MissionExecutor) -> None:
            altitude_watch.on_cycle(executor)
            now = clock.now_s()
            if progress is not None:
                try:
                    progress(now, planned_s, executor.result.state)
                except KeyboardInterrupt:  # the executor commands its safe action; raised again below
                    holder["interrupted"] = True
                    raise
            t0 = 0.0
            if isinstance(faults, AnchoredFaults):
                if "t0_s" not in faults.anchor:
                    entered = [t for t, state in executor.result.states if state == scenario.faults_from_state]
                    if entered:
                        faults.anchor["t0_s"] = entered[0]  # the fault windows count from here
                t0 = faults.anchor.get("t0_s", math.inf)
            if scenario.companion_dies_at_s is not None and now >= t0 + scenario.companion_dies_at_s:
                raise CompanionDied()

        joined, flown = threading.Event(), threading.Event()

        def fly() -> None:
            with clock.participant("executor"):
                joined.set()  # the simulator starts only once this thread holds it back
                try:
                    _fly()
                finally:
                    flown.set()  # at this simulated instant: the dive's thread holds the clock here
                    clock.notify()

        def _fly() -> None:
            client = ArduSubClient(link_config, clock=clock, on_link_lost=lambda h: executor.on_link_lost(h),
                                   on_link_restored=lambda h: executor.on_link_restored(h))
            executor = MissionExecutor(client, sim.sonar, plan, exec_config, run, clock, onboard, tilt=tilt,
                                       on_cycle=cycle)
            holder["executor"] = executor
            client.add_listener(onboard.listener)
            try:
                holder["result"] = executor.run_dive()
            except CompanionDied:
                # Killed: no safe action, no goodbye; the link's I/O passes die with it.
                holder["killed_s"] = clock.now_s()
                executor.result.status, executor.result.reason = "killed", "companion_killed"
                executor.result.message = f"the companion's process was killed at {clock.now_s():.1f} s"
                executor.result.end_s = clock.now_s()
                holder["result"] = executor.result
            except BaseException as exc:  # a Ctrl-C from the progress callback: raised again below
                holder["error"] = exc
            finally:
                client.close()

        pilot = threading.Thread(target=fly, name="executor")
        # This thread holds the clock too, so the simulation stops at a simulated time that
        # depends only on the dive (the executor's end, or run_on_s after it), never on how
        # soon the host schedules it after the executor's thread is done.
        with clock.participant("dry run"):
            pilot.start()
            joined.wait()
            sim.start()
            try:
                clock.wait_for(flown.is_set, math.inf)
                if scenario.run_on_s > 0.0:  # let the vehicle show what it does on its own
                    clock.sleep_until(holder.get("killed_s", clock.now_s()) + scenario.run_on_s)
            except ClockStopped:
                if sim.error is None:  # only the simulator stops the clock early, on an error of its own
                    raise
            finally:
                sim.stop()
        pilot.join()
        if sim.error is not None:  # the simulated vehicle failed: that, not the stopped clock, is the cause
            run.close()
            raise sim.error
        if "result" not in holder:
            run.close()
            if "error" in holder:
                raise holder["error"]
            raise RuntimeError("the executor thread ended without a result (see the log above)")
        if holder.get("interrupted"):
            run.close()
            raise KeyboardInterrupt
        result: DiveResult = holder["result"]
        executor = holder["executor"]
        if progress is not None:  # the dive is over: 100 %, while the products are written
            progress(max(planned_s, clock.now_s()), max(planned_s, clock.now_s()),
                     f"{result.state} at {clock.now_s():.0f} s, writing the run folder")
        excursions = altitude_watch.finish(result.end_s)
        products = write_products(run, executor.onboard, executor.map_origin, final=True, figures=figures,
                                  truth_points=tuple((t.north_m, t.east_m, t.height_m) for t in scene.world.targets))
        truth_extra = score_against_truth(run, sim, settings, result, products.targets,
                                          n_beams=renderer.config.n_beams, truth_targets=scene.world.targets,
                                          beam_azimuth_rad=renderer.config.beam_azimuth_rad, plan=plan)
        truth_extra.update(score_altitude(run, sim, result, limits, altitude_watch.std_at))
        truth_extra["coverage_by_truth"] = pass_coverage(
            sim.sonar_truths(), pass_intervals(result.states, result.end_s), area.coverage_region,
            beam_azimuth_rad=renderer.config.beam_azimuth_rad, window_start_m=settings.sonar.window_start_m,
            window_end_m=settings.sonar.window_end_m, elevation_aperture_rad=settings.sonar.elevation_aperture_rad)
        summary = summary_document(result, executor.onboard, wall_s=time.perf_counter() - wall0,
                                   abort_message=run.last_message("failsafe"),
                                   extra={"scenario": scenario.name, "min_altitude_allowed_m": settings.min_altitude_m,
                                          "altitude_excursions": [ex.to_dict() for ex in excursions], **truth_extra})
        run.write_json("summary.json", summary)
        if figures is not None:
            # The plan's and the map's pictures are in the folder before it is complete; this
            # process imports matplotlib for the report's own figures meanwhile (the report follows).
            figures.wait_all(warm_here=REPORT_DRAWING_MODULES)
        run.close()
        return DryRun(Path(out_dir), plan, result, summary, sim)
    finally:
        onboard.close()


def dry_dive_into(
    prepared: PreparedDive,
    out: Path,
    *,
    overwrite: bool = False,
    progress: Callable[[float, float, str], None] | None = None,
    figures: FigureWorker | None = None,
) -> DryRun:
    """:func:`run_dry_dive` into the run folder ``out``, never losing what is there.

    The run is built in a staged folder beside ``out`` and moved into place when it is
    complete (:func:`planner.mission.output_folder.staged_folder`): an existing folder
    needs ``overwrite`` and stays byte for byte as it was if the dive crashes or is
    interrupted; the stopped run is then kept beside it, its summary marked partial
    (:func:`planner.mission.run_folder.mark_partial`). A figure process (``figures``) is
    stopped before a failed run is set aside, so that nothing writes into it after.
    """
    with staged_folder(Path(out), kind="run", overwrite=overwrite, on_failure=mark_partial) as stage:
        try:
            dry = run_dry_dive(prepared, stage, progress=progress, figures=figures)
        except BaseException:
            if figures is not None:
                figures.close()
            raise
    return replace(dry, out_dir=Path(out))


def truth_document(scene: Scene, origin: LocalOrigin) -> dict[str, Any]:
    targets = []
    for t in scene.world.targets:
        lat, lon = origin.to_lat_lon(t.north_m, t.east_m)
        targets.append({"id": t.target_id, "lat": round(float(lat), 9), "lon": round(float(lon), 9),
                         "north_m": t.north_m, "east_m": t.east_m, "height_m": t.height_m, "shape": t.shape})
    return {"scene": scene.name, "origin": {"lat_deg": origin.lat_deg, "lon_deg": origin.lon_deg},
            "targets": targets}
