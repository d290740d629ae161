"""Small exact synthetic sonar frames for the perception tests (boxes on a flat seabed).

Geometry (flat seabed, sonar ``altitude_m`` above it, beam axis depressed ``tilt_rad``):
a seabed point seen in beam azimuth ``a`` at slant range ``r`` lies at ground distance
``g = sqrt(r^2 - H^2)`` along azimuth ``a``. A box (near edge ``x0_m`` along the azimuth
0 axis, length ``length_m``, cross-range centre ``y_m`` and width ``width_m``, height
``height_m``) is crossed by the ground track of beam ``a`` over ``[g_in, g_out]``. Its top
returns over slant ``[hypot(g_in, H-h), hypot(g_out, H-h)]``, its front face over
``[hypot(g_in, H-h), hypot(g_in, H)]``, and the seabed is hidden over
``[hypot(g_in, H), hypot(g_s, H)]`` with ``g_s = g_out H / (H - h)`` (the ray through the
far top edge). So the shadow runs from ``r_top = hypot(g_out, H - h)`` to
``r_end = hypot(g_s, H) = r_top H / (H - h)``.

Each pixel integrates its range cell exactly (area sampling); the power is blurred a
little in range and azimuth, multiplied by gamma speckle (``looks``), floored by noise and
mapped to uint8 as ARIS does (0-80 dB over 0-255).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from perception.sonar_io.frame import SonarFrame

LABEL_OUTSIDE = 0
LABEL_SEABED = 2
LABEL_HIGHLIGHT = 3
LABEL_SHADOW = 4


@dataclass(frozen=True)
class Box:
    x0_m: float
    y_m: float
    length_m: float
    width_m: float
    height_m: float


@dataclass(frozen=True)
class SynthConfig:
    altitude_m: float = 0.5
    tilt_deg: float = 20.0
    aperture_deg: float = 14.0
    window_m: tuple[float, float] = (0.9, 2.6)
    n_samples: int = 800
    n_beams: int = 128
    fov_deg: float = 30.0
    seabed_level: float = 1e5
    top_level: float = 3e6
    face_level: float = 6e6
    noise_level: float = 10.0
    speckle_looks: float = 4.0
    blur_samples: float = 0.8
    blur_beams: float = 0.6
    boxes: tuple[Box, ...] = field(default_factory=tuple)


@dataclass(frozen=True)
class BoxTruth:
    box: Box
    azimuth_rad: float
    r_top_m: float
    r_end_m: float
    in_band: bool


def _overlap(lo: np.ndarray, hi: np.ndarray, a: float, b: float) -> np.ndarray:
    return np.clip(np.minimum(hi, b) - np.maximum(lo, a), 0.0, None)


def _track_interval(box: Box, azimuth: float) -> tuple[float, float] | None:
    """Ground distances [g_in, g_out] where beam azimuth's ground track crosses the box."""
    c, s = math.cos(azimuth), math.sin(azimuth)
    lo, hi = 0.0, math.inf
    for origin_lo, origin_hi, d in (
        (box.x0_m, box.x0_m + box.length_m, c),
        (box.y_m - box.width_m / 2, box.y_m + box.width_m / 2, s),
    ):
        if abs(d) < 1e-12:
            if not origin_lo <= 0 <= origin_hi:
                return None
            continue
        a, b = origin_lo / d, origin_hi / d
        lo, hi = max(lo, min(a, b)), min(hi, max(a, b))
    return (lo, hi) if hi > lo else None


def edges_at(box: Box, azimuth_rad: float, altitude_m: float) -> tuple[float, float] | None:
    """Exact (r_top, r_end) of a box's shadow in the beam at ``azimuth_rad``; None if missed."""
    track = _track_interval(box, azimuth_rad)
    if track is None:
        return None
    r_top = math.hypot(track[1], altitude_m - box.height_m)
    return r_top, r_top * altitude_m / (altitude_m - box.height_m)


def render(
    config: SynthConfig, *, rng: np.random.Generator, timestamp_s: float = 0.0
) -> tuple[SonarFrame, np.ndarray, list[BoxTruth]]:
    """A uint8 frame, its label image (codes above) and per-box truth."""
    cfg = config
    H = cfg.altitude_m
    ranges = np.linspace(cfg.window_m[0], cfg.window_m[1], cfg.n_samples)
    dr = ranges[1] - ranges[0]
    lo_edges, hi_edges = ranges - dr / 2, ranges + dr / 2
    half_fov = math.radians(cfg.fov_deg) / 2
    azimuths = np.linspace(-half_fov, half_fov, cfg.n_beams)
    tilt = math.radians(cfg.tilt_deg)
    half_ap = math.radians(cfg.aperture_deg) / 2
    # Seabed weight per range (same for every beam): inside the vertical aperture.
    with np.errstate(invalid="ignore"):
        depression = np.arcsin(np.clip(H / ranges, -1, 1))
    depression[ranges < H] = np.nan
    band = np.nan_to_num(np.clip((half_ap - np.abs(depression - tilt)) / math.radians(0.3) + 0.5, 0, 1))
    scatter = np.zeros((cfg.n_samples, cfg.n_beams))
    labels = np.where(band[:, None] > 0.5, LABEL_SEABED, LABEL_OUTSIDE) * np.ones(
        (1, cfg.n_beams), dtype=np.uint8
    )
    labels = labels.astype(np.uint8)
    truths: list[BoxTruth] = []
    for j, a in enumerate(azimuths):
        seabed = np.ones(cfg.n_samples)
        target = np.zeros(cfg.n_samples)
        for box in cfg.boxes:
            track = _track_interval(box, float(a))
            if track is None:
                continue
            g_in, g_out = track
            h = box.height_m
            r_near_top = math.hypot(g_in, H - h)
            r_top = math.hypot(g_out, H - h)
            r_face_end = math.hypot(g_in, H)
            g_s = g_out * H / (H - h)
            r_end = math.hypot(g_s, H)
            seabed -= _overlap(lo_edges, hi_edges, r_face_end, r_end) / dr
            target += cfg.top_level * _overlap(lo_edges, hi_edges, r_near_top, r_top) / dr
            target += cfg.face_level * _overlap(lo_edges, hi_edges, r_near_top, r_face_end) / dr
            hl = (ranges >= r_near_top) & (ranges <= r_top)
            sh = (ranges > r_top) & (ranges < r_end) & (band > 0.5)
            labels[sh, j] = LABEL_SHADOW
            labels[hl, j] = LABEL_HIGHLIGHT
        scatter[:, j] = np.clip(seabed, 0, 1) * band * cfg.seabed_level + target
    power = cv2.GaussianBlur(
        scatter.astype(np.float32), (0, 0), sigmaX=cfg.blur_beams, sigmaY=cfg.blur_samples
    ).astype(np.float64)
    if cfg.speckle_looks > 0:
        power = power * rng.gamma(cfg.speckle_looks, 1.0 / cfg.speckle_looks, power.shape)
    power = power + cfg.noise_level * rng.exponential(1.0, power.shape)
    image = np.clip(np.round(10 * np.log10(power) * 255 / 80), 0, 255).astype(np.uint8)
    for box in cfg.boxes:
        az = math.atan2(box.y_m, box.x0_m + box.length_m)
        track = _track_interval(box, az)
        assert track is not None
        h = box.height_m
        r_top = math.hypot(track[1], H - h)
        r_end = r_top * H / (H - h)
        in_band = bool(
            np.interp(r_end, ranges, band) > 0.99
            and np.interp(r_top, ranges, band) > 0.99
            and r_end < ranges[-1]
        )
        truths.append(BoxTruth(box, az, r_top, r_end, in_band))
    frame = SonarFrame(
        image=image,
        range_m=ranges,
        beam_azimuth_rad=azimuths,
        elevation_aperture_rad=2 * half_ap,
        timestamp_s=timestamp_s,
        altitude_m=H,
        tilt_rad=tilt,
    )
    return frame, labels, truths
