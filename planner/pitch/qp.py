"""The pitch loop: a short-horizon QP (casadi) that moves the sonar tilt mount so that the
whole cast shadow of every tracked target stays inside the vertical field of view.

Frames and signs are those of :mod:`perception.geometry`. Here the *level frame* is the
vehicle's heading frame: ``along_m`` forward along the heading (horizontal), ``cross_m``
to starboard, ``depth_m`` down, origin at the sonar's acoustic centre. Roll is ignored.

Geometry (flat seabed, sonar at altitude ``H``). The beam axis has depression
``d = tilt - pitch`` (tilt positive down, pitch positive nose up). A point at level
position ``(x, y, z)`` has, in the sonar frame, elevation ``e`` with
``sin e = k sin(delta' - d)``, where ``delta' = atan2(z, x)`` is the depression of its
projection on the vertical plane of the heading and ``k = hypot(x, z) / |p|``. So the
point is inside the vertical aperture ``a`` with elevation margin ``m`` exactly when

    delta' - w <= d <= delta' + w,   w = asin(min(1, sin(a/2 - m) / k))

which is *linear in d* (for a point on the axis, ``k = 1`` and ``w = a/2 - m``).

A target of height ``h`` with its far top edge at ``(x, y)`` and a footprint ``f``
(horizontal extent from its near foot to its far top edge, 0 for a post): the ray through
the top edge meets the seabed at the shadow end ``(x, y) H / (H - h)`` (slant
``r_end = r_top H / (H - h)``); top edge and shadow end share one ray and so one
elevation. The whole shadow is seen when the top/end ray, the far foot ``(x, y, H)``
and the near foot are all inside the aperture (the seabed between them lies between
these rays), and the slant ranges of the near foot and the shadow end lie inside the
range window. Each such target gives one interval ``[lo, hi]`` of ``d`` per step; the
range window cannot be fixed by tilting and only decides whether a target is served.

The QP over ``N`` steps of ``dt`` (decision ``tilt_1..tilt_N``, the mount angle held
through step ``k``, so it must suit the geometry at both of the step's ends):
``lo_ik + pitch_k + e <= tilt_k <= hi_ik + pitch_k - e`` softened by a
slack ``s_ik >= 0`` (L1 + L2 cost with a large weight, so it is met whenever it can
be), ``e`` the pitch-prediction envelope over one step, ``|tilt_k - tilt_{k-1}| <=
rate dt``, tilt limits as bounds, a small pull toward the nominal tilt (the planner's
tilt for this altitude: seabed coverage for the mosaic), an optional soft band on the
depression for coverage, and a weight on tilt increments (smoothness, no limit cycles).
The problem's structure is built once per number of targets served (a casadi ``conic``,
default plugin daqp; 0 to ``max_targets`` slots, each built when first needed); every step
re-solves the one for its targets with new bounds, linear terms and slack weights. A slot
left empty would only add slacks with no constraint on them, held at zero by their own
cost: the same optimum, but an active-set solver spends an iteration on each such bound
(a field survey has no target in the zone most of the time: 0.7 against 0.14 ms a solve).

Targets that no tilt can serve (behind, outside the fan, outside the range window,
nearer than 2 altitudes, a shadow spanning more than the aperture, beyond the mount
limits) are dropped with a reason instead of dragging the beam. The window and zone
checks are widened by a lead (serve a little early and late, against prediction errors);
a target only within the lead band has its slack weighed far less, so it never pulls the
beam off a target properly within range. The *tracking zone* (one tilt holds every
shadow in it) is served in full; the *near band* between 2 altitudes and the zone's start
is served with a lower weight and yields in any conflict with the zone, so the beam
follows a target in as far as it costs no shadow in the zone.

Everything here is pure: no sockets, clocks, threads or files; the caller times solves.
:func:`simulate_pass` is a small closed-loop kinematic simulation used by the tests and
the benchmark."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca
import numpy as np

from planner.pitch.config import MountLimits, PitchLoopConfig
from planner.pitch.prediction import search_band_rad
from planner.pitch.selection import select_shadows, served_margins
from planner.pitch.types import PitchCommand, PitchState, TrackedShadow


class _Qp:
    """The QP's structure for ``m`` target slots (module docstring), built once, and its
    solver evaluated on numpy arrays in place."""

    def __init__(self, config: PitchLoopConfig, m: int):
        n = config.horizon_steps
        self.m = m
        nx = n + n * m + n + n  # tilts, target slacks (step-major), coverage slacks, search slacks
        self.nx = nx
        s0, c0, q0 = n, n + n * m, n + n * m + n
        hess = np.zeros((nx, nx))
        wi, wn = config.weight_increment, config.weight_nominal
        for k in range(n):
            hess[k, k] += 2.0 * (wi + wn) + (2.0 * wi if k < n - 1 else 0.0)
            if k < n - 1:
                hess[k, k + 1] = hess[k + 1, k] = -2.0 * wi
        hess[s0:c0, s0:c0] = np.eye(n * m) * 2.0 * config.weight_slack_l2
        hess[c0:q0, c0:q0] = np.eye(n) * 2.0 * config.weight_coverage
        hess[q0:, q0:] = np.eye(n) * 2.0 * config.weight_slack_l2 * max(config.search_weight_factor, 1e-3)
        rows = 2 * n * m + 2 * n + (n - 1) + 2 * n
        a = np.zeros((rows, nx))
        r = 0
        for k in range(n):
            for i in range(m):
                a[r, k], a[r, s0 + k * m + i] = 1.0, 1.0
                a[r + 1, k], a[r + 1, s0 + k * m + i] = 1.0, -1.0
                r += 2
        for k in range(n):
            a[r, k], a[r, c0 + k] = 1.0, 1.0
            a[r + 1, k], a[r + 1, c0 + k] = 1.0, -1.0
            r += 2
        for k in range(1, n):
            a[r, k], a[r, k - 1] = 1.0, -1.0
            r += 1
        for k in range(n):
            a[r, k], a[r, q0 + k] = 1.0, 1.0
            a[r + 1, k], a[r + 1, q0 + k] = 1.0, -1.0
            r += 2
        self.rows = rows
        self.s0, self.c0, self.q0 = s0, c0, q0
        self._hess_dm, self.a_dm = ca.sparsify(ca.DM(hess)), ca.sparsify(ca.DM(a))
        opts: dict[str, Any] = {"error_on_fail": False}
        if config.solver == "qpoases":
            opts["printLevel"] = "none"
        elif config.solver == "highs":
            opts["highs"] = {"output_flag": False}
        self.hess_sp = self._hess_dm.sparsity()
        self.hess_nz = np.asarray(self._hess_dm.nonzeros(), dtype=np.float64)
        nz_rows = np.asarray(self.hess_sp.row())
        nz_cols = np.asarray(self.hess_sp.get_col())
        diag = {int(r): j for j, (r, c) in enumerate(zip(nz_rows, nz_cols, strict=True)) if r == c}
        self.slack_nz = np.array([diag[s0 + j] for j in range(n * m)], dtype=np.intp)  # slack j = k * m + slot
        self.solver = ca.conic("pitch_loop_qp", config.solver,
                                {"h": self._hess_dm.sparsity(), "a": self.a_dm.sparsity()}, opts)
        # The solver evaluated on numpy arrays it reads and writes in place (casadi's
        # FunctionBuffer), the same numbers as a call with DMs without converting them each step.
        self._buffer, self._evaluate = self.solver.buffer()
        self._args: dict[str, np.ndarray] = {}
        fixed = {"h": self._hess_dm, "a": self.a_dm}
        for i, name in enumerate(self.solver.name_in()):
            sp = self.solver.sparsity_in(i)
            if name in fixed and fixed[name].sparsity() != sp:
                raise RuntimeError(f"casadi changed the sparsity of the QP's {name}")  # never: built from them
            self._args[name] = np.array(fixed[name].nonzeros() if name in fixed else
                                        np.full(sp.nnz(), self.solver.default_in(i)), dtype=np.float64)
            # One memoryview fills the C++ (buffer, size in bytes) pair that casadi's stubs list.
            self._buffer.set_arg(i, memoryview(self._args[name]))  # type: ignore[call-arg, arg-type]
        self._x = np.zeros(self.solver.sparsity_out(0).nnz())
        self._outs = [self._x] + [np.zeros(self.solver.sparsity_out(i).nnz()) for i in range(1, self.solver.n_out())]
        for i, out in enumerate(self._outs):
            self._buffer.set_res(i, memoryview(out))  # type: ignore[call-arg, arg-type]

    def solve(self, hess_nz: np.ndarray, g: np.ndarray, lba: np.ndarray, uba: np.ndarray, lbx: np.ndarray,
              ubx: np.ndarray) -> tuple[np.ndarray, bool]:
        """The QP with the Hessian's nonzeros ``hess_nz`` and these terms and bounds: (x, solved)."""
        args = self._args
        args["h"][:], args["g"][:], args["lba"][:], args["uba"][:] = hess_nz, g, lba, uba
        args["lbx"][:], args["ubx"][:] = lbx, ubx
        self._evaluate()
        return self._x.copy(), bool(self._buffer.stats().get("success", False))


class PitchLoop:
    """The MPC pitch loop. Build once per configuration; call :meth:`step` each control step.

    The only state it keeps is its solvers (one per number of targets served, each built
    on first use); every step is a function of its arguments.
    """

    def __init__(self, config: PitchLoopConfig, limits: MountLimits):
        self.config = config
        self.limits = limits
        self._n = config.horizon_steps
        self._qps: dict[int, _Qp] = {}

    def _slots(self, n_served: int) -> int:
        """Target slots of the QP for ``n_served`` targets (all of them; tests widen it)."""
        return n_served

    def _qp(self, slots: int) -> _Qp:
        """The QP with ``slots`` target slots, built on first use."""
        qp = self._qps.get(slots)
        if qp is None:
            qp = self._qps[slots] = _Qp(self.config, slots)
        return qp

    def _solve(self, qp: _Qp, hess_nz: np.ndarray, g: np.ndarray, lba: np.ndarray, uba: np.ndarray,
               lbx: np.ndarray, ubx: np.ndarray) -> tuple[np.ndarray, bool]:
        """``qp`` with these Hessian nonzeros, terms and bounds: (x, solved)."""
        return qp.solve(hess_nz, g, lba, uba, lbx, ubx)

    @property
    def envelope_rad(self) -> float:
        """Pitch-prediction envelope over one step, ``0.5 a_max dt^2``, rad."""
        return self.config.pitch_envelope_rad

    def step(self, state: PitchState, shadows: Sequence[TrackedShadow]) -> PitchCommand:
        """One control step: the tilt to command now.

        Parameters
        ----------
        state : PitchState
            Telemetry at the step.
        shadows : sequence of TrackedShadow
            The tracked targets ahead (measured this frame or predicted), level frame.

        Returns
        -------
        PitchCommand
        """
        cfg, lim = self.config, self.limits
        n = self._n
        t0 = lim.clip(state.current_tilt_rad)
        served, dropped, low, up, factor, pred = select_shadows(state, shadows, cfg, lim, self.envelope_rad)
        qp = self._qp(self._slots(len(served)))
        m = qp.m
        weight = np.ones((n, m))  # slack weight factors, (step, slot)
        lba = np.full(qp.rows, -np.inf)
        uba = np.full(qp.rows, np.inf)
        for slot, (i, _) in enumerate(served):
            for k in range(n):
                if np.isfinite(low[i, k + 1]):
                    r = 2 * (k * m + slot)
                    lba[r], uba[r + 1] = low[i, k + 1], up[i, k + 1]
                    weight[k, slot] = factor[i, k + 1]
        if cfg.coverage_depression_rad is not None:
            base = 2 * n * m
            for k in range(n):
                lba[base + 2 * k] = cfg.coverage_depression_rad[0] + pred.pitch_rad[k + 1]
                uba[base + 2 * k + 1] = cfg.coverage_depression_rad[1] + pred.pitch_rad[k + 1]
        step_max = lim.max_rate_rad_s * cfg.dt_s
        inc0 = 2 * n * m + 2 * n
        lba[inc0:inc0 + n - 1] = -step_max
        uba[inc0:inc0 + n - 1] = step_max
        lbx = np.zeros(qp.nx)
        ubx = np.full(qp.nx, np.inf)
        search = search_band_rad(pred, cfg)
        if search is None:
            ubx[qp.q0:] = 0.0
        else:
            lba[inc0 + n - 1::2] = search[0][1:] + pred.pitch_rad[1:]
            uba[inc0 + n::2] = search[1][1:] + pred.pitch_rad[1:]
        lbx[:n], ubx[:n] = lim.min_tilt_rad, lim.max_tilt_rad
        first_lo, first_hi = max(lim.min_tilt_rad, t0 - step_max), min(lim.max_tilt_rad, t0 + step_max)
        lbx[0], ubx[0] = first_lo, first_hi
        g = np.zeros(qp.nx)
        g[:n] = -2.0 * cfg.weight_nominal * cfg.nominal_tilt_rad
        g[0] += -2.0 * cfg.weight_increment * t0
        g[qp.s0:qp.c0] = cfg.weight_slack_l1 * weight.ravel()
        g[qp.c0:qp.q0] = cfg.weight_coverage
        g[qp.q0:] = cfg.weight_slack_l1 * cfg.search_weight_factor
        hess_nz = qp.hess_nz.copy()
        hess_nz[qp.slack_nz] = 2.0 * cfg.weight_slack_l2 * weight.ravel()
        x, ok = self._solve(qp, hess_nz, g, lba, uba, lbx, ubx)
        if ok and np.all(np.isfinite(x)):
            plan = np.clip(x[:n], lim.min_tilt_rad, lim.max_tilt_rad)
            tilt = float(min(max(plan[0], first_lo), first_hi))
        else:
            ok, plan, tilt = False, np.full(n, t0), t0
        idx = [i for i, _ in served]  # NaN bounds (not served at step 1) count as no violation
        slack = float(np.sum(np.fmax(0.0, low[idx, 1] - tilt)) + np.sum(np.fmax(0.0, tilt - up[idx, 1])))
        return PitchCommand(tilt, tuple(float(v) for v in plan),
                            served_margins(pred, shadows, served, tilt, cfg), tuple(dropped), slack, ok)
