"""``shadowsurvey sim-vehicle``: serve the software ROV over MAVLink, like a BlueOS sub.

``shadowsurvey sim-vehicle --listen udp:127.0.0.1:14550`` binds that address and talks to
whichever ground station sends to it (MAVProxy ``--master=udpout:127.0.0.1:14550``,
QGroundControl with a UDP link to that port); ``tcp:HOST:PORT`` listens for TCP clients.
Runs in real time until interrupted (Ctrl-C), or for ``--duration-s`` simulated seconds.
"""

from __future__ import annotations

import argparse
import math
import sys

from planner.commands import args as args_types
from sim_harness.autopilot.autopilot import AutopilotConfig
from sim_harness.clock import SimClock
from sim_harness.simulator import VehicleConfig, VehicleSimulator
from sim_harness.vehicle.sensors import FlatSeabed, SeabedWorld


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``sim-vehicle`` subcommand."""
    parser = subparsers.add_parser(
        "sim-vehicle",
        help="run the software ROV behind an ArduSub-like MAVLink autopilot",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--listen", default="udp:127.0.0.1:14550",
                        help="udp:HOST:PORT or tcp:HOST:PORT to serve MAVLink on "
                             "(default %(default)s)")
    parser.add_argument("--speedup", type=args_types.positive, default=1.0,
                        help="simulated seconds per wall second (default 1 = real time)")
    parser.add_argument("--duration-s", type=args_types.positive, default=None,
                        help="stop after this many simulated seconds (default: run until "
                             "interrupted)")
    parser.add_argument("--seabed-depth-m", type=args_types.number(0.0, 11000.0, lo_open=True, unit="m"), default=20.0,
                        help="depth of the flat seabed, metres (default %(default)s)")
    parser.add_argument("--scene", default=None,
                        help="a scene file or built-in scene name for the seabed (instead of "
                             "a flat seabed); its origin becomes home unless --origin is given")
    parser.add_argument("--start-depth-m", type=args_types.nonnegative, default=0.0,
                        help="starting depth of the vehicle, metres (default %(default)s)")
    parser.add_argument("--origin", type=args_types.finite, nargs=2, metavar=("LAT_DEG", "LON_DEG"),
                        default=None, help="EKF origin at boot, as the BlueOS DVL extension sets it "
                                           "(default: the scene's, else none: a ground station sets it "
                                           "with SET_GPS_GLOBAL_ORIGIN)")
    parser.add_argument("--sitl", action="store_true",
                        help="behave as ArduPilot's SITL build (no pilot-input failsafe, arming texts)")
    parser.add_argument("--seed", type=args_types.integer(0, 2**32 - 1), default=0, help="random seed (default 0)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Build the simulator and run it; returns the exit code."""
    from planner.errors import UsageError

    if not (math.isfinite(args.speedup) and args.speedup > 0.0):
        raise UsageError(f"--speedup must be a positive number, got {args.speedup}")
    if args.duration_s is not None and not args.duration_s > 0.0:
        raise UsageError(f"--duration-s must be positive, got {args.duration_s}")
    world: SeabedWorld = FlatSeabed(args.seabed_depth_m)
    origin: tuple[float, float] | None = None
    if args.scene is not None:
        from sim_harness.sonar.scene import load_scene  # the renderer's scenes, loaded on demand

        world = load_scene(args.scene).world
        scene_origin = (world.origin_lat_deg, world.origin_lon_deg)
        if all(math.isfinite(v) for v in scene_origin):
            origin = scene_origin
    if args.origin is not None:
        origin = (args.origin[0], args.origin[1])
        if not (-90.0 <= origin[0] <= 90.0 and -180.0 <= origin[1] <= 180.0):
            raise UsageError(f"--origin {origin[0]:g} {origin[1]:g}: latitude must be within -90..90 and "
                             "longitude within -180..180 deg")
    seabed_m = world.seabed_depth_m(0.0, 0.0)
    if not seabed_m > args.start_depth_m:
        where = f"--scene {args.scene}" if args.scene is not None else "--seabed-depth-m"
        raise UsageError(f"--start-depth-m {args.start_depth_m:g} must be above the seabed, which lies at "
                         f"{seabed_m:g} m at the start point ({where})")
    config = VehicleConfig(
        start_depth_m=args.start_depth_m,
        autopilot=AutopilotConfig(origin=None if origin is None else (origin[0], origin[1], 0.0),
                                  sitl_build=args.sitl),
        seed=args.seed,
    )
    clock = SimClock(speedup=args.speedup)
    sim = VehicleSimulator(world, config=config, clock=clock, listen=args.listen)
    host, port = sim.address
    kind = args.listen.split(":", 1)[0]
    try:
        print(f"sim-vehicle: MAVLink 2 on {kind}:{host}:{port} (system 1, submarine); "
              "Ctrl-C to stop", file=sys.stderr, flush=True)
        if args.duration_s is not None:
            sim.run_for(args.duration_s)
        else:
            while True:
                sim.step()
    except KeyboardInterrupt:
        print("sim-vehicle: interrupted, closing", file=sys.stderr)
    finally:
        sim.close()
    return 0
