"""Seabed and target materials: backscatter strength and roughness, and their scattering.

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
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sim_harness.world.errors import WorldError, finite

#: Gain of the specular lobe of a smooth material over Lambert's law at normal incidence.
SPECULAR_GAIN = 10.0
#: Angular width (1/e) of the specular lobe, rad.
SPECULAR_WIDTH_RAD = math.radians(12.0)


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
        finite(self.backscatter_db, f"materials.{self.name}.backscatter_db")
        r = finite(self.roughness, f"materials.{self.name}.roughness")
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
