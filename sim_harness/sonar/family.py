"""Members of the renderer's model family: named presets and random draws from realistic ranges.

A member is a set of changes to :class:`~sim_harness.sonar.renderer.SonarConfig` (gain, TVG
law, speckle looks, noise floor, pulse, side lobes, elevation edge) and a
:class:`~sim_harness.sonar.physics.SonarPhysics`. Tests and benchmarks render the same
scenes through several members so that perception is checked against a family of forward
models, not one. The ranges (see :mod:`sim_harness.sonar.physics` for the physics fields):

=========================  ==========================================================
speckle looks              1, 2, 4, 8 (1: fully developed, Rayleigh amplitude)
K texture shape nu         inf (none) or 1-20, log-uniform (small: heavy tails)
noise floor                none, or 0-25 dB display power
TVG                        off, 20, 30 or 40 log R, with or without the absorption
gain                       -6 .. +12 dB about the historical 127 dB (saturates targets; lower
                           gains sink a long window's far seabed into the noise floor)
pulse                      4-16 us (range blur 3-12 mm FWHM)
azimuth pattern            the historical kernel, or sinc^2 of width 0.8-1.6 beams with
                           peak side lobes -13 .. -40 dB
elevation pattern          Gaussian or flat with raised-cosine edges, edge -1 .. -6 dB
seabed law                 cos^n, n 1-3
targets                    each material's roughness, or all 0.05-1 (specular to
                           diffuse), lobe gain 3-30, width 4-20 deg
near blanking              0, or the window's first 5-25 %
output                     uint8 (ARIS 0-80 dB, or 60-100 dB), uint16 amplitude or
                           power (automatic full scale 0-6 dB above the brightest
                           echo's 99.9th percentile), float32 power
=========================  ==========================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from sim_harness.sonar.physics import SonarPhysics
from sim_harness.sonar.renderer import SonarConfig

#: Historical receiver gain of :class:`SonarConfig`, dB.
BASE_GAIN_DB = SonarConfig().gain_db


@dataclass(frozen=True)
class FamilyMember:
    """One forward model of the family.

    Attributes
    ----------
    name : str
        What sets it apart (for tables).
    config_changes : dict
        :class:`SonarConfig` fields to replace (not the window, which belongs to the scene).
    physics : SonarPhysics
    blank_fraction : float
        Near-range blanking of the window's first ``blank_fraction`` (0: none); it
        overrides ``physics.blank_range_m`` when > 0.
    """

    name: str
    config_changes: dict[str, Any] = field(default_factory=dict)
    physics: SonarPhysics = field(default_factory=SonarPhysics)
    blank_fraction: float = 0.0

    def config(self, base: SonarConfig) -> SonarConfig:
        """``base`` (its window, seed, beams) with this member's physics."""
        physics = self.physics
        if self.blank_fraction > 0:
            blank = base.window_start_m + self.blank_fraction * base.window_length_m
            physics = replace(physics, blank_range_m=blank)
        return replace(base, **self.config_changes, physics=physics)


def presets() -> tuple[FamilyMember, ...]:
    """Named members, one departure from the historical renderer each (plus the historical one)."""
    p = SonarPhysics
    return (
        FamilyMember("historical renderer"),
        FamilyMember("4 looks", {"speckle_looks": 4.0}),
        FamilyMember("K-distributed speckle (nu = 1.5)", physics=p(speckle_texture_shape=1.5)),
        FamilyMember("TVG off", {"tvg_db_per_decade": 0.0, "tvg_absorption": False}),
        FamilyMember("20 log R TVG, no absorption", {"tvg_db_per_decade": 20.0, "tvg_absorption": False}),
        FamilyMember("40 log R TVG", {"tvg_db_per_decade": 40.0}),
        FamilyMember("gain +12 dB (saturates)", {"gain_db": BASE_GAIN_DB + 12.0}),
        FamilyMember("gain -10 dB, noise floor 20 dB", {"gain_db": BASE_GAIN_DB - 10.0, "noise_floor_db": 20.0}),
        FamilyMember("sinc^2 beams, 1.5 wide, -13 dB side lobes",
                     physics=p(azimuth_pattern="sinc", azimuth_width_beams=1.5, azimuth_sidelobe_db=-13.3)),
        FamilyMember("flat elevation pattern, -6 dB edges", {"elevation_edge_db": -6.0},
                     physics=p(elevation_pattern="flat", elevation_rolloff_fraction=0.4)),
        FamilyMember("seabed cos^1 (mud-like)", physics=p(seabed_lambert_exponent=1.0)),
        FamilyMember("seabed cos^3", physics=p(seabed_lambert_exponent=3.0)),
        FamilyMember("specular targets", physics=p(target_roughness=0.1, specular_gain=25.0,
                                                   specular_width_rad=math.radians(6.0))),
        FamilyMember("long pulse (16 us)", {"pulse_length_s": 16e-6}),
        FamilyMember("near-range blanking (window's first 20 %)", blank_fraction=0.2),
        FamilyMember("uint16 amplitude", physics=p(output="uint16_amplitude", full_scale_db=None)),
        FamilyMember("uint16 power", physics=p(output="uint16_power", full_scale_db=None)),
        FamilyMember("float32 power", physics=p(output="float32_power")),
    )


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def draw_member(rng: np.random.Generator) -> FamilyMember:
    """A random member: every choice drawn from its range (module docstring)."""
    changes: dict[str, Any] = {
        "speckle_looks": float(rng.choice([1.0, 1.0, 2.0, 4.0, 8.0])),
        "noise_floor_db": None if rng.random() < 0.15 else float(rng.uniform(0.0, 25.0)),
        "gain_db": BASE_GAIN_DB + float(rng.uniform(-6.0, 12.0)),
        "pulse_length_s": float(rng.uniform(4e-6, 16e-6)),
        "elevation_edge_db": float(rng.uniform(-6.0, -1.0)),
    }
    tvg = rng.choice(["off", "20", "30", "40"])
    changes["tvg_db_per_decade"] = 0.0 if tvg == "off" else float(tvg)
    changes["tvg_absorption"] = bool(tvg != "off" and rng.random() < 0.7)
    sinc = rng.random() < 0.6
    if not sinc:
        first = float(rng.uniform(-26.0, -14.0))
        changes["sidelobe_db"] = (first, first - 7.0, first - 13.0)
    rough = None if rng.random() < 0.5 else float(rng.uniform(0.05, 1.0))
    output = str(rng.choice(["uint8", "uint8", "uint16_amplitude", "uint16_power", "float32_power"]))
    physics = SonarPhysics(
        speckle_texture_shape=math.inf if rng.random() < 0.5 else _log_uniform(rng, 1.0, 20.0),
        azimuth_pattern="sinc" if sinc else "kernel",
        azimuth_width_beams=float(rng.uniform(0.8, 1.6)),
        azimuth_sidelobe_db=float(rng.uniform(-40.0, -13.3)),
        elevation_pattern=str(rng.choice(["gaussian", "flat"])),
        elevation_rolloff_fraction=float(rng.uniform(0.1, 0.5)),
        seabed_lambert_exponent=float(rng.uniform(1.0, 3.0)),
        target_roughness=rough,
        specular_gain=float(rng.uniform(3.0, 30.0)),
        specular_width_rad=math.radians(float(rng.uniform(4.0, 20.0))),
        output=output,
        display_range_db=80.0 if rng.random() < 0.7 else float(rng.uniform(60.0, 100.0)),
        full_scale_db=None,
        full_scale_headroom_db=float(rng.uniform(0.0, 6.0)),
    )
    blank = 0.0 if rng.random() < 0.6 else float(rng.uniform(0.05, 0.25))
    parts = [f"looks {changes['speckle_looks']:g}", f"TVG {tvg}", f"gain {changes['gain_db'] - BASE_GAIN_DB:+.0f} dB",
             "sinc" if sinc else "kernel", physics.elevation_pattern, output]
    if math.isfinite(physics.speckle_texture_shape):
        parts.append(f"K nu {physics.speckle_texture_shape:.1f}")
    return FamilyMember("random: " + ", ".join(parts), changes, physics, blank)
