"""The navigation filter: an extended Kalman filter of the vehicle state AND the water current.

It fuses asynchronous sensor readings (the kinds of :mod:`auvdock.measurements`: attitude,
gyro, accel, depth, position, dvl) with the ONE vehicle model
(:class:`auvdock.vehicle.model.VehicleModel`) driven by the commanded thrust.

Filter state (20): ``z = [x (12); v_c north, v_c east; b_a (3); b_g (3)]`` -- the vehicle
state ``x = [eta; nu]`` (NED position m, ZYX Euler angles rad, body velocity over ground m/s
and rad/s), the horizontal water current in {n} (m/s), constant plus a random walk (paper
Assumption 4: the current is horizontal, its down component is zero), and the IMU's
accelerometer (m/s^2) and gyro (rad/s) biases, constant plus a slow random walk.  The IMU
readings are modelled as the measurement's definition plus its bias
(``accel = h_accel(x, u, v_c) + b_a``, ``gyro = x[ANG] + b_g``): an unestimated accelerometer
bias of 0.02 m/s^2 is read as a heave velocity of centimetres per second, enough to hold a
docking vehicle off its dock.

Predict (from the last step's time to the new one): classical RK4 of ``x_dot = f(x, u, v_c)``
with the thrust held, the current held; the Jacobian ``F = dz_next/dz`` comes from CasADi
(``jacobian`` of the discrete step) in the same function, and
``P <- F P F^T + diag(q^2) h`` (q the process-noise densities of
:class:`NavigationSettings`, h the time step).  Update: every reading of the step in ONE stacked
update (the readings' noises are independent, so this equals updating with them one after the
other), ``y = h(x, u, v_c)`` and ``H = dh/dz`` from :mod:`auvdock.measurements`,
``R = diag(std^2)``, Joseph form ``P <- (I - K H) P (I - K H)^T + K R K^T``; attitude
residuals are wrapped to [-pi, pi), and so is the yaw estimate.

Latency: a reading sampled before the step's time (``Reading.t < t``) is applied at ``t``;
position and depth readings are first carried forward over their age along the estimated
velocity (no retrodiction of the whole filter).

Cost: one CasADi call (predict, F, P propagation and every measurement's value and Jacobian
at the predicted state) and a few small numpy products per step; compiled C when a C compiler
is available and ``$AUVDOCK_COMPILE`` is not ``never`` (:func:`auvdock.codegen.compiled_function`).
``benchmarks/navigation_step.py`` measures it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from pydantic import Field

from . import measurements
from .codegen import compiled_function
from .schema import PosFloat, Strict
from .vehicle.model import rk4
from .vehicle.state import ANG, ATT, LIN, NX, POS, YAW

__all__ = ["NavigationSettings", "Reading", "NavEstimate", "NavigationFilter", "NZ"]

#: Filter state dimension: vehicle state (12), horizontal current (2), accelerometer and gyro biases (3 + 3).
NZ = NX + 8
_CURRENT = slice(NX, NX + 2)
_BIAS_A = slice(NX + 2, NX + 5)
_BIAS_G = slice(NX + 5, NX + 8)

# Row offsets of each kind in the stacked measurement vector.
_OFFSETS: dict[str, int] = {}
_off = 0
for _k, _n in measurements.KINDS.items():
    _OFFSETS[_k] = _off
    _off += _n
_NY = _off
_ANGLE_ROWS = np.array(
    sorted(_OFFSETS[k] + i for k, rows in measurements.ANGLE_ROWS.items() for i in rows), dtype=int
)


#: Most relinearisations of one update (iterated EKF).
IEKF_MAX_ITER = 8

#: Rows of the stacked measurement whose model is curved in z (the accelerometer's): their
#: second-order covariance is added to the noise (Gaussian second-order filter).
_CURVED_ROWS = np.arange(_OFFSETS["accel"], _OFFSETS["accel"] + measurements.KINDS["accel"])

#: The iterated update stops once the measurement model at the new iterate differs from its
#: linearisation by less than this many noise standard deviations in every row.
IEKF_LIN_TOL = 0.1


class NavigationSettings(Strict):
    """Noise model of the navigation filter (standard deviations; densities per sqrt(s)).

    The process noise is the model's error, per state group, as white noise on the state
    derivative: over a step of h seconds a group's variance grows by ``q^2 h``.  For a filter
    whose model equals the truth it can be small (the defaults); unmodelled dynamics
    (damping, buoyancy, thruster errors) go into the velocity and rate terms.
    """

    position_noise_m_sqrt_s: PosFloat = Field(
        default=1e-3, description="process noise of the position, m/sqrt(s)"
    )
    attitude_noise_rad_sqrt_s: PosFloat = Field(
        default=1e-3, description="process noise of the Euler angles, rad/sqrt(s)"
    )
    velocity_noise_m_s_sqrt_s: PosFloat = Field(
        default=0.02, description="process noise of the body linear velocity, m/s/sqrt(s)"
    )
    rate_noise_rad_s_sqrt_s: PosFloat = Field(
        default=0.02, description="process noise of the body angular rate, rad/s/sqrt(s)"
    )
    current_walk_m_s_sqrt_s: PosFloat = Field(
        default=0.005, description="random-walk density of the horizontal current, m/s/sqrt(s)"
    )
    prior_current_std_m_s: PosFloat = Field(
        default=1.0, description="prior standard deviation of each current component (mean zero), m/s"
    )
    accel_bias_walk_m_s2_sqrt_s: PosFloat = Field(
        default=1e-4, description="random-walk density of the accelerometer bias, m/s^2/sqrt(s)"
    )
    gyro_bias_walk_rad_s_sqrt_s: PosFloat = Field(
        default=1e-5, description="random-walk density of the gyro bias, rad/s/sqrt(s)"
    )
    prior_accel_bias_std_m_s2: PosFloat = Field(
        default=0.05, description="prior std of each accelerometer bias component (mean zero), m/s^2"
    )
    prior_gyro_bias_std_rad_s: PosFloat = Field(
        default=0.005, description="prior std of each gyro bias component (mean zero), rad/s"
    )
    prior_position_std_m: PosFloat = Field(default=1.0, description="prior position std, m")
    prior_attitude_std_rad: PosFloat = Field(default=0.1, description="prior Euler-angle std, rad")
    prior_velocity_std_m_s: PosFloat = Field(default=0.5, description="prior body linear velocity std, m/s")
    prior_rate_std_rad_s: PosFloat = Field(default=0.2, description="prior body angular rate std, rad/s")
    substeps: int = Field(default=1, ge=1, le=20, description="RK4 steps per prediction period")
    second_order_prediction: bool = Field(
        default=True,
        description="add the second-order term of the model to the predicted covariance (the "
        "model's rates are worth little while the velocity through the water is uncertain)",
    )
    settle_s: float = Field(
        default=2.0,
        ge=0.0,
        description="the controllers hold zero thrust for this long while the filter settles "
        "from its prior (its first estimates can be metres per second off), s",
    )

    def process_density(self) -> np.ndarray:
        """Diagonal of the process-noise density (20,): variance growth per second of each component."""
        q = np.empty(NZ)
        q[POS] = self.position_noise_m_sqrt_s
        q[ATT] = self.attitude_noise_rad_sqrt_s
        q[LIN] = self.velocity_noise_m_s_sqrt_s
        q[ANG] = self.rate_noise_rad_s_sqrt_s
        q[_CURRENT] = self.current_walk_m_s_sqrt_s
        q[_BIAS_A] = self.accel_bias_walk_m_s2_sqrt_s
        q[_BIAS_G] = self.gyro_bias_walk_rad_s_sqrt_s
        return q**2

    def prior_state_std(self) -> np.ndarray:
        """Prior standard deviation of the vehicle state (12,)."""
        s = np.empty(NX)
        s[POS] = self.prior_position_std_m
        s[ATT] = self.prior_attitude_std_rad
        s[LIN] = self.prior_velocity_std_m_s
        s[ANG] = self.prior_rate_std_rad_s
        return s


@dataclass
class Reading:
    """One sensor reading.

    ``kind``: a key of :data:`auvdock.measurements.KINDS`; ``t``: sample time, s; ``value``
    (``KINDS[kind]``,) in the kind's units; ``std`` (same shape, or a scalar): the noise
    standard deviation of each component.
    """

    kind: str
    t: float
    value: np.ndarray
    std: np.ndarray


@dataclass
class NavEstimate:
    """The filter's estimate at time ``t`` (s).

    ``state`` (12,) and ``state_cov`` (12, 12); ``flow_ned`` (3,) the water current in {n}, m/s
    (down component 0) and ``flow_cov`` (3, 3) (zero third row and column); ``nis`` the
    normalized innovation squared of this step's readings (0 with none; chi-square with
    ``n_meas`` degrees of freedom for a consistent filter).
    """

    t: float
    state: np.ndarray
    state_cov: np.ndarray
    flow_ned: np.ndarray
    flow_cov: np.ndarray
    nis: float
    n_meas: int = 0


def _second_order_covariance(f: ca.SX, z: ca.SX, P: ca.SX, h: Any, n: int) -> ca.SX:
    """The covariance the first-order prediction leaves out (Gaussian second-order filter).

    Over a step ``h`` the state moves by ``h f(z)``; for an error ``e ~ N(0, P)`` its second-order
    part ``h/2 e^T Hess(f_i) e`` has the covariance ``h^2/2 tr(Hess(f_i) P Hess(f_j) P)``
    (Bar-Shalom, Li and Kirubarajan 2001, 10.3).  It matters while the filter is unsure of the
    velocity through the water: the Munk moment ``(Y_vdot - X_udot) u_r v_r`` turns the BlueROV2
    at 26 rad/s^2 per (m/s)^2, so at the prior (0.5 m/s velocity, 1 m/s current) the model's
    yaw-rate prediction is worth about 0.3 rad/s per step, not the first-order 0.005.  Without
    it the gyro's innovation went into the gyro bias.  Once the velocity is known to cm/s it is
    nil.  The same term of a measurement (``f = y``, ``h = 1``; only the accelerometer's is
    not zero: its drag term alone curves by about 1.9 m/s^2 per (m/s)^2 in surge) is added to
    its noise covariance in the update.
    """
    nf = f.shape[0]
    hess = [ca.hessian(f[i], z)[0] for i in range(nf)]
    M = [ca.mtimes(H, P) if H.nnz() else None for H in hess]
    dP = ca.SX.zeros(n, n)
    for i in range(nf):
        for j in range(i, nf):
            if M[i] is not None and M[j] is not None:
                dP[i, j] = dP[j, i] = 0.5 * h * h * ca.sum1(ca.sum2(M[i] * M[j].T))
    return dP


def _step_function(
    vehicle: Any, substeps: int, second_order: bool = True
) -> tuple[ca.Function, ca.Function, ca.Function]:
    """The measurement model ``(z, u) -> (y_all, H_all)``, its second-order covariance
    ``(z, u, P) -> (NY x NY)`` and the step ``(z[NZ], P[NZ x NZ], u[n], h, qd[NZ]) -> (z_next,
    P_next, y_all(z_next), H_all(z_next))``."""
    m = vehicle.model
    z = ca.SX.sym("z", NZ)
    P = ca.SX.sym("P", NZ, NZ)
    u = ca.SX.sym("u", vehicle.n_thrusters)
    h = ca.SX.sym("h")
    qd = ca.SX.sym("qd", NZ)

    def zdot(zz: ca.SX) -> ca.SX:
        vc = ca.vertcat(zz[NX], zz[NX + 1], 0)
        return ca.vertcat(m.dynamics(zz[0:NX], u, vc, ca.DM.zeros(3)), ca.DM.zeros(NZ - NX))

    z_next = rk4(zdot, z, h, substeps)
    F = ca.jacobian(z_next, z)
    P_next = ca.mtimes([F, P, F.T]) + ca.diag(qd) * h
    if second_order:
        P_next = P_next + _second_order_covariance(zdot(z), z, P, h, NZ)
    P_next = 0.5 * (P_next + P_next.T)
    # every measurement at a state zs (symbolic), then at z_next
    zs = ca.SX.sym("zs", NZ)
    vc = ca.vertcat(zs[NX], zs[NX + 1], 0)
    bias = {"accel": zs[_BIAS_A], "gyro": zs[_BIAS_G]}
    y = ca.vertcat(
        *(
            measurements.expression(k, m, zs[0:NX], u, vc) + bias[k]
            if k in bias
            else measurements.expression(k, m, zs[0:NX], u, vc)
            for k in measurements.KINDS
        )
    )
    meas = ca.Function("nav_meas", [zs, u], [ca.densify(y), ca.densify(ca.jacobian(y, zs))])
    Ps = ca.SX.sym("Ps", NZ, NZ)
    curv = ca.Function(
        "nav_meas_curvature", [zs, u, Ps], [ca.densify(_second_order_covariance(y, zs, Ps, 1.0, _NY))]
    )
    y_next, H_next = meas(z_next, u)
    return meas, curv, ca.Function(
        "nav_step",
        [z, P, u, h, qd],
        [ca.densify(z_next), ca.densify(P_next), ca.densify(y_next), ca.densify(H_next)],
        ["z", "P", "u", "h", "qd"],
        ["z_next", "P_next", "y", "H"],
    )


class NavigationFilter:
    """EKF of the vehicle state and the horizontal current (see the module docstring).

    Parameters
    ----------
    settings : NavigationSettings
        Process and prior noise.
    vehicle : auvdock.vehicle.Vehicle
        The vehicle whose model predicts (the same model the controllers use).
    dt : float
        The control period, s: the longest single prediction (longer gaps are split).
    """

    def __init__(self, settings: NavigationSettings, vehicle: Any, dt: float) -> None:
        if not dt > 0:
            raise ValueError(f"dt must be > 0, got {dt}")
        self.settings = settings
        self.vehicle = vehicle
        self.dt = float(dt)
        meas, curv, fn = _step_function(vehicle, settings.substeps, settings.second_order_prediction)
        self._fn, self.build = compiled_function(fn)
        self._meas, _ = compiled_function(meas)
        assert all(self._fn.sparsity_out(i).is_dense() for i in range(4))
        self._qd = settings.process_density()
        # zero-copy evaluation into preallocated arrays
        self._buf, self._eval = self._fn.buffer()
        self._in_z = np.zeros(NZ)
        self._in_P = np.zeros((NZ, NZ))
        self._in_u = np.zeros(vehicle.n_thrusters)
        # the measurements' second-order covariance at the prediction (zero-copy)
        self._second_order = bool(settings.second_order_prediction)
        self._curv, _ = compiled_function(curv)
        self._cbuf, self._ceval = self._curv.buffer()
        self._c_out = np.zeros((_NY, _NY))
        self._c_in_z = np.zeros(NZ)
        self._c_in_P = np.zeros((NZ, NZ))
        for i, a in enumerate((self._c_in_z, self._in_u, self._c_in_P)):
            self._cbuf.set_arg(i, memoryview(a))
        self._cbuf.set_res(0, memoryview(self._c_out))
        self._in_h = np.zeros(1)
        self._out_z = np.zeros(NZ)
        self._out_P = np.zeros((NZ, NZ))
        self._out_y = np.zeros(_NY)
        self._out_Ht = np.zeros((NZ, _NY))  # column-major H (NY x NZ) read as its transpose
        for i, a in enumerate((self._in_z, self._in_P, self._in_u, self._in_h, self._qd)):
            self._buf.set_arg(i, memoryview(a))
        for i, a in enumerate((self._out_z, self._out_P, self._out_y, self._out_Ht)):
            self._buf.set_res(i, memoryview(a))
        # the measurement model alone, at an iterate of the iterated update (zero-copy too)
        self._mbuf, self._meval = self._meas.buffer()
        self._m_in_z = np.zeros(NZ)
        self._m_out_y = np.zeros(_NY)
        self._m_out_Ht = np.zeros((NZ, _NY))
        for i, a in enumerate((self._m_in_z, self._in_u)):
            self._mbuf.set_arg(i, memoryview(a))
        for i, a in enumerate((self._m_out_y, self._m_out_Ht)):
            self._mbuf.set_res(i, memoryview(a))
        # per tuple of reading kinds: its rows of the stacked measurement, which are angles,
        # and, if any is curved (its second-order covariance is not zero), their block's index
        self._rows: dict[tuple[str, ...], tuple[np.ndarray, np.ndarray, Any]] = {}
        self._rotation = vehicle.model.function("rotation")
        #: Updates dropped because they would have made the estimate non-finite.
        self.rejected_updates = 0
        self.z = np.zeros(NZ)
        self.P = np.eye(NZ)
        self.t: float | None = None
        self.reset(np.zeros(NX))

    # --- state ---------------------------------------------------------------------------
    def reset(self, x0: np.ndarray, x0_std: np.ndarray | None = None) -> None:
        """Start again from the first guess ``x0`` (12,), current and IMU biases zero.

        ``x0_std`` (12,) its standard deviation (default: the settings' prior); the current and
        the biases start with their priors' std.  The first :meth:`step` only updates.
        """
        x0 = np.asarray(x0, dtype=float).reshape(NX)
        st = self.settings
        std = st.prior_state_std() if x0_std is None else np.asarray(x0_std, float).reshape(NX)
        self.z = np.concatenate([x0, np.zeros(NZ - NX)])
        extra = np.concatenate(
            [
                np.full(2, st.prior_current_std_m_s),
                np.full(3, st.prior_accel_bias_std_m_s2),
                np.full(3, st.prior_gyro_bias_std_rad_s),
            ]
        )
        self.P = np.diag(np.concatenate([std, extra]) ** 2)
        self.t = None

    def estimate(self, nis: float = 0.0, n_meas: int = 0) -> NavEstimate:
        """The current estimate (copies)."""
        flow = np.zeros(3)
        flow[0:2] = self.z[_CURRENT]
        flow_cov = np.zeros((3, 3))
        flow_cov[0:2, 0:2] = self.P[_CURRENT, _CURRENT]
        return NavEstimate(
            t=float(self.t) if self.t is not None else 0.0,
            state=self.z[0:NX].copy(),
            state_cov=self.P[0:NX, 0:NX].copy(),
            flow_ned=flow,
            flow_cov=flow_cov,
            nis=float(nis),
            n_meas=int(n_meas),
        )

    # --- one step ------------------------------------------------------------------------
    def _evaluate(self, h: float) -> None:
        self._in_z[:] = self.z
        self._in_P[:] = self.P
        self._in_h[0] = h
        self._eval()

    def _predict(self, t: float, u: np.ndarray) -> None:
        self._in_u[:] = u
        if self.t is None or t <= self.t:
            self._evaluate(0.0)  # measurements at the current state
            self.t = t if self.t is None else max(self.t, t)
            return
        gap = t - self.t
        n = max(1, math.ceil(gap / self.dt - 1e-9))
        h = gap / n
        for _ in range(n):
            self._evaluate(h)
            self.z[:] = self._out_z
            self.P[:] = self._out_P
        self.t = t

    def step(self, t: float, readings: list[Reading], u_applied: np.ndarray) -> NavEstimate:
        """Predict to time ``t`` (s) with thrust ``u_applied`` (n,, N, held since the last step),
        then update with ``readings`` (applied at ``t`` whatever their sample time)."""
        before_z, before_P = self.z.copy(), self.P.copy()
        self._predict(float(t), np.asarray(u_applied, dtype=float))
        if not (np.all(np.isfinite(self.z)) and np.all(np.isfinite(self.P))):
            # the model integrated a diverged estimate into overflow: hold the last finite one
            self.z, self.P = before_z, before_P
            self.rejected_updates += 1
        nis = 0.0
        n_meas = 0
        if readings:
            key = tuple(r.kind for r in readings)
            cached = self._rows.get(key)
            if cached is None:
                rows = np.concatenate(
                    [np.arange(_OFFSETS[k], _OFFSETS[k] + measurements.KINDS[k]) for k in key]
                )
                ang = np.flatnonzero(np.isin(rows, _ANGLE_ROWS))
                curved = np.ix_(rows, rows) if np.isin(rows, _CURVED_ROWS).any() else None
                cached = self._rows[key] = (rows, ang, curved)
            rows, ang, curved = cached
            values = np.concatenate([self._aged(r, float(t)) for r in readings])
            var = np.concatenate(
                [
                    np.broadcast_to(np.asarray(r.std, dtype=float), (measurements.KINDS[r.kind],))
                    for r in readings
                ]
            )
            var = var * var
            good_z, good_P = self.z.copy(), self.P.copy()
            R_extra = None
            if curved is not None and self._second_order:
                self._c_in_z[:] = self.z
                self._c_in_P[:] = self.P
                self._ceval()
                R_extra = self._c_out[curved]
            try:
                nis, n_meas = self._update(rows, values, var, ang, R_extra)
            except np.linalg.LinAlgError:
                self.z, self.P = good_z, good_P
                nis, n_meas = math.inf, 0
            if not (np.all(np.isfinite(self.z)) and np.all(np.isfinite(self.P))):
                # never hand on a non-finite estimate: keep the predicted one, and count it
                self.z, self.P = good_z, good_P
                self.rejected_updates += 1
                nis, n_meas = math.inf, 0
        self.z[YAW] = (self.z[YAW] + math.pi) % (2 * math.pi) - math.pi
        return self.estimate(nis, n_meas)

    def _aged(self, r: Reading, t: float) -> np.ndarray:
        """The reading's value carried from its sample time to ``t`` along the estimated motion.

        A position fix ``age = t - r.t`` old is moved by ``age R(Theta) nu_1`` (a camera fix
        0.1 s old of a vehicle at 0.5 m/s is 5 cm behind: five times its noise), a depth by
        the estimated depth rate over the age; other kinds are used as they are.
        """
        value = np.atleast_1d(np.asarray(r.value, dtype=float))
        age = t - float(r.t)
        if age <= 0.0 or r.kind not in ("position", "depth"):
            return value
        R = np.asarray(self._rotation(self.z[ATT]))
        v_ned = R @ self.z[LIN]
        return value + age * (v_ned if r.kind == "position" else v_ned[2:3])

    def _update(
        self,
        rows: np.ndarray,
        values: np.ndarray,
        var: np.ndarray,
        ang: np.ndarray | None = None,
        R_extra: np.ndarray | None = None,
    ) -> tuple[float, int]:
        """Iterated EKF update (Gauss-Newton on the measurement model; Bell and Cathey 1993).

        The first iteration is the EKF update at the prediction.  The measurement model is then
        evaluated at the new iterate; while it differs from its linearisation by more than
        :data:`IEKF_LIN_TOL` noise standard deviations in any row (a start far from the truth,
        where the accelerometer's dependence on the velocity through the water, through the
        quadratic drag, is poorly linearised at the prediction), it is linearised again there,
        up to :data:`IEKF_MAX_ITER` times.  (Iterating only while the innovation was
        improbable missed exactly that case: the prior's own wide covariance makes a large
        innovation look probable, and one linear step from zero relative velocity, where
        the drag's slope is the small linear damping, put the first estimate 3.6 m/s off the
        current -- converged, the same update is 0.2 m/s off.)
        """
        z_pred, P = self.z.copy(), self.P
        y, Ht = self._out_y, self._out_Ht
        z_i = z_pred
        nis = math.inf
        if ang is None:
            ang = np.flatnonzero(np.isin(rows, _ANGLE_ROWS))
        inv_std = 1.0 / np.sqrt(var)
        for it in range(IEKF_MAX_ITER):
            H = Ht[:, rows].T  # (m, NZ)
            r = values - y[rows] - H @ (z_pred - z_i)
            if len(ang):
                r[ang] = (r[ang] + math.pi) % (2 * math.pi) - math.pi
            PHt = P @ H.T
            S = H @ PHt
            S[np.diag_indices_from(S)] += var
            if R_extra is not None:
                S += R_extra
            Sinv_r = np.linalg.solve(S, np.column_stack([r, PHt.T]))
            K = Sinv_r[:, 1:].T  # P H^T S^-1 (S symmetric)
            if it == 0:
                nis = float(r @ Sinv_r[:, 0])
            z_new = z_pred + K @ r
            if it == IEKF_MAX_ITER - 1:
                z_i = z_new
                break
            y_lin = y[rows] + H @ (z_new - z_i)  # the linearised model at the new iterate
            self._m_in_z[:] = z_new
            self._meval()
            y, Ht = self._m_out_y, self._m_out_Ht
            z_i = z_new
            # (angle rows are linear in z: no wrap needed here)
            if float(np.max(np.abs(y[rows] - y_lin) * inv_std)) < IEKF_LIN_TOL:
                break
        self.z = z_i
        A = np.eye(NZ) - K @ H
        R = np.diag(var) if R_extra is None else np.diag(var) + R_extra
        self.P = A @ P @ A.T + K @ R @ K.T
        return nis, len(rows)
