"""Scenario files of the dry-run dive: the world, the area and settings, the vehicle's start, faults."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

from planner.errors import ConfigError
from sim_harness.autopilot.params import ARDUSUB_4_5
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.peers import TopsidePilot
from sim_harness.vehicle.dynamics import AttitudeDisturbance
from sim_harness.vehicle.sensors import SensorConfig

BUILTIN_SCENARIOS = ("paper-targets",)


_SCENARIO_KEYS = {"name", "description", "scene", "area", "survey", "vehicle", "executor", "faults", "current",
                  "sensors", "attitude", "autopilot", "topside"}


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
    #: ArduSub 4.5 parameters of the simulated sub on top of its BlueOS DVL set-up
    #: (``[autopilot]``, e.g. ``MNT1_TYPE = 7`` for an unstabilised mount).
    autopilot_params: dict[str, float] = field(default_factory=dict)
    #: A topside ground station with a joystick (``[topside]``); None: none (a bench).
    topside: TopsidePilot | None = None
    #: The companion computer dies (its process killed) at this simulated time, s.
    companion_dies_at_s: float | None = None
    #: Count the fault windows and ``companion_dies_at_s`` from the executor's first
    #: entering this state (e.g. "PASS_1"; ``[faults] from_state``), not from the start
    #: (:mod:`planner.dryrun.anchored_faults`).
    faults_from_state: str | None = None
    #: The simulator runs on this long after the executor stops (finished, aborted or
    #: killed) to show what the vehicle does by itself, s.
    run_on_s: float = 0.0


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
    from_state = faults_doc.pop("from_state", None)
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
    autopilot = dict(doc.get("autopilot", {}))
    for key, value in autopilot.items():
        if key not in ARDUSUB_4_5 or isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError("must be an ArduSub 4.5 parameter with a number", key=f"autopilot.{key}", path=where)
    topside_doc = doc.get("topside")
    topside = None
    if topside_doc is not None:
        try:
            buttons = tuple((float(t), int(b)) for t, b in topside_doc.pop("buttons", []))
            topside = TopsidePilot(buttons=buttons, **topside_doc)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"bad topside setting: {exc}", key="topside", path=where) from exc
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
        attitude=attitude, autopilot_params={k: float(v) for k, v in autopilot.items()}, topside=topside,
        faults_from_state=None if from_state is None else str(from_state),
    )
    return replace(scenario, **overrides) if overrides else scenario
