"""Flow state estimation (paper section IV.A; Chang et al.; docs/parameter-sources.md section 5).

A Kalman filter on the body-frame flow ``f = nu_c1`` (3 states, m/s) from inertial
measurements only -- no velocity sensor (no DVL):

* process (paper eq. 4): ``f_dot = -S(nu_2) f``, discretised ``F_k = I - S(nu_2,k) dt``,
  process noise ``Q_f`` per step;
* measurements, from the accelerometer and the depth rate::

      z = [ a_meas - nu_r1_dot_hat          ]  = H f + v,    H = [ -S(nu_2)     ]   (4 x 3)
          [ z_dot_meas - e3^T R nu_r1_hat   ]                    [ e3^T R(eta)  ]

  As in the paper's formulation (the authors' state is ``[eta; nu_r]``, Assumption 1), the
  vehicle knows its pose and its velocity relative to the water ``nu_r`` (from a
  model-based velocity observer or a water-track log) but neither its velocity over
  ground nor the current.  ``nu_r1_hat`` is that relative velocity and ``nu_r1_dot_hat``
  the relative acceleration the one vehicle model (eq. 6, which does not involve the
  flow) predicts over the last period from it and the applied thrust.  Since
  ``nu_1 = nu_r1 + f`` and ``f_dot = -S(nu_2) f``, the body acceleration is
  ``nu_1_dot = nu_r1_dot - S(nu_2) f``: horizontal flow is seen only while the vehicle
  rotates (with ``nu_2 = 0`` it is unobservable); the depth rate sees ``e3^T R f``.

The accelerometer here reports the mean body-frame acceleration ``d nu_1 / dt`` over the
last control period with gravity removed (a delta-velocity reading, as IMUs integrate);
the model's relative acceleration is taken over the same period, so the two match.

Information metric (paper eq. 8): ``F = lambda_min(G)``, with the constructability gramian
propagated recursively (docs/parameter-sources.md section 5)::

    G_k = gamma F_k^-T G_(k-1) F_k^-1 + H_k^T R^-1 H_k,     G_0 = I,

``gamma`` in (0, 1] an optional forgetting factor (1 = none).

The interface (``predict``, ``update``, ``estimate``, ``covariance``, ``information``) is
small so that another filter can replace this one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import casadi as ca
import numpy as np

from auvdock.estimation.settings import EstimatorSettings
from auvdock.runtime.codegen import compiled_function
from auvdock.runtime.fastcall import BufferedFunction
from auvdock.vehicle import Vehicle
from auvdock.vehicle.geometry import skew
from auvdock.vehicle.model import rk4
from auvdock.vehicle.state import ATT, LIN, NX

__all__ = [
    "EstimatorSettings",
    "gramian_step",
    "FlowKalmanFilter",
    "FlowEstimator",
    "EstimatorStep",
    "flow_transition",
    "information_lower_bound",
]


def flow_transition(nu2, dt: float, lib=np):
    """Exact flow transition over dt at constant angular rate: ``expm(-S(nu_2) dt)`` (3x3).

    Evaluated as the 4th-order Taylor series of the matrix exponential, exact to
    ``(|nu_2| dt)^5 / 120`` (below 3e-12 at the MPC's rate bound of 0.25 rad/s and dt = 0.05 s),
    polynomial so that CasADi can differentiate it.  The paper's ``I - S(nu_2) dt`` is its
    first-order truncation; it is not a rotation, so a filter built on it believes that ``|f|``
    grows every step and drifts outward (measured: +0.017 m/s after 30 s at 0.3 rad/s).
    """
    eye: np.ndarray | ca.DM
    if lib is np:
        A = -skew(np.asarray(nu2, dtype=float)) * dt
        eye = np.eye(3)
    else:
        from auvdock.vehicle.model import Smtrx

        A = -Smtrx(nu2) * dt
        eye = ca.DM.eye(3)
    A2 = A @ A
    return eye + A + A2 / 2.0 + A2 @ A / 6.0 + A2 @ A2 / 24.0


def gramian_step(G, nu2, depth_row, dt: float, R_inv: np.ndarray, gamma: float = 1.0, lib=np):
    """One step of the constructability gramian: ``gamma F^-T G F^-1 + H^T R^-1 H`` (3x3).

    ``F = expm(-S(nu_2) dt)`` (so ``F^-1 = expm(S(nu_2) dt)``), the accelerometer rows of H
    are ``(I - F^-1)/dt`` (the paper's ``-S(nu_2)`` to first order) and ``depth_row`` (1x3)
    is the depth-rate row ``e3^T R(Theta)``.  The one definition used by the optimisers
    (``lib=ca``, symbolic) and checked against :class:`FlowKalmanFilter`'s numeric recursion
    (its ``predict`` then ``update`` with the same R) by the tests.
    """
    if lib is np:
        Fi = flow_transition(-np.asarray(nu2, dtype=float), dt)
        H = np.vstack([(np.eye(3) - Fi) / dt, np.reshape(depth_row, (1, 3))])
        return gamma * Fi.T @ G @ Fi + H.T @ R_inv @ H
    Fi = flow_transition(-nu2, dt, ca)
    H = ca.vertcat((ca.DM.eye(3) - Fi) / dt, ca.reshape(depth_row, 1, 3))
    return gamma * ca.mtimes([Fi.T, G, Fi]) + ca.mtimes([H.T, ca.DM(R_inv), H])


def information_lower_bound(G):
    """Smooth lower bound of lambda_min(G) for a symmetric positive definite 3x3 G (numpy or CasADi).

    ``F_lb = 1 / tr(G^-1) = det(G) / c_2(G)``, with ``c_2`` the sum of the principal 2x2
    minors.  Since ``tr(G^-1) = sum 1/lambda_i``::

        lambda_min / 3  <=  F_lb  <=  lambda_min,

    tight (relative error ~ lambda_min / lambda_mid) when the smallest eigenvalue is well
    separated -- the usual case here, the unobservable horizontal direction against a
    well-observed vertical one -- and a factor 2 (3) low when two (three) are equal.  It is
    a rational function of G, smooth everywhere on SPD matrices, so its gradient is
    well-defined where lambda_min itself is not differentiable (repeated eigenvalues, e.g.
    G_0 = I, or the two horizontal eigenvalues under a pure yaw).  We use it instead of the
    closed-form eigenvalue: with the gramian's spread (1e0 to 1e7) the trigonometric formula
    needs a guard near repeated eigenvalues whose bias scales with the spread (85 at
    diag(1, 1, 1e7)).  It is the A-optimal design criterion: ``tr(G^-1)`` bounds the sum of
    the estimation variances.
    """
    g11, g22, g33 = G[0, 0], G[1, 1], G[2, 2]
    g12, g13, g23 = G[0, 1], G[0, 2], G[1, 2]
    det = g11 * (g22 * g33 - g23 * g23) - g12 * (g12 * g33 - g23 * g13) + g13 * (g12 * g23 - g22 * g13)
    c2 = (g11 * g22 - g12 * g12) + (g11 * g33 - g13 * g13) + (g22 * g33 - g23 * g23)
    return det / c2


def chi2_quantile(p: float, k: int) -> float:
    """The ``p`` quantile of chi-square with ``k`` degrees of freedom (Wilson-Hilferty; within
    2 % of the exact value for k >= 3 at p = 0.999: 16.55 for 3 rows, exactly 16.27)."""
    z = NormalDist().inv_cdf(p)
    c = 2.0 / (9.0 * k)
    return float(k * (1.0 - c + z * math.sqrt(c)) ** 3)


def _finite(*arrays: np.ndarray) -> bool:
    return all(bool(np.all(np.isfinite(a))) for a in arrays)


class FlowKalmanFilter:
    """Linear Kalman filter on the body-frame flow with its constructability gramian.

    Parameters
    ----------
    dt : float
        Step, s.
    prior_flow_body : ndarray (3,)
        Initial estimate of f, m/s, body frame.
    prior_var : float
        Initial variance per axis, (m/s)^2.
    process_noise : float
        Q_f per axis per step, (m/s)^2.
    meas_noise : ndarray (4,)
        Diagonal of R: accelerometer (m/s^2)^2 x 3 and depth rate (m/s)^2.
    forgetting_factor : float
        gamma in (0, 1] of the gramian recursion.
    """

    def __init__(
        self,
        dt: float,
        prior_flow_body: np.ndarray,
        prior_var: float,
        process_noise: float,
        meas_noise: np.ndarray,
        forgetting_factor: float = 1.0,
    ) -> None:
        self.dt = float(dt)
        self.Qf = float(process_noise) * np.eye(3)
        self.R = np.diag(np.asarray(meas_noise, dtype=float))
        self.R_inv = np.linalg.inv(self.R)
        self.gamma = float(forgetting_factor)
        self.f = np.asarray(prior_flow_body, dtype=float).copy()
        self.P = float(prior_var) * np.eye(3)
        self.G = np.eye(3)
        self.last_innovation = np.zeros(4)
        #: Updates skipped because they would have made the estimate non-finite.
        self.rejected = 0
        #: Updates skipped by the innovation gate.
        self.gated = 0

    @staticmethod
    def transition(nu2: np.ndarray, dt: float) -> np.ndarray:
        """F_k = expm(-S(nu_2) dt) (3x3); the paper's I - S dt to first order."""
        return flow_transition(nu2, dt)

    @staticmethod
    def measurement_matrix(nu2: np.ndarray, R_nb: np.ndarray, dt: float | None = None) -> np.ndarray:
        """H (4x3): accelerometer rows and the depth-rate row e3^T R.

        With ``dt`` None the accelerometer rows are the paper's instantaneous ``-S(nu_2)``.
        With ``dt``, they are ``(I - F_k^-1) / dt = (I - expm(S(nu_2) dt)) / dt`` for a reading
        that is the MEAN acceleration over the last period, applied to the flow at its end
        (equal to ``-S(nu_2)`` to first order; without it the estimate lags in heading).
        """
        if dt is None:
            acc = -skew(nu2)
        else:
            acc = (np.eye(3) - flow_transition(-np.asarray(nu2, dtype=float), dt)) / dt
        return np.vstack([acc, R_nb[2:3, :]])

    def predict(self, nu2: np.ndarray, extra_process_noise: np.ndarray | None = None) -> None:
        """Time update over one step with angular rate ``nu2`` (rad/s); propagates G too.

        ``extra_process_noise`` (3x3) is added to Q_f for this step (e.g. gyro noise).
        """
        with np.errstate(all="ignore"):
            self._predict(nu2, extra_process_noise)

    def _predict(self, nu2: np.ndarray, extra_process_noise: np.ndarray | None) -> None:
        F = self.transition(nu2, self.dt)
        f = F @ self.f
        P = F @ self.P @ F.T + self.Qf + (0 if extra_process_noise is None else extra_process_noise)
        try:
            Fi = np.linalg.inv(F)
            G = self.gamma * Fi.T @ self.G @ Fi
        except np.linalg.LinAlgError:
            G = np.full((3, 3), np.nan)
        if not _finite(f, P, G):  # a non-finite rate: no time update (never a non-finite estimate)
            self.rejected += 1
            return
        self.f, self.P, self.G = f, P, G

    def update(
        self,
        z: np.ndarray,
        H: np.ndarray,
        R: np.ndarray | None = None,
        gate: float | None = None,
        information: bool = True,
    ) -> np.ndarray:
        """Measurement update with ``z`` = H f + v (4 rows, or a subset with its ``R``).

        Adds ``H^T R^-1 H`` to G; returns the innovation ``z - H f_prior``.  ``gate``: skip
        (and count in :attr:`gated`) an update whose normalised innovation squared
        ``y^T S^-1 y`` exceeds it (None: every update is taken, the paper's filter).
        ``information`` False: the rows do not enter the gramian G (the paper's information
        metric counts the accelerometer and depth-rate rows only).
        """
        R = self.R if R is None else R
        y = z - H @ self.f
        self.last_innovation = np.zeros(4)
        self.last_innovation[: len(y)] = y
        if gate is not None:
            with np.errstate(all="ignore"):
                S = H @ self.P @ H.T + R
                try:
                    nis = float(y @ np.linalg.solve(S, y))
                except np.linalg.LinAlgError:
                    nis = np.inf
            if not nis <= gate:
                self.gated += 1
                return y
        with np.errstate(all="ignore"):
            f, P, G = self._updated(y, H, R)
        if not information:
            G = self.G
        if not _finite(f, P, G):
            # a non-finite reading (or an overflow): skip the update, so that the estimate, its
            # covariance and the gramian stay finite whatever the sensors say
            self.rejected += 1
            return y
        self.f, self.P, self.G = f, P, G
        return y

    def _updated(self, y: np.ndarray, H: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, ...]:
        """(f, P, G) after the update with innovation ``y`` (NaN if it cannot be computed)."""
        try:
            S = H @ self.P @ H.T + R
            K = np.linalg.solve(S, H @ self.P).T
            f = self.f + K @ y
            IKH = np.eye(3) - K @ H
            P = IKH @ self.P @ IKH.T + K @ R @ K.T  # Joseph form
            G = self.G + H.T @ np.linalg.inv(R) @ H
        except np.linalg.LinAlgError:
            f = P = G = np.full((3, 3), np.nan)
        return f, P, G

    def estimate(self) -> np.ndarray:
        """Flow estimate f (3,), body frame, m/s."""
        return self.f.copy()

    def covariance(self) -> np.ndarray:
        """Estimate covariance P (3x3), (m/s)^2."""
        return self.P.copy()

    def information(self) -> float:
        """F = lambda_min(G) (paper eq. 8)."""
        return float(np.linalg.eigvalsh(0.5 * (self.G + self.G.T))[0])


@dataclass
class EstimatorStep:
    """Diagnostics of one estimator cycle."""

    flow_body: np.ndarray
    flow_ned: np.ndarray
    covariance: np.ndarray
    information: float
    #: (4,): the accelerometer rows (body axes, m/s^2) and the depth-rate row (m/s) of z - H f; NaN
    #: on a step without those readings
    innovation: np.ndarray
    state: np.ndarray  # estimated state (12,), over-ground velocity


class FlowEstimator:
    """The vehicle-side estimation pipeline: relative-velocity prediction + flow Kalman filter.

    Each :meth:`step` takes the measurements at t_k (pose, gyro, accelerometer, depth rate)
    and the thrust applied over [t_(k-1), t_k), and returns the estimated state
    ``[eta; nu_r_hat + (f_hat, 0)]`` for the controller and the flow estimate in {n}.

    Parameters
    ----------
    vehicle : Vehicle
        The one model (its eq. (6) predicts the relative velocity).
    dt : float
        Control period, s.
    prior_flow_ned : ndarray (3,)
        Prior flow in {n}, m/s; rotated into {b} with the first measured attitude.
    prior_std, process_noise, accel_noise_var, depth_rate_noise_var, forgetting_factor :
        See :class:`EstimatorSettings` (the paper's R and Q_f).
    gyro_std, attitude_std, relative_velocity_std : float
        Noise of the other readings the filter uses as if exact (rad/s, rad, m/s).  They
        are propagated into the filter each step, linearised at the current estimate:
        gyro noise into the process (``dt^2 S(f) Sigma_g S(f)^T``) and into the
        accelerometer rows (``S(f) Sigma_g S(f)^T``); attitude and relative-velocity noise
        into the depth-rate row (``sigma_att^2 |f_h|^2 + sigma_vr^2``).  Zero gives the
        paper's filter.
    """

    def __init__(
        self,
        vehicle: Vehicle,
        dt: float,
        prior_flow_ned: np.ndarray,
        prior_std: float,
        process_noise: float,
        accel_noise_var: float,
        depth_rate_noise_var: float,
        forgetting_factor: float = 1.0,
        gyro_std: float = 0.0,
        attitude_std: float = 0.0,
        relative_velocity_std: float = 0.0,
        innovation_gate: float | None = None,
        position_std: float | None = None,
        model_accel_error: float = 0.0,
    ) -> None:
        self.vehicle = vehicle
        self.gyro_var = float(gyro_std) ** 2
        self.attitude_var = float(attitude_std) ** 2
        #: Gate probability of the innovation test (None: off, the paper's filter).
        self.innovation_gate = innovation_gate
        #: Noise variance of the pose's position, m^2: with it the filter also reads the pose's
        #: motion (model-free; None: not, the paper's filter, accelerometer and depth rate only).
        self.position_var = None if position_std is None else max(float(position_std), 1e-4) ** 2
        #: Relative error of the model's predicted acceleration, added to the accelerometer rows'
        #: noise as ``(error |nu_r1_dot|)^2`` (0: none, the paper's filter).
        self.model_accel_error = float(model_accel_error)
        self.vr_var = float(relative_velocity_std) ** 2
        self.dt = float(dt)
        self.prior_flow_ned = np.asarray(prior_flow_ned, dtype=float)
        self.prior_var = float(prior_std) ** 2
        self.process_noise = float(process_noise)
        self.meas_noise = np.array([accel_noise_var] * 3 + [depth_rate_noise_var], dtype=float)
        self.gamma = float(forgetting_factor)
        m = vehicle.model

        def prop() -> ca.Function:
            xr = ca.SX.sym("xr", NX)
            u = ca.SX.sym("u", vehicle.n_thrusters)
            zero = ca.DM.zeros(3)
            fn = ca.Function(
                "nu_r_prop", [xr, u], [rk4(lambda x, uu: m.relative_dynamics(x, uu, zero), xr, self.dt, 2, u)]
            )
            return compiled_function(fn)[0]

        # called every step: compiled (cached; built once per vehicle and step), on bound arrays
        self._prop = BufferedFunction(vehicle.built("flow_filter_prop", (self.dt,), prop))
        self._rot = BufferedFunction(m.function("rotation"))
        self.kf: FlowKalmanFilter | None = None
        self._prev: tuple[np.ndarray, np.ndarray] | None = None

    def _gate(self, rows: int) -> float | None:
        """The NIS above which an update of ``rows`` rows is skipped (chi-square quantile)."""
        if self.innovation_gate is None:
            return None
        return chi2_quantile(self.innovation_gate, rows)

    def reset(self) -> None:
        """Forget everything; the next :meth:`step` initialises from the prior."""
        self.kf = None
        self._prev = None

    def R(self, angles: np.ndarray) -> np.ndarray:
        """R(Theta) (3, 3), {b} -> {n}, from the one model."""
        return self._rot(angles)[0].reshape(3, 3, order="F").copy()

    def step(
        self,
        eta: np.ndarray,
        nu_r: np.ndarray,
        accel: np.ndarray | None,
        depth_rate: float | None,
        u_applied: np.ndarray,
    ) -> EstimatorStep:
        """One estimation cycle at t_k: predict over the last period, then correct.

        Parameters
        ----------
        eta : ndarray (6,)
            Measured pose at t_k (m, rad).
        nu_r : ndarray (6,)
            Velocity relative to the water at t_k, body frame (m/s; the angular part is the
            gyro's rate, rad/s).
        accel : ndarray (3,) or None
            Mean body acceleration over the last period (m/s^2, gravity removed); None at
            the first step.
        depth_rate : float or None
            Measured depth rate at t_k (m/s, positive down); None to skip that row.
        u_applied : ndarray (n,)
            Thrust held over the last period (N).

        Returns
        -------
        EstimatorStep
            Flow estimate (body and NED), covariance, F, innovation, and the estimated
            state ``[eta; nu_r1 + f_hat; nu_2]`` (over-ground velocity) for the controller.
        """
        eta = np.asarray(eta, dtype=float)
        nu_r = np.asarray(nu_r, dtype=float)
        R_nb = self.R(eta[ATT])
        # the innovation recorded: the accelerometer and depth-rate rows' (NaN: no such reading this
        # step; a 0 would read as a perfect one), not the pose-motion update's that may follow (another
        # measurement, in NED)
        innovation = np.full(4, np.nan)
        if self.kf is None:
            f0 = R_nb.T @ self.prior_flow_ned
            self.kf = FlowKalmanFilter(
                self.dt, f0, self.prior_var, self.process_noise, self.meas_noise, self.gamma
            )
        elif self._prev is not None:
            eta_prev, nu_r_prev = self._prev
            pred = self._prop(np.concatenate([eta_prev, nu_r_prev]), u_applied)[0].copy()
            nu_r1_dot = (pred[LIN] - nu_r_prev[0:3]) / self.dt
            nu2_mid = 0.5 * (nu_r_prev[3:6] + nu_r[3:6])
            Sf = skew(self.kf.f)
            gyro_cov = self.gyro_var * 0.5 * (Sf @ Sf.T)  # mean of two gyro readings
            self.kf.predict(nu2_mid, self.dt**2 * gyro_cov)
            if accel is not None:
                H = FlowKalmanFilter.measurement_matrix(nu2_mid, R_nb, self.dt)
                z = np.concatenate([np.asarray(accel, dtype=float) - nu_r1_dot, [0.0]])
                R = self.kf.R.copy()
                R[0:3, 0:3] += gyro_cov
                if self.model_accel_error:
                    # the model's own uncertainty: its predicted acceleration is only so good
                    sigma = self.model_accel_error * float(np.linalg.norm(nu_r1_dot))
                    R[0:3, 0:3] += sigma**2 * np.eye(3)
                f_ned = R_nb @ self.kf.f
                R[3, 3] += self.attitude_var * float(f_ned[0] ** 2 + f_ned[1] ** 2) + self.vr_var
                if depth_rate is None:
                    self.kf.update(z[0:3], H[0:3], R[0:3, 0:3], self._gate(3))
                else:
                    z[3] = depth_rate - R_nb[2] @ nu_r[0:3]
                    self.kf.update(z, H, R, self._gate(4))
                innovation = self.kf.last_innovation.copy()
            if self.position_var is not None:
                # the pose's own motion: (p_k - p_(k-1)) / dt = R (nu_r1 + f) over the period, so
                # z = dp/dt - R nu_r1 = R f, model-free (the accelerometer rows need the model)
                R_prev = self.R(eta_prev[ATT])
                v_r_ned = 0.5 * (R_prev @ nu_r_prev[0:3] + R_nb @ nu_r[0:3])
                zp = (eta[0:3] - eta_prev[0:3]) / self.dt - v_r_ned
                Rp = (2.0 * self.position_var / self.dt**2 + self.vr_var) * np.eye(3)
                self.kf.update(zp, 0.5 * (R_prev + R_nb), Rp, self._gate(3), information=False)
        self._prev = (eta.copy(), nu_r.copy())
        f = self.kf.estimate()
        state = np.concatenate([eta, nu_r[0:3] + f, nu_r[3:6]])
        return EstimatorStep(f, R_nb @ f, self.kf.covariance(), self.kf.information(), innovation, state)

    # the small interface, delegated
    def estimate(self) -> np.ndarray:
        """Flow estimate, body frame (3,), m/s."""
        return np.zeros(3) if self.kf is None else self.kf.estimate()

    def covariance(self) -> np.ndarray:
        """Covariance of the flow estimate (3x3)."""
        return self.prior_var * np.eye(3) if self.kf is None else self.kf.covariance()

    def information(self) -> float:
        """F = lambda_min(G)."""
        return 1.0 if self.kf is None else self.kf.information()

    def gramian(self) -> np.ndarray:
        """G (3x3)."""
        return np.eye(3) if self.kf is None else self.kf.G.copy()
