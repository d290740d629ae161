"""The reference (first frame's) altitude when the frames give only altitude changes.

Two sources, combined by :func:`shared_reference_altitude`: every target's own solve of
Eq. 2 over its altitudes (poorly conditioned, ``H^2 / dH``, but independent between
targets), and each frame's seabed onset (where the steepest ray of the vertical aperture
meets the seabed, :mod:`perception.navigation.seabed_start`), which fixes it to about 1 %.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from perception.errors import SolverError
from perception.heights.config import HeightsConfig
from perception.heights.models import OnsetAltitude, inverse_variance_mean
from perception.heights.target_solve import TargetSolver
from perception.tracking.tracker import Track


def onset_reference_altitude(onsets: Sequence[OnsetAltitude]) -> tuple[float, float] | None:
    """The first frame's altitude and its 1-sigma from the seabed onsets, m.

    Each frame with an onset gives ``altitude_i - dH_i``; their mean has the range
    noise averaged over the frames and the common (tilt, beam-edge model) error in
    full. None when no frame gave an onset.
    """
    if not onsets:
        return None
    refs = np.array([o.altitude_m - o.delta_h_m for o in onsets])
    noise = np.array([o.noise_std_m for o in onsets])
    common = float(np.mean([o.common_std_m for o in onsets]))
    mean = float(np.mean(refs))
    scatter = float(np.std(refs, ddof=1)) if refs.size > 1 else 0.0
    noise_std = max(float(np.sqrt(np.mean(noise**2))), scatter) / math.sqrt(refs.size)
    return mean, math.hypot(common, noise_std)


def shared_reference_altitude(
    tracks: Sequence[Track], solver: TargetSolver, onsets: Sequence[OnsetAltitude], config: HeightsConfig
) -> tuple[float, float] | None:
    """The first frame's altitude and its 1-sigma, m, solved from all targets together.

    Each target seen at two or more altitudes without absolute altitudes gives its own
    reference altitude (:func:`solve_height`); their inverse-variance mean, after
    dropping those more than 3 sigma from the median, is the shadows' estimate (needs
    two targets). This is the joint least-squares solution of one common altitude
    with every target's height free. The seabed onset's estimate
    (:func:`onset_reference_altitude`, when ``config.seabed_onset_altitude``) leads
    when there is one: a target's own altitude is poorly conditioned and carries the
    edges' systematic errors that its sigma does not hold (on the second forward model
    most targets' own altitudes disagree with a right onset by more than 3 of their
    sigmas), so only targets about as sure as the onset (sigma at most twice the
    onset's) that agree with it (within 3 combined sigma) join it. The onset trusts the
    frames' tilt: a tilt error moves it (``seabed_onset_altitude=False`` then keeps the
    shadows' own estimate). None when neither source gives an estimate.
    """
    values, sigmas = [], []
    for track in tracks:
        usable = [d for d in track.detections if d.measurement.usable]
        if len(usable) < max(2, config.min_frames):
            continue
        if all(math.isfinite(d.altitude_m) for d in usable):
            continue
        try:
            estimate = solver.height_of(usable, None)
            bias = solver.edge_bias(usable, None)
        except SolverError:
            continue
        if math.isfinite(estimate.ref_altitude_m) and estimate.ref_altitude_std_m > 0:
            values.append(estimate.ref_altitude_m)
            sigmas.append(math.hypot(estimate.ref_altitude_std_m, bias.ref_altitude_std_m))
    h0, sig = np.array(values), np.array(sigmas)
    onset = onset_reference_altitude(onsets) if config.seabed_onset_altitude else None
    if onset is not None:
        # The onset is well conditioned, a target's own H0 is not (Eq. 2's H^2 / dH, and
        # the edges' systematic errors that its sigma does not hold): only targets whose
        # own H0 is about as sure as the onset's, and agrees with it, join it.
        join = (np.abs(h0 - onset[0]) <= 3 * np.hypot(sig, onset[1])) & (sig <= 2.0 * onset[1])
        return inverse_variance_mean(np.append(h0[join], onset[0]), np.append(sig[join], onset[1]))
    if h0.size < 2:
        return None
    keep = np.abs(h0 - np.median(h0)) <= 3 * np.maximum(sig, 1e-6)
    if np.count_nonzero(keep) < 2:
        return None
    return inverse_variance_mean(h0[keep], sig[keep])
