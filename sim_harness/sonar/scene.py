"""Scene files: a seabed world, a default viewpoint and sonar window, as TOML or JSON.

(Over 400 lines: the one parser of the scene format, its helpers sharing the key-naming
context ``_Ctx``; the format's documentation is this docstring.)

A scene is a file (``.toml`` or ``.json``, same keys) or the name of a scene shipped with
the package (:func:`builtin_scenes`: ``paper-tank``, ``open-seabed``). Keys (metres and
degrees at this edge; radians inside):

```toml
name = "my-site"                 # optional, default: the file's stem
description = "..."              # optional
include = ["open-seabed"]        # optional: built-in names or paths (relative to this file)

[origin]                         # optional WGS84 position of the local NED origin
lat_deg = 43.1
lon_deg = 5.9

[seabed]
depth_m = 12.0                   # depth of the seabed plane at the origin
slope_deg = 1.0                  # optional, default 0
slope_direction_deg = 90.0       # optional: compass direction in which the seabed deepens
material = "sand"                # optional, default sand
relief = { amplitude_m = 0.03, wavelength_m = 6.0, seed = 1, components = 6 }  # optional
texture_db = 3.0                 # optional: persistent reflectivity texture, std in dB (0/absent: off)
texture_scale_m = 0.1            # optional: its correlation length, m (default 0.1)
texture_seed = 0                 # optional: its seed (default 0)

[materials.steel]                # optional extra materials
backscatter_db = -8.0
roughness = 0.3

[[targets]]
id = "T1"
shape = "box"                    # box | cylinder | stone | rock | pipe (lying, along yaw_deg)
north_m = 3.0                    # its place: north_m/east_m (metres from the origin) or
east_m = 0.5                     # lat_deg/lon_deg (WGS84; needs an [origin]), one pair
length_m = 0.19                  # box, stone, rock, pipe (cylinder: diameter_m; pipe: diameter_m too)
width_m = 0.19
height_m = 0.028
yaw_deg = 0.0                    # optional
material = "concrete"            # optional
seed = 0                         # optional (shapes a rock)

[viewpoint]                      # the default place the `render` command looks from
north_m = 0.0
east_m = 0.0
heading_deg = 0.0
altitude_m = 0.5
tilt_deg = 20.0                  # optional: chosen from the targets when absent

[sonar]                          # optional window overrides
window_start_m = 0.7
window_length_m = 2.3
samples_per_beam = 1000
sound_speed_m_s = 1480.0
```

Included scenes are loaded first; the including file's ``targets`` are appended to theirs
(ids must stay unique), its ``materials`` added, and each of its ``seabed``, ``origin``,
``viewpoint`` and ``sonar`` tables replaces the included one whole. A target placed by
``lat_deg``/``lon_deg`` stays where it is on the Earth: it is converted to local metres
about the scene's final origin (after every include), through the product's one geodesy
(:mod:`perception.geodesy`, the local frame's georeference). Any error names the file and
the key (:class:`~sim_harness.world.errors.SceneError`).
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

from perception.geodesy import LocalOrigin
from sim_harness.world.errors import SceneError, WorldError
from sim_harness.world.materials import MATERIALS, Material
from sim_harness.world.relief import Relief
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import SHAPES, Seabed, TargetSpec, World

#: Built-in scene names and their files under ``sim_harness/data/scenes``.
BUILTIN = {"paper-tank": "paper-tank.toml", "open-seabed": "open-seabed.toml"}

_TOP_KEYS = {"name", "description", "include", "origin", "seabed", "materials", "targets", "viewpoint", "sonar"}
_SEABED_KEYS = {"depth_m", "slope_deg", "slope_direction_deg", "material", "relief", "texture_db",
                "texture_scale_m", "texture_seed"}
#: Correlation length of the seabed texture when a scene gives none, m.
DEFAULT_TEXTURE_SCALE_M = 0.1
_RELIEF_KEYS = {"amplitude_m", "wavelength_m", "seed", "components"}
_MATERIAL_KEYS = {"backscatter_db", "roughness"}
_TARGET_KEYS = {"id", "shape", "north_m", "east_m", "lat_deg", "lon_deg", "length_m", "width_m", "diameter_m",
                "height_m", "yaw_deg", "material", "seed"}
#: The two ways to place a target: local metres about the origin, or WGS84 degrees.
_LOCAL_PAIR = ("north_m", "east_m")
_GEOGRAPHIC_PAIR = ("lat_deg", "lon_deg")
_VIEW_KEYS = {"north_m", "east_m", "heading_deg", "altitude_m", "tilt_deg", "pitch_deg", "roll_deg"}
_SONAR_KEYS = {"window_start_m", "window_length_m", "samples_per_beam", "sound_speed_m_s"}
_MAX_INCLUDE_DEPTH = 8
#: Largest magnitude of any number in a scene file (metres, degrees, dB).
MAX_SCENE_VALUE = 1.0e5


@dataclass(frozen=True)
class Viewpoint:
    """Default sonar placement of a scene (radians; ``tilt_rad`` NaN = choose it)."""

    north_m: float = 0.0
    east_m: float = 0.0
    heading_rad: float = 0.0
    altitude_m: float = 1.0
    tilt_rad: float = math.nan
    pitch_rad: float = 0.0
    roll_rad: float = 0.0


@dataclass(frozen=True)
class Scene:
    """A loaded scene: the world, its default viewpoint and sonar window overrides."""

    name: str
    world: World
    viewpoint: Viewpoint
    sonar: dict[str, Any] = field(default_factory=dict)
    description: str = ""
    source: str = ""


def builtin_scenes() -> tuple[str, ...]:
    """Names of the scenes shipped with the package."""
    return tuple(BUILTIN)


class _Ctx:
    """Where we are in a scene document, for error messages."""

    def __init__(self, path: str):
        self.path = path

    def fail(self, key: str | None, message: str) -> SceneError:
        return SceneError(message, path=self.path, key=key)

    def table(self, value: Any, key: str, allowed: set[str]) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(key, f"must be a table/object, got {type(value).__name__}")
        unknown = sorted(set(value) - allowed)
        if unknown:
            raise self.fail(f"{key}.{unknown[0]}" if key else unknown[0],
                            f"unknown key; allowed: {', '.join(sorted(allowed))}")
        return value

    def number(self, table: dict[str, Any], name: str, key: str, *, default: float | None = None,
               positive: bool = False, nonneg: bool = False) -> float:
        full = f"{key}.{name}" if key else name
        if name not in table:
            if default is None:
                raise self.fail(full, "is required")
            return default
        v = table[name]
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise self.fail(full, f"must be a number, got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.fail(full, f"must be finite, got {v}")
        if abs(v) > MAX_SCENE_VALUE:  # no distance, angle or level of a scene is this large
            raise self.fail(full, f"must be within +-{MAX_SCENE_VALUE:g}, got {v:g}")
        if positive and v <= 0:
            raise self.fail(full, f"must be > 0, got {v}")
        if nonneg and v < 0:
            raise self.fail(full, f"must be >= 0, got {v}")
        return v

    def integer(self, table: dict[str, Any], name: str, key: str, default: int) -> int:
        v = table.get(name, default)
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.fail(f"{key}.{name}", f"must be an integer, got {v!r}")
        return int(v)

    def string(self, table: dict[str, Any], name: str, key: str, default: str | None = None) -> str:
        full = f"{key}.{name}" if key else name
        if name not in table:
            if default is None:
                raise self.fail(full, "is required")
            return default
        v = table[name]
        if not isinstance(v, str) or not v:
            raise self.fail(full, f"must be a non-empty string, got {v!r}")
        return v


def _read_document(path: Path, label: str) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError("scene file not found", path=label) from None
    except UnicodeDecodeError as exc:
        raise SceneError(f"not UTF-8 text ({exc})", path=label) from exc
    suffix = path.suffix.lower()
    try:
        if suffix == ".toml":
            doc: Any = tomllib.loads(text)
        elif suffix == ".json":
            doc = json.loads(text)
        else:
            raise SceneError(f"unknown scene file type {suffix!r}; use .toml or .json", path=label)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        raise SceneError(f"cannot parse: {exc}", path=label) from exc
    if not isinstance(doc, dict):
        raise SceneError("the document must be a table/object at the top", path=label)
    return doc


def _builtin_document(name: str) -> dict[str, Any]:
    text = resources.files("sim_harness").joinpath("data", "scenes", BUILTIN[name]).read_text(encoding="utf-8")
    return tomllib.loads(text)


def _parse_relief(ctx: _Ctx, value: Any) -> Relief:
    t = ctx.table(value, "seabed.relief", _RELIEF_KEYS)
    try:
        return Relief(
            amplitude_m=ctx.number(t, "amplitude_m", "seabed.relief", nonneg=True),
            wavelength_m=ctx.number(t, "wavelength_m", "seabed.relief", positive=True),
            seed=ctx.integer(t, "seed", "seabed.relief", 0),
            n_components=ctx.integer(t, "components", "seabed.relief", 6),
        )
    except WorldError as exc:
        raise ctx.fail(exc.key, str(exc).split(": ", 1)[-1]) from exc


def _parse_texture(ctx: _Ctx, t: dict[str, Any]) -> SeabedTexture | None:
    """The [seabed] table's texture keys: None when ``texture_db`` is absent or 0."""
    if "texture_db" not in t:
        for name in ("texture_scale_m", "texture_seed"):
            if name in t:
                raise ctx.fail(f"seabed.{name}", "needs seabed.texture_db (the texture's strength, dB)")
        return None
    std_db = ctx.number(t, "texture_db", "seabed", nonneg=True)
    scale_m = ctx.number(t, "texture_scale_m", "seabed", default=DEFAULT_TEXTURE_SCALE_M, positive=True)
    seed = ctx.integer(t, "texture_seed", "seabed", 0)
    if seed < 0:
        raise ctx.fail("seabed.texture_seed", f"must be >= 0, got {seed}")
    if std_db == 0.0:
        return None
    try:
        return SeabedTexture(std_db=std_db, correlation_m=scale_m, seed=seed)
    except WorldError as exc:
        raise ctx.fail(exc.key, str(exc).split(": ", 1)[-1]) from exc


def _parse_seabed(ctx: _Ctx, value: Any) -> Seabed:
    t = ctx.table(value, "seabed", _SEABED_KEYS)
    relief = _parse_relief(ctx, t["relief"]) if "relief" in t else None
    texture = _parse_texture(ctx, t)
    try:
        return Seabed(
            depth_m=ctx.number(t, "depth_m", "seabed", positive=True),
            slope_rad=math.radians(ctx.number(t, "slope_deg", "seabed", default=0.0)),
            slope_direction_rad=math.radians(ctx.number(t, "slope_direction_deg", "seabed", default=0.0)),
            material=ctx.string(t, "material", "seabed", "sand"),
            relief=relief,
            texture=texture,
        )
    except WorldError as exc:
        raise ctx.fail(exc.key, str(exc).split(": ", 1)[-1]) from exc


@dataclass(frozen=True)
class _Geographic:
    """A target placed by latitude and longitude, to be placed in metres once the origin is known."""

    index: int  # in the scene's list of targets
    lat_deg: float
    lon_deg: float
    path: str
    key: str  # "targets[3]"


def _target_place(ctx: _Ctx, t: dict[str, Any], key: str) -> tuple[float, float] | None:
    """``(lat_deg, lon_deg)`` of a target placed geographically; None when it gives north_m/east_m.

    Exactly one pair, whole: ``lat_deg``/``lon_deg`` or ``north_m``/``east_m``.
    """
    geographic = [k for k in _GEOGRAPHIC_PAIR if k in t]
    local = [k for k in _LOCAL_PAIR if k in t]
    if geographic and local:
        raise ctx.fail(f"{key}.{geographic[0]}", "give either lat_deg/lon_deg or north_m/east_m, not both")
    if not geographic:
        if not local:
            raise ctx.fail(f"{key}.north_m", "is required (a target's place: north_m/east_m or lat_deg/lon_deg)")
        return None
    for name, other in (_GEOGRAPHIC_PAIR, _GEOGRAPHIC_PAIR[::-1]):
        if name not in t:
            raise ctx.fail(f"{key}.{name}", f"is required with {other}")
    lat = ctx.number(t, "lat_deg", key)
    lon = ctx.number(t, "lon_deg", key)
    if not -90.0 < lat < 90.0:
        raise ctx.fail(f"{key}.lat_deg", f"must be within (-90, 90) deg, got {lat:g}")
    if not -180.0 <= lon <= 180.0:
        raise ctx.fail(f"{key}.lon_deg", f"must be within -180..180 deg, got {lon:g}")
    return lat, lon


def _parse_target(ctx: _Ctx, value: Any, i: int) -> tuple[TargetSpec, tuple[float, float] | None]:
    """The target (at north 0, east 0 when placed geographically) and its ``(lat_deg, lon_deg)`` if so."""
    key = f"targets[{i}]"
    t = ctx.table(value, key, _TARGET_KEYS)
    place = _target_place(ctx, t, key)
    shape = ctx.string(t, "shape", key)
    if shape not in SHAPES:
        raise ctx.fail(f"{key}.shape", f"unknown shape {shape!r}; known: {', '.join(SHAPES)}")
    height: float | None = None
    if shape == "cylinder":
        for bad in ("length_m", "width_m"):
            if bad in t:
                raise ctx.fail(f"{key}.{bad}", "a cylinder takes diameter_m, not length/width")
        length = width = ctx.number(t, "diameter_m", key, positive=True)
    elif shape == "pipe":
        for bad in ("width_m", "height_m"):
            if bad in t:
                raise ctx.fail(f"{key}.{bad}", "a pipe takes length_m and diameter_m (its height)")
        length = ctx.number(t, "length_m", key, positive=True)
        width = height = ctx.number(t, "diameter_m", key, positive=True)
    else:
        if "diameter_m" in t:
            raise ctx.fail(f"{key}.diameter_m", f"a {shape} takes length_m and width_m")
        length = ctx.number(t, "length_m", key, positive=True)
        width = ctx.number(t, "width_m", key, positive=True)
    try:
        spec = TargetSpec(
            target_id=ctx.string(t, "id", key),
            shape=shape,
            north_m=0.0 if place else ctx.number(t, "north_m", key),
            east_m=0.0 if place else ctx.number(t, "east_m", key),
            length_m=length,
            width_m=width,
            height_m=height if height is not None else ctx.number(t, "height_m", key, positive=True),
            yaw_rad=math.radians(ctx.number(t, "yaw_deg", key, default=0.0)),
            material=ctx.string(t, "material", key, "concrete"),
            seed=ctx.integer(t, "seed", key, 0),
        )
    except WorldError as exc:
        raise ctx.fail(key, str(exc)) from exc
    return spec, place


def _parse_viewpoint(ctx: _Ctx, value: Any) -> Viewpoint:
    t = ctx.table(value, "viewpoint", _VIEW_KEYS)
    tilt = ctx.number(t, "tilt_deg", "viewpoint", default=math.nan) if "tilt_deg" in t else math.nan
    return Viewpoint(
        north_m=ctx.number(t, "north_m", "viewpoint", default=0.0),
        east_m=ctx.number(t, "east_m", "viewpoint", default=0.0),
        heading_rad=math.radians(ctx.number(t, "heading_deg", "viewpoint", default=0.0)),
        altitude_m=ctx.number(t, "altitude_m", "viewpoint", positive=True),
        tilt_rad=math.radians(tilt),
        pitch_rad=math.radians(ctx.number(t, "pitch_deg", "viewpoint", default=0.0)),
        roll_rad=math.radians(ctx.number(t, "roll_deg", "viewpoint", default=0.0)),
    )


def _parse_sonar(ctx: _Ctx, value: Any) -> dict[str, Any]:
    t = ctx.table(value, "sonar", _SONAR_KEYS)
    out: dict[str, Any] = {}
    for name in ("window_start_m", "window_length_m", "sound_speed_m_s"):
        if name in t:
            out[name] = ctx.number(t, name, "sonar", nonneg=name == "window_start_m",
                                   positive=name != "window_start_m")
    if "samples_per_beam" in t:
        n = ctx.integer(t, "samples_per_beam", "sonar", 0)
        if n < 2:
            raise ctx.fail("sonar.samples_per_beam", f"must be >= 2, got {n}")
        out["samples_per_beam"] = n
    return out


@dataclass
class _Parts:
    seabed: Seabed | None = None
    origin: tuple[float, float] | None = None
    materials: dict[str, Material] = field(default_factory=dict)
    targets: list[TargetSpec] = field(default_factory=list)
    geographic: list[_Geographic] = field(default_factory=list)
    viewpoint: Viewpoint | None = None
    sonar: dict[str, Any] = field(default_factory=dict)
    description: str = ""


def _load_parts(source: str | Path, base: Path | None, stack: tuple[str, ...]) -> tuple[str, _Parts]:
    text = str(source)
    builtin = text in BUILTIN and not (base is not None and (base / text).exists())
    if builtin:
        label = text
        doc = _builtin_document(text)
        here: Path | None = None
    else:
        path = Path(text)
        if base is not None and not path.is_absolute():
            path = base / path
        label = str(path)
        if not path.exists() and path.suffix == "":
            known = ", ".join(BUILTIN)
            raise SceneError(f"no such scene file, and not a built-in scene ({known})", path=label)
        doc = _read_document(path, label)
        here = path.resolve().parent
        label = str(path)
    if label in stack:
        raise SceneError(f"include cycle: {' -> '.join(stack + (label,))}", path=label)
    if len(stack) >= _MAX_INCLUDE_DEPTH:
        raise SceneError("includes nested too deep", path=label)
    ctx = _Ctx(label)
    ctx.table(doc, "", _TOP_KEYS)
    parts = _Parts()
    includes = doc.get("include", [])
    if not isinstance(includes, list) or not all(isinstance(x, str) for x in includes):
        raise ctx.fail("include", "must be a list of scene names or paths")
    for inc in includes:
        _, sub = _load_parts(inc, here, stack + (label,))
        parts.seabed = sub.seabed or parts.seabed
        parts.origin = sub.origin or parts.origin
        parts.materials.update(sub.materials)
        parts.geographic.extend(replace(g, index=g.index + len(parts.targets)) for g in sub.geographic)
        parts.targets.extend(sub.targets)
        parts.viewpoint = sub.viewpoint or parts.viewpoint
        parts.sonar.update(sub.sonar)
    if "description" in doc:
        parts.description = ctx.string(doc, "description", "")
    if "origin" in doc:
        t = ctx.table(doc["origin"], "origin", {"lat_deg", "lon_deg"})
        lat = ctx.number(t, "lat_deg", "origin")
        lon = ctx.number(t, "lon_deg", "origin")
        if not (-90 <= lat <= 90 and -180 <= lon <= 180):
            raise ctx.fail("origin", f"lat/lon out of range: {lat}, {lon}")
        parts.origin = (lat, lon)
    if "materials" in doc:
        mats = doc["materials"]
        if not isinstance(mats, dict):
            raise ctx.fail("materials", "must be a table of material tables")
        for name, spec in mats.items():
            key = f"materials.{name}"
            t = ctx.table(spec, key, _MATERIAL_KEYS)
            try:
                parts.materials[name] = Material(
                    name, ctx.number(t, "backscatter_db", key), ctx.number(t, "roughness", key, default=1.0)
                )
            except WorldError as exc:
                raise ctx.fail(key, str(exc)) from exc
    if "seabed" in doc:
        parts.seabed = _parse_seabed(ctx, doc["seabed"])
    if "targets" in doc:
        if not isinstance(doc["targets"], list):
            raise ctx.fail("targets", "must be an array of tables")
        for i, t in enumerate(doc["targets"]):
            spec, place = _parse_target(ctx, t, i)
            if place is not None:
                parts.geographic.append(_Geographic(len(parts.targets), *place, label, f"targets[{i}]"))
            parts.targets.append(spec)
    if "viewpoint" in doc:
        parts.viewpoint = _parse_viewpoint(ctx, doc["viewpoint"])
    if "sonar" in doc:
        parts.sonar.update(_parse_sonar(ctx, doc["sonar"]))
    name = ctx.string(doc, "name", "", text if builtin else Path(label).stem)
    return name, parts


def _placed(parts: _Parts, label: str) -> list[TargetSpec]:
    """The targets, those given by latitude and longitude placed in metres about the scene's origin."""
    targets = list(parts.targets)
    if not parts.geographic:
        return targets
    first = parts.geographic[0]
    if parts.origin is None:
        raise SceneError("a target placed by lat_deg/lon_deg needs the scene's [origin] (lat_deg, lon_deg)",
                         path=first.path, key=f"{first.key}.lat_deg")
    try:
        origin = LocalOrigin(*parts.origin)
    except ValueError as exc:
        raise SceneError(f"cannot place targets by lat_deg/lon_deg about it: {exc}", path=label, key="origin") from exc
    north, east = origin.to_local([g.lat_deg for g in parts.geographic], [g.lon_deg for g in parts.geographic])
    for g, n, e in zip(parts.geographic, north.tolist(), east.tolist(), strict=True):
        far = math.hypot(n, e)
        if not far <= MAX_SCENE_VALUE:
            raise SceneError(f"lies {far / 1000:.0f} km from the scene's origin ({origin.lat_deg:g}, "
                             f"{origin.lon_deg:g}); a target must lie within {MAX_SCENE_VALUE / 1000:g} km of it",
                             path=g.path, key=f"{g.key}.lat_deg")
        targets[g.index] = replace(targets[g.index], north_m=n, east_m=e)
    return targets


def load_scene(source: str | Path) -> Scene:
    """Load a scene from a file path or a built-in name (see the module docstring).

    Raises
    ------
    SceneError
        Naming the file and key of whatever is missing, unknown or invalid.
    """
    name, parts = _load_parts(source, None, ())
    label = str(source)
    if parts.seabed is None:
        raise SceneError("no [seabed] table (directly or through include)", path=label, key="seabed")
    if parts.viewpoint is None:
        raise SceneError("no [viewpoint] table (directly or through include)", path=label, key="viewpoint")
    materials = dict(MATERIALS)
    materials.update(parts.materials)
    lat, lon = parts.origin if parts.origin else (math.nan, math.nan)
    try:
        world = World(parts.seabed, tuple(_placed(parts, label)), materials, name, lat, lon)
    except WorldError as exc:
        raise SceneError(str(exc), path=label) from exc
    return Scene(name, world, parts.viewpoint, dict(parts.sonar), parts.description, label)
