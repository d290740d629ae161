"""The seabed world: a (sloped) plane with gentle relief, materials, and targets on it.

Frames and signs follow :mod:`perception.geometry` (local NED metres, depth positive down).
The seabed's depth at a point is

    depth(n, e) = depth_m + g_n * n + g_e * e - relief(n, e),

with ``(g_n, g_e) = tan(slope) * (cos(dir), sin(dir))`` (the seabed deepens towards the
compass direction ``dir``) and ``relief`` a seeded sum of a few long, low sinusoids
(positive up). Targets rest on the seabed: the base of each stands at the seabed depth
under the target's centre and the target's ``height_m`` is measured vertically from there.

Materials and their scattering are :mod:`sim_harness.world.materials`, the relief
:mod:`sim_harness.world.relief`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sim_harness.world.errors import WorldError, finite
from sim_harness.world.materials import MATERIALS, Material
from sim_harness.world.pipe import PipeSolid
from sim_harness.world.relief import Relief
from sim_harness.world.shapes import BoxSolid, CompositeSolid, CylinderSolid, EllipsoidSolid, Solid
from sim_harness.world.texture import SeabedTexture

FloatArray = NDArray[np.float64]

#: Shapes a target may have.
SHAPES = ("box", "cylinder", "stone", "rock", "pipe")


@dataclass(frozen=True)
class Seabed:
    """The seabed: a plane through ``depth_m`` at the local origin, plus optional relief and
    an optional persistent reflectivity texture (:class:`~sim_harness.world.texture.SeabedTexture`,
    a gain on the material's backscatter fixed in north/east; None: uniform)."""

    depth_m: float
    slope_rad: float = 0.0
    slope_direction_rad: float = 0.0
    material: str = "sand"
    relief: Relief | None = None
    texture: SeabedTexture | None = None

    def __post_init__(self) -> None:
        finite(self.depth_m, "seabed.depth_m", positive=True)
        s = finite(self.slope_rad, "seabed.slope_deg")
        if not 0.0 <= s < math.radians(45.0):
            raise WorldError(f"must be in [0, 45) deg, got {math.degrees(s):.3g}", key="seabed.slope_deg")
        finite(self.slope_direction_rad, "seabed.slope_direction_deg")

    @property
    def gradient(self) -> tuple[float, float]:
        """(d depth / d north, d depth / d east) of the plane."""
        g = math.tan(self.slope_rad)
        return g * math.cos(self.slope_direction_rad), g * math.sin(self.slope_direction_rad)

    def plane_depth_m(self, north_m: float, east_m: float) -> float:
        """Depth of the plane (no relief), m."""
        gn, ge = self.gradient
        return self.depth_m + gn * north_m + ge * east_m

    def depth_at(self, north_m: ArrayLike, east_m: ArrayLike) -> FloatArray:
        """Seabed depth with relief, m, vectorised."""
        gn, ge = self.gradient
        n = np.asarray(north_m, dtype=np.float64)
        e = np.asarray(east_m, dtype=np.float64)
        depth = self.depth_m + gn * n + ge * e
        if self.relief is not None:
            depth = depth - self.relief.height_m(n, e)
        return np.asarray(depth)


@dataclass(frozen=True)
class TargetSpec:
    """A target as a scene describes it (sizes in metres, yaw in radians).

    ``shape`` is one of :data:`SHAPES`: ``box`` (length x width x height, yaw),
    ``cylinder`` (vertical; diameter = ``length_m``), ``stone`` (a half-ellipsoid of
    length x width x height) or ``rock`` (an irregular union of 3-5 ellipsoids inside the
    length x width footprint, the tallest exactly ``height_m``; ``seed`` shapes it) or
    ``pipe`` (a pipe section lying on the seabed along ``yaw``: ``length_m`` long, its
    diameter ``height_m``; ``width_m`` is ignored).
    """

    target_id: str
    shape: str
    north_m: float
    east_m: float
    length_m: float
    width_m: float
    height_m: float
    yaw_rad: float = 0.0
    material: str = "concrete"
    seed: int = 0

    def __post_init__(self) -> None:
        key = f"targets[{self.target_id}]"
        if self.shape not in SHAPES:
            raise WorldError(f"unknown shape {self.shape!r}; known: {', '.join(SHAPES)}", key=f"{key}.shape")
        for name in ("north_m", "east_m", "yaw_rad"):
            finite(getattr(self, name), f"{key}.{name}")
        for name in ("length_m", "width_m", "height_m"):
            finite(getattr(self, name), f"{key}.{name}", positive=True)


def _rock_lobes(spec: TargetSpec, base_depth_m: float) -> tuple[EllipsoidSolid, ...]:
    rng = np.random.default_rng(int(spec.seed))
    n_extra = int(rng.integers(2, 5))
    c, s = math.cos(spec.yaw_rad), math.sin(spec.yaw_rad)
    axes = np.array([[c, s], [-s, c]])
    lobes = [
        EllipsoidSolid(spec.north_m, spec.east_m, base_depth_m, 0.7 * spec.length_m, 0.7 * spec.width_m,
                       spec.height_m, spec.yaw_rad)
    ]
    for _ in range(n_extra):
        du = rng.uniform(-0.22, 0.22) * spec.length_m
        dv = rng.uniform(-0.22, 0.22) * spec.width_m
        dn, de = du * axes[0] + dv * axes[1]
        lobes.append(
            EllipsoidSolid(
                spec.north_m + dn,
                spec.east_m + de,
                base_depth_m,
                rng.uniform(0.35, 0.55) * spec.length_m,
                rng.uniform(0.35, 0.55) * spec.width_m,
                rng.uniform(0.45, 0.85) * spec.height_m,
                spec.yaw_rad + rng.uniform(-0.8, 0.8),
            )
        )
    return tuple(lobes)


@dataclass(frozen=True)
class PlacedTarget:
    """A target resting on the world's seabed.

    ``base_depth_m`` is the seabed depth under its centre; its top is at
    ``base_depth_m - spec.height_m``. ``corners_ned`` (n, 3): corners of boxes that bound the
    solid (read-only), NED m.
    """

    spec: TargetSpec
    base_depth_m: float
    solid: Solid
    corners_ned: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        corners = np.asarray(self.solid.corners_ned(), dtype=np.float64)
        corners.flags.writeable = False
        object.__setattr__(self, "corners_ned", corners)

    @property
    def target_id(self) -> str:
        """The scene's id of the target."""
        return self.spec.target_id

    @property
    def top_depth_m(self) -> float:
        """Depth of the target's highest point, m."""
        return self.base_depth_m - self.spec.height_m


@dataclass(frozen=True)
class World:
    """A seabed with targets and materials.

    Parameters
    ----------
    seabed : Seabed
    targets : tuple of TargetSpec
        Target ids must be unique.
    materials : mapping of str to Material
        Materials by name; defaults to :data:`MATERIALS`. Every material used must be here.
    name : str
    origin_lat_deg, origin_lon_deg : float
        WGS84 position of the local NED origin, NaN when the scene gave none.
    """

    seabed: Seabed
    targets: tuple[TargetSpec, ...] = ()
    materials: Mapping[str, Material] = field(default_factory=lambda: dict(MATERIALS))
    name: str = "world"
    origin_lat_deg: float = math.nan
    origin_lon_deg: float = math.nan
    placed: tuple[PlacedTarget, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "targets", tuple(self.targets))
        seen: set[str] = set()
        for spec in self.targets:
            if spec.target_id in seen:
                raise WorldError(f"duplicate target id {spec.target_id!r}", key="targets")
            seen.add(spec.target_id)
        for name in [self.seabed.material] + [t.material for t in self.targets]:
            if name not in self.materials:
                raise WorldError(
                    f"unknown material {name!r}; known: {', '.join(sorted(self.materials))}",
                    key="material",
                )
        relief_amp = self.seabed.relief.amplitude_m if self.seabed.relief else 0.0
        slope = math.tan(self.seabed.slope_rad)
        placed = []
        for spec in self.targets:
            base = self.seabed_depth_m(spec.north_m, spec.east_m)
            radius = 0.5 * math.hypot(spec.length_m, spec.width_m)
            footing = 0.01 + slope * radius + 2.0 * relief_amp
            solid: Solid
            if spec.shape == "box":
                solid = BoxSolid(spec.north_m, spec.east_m, base, spec.length_m, spec.width_m,
                                 spec.height_m, spec.yaw_rad, footing)
            elif spec.shape == "cylinder":
                solid = CylinderSolid(spec.north_m, spec.east_m, base, spec.length_m / 2,
                                      spec.height_m, footing)
            elif spec.shape == "pipe":
                solid = PipeSolid(spec.north_m, spec.east_m, base, spec.length_m, spec.height_m / 2, spec.yaw_rad)
            elif spec.shape == "stone":
                solid = EllipsoidSolid(spec.north_m, spec.east_m, base, spec.length_m,
                                       spec.width_m, spec.height_m, spec.yaw_rad)
            else:
                solid = CompositeSolid(_rock_lobes(spec, base))
            placed.append(PlacedTarget(spec, base, solid))
        object.__setattr__(self, "placed", tuple(placed))

    def seabed_depth_m(self, north_m: float, east_m: float) -> float:
        """Depth of the seabed at a point, m, positive down (local NED)."""
        gn, ge = self.seabed.gradient
        depth = self.seabed.depth_m + gn * north_m + ge * east_m
        if self.seabed.relief is not None:
            depth -= float(self.seabed.relief.height_m(north_m, east_m))
        return float(depth)

    def seabed_normal_ned(self, north_m: float, east_m: float) -> FloatArray:
        """Unit normal of the seabed at a point, pointing up into the water, NED, shape (3,)."""
        gn, ge = self.seabed.gradient
        if self.seabed.relief is not None:
            rn, re = self.seabed.relief.gradient(north_m, east_m)
            gn, ge = gn - float(rn), ge - float(re)
        v = np.array([gn, ge, -1.0])
        return v / np.linalg.norm(v)

    def material(self, name: str) -> Material:
        """The material called ``name``."""
        try:
            return self.materials[name]
        except KeyError:
            raise WorldError(f"unknown material {name!r}", key="material") from None

    def target(self, target_id: str) -> PlacedTarget:
        """The placed target with this id."""
        for placed in self.placed:
            if placed.target_id == target_id:
                return placed
        raise KeyError(f"no target {target_id!r} in world {self.name!r}")

    def with_targets(self, extra: tuple[TargetSpec, ...], *, name: str | None = None) -> World:
        """A copy with more targets (ids must stay unique)."""
        return World(self.seabed, self.targets + tuple(extra), self.materials,
                     name or self.name, self.origin_lat_deg, self.origin_lon_deg)
