"""``shadowsurvey run --connect udpin:0.0.0.0:14770 --plan DIR``: fly a planned survey on a real ArduSub.

The same executor, MAVLink client and on-board perception as ``shadowsurvey sim``, on the
wall clock, against the vehicle at ``--connect`` (on BlueOS: a MAVLink endpoint, see
docs/flying-a-real-sub.md). Order: connect, the pre-flight checks (sensors, EKF origin,
SYSID_MYGCS and the failsafes, the topside's heartbeat and joystick, the mount), then
the ARM prompt showing what they found (type ``ARM``; ``--yes`` for scripts with their
own interlock), then the dive. The companion reads the vehicle's parameters and never
changes one. Ctrl-C at any time commands the safe action (``--safe-action``, if armed)
and still writes the run folder's summary. Sonar frames come from a driver that drops
``.npz`` frames into ``--sonar-dir`` (:mod:`planner.mission.sonar_sources`); without
one the survey is flown and logged but no heights are measured.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from planner.commands import args as args_types
from planner.config import Settings, default_settings, load_settings
from planner.errors import UsageError
from planner.mission.output_folder import check_output_folder, staged_folder
from planner.survey.plan import SurveyPlan, load_plan

if TYPE_CHECKING:
    from planner.mission.preflight import PreflightReport
    from vehicle_link.client import LinkHealth

#: Components BlueOS leaves free for a companion program (194 is mavlink2rest's).
COMPANION_COMPONENTS = (191, 192, 193)


def register(subparsers: Any) -> None:
    """Add the ``run`` subcommand."""
    parser = subparsers.add_parser(
        "run",
        help="fly a planned survey on a real vehicle (asks before arming)",
        description="Fly plan.json (from `shadowsurvey plan`) on an ArduSub 4.5 vehicle over MAVLink.",
    )
    parser.add_argument("--connect", required=True, type=args_types.connection_string,
                        help="MAVLink connection, e.g. udpin:0.0.0.0:14770 (a BlueOS UDP client endpoint to "
                             "this port), udpout:192.168.2.2:14550, tcp:127.0.0.1:5777")
    parser.add_argument("--plan", required=True, help="folder written by `shadowsurvey plan` (or its plan.json)")
    parser.add_argument("--config", help="the settings TOML the plan was made with (default: shipped)")
    parser.add_argument("--out", default="runs/dive",
                        help="run folder (default: runs/dive; an existing run needs --overwrite)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing run folder at --out")
    parser.add_argument("--sonar-dir", help="folder where the sonar driver drops .npz frames")
    parser.add_argument("--fixed-tilt", action="store_true", help="hold the plan's tilts (no pitch loop)")
    parser.add_argument("--on-link-loss", choices=("hold", "surface"), default="surface",
                        help="commanded when the link comes back after a loss (default: surface)")
    parser.add_argument("--safe-action", choices=("hold", "surface"), default="surface",
                        help="commanded on an abort or Ctrl-C (default: surface: ALT_HOLD and a controlled "
                             "ascent, which needs no position)")
    parser.add_argument("--component-id", type=int, default=191, choices=COMPANION_COMPONENTS,
                        help="our MAVLink component id (default 191; 194 is BlueOS's mavlink2rest)")
    parser.add_argument("--no-topside", action="store_true",
                        help="bench test: arm without a topside ground station and joystick (nobody can take over)")
    parser.add_argument("--set-origin", action="store_true",
                        help="if the vehicle has no EKF origin, give it the plan's (only if the vehicle was "
                             "switched on at the plan's origin; otherwise set its position in the DVL extension)")
    parser.add_argument("--yes", action="store_true", help="do not ask before arming")
    parser.set_defaults(func=run)


def confirm_arming(plan_text: str, *, stdin: TextIO | None = None, stdout: TextIO | None = None) -> bool:
    """Show what will be flown and ask for ``ARM``; False on anything else or no terminal."""
    stdin = sys.stdin if stdin is None else stdin
    stdout = sys.stdout if stdout is None else stdout
    stdout.write(plan_text + "\nType ARM to arm the vehicle and start the dive: ")
    stdout.flush()
    answer = stdin.readline()
    return answer.strip() == "ARM"


def _plan_text(args: argparse.Namespace, plan: SurveyPlan, settings: Settings) -> str:
    passes = ", ".join(f"{p.name}: {p.altitude_m:.2f} m altitude, tilt {p.tilt_rad * 57.2958:.1f} deg, "
                       f"{p.length_m:.0f} m" for p in plan.passes)
    return (f"plan {args.plan}: {len(plan.passes)} passes ({passes}); depth limit {settings.vehicle.max_depth_m} m, "
            f"clearance {settings.vehicle.min_clearance_m} m over the tallest target (never below "
            f"{settings.min_altitude_m:.2f} m above the seabed); on abort or Ctrl-C: {args.safe_action}; "
            f"on link loss: {args.on_link_loss}")


def run(args: argparse.Namespace) -> int:
    """Connect, check, confirm, fly, write the run folder; exit 0 when completed.

    The run is built in a staged folder and moved to ``--out`` when complete; a crash
    leaves it beside, marked partial (:mod:`planner.mission.output_folder`). Ctrl-C
    during the dive commands the safe action and still writes the whole run folder.
    """
    from planner.mission.run_folder import mark_partial
    from planner.mission.sonar_sources import DirectorySonarSource
    from planner.report.markdown import generate_report

    check_output_folder(Path(args.out), kind="run", overwrite=args.overwrite)
    plan = load_plan(args.plan)
    settings = load_settings(args.config) if args.config else default_settings()
    sonar = DirectorySonarSource(Path(args.sonar_dir)) if args.sonar_dir else None
    with staged_folder(Path(args.out), kind="run", overwrite=args.overwrite, on_failure=mark_partial) as stage:
        summary = _fly(args, plan, settings, sonar, stage)
    generate_report(Path(args.out))
    print(f"dive {summary['status']}: {summary['message'] or summary['reason']}; run folder {args.out}")
    if summary["reason"] == "arming_not_confirmed":
        raise UsageError("arming not confirmed: the vehicle was not armed")
    return 0 if summary["status"] == "completed" else 1


def _fly(args: argparse.Namespace, plan: SurveyPlan, settings: Settings, sonar: Any, out: Path) -> dict[str, Any]:
    """Connect, check, ask, fly the dive into the run folder ``out``; returns the summary."""
    from planner.mission.altitude_watch import AltitudeLimits, DiveWatch
    from planner.mission.executor import ExecutorConfig, MissionExecutor, PlanTilt
    from planner.mission.onboard import OnboardConfig, OnboardPerception
    from planner.mission.products import summary_document, write_products
    from planner.mission.run_folder import RunFolder
    from planner.mission.safety import SafetyLimits
    from planner.pitch.control import ShadowPitchLoop
    from vehicle_link.client import ArduSubClient
    from vehicle_link.clock import WallClock
    from vehicle_link.config import LinkConfig

    text = _plan_text(args, plan, settings)

    def confirm(report: PreflightReport) -> bool:
        lines = "\n".join(f"  {line}" for line in report.lines())
        return args.yes or confirm_arming(f"pre-flight checks passed:\n{lines}\n{text}")

    clock = WallClock()
    run_folder = RunFolder(out)
    config = ExecutorConfig(
        safety=SafetyLimits(min_clearance_m=settings.min_altitude_m, depth_limit_m=settings.vehicle.max_depth_m),
        speed_m_s=settings.vehicle.speed_m_s, acceptance_radius_m=settings.mission.acceptance_radius_m,
        link_lost_action=args.on_link_loss, abort_action=args.safe_action, finish_action=args.safe_action,
        topside="absent" if args.no_topside else "required", set_ekf_origin=args.set_origin,
    )
    onboard = OnboardPerception(OnboardConfig())
    tilt = PlanTilt() if args.fixed_tilt else ShadowPitchLoop(plan, settings)
    link = LinkConfig(args.connect, source_component=args.component_id, max_depth_m=settings.vehicle.max_depth_m,
                      min_clearance_m=settings.min_altitude_m,
                      tlog_path=str(run_folder.path("dive.tlog")), link_timeout_s=5.0, heartbeat_period_s=0.5)
    executors: list[MissionExecutor] = []

    def lost(health: LinkHealth) -> None:
        for e in executors:
            e.on_link_lost(health)

    def restored(health: LinkHealth) -> None:
        for e in executors:
            e.on_link_restored(health)

    wall0 = time.perf_counter()
    client = ArduSubClient(link, clock=clock, on_link_lost=lost, on_link_restored=restored)
    limits = AltitudeLimits(tuple(p.altitude_m for p in plan.passes), settings.min_altitude_m)
    watch = DiveWatch(limits, run_folder.event)
    executor = MissionExecutor(client, sonar, plan, config, run_folder, clock, onboard, tilt=tilt,
                               on_cycle=watch.on_cycle, confirm_arm=confirm)
    executors.append(executor)
    client.add_listener(onboard.listener)
    try:
        result = executor.run_dive()  # Ctrl-C inside: the safe action, then a result
    finally:
        client.close()
    excursions = watch.finish(result.end_s)
    write_products(run_folder, onboard, executor.map_origin, final=True)
    summary = summary_document(result, onboard, wall_s=time.perf_counter() - wall0,
                               abort_message=run_folder.last_message("failsafe"),
                               extra={"min_altitude_allowed_m": settings.min_altitude_m,
                                      "altitude_excursions": [ex.to_dict() for ex in excursions]})
    run_folder.write_json("summary.json", summary)
    run_folder.close()
    return summary
