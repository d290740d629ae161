# Kept in one file (over 400 lines): an independently written forward model, copied as written
# (see README.md here); splitting it would make it ours.
"""facet_sonar: an independent forward model of a forward-looking imaging sonar.

ARIS Explorer 3000 class acoustic camera over a flat (optionally slightly sloped) seabed
with targets.  Method: the seabed and the visible surfaces of each target are sampled as
many small area-weighted point scatterers ("facets") with random complex amplitudes.  Each
scatterer's echo is spread over the range samples by the pulse envelope (evaluated exactly
at every sample centre), weighted by the elevation beam pattern, a grazing-angle
backscatter law, two-way spreading and absorption, and summed *coherently* into a fine
azimuth grid, which is then beam-formed into the 128 beams by one matrix product with the
azimuth beam pattern (main lobe + sidelobes).  Speckle is the interference of the sums.
Occlusion is analytic: a scatterer is silent if the segment from the sonar to it enters
any target solid first (ray/solid intersection per solid, pruned by bounding spheres).

Only numpy (and the standard library) is used.  Nothing of the shadowsurvey project is
imported.  Coordinates: local NED (x north, y east, z down); sonar frame x forward,
y starboard, z down; tilt positive = pointing down; azimuth positive to starboard;
elevation positive down (below the acoustic axis).  Images are (n_samples, n_beams),
row 0 nearest range.  Internally SI units and radians; degrees only in dataclass fields
whose names say so and in the files.
"""
from __future__ import annotations

import math
import struct
import zlib
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np

DEG = math.pi / 180.0

__all__ = [
    "Seabed", "Target", "Scene", "SonarPose", "Window", "FrameSettings", "SonarParams",
    "ScenePlan", "render_frame", "frame_truth", "write_frame_npz", "read_frame_npz",
    "sample_scene", "sample_pair", "render_plan", "paper_targets", "aris3000_beam_azimuths_deg",
    "uniform_fan_azimuths_deg", "sonar_rotation", "fan_image", "polar_image", "save_png",
    "write_pair_files", "REQUIRED_KEYS",
    "OPTIONAL_KEYS",
]

# ---------------------------------------------------------------------------------------
# ARIS Explorer 3000, 128 beams: beam centre angles from Sound Metrics' ARIS File SDK
# (BeamWidths_ARIS3000_128, MIT licence, (c) 2015 Sound Metrics).  Beam 0 is the
# right-most beam and negative angles are to starboard, so azimuth = -center, sorted.
_ARIS3000_128_CENTER_DEG = (
    -15.0068, -14.7768, -14.5462, -14.3150, -14.0833, -13.8511, -13.6186, -13.3858,
    -13.1528, -12.9196, -12.6861, -12.4523, -12.2182, -11.9838, -11.7491, -11.5141,
    -11.2789, -11.0435, -10.8079, -10.5721, -10.3361, -10.0999, -9.8635, -9.6269,
    -9.3902, -9.1534, -8.9165, -8.6795, -8.4424, -8.2053, -7.9682, -7.7310,
    -7.4938, -7.2566, -7.0193, -6.7820, -6.5446, -6.3072, -6.0698, -5.8324,
    -5.5949, -5.3574, -5.1199, -4.8823, -4.6447, -4.4071, -4.1695, -3.9318,
    -3.6941, -3.4564, -3.2187, -2.9809, -2.7430, -2.5050, -2.2669, -2.0287,
    -1.7904, -1.5520, -1.3135, -1.0749, -0.8362, -0.5974, -0.3585, -0.1196,
    0.1194, 0.3584, 0.5973, 0.8362, 1.0750, 1.3137, 1.5523, 1.7908,
    2.0292, 2.2675, 2.5057, 2.7438, 2.9818, 3.2197, 3.4575, 3.6952,
    3.9329, 4.1706, 4.4083, 4.6459, 4.8835, 5.1211, 5.3587, 5.5962,
    5.8337, 6.0712, 6.3086, 6.5460, 6.7834, 7.0208, 7.2581, 7.4954,
    7.7326, 7.9698, 8.2070, 8.4441, 8.6812, 8.9183, 9.1553, 9.3922,
    9.6290, 9.8657, 10.1023, 10.3387, 10.5749, 10.8109, 11.0467, 11.2823,
    11.5177, 11.7529, 11.9879, 12.2226, 12.4570, 12.6911, 12.9249, 13.1584,
    13.3916, 13.6246, 13.8574, 14.0899, 14.3221, 14.5538, 14.7850, 15.0156,)


def aris3000_beam_azimuths_deg() -> np.ndarray:
    """The 128 ARIS 3000 beam axes in the frame-format convention (increasing, + starboard)."""
    return np.sort(-np.asarray(_ARIS3000_128_CENTER_DEG, dtype=np.float64))


def uniform_fan_azimuths_deg(n_beams: int = 128, fan_deg: float = 30.0) -> np.ndarray:
    """Evenly spaced beam axes over a fan of fan_deg (centre to centre of the edge beams)."""
    return np.linspace(-fan_deg / 2.0, fan_deg / 2.0, int(n_beams))


def load_beam_table_csv(path: str) -> np.ndarray:
    """Beam azimuths (deg, increasing) from an SDK beam-width CSV (beam,center_deg,...)."""
    rows = np.genfromtxt(path, delimiter=",", names=True)
    return np.sort(-np.asarray(rows["center_deg"], dtype=np.float64))


# ---------------------------------------------------------------------------------------
# rotations

def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def sonar_rotation(heading_deg: float, pitch_deg: float, roll_deg: float, tilt_deg: float) -> np.ndarray:
    """3x3 matrix whose columns are the sonar axes (x fwd, y stbd, z down) in NED.

    Vehicle attitude in ArduPilot conventions (heading clockwise from north, pitch nose
    up, roll starboard down: R = Rz(heading) Ry(pitch) Rx(roll)); the sonar is mounted
    with a depression tilt about the vehicle's y axis: Ry(-tilt).
    """
    return (_rz(heading_deg * DEG) @ _ry(pitch_deg * DEG) @ _rx(roll_deg * DEG)
            @ _ry(-tilt_deg * DEG))


def _unit_dirs(az, el):
    """Unit vectors in the sonar frame for azimuth az (+stbd) and elevation el (+down)."""
    ce = np.cos(el)
    return np.stack([ce * np.cos(az), ce * np.sin(az), np.sin(el)], axis=-1)


# ---------------------------------------------------------------------------------------
# scene description

@dataclass(frozen=True)
class Seabed:
    """Seabed plane z = depth_m + slope_north*north + slope_east*east (NED, metres).

    reflectivity_db: Lambert coefficient mu (10 log10) of the backscatter law
    sigma = mu * cos(incidence)**lambert_exponent per unit area.
    texture_shape: K-distribution shape nu of a gamma intensity texture (inf = Rayleigh),
    texture_scale_m: its correlation (patch) size on the seabed.
    """
    depth_m: float = 10.0
    slope_north: float = 0.0
    slope_east: float = 0.0
    reflectivity_db: float = -20.0
    lambert_exponent: float = 2.0
    texture_shape: float = math.inf
    texture_scale_m: float = 0.05
    texture_seed: int = 0

    def normal_down(self) -> np.ndarray:
        n = np.array([-self.slope_north, -self.slope_east, 1.0])
        return n / np.linalg.norm(n)

    def plane_offset(self) -> float:
        return self.depth_m / float(np.linalg.norm([-self.slope_north, -self.slope_east, 1.0]))

    def depth_at(self, north: float, east: float) -> float:
        return self.depth_m + self.slope_north * north + self.slope_east * east

    def perp_distance(self, p) -> float:
        """Distance of point p (NED) above the plane, measured along its normal."""
        return float(self.plane_offset() - self.normal_down() @ np.asarray(p, float))


TARGET_KINDS = ("box", "pipe", "post", "dome", "sphere", "rock")


@dataclass(frozen=True)
class Target:
    """One object resting on the seabed; its local z axis is the seabed normal (up).

    kind     'box'    L x W x H block, L along the yaw axis.
             'pipe'   cylinder lying on its side, axis along yaw, length L, diameter W,
                      top at H above the seabed (H < W: partly buried).
             'post'   standing cylinder, diameter L, height H.
             'dome'   ellipsoid with horizontal semi-axes L/2, W/2 and vertical semi-axis
                      c (vertical_semi_axis_m, default H: a half-ellipsoid), top at H.
             'sphere' sphere of diameter L, top at H (H < L: partly buried).
             'rock'   irregular: an ellipsoid (L/2, W/2, c) with a random smooth radial
                      perturbation (roughness, shape_seed), shifted so its top is at H.
    yaw_deg  world heading of the local x axis (clockwise from north).
    reflectivity_db, lambert_exponent: diffuse backscatter mu*cos(inc)**n.
    specular_db, specular_width_deg: extra lobe s*exp(-inc^2/(2 w^2)) about normal incidence.
    """
    kind: str
    north_m: float
    east_m: float
    length_m: float
    width_m: float
    height_m: float
    yaw_deg: float = 0.0
    reflectivity_db: float = -10.0
    lambert_exponent: float = 2.0
    specular_db: float = -200.0
    specular_width_deg: float = 6.0
    vertical_semi_axis_m: float | None = None
    roughness: float = 0.2
    shape_seed: int = 0
    target_id: int = 0


@dataclass(frozen=True)
class Scene:
    seabed: Seabed = Seabed()
    targets: tuple = ()


@dataclass(frozen=True)
class SonarPose:
    """True pose of the sonar's acoustic centre and the vehicle attitude."""
    north_m: float = 0.0
    east_m: float = 0.0
    depth_m: float = 9.0
    heading_deg: float = 0.0
    pitch_deg: float = 0.0
    roll_deg: float = 0.0
    tilt_deg: float = 20.0

    def position(self) -> np.ndarray:
        return np.array([self.north_m, self.east_m, self.depth_m], float)

    def rotation(self) -> np.ndarray:
        return sonar_rotation(self.heading_deg, self.pitch_deg, self.roll_deg, self.tilt_deg)


@dataclass(frozen=True)
class Window:
    """Range window: n_samples rows, row i at start_m + i*length_m/n_samples (ARIS formula)."""
    start_m: float = 0.7
    length_m: float = 2.0
    n_samples: int = 1500

    def range_m(self) -> np.ndarray:
        return self.start_m + np.arange(int(self.n_samples)) * (self.length_m / int(self.n_samples))

    @staticmethod
    def from_aris(sample_start_delay_us: float, sample_period_us: float, samples_per_beam: int,
                  sound_speed_mps: float) -> Window:
        start = sample_start_delay_us * 1e-6 * sound_speed_mps / 2.0
        length = sample_period_us * samples_per_beam * 1e-6 * sound_speed_mps / 2.0
        return Window(start, length, int(samples_per_beam))


@dataclass(frozen=True)
class FrameSettings:
    """Operator/recording settings of one frame.

    tvg: 'none', '20log', '30log' or '40log' (each + 2*alpha*R, alpha = tvg_alpha_db_per_m,
    default the model's absorption).  dtype: 'uint8' (0..db_range dB -> 0..255, ARIS),
    'uint16' (linear amplitude, 65535 = db_range dB), 'float32' (linear intensity,
    10**(dB/10), capped at db_range) or 'float32_db' (dB, clipped to 0..db_range).
    The sonar converts time to range with sound_speed_reported_mps; the water has
    sound_speed_true_mps (equal by default).
    """
    window: Window = Window()
    gain_db: float = 0.0
    tvg: str = "30log"
    tvg_alpha_db_per_m: float | None = None
    dtype: str = "uint8"
    db_range: float = 80.0
    n_looks: int = 1
    blank_m: float = 0.0
    timestamp_s: float = 0.0
    sound_speed_true_mps: float = 1480.0
    sound_speed_reported_mps: float | None = None

    def c_reported(self) -> float:
        return self.sound_speed_true_mps if self.sound_speed_reported_mps is None else self.sound_speed_reported_mps


@dataclass(frozen=True)
class SonarParams:
    """Sonar hardware and propagation physics (see README for realistic ranges)."""
    beam_azimuths_deg: tuple = tuple(aris3000_beam_azimuths_deg())
    beam_width_deg: float = 0.25          # -3 dB width of the two-way azimuth pattern
    sidelobe_db: float = -25.0            # peak sidelobe level, -13.3 .. -42 dB
    elevation_aperture_deg: float = 14.0  # full vertical opening at the -3 dB edges
    elevation_edge_deg: float = 1.5       # width of the raised-cosine roll-off at each edge
    elevation_floor_db: float = -35.0     # two-way elevation response outside the aperture
    elevation_offset_deg: float = 0.0     # acoustic axis below the mechanical axis (mis-mount)
    range_res_m: float = 0.003            # -3 dB (intensity) length of the range response
    pulse_shape: str = "gaussian"         # 'gaussian' or 'hann' (raised cosine)
    match_pulse_to_sample: bool = True    # resolution never finer than the sample spacing
    absorption_db_per_m: float = 0.8      # one-way
    source_level_db: float = 120.0        # arbitrary reference; sets where echoes sit in dB
    noise_db: float = 3.0                 # receiver noise power per cell before TVG/gain
    scatterers_per_cell: float = 4.0      # per range-resolution x beam-width cell
    amplitude_model: str = "gaussian"     # 'gaussian' (complex normal) or 'phase' (unit, random phase)
    az_oversample: int = 6                # fine azimuth bins per beam width
    az_margin_deg: float = 1.5            # scatterers simulated beyond the edge beams
    max_target_scatterers: int = 400000


# ---------------------------------------------------------------------------------------
# solids: analytic ray intersection and surface sampling in the target's local frame
# (origin on the seabed below the target centre, x along yaw, z up along the normal)

_EPS = 1e-12


def _slab(o, D, lo, hi):
    """Entry/exit parameters of rays o + t D (o (3,), D (N,3)) through an axis box."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.where(np.abs(D) < _EPS, _EPS, D)
        t1 = (lo - o) * inv
        t2 = (hi - o) * inv
    tmin = np.max(np.minimum(t1, t2), axis=1)
    tmax = np.min(np.maximum(t1, t2), axis=1)
    return tmin, tmax


def _disc_cyl(oa, ob, da, db, radius):
    """Entry/exit of rays through an infinite cylinder a^2 + b^2 = radius^2."""
    A = da * da + db * db
    B = 2.0 * (oa * da + ob * db)
    C = oa * oa + ob * ob - radius * radius
    disc = B * B - 4.0 * A * C
    ok = disc >= 0.0
    sq = np.sqrt(np.where(ok, disc, 0.0))
    par = A < 1e-14
    Asafe = np.where(par, 1.0, A)
    t0 = np.where(ok, (-B - sq) / (2.0 * Asafe), np.inf)
    t1 = np.where(ok, (-B + sq) / (2.0 * Asafe), -np.inf)
    # rays parallel to the axis: inside for all t if C <= 0
    t0 = np.where(par, np.where(C <= 0, -np.inf, np.inf), t0)
    t1 = np.where(par, np.where(C <= 0, np.inf, -np.inf), t1)
    return t0, t1


def _finish(tmin, tmax):
    hit = (tmax >= tmin) & (tmax > 1e-9)
    return np.where(hit, np.maximum(tmin, 0.0), np.inf)


def _fibonacci_sphere(n):
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    th = math.pi * (1 + 5 ** 0.5) * i
    return np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], 1)


def _icosphere(level):
    t = (1.0 + 5 ** 0.5) / 2.0
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(level):
        cache = {}
        nf = []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return np.array(verts), np.array(f, dtype=np.int64)


def _legendre(l, x):
    if l == 2:
        return 0.5 * (3 * x * x - 1)
    if l == 3:
        return 0.5 * (5 * x ** 3 - 3 * x)
    return (35 * x ** 4 - 30 * x * x + 3) / 8.0


class _Solid:
    """A target turned into geometry in world coordinates (NED)."""

    def __init__(self, target: Target, seabed: Seabed):
        self.t = target
        k = target.kind
        if k not in TARGET_KINDS:
            raise ValueError(f"unknown target kind {k!r}; one of {TARGET_KINDS}")
        up = -seabed.normal_down()
        yaw = target.yaw_deg * DEG
        h = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        x = h - (h @ up) * up
        x /= np.linalg.norm(x)
        y = np.cross(up, x)
        self.M = np.stack([x, y, up], axis=1)          # columns: local axes in NED
        self.O = np.array([target.north_m, target.east_m,
                           seabed.depth_at(target.north_m, target.east_m)])
        L, W, H = float(target.length_m), float(target.width_m), float(target.height_m)
        if H <= 0:
            raise ValueError("target height must be positive")
        self.height = H
        if k == "box":
            self.lo = np.array([-L / 2, -W / 2, 0.0])
            self.hi = np.array([L / 2, W / 2, H])
            self.bc = np.array([0, 0, H / 2])
            self.br = math.sqrt((L / 2) ** 2 + (W / 2) ** 2 + (H / 2) ** 2)
        elif k == "post":
            self.rad = L / 2
            self.bc = np.array([0, 0, H / 2])
            self.br = math.hypot(self.rad, H / 2)
        elif k == "pipe":
            self.rad = W / 2
            if H > W + 1e-12:
                raise ValueError("pipe: height cannot exceed the diameter (width_m)")
            self.zc = H - self.rad
            self.len = L
            self.bc = np.array([0, 0, self.zc])
            self.br = math.hypot(L / 2, self.rad)
        elif k in ("dome", "sphere"):
            if k == "sphere":
                a = b = c = L / 2
            else:
                a, b = L / 2, W / 2
                c = H if target.vertical_semi_axis_m is None else float(target.vertical_semi_axis_m)
            if H > 2 * c + 1e-12:
                raise ValueError("dome/sphere: height cannot exceed the full vertical axis")
            self.ax = np.array([a, b, c])
            self.zc = H - c
            self.bc = np.array([0, 0, self.zc])
            self.br = max(a, b, c)
        elif k == "rock":
            a, b = L / 2, W / 2
            c = H if target.vertical_semi_axis_m is None else float(target.vertical_semi_axis_m)
            V, F = _icosphere(3)
            srng = np.random.default_rng(int(target.shape_seed))
            pert = np.zeros(len(V))
            for l in (2, 2, 3, 3, 4, 4):
                axis = srng.normal(size=3)
                axis /= np.linalg.norm(axis)
                pert += srng.normal() * _legendre(l, V @ axis) / math.sqrt(3.0)
            rscale = np.exp(target.roughness * pert)
            P = V * rscale[:, None] * np.array([a, b, c])
            shift = H - P[:, 2].max()
            P[:, 2] += shift
            self.rock_centre = np.array([0.0, 0.0, shift])
            self.V, self.F = P, F
            tri = P[F]
            self.e1 = tri[:, 1] - tri[:, 0]
            self.e2 = tri[:, 2] - tri[:, 0]
            self.v0 = tri[:, 0]
            cen = P.mean(0)
            self.bc = cen
            self.br = float(np.max(np.linalg.norm(P - cen, axis=1)))
        self.kind = k
        self.bc_w = self.O + self.M @ self.bc

    # ----- coordinates
    def to_local(self, P):
        return (np.atleast_2d(P) - self.O) @ self.M

    def to_world(self, P):
        return P @ self.M.T + self.O

    def centre_world(self):
        """Centre of the solid at half its height above the seabed."""
        return self.O + self.M @ np.array([0.0, 0.0, self.height / 2.0])

    # ----- ray intersection (first entry distance, inf on a miss)
    def intersect_world(self, o_w, D_w):
        o = (np.asarray(o_w, float) - self.O) @ self.M
        D = D_w @ self.M
        return self._intersect_local(o, D)

    def _intersect_local(self, o, D):
        k = self.kind
        if k == "box":
            return _finish(*_slab(o, D, self.lo, self.hi))
        if k == "post":
            c0, c1 = _disc_cyl(o[0], o[1], D[:, 0], D[:, 1], self.rad)
            s0, s1 = _slab(o[2:3], D[:, 2:3], np.array([0.0]), np.array([self.height]))
            return _finish(np.maximum(c0, s0), np.minimum(c1, s1))
        if k == "pipe":
            c0, c1 = _disc_cyl(o[1], o[2] - self.zc, D[:, 1], D[:, 2], self.rad)
            s0, s1 = _slab(o[0:1], D[:, 0:1], np.array([-self.len / 2]), np.array([self.len / 2]))
            return _finish(np.maximum(c0, s0), np.minimum(c1, s1))
        if k in ("dome", "sphere"):
            oc = (o - np.array([0, 0, self.zc])) / self.ax
            Dc = D / self.ax
            A = np.einsum("ij,ij->i", Dc, Dc)
            B = 2.0 * Dc @ oc
            C = oc @ oc - 1.0
            disc = B * B - 4 * A * C
            ok = disc >= 0
            sq = np.sqrt(np.where(ok, disc, 0))
            t0 = np.where(ok, (-B - sq) / (2 * A), np.inf)
            t1 = np.where(ok, (-B + sq) / (2 * A), -np.inf)
            return _finish(t0, t1)
        # rock: Moller-Trumbore against all triangles.  With one ray origin the triple
        # products reduce to matrix products: det = d.(e2 x e1), u = d.(e2 x tv)/det,
        # v = d.(tv x e1)/det, t = e2.(tv x e1)/det with tv = o - v0.
        tv = o[None, :] - self.v0
        n_det = np.cross(self.e2, self.e1)
        n_u = np.cross(self.e2, tv)
        q = np.cross(tv, self.e1)
        t_num = np.einsum("tk,tk->t", self.e2, q)
        out = np.full(len(D), np.inf)
        chunk = max(1, int(4_000_000 // len(self.F)))
        for s in range(0, len(D), chunk):
            d = D[s:s + chunk]
            det = d @ n_det.T
            ok = np.abs(det) > 1e-14
            inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
            u = (d @ n_u.T) * inv
            v = (d @ q.T) * inv
            tt = t_num[None, :] * inv
            good = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (tt > 1e-9)
            out[s:s + chunk] = np.where(good, tt, np.inf).min(axis=1)
        return out

    # ----- surface sampling: points, outward normals (world) and area per point
    def sample_surface(self, rng, density_per_m2, max_points):
        k = self.kind
        pts, nrm, area = [], [], []

        def add(P, N, A_total):
            if len(P):
                pts.append(P)
                nrm.append(N)
                area.append(np.full(len(P), A_total / len(P)))

        def count(A):
            return int(min(max_points, max(8, math.ceil(A * density_per_m2))))

        H = self.height
        if k == "box":
            (x0, y0, _), (x1, y1, _) = self.lo, self.hi
            faces = [  # (area, sampler)
                ((x1 - x0) * (y1 - y0), lambda n: (np.c_[rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), np.full(n, H)], (0, 0, 1))),
                ((y1 - y0) * H, lambda n: (np.c_[np.full(n, x1), rng.uniform(y0, y1, n), rng.uniform(0, H, n)], (1, 0, 0))),
                ((y1 - y0) * H, lambda n: (np.c_[np.full(n, x0), rng.uniform(y0, y1, n), rng.uniform(0, H, n)], (-1, 0, 0))),
                ((x1 - x0) * H, lambda n: (np.c_[rng.uniform(x0, x1, n), np.full(n, y1), rng.uniform(0, H, n)], (0, 1, 0))),
                ((x1 - x0) * H, lambda n: (np.c_[rng.uniform(x0, x1, n), np.full(n, y0), rng.uniform(0, H, n)], (0, -1, 0))),
            ]
            for A, fn in faces:
                P, n = fn(count(A))
                add(P, np.tile(np.array(n, float), (len(P), 1)), A)
        elif k == "post":
            R = self.rad
            A = 2 * math.pi * R * H
            n = count(A)
            ph = rng.uniform(0, 2 * math.pi, n)
            add(np.c_[R * np.cos(ph), R * np.sin(ph), rng.uniform(0, H, n)],
                np.c_[np.cos(ph), np.sin(ph), np.zeros(n)], A)
            A = math.pi * R * R
            n = count(A)
            rr = R * np.sqrt(rng.uniform(0, 1, n))
            ph = rng.uniform(0, 2 * math.pi, n)
            add(np.c_[rr * np.cos(ph), rr * np.sin(ph), np.full(n, H)],
                np.tile([0.0, 0.0, 1.0], (n, 1)), A)
        elif k == "pipe":
            R, zc, Lp = self.rad, self.zc, self.len
            # lateral surface above z = 0: angle phi with zc + R sin(phi) > 0
            s = max(-1.0, min(1.0, -zc / R))
            ph0 = math.asin(s)
            ph1 = math.pi - ph0
            A = (ph1 - ph0) * R * Lp
            n = count(A)
            ph = rng.uniform(ph0, ph1, n)
            add(np.c_[rng.uniform(-Lp / 2, Lp / 2, n), R * np.cos(ph), zc + R * np.sin(ph)],
                np.c_[np.zeros(n), np.cos(ph), np.sin(ph)], A)
            for sx in (-1.0, 1.0):  # end caps, above the seabed part only
                n = count(math.pi * R * R)
                rr = R * np.sqrt(rng.uniform(0, 1, n))
                ph = rng.uniform(0, 2 * math.pi, n)
                yz = np.c_[rr * np.cos(ph), zc + rr * np.sin(ph)]
                keep = yz[:, 1] > 0
                A = math.pi * R * R * keep.mean()
                m = int(keep.sum())
                add(np.c_[np.full(m, sx * Lp / 2), yz[keep]], np.tile([sx, 0.0, 0.0], (m, 1)), A)
        elif k in ("dome", "sphere"):
            a, b, c = self.ax
            ninv = np.array([1 / a, 1 / b, 1 / c])
            wmax = float(ninv.max())
            # total area estimate from a large quasi-uniform set of sphere directions
            U = _fibonacci_sphere(20000)
            g = np.linalg.norm(U * ninv, axis=1)
            A_all = 4 * math.pi * a * b * c * g.mean()
            z = self.zc + c * U[:, 2]
            frac = float(np.mean(g * (z > 0)) / g.mean())
            A = A_all * frac
            n = count(A)
            got = []
            tot = 0
            while tot < n:
                u = rng.normal(size=(2 * n + 16, 3))
                u /= np.linalg.norm(u, axis=1, keepdims=True)
                gg = np.linalg.norm(u * ninv, axis=1)
                u = u[(rng.uniform(0, wmax, len(u)) < gg) & (self.zc + c * u[:, 2] > 0)]
                got.append(u)
                tot += len(u)
            u = np.concatenate(got)[:n]
            P = u * self.ax + np.array([0, 0, self.zc])
            N = u * ninv
            N /= np.linalg.norm(N, axis=1, keepdims=True)
            add(P, N, A)
        else:  # rock
            tri = self.V[self.F]
            cr = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            ta = 0.5 * np.linalg.norm(cr, axis=1)
            fn = cr / (2 * ta[:, None])
            out = np.einsum("ij,ij->i", fn, tri.mean(1) - self.rock_centre) < 0
            fn[out] *= -1
            vis = tri[:, :, 2].max(1) > 0
            A = float(ta[vis].sum())
            n = count(A)
            idx = rng.choice(np.nonzero(vis)[0], size=n, p=ta[vis] / A)
            r1 = np.sqrt(rng.uniform(0, 1, n))
            r2 = rng.uniform(0, 1, n)
            P = (tri[idx, 0] * (1 - r1)[:, None] + tri[idx, 1] * (r1 * (1 - r2))[:, None]
                 + tri[idx, 2] * (r1 * r2)[:, None])
            keep = P[:, 2] > 0
            add(P[keep], fn[idx][keep], A * keep.mean())
        P = np.concatenate(pts)
        N = np.concatenate(nrm)
        dA = np.concatenate(area)
        return self.to_world(P), N @ self.M.T, dA

    def max_height(self):
        if self.kind == "rock":
            return float(self.V[:, 2].max())
        return self.height


# ---------------------------------------------------------------------------------------
# beam patterns, pulse, texture

def _taper_pattern(x, p):
    """Amplitude pattern of the aperture taper p + (1-p) cos^2(pi*zeta), |zeta| <= 1/2."""
    num = p * np.sinc(x) + 0.5 * (1 - p) * (np.sinc(x) + 0.5 * (np.sinc(x + 1) + np.sinc(x - 1)))
    return num / (p + 0.5 * (1 - p))


_PED_TABLE = None


def _pedestal_for(sidelobe_db):
    """Pedestal p giving the requested peak sidelobe (p=1 uniform -13.3 dB, p=0.08 Hamming -42.7)."""
    global _PED_TABLE
    if _PED_TABLE is None:
        x = np.linspace(0, 24, 9601)
        ps = np.linspace(0.08, 1.0, 93)
        sll = []
        for p in ps:
            A = _taper_pattern(x, p)
            i0 = int(np.argmax(A <= 0))
            sll.append(20 * np.log10(np.abs(A[i0:]).max()))
        _PED_TABLE = (np.array(sll), ps)
    sll, ps = _PED_TABLE
    return float(np.interp(sidelobe_db, sll, ps))


class _AzPattern:
    """Two-way azimuth amplitude pattern vs angle off the beam axis (radians)."""

    def __init__(self, beam_width_deg, sidelobe_db):
        self.p = _pedestal_for(sidelobe_db)
        lo, hi = 0.0, 2.0
        for _ in range(60):
            m = 0.5 * (lo + hi)
            if _taper_pattern(m, self.p) ** 2 > 0.5:
                lo = m
            else:
                hi = m
        self.scale = lo / (0.5 * beam_width_deg * DEG)

    def __call__(self, dtheta):
        return _taper_pattern(np.asarray(dtheta) * self.scale, self.p)


def _elevation_power(el, sp: SonarParams):
    """Two-way elevation power response; -3 dB at +-aperture/2 about the acoustic axis."""
    half = 0.5 * sp.elevation_aperture_deg * DEG
    e = max(sp.elevation_edge_deg * DEG, 1e-6)
    fl = 10 ** (sp.elevation_floor_db / 10)
    a = np.abs(np.asarray(el) - sp.elevation_offset_deg * DEG)
    mid = fl + (1 - fl) * 0.5 * (1 + np.cos(np.pi * np.clip((a - (half - e / 2)) / e, 0, 1)))
    return np.where(a <= half - e / 2, 1.0, np.where(a >= half + e / 2, fl, mid))


def _pulse(x, res, shape):
    """Range envelope (amplitude) whose intensity has a -3 dB width of res."""
    if shape == "gaussian":
        sa = res / (2 * math.sqrt(math.log(2)))
        return np.exp(-0.5 * (x / sa) ** 2)
    if shape == "hann":
        L = res / 0.36408
        return np.where(np.abs(x) < L / 2, np.cos(np.pi * x / L) ** 2, 0.0)
    raise ValueError(f"pulse_shape must be 'gaussian' or 'hann', not {shape!r}")


def _pulse_support(res, shape):
    return 3.0 * res / (2 * math.sqrt(math.log(2))) if shape == "gaussian" else 0.5 * res / 0.36408


def _hash_uniform(i, j, seed):
    """Deterministic uniforms in (0,1) for integer cells (splitmix64 of the cell index)."""
    with np.errstate(over="ignore"):
        x = (i.astype(np.int64).astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
             ^ j.astype(np.int64).astype(np.uint64) * np.uint64(0xC2B2AE3D27D4EB4F)
             ^ np.uint64(int(seed) & 0xFFFFFFFFFFFFFFFF))
        z = x + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return ((z >> np.uint64(11)).astype(np.float64) + 0.5) * 2.0 ** -53


def _gamma_from_uniform(u, nu):
    try:
        from scipy.special import gammaincinv
        return gammaincinv(nu, u) / nu
    except Exception:  # Wilson-Hilferty approximation, numpy + stdlib only
        from statistics import NormalDist
        z = np.vectorize(NormalDist().inv_cdf)(u)
        return np.maximum(1 - 1 / (9 * nu) + z * np.sqrt(1 / (9 * nu)), 0) ** 3


def _norm_ppf(u):
    try:
        from scipy.special import ndtri
        return ndtri(u)
    except Exception:
        from statistics import NormalDist
        return np.vectorize(NormalDist().inv_cdf)(u)


def _norm_cdf(z):
    from math import erf
    try:
        from scipy.special import ndtr
        return ndtr(z)
    except Exception:
        return 0.5 * (1 + np.vectorize(erf)(z / math.sqrt(2)))


def _texture(P_w, sb: Seabed):
    """Gamma(nu) intensity texture (mean 1) fixed to the seabed, the same in every frame.

    A smooth Gaussian field (i.i.d. normals on a grid of texture_scale_m, bilinearly
    interpolated and renormalised to unit variance) mapped through the normal CDF and the
    gamma quantile: the marginal is exactly gamma(nu), so seabed intensity is K-distributed
    with shape nu over patches larger than texture_scale_m."""
    nu = sb.texture_shape
    if not np.isfinite(nu):
        return np.ones(len(P_w))
    g = P_w[:, :2] / sb.texture_scale_m
    i0 = np.floor(g).astype(np.int64)
    f = g - i0
    cells, inv = np.unique(np.concatenate([i0 + np.array(o) for o in ((0, 0), (1, 0), (0, 1), (1, 1))]),
                           axis=0, return_inverse=True)
    zc = _norm_ppf(_hash_uniform(cells[:, 0], cells[:, 1], sb.texture_seed))
    zc = zc[inv.ravel()].reshape(4, len(P_w))
    w = np.stack([(1 - f[:, 0]) * (1 - f[:, 1]), f[:, 0] * (1 - f[:, 1]), (1 - f[:, 0]) * f[:, 1], f[:, 0] * f[:, 1]])
    z = (w * zc).sum(0) / np.sqrt((w * w).sum(0))
    u = np.clip(_norm_cdf(z), 1e-12, 1 - 1e-12)
    return _gamma_from_uniform(u, nu)


def _seabed_el(r, az, n_s, H):
    """Elevation of the seabed point at slant range r in azimuth az (forward root)."""
    A = n_s[0] * np.cos(az) + n_s[1] * np.sin(az)
    B = n_s[2]
    S = np.hypot(A, B)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = H / (r * S)
    ok = (q <= 1) & (S > 1e-12)
    el = np.arctan2(B, A) - np.arccos(np.clip(q, -1, 1))
    ok &= (el > -math.pi / 2) & (el < math.pi / 2)
    return el, ok


def _first_hit(solids, o, D, tmax):
    """Smallest entry distance over all solids for rays o + t D (D unit, (N,3))."""
    t = np.full(len(D), np.inf)
    for sol in solids:
        v = sol.bc_w - o
        proj = D @ v
        perp2 = v @ v - proj ** 2
        cand = np.nonzero((perp2 <= sol.br ** 2) & (proj + sol.br > 0) & (proj - sol.br < tmax))[0]
        if cand.size:
            t[cand] = np.minimum(t[cand], sol.intersect_world(o, D[cand]))
    return t


# ---------------------------------------------------------------------------------------
# rendering

REQUIRED_KEYS = ("image", "range_m", "beam_azimuth_deg", "elevation_aperture_deg", "timestamp_s")
OPTIONAL_KEYS = ("sonar_depth_m", "altitude_m", "tilt_deg", "vehicle_pitch_deg", "vehicle_roll_deg",
                 "heading_deg", "north_m", "east_m", "sound_speed_mps")
_TVG_K = {"none": None, "20log": 20.0, "30log": 30.0, "40log": 40.0}
_OCC_EPS = 1e-4


def _reported_from_truth(scene, pose, settings, report):
    rep = {
        "sonar_depth_m": pose.depth_m,
        "altitude_m": scene.seabed.depth_at(pose.north_m, pose.east_m) - pose.depth_m,
        "tilt_deg": pose.tilt_deg,
        "vehicle_pitch_deg": pose.pitch_deg,
        "vehicle_roll_deg": pose.roll_deg,
        "heading_deg": pose.heading_deg % 360.0,
        "north_m": pose.north_m,
        "east_m": pose.east_m,
        "sound_speed_mps": settings.c_reported(),
    }
    for k, v in (report or {}).items():
        if k not in OPTIONAL_KEYS:
            raise KeyError(f"unknown reported key {k!r}; one of {OPTIONAL_KEYS}")
        rep[k] = float(v) if v is not None else float("nan")
    return {k: float(v) for k, v in rep.items()}


def render_frame(scene: Scene, pose: SonarPose, settings: FrameSettings = FrameSettings(),
                 sonar: SonarParams = SonarParams(), rng=None, report: dict | None = None,
                 return_linear: bool = False):
    """Render one frame.  Returns (frame, truth).

    frame: dict with the frame-format arrays ('image', 'range_m', 'beam_azimuth_deg',
    'elevation_aperture_deg', 'timestamp_s'), 'reported' (the optional scalars as the
    source would report them: true pose unless overridden by `report`), and with
    return_linear also 'linear_intensity' (float64, after TVG and gain, before
    quantisation).  truth: see frame_truth().
    rng: numpy Generator or seed; every random draw comes from it.
    """
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    sb = scene.seabed
    R = pose.rotation()
    s = pose.position()
    n_s = R.T @ sb.normal_down()
    H = sb.perp_distance(s)
    if H <= 0:
        raise ValueError("the sonar is below the seabed")
    r_file = settings.window.range_m()
    n = len(r_file)
    if n < 2 or settings.window.length_m <= 0 or settings.window.start_m <= 0:
        raise ValueError("window needs start > 0, length > 0 and at least 2 samples")
    c_ratio = settings.sound_speed_true_mps / settings.c_reported()
    r_true = r_file * c_ratio
    dr = r_true[1] - r_true[0]
    az_b = np.asarray(sonar.beam_azimuths_deg, float) * DEG
    if np.any(np.diff(az_b) <= 0):
        raise ValueError("beam azimuths must be strictly increasing")
    nb = len(az_b)
    bw = sonar.beam_width_deg * DEG
    da = bw / sonar.az_oversample
    az_lo = az_b[0] - sonar.az_margin_deg * DEG
    naz = int(math.ceil((az_b[-1] + sonar.az_margin_deg * DEG - az_lo) / da)) + 1
    az_hi = az_lo + (naz - 1) * da
    res = max(sonar.range_res_m, dr) if sonar.match_pulse_to_sample else sonar.range_res_m
    sup = _pulse_support(res, sonar.pulse_shape)
    r_lo, r_hi = r_true[0] - sup, r_true[-1] + sup
    solids = [_Solid(t, sb) for t in scene.targets]

    # --- seabed scatterers, uniform in (slant range, azimuth) over the window and fan
    # (jittered-stratified: one scatterer per sub-cell, so the number of scatterers in a
    # resolution cell does not fluctuate and add a spurious texture)
    q = math.sqrt(sonar.scatterers_per_cell)
    n_r = int(math.ceil(q * (r_hi - r_lo) / res))
    n_a = int(math.ceil(q * (az_hi - az_lo) / bw))
    n_sb = n_r * n_a
    rr = r_lo + (np.repeat(np.arange(n_r), n_a) + rng.uniform(0, 1, n_sb)) * ((r_hi - r_lo) / n_r)
    aa = az_lo + (np.tile(np.arange(n_a), n_r) + rng.uniform(0, 1, n_sb)) * ((az_hi - az_lo) / n_a)
    el, ok = _seabed_el(rr, aa, n_s, H)
    hr, ha = 1e-5, 1e-6
    el_r, ok_r = _seabed_el(rr + hr, aa, n_s, H)
    el_a, ok_a = _seabed_el(rr, aa + ha, n_s, H)
    ok &= ok_r & ok_a
    rr, aa, el, el_r, el_a = rr[ok], aa[ok], el[ok], el_r[ok], el_a[ok]
    d_s = _unit_dirs(aa, el)
    P0 = rr[:, None] * d_s
    Jr = ((rr + hr)[:, None] * _unit_dirs(aa, el_r) - P0) / hr
    Ja = (rr[:, None] * _unit_dirs(aa + ha, el_a) - P0) / ha
    dA = np.linalg.norm(np.cross(Jr, Ja), axis=1) * ((r_hi - r_lo) * (az_hi - az_lo) / n_sb)
    cos_i = np.clip(d_s @ n_s, 0, 1)
    sigma = 10 ** (sb.reflectivity_db / 10) * cos_i ** sb.lambert_exponent
    D_w = d_s @ R.T
    P_w = s + rr[:, None] * D_w
    sigma = sigma * _texture(P_w, sb)
    if solids:
        vis = _first_hit(solids, s, D_w, rr) >= rr - _OCC_EPS
        rr, aa, el, dA, sigma = rr[vis], aa[vis], el[vis], dA[vis], sigma[vis]
    parts = [(rr, aa, el, sigma * dA)]

    # --- target surface scatterers
    for sol in solids:
        dist = float(np.linalg.norm(sol.bc_w - s))
        rmin = max(dist - sol.br, 0.05)
        dens = 1.5 * sonar.scatterers_per_cell / (res * rmin * bw)
        P, N, dAt = sol.sample_surface(rng, dens, sonar.max_target_scatterers)
        v = P - s
        r = np.linalg.norm(v, axis=1)
        dw = v / r[:, None]
        ci = -np.einsum("ij,ij->i", N, dw)
        ds = dw @ R
        az = np.arctan2(ds[:, 1], ds[:, 0])
        keep = (ci > 1e-6) & (r > r_lo) & (r < r_hi) & (az >= az_lo) & (az <= az_hi)
        if not keep.any():
            continue
        P, dw, ds, r, ci, az, dAt = P[keep], dw[keep], ds[keep], r[keep], ci[keep], az[keep], dAt[keep]
        vis = _first_hit(solids, s, dw, r) >= r - _OCC_EPS
        if not vis.any():
            continue
        r, ci, az, dAt, ds = r[vis], ci[vis], az[vis], dAt[vis], ds[vis]
        t = sol.t
        inc = np.arccos(np.clip(ci, 0, 1))
        sig = (10 ** (t.reflectivity_db / 10) * ci ** t.lambert_exponent
               + 10 ** (t.specular_db / 10) * np.exp(-0.5 * (inc / (t.specular_width_deg * DEG)) ** 2))
        parts.append((r, az, np.arcsin(np.clip(ds[:, 2], -1, 1)), sig * dAt))

    r_k = np.concatenate([p[0] for p in parts])
    az_k = np.concatenate([p[1] for p in parts])
    el_k = np.concatenate([p[2] for p in parts])
    en_k = np.concatenate([p[3] for p in parts])      # sigma * area
    alpha = sonar.absorption_db_per_m
    amp = (np.sqrt(10 ** (sonar.source_level_db / 10) * en_k * _elevation_power(el_k, sonar))
           / r_k ** 2 * 10 ** (-alpha * r_k / 10))

    # --- exact range taps at every sample centre, nearest fine-azimuth bin
    K = int(math.ceil(sup / dr)) + 1
    ic = np.rint((r_k - r_true[0]) / dr).astype(np.int64)
    ii = ic[:, None] + np.arange(-K, K + 1)[None, :]
    w = _pulse(r_true[0] + ii * dr - r_k[:, None], res, sonar.pulse_shape)
    jj = np.clip(np.rint((az_k - az_lo) / da).astype(np.int64), 0, naz - 1)
    valid = (ii >= 0) & (ii < n) & (w > 1e-6)
    bins = (ii * naz + jj[:, None])[valid]
    wv = w[valid]
    kk = np.broadcast_to(np.arange(len(r_k))[:, None], ii.shape)[valid]
    Bm = _AzPattern(sonar.beam_width_deg, sonar.sidelobe_db)(az_lo + np.arange(naz)[:, None] * da
                                                             - az_b[None, :])   # (naz, nb)
    looks = max(1, int(settings.n_looks))
    I = np.zeros((n, nb))
    n0 = 10 ** (sonar.noise_db / 10)
    for _ in range(looks):
        if sonar.amplitude_model == "gaussian":
            z = (rng.standard_normal(len(r_k)) + 1j * rng.standard_normal(len(r_k))) / math.sqrt(2)
        elif sonar.amplitude_model == "phase":
            z = np.exp(2j * math.pi * rng.uniform(0, 1, len(r_k)))
        else:
            raise ValueError("amplitude_model must be 'gaussian' or 'phase'")
        c = (amp * z)[kk] * wv
        Gr = np.bincount(bins, weights=c.real, minlength=n * naz).reshape(n, naz)
        Gi = np.bincount(bins, weights=c.imag, minlength=n * naz).reshape(n, naz)
        Sr = Gr @ Bm + rng.standard_normal((n, nb)) * math.sqrt(n0 / 2)
        Si = Gi @ Bm + rng.standard_normal((n, nb)) * math.sqrt(n0 / 2)
        I += Sr * Sr + Si * Si
    I /= looks
    if settings.blank_m > 0:
        I[r_file < settings.blank_m] = 0.0
    k = _TVG_K.get(settings.tvg, "bad")
    if k == "bad":
        raise ValueError(f"tvg must be one of {tuple(_TVG_K)}")
    if k is not None:
        a_tvg = alpha if settings.tvg_alpha_db_per_m is None else settings.tvg_alpha_db_per_m
        I = I * (r_file ** (k / 10.0) * 10 ** (2 * a_tvg * r_file / 10))[:, None]
    I = I * 10 ** (settings.gain_db / 10)
    image = _quantise(I, settings.dtype, settings.db_range)
    frame = {
        "image": image,
        "range_m": r_file.astype(np.float64),
        "beam_azimuth_deg": (az_b / DEG).astype(np.float64),
        "elevation_aperture_deg": np.float64(sonar.elevation_aperture_deg),
        "timestamp_s": np.float64(settings.timestamp_s),
        "reported": _reported_from_truth(scene, pose, settings, report),
    }
    if return_linear:
        frame["linear_intensity"] = I
    truth = frame_truth(scene, pose, settings, sonar)
    truth["n_scatterers"] = int(len(r_k))
    return frame, truth


def _quantise(I, dtype, db_range):
    with np.errstate(divide="ignore"):
        dB = 10 * np.log10(np.maximum(I, 1e-30))
    if dtype == "uint8":
        return np.clip(np.rint(dB * 255.0 / db_range), 0, 255).astype(np.uint8)
    if dtype == "uint16":
        return np.clip(np.rint(65535.0 * 10 ** ((np.minimum(dB, db_range) - db_range) / 20)), 0,
                       65535).astype(np.uint16)
    if dtype == "float32":
        return np.minimum(I, 10 ** (db_range / 10)).astype(np.float32)
    if dtype == "float32_db":
        return np.clip(dB, 0, db_range).astype(np.float32)
    raise ValueError("dtype must be 'uint8', 'uint16', 'float32' or 'float32_db'")


# ---------------------------------------------------------------------------------------
# ground truth from geometry

def _shadow_rays(sol, azs, s, R, n_s, H, grid=160, iters=56):
    """For each azimuth in azs (rad): the uppermost ray of that azimuth plane that meets the
    solid (above the seabed) -> elevation, range of its contact (r_top), its seabed range
    (r_shadow_end), the contact height, and the nearest range of the solid in that plane.
    NaN where the plane misses the solid."""
    azs = np.atleast_1d(np.asarray(azs, float))
    m = len(azs)
    v = sol.bc_w - s
    dist = float(np.linalg.norm(v))
    vs = R.T @ v
    elc = math.asin(max(-1.0, min(1.0, vs[2] / dist)))
    ang = math.asin(min(1.0, sol.br / dist)) if dist > sol.br else math.pi / 2
    e0 = max(-math.pi / 2 + 1e-6, elc - ang - 2e-3)
    e1 = min(math.pi / 2 - 1e-6, elc + ang + 2e-3)
    els = np.linspace(e0, e1, grid)

    def probe(az, el):
        d = _unit_dirs(az, el)
        t = sol.intersect_world(s, d @ R.T)
        nd = d @ n_s
        ts = np.where(nd > 1e-12, H / np.where(nd > 1e-12, nd, 1.0), np.inf)
        return t, ts, (t < ts), nd

    A = np.repeat(azs, grid)
    E = np.tile(els, m)
    t, ts, hit, _ = probe(A, E)
    t, hit = t.reshape(m, grid), hit.reshape(m, grid)
    out = {k: np.full(m, np.nan) for k in ("el_top", "r_top", "r_s", "h_c", "r_near")}
    any_hit = hit.any(1)
    if not any_hit.any():
        return out
    k = np.argmax(hit, axis=1)
    idx = np.nonzero(any_hit)[0]
    lo = els[np.maximum(k[idx] - 1, 0)]
    hi = els[k[idx]]
    az = azs[idx]
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        _, _, hm, _ = probe(az, mid)
        hi = np.where(hm, mid, hi)
        lo = np.where(hm, lo, mid)
    tt, tts, _, nd = probe(az, hi)
    out["el_top"][idx] = hi
    out["r_top"][idx] = tt
    out["r_s"][idx] = tts
    out["h_c"][idx] = H - tt * nd
    out["r_near"][idx] = np.where(hit[idx], t[idx], np.inf).min(1)
    return out


def _f(x):
    x = float(x)
    return x if np.isfinite(x) else None


def frame_truth(scene: Scene, pose: SonarPose, settings: FrameSettings = FrameSettings(),
                sonar: SonarParams = SonarParams()) -> dict:
    """Geometry truth of one frame (plain JSON-serialisable dict).

    Per target: id, kind, true max height above the seabed (perpendicular to it), centre
    north/east, the azimuth through the target centre (centre of the solid at half height),
    and along that azimuth: r_top_m (slant range of the shadow-casting contact, the far top
    edge, where the shadow starts), r_shadow_end_m (where that same ray meets the seabed),
    height_contact_m (height of that contact point; = height_m for flat tops), whether the
    whole shadow lies inside the range window and inside the elevation aperture.  Ranges
    are true slant ranges; *_reported_m are on the file's range scale (they differ only if
    the sound speed the sonar assumes is wrong).  'nearest_beam' repeats it along the
    nearest beam's axis and 'shadow_profile' along every beam that crosses the target.
    """
    sb = scene.seabed
    R = pose.rotation()
    s = pose.position()
    n_s = R.T @ sb.normal_down()
    H = sb.perp_distance(s)
    r_file = settings.window.range_m()
    c_ratio = settings.sound_speed_true_mps / settings.c_reported()
    rt0, rt1 = r_file[0] * c_ratio, r_file[-1] * c_ratio
    az_b = np.asarray(sonar.beam_azimuths_deg, float) * DEG
    half = 0.5 * sonar.elevation_aperture_deg * DEG
    off = sonar.elevation_offset_deg * DEG
    axis_w = R[:, 0]
    out = {
        "altitude_perp_m": H,
        "altitude_vertical_m": sb.depth_at(pose.north_m, pose.east_m) - pose.depth_m,
        "seabed_depth_below_sonar_m": sb.depth_at(pose.north_m, pose.east_m),
        "true_pose": {k: float(v) for k, v in asdict(pose).items()},
        "axis_depression_deg": math.degrees(math.asin(axis_w[2])),
        "window": {"start_m": settings.window.start_m, "length_m": settings.window.length_m,
                   "n_samples": int(settings.window.n_samples)},
        "range_true_first_m": float(rt0), "range_true_last_m": float(rt1),
        "sound_speed_true_mps": settings.sound_speed_true_mps,
        "sound_speed_reported_mps": settings.c_reported(),
        "gain_db": settings.gain_db, "tvg": settings.tvg, "dtype": settings.dtype,
        "n_looks": int(settings.n_looks),
        "targets": [],
    }

    def judge(r):
        el_top, r_top, r_s = r["el_top"], r["r_top"], r["r_s"]
        el_near, okn = _seabed_el(np.atleast_1d(r_top), np.atleast_1d(r["az"]), n_s, H)
        el_near = np.where(okn, el_near, np.nan)
        in_win = (r_top >= rt0) & (r_s <= rt1)
        in_ap = (el_top - off >= -half) & (el_near - off <= half)
        return el_near, in_win, in_ap

    for i, t in enumerate(scene.targets):
        sol = _Solid(t, sb)
        c = R.T @ (sol.centre_world() - s)
        az_c = math.atan2(c[1], c[0])
        el_c = math.atan2(c[2], math.hypot(c[0], c[1]))
        jn = int(np.argmin(np.abs(az_b - az_c)))
        # azimuth span of the solid from a cloud of its surface points
        P, _, _ = sol.sample_surface(np.random.default_rng(12345), 5e4, 4000)
        ds = (P - s) @ R
        azp = np.arctan2(ds[:, 1], ds[:, 0])
        beams = np.nonzero((az_b >= azp.min()) & (az_b <= azp.max()))[0]
        azs = np.concatenate([[az_c, az_b[jn]], az_b[beams]])
        sh = _shadow_rays(sol, azs, s, R, n_s, H)
        sh["az"] = azs
        el_near, in_win, in_ap = judge(sh)
        fan = (az_c >= az_b[0]) & (az_c <= az_b[-1])

        def rec(q):
            return {
                "r_top_m": _f(sh["r_top"][q]), "r_shadow_end_m": _f(sh["r_s"][q]),
                "shadow_length_m": _f(sh["r_s"][q] - sh["r_top"][q]),
                "r_top_reported_m": _f(sh["r_top"][q] / c_ratio),
                "r_shadow_end_reported_m": _f(sh["r_s"][q] / c_ratio),
                "r_near_m": _f(sh["r_near"][q]),
                "height_contact_m": _f(sh["h_c"][q]),
                "el_top_deg": _f(math.degrees(sh["el_top"][q])),
                "el_shadow_near_deg": _f(math.degrees(el_near[q])),
                "shadow_in_window": bool(in_win[q]), "shadow_in_aperture": bool(in_ap[q]),
            }
        d = {
            "target_id": int(t.target_id), "kind": t.kind, "height_m": sol.max_height(),
            "length_m": t.length_m, "width_m": t.width_m,
            "north_m": t.north_m, "east_m": t.east_m, "yaw_deg": t.yaw_deg,
            "yaw_rel_heading_deg": (t.yaw_deg - pose.heading_deg + 180) % 360 - 180,
            "reflectivity_db": t.reflectivity_db, "specular_db": t.specular_db,
            "azimuth_deg": math.degrees(az_c), "elevation_deg": math.degrees(el_c),
            "range_centre_m": float(np.linalg.norm(c)),
            "in_fan": bool(fan),
        }
        d.update(rec(0))
        d["shadow_ok"] = bool(d["in_fan"] and d["shadow_in_window"] and d["shadow_in_aperture"])
        nb_rec = rec(1)
        nb_rec.update({"beam": jn, "azimuth_deg": math.degrees(az_b[jn])})
        d["nearest_beam"] = nb_rec
        prof = []
        for q, j in enumerate(beams):
            if np.isfinite(sh["r_top"][q + 2]):
                prof.append({"beam": int(j), "azimuth_deg": math.degrees(az_b[j]),
                             "r_top_m": _f(sh["r_top"][q + 2]), "r_shadow_end_m": _f(sh["r_s"][q + 2]),
                             "height_contact_m": _f(sh["h_c"][q + 2])})
        d["shadow_profile"] = prof
        out["targets"].append(d)
    return out


# ---------------------------------------------------------------------------------------
# files

DEFAULT_KNOWN = OPTIONAL_KEYS


def write_frame_npz(path, frame: dict, known: Sequence[str] = DEFAULT_KNOWN, compressed: bool = True):
    """Write one frame as the project's .npz frame file.

    Required arrays with exact names/dtypes/shapes; of the optional scalars only those in
    `known` (values from frame['reported']; non-finite ones are left out = not known).
    """
    img = np.asarray(frame["image"])
    if img.ndim != 2 or img.dtype not in (np.uint8, np.uint16, np.float32):
        raise ValueError("image must be 2-D uint8, uint16 or float32")
    rng_m = np.asarray(frame["range_m"], np.float64)
    az = np.asarray(frame["beam_azimuth_deg"], np.float64)
    if rng_m.shape != (img.shape[0],) or az.shape != (img.shape[1],):
        raise ValueError("range_m / beam_azimuth_deg do not match the image shape")
    if np.any(np.diff(rng_m) <= 0) or np.any(np.diff(az) <= 0) or rng_m[0] <= 0:
        raise ValueError("range_m and beam_azimuth_deg must be strictly increasing, range > 0")
    arrays = {
        "image": img,
        "range_m": rng_m,
        "beam_azimuth_deg": az,
        "elevation_aperture_deg": np.array(float(frame["elevation_aperture_deg"]), np.float64),
        "timestamp_s": np.array(float(frame["timestamp_s"]), np.float64),
    }
    rep = frame.get("reported", {})
    for k in known:
        if k not in OPTIONAL_KEYS:
            raise KeyError(f"{k!r} is not an optional frame-format key")
        v = rep.get(k)
        if v is not None and np.isfinite(v):
            arrays[k] = np.array(float(v), np.float64)
    with open(path, "wb") as fh:
        (np.savez_compressed if compressed else np.savez)(fh, **arrays)
    return str(path)


def read_frame_npz(path) -> dict:
    """Load and check a single-frame file (shapes, dtypes, monotonicity, finiteness)."""
    with np.load(path) as z:
        d = {k: z[k] for k in z.files}
    for k in REQUIRED_KEYS:
        if k not in d:
            raise ValueError(f"{path}: missing key {k}")
    img = d["image"]
    if img.ndim != 2 or img.dtype not in (np.uint8, np.uint16, np.float32):
        raise ValueError(f"{path}: image has shape {img.shape} dtype {img.dtype}")
    for k, n in (("range_m", img.shape[0]), ("beam_azimuth_deg", img.shape[1])):
        a = d[k]
        if a.dtype != np.float64 or a.shape != (n,) or not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0):
            raise ValueError(f"{path}: bad {k}")
    for k in ("elevation_aperture_deg", "timestamp_s") + OPTIONAL_KEYS:
        if k in d and (d[k].shape != () or d[k].dtype != np.float64):
            raise ValueError(f"{path}: {k} must be a float64 scalar")
    return d


# ---------------------------------------------------------------------------------------
# scene sampling

@dataclass(frozen=True)
class ScenePlan:
    """A scene and the true sonar poses of its frames (one per altitude, moving vertically)."""
    scene: Scene
    poses: tuple
    info: dict = field(default_factory=dict)


def _u(rng, lo, hi):
    return float(rng.uniform(lo, hi))


def _draw_target(rng, kind, h, size_range, tid, north, east, yaw, refl, spec):
    s0, s1 = size_range
    kw = dict(kind=kind, north_m=north, east_m=east, yaw_deg=yaw, height_m=h,
              reflectivity_db=refl, specular_db=spec, target_id=tid)
    if kind == "box":
        L = _u(rng, s0, s1)
        W = _u(rng, s0, s1)
        return Target(length_m=L, width_m=W, **kw)
    if kind == "pipe":
        d = min(s1, max(s0, h / _u(rng, 0.6, 1.0)))
        h = min(h, d)
        kw["height_m"] = h
        return Target(length_m=_u(rng, max(s0, d), s1), width_m=d, **kw)
    if kind == "post":
        d = _u(rng, s0, min(s1, 0.3))
        return Target(length_m=d, width_m=d, **kw)
    if kind == "sphere":
        d = min(s1, max(s0, h / _u(rng, 0.6, 1.0)))
        kw["height_m"] = min(h, d)
        return Target(length_m=d, width_m=d, **kw)
    if kind == "dome":
        return Target(length_m=_u(rng, max(s0, h), s1), width_m=_u(rng, max(s0, h), s1),
                      vertical_semi_axis_m=h * _u(rng, 0.6, 1.5), **kw)
    if kind == "rock":
        return Target(length_m=_u(rng, max(s0, h), s1), width_m=_u(rng, max(s0, h), s1),
                      vertical_semi_axis_m=h * _u(rng, 0.7, 1.2), roughness=_u(rng, 0.1, 0.3),
                      shape_seed=int(rng.integers(0, 2 ** 31)), **kw)
    raise ValueError(f"unknown kind {kind!r}")


def _tilt_for(H, items, rng, jitter_deg, aperture_deg):
    """Axis depression (deg) that puts every target and its shadow inside the aperture.
    items: (ground distance of centre, half extent, height) per target."""
    lo = min(math.atan2(H - h, D + e) for D, e, h in items)          # shadow far end
    hi_t = max(math.atan2(H, max(D - e, 0.02)) for D, e, h in items)  # target front on seabed
    hi_s = max(math.atan2(H, D + e) for D, e, h in items)             # shadow near end
    span_ok = (aperture_deg - 3.0) * DEG
    hi = hi_t if hi_t - lo < span_ok else hi_s
    slack = max(0.0, span_ok - (hi - lo)) / 2
    j = min(jitter_deg * DEG, slack)
    return math.degrees(0.5 * (lo + hi) + rng.uniform(-j, j))


def _check(scene, poses, sonar, margin_deg=0.5):
    big = FrameSettings(window=Window(0.02, 50.0, 2))
    half = 0.5 * sonar.elevation_aperture_deg - margin_deg
    truths = []
    for p in poses:
        tr = frame_truth(scene, p, big, sonar)
        for t in tr["targets"]:
            if not t["in_fan"] or t["r_top_m"] is None or t["r_shadow_end_m"] is None:
                return None
            if t["el_shadow_near_deg"] is None or t["el_top_deg"] < -half or t["el_shadow_near_deg"] > half:
                return None
            nb = t["nearest_beam"]
            if nb["r_top_m"] is None or nb["r_shadow_end_m"] is None:
                return None
        truths.append(tr)
    return truths


def sample_scene(rng, n_targets: int | None = None, kinds: Sequence[str] = TARGET_KINDS,
                 altitude_range_m=(0.4, 1.5), dh_range_m=(0.05, 0.3), height_range_m=(0.02, 0.30),
                 size_range_m=(0.05, 0.60), max_height_fraction: float = 0.35,
                 depression_range_deg=(20.0, 40.0), low_contrast_prob: float = 0.2,
                 specular_prob: float = 0.3, texture_prob: float = 0.3, slope_max: float = 0.0,
                 true_attitude_sigma_deg: float = 0.0, same_tilt: bool = False,
                 tilt_jitter_deg: float = 1.5, sonar: SonarParams = SonarParams(),
                 max_tries: int = 300) -> ScenePlan:
    """Random scene of 1-3 targets whose shadows are inside the fan and the elevation
    aperture at both altitudes.  Frame 0 at altitude H1, frame 1 at H1 + dH (higher, like
    the paper's image 2); the sonar moves only vertically.  Target heights are capped at
    max_height_fraction * H1 (a taller target's shadow cannot fit a 14 deg aperture).
    Every random choice comes from rng.
    """
    half_fan = 0.5 * (sonar.beam_azimuths_deg[-1] - sonar.beam_azimuths_deg[0])
    for attempt in range(max_tries):
        H1 = _u(rng, *altitude_range_m)
        dH = _u(rng, *dh_range_m)
        sb_refl = _u(rng, -26.0, -16.0)
        tex = rng.uniform() < texture_prob
        sb = Seabed(depth_m=_u(rng, 3.0, 30.0),
                    slope_north=_u(rng, -slope_max, slope_max) if slope_max > 0 else 0.0,
                    slope_east=_u(rng, -slope_max, slope_max) if slope_max > 0 else 0.0,
                    reflectivity_db=sb_refl, lambert_exponent=_u(rng, 1.5, 2.5),
                    texture_shape=_u(rng, 1.5, 10.0) if tex else math.inf,
                    texture_scale_m=_u(rng, 0.02, 0.1), texture_seed=int(rng.integers(0, 2 ** 31)))
        heading = _u(rng, 0.0, 360.0)
        nt = int(n_targets) if n_targets else int(rng.integers(1, 4))
        dep0 = _u(rng, *depression_range_deg) * DEG
        D0 = H1 / math.tan(dep0)
        hmax = max(height_range_m[0], min(height_range_m[1], max_height_fraction * H1))
        targets, items = [], []
        usable = half_fan - 2.5                        # keep shadows off the edge beams
        sector = 2 * usable / nt                       # one azimuth sector per target
        for i in range(nt):
            kind = str(rng.choice(list(kinds)))
            refl = sb_refl + (_u(rng, -2.0, 3.0) if rng.uniform() < low_contrast_prob else _u(rng, 6.0, 16.0))
            spec = _u(rng, -25.0, -8.0) if rng.uniform() < specular_prob else -200.0
            D = D0 * _u(rng, 0.85, 1.15)
            yaw_rel = _u(rng, 0.0, 90.0)
            for _ in range(50):   # redraw until the target fits its sector at this distance
                h = _u(rng, height_range_m[0], hmax)
                t = _draw_target(rng, kind, h, size_range_m, i + 1, 0.0, 0.0, heading + yaw_rel, refl, spec)
                ext = 0.5 * math.hypot(t.length_m, t.width_m)
                hw = math.degrees(math.atan2(ext, D)) + 0.5
                if hw <= 0.5 * sector - 0.5:
                    break
            else:
                break
            lo = -usable + i * sector + hw + 0.5
            az = _u(rng, lo, lo + sector - 2 * hw - 1.0)
            b = (heading + az) * DEG
            targets.append(replace(t, north_m=D * math.cos(b), east_m=D * math.sin(b),
                                   yaw_deg=t.yaw_deg % 360.0))
            items.append((D, ext, t.height_m))
        if len(targets) != nt:
            continue
        scene = Scene(sb, tuple(targets))
        z0 = sb.depth_at(0.0, 0.0)
        poses = []
        tilt0 = None
        for f, Hf in enumerate((H1, H1 + dH)):
            pitch = float(rng.normal(0, true_attitude_sigma_deg)) if true_attitude_sigma_deg > 0 else 0.0
            roll = float(rng.normal(0, true_attitude_sigma_deg)) if true_attitude_sigma_deg > 0 else 0.0
            dep = _tilt_for(Hf, items, rng, tilt_jitter_deg, sonar.elevation_aperture_deg)
            tilt = dep + pitch if (tilt0 is None or not same_tilt) else tilt0
            tilt0 = tilt
            poses.append(SonarPose(0.0, 0.0, z0 - Hf, heading, pitch, roll, tilt))
        truths = _check(scene, poses, sonar)
        if truths is None:
            continue
        return ScenePlan(scene, tuple(poses), {"altitudes_m": [H1, H1 + dH], "delta_h_m": dH,
                                               "attempts": attempt + 1})
    raise RuntimeError("sample_scene: no valid scene found; widen the options")


def _window_for(truths, rng, margin_range=(0.15, 0.8), n_samples=1500, min_start=0.3):
    r0 = min(t["r_near_m"] for tr in truths for t in tr["targets"])
    r1 = max(t["r_shadow_end_m"] for tr in truths for t in tr["targets"])
    for tr in truths:
        for t in tr["targets"]:
            for p in t["shadow_profile"]:
                r1 = max(r1, p["r_shadow_end_m"])
    a = _u(rng, *margin_range) if rng is not None else margin_range[0]
    b = _u(rng, *margin_range) if rng is not None else margin_range[0]
    start = max(min_start, r0 - a)
    return Window(start, (r1 + b) - start, int(n_samples))


_REPORT_MODES = ("true", "zero", "noisy")


def _report_for(rng, pose, mode, noise_deg):
    if mode == "true":
        return None
    if mode == "zero":
        return {"vehicle_pitch_deg": 0.0, "vehicle_roll_deg": 0.0}
    if mode == "noisy":
        return {"vehicle_pitch_deg": pose.pitch_deg + float(rng.normal(0, noise_deg)),
                "vehicle_roll_deg": pose.roll_deg + float(rng.normal(0, noise_deg))}
    raise ValueError(f"report_attitude must be one of {_REPORT_MODES}")


def sample_pair(rng, plan: ScenePlan | None = None, vary_window: bool = True,
                vary_gain: bool = True, vary_dtype: bool = False,
                dtypes: Sequence[str] = ("uint8", "uint16", "float32"), dtype: str = "uint8",
                n_samples_range=(1000, 2000), gain_range_db=(-6.0, 6.0), tvg: str = "30log",
                n_looks: int = 1, report_attitude: str = "true", attitude_noise_deg: float = 0.5,
                sound_speed_mps: float = 1480.0, sound_speed_error_mps: float = 0.0,
                sonar: SonarParams = SonarParams(), render: bool = True, timestamp0_s: float = 0.0,
                **scene_options) -> dict:
    """Two frames of one scene from two altitudes (frame 1 is the higher one).

    Window start/length/sample count, gain and dtype are drawn per frame when vary_* is
    set (otherwise one window covering both, gain 0, `dtype`).  report_attitude: 'true'
    (the file reports the true pitch/roll), 'zero' (reports 0: uncorrected attitude) or
    'noisy' (true + N(0, attitude_noise_deg)).  The water's sound speed is
    sound_speed_mps; the sonar assumes sound_speed_mps + sound_speed_error_mps.
    Returns {'plan', 'settings', 'frames' (None if render=False), 'truth'}.
    """
    plan = plan if plan is not None else sample_scene(rng, sonar=sonar, **scene_options)
    big = FrameSettings(window=Window(0.02, 50.0, 2))
    truths_big = [frame_truth(plan.scene, p, big, sonar) for p in plan.poses]
    settings, frames, truths = [], [], []
    if not vary_window:
        ns = int(rng.integers(n_samples_range[0], n_samples_range[1] + 1))
        common = _window_for(truths_big, rng, n_samples=ns)
    for f, pose in enumerate(plan.poses):
        if vary_window:
            ns = int(rng.integers(n_samples_range[0], n_samples_range[1] + 1))
            win = _window_for([truths_big[f]], rng, n_samples=ns)
        else:
            win = common
        st = FrameSettings(
            window=win,
            gain_db=_u(rng, *gain_range_db) if vary_gain else 0.0,
            tvg=tvg,
            dtype=str(rng.choice(list(dtypes))) if vary_dtype else dtype,
            n_looks=n_looks,
            timestamp_s=timestamp0_s + 2.0 * f,
            sound_speed_true_mps=sound_speed_mps,
            sound_speed_reported_mps=sound_speed_mps + sound_speed_error_mps,
        )
        rep = _report_for(rng, pose, report_attitude, attitude_noise_deg)
        settings.append(st)
        if render:
            fr, tr = render_frame(plan.scene, pose, st, sonar, rng, report=rep)
            frames.append(fr)
        else:
            tr = frame_truth(plan.scene, pose, st, sonar)
        tr["reported_overrides"] = rep
        truths.append(tr)
    return {"plan": plan, "settings": settings, "frames": frames if render else None, "truth": truths}


def render_plan(plan: ScenePlan, settings: Sequence[FrameSettings], rng, sonar: SonarParams = SonarParams(),
                reports: Sequence[dict | None] | None = None):
    """Render every pose of a plan with its settings; returns (frames, truths)."""
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    frames, truths = [], []
    for i, (p, st) in enumerate(zip(plan.poses, settings)):
        fr, tr = render_frame(plan.scene, p, st, sonar, rng, report=(reports[i] if reports else None))
        frames.append(fr)
        truths.append(tr)
    return frames, truths


PAPER_TABLE_I_CM = ((19, 19, 2.8), (10, 5, 3.9), (5, 4, 4.7), (9, 4, 3.0), (6, 5, 2.8))


def paper_targets(orientation_deg: float = 0.0, altitudes_m=(0.5, 0.6), ground_distance_m: float = 1.0,
                  water_depth_m: float = 0.85, n_samples: int = 1200, target_reflectivity_db: float = -8.0,
                  seabed: Seabed | None = None, sonar: SonarParams = SonarParams(),
                  per_frame_tilt: bool = True) -> list:
    """The paper's five Table I boxes, one per scene, in a tank-like setup.

    The sonar (heading north, level vehicle) looks along the tank at altitude
    altitudes_m[0] then altitudes_m[1] (image 2 higher, as in the paper); each box sits
    ground_distance_m ahead on the beam axis (azimuth 0), yawed orientation_deg to that
    beam.  The tilt is chosen per frame (or once) so target and shadow are in the 14 deg
    aperture, and one range window covers both frames.  Returns a list of 5 dicts
    {'plan': ScenePlan, 'settings': [FrameSettings, FrameSettings], 'gt_height_m'}.
    Nothing is random here: render with render_plan(plan, settings, rng).
    """
    sb = seabed if seabed is not None else Seabed(depth_m=water_depth_m, reflectivity_db=-20.0)
    out = []
    for i, (L, W, Hc) in enumerate(PAPER_TABLE_I_CM):
        t = Target("box", ground_distance_m, 0.0, L / 100, W / 100, Hc / 100, yaw_deg=orientation_deg,
                   reflectivity_db=target_reflectivity_db, target_id=i + 1)
        scene = Scene(sb, (t,))
        ext = 0.5 * math.hypot(t.length_m, t.width_m)
        deps = [math.degrees(0.5 * (math.atan2(H - t.height_m, ground_distance_m + ext)
                                    + math.atan2(H, max(ground_distance_m - ext, 0.02))))
                for H in altitudes_m]
        if not per_frame_tilt:
            deps = [float(np.mean(deps))] * len(deps)
        poses = tuple(SonarPose(0.0, 0.0, sb.depth_at(0, 0) - H, 0.0, 0.0, 0.0, d)
                      for H, d in zip(altitudes_m, deps))
        big = FrameSettings(window=Window(0.02, 50.0, 2))
        tb = [frame_truth(scene, p, big, sonar) for p in poses]
        win = _window_for(tb, None, margin_range=(0.25, 0.25), n_samples=n_samples)
        settings = [FrameSettings(window=win, timestamp_s=2.0 * k) for k in range(len(poses))]
        out.append({"plan": ScenePlan(scene, poses, {"altitudes_m": list(altitudes_m),
                                                     "delta_h_m": altitudes_m[1] - altitudes_m[0],
                                                     "orientation_deg": orientation_deg}),
                    "settings": settings, "gt_height_m": Hc / 100})
    return out


# ---------------------------------------------------------------------------------------
# pictures (no plotting library needed)

def display_db(frame, db_range: float = 80.0) -> np.ndarray:
    """The frame's image as dB (0..db_range) whatever its dtype."""
    img = np.asarray(frame["image"])
    if img.dtype == np.uint8:
        return img.astype(float) * db_range / 255.0
    if img.dtype == np.uint16:
        with np.errstate(divide="ignore"):
            return np.clip(db_range + 20 * np.log10(np.maximum(img, 1) / 65535.0), 0, db_range)
    with np.errstate(divide="ignore"):
        return np.clip(10 * np.log10(np.maximum(img.astype(float), 1e-30)), 0, db_range)


def polar_image(frame, lo_db=None, hi_db=None) -> np.ndarray:
    """uint8 picture of the polar image, nearest range at the bottom."""
    d = display_db(frame)
    lo = np.percentile(d, 1) if lo_db is None else lo_db
    hi = np.percentile(d, 99.7) if hi_db is None else hi_db
    return np.clip((d - lo) / max(hi - lo, 1e-9) * 255, 0, 255).astype(np.uint8)[::-1]


def fan_image(frame, width_px: int = 700, lo_db=None, hi_db=None) -> np.ndarray:
    """uint8 Cartesian fan view (sonar at the bottom centre), nearest-neighbour resampled."""
    pol = polar_image(frame, lo_db, hi_db)[::-1]
    r = np.asarray(frame["range_m"])
    az = np.asarray(frame["beam_azimuth_deg"]) * DEG
    rmax = r[-1]
    xmax = rmax * math.sin(max(abs(az[0]), abs(az[-1])))
    ymin = r[0] * math.cos(max(abs(az[0]), abs(az[-1])))
    scale = width_px / (2 * xmax)
    hpx = int(math.ceil((rmax - ymin) * scale)) + 1
    X, Y = np.meshgrid((np.arange(width_px) + 0.5) / scale - xmax, rmax - (np.arange(hpx) + 0.5) / scale)
    rr = np.hypot(X, Y)
    aa = np.arctan2(X, Y)
    ri = np.rint((rr - r[0]) / (r[1] - r[0])).astype(int)
    half = np.diff(az).mean() / 2
    bj = np.clip(np.searchsorted(az, aa), 1, len(az) - 1)
    bj = np.where(np.abs(aa - az[bj - 1]) < np.abs(aa - az[bj]), bj - 1, bj)
    inside = (ri >= 0) & (ri < len(r)) & (aa >= az[0] - half) & (aa <= az[-1] + half)
    out = np.zeros(rr.shape, np.uint8)
    out[inside] = pol[ri[inside], bj[inside]]
    return out


def save_png(path, img) -> str:
    """Write a 2-D uint8 array as an 8-bit greyscale PNG (zlib + struct only)."""
    img = np.ascontiguousarray(np.asarray(img, np.uint8))
    h, w = img.shape
    raw = b"".join(b"\x00" + img[y].tobytes() for y in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    with open(path, "wb") as fh:
        fh.write(png)
    return str(path)


def write_pair_files(result: dict, out_dir, prefix: str = "frame", known: Sequence[str] = DEFAULT_KNOWN) -> dict:
    """Write the frames of a sample_pair() result as <prefix>_<i>.npz plus <prefix>_truth.json.

    The truth file holds per-frame truth and the scene (targets, seabed, true poses).
    Returns {'frames': [paths], 'truth': path}."""
    import json
    import os
    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for i, fr in enumerate(result["frames"]):
        paths.append(write_frame_npz(os.path.join(out_dir, f"{prefix}_{i}.npz"), fr, known))
    plan = result["plan"]
    doc = {
        "frames": [os.path.basename(p) for p in paths],
        "known": list(known),
        "scene": {"seabed": asdict(plan.scene.seabed), "targets": [asdict(t) for t in plan.scene.targets]},
        "poses_true": [asdict(p) for p in plan.poses],
        "info": plan.info,
        "truth": result["truth"],
    }
    tpath = os.path.join(out_dir, f"{prefix}_truth.json")
    with open(tpath, "w") as fh:
        json.dump(doc, fh, indent=1, default=lambda o: None if o is None else float(o))
    return {"frames": paths, "truth": tpath}
