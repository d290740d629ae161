"""The seabed world: a (sloped) plane with gentle relief, materials, and targets on it.

Frames and signs follow :mod:`perception.geometry` (local NED metres, depth positive down).
The seabed's depth at a point is

    depth(n, e) = depth_m + g_n * n + g_e * e - relief(n, e),

with ``(g_n, g_e) = tan(slope) * (cos(dir), sin(dir))`` (the seabed deepens towards the
compass direction ``dir``) and ``relief`` a seeded sum of a few long, low sinusoids
(positive up). Targets rest on the seabed: the base of each stands at the seabed depth
under the target's centre and the target's ``height_m`` is measured vertically from there.

Scattering of a material (backscatter cross-section per unit area and steradian, linear)
at incidence angle ``theta`` (between the ray and the surface normal)::

    sigma(theta) = mu * (roughness * cos^2(theta)
                         + (1 - roughness) * SPECULAR_GAIN * exp(-(theta / SPECULAR_WIDTH)^2))

with ``mu = 10 ** (backscatter_db / 10)``: a rough material scatters by Lambert's law, a
smooth one mostly back along the normal.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sim_harness.world.errors import WorldError
from sim_harness.world.pipe import PipeSolid
from sim_harness.world.shapes import BoxSolid, CompositeSolid, CylinderSolid, EllipsoidSolid, Solid
from sim_harness.world.texture import SeabedTexture

FloatArray = NDArray[np.float64]

#: Gain of the specular lobe of a smooth material over Lambert's law at normal incidence.
SPECULAR_GAIN = 10.0
#: Angular width (1/e) of the specular lobe, rad.
SPECULAR_WIDTH_RAD = math.radians(12.0)
#: Steepest relief slope accepted as "gentle" (rise over run).
MAX_RELIEF_SLOPE = 0.25
#: Shapes a target may have.
SHAPES = ("box", "cylinder", "stone", "rock", "pipe")


def _finite(value: float, key: str, *, positive: bool = False, nonneg: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise WorldError(f"must be finite, got {value!r}", key=key)
    if positive and v <= 0:
        raise WorldError(f"must be > 0, got {value!r}", key=key)
    if nonneg and v < 0:
        raise WorldError(f"must be >= 0, got {value!r}", key=key)
    return v


@dataclass(frozen=True)
class Material:
    """Acoustic surface properties.

    Attributes
    ----------
    name : str
    backscatter_db : float
        Lambert coefficient ``mu`` in dB (e.g. -27 for sand).
    roughness : float
        In [0, 1]: 1 scatters by Lambert's law, 0 is a smooth, mirror-like surface.
    """

    name: str
    backscatter_db: float
    roughness: float = 1.0

    def __post_init__(self) -> None:
        _finite(self.backscatter_db, f"materials.{self.name}.backscatter_db")
        r = _finite(self.roughness, f"materials.{self.name}.roughness")
        if not 0.0 <= r <= 1.0:
            raise WorldError(f"must lie in [0, 1], got {r}", key=f"materials.{self.name}.roughness")

    def sigma_over_cos(self, cos_incidence: ArrayLike) -> NDArray[np.floating]:
        """``sigma(theta) / cos(theta)``, linear, for cosines of the incidence angle.

        Cosines are clipped to [0, 1]; float32 input stays float32, anything else is float64.
        """
        c = np.asarray(cos_incidence)
        if c.dtype != np.float32:
            c = c.astype(np.float64)
        dt = c.dtype.type
        c = np.clip(c, dt(0.0), dt(1.0))
        out = dt(self.roughness * 10.0 ** (self.backscatter_db / 10.0)) * c
        if self.roughness < 1.0:
            theta = np.arccos(c)
            spec = np.exp(dt(-1.0 / SPECULAR_WIDTH_RAD**2) * theta * theta) / np.maximum(c, dt(1e-6))
            mu = 10.0 ** (self.backscatter_db / 10.0)
            out = out + dt((1.0 - self.roughness) * SPECULAR_GAIN * mu) * spec
        return out


#: Materials every scene knows; scenes may add their own.
MATERIALS: Mapping[str, Material] = {
    m.name: m
    for m in (
        Material("mud", -35.0, 1.0),
        Material("sand", -27.0, 1.0),
        Material("gravel", -20.0, 1.0),
        Material("rock", -15.0, 0.9),
        Material("concrete", -14.0, 0.8),
        Material("brick", -16.0, 0.85),
        Material("wood", -20.0, 0.8),
        Material("plastic", -18.0, 0.5),
        Material("rubber", -22.0, 0.7),
        Material("glass", -25.0, 0.2),
        Material("metal", -10.0, 0.3),
    )
}


@dataclass(frozen=True)
class Relief:
    """Gentle seabed relief: ``n_components`` seeded sinusoids, heights positive up.

    Amplitudes sum to ``amplitude_m`` (so the relief never exceeds it); wavelengths are
    drawn within [0.7, 1.4] x ``wavelength_m``; directions and phases uniform.
    """

    amplitude_m: float
    wavelength_m: float
    seed: int = 0
    n_components: int = 6
    _k: FloatArray = field(init=False, repr=False, compare=False)
    _a: FloatArray = field(init=False, repr=False, compare=False)
    _phase: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        amp = _finite(self.amplitude_m, "seabed.relief.amplitude_m", nonneg=True)
        wl = _finite(self.wavelength_m, "seabed.relief.wavelength_m", positive=True)
        if not 1 <= int(self.n_components) <= 32:
            raise WorldError("must be in 1..32", key="seabed.relief.n_components")
        rng = np.random.default_rng(int(self.seed))
        n = int(self.n_components)
        weights = rng.uniform(0.5, 1.5, n)
        a = amp * weights / weights.sum()
        lam = wl * rng.uniform(0.7, 1.4, n)
        direction = rng.uniform(0.0, 2 * math.pi, n)
        k = (2 * math.pi / lam)[:, None] * np.stack([np.cos(direction), np.sin(direction)], axis=1)
        slope = float(np.sum(a * np.hypot(k[:, 0], k[:, 1])))
        if slope > MAX_RELIEF_SLOPE:
            raise WorldError(
                f"relief of {amp} m over {wl} m wavelength reaches a slope of {slope:.2f}; "
                f"gentle relief needs <= {MAX_RELIEF_SLOPE} (lower the amplitude or lengthen "
                "the wavelength)",
                key="seabed.relief",
            )
        object.__setattr__(self, "_k", k)
        object.__setattr__(self, "_a", a)
        object.__setattr__(self, "_phase", rng.uniform(0.0, 2 * math.pi, n))

    def height_m(self, north_m: ArrayLike, east_m: ArrayLike) -> FloatArray:
        """Relief height (positive up), m, broadcast over the inputs."""
        n = np.asarray(north_m, dtype=np.float64)
        e = np.asarray(east_m, dtype=np.float64)
        shape, n_flat, e_flat = _rows_of(n, e)
        # all components at once, (n_components, points), summed row by row in component order
        arg = n_flat * self._k[:, :1]
        arg += e_flat * self._k[:, 1:]
        arg += self._phase[:, None]
        np.cos(arg, out=arg)
        arg *= self._a[:, None]
        return np.asarray(_sum_rows(arg).reshape(shape), dtype=np.float64)

    def gradient(self, north_m: ArrayLike, east_m: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """(d height / d north, d height / d east), dimensionless."""
        _, gn, ge = self.height_and_gradient(north_m, east_m)
        return np.asarray(gn, dtype=np.float64), np.asarray(ge, dtype=np.float64)

    def height_and_gradient(
        self, north_m: ArrayLike, east_m: ArrayLike, *, dtype: type = np.float64
    ) -> tuple[NDArray[np.floating], NDArray[np.floating], NDArray[np.floating]]:
        """(height m, d height / d north, d height / d east) at once, broadcast over the inputs.

        ``dtype`` float32 trades precision for speed (vectorised trigonometry): the phases
        are off by ~1e-7 of themselves, i.e. the height by ~1e-7 x amplitude x |k| x distance
        from the origin (~1e-6 m for 5 cm relief 500 m out).
        """
        n: NDArray[np.floating] = np.asarray(north_m, dtype=dtype)
        e: NDArray[np.floating] = np.asarray(east_m, dtype=dtype)
        shape, n_flat, e_flat = _rows_of(n, e)
        # all components at once, (n_components, points), summed row by row in component order
        a: NDArray[np.floating] = self._a.astype(dtype)[:, None]
        kn: NDArray[np.floating] = self._k[:, :1].astype(dtype)
        ke: NDArray[np.floating] = self._k[:, 1:].astype(dtype)
        arg = n_flat * kn
        arg += e_flat * ke
        arg += self._phase.astype(dtype)[:, None]
        s = np.sin(arg)
        np.cos(arg, out=arg)
        arg *= a
        s *= -a
        h: NDArray[np.floating] = _sum_rows(arg).reshape(shape)
        gn: NDArray[np.floating] = _sum_rows(s * kn).reshape(shape)
        ge: NDArray[np.floating] = _sum_rows(s * ke).reshape(shape)
        return h, gn, ge


def _rows_of(
    n: NDArray[np.floating], e: NDArray[np.floating]
) -> tuple[tuple[int, ...], NDArray[np.floating], NDArray[np.floating]]:
    """(broadcast shape, ``n`` and ``e`` broadcast to it as (1, points) rows)."""
    if n.shape == e.shape:
        return n.shape, n.reshape(1, -1), e.reshape(1, -1)
    shape = np.broadcast_shapes(n.shape, e.shape)
    return shape, np.broadcast_to(n, shape).reshape(1, -1), np.broadcast_to(e, shape).reshape(1, -1)


def _sum_rows(x: NDArray[np.floating]) -> NDArray[np.floating]:
    """Sum of the rows of ``x`` (k, m), added one after another onto zero (the order of a
    loop over the rows, unlike numpy's pairwise summation), shape (m,)."""
    out = x[0] + x.dtype.type(0.0)
    for row in x[1:]:
        out += row
    return out


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
        _finite(self.depth_m, "seabed.depth_m", positive=True)
        s = _finite(self.slope_rad, "seabed.slope_deg")
        if not 0.0 <= s < math.radians(45.0):
            raise WorldError(f"must be in [0, 45) deg, got {math.degrees(s):.3g}", key="seabed.slope_deg")
        _finite(self.slope_direction_rad, "seabed.slope_direction_deg")

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
            _finite(getattr(self, name), f"{key}.{name}")
        for name in ("length_m", "width_m", "height_m"):
            _finite(getattr(self, name), f"{key}.{name}", positive=True)


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
