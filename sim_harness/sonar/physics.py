"""The renderer's physical choices that are not geometry: one frozen dataclass, validated once.

:class:`SonarPhysics` holds every modelling choice of :class:`~sim_harness.sonar.renderer.SonarRenderer`
besides what :class:`~sim_harness.sonar.renderer.SonarConfig` already names (window,
pulse, absorption, gain, TVG law, speckle looks, noise floor, side-lobe kernel, elevation
edge level). Its defaults are the renderer's historical choices, so a default render is
bit for bit what it was before these became parameters. :mod:`sim_harness.sonar.family`
draws members of the family from realistic ranges for tests and benchmarks.

The choices, with the realistic ranges the family draws from:

- **Speckle statistics**: fully developed speckle is exponential in power (Rayleigh in
  amplitude) with ``SonarConfig.speckle_looks`` = 1, gamma with more looks (1-8);
  ``speckle_texture_shape`` ``nu`` (finite) multiplies it by an independent gamma texture of
  shape ``nu`` and mean 1 per range cell and ping, which makes the power K-distributed:
  heavier-tailed than Rayleigh, the more so the smaller ``nu`` (1-20; ``inf``: off).
- **Azimuth beam pattern**: ``azimuth_pattern`` ``"kernel"`` leaks each beam into its
  neighbours by ``SonarConfig.sidelobe_db`` (the historical choice); ``"sinc"`` takes the
  kernel from a sinc^2 receive pattern whose -3 dB full width is
  ``azimuth_width_beams`` beam spacings (0.8-1.6; the main lobe reaches the neighbours)
  with the side lobes scaled to a peak of ``azimuth_sidelobe_db`` (-13 for an untapered
  array, about -40 for a strong taper), out to ``azimuth_kernel_beams`` beams each side.
- **Elevation beam pattern**: ``elevation_pattern`` ``"gaussian"`` is
  ``exp(ln(10)/10 * edge_db * (e/A)^2)`` inside the half aperture ``A`` (the historical
  choice, ``edge_db = SonarConfig.elevation_edge_db``, -1 to -6 dB); ``"flat"`` is flat
  with a raised-cosine fall to ``edge_db`` over the outer ``elevation_rolloff_fraction``
  of the half aperture (0.1-0.5). Zero outside the aperture in both.
- **Seabed backscatter against incidence**: ``sigma = mu cos^n(theta)``, ``n =
  seabed_lambert_exponent`` (Lambert's law n = 2, the historical choice; 1-3 for sand to
  mud); a material's specular part (roughness < 1) as in :mod:`sim_harness.world.world`.
- **Target reflectivity against incidence**: ``target_roughness`` None keeps each
  material's roughness (diffuse 1 .. mirror-like 0); a number in [0, 1] sets every
  target's; its diffuse part falls as ``cos^n``, ``n = target_lambert_exponent`` (2), the
  specular lobe has gain ``specular_gain`` (10, 3-30) over the diffuse law at normal
  incidence and 1/e width ``specular_width_rad`` (12 deg, 4-20 deg).
- **Near-range blanking**: samples nearer than ``blank_range_m`` are zero (0-1 m).
- **Output**: ``output`` ``"uint8"`` (ARIS: 0-``display_range_db`` dB over 0-255, the
  historical choice with 80 dB), ``"uint16_amplitude"``/``"uint16_power"`` (linear
  amplitude or power, 65535 at ``full_scale_db`` dB of display power; None: an automatic
  gain puts full scale ``full_scale_headroom_db`` above the frame's 99.9th percentile
  power, as a sonar's auto range does), ``"float32_power"``/
  ``"float32_amplitude"`` (linear). ``saturation_db`` (None: off) caps the display power
  before the mapping, as a saturating receiver does; the integer outputs also saturate at
  their full scale.

Geometry (window, altitude, tilt), gain, TVG law (20, 30, 40 log R, with or without the
absorption, or off), pulse length and the noise floor stay in :class:`SonarConfig`; target
shapes, orientation and materials (low contrast: a material near the seabed's
backscatter) in the world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim_harness.world.errors import SonarConfigError

#: Output forms of a rendered image (see the module docstring).
OUTPUTS = ("uint8", "uint16_amplitude", "uint16_power", "float32_power", "float32_amplitude")
#: Azimuth patterns.
AZIMUTH_PATTERNS = ("kernel", "sinc")
#: Elevation patterns.
ELEVATION_PATTERNS = ("gaussian", "flat")
#: Peak side lobe of an untapered sinc^2 pattern, dB.
SINC2_SIDELOBE_DB = -13.26


@dataclass(frozen=True)
class SonarPhysics:
    """Physical modelling choices of the renderer (see the module docstring for each).

    Attributes
    ----------
    speckle_texture_shape : float
        Shape ``nu`` of the per-cell gamma texture (K-distributed power); ``inf``: none.
    azimuth_pattern : str
        ``"kernel"`` or ``"sinc"``.
    azimuth_width_beams : float
        -3 dB full width of the ``"sinc"`` pattern, beam spacings (> 0).
    azimuth_sidelobe_db : float
        Peak side lobe of the ``"sinc"`` pattern, dB (<= 0).
    azimuth_kernel_beams : int
        Beams each side the ``"sinc"`` kernel reaches (>= 1).
    elevation_pattern : str
        ``"gaussian"`` or ``"flat"``.
    elevation_rolloff_fraction : float
        Outer fraction of the half aperture over which ``"flat"`` falls to the edge level.
    seabed_lambert_exponent, target_lambert_exponent : float
        ``n`` of the ``cos^n`` diffuse laws (> 0).
    target_roughness : float or None
        Every target's roughness in [0, 1]; None: each material's.
    specular_gain : float
        Specular lobe over the diffuse law at normal incidence (>= 0).
    specular_width_rad : float
        1/e width of the specular lobe, rad (> 0).
    blank_range_m : float
        Samples nearer than this are zero, m (>= 0).
    output : str
        One of :data:`OUTPUTS`.
    display_range_db : float
        dB spanned by uint8 0-255 (> 0).
    full_scale_db : float or None
        Display power (dB) that maps to 65535 in the uint16 outputs; None: automatic.
    full_scale_headroom_db : float
        Automatic full scale above the frame's 99.9th percentile power, dB.
    saturation_db : float or None
        Display power cap, dB; None: no cap beyond the output's own.
    """

    speckle_texture_shape: float = math.inf
    azimuth_pattern: str = "kernel"
    azimuth_width_beams: float = 1.2
    azimuth_sidelobe_db: float = -25.0
    azimuth_kernel_beams: int = 8
    elevation_pattern: str = "gaussian"
    elevation_rolloff_fraction: float = 0.3
    seabed_lambert_exponent: float = 2.0
    target_lambert_exponent: float = 2.0
    target_roughness: float | None = None
    specular_gain: float = 10.0
    specular_width_rad: float = math.radians(12.0)
    blank_range_m: float = 0.0
    output: str = "uint8"
    display_range_db: float = 80.0
    full_scale_db: float | None = 80.0
    full_scale_headroom_db: float = 3.0
    saturation_db: float | None = None

    def __post_init__(self) -> None:
        if not (self.speckle_texture_shape > 0):
            raise SonarConfigError("must be > 0 (inf: no texture)", key="physics.speckle_texture_shape")
        for key, allowed in (("azimuth_pattern", AZIMUTH_PATTERNS), ("elevation_pattern", ELEVATION_PATTERNS),
                             ("output", OUTPUTS)):
            if getattr(self, key) not in allowed:
                raise SonarConfigError(f"must be one of {allowed}, got {getattr(self, key)!r}", key=f"physics.{key}")
        positive = ("azimuth_width_beams", "seabed_lambert_exponent", "target_lambert_exponent",
                    "specular_width_rad", "display_range_db")
        for key in positive:
            value = float(getattr(self, key))
            if not (math.isfinite(value) and value > 0):
                raise SonarConfigError(f"must be finite and > 0, got {value}", key=f"physics.{key}")
        for key in ("specular_gain", "blank_range_m"):
            value = float(getattr(self, key))
            if not (math.isfinite(value) and value >= 0):
                raise SonarConfigError(f"must be finite and >= 0, got {value}", key=f"physics.{key}")
        if not (math.isfinite(self.azimuth_sidelobe_db) and self.azimuth_sidelobe_db <= 0):
            raise SonarConfigError("must be finite and <= 0 dB", key="physics.azimuth_sidelobe_db")
        if int(self.azimuth_kernel_beams) != self.azimuth_kernel_beams or self.azimuth_kernel_beams < 1:
            raise SonarConfigError("must be an integer >= 1", key="physics.azimuth_kernel_beams")
        if not 0 < self.elevation_rolloff_fraction <= 1:
            raise SonarConfigError("must lie in (0, 1]", key="physics.elevation_rolloff_fraction")
        if self.target_roughness is not None and not 0 <= self.target_roughness <= 1:
            raise SonarConfigError("must lie in [0, 1] or be None", key="physics.target_roughness")
        if self.full_scale_db is not None and not math.isfinite(self.full_scale_db):
            raise SonarConfigError("must be finite or None", key="physics.full_scale_db")
        if not math.isfinite(self.full_scale_headroom_db):
            raise SonarConfigError("must be finite", key="physics.full_scale_headroom_db")
        if self.saturation_db is not None and not math.isfinite(self.saturation_db):
            raise SonarConfigError("must be finite or None", key="physics.saturation_db")

    @property
    def is_historical_seabed(self) -> bool:
        """Whether the seabed law is the historical one (Lambert, n = 2)."""
        return self.seabed_lambert_exponent == 2.0

    @property
    def is_historical_target(self) -> bool:
        """Whether the target law is the historical one (materials' roughness, n = 2, default lobe)."""
        return (self.target_roughness is None and self.target_lambert_exponent == 2.0
                and self.specular_gain == 10.0 and self.specular_width_rad == math.radians(12.0))


def sinc_kernel(physics: SonarPhysics) -> np.ndarray:
    """Leakage of a beam into its neighbours, shape (2 K + 1,), float32, 1 at the centre.

    The sinc^2 receive pattern sampled at whole beam spacings: ``x = 0.886 * offset / w``
    puts its -3 dB points at ``+-w/2``; beyond the first null (``|x| >= 1``) the pattern is
    scaled so that its first side lobe peaks at ``azimuth_sidelobe_db``.
    """
    k = int(physics.azimuth_kernel_beams)
    offsets = np.arange(-k, k + 1, dtype=np.float64)
    x = 0.886 * offsets / physics.azimuth_width_beams
    pattern = np.sinc(x) ** 2
    side = np.abs(x) >= 1.0
    pattern[side] *= 10.0 ** ((physics.azimuth_sidelobe_db - SINC2_SIDELOBE_DB) / 10.0)
    return (pattern / pattern[k]).astype(np.float32)


def elevation_gain(elevation_rad: np.ndarray, *, half_aperture_rad: float, edge_db: float,
                   physics: SonarPhysics) -> np.ndarray:
    """Two-way elevation pattern (power) at elevations inside the aperture, dtype of the input.

    ``"gaussian"``: ``exp(ln(10)/10 edge_db (e/A)^2)``; ``"flat"``: 1 out to ``(1 - f) A``,
    then a raised-cosine fall to ``10^(edge_db/10)`` at ``A``. Zero where ``|e| > A``.
    """
    e = np.asarray(elevation_rad)
    dt = e.dtype.type if e.dtype in (np.float32, np.float64) else np.float64
    u = np.abs(e) / dt(half_aperture_rad)
    edge = 10.0 ** (edge_db / 10.0)
    if physics.elevation_pattern == "gaussian":
        out = np.exp(dt(edge_db * math.log(10.0) / 10.0) * u * u)
    else:
        f = physics.elevation_rolloff_fraction
        s = np.clip((u - (1.0 - f)) / f, 0.0, 1.0)
        out = dt(1.0) - dt(1.0 - edge) * dt(0.5) * (dt(1.0) - np.cos(dt(math.pi) * s))
    return np.where(u <= 1.0, out, dt(0.0)).astype(dt)


def sigma_over_cos(cos_incidence: np.ndarray, roughness: np.ndarray | float, *, lambert_exponent: float,
                   specular_gain: float, specular_width_rad: float) -> np.ndarray:
    """``sigma(theta) / (mu cos(theta))`` of a surface, float64, for cosines of the incidence.

    ``sigma = mu (rough cos^n(theta) + (1 - rough) G exp(-(theta / W)^2))``, so this is
    ``rough cos^(n-1) + (1 - rough) G exp(-(theta/W)^2) / cos``; with n = 2, G = 10 and
    W = 12 deg it is the historical law of :mod:`sim_harness.world.world` (cosines clipped
    to [0, 1], the specular term's cosine floored at 1e-6).
    """
    c = np.clip(np.asarray(cos_incidence, dtype=np.float64), 0.0, 1.0)
    rough = np.asarray(roughness, dtype=np.float64)
    out = rough * np.power(c, lambert_exponent - 1.0)
    if np.any(rough < 1.0):
        theta = np.arccos(c)
        spec = specular_gain * np.exp(-((theta / specular_width_rad) ** 2)) / np.maximum(c, 1e-6)
        out = out + (1.0 - rough) * spec
    return np.asarray(out)
