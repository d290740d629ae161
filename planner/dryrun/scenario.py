"""Scenario files of the dry-run dive: the world, the area and settings, the vehicle's start, faults.

A scenario is a folder with a ``scenario.toml`` (or the file itself, or a built-in name:
:data:`BUILTIN_SCENARIOS`). Its format is documented in ``docs/scenario-format.md``; in
short:

``name``, ``description`` (strings), ``scene``, ``area``, ``survey`` (files relative to the
scenario: a sim_harness scene, a GeoJSON area, a survey.toml), and the tables

- ``[vehicle]`` ``start_north_m``, ``start_east_m`` (within :data:`MAX_START_OFFSET_M`),
  ``start_heading_deg``, ``seed``;
- ``[executor]`` ``pitch_loop`` (true/false), ``link_timeout_s`` and any field of
  :class:`planner.mission.executor.ExecutorConfig` but those survey.toml sets
  (:data:`EXECUTOR_FROM_SURVEY`);
- ``[current]`` ``north_m_s``, ``east_m_s`` (a uniform current, at most :data:`MAX_CURRENT_M_S`);
- ``[attitude]`` the vehicle's pitch and roll disturbance (degrees and seconds);
- ``[faults]`` the fields of :class:`sim_harness.faults.FaultConfig`: probabilities within
  0..1, time windows as ``[[start_s, end_s], ...]``, ``refuse_commands`` as MAV_CMD ids;
- ``[sensors]`` the fields of :class:`sim_harness.vehicle.sensors.SensorConfig`;
- ``[autopilot]`` ArduSub 4.5 parameters of the simulated sub on top of its BlueOS DVL
  set-up (names of :data:`sim_harness.autopilot.params.ARDUSUB_4_5`, e.g. ``MNT1_TYPE = 7``
  for an unstabilised mount);
- ``[topside]`` a topside ground station with a joystick (the fields of
  :class:`sim_harness.peers.TopsidePilot`, ``buttons = [[t_s, button], ...]``); without
  it the dive is a bench test, nobody at the topside;
- ``[faults] from_state``: count the fault windows from the executor's first entering
  that state (e.g. ``"PASS_1"``) instead of the dive's start.

Everything is validated here, once: an unknown key, a value of the wrong type or out of
its range raises :class:`~planner.errors.ConfigError` naming the file and the key
(``faults.packet_loss``), before anything is flown or written.
"""

from __future__ import annotations

import math
import tomllib
import typing
from dataclasses import dataclass, field, fields, replace
from importlib import resources
from pathlib import Path
from typing import Any

from planner.errors import ConfigError
from planner.mission.executor_config import ExecutorConfig
from planner.mission.safety import SafetyLimits
from planner.settings_table import SettingsTable
from sim_harness.autopilot.params import ARDUSUB_4_5
from sim_harness.errors import SimConfigError
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.peers import TopsidePilot
from sim_harness.vehicle.dynamics import AttitudeDisturbance
from sim_harness.vehicle.sensors import SensorConfig

BUILTIN_SCENARIOS = ("paper-targets", "harbour-field")

_SCENARIO_KEYS = {"name", "description", "scene", "area", "survey", "vehicle", "executor", "faults", "current",
                  "sensors", "attitude", "autopilot", "topside"}
#: The executor's states a fault may be counted from (``[faults] from_state``).
FAULT_ANCHOR_STATES = ("PREFLIGHT", "ARM", "DESCEND", "PASS_1", "ALTITUDE_CHANGE", "PASS_2", "FINISH")

#: ``[attitude]`` keys (degrees and seconds) and the AttitudeDisturbance field each sets.
_ATTITUDE_KEYS = {"pitch_bias_deg": "pitch_bias_rad", "pitch_amplitude_deg": "pitch_amplitude_rad",
                  "pitch_period_s": "pitch_period_s", "roll_amplitude_deg": "roll_amplitude_rad",
                  "roll_period_s": "roll_period_s"}

#: The vehicle starts at most this far from the local origin, m (it must reach the survey).
MAX_START_OFFSET_M = 1000.0
#: Strongest uniform current a scenario may set, m/s (ROVs fly in well under 2 m/s).
MAX_CURRENT_M_S = 3.0
#: Longest time a fault window may reach, s of simulated time.
MAX_FAULT_TIME_S = 86_400.0
#: Largest value any other time, distance or noise setting may take (catches unit slips).
MAX_SETTING = 1.0e5
#: ExecutorConfig fields that come from survey.toml, never from a scenario.
EXECUTOR_FROM_SURVEY = ("safety", "speed_m_s", "acceptance_radius_m")
_PROBABILITIES = ("packet_loss", "duplicate", "corrupt_bytes", "depth_spike_prob", "sonar_drop",
                  "altimeter_dropout_prob")
_WINDOWS = ("link_cuts", "altimeter_dropouts", "position_loss")


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
    source: str = ""
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


def _attitude(t: SettingsTable) -> AttitudeDisturbance:
    """The ``[attitude]`` table: the vehicle's pitch and roll disturbance (waves, trim)."""
    kwargs: dict[str, float] = {}
    for key, name in _ATTITUDE_KEYS.items():
        if not t.has(key):
            t.used.add(key)
            continue
        if key.endswith("_period_s"):
            value = t.number(key, lo=0.0, hi=MAX_SETTING, lo_open=True)
        elif key == "pitch_bias_deg":
            value = t.number(key, lo=-30.0, hi=30.0)
        else:
            value = t.number(key, lo=0.0, hi=30.0)
        kwargs[name] = math.radians(value) if key.endswith("_deg") else value
    t.finish()
    return AttitudeDisturbance(**kwargs)


def _typed_fields(t: SettingsTable, cls: type, skip: tuple[str, ...] = ()) -> dict[str, Any]:
    """Every key of ``t`` read as the field of dataclass ``cls`` it names, by the field's type."""
    hints = typing.get_type_hints(cls)
    out: dict[str, Any] = {}
    for f in fields(cls):
        name = f.name
        if name in skip or not t.has(name):
            continue
        kind = hints[name]
        if kind is bool:
            out[name] = t.boolean(name)
        elif kind is int:
            out[name] = t.integer(name, lo=0, hi=2**32 - 1)
        elif kind is float:
            if name in _PROBABILITIES:
                out[name] = t.number(name, lo=0.0, hi=1.0)
            elif name.endswith("offset_m") or name.endswith("_deg"):
                out[name] = t.number(name, lo=-MAX_SETTING, hi=MAX_SETTING)
            else:
                out[name] = t.number(name, lo=0.0, hi=MAX_SETTING)
        elif typing.get_origin(kind) is typing.Literal:
            out[name] = t.string(name, tuple(typing.get_args(kind)))
        elif name in _WINDOWS:
            out[name] = tuple(TimeWindow(a, b) for a, b in t.windows(name, hi=MAX_FAULT_TIME_S))
        elif name == "refuse_commands":
            out[name] = frozenset(t.integers(name, lo=0, hi=65535))
        else:  # pragma: no cover - a new field type must be taught here
            raise t.error(name, f"cannot be set from a scenario (type {kind})")
    t.finish()
    return out


def _autopilot(t: SettingsTable) -> dict[str, float]:
    """The ``[autopilot]`` table: ArduSub 4.5 parameter names with numbers."""
    params = {}
    for key in list(t.data):
        if key not in ARDUSUB_4_5:
            raise t.error(key, "is not an ArduSub 4.5 parameter of the simulated sub")
        params[key] = t.number(key, lo=-MAX_SETTING, hi=MAX_SETTING)
    t.finish()
    return params


def _topside(t: SettingsTable) -> TopsidePilot:
    """The ``[topside]`` table: the ground station's ids, timing and joystick buttons."""
    buttons: tuple[tuple[float, int], ...] = ()
    if t.has("buttons"):
        t.used.add("buttons")
        raw = t.data["buttons"]
        ok = isinstance(raw, list) and all(
            isinstance(b, list) and len(b) == 2 and isinstance(b[0], int | float) and not isinstance(b[0], bool)
            and isinstance(b[1], int) and not isinstance(b[1], bool) and 1 <= b[1] <= 16 for b in raw)
        if not ok:
            raise t.error("buttons", "must be a list of [t_s, button] pairs (button 1..16)")
        buttons = tuple((float(a), int(b)) for a, b in raw)
    kwargs: dict[str, Any] = {}
    for key in ("system_id", "component_id", "target_system"):
        if t.has(key):
            kwargs[key] = t.integer(key, lo=1, hi=255)
    for key in ("start_s", "stop_s"):
        if t.has(key):
            kwargs[key] = t.number(key, lo=0.0, hi=MAX_FAULT_TIME_S)
    for key in ("heartbeat_hz", "manual_control_hz"):
        if t.has(key):
            kwargs[key] = t.number(key, lo=0.0, hi=100.0, lo_open=True)
    t.finish()
    return TopsidePilot(buttons=buttons, **kwargs)


def _build(cls: Any, kwargs: dict[str, Any], section: str, where: str) -> Any:
    try:
        return cls(**kwargs)
    except SimConfigError as exc:
        raise ConfigError(str(exc).split(": ", 1)[-1], key=f"{section}.{exc.key}" if exc.key else section,
                          path=where) from exc
    except ValueError as exc:
        raise ConfigError(str(exc), key=section, path=where) from exc


def _read(path: Path) -> dict[str, Any]:
    where = str(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read scenario file: {exc.strerror or exc}", path=where) from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"not UTF-8 text ({exc.reason} at byte {exc.start})", path=where) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", path=where) from exc
    except RecursionError:
        raise ConfigError("not valid TOML: nested too deeply", path=where) from None


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
    doc = _read(path)
    top = SettingsTable(doc, "", where)
    unknown = sorted(set(doc) - _SCENARIO_KEYS)
    if unknown:
        raise ConfigError(f"unknown key; allowed: {', '.join(sorted(_SCENARIO_KEYS))}", key=unknown[0], path=where)
    files = {}
    for key in ("scene", "area", "survey"):
        if not isinstance(doc.get(key), str) or not doc[key]:
            raise ConfigError("is required (a file name relative to the scenario)", key=key, path=where)
        files[key] = path.parent / doc[key]
        if not files[key].is_file():
            raise ConfigError(f"file {files[key]} not found", key=key, path=where)
    name = top.string("name", default=path.parent.name)
    description = top.string("description", default="")

    vehicle = SettingsTable(doc.get("vehicle", {}), "vehicle", where)
    start_north = vehicle.number("start_north_m", lo=-MAX_START_OFFSET_M, hi=MAX_START_OFFSET_M, default=0.0)
    start_east = vehicle.number("start_east_m", lo=-MAX_START_OFFSET_M, hi=MAX_START_OFFSET_M, default=0.0)
    heading = vehicle.number("start_heading_deg", lo=-360.0, hi=360.0, default=0.0)
    seed = vehicle.integer("seed", lo=0, hi=2**32 - 1, default=0)
    vehicle.finish()

    executor_table = SettingsTable(doc.get("executor", {}), "executor", where)
    pitch_loop = executor_table.boolean("pitch_loop", default=True)
    link_timeout_s = executor_table.number("link_timeout_s", lo=0.0, hi=600.0, lo_open=True, default=5.0)
    executor = _typed_fields(executor_table, ExecutorConfig, skip=EXECUTOR_FROM_SURVEY)
    try:  # ExecutorConfig's own checks, with placeholder limits (survey.toml gives the real ones)
        ExecutorConfig(safety=SafetyLimits(min_clearance_m=1.0, depth_limit_m=10.0), **executor)
    except ValueError as exc:
        raise ConfigError(str(exc), key="executor", path=where) from exc

    current = SettingsTable(doc.get("current", {}), "current", where)
    current_n = current.number("north_m_s", lo=-MAX_CURRENT_M_S, hi=MAX_CURRENT_M_S, default=0.0)
    current_e = current.number("east_m_s", lo=-MAX_CURRENT_M_S, hi=MAX_CURRENT_M_S, default=0.0)
    current.finish()

    faults_table = SettingsTable(doc.get("faults", {}), "faults", where)
    from_state = faults_table.string("from_state", FAULT_ANCHOR_STATES) if faults_table.has("from_state") else None
    faults = _build(FaultConfig, _typed_fields(faults_table, FaultConfig), "faults", where)
    sensors = _build(SensorConfig,
                     _typed_fields(SettingsTable(doc.get("sensors", {}), "sensors", where), SensorConfig),
                     "sensors", where)
    attitude = _build(AttitudeDisturbance, {}, "attitude", where) if "attitude" not in doc else \
        _attitude(SettingsTable(doc["attitude"], "attitude", where))
    scenario = Scenario(
        name=name, description=description,
        scene_path=files["scene"], area_path=files["area"], survey_path=files["survey"],
        start_north_m=start_north, start_east_m=start_east, start_heading_rad=math.radians(heading),
        executor=executor, faults=faults, current_north_m_s=current_n, current_east_m_s=current_e,
        pitch_loop=pitch_loop, seed=seed, sensors=sensors, link_timeout_s=link_timeout_s,
        attitude=attitude, source=where,
        autopilot_params=_autopilot(SettingsTable(doc.get("autopilot", {}), "autopilot", where)),
        topside=_topside(SettingsTable(doc["topside"], "topside", where)) if "topside" in doc else None,
        faults_from_state=from_state,
    )
    return replace(scenario, **overrides) if overrides else scenario
