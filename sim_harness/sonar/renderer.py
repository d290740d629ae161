"""Forward-looking sonar renderer: polar frames of a :class:`~sim_harness.world.world.World`.

Defaults are an ARIS Explorer 3000 in its 128-beam mode (SDK beam table, 14 deg vertical
aperture, 3 MHz, window 0.7-3.0 m with 1000 samples); any other forward-looking sonar is
set by :class:`SonarConfig`.

Pipeline per frame (geometry in :mod:`sim_harness.sonar.geometry`, the seabed in
:mod:`sim_harness.sonar.seabed`, target rays in :mod:`sim_harness.sonar.target_rays`, their echo
and truth in :mod:`sim_harness.sonar.targets`):

1. the seabed's echo per (range cell, beam), analytic: the exact elevation interval of
   each cell's seabed, weighted by the elevation beam pattern
   ``exp(ln(10)/10 * edge_db * (e/A)^2)`` (``edge_db`` at the aperture edge ``A``, zero
   outside), the material's scattering at the incidence angle, the footprint and 1/r^2,
   times the seabed's persistent reflectivity texture at the cell's ground point when the
   world has one (:mod:`sim_harness.world.texture`; fixed in north/east, so it stays put
   from ping to ping while the speckle of step 5 does not);
2. targets: beam-axis rays on a fine elevation grid; the nearest hit wins, so the seabed
   inside each occluded (edge-refined) elevation interval is removed -- shadows come from
   occlusion -- and target hits add echo at their ranges;
3. two-way absorption, gain and time-varying gain (``tvg_db_per_decade * log10(r)`` plus
   the absorption when ``tvg_absorption``);
4. range blur by the pulse (Gaussian, FWHM = c * pulse / 2) and leakage into neighbouring
   beams (side lobes, ``sidelobe_db`` for neighbours 1, 2, 3, ...), filtered on the rows
   that hold echo (and a kernel's half length around them; the rest stays zero);
5. multiplicative speckle, gamma distributed with ``speckle_looks`` looks and mean 1 (times
   a gamma texture for K-distributed power when ``physics.speckle_texture_shape`` is finite),
   and an additive noise floor (exponential power of mean ``noise_floor_db``); near-range
   blanking (``physics.blank_range_m``);
6. by default 0-80 dB mapped linearly to 0-255, as the ARIS SDK documents
   (``understanding-aris-data``: "sample values 0-255 map to an acoustic signal in the range
   0-80 dB"), i.e. ``uint8 = clip(round(10 log10(power) * 255 / 80), 0, 255)`` with power in
   display units; ``physics.output`` chooses uint16 or float32 amplitude or power instead
   (:mod:`sim_harness.sonar.receiver`).

Every physical choice besides the geometry is a parameter: the fields below and
:class:`~sim_harness.sonar.physics.SonarPhysics` (``config.physics``), whose defaults are the
historical choices; :mod:`sim_harness.sonar.family` draws members of the family. The
settings and the pose are in :mod:`sim_harness.sonar.config` (re-exported here).

Determinism: the noise of a frame depends only on ``config.seed`` and the frame's
``timestamp_s`` (its float64 bit pattern seeds the offsets into two seeded banks of
independent gamma and exponential variates drawn once per renderer). The same world,
config, pose and timestamp give the identical frame, in any call order.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import math
import sys
from dataclasses import dataclass

import cv2
import numpy as np

from perception.sonar_io.beams import aris3000_128
from perception.sonar_io.frame import SonarFrame
from sim_harness.sonar.config import SonarConfig, SonarPose, default_beam_azimuths, validate_pose
from sim_harness.sonar.geometry import pose_geometry, target_table
from sim_harness.sonar.physics import sinc_kernel
from sim_harness.sonar.receiver import NoiseBanks, blank_near_rows, power_to_image
from sim_harness.sonar.seabed import seabed_branches
from sim_harness.sonar.target_rays import Sampling, cast_all, no_runs, occlusion_runs, ray_batch
from sim_harness.sonar.targets import hidden_seabed, target_echo, target_truths
from sim_harness.sonar.truth import FrameTruth, Label, TargetTruth
from sim_harness.world.errors import PoseError
from sim_harness.world.world import World

__all__ = ["RenderLayers", "SonarConfig", "SonarPose", "SonarRenderer", "validate_pose"]

FloatArray = np.ndarray



#: glibc ``mallopt`` parameters (malloc.h): M_TRIM_THRESHOLD and M_MMAP_THRESHOLD.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: Freed heap glibc may keep for reuse instead of returning it to the OS, bytes.
ALLOCATOR_TRIM_BYTES = 64 << 20
#: Allocations at least this large get their own mapping (the noise banks do not), bytes.
ALLOCATOR_MMAP_BYTES = 16 << 20


@functools.cache
def _keep_freed_memory() -> None:
    """Let glibc keep freed heap memory between frames (process-wide, once, Linux only).

    A frame allocates and frees a few MB of temporaries. With glibc's default thresholds
    the freed memory goes back to the OS (trim / munmap) and comes back as ~1000 page
    faults a frame -- about a quarter of the frame time. Raising the thresholds keeps at
    most ALLOCATOR_TRIM_BYTES of freed heap for reuse; results are unchanged. Elsewhere
    (another C library, no ``mallopt``) this does nothing.
    """
    if not sys.platform.startswith("linux"):
        return
    name = ctypes.util.find_library("c")
    if name is None:
        return
    try:
        mallopt = ctypes.CDLL(name).mallopt
    except (OSError, AttributeError):
        return
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    mallopt(_M_MMAP_THRESHOLD, ALLOCATOR_MMAP_BYTES)
    mallopt(_M_TRIM_THRESHOLD, ALLOCATOR_TRIM_BYTES)


@dataclass(frozen=True, eq=False)
class RenderLayers:
    """Intermediate products of one render, arrays of shape (n_samples, n_beams).

    ``clean_power``: display-linear power before speckle and noise (float32);
    ``power``: after speckle, noise and blanking; ``image``: the output image (uint8, 0-80
    dB, by default; ``config.physics.output``); ``seabed_span_rad``:
    total seabed elevation span inside the aperture per cell; ``labels``/``owner``: as in
    :class:`~sim_harness.sonar.truth.FrameTruth`.
    """

    clean_power: np.ndarray
    power: np.ndarray
    image: np.ndarray
    seabed_span_rad: FloatArray
    labels: np.ndarray
    owner: np.ndarray
    targets: tuple[TargetTruth, ...]
    altitude_m: float
    altitude_normal_m: float
    seabed_normal_ned: FloatArray


def _gaussian_kernel(sigma: float) -> np.ndarray:
    if sigma < 0.25:
        return np.ones(1, dtype=np.float32)
    half = max(1, math.ceil(3.0 * sigma))
    x = np.arange(-half, half + 1, dtype=np.float64)
    k = np.exp(-0.5 * (x / sigma) ** 2)
    return (k / k.sum()).astype(np.float32)


class SonarRenderer:
    """Renders :class:`~perception.sonar_io.frame.SonarFrame` s of a world (see module docstring).

    Parameters
    ----------
    world : World
    config : SonarConfig
    """

    def __setstate__(self, state: dict) -> None:
        """Unpickled (in a render process, :mod:`sim_harness.render_worker`): the same
        allocator setting as a renderer built there."""
        _keep_freed_memory()
        self.__dict__.update(state)

    def __init__(self, world: World, config: SonarConfig | None = None):
        _keep_freed_memory()
        self.world = world
        self.config = config if config is not None else SonarConfig()
        cfg = self.config
        self._azimuth = np.asarray(cfg.beam_azimuth_rad, dtype=np.float64)
        if cfg.beam_width_rad is not None:
            self._beam_width = np.asarray(cfg.beam_width_rad, dtype=np.float64)
        elif cfg.beam_azimuth_rad == default_beam_azimuths():
            table = aris3000_128()
            self._beam_width = np.asarray(table.right_rad - table.left_rad, dtype=np.float64)
        else:
            self._beam_width = np.gradient(self._azimuth)
        self._range = cfg.range_m
        dr = cfg.range_resolution_m
        self._edges = cfg.window_start_m + np.arange(cfg.samples_per_beam + 1) * dr
        self._half_ap = cfg.elevation_aperture_rad / 2
        footprint_m = self._beam_width[None, :] / self._range[:, None] ** 2
        self._pattern_coeff = cfg.elevation_edge_db * math.log(10.0) / 10.0
        absorb_db = -2.0 * cfg.absorption_db_per_m * self._range
        tvg_db = cfg.tvg_db_per_decade * np.log10(self._range / 1.0) if cfg.tvg_db_per_decade else 0.0
        if cfg.tvg_absorption:
            tvg_db = tvg_db + 2.0 * cfg.absorption_db_per_m * self._range
        row_db = cfg.gain_db + absorb_db + tvg_db
        self._row_gain = (10.0 ** (row_db / 10.0)).astype(np.float32)[:, None]
        # footprint with the row gain folded in: the seabed comes out in display units
        self._footprint = (footprint_m * self._row_gain).astype(np.float32)
        fwhm_m = cfg.sound_speed_m_s * cfg.pulse_length_s / 2.0
        self._range_kernel = _gaussian_kernel(fwhm_m / 2.3548 / dr)
        if cfg.physics.azimuth_pattern == "sinc":
            self._beam_kernel = sinc_kernel(cfg.physics)
        else:
            side = [10.0 ** (db / 10.0) for db in cfg.sidelobe_db]
            self._beam_kernel = np.array(side[::-1] + [1.0] + side, dtype=np.float32)
        self._noise = NoiseBanks(
            seed=cfg.seed, size=int(cfg.noise_bank_size), speckle_looks=cfg.speckle_looks,
            texture_shape=cfg.physics.speckle_texture_shape,
            noise_mean=0.0 if cfg.noise_floor_db is None else 10.0 ** (cfg.noise_floor_db / 10.0),
        )
        self._targets = target_table(world)
        self._sampling = Sampling(
            n_samples=cfg.samples_per_beam,
            n_beams=cfg.n_beams,
            window_start_m=float(self._edges[0]),
            window_end_m=float(self._edges[-1]),
            range_resolution_m=dr,
            azimuth_rad=self._azimuth,
            beam_width_rad=self._beam_width,
            half_aperture_rad=self._half_ap,
            pattern_coeff=self._pattern_coeff,
            ray_step_rad=cfg.target_ray_step_rad,
            row_gain=self._row_gain,
            physics=cfg.physics,
        )

    def _blur(self, raw: np.ndarray, band: list[tuple[int, int]]) -> np.ndarray:
        """Range blur and side lobes of ``raw`` (float32, (n_samples, n_beams)), zero outside
        the rows ``band`` [(start, stop), ...] that hold its echo, into a new array.

        Only the rows within a kernel's half length of the echo are filtered: farther rows
        are zero, and the rows filtered see the same zeros beyond their edge as the whole
        image would (``BORDER_CONSTANT``), so the result is the whole image's, bit for bit.
        """
        band = [(a, b) for a, b in band if b > a]
        if not band:
            return np.zeros_like(raw)
        half = self._range_kernel.size // 2
        lo = max(min(a for a, _ in band) - half, 0)
        hi = min(max(b for _, b in band) + half, raw.shape[0])
        clean = np.zeros_like(raw)
        part = clean[lo:hi]
        out = cv2.sepFilter2D(raw[lo:hi], cv2.CV_32F, self._beam_kernel, self._range_kernel, dst=part,
                              borderType=cv2.BORDER_CONSTANT)
        if out is not part:  # OpenCV wrote elsewhere (it should not for a contiguous float32 view)
            part[...] = out
        return clean

    # ------------------------------------------------------------------ public API
    def render(
        self, pose: SonarPose, timestamp_s: float, *, altitude_m: float | None = None
    ) -> tuple[SonarFrame, FrameTruth]:
        """Render one ping.

        Parameters
        ----------
        pose : SonarPose
        timestamp_s : float
            Ping time, s; with ``config.seed`` it fixes the noise.
        altitude_m : float, optional
            Altitude to report in the frame (e.g. a simulated altimeter's reading); by
            default the true altitude when ``config.fill_altitude``, else NaN.

        Returns
        -------
        (SonarFrame, FrameTruth)
            The frame carries the image, ranges, azimuths, aperture, timestamp, sound speed
            and the pose a vehicle knows; the truth carries labels and target geometry.

        Raises
        ------
        PoseError
            For a pose under the seabed, above the water, or not finite.
        """
        layers = self.render_layers(pose, timestamp_s)
        if altitude_m is None:
            altitude_m = layers.altitude_m if self.config.fill_altitude else math.nan
        frame = SonarFrame(
            image=layers.image,
            range_m=self._range,
            beam_azimuth_rad=self._azimuth,
            elevation_aperture_rad=self.config.elevation_aperture_rad,
            timestamp_s=float(timestamp_s),
            sonar_depth_m=pose.depth_m,
            altitude_m=float(altitude_m),
            tilt_rad=pose.tilt_rad,
            vehicle_pitch_rad=pose.pitch_rad,
            vehicle_roll_rad=pose.roll_rad,
            heading_rad=pose.heading_rad,
            north_m=pose.north_m,
            east_m=pose.east_m,
            sound_speed_m_s=self.config.sound_speed_m_s,
        )
        truth = FrameTruth(
            labels=layers.labels,
            owner=layers.owner,
            targets=layers.targets,
            timestamp_s=float(timestamp_s),
            pose=pose,
            altitude_m=layers.altitude_m,
            altitude_normal_m=layers.altitude_normal_m,
            seabed_normal_ned=layers.seabed_normal_ned,
            seed=self.config.seed,
        )
        return frame, truth

    def render_layers(self, pose: SonarPose, timestamp_s: float) -> RenderLayers:
        """Render one ping and keep the intermediate layers (see :class:`RenderLayers`)."""
        if not math.isfinite(float(timestamp_s)):
            raise PoseError(f"timestamp must be finite, got {timestamp_s!r}")
        seabed_depth_m = validate_pose(self.world, pose)
        cfg = self.config
        n_s, n_b = cfg.samples_per_beam, cfg.n_beams
        geo = pose_geometry(
            self.world,
            north_m=pose.north_m,
            east_m=pose.east_m,
            depth_m=pose.depth_m,
            heading_rad=pose.heading_rad,
            pitch_rad=pose.pitch_rad,
            roll_rad=pose.roll_rad,
            tilt_rad=pose.tilt_rad,
            beam_azimuth_rad=self._azimuth,
        )
        branches = seabed_branches(
            self.world,
            geo,
            range_edges_m=self._edges,
            range_centres_m=self._range,
            half_aperture_rad=self._half_ap,
            pattern_coeff=self._pattern_coeff,
            footprint=self._footprint,
            physics=cfg.physics,
        )
        casts = cast_all(self.world, geo, self._sampling, self._targets)
        if casts:
            batch = ray_batch(casts)
            runs = occlusion_runs(self.world, geo, casts, batch)
            target_power, highlight, owner = target_echo(self.world, casts, batch, runs, self._sampling)
        else:
            runs = no_runs()
            highlight = np.zeros((n_s, n_b), dtype=bool)
            owner = np.zeros((n_s, n_b), dtype=np.uint8)
        owner_flat = owner.ravel()
        hidden = hidden_seabed(self.world, geo, branches, runs, owner_flat, highlight, self._sampling)

        seabed = np.zeros((n_s, n_b), dtype=np.float32)
        span = np.zeros((n_s, n_b), dtype=np.float32)
        seabed_flat, span_flat = seabed.ravel(), span.ravel()
        for branch, (cells, gone) in zip(branches, hidden, strict=True):
            rows = branch.rows
            span[rows] += branch.span
            seabed[rows] += branch.power
            if cells.size:
                local = cells - branch.row0 * n_b
                seabed_flat[cells] -= branch.power.ravel()[local] * gone / branch.span.ravel()[local]
        for cells, _ in hidden:  # rounding of a fully hidden cell (elsewhere the echo is >= 0)
            if cells.size:
                seabed_flat[cells] = np.maximum(seabed_flat[cells], np.float32(0.0))

        labels = (span > 0).view(np.uint8) * np.uint8(Label.SEABED)
        labels_flat = labels.ravel()
        touched = [c for c, _ in hidden if c.size]
        if touched:
            cells_all = np.concatenate(touched)
            gone_all = np.concatenate([g for c, g in hidden if c.size])
            unique, inverse = np.unique(cells_all, return_inverse=True)
            gone_sum = np.bincount(inverse, weights=gone_all)
            total = span_flat[unique]
            lit = highlight.ravel()[unique]
            shadow = (total > 0) & (gone_sum >= 0.5 * total) & ~lit
            labels_flat[unique[shadow]] = Label.SHADOW
            owner_flat[unique[~shadow & ~lit]] = 0
        labels[highlight] = Label.HIGHLIGHT

        raw = seabed  # gains are folded into the footprint and the target weights
        band = [(b.row0, b.row0 + b.span.shape[0]) for b in branches]
        if casts:
            target_power.add_to(raw)
            band.append(target_power.rows(n_b))
        clean = self._blur(raw, band)
        power = blank_near_rows(self._noise.apply(clean, timestamp_s), self._range, cfg.physics.blank_range_m)
        image = power_to_image(power, cfg.physics)
        truths = target_truths(geo, casts, runs, self._sampling)
        altitude = seabed_depth_m - pose.depth_m
        normal = -geo.c_vec / geo.c_norm
        return RenderLayers(
            clean_power=clean,
            power=power,
            image=image,
            seabed_span_rad=span,
            labels=labels,
            owner=owner,
            targets=truths,
            altitude_m=float(altitude),
            altitude_normal_m=geo.height_v_m / geo.c_norm,
            seabed_normal_ned=normal,
        )
