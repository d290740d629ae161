"""Choice of the two survey altitudes and the mount tilt at each (casadi + ipopt).

Model (flat seabed, level vehicle, see ``docs/architecture.md``): a thin target of
height ``h`` whose top is at ground range ``g`` ahead of a sonar at altitude ``H`` has its
top edge at slant range ``r_top = sqrt(g^2 + (H - h)^2)``; its shadow ends where the same
ray meets the seabed, ``r_s = r_top H / (H - h)``, so the shadow is
``L = r_s - r_top = r_top h / (H - h)`` long in range and

    dL/dh = r_top H / (H - h)^2 - h / r_top.

The survey flies the same ground at ``H1`` and ``H2 = H1 + dH``. What resolves heights is
how much the *change* of shadow length between the two altitudes moves per centimetre
of target height, ``d(L1 - L2)/dh`` (the same target, top at the same ground range
``g``), counted in range samples. The choice maximises its worst case over the expected
target heights, over ``(H1, dH, tilt1, tilt2, g)``, subject to:

- clearance: ``H1 - h_max >= min_clearance + depth_hold`` (the vehicle's depth-hold error
  kept above the lowest allowed altitude);
- depth limit and surface: ``min_depth <= water_depth - H <= max_depth``;
- ``dH >= dh_min_over_std * filter_dh_std`` (dH large against the filter's uncertainty);
- for each pass and each expected height, the whole shadow inside the range window
  (``r_top >= window_start + margin``, ``r_s <= window_end - margin``) and inside the
  vertical beam (the seabed behind the target no nearer than the band's near edge, the
  shadow end no farther than its far edge);
- each pass alone still resolves heights: ``dL/dh >= min_pass_samples_per_cm``;
- altitudes within ``[altitude_min, altitude_max]``, tilts within the mount's limits.

The objective does not fix the tilts inside the range where the shadow fits, so a
second solve keeps the optimal resolution and centres the design shadow on each beam
axis (tilt = depression of the seabed at the middle of the shadow).

When ipopt finds no feasible point, a phase-1 problem with a slack on every named
constraint finds the constraints that cannot be met and :class:`InfeasibleError` names
them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from perception.geometry.shadow import shadow_end_slant_m, shadow_scale
from planner.config import Settings
from planner.errors import InfeasibleError

#: Tolerance on constraint values (m or samples) accepted as met.
FEASIBILITY_TOL = 1e-5

#: The main solve asks every constraint to hold by this much, so that rounding never
#: puts the answer on the wrong side of a limit such as the clearance.
INTERIOR_M = 1e-6

#: Least height of the sonar above the tallest target the model considers, m.
ABOVE_TARGET_M = 1e-3

#: What each named constraint means, for error messages.
CONSTRAINT_TEXT = {
    "clearance": "clearance over the tallest target (site.target_height_max_m + "
    "vehicle.min_clearance_m)",
    "depth_limit": "vehicle depth limit (vehicle.max_depth_m vs site.water_depth_m)",
    "surface": "minimum depth below the surface (vehicle.min_depth_m)",
    "dh_vs_filter": "dH large against the altitude filter's uncertainty "
    "(altitudes.filter_dh_std_m x altitudes.dh_min_over_std)",
    "window_start": "shadow's target top after the range window start (sonar.window_start_m)",
    "window_end": "shadow end before the range window end (sonar.window_end_m)",
    "beam_near": "shadow inside the vertical beam, near edge (sonar.elevation_aperture_deg)",
    "beam_far": "shadow inside the vertical beam, far edge (sonar.elevation_aperture_deg)",
    "pass_sensitivity": "each pass alone resolves heights (altitudes.min_pass_samples_per_cm)",
}


@dataclass(frozen=True)
class AltitudeChoice:
    """The chosen altitudes and tilts with the predicted height resolution.

    Attributes
    ----------
    altitude1_m, delta_altitude_m : float
        Lower altitude above the seabed and the climb to the second, m.
    tilt1_rad, tilt2_rad : float
        Mount depression at each altitude, rad (positive down).
    design_ground_range_m : float
        Ground range of the target top at which both passes see the whole shadow, m.
    samples_per_cm : float
        Worst-case change of ``L1 - L2`` per cm of target height, range samples.
    pass_samples_per_cm : tuple of float
        Worst-case ``dL/dh`` of each pass alone, range samples per cm.
    height_resolution_m : float
        Height change that moves ``L1 - L2`` by one range sample (worst case), m.
    height_std_from_dh_m : float
        Height error of the tallest target from the filter's dH std, m.
    binding : tuple of str
        Names of the constraints active at the optimum.
    """

    altitude1_m: float
    delta_altitude_m: float
    tilt1_rad: float
    tilt2_rad: float
    design_ground_range_m: float
    samples_per_cm: float
    pass_samples_per_cm: tuple[float, float]
    height_resolution_m: float
    height_std_from_dh_m: float
    binding: tuple[str, ...]

    @property
    def altitude2_m(self) -> float:
        """The upper altitude, m."""
        return self.altitude1_m + self.delta_altitude_m


def shadow_length_m(altitude_m: Any, height_m: Any, ground_m: Any, sqrt: Callable = np.sqrt) -> Any:
    """Shadow length in slant range, ``r_s - r_top``, m (numpy or casadi arguments)."""
    r_top = sqrt(ground_m * ground_m + (altitude_m - height_m) ** 2)
    return shadow_end_slant_m(r_top, altitude_m, height_m) - r_top


def shadow_slope(altitude_m: Any, height_m: Any, ground_m: Any, sqrt: Callable = np.sqrt) -> Any:
    """``dL/dh``: shadow length change per metre of target height (dimensionless)."""
    r_top = sqrt(ground_m * ground_m + (altitude_m - height_m) ** 2)
    return r_top * altitude_m / (altitude_m - height_m) ** 2 - height_m / r_top


def _constraints(
    x: Any, settings: Settings, sqrt: Callable, sin: Callable
) -> list[tuple[str, Any]]:
    """Named constraint values, each to be >= 0, for ``x = (H1, dH, t1, t2, g)``."""
    h1, dh, t1, t2, g = x[0], x[1], x[2], x[3], x[4]
    sonar, vehicle, site, alt = settings.sonar, settings.vehicle, settings.site, settings.altitudes
    half_ap = sonar.elevation_aperture_rad / 2.0
    margin = alt.shadow_margin_m
    per_cm = 0.01 / sonar.range_resolution_m
    out: list[tuple[str, Any]] = [
        # the lower pass this far above the lowest allowed altitude (the vehicle's depth hold)
        ("clearance", h1 - site.target_height_max_m - vehicle.min_clearance_m - vehicle.depth_hold_m),
        ("depth_limit", vehicle.max_depth_m - (site.water_depth_m - h1)),
        ("surface", site.water_depth_m - (h1 + dh) - vehicle.min_depth_m),
        ("dh_vs_filter", dh - alt.dh_min_over_std * alt.filter_dh_std_m),
    ]
    heights = (site.target_height_min_m, site.target_height_max_m)
    for k, (altitude, tilt) in enumerate(((h1, t1), (h1 + dh, t2)), start=1):
        h_max = heights[1]
        r_top = sqrt(g * g + (altitude - h_max) ** 2)
        r_s = shadow_end_slant_m(r_top, altitude, h_max)
        seabed_slant = sqrt(g * g + altitude * altitude)
        out += [
            (f"window_start_pass{k}", r_top - sonar.window_start_m - margin),
            (f"window_end_pass{k}", sonar.window_end_m - margin - r_s),
            (f"beam_near_pass{k}", (seabed_slant - margin) * sin(tilt + half_ap) - altitude),
            (f"beam_far_pass{k}", altitude - (r_s + margin) * sin(tilt - half_ap)),
            (
                f"pass_sensitivity_pass{k}",
                shadow_slope(altitude, heights[0], g, sqrt) * per_cm - alt.min_pass_samples_per_cm,
            ),
        ]
    return out


def _objective_terms(x: Any, settings: Settings, sqrt: Callable) -> list[Any]:
    """``d(L1 - L2)/dh`` in samples per cm at each expected height."""
    h1, dh, g = x[0], x[1], x[4]
    per_cm = 0.01 / settings.sonar.range_resolution_m
    heights = (settings.site.target_height_min_m, settings.site.target_height_max_m)
    return [
        (shadow_slope(h1, h, g, sqrt) - shadow_slope(h1 + dh, h, g, sqrt)) * per_cm for h in heights
    ]


def _np_constraints(x: np.ndarray, settings: Settings) -> dict[str, float]:
    return {n: float(v) for n, v in _constraints(x, settings, math.sqrt, math.sin)}


def _bounds(settings: Settings) -> tuple[list[float], list[float]]:
    alt, veh, sonar = settings.altitudes, settings.vehicle, settings.sonar
    t_lo = max(veh.tilt_min_rad, -math.pi / 2 + sonar.elevation_aperture_rad)
    t_hi = min(veh.tilt_max_rad, math.pi / 2 - 1e-3)
    # The sonar must at least be above the tallest target (the model divides by H - h).
    h_lo = max(alt.altitude_min_m, settings.site.target_height_max_m + ABOVE_TARGET_M)
    lbx = [h_lo, 0.0, t_lo, t_lo, 0.05]
    ubx = [alt.altitude_max_m, max(alt.altitude_max_m - h_lo, 0.0), t_hi, t_hi, sonar.window_end_m]
    return lbx, ubx


_IPOPT_OPTS: dict[str, Any] = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
               "ipopt.max_iter": 500, "ipopt.tol": 1e-9}


def _starts(settings: Settings) -> list[list[float]]:
    """Initial guesses, inside the variable bounds."""
    lbx, ubx = _bounds(settings)
    h_lo = max(lbx[0], settings.min_altitude_m + settings.vehicle.depth_hold_m)
    dh0 = max(settings.altitudes.dh_min_over_std * settings.altitudes.filter_dh_std_m, 0.1)
    mid_t = math.radians(20.0)
    g0 = 0.5 * settings.sonar.window_end_m
    starts = [
        [h_lo + 0.1, dh0, mid_t, mid_t, g0],
        [0.5 * (lbx[0] + ubx[0]), 0.25 * (ubx[0] - lbx[0]), mid_t, mid_t, 0.7 * g0],
    ]
    return [[min(max(v, lo), hi) for v, lo, hi in zip(x, lbx, ubx, strict=True)] for x in starts]


def _solve_main(settings: Settings) -> np.ndarray | None:
    import casadi as ca  # the NLP solver: loaded when a survey is planned

    x = ca.SX.sym("x", 5)
    tau = ca.SX.sym("tau")
    cons = _constraints(x, settings, ca.sqrt, ca.sin)
    terms = _objective_terms(x, settings, ca.sqrt)
    alt = settings.altitudes
    g_expr = ca.vertcat(
        *[c for _, c in cons],
        *[t - tau for t in terms],
        alt.altitude_max_m - (x[0] + x[1]),
    )
    nlp = {"x": ca.vertcat(x, tau), "f": -tau, "g": g_expr}
    solver = ca.nlpsol("altitudes", "ipopt", nlp, _IPOPT_OPTS)
    lbx, ubx = _bounds(settings)
    best: np.ndarray | None = None
    best_tau = -math.inf
    for start in _starts(settings):
        res = solver(
            x0=start + [0.0],
            lbx=lbx + [-1e3],
            ubx=ubx + [1e3],
            lbg=INTERIOR_M,
            ubg=math.inf,
        )
        sol = np.asarray(res["x"]).ravel()
        xs = sol[:5]
        if not _feasible(xs, settings):
            continue
        if sol[5] > best_tau:
            best, best_tau = xs, float(sol[5])
    if best is None:
        return None
    centred = _centre_tilts(settings, best, best_tau)
    return best if centred is None else centred


def _centre_tilts(settings: Settings, x0: np.ndarray, tau: float) -> np.ndarray | None:
    """Second stage: among the choices that keep the optimal resolution ``tau``, the one
    whose tilts put the middle of the design shadow on the beam axis (the objective does
    not depend on the tilts otherwise, so they would be arbitrary within the beam)."""
    import casadi as ca  # the NLP solver: loaded when a survey is planned

    x = ca.SX.sym("x", 5)
    cons = _constraints(x, settings, ca.sqrt, ca.sin)
    terms = _objective_terms(x, settings, ca.sqrt)
    h_max = settings.site.target_height_max_m
    miss = ca.SX(0.0)
    for altitude, tilt in ((x[0], x[2]), (x[0] + x[1], x[3])):
        g_mid = x[4] * (1.0 + shadow_scale(altitude, h_max)) / 2.0  # middle of the shadow
        miss += (tilt - ca.atan2(altitude, g_mid)) ** 2
    keep = tau - 1e-6 * abs(tau) - 1e-9
    g_expr = ca.vertcat(*[c for _, c in cons], *[t - keep for t in terms],
                        settings.altitudes.altitude_max_m - (x[0] + x[1]))
    solver = ca.nlpsol("centre", "ipopt", {"x": x, "f": miss, "g": g_expr}, _IPOPT_OPTS)
    lbx, ubx = _bounds(settings)
    res = solver(x0=list(x0), lbx=lbx, ubx=ubx, lbg=INTERIOR_M, ubg=math.inf)
    xs = np.asarray(res["x"]).ravel()
    if not _feasible(xs, settings) or min(_objective_terms(xs, settings, math.sqrt)) < keep - 1e-9:
        return None
    return xs


def _feasible(x: np.ndarray, settings: Settings) -> bool:
    lbx, ubx = _bounds(settings)
    if any(v < lo - 1e-7 or v > hi + 1e-7 for v, lo, hi in zip(x, lbx, ubx, strict=True)):
        return False
    if x[0] + x[1] > settings.altitudes.altitude_max_m + 1e-7:
        return False
    return min(_np_constraints(x, settings).values()) >= -FEASIBILITY_TOL


#: Constraints that protect the vehicle; the diagnosis first keeps them hard.
SAFETY = ("clearance", "depth_limit", "surface", "dh_vs_filter")


def _phase1(settings: Settings, hard: tuple[str, ...]) -> list[tuple[str, float]] | None:
    """Minimise the summed slack of the soft constraints with ``hard`` ones kept; the
    constraints still short at the best start, or None when even that fails."""
    import casadi as ca  # the NLP solver: loaded when a survey is planned

    x = ca.SX.sym("x", 5)
    cons = _constraints(x, settings, ca.sqrt, ca.sin)
    soft = [i for i, (n, _) in enumerate(cons) if n not in hard]
    s = ca.SX.sym("s", len(soft))
    slack = {i: s[j] for j, i in enumerate(soft)}
    g_expr = ca.vertcat(
        *[c + slack[i] if i in slack else c for i, (_, c) in enumerate(cons)],
        settings.altitudes.altitude_max_m - (x[0] + x[1]),
    )
    solver = ca.nlpsol("phase1", "ipopt", {"x": ca.vertcat(x, s), "f": ca.sum1(s), "g": g_expr},
                       _IPOPT_OPTS)
    lbx, ubx = _bounds(settings)
    best: list[tuple[str, float]] | None = None
    best_total = math.inf
    for start in _starts(settings):
        res = solver(x0=start + [1.0] * len(soft), lbx=lbx + [0.0] * len(soft),
                     ubx=ubx + [1e6] * len(soft), lbg=0.0, ubg=math.inf)
        xs = np.asarray(res["x"]).ravel()[:5]
        values = _np_constraints(xs, settings)
        if any(values[n] < -1e-6 for n in hard if n in values):
            continue
        if xs[0] + xs[1] > settings.altitudes.altitude_max_m + 1e-6:
            continue
        short = [(n, -v) for n, v in values.items() if v < -1e-4]
        total = sum(v for _, v in short)
        if total < best_total:
            best, best_total = short, total
    return best


def _diagnose(settings: Settings) -> list[tuple[str, float]]:
    """Which constraints cannot be met: first with the vehicle's safety constraints kept
    (so the sensing constraint at fault is named), else with all of them softened."""
    for hard in (SAFETY, ()):
        short = _phase1(settings, hard)
        if short:
            return sorted(short, key=lambda item: -item[1])
    return []


def _describe(name: str) -> str:
    base = name.rsplit("_pass", 1)[0]
    suffix = f" at altitude {name[-1]}" if "_pass" in name else ""
    return f"{name}: {CONSTRAINT_TEXT.get(base, base)}{suffix}"


def choose_altitudes(settings: Settings) -> AltitudeChoice:
    """Choose ``H1``, ``dH`` and both tilts (see the module docstring).

    Raises
    ------
    InfeasibleError
        When no choice satisfies the constraints; ``reason`` names the constraints that
        cannot be met and by how much.
    """
    alt = settings.altitudes
    dh_min = alt.dh_min_over_std * alt.filter_dh_std_m
    above = settings.site.target_height_max_m + ABOVE_TARGET_M
    if above + dh_min > alt.altitude_max_m:
        raise InfeasibleError(
            f"clearance: the tallest target ({settings.site.target_height_max_m:g} m) plus dH "
            f"({dh_min:g} m) does not fit below altitudes.altitude_max_m ({alt.altitude_max_m:g} m)"
        )
    if alt.altitude_min_m + dh_min > alt.altitude_max_m:
        raise InfeasibleError(
            f"dh_vs_filter: the altitude range {alt.altitude_min_m:g}-{alt.altitude_max_m:g} m "
            f"is narrower than the smallest dH {dh_min:g} m (altitudes.*)"
        )
    x = _solve_main(settings)
    if x is None:
        short = _diagnose(settings)
        if not short:
            raise InfeasibleError("no feasible altitudes and tilts found (solver failed)")
        parts = [f"{_describe(n)} short by {v:.3g}" for n, v in short]
        raise InfeasibleError("no feasible altitudes and tilts: " + "; ".join(parts))
    terms = [float(t) for t in _objective_terms(x, settings, math.sqrt)]
    per_cm = 0.01 / settings.sonar.range_resolution_m
    h_min = settings.site.target_height_min_m
    pass_s = tuple(
        float(shadow_slope(a, h_min, x[4], math.sqrt) * per_cm) for a in (x[0], x[0] + x[1])
    )
    worst = min(terms)
    values = _np_constraints(x, settings)
    binding = tuple(sorted(n for n, v in values.items() if abs(v) < 1e-4))
    return AltitudeChoice(
        altitude1_m=float(x[0]),
        delta_altitude_m=float(x[1]),
        tilt1_rad=float(x[2]),
        tilt2_rad=float(x[3]),
        design_ground_range_m=float(x[4]),
        samples_per_cm=worst,
        pass_samples_per_cm=(pass_s[0], pass_s[1]),
        height_resolution_m=0.01 / worst if worst > 0 else math.inf,
        height_std_from_dh_m=settings.site.target_height_max_m * alt.filter_dh_std_m / float(x[1]),
        binding=binding,
    )


def constraint_values(choice: AltitudeChoice, settings: Settings) -> dict[str, float]:
    """The named constraint values (>= 0 when met) at a choice; for reports and tests."""
    x = np.array([choice.altitude1_m, choice.delta_altitude_m, choice.tilt1_rad,
                  choice.tilt2_rad, choice.design_ground_range_m])
    return _np_constraints(x, settings)
