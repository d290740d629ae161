"""The sonar renderer's settings and pose (:mod:`sim_harness.sonar.renderer`), validated once.

Units: metres, seconds, radians, dB; azimuth positive to starboard, tilt positive down.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from perception.sonar_io.beams import aris3000_128
from sim_harness.sonar.physics import SonarPhysics
from sim_harness.world.errors import PoseError, SonarConfigError
from sim_harness.world.world import World

FloatArray = np.ndarray


def default_beam_azimuths() -> tuple[float, ...]:
    """The ARIS 3000 128-beam azimuths (the SDK table), rad."""
    return tuple(float(a) for a in aris3000_128().azimuth_rad)


@dataclass(frozen=True)
class SonarPose:
    """Where the sonar is and how it points.

    ``depth_m`` is the SONAR's depth (positive down); heading clockwise from north, pitch
    positive nose up, roll positive starboard down (vehicle attitude, ArduPilot
    conventions); ``tilt_rad`` the mount depression, positive down. Radians throughout.
    """

    north_m: float
    east_m: float
    depth_m: float
    heading_rad: float = 0.0
    pitch_rad: float = 0.0
    roll_rad: float = 0.0
    tilt_rad: float = 0.0


@dataclass(frozen=True)
class SonarConfig:
    """Sonar parameters (ARIS Explorer 3000, 128 beams, by default).

    Attributes
    ----------
    beam_azimuth_rad : tuple of float
        Beam axis azimuths, strictly increasing, rad (default: the SDK's ARIS3000_128 table).
    beam_width_rad : tuple of float or None
        Azimuth width of each beam, rad; None: the SDK table's (default azimuths) or the
        beam spacing.
    elevation_aperture_rad : float
        Full vertical aperture, rad (14 deg).
    elevation_edge_db : float
        Beam pattern at the aperture edges relative to the axis, dB (<= 0).
    frequency_hz : float
        Carrier frequency (metadata; absorption is set directly).
    window_start_m, window_length_m : float
        Range window; sample i covers ``[start + i dr, start + (i+1) dr]``, ``dr =
        length / samples_per_beam``, and ``range_m`` holds the cell centres.
    samples_per_beam : int
    frame_rate_hz : float
        Ping rate (metadata for callers and the .aris writer).
    sound_speed_m_s : float
    pulse_length_s : float
        Transmit pulse; range blur FWHM ``c * pulse / 2``; 0 turns the blur off.
    absorption_db_per_m : float
        One-way absorption (about 2 dB/m at 3 MHz).
    gain_db : float
        Receiver gain from model power to display power (1 display unit = 0 dB).
    tvg_db_per_decade : float
        Time-varying gain ``tvg_db_per_decade * log10(r / 1 m)``; 0 turns it off.
    tvg_absorption : bool
        Whether the TVG also restores the two-way absorption.
    sidelobe_db : tuple of float
        Leakage into beams 1, 2, ... columns away, dB; empty for none.
    speckle_looks : float
        Looks of the gamma speckle (mean 1, CV ``1/sqrt(looks)``); 0 turns speckle off. The
        default, 1 (fully developed speckle), gives the grain of the real ARIS recording in
        ``tests/data/aris/sample.aris`` (local CV of the uint8 samples ~0.15).
    noise_floor_db : float or None
        Mean display power of the additive noise, dB; None for no noise.
    target_ray_step_rad : float
        Elevation step of the rays cast at targets (their occlusion edges are refined to
        1/32 of it; their echo is spread between neighbouring rays, so no cell is missed).
    seed : int
    fill_altitude : bool
        Whether frames report the (true) altitude as an altimeter would.
    noise_bank_size : int
        Variates in each seeded noise bank (>= 2 x samples x beams).
    physics : SonarPhysics
        The other physical choices (speckle texture, beam patterns, backscatter laws,
        blanking, output form); the default is the historical renderer.
    """

    beam_azimuth_rad: tuple[float, ...] = field(default_factory=default_beam_azimuths)
    beam_width_rad: tuple[float, ...] | None = None
    elevation_aperture_rad: float = math.radians(14.0)
    elevation_edge_db: float = -3.0
    frequency_hz: float = 3.0e6
    window_start_m: float = 0.7
    window_length_m: float = 2.3
    samples_per_beam: int = 1000
    frame_rate_hz: float = 10.0
    sound_speed_m_s: float = 1480.0
    pulse_length_s: float = 8e-6
    absorption_db_per_m: float = 2.0
    gain_db: float = 127.0
    tvg_db_per_decade: float = 30.0
    tvg_absorption: bool = True
    sidelobe_db: tuple[float, ...] = (-20.0, -27.0, -33.0)
    speckle_looks: float = 1.0
    noise_floor_db: float | None = 12.0
    target_ray_step_rad: float = math.radians(0.08)
    seed: int = 0
    fill_altitude: bool = True
    noise_bank_size: int = 1 << 21
    physics: SonarPhysics = field(default_factory=SonarPhysics)

    def __post_init__(self) -> None:
        az = np.asarray(self.beam_azimuth_rad, dtype=np.float64)
        if az.ndim != 1 or az.size < 2 or not np.all(np.isfinite(az)) or not np.all(np.diff(az) > 0):
            raise SonarConfigError("must be >= 2 finite, strictly increasing azimuths", key="beam_azimuth_rad")
        if np.any(np.abs(az) >= math.pi / 2):
            raise SonarConfigError("azimuths must lie within (-90, 90) deg", key="beam_azimuth_rad")
        if self.beam_width_rad is not None:
            w = np.asarray(self.beam_width_rad, dtype=np.float64)
            if w.shape != az.shape or not np.all(w > 0):
                raise SonarConfigError("must be one positive width per beam", key="beam_width_rad")
        checks = {
            "elevation_aperture_rad": (0.0, math.pi, False),
            "window_start_m": (0.0, math.inf, True),
            "window_length_m": (0.0, math.inf, False),
            "frame_rate_hz": (0.0, math.inf, False),
            "frequency_hz": (0.0, math.inf, False),
            "sound_speed_m_s": (1300.0, 1700.0, True),
            "pulse_length_s": (0.0, 1e-3, True),
            "absorption_db_per_m": (0.0, 100.0, True),
            "target_ray_step_rad": (0.0, math.radians(1.0), False),
        }
        for key, (lo, hi, closed) in checks.items():
            v = float(getattr(self, key))
            ok = math.isfinite(v) and (lo <= v if closed else lo < v) and v < hi
            if not ok:
                raise SonarConfigError(f"must be finite and in {'[' if closed else '('}{lo}, {hi}), got {v}", key=key)
        for key in ("gain_db", "tvg_db_per_decade", "elevation_edge_db"):
            if not math.isfinite(float(getattr(self, key))):
                raise SonarConfigError("must be finite", key=key)
        if self.elevation_edge_db > 0:
            raise SonarConfigError("must be <= 0 dB", key="elevation_edge_db")
        if int(self.samples_per_beam) != self.samples_per_beam or self.samples_per_beam < 2:
            raise SonarConfigError("must be an integer >= 2", key="samples_per_beam")
        if not (math.isfinite(self.speckle_looks) and self.speckle_looks >= 0):
            raise SonarConfigError("must be >= 0 (0 = no speckle)", key="speckle_looks")
        if self.noise_floor_db is not None and not math.isfinite(self.noise_floor_db):
            raise SonarConfigError("must be finite or None", key="noise_floor_db")
        if any(not (math.isfinite(v) and v <= 0) for v in self.sidelobe_db):
            raise SonarConfigError("side lobes must be finite and <= 0 dB", key="sidelobe_db")
        if self.noise_bank_size < 2 * self.samples_per_beam * az.size:
            raise SonarConfigError("must be >= 2 x samples_per_beam x beams", key="noise_bank_size")
        if not isinstance(self.physics, SonarPhysics):
            raise SonarConfigError(f"must be a SonarPhysics, got {type(self.physics).__name__}", key="physics")

    @property
    def n_beams(self) -> int:
        """Number of beams."""
        return len(self.beam_azimuth_rad)

    @property
    def range_resolution_m(self) -> float:
        """Range cell size, m."""
        return self.window_length_m / self.samples_per_beam

    @property
    def range_m(self) -> FloatArray:
        """Range cell centres, shape (samples_per_beam,), m."""
        return self.window_start_m + (np.arange(self.samples_per_beam) + 0.5) * self.range_resolution_m

    @property
    def window_end_m(self) -> float:
        """Far end of the range window, m."""
        return self.window_start_m + self.window_length_m

    def with_range_grid(self, range_m: FloatArray) -> SonarConfig:
        """A copy whose cell centres are the evenly spaced ``range_m`` (e.g. an ARIS grid)."""
        r = np.asarray(range_m, dtype=np.float64)
        if r.ndim != 1 or r.size < 2 or not np.all(np.diff(r) > 0):
            raise SonarConfigError("must be an increasing 1-D grid", key="range_m")
        dr = float(r[-1] - r[0]) / (r.size - 1)
        return replace(self, window_start_m=float(r[0]) - dr / 2, window_length_m=dr * r.size,
                       samples_per_beam=int(r.size))


def validate_pose(world: World, pose: SonarPose) -> float:
    """Raise :class:`PoseError` for a pose the renderer cannot use; else return the seabed's
    depth (with relief) under the sonar, m."""
    for name in ("north_m", "east_m", "depth_m", "heading_rad", "pitch_rad", "roll_rad", "tilt_rad"):
        if not math.isfinite(float(getattr(pose, name))):
            raise PoseError(f"must be finite, got {getattr(pose, name)!r}", field=name)
    if pose.depth_m < 0:
        raise PoseError(f"sonar is above the water surface (depth {pose.depth_m} m)", field="depth_m")
    for name in ("pitch_rad", "roll_rad", "tilt_rad"):
        if abs(getattr(pose, name)) > math.pi / 2:
            raise PoseError(f"must lie within +-90 deg, got {math.degrees(getattr(pose, name)):.1f} deg", field=name)
    seabed = world.seabed_depth_m(pose.north_m, pose.east_m)
    if seabed - pose.depth_m <= 0:
        raise PoseError(
            f"sonar at depth {pose.depth_m} m is at or below the seabed ({seabed:.3f} m) at "
            f"north {pose.north_m} m, east {pose.east_m} m",
            field="depth_m",
        )
    return float(seabed)
