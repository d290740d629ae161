"""The renderer's receiver: speckle, texture and noise, blanking, and the output image.

Part of :mod:`sim_harness.sonar.renderer` (see its step 5 and 6). Display power is linear
with 1 = 0 dB. Determinism: the random variates come from seeded banks drawn once per
renderer; a frame picks its offsets into them from ``(seed, timestamp bits)``, so the same
config, pose and timestamp give the identical frame in any call order.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from sim_harness.sonar.physics import SonarPhysics
from sim_harness.sonar.seabed import constant_f32

#: Largest value of the uint16 outputs.
UINT16_FULL_SCALE = 65535.0


def power_to_uint8(power: np.ndarray, *, display_range_db: float = 80.0) -> np.ndarray:
    """Display power (linear, 1 = 0 dB) to ARIS sample values: 0-80 dB -> 0-255, saturating.

    ``round(10 log10(power) * 255 / display_range_db)`` clipped to [0, 255]; powers below 1
    give 0 (``display_range_db`` 80 is the ARIS SDK's mapping).
    """
    p = np.asarray(power, dtype=np.float32)
    log = cv2.log(np.maximum(p, constant_f32(1.0, p.shape)))
    scale = 10.0 / math.log(10.0) * 255.0 / display_range_db
    return np.asarray(cv2.convertScaleAbs(log, alpha=scale), dtype=np.uint8)


def power_to_image(power: np.ndarray, physics: SonarPhysics) -> np.ndarray:
    """The output image of ``physics.output`` from display power (see :mod:`sim_harness.sonar.physics`).

    ``saturation_db`` caps the power first; uint16 outputs put ``full_scale_db`` (or the
    automatic full scale) at 65535
    (amplitude: ``65535 sqrt(p / p_fs)``, power: ``65535 p / p_fs``), rounded and clipped.
    """
    p = np.asarray(power, dtype=np.float32)
    if physics.saturation_db is not None:
        p = np.minimum(p, np.float32(10.0 ** (physics.saturation_db / 10.0)))
    if physics.output == "uint8":
        return power_to_uint8(p, display_range_db=physics.display_range_db)
    if physics.full_scale_db is None:
        top = float(np.percentile(p, 99.9)) if p.size else 1.0
        full = max(top, 1e-12) * 10.0 ** (physics.full_scale_headroom_db / 10.0)
    else:
        full = 10.0 ** (physics.full_scale_db / 10.0)
    if physics.output == "uint16_amplitude":
        value = UINT16_FULL_SCALE * np.sqrt(p.astype(np.float64) / full)
    elif physics.output == "uint16_power":
        value = UINT16_FULL_SCALE * (p.astype(np.float64) / full)
    elif physics.output == "float32_power":
        return np.ascontiguousarray(p, dtype=np.float32)
    else:  # float32_amplitude
        return np.sqrt(p).astype(np.float32)
    return np.clip(np.rint(value), 0, UINT16_FULL_SCALE).astype(np.uint16)


class NoiseBanks:
    """Seeded banks of speckle, texture and noise variates (see the module docstring).

    Parameters
    ----------
    seed : int
    size : int
        Variates per bank (>= 2 x the pixels of a frame).
    speckle_looks : float
        Looks of the gamma speckle (mean 1); 0: none.
    texture_shape : float
        Shape of the per-cell gamma texture (mean 1, K-distributed power); inf: none.
    noise_mean : float
        Mean display power of the additive exponential noise; 0: none.
    """

    def __init__(self, *, seed: int, size: int, speckle_looks: float, texture_shape: float, noise_mean: float):
        self.seed = int(seed)
        self.size = int(size)
        bank_rng = np.random.default_rng([self.seed, 0x5EED])
        if speckle_looks > 0:
            looks = float(speckle_looks)
            self._speckle = bank_rng.standard_gamma(looks, self.size, dtype=np.float32) / np.float32(looks)
        else:
            self._speckle = np.ones(0, dtype=np.float32)
        # the mean folded in once (the same float32 product a frame would take of its slice)
        self._noise_mean = float(noise_mean)
        self._noise = np.float32(self._noise_mean) * bank_rng.standard_exponential(self.size, dtype=np.float32)
        if math.isfinite(texture_shape):
            nu = float(texture_shape)
            self._texture = bank_rng.standard_gamma(nu, self.size, dtype=np.float32) / np.float32(nu)
        else:
            self._texture = np.ones(0, dtype=np.float32)

    def apply(self, clean: np.ndarray, timestamp_s: float) -> np.ndarray:
        """``clean`` x speckle x texture + noise, a new float32 array (``clean`` is kept)."""
        size = clean.size
        bits = int(np.array([timestamp_s], dtype=np.float64).view(np.uint64)[0])
        rng = np.random.default_rng([self.seed, bits])
        n = self.size
        if self._speckle.size:  # a new array either way: ``clean`` is kept as a layer
            o = int(rng.integers(0, n - size + 1))
            out = np.multiply(clean, self._speckle[o:o + size].reshape(clean.shape), dtype=np.float32)
        else:
            out = np.array(clean, dtype=np.float32)
        if self._noise_mean > 0:
            o = int(rng.integers(0, n - size + 1))
            noise = self._noise[o:o + size].reshape(clean.shape)  # mean x exponential
        else:
            noise = None
        if self._texture.size:
            o = int(rng.integers(0, n - size + 1))
            out *= self._texture[o:o + size].reshape(clean.shape)
        if noise is not None:
            out += noise
        return out


def blank_near_rows(power: np.ndarray, range_m: np.ndarray, blank_range_m: float) -> np.ndarray:
    """``power`` with the rows nearer than ``blank_range_m`` set to zero (in place; returned)."""
    if blank_range_m > 0:
        rows = int(np.searchsorted(range_m, blank_range_m))
        power[:rows] = 0.0
    return power
