"""``shadowsurvey run --connect udp:... --plan DIR``: fly a planned survey on a real ArduSub.

The same executor, MAVLink client and on-board perception as ``shadowsurvey sim``, on the
wall clock, against the vehicle at ``--connect``. Sonar frames come from a sonar driver
that drops ``.npz`` frames into ``--sonar-dir`` (see :mod:`planner.mission.sonar_sources`);
without one the survey is flown and logged but no heights are measured. Arming needs an
explicit confirmation: type ``ARM`` at the prompt, or pass ``--yes`` in scripts that have
their own interlock.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any, TextIO

from perception.geodesy import LocalOrigin
from planner.config import default_settings, load_settings
from planner.errors import UsageError
from planner.mission.executor import ExecutorConfig, MissionExecutor, PlanTilt
from planner.mission.onboard import OnboardConfig, OnboardPerception
from planner.mission.products import summary_document, write_products
from planner.mission.run_folder import RunFolder
from planner.mission.safety import SafetyLimits
from planner.mission.sonar_sources import DirectorySonarSource
from planner.pitch.control import ShadowPitchLoop
from planner.report.markdown import generate_report
from planner.survey.plan import load_plan
from vehicle_link.client import ArduSubClient, LinkHealth
from vehicle_link.clock import WallClock
from vehicle_link.config import LinkConfig


def register(subparsers: Any) -> None:
    """Add the ``run`` subcommand."""
    parser = subparsers.add_parser(
        "run",
        help="fly a planned survey on a real vehicle (asks before arming)",
        description="Fly plan.json (from `shadowsurvey plan`) on an ArduSub vehicle over MAVLink.",
    )
    parser.add_argument("--connect", required=True,
                        help="MAVLink connection, e.g. udpin:0.0.0.0:14770, udpout:192.168.2.2:14550, tcp:host:port")
    parser.add_argument("--plan", required=True, help="folder written by `shadowsurvey plan` (or its plan.json)")
    parser.add_argument("--config", help="the settings TOML the plan was made with (default: shipped)")
    parser.add_argument("--out", default="runs/dive", help="run folder (default: runs/dive)")
    parser.add_argument("--sonar-dir", help="folder where the sonar driver drops .npz frames")
    parser.add_argument("--fixed-tilt", action="store_true", help="hold the plan's tilts (no pitch loop)")
    parser.add_argument("--on-link-loss", choices=("hold", "surface"), default="surface",
                        help="safe action when the link drops (default: surface)")
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


def run(args: argparse.Namespace) -> int:
    """Connect, confirm, fly, write the run folder; exit 0 when completed."""
    plan = load_plan(args.plan)
    settings = load_settings(args.config) if args.config else default_settings()
    sonar = DirectorySonarSource(Path(args.sonar_dir)) if args.sonar_dir else None
    passes = ", ".join(f"{p.name}: {p.altitude_m:.2f} m altitude, tilt {p.tilt_rad * 57.2958:.1f} deg, "
                       f"{p.length_m:.0f} m" for p in plan.passes)
    text = (f"plan {args.plan}: {len(plan.passes)} passes ({passes}); depth limit "
            f"{settings.vehicle.max_depth_m} m, clearance {settings.vehicle.min_clearance_m} m; "
            f"on link loss: {args.on_link_loss}")
    if not args.yes and not confirm_arming(text):
        raise UsageError("arming not confirmed: nothing was sent to the vehicle")
    clock = WallClock()
    run_folder = RunFolder(Path(args.out))
    origin = LocalOrigin(plan.origin_lat_deg, plan.origin_lon_deg)
    config = ExecutorConfig(
        safety=SafetyLimits(min_clearance_m=settings.vehicle.min_clearance_m,
                            depth_limit_m=settings.vehicle.max_depth_m),
        speed_m_s=settings.vehicle.speed_m_s, acceptance_radius_m=settings.mission.acceptance_radius_m,
        link_lost_action=args.on_link_loss,
    )
    onboard = OnboardPerception(OnboardConfig())
    tilt = PlanTilt() if args.fixed_tilt else ShadowPitchLoop(plan, settings)
    link = LinkConfig(args.connect, max_depth_m=settings.vehicle.max_depth_m,
                      min_clearance_m=settings.vehicle.min_clearance_m,
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
    executor = MissionExecutor(client, sonar, plan, config, run_folder, clock, onboard, tilt=tilt)
    executors.append(executor)
    client.add_listener(onboard.listener)
    try:
        result = executor.run_dive()
    finally:
        client.close()
    write_products(run_folder, onboard, origin, final=True)
    summary = summary_document(result, onboard, wall_s=time.perf_counter() - wall0)
    run_folder.write_json("summary.json", summary)
    run_folder.close()
    generate_report(Path(args.out))
    print(f"dive {summary['status']}: {summary['reason']}; run folder {args.out}")
    return 0 if summary["status"] == "completed" else 1
