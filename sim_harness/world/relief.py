"""Gentle seabed relief: a seeded sum of a few long, low sinusoids, heights positive up
(local NED metres, see :mod:`perception.geometry`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sim_harness.world.errors import WorldError, finite

FloatArray = NDArray[np.float64]

#: Steepest relief slope accepted as "gentle" (rise over run).
MAX_RELIEF_SLOPE = 0.25


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
        amp = finite(self.amplitude_m, "seabed.relief.amplitude_m", nonneg=True)
        wl = finite(self.wavelength_m, "seabed.relief.wavelength_m", positive=True)
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
        if isinstance(north_m, (float, int, np.floating)) and isinstance(east_m, (float, int, np.floating)):
            return np.float64(self.height_at_m(float(north_m), float(east_m)))
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

    def height_at_m(self, north_m: float, east_m: float) -> float:
        """:meth:`height_m` at one point, the same number bit for bit: the same float64
        operations in the same order (one cosine call over the components, their sum in
        component order), without the array machinery (the simulator asks at every step)."""
        arg = self._k[:, 0] * north_m
        arg += self._k[:, 1] * east_m
        arg += self._phase
        np.cos(arg, out=arg)
        arg *= self._a
        terms = arg.tolist()
        total = terms[0] + 0.0
        for term in terms[1:]:
            total += term
        return total

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
