"""The 6-DOF vehicle model, written once, symbolically (CasADi).

Paper eqs. (1), (2) and (6); Fossen, *Handbook of Marine Craft Hydrodynamics and Motion
Control* (2011/2021), chapters 2, 3, 6 and 10.  The helper names follow Fossen's
PythonVehicleSimulator (``Smtrx``, ``Rzyx``, ``Tzyx``, ``m2c``, ``gvect``).

Conventions
-----------
State ``x = [eta; nu]`` (12):

* ``eta = [x, y, z, phi, theta, psi]``: position in {n} (NED, m) and ZYX Euler angles (rad);
* ``nu = [u, v, w, p, q, r]``: the vehicle's body-frame velocity **over ground** (m/s, rad/s).

Input ``u`` (n): thrust of T1..Tn in N (n = 8 for the Heavy, 6 for the standard frame);
the body wrench is ``tau = B u`` (N, N m).
Flow: ``v_c`` is the water velocity in {n} (m/s) at the vehicle; in {b} it is
``nu_c1 = R(Theta)^T v_c`` and the relative velocity is ``nu_r = nu - [nu_c1; 0]``
(irrotational flow, ``nu_c2 = 0``).

Truth dynamics (paper eq. 2)::

    M_RB nu_dot + M_A nu_r_dot + C_RB(nu) nu + C_A(nu_r) nu_r + D(nu_r) nu_r + g(eta) = tau

with ``nu_r_dot = nu_dot - nu_c_dot`` and, for a field ``v_c(p, t)`` seen along the path,
``nu_c1_dot = -S(nu_2) nu_c1 + R^T v_c_dot`` (``v_c_dot`` is the flow's rate of change along
the vehicle's path in {n}; for a current constant in {n} it is zero and this is paper eq. 4).

Waves (Fossen 2021, section 10.3, the relative-velocity form): the water velocity ``v_c`` is the
current plus the waves' orbital velocity, and the water's own acceleration ``a_w`` (in {n})
adds the Froude-Krylov force of the pressure field that accelerates it, on the right::

    ... = tau + [rho V R^T a_w; 0]

(``rho V = B / g``, the displaced mass).  With ``nu_r_dot = nu_dot - nu_c_dot`` the total inertial
forcing of the water on the body is ``(rho V + M_A) a_w`` (Morison's ``C_M = 1 + C_a``).  The body
(about 0.5 m) is small against the waves (tens of metres), so the water's acceleration is taken
uniform over it and the wave moments are neglected.  The term is left out (``a_w`` None) for
the paper's currents: eq. (2) has none, and the double gyre accelerates its water by less than
1e-3 m/s^2 (a force below 0.01 N).

Every consumer (simulator, every MPC, the estimator) builds on :class:`VehicleModel`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from auvdock.vehicle.constants import GRAVITY_M_S2
from auvdock.vehicle.geometry import skew, zyx_entries
from auvdock.vehicle.params import VehicleParams
from auvdock.vehicle.state import ANG, ETA, NU, NX
from auvdock.vehicle.thrusters import allocation_matrix

__all__ = [
    "Smtrx",
    "Rzyx",
    "Tzyx",
    "Jeta",
    "m2c",
    "gvect",
    "rigid_body_mass",
    "VehicleModel",
    "rk4",
]

Sym = Any  # ca.SX | ca.MX | ca.DM


def Smtrx(a: Sym) -> Sym:
    """Skew-symmetric matrix S(a) (3x3) such that ``S(a) b = a x b``."""
    return ca.vertcat(
        ca.horzcat(0, -a[2], a[1]),
        ca.horzcat(a[2], 0, -a[0]),
        ca.horzcat(-a[1], a[0], 0),
    )


def Rzyx(phi: Sym, theta: Sym, psi: Sym) -> Sym:
    """Rotation matrix R (3x3) from {b} to {n}, ZYX Euler angles (rad): the one formula
    (:func:`auvdock.vehicle.geometry.zyx_entries`) in CasADi."""
    e = zyx_entries(phi, theta, psi, ca.cos, ca.sin)
    return ca.vertcat(ca.horzcat(*e[0:3]), ca.horzcat(*e[3:6]), ca.horzcat(*e[6:9]))


def Tzyx(phi: Sym, theta: Sym) -> Sym:
    """Euler-rate matrix T (3x3): ``[phi_dot, theta_dot, psi_dot] = T nu_2`` (singular at theta = +-pi/2)."""
    cphi, sphi = ca.cos(phi), ca.sin(phi)
    cth, tth = ca.cos(theta), ca.tan(theta)
    return ca.vertcat(
        ca.horzcat(1, sphi * tth, cphi * tth),
        ca.horzcat(0, cphi, -sphi),
        ca.horzcat(0, sphi / cth, cphi / cth),
    )


def Jeta(eta: Sym) -> Sym:
    """Kinematic transformation J(Theta) (6x6), ``eta_dot = J nu`` (paper eq. 1)."""
    R = Rzyx(eta[3], eta[4], eta[5])
    T = Tzyx(eta[3], eta[4])
    Z = ca.DM.zeros(3, 3)
    return ca.vertcat(ca.horzcat(R, Z), ca.horzcat(Z, T))


def m2c(M: np.ndarray, nu: Sym) -> Sym:
    """Coriolis-centripetal matrix C(nu) (6x6) from a 6x6 mass matrix, Fossen's ``m2c``.

    ``C = [[0, -S(M11 nu1 + M12 nu2)], [-S(M11 nu1 + M12 nu2), -S(M21 nu1 + M22 nu2)]]``;
    skew-symmetric for any nu when M is symmetric.  Serves C_RB (with M_RB about the origin,
    including r_g) and C_A (with M_A).
    """
    M = 0.5 * (np.asarray(M) + np.asarray(M).T)
    nu1, nu2 = nu[0:3], nu[3:6]
    a = ca.mtimes(M[0:3, 0:3], nu1) + ca.mtimes(M[0:3, 3:6], nu2)
    b = ca.mtimes(M[3:6, 0:3], nu1) + ca.mtimes(M[3:6, 3:6], nu2)
    Z = ca.DM.zeros(3, 3)
    return ca.vertcat(ca.horzcat(Z, -Smtrx(a)), ca.horzcat(-Smtrx(a), -Smtrx(b)))


def gvect(W: float, B: float, theta: Sym, phi: Sym, r_bg: np.ndarray, r_bb: np.ndarray) -> Sym:
    """Restoring forces and moments g(eta) (6,), Fossen's ``gvect``.

    ``W`` weight and ``B`` buoyancy in N; ``r_bg``, ``r_bb`` the centres of gravity and
    buoyancy in {b} (m).  Appears on the left of eq. (2): the net hydrostatic wrench on
    the vehicle is ``-g``.
    """
    sth, cth = ca.sin(theta), ca.cos(theta)
    sphi, cphi = ca.sin(phi), ca.cos(phi)
    xg, yg, zg = (float(v) for v in r_bg)
    xb, yb, zb = (float(v) for v in r_bb)
    return ca.vertcat(
        (W - B) * sth,
        -(W - B) * cth * sphi,
        -(W - B) * cth * cphi,
        -(yg * W - yb * B) * cth * cphi + (zg * W - zb * B) * cth * sphi,
        (zg * W - zb * B) * sth + (xg * W - xb * B) * cth * cphi,
        -(xg * W - xb * B) * cth * sphi - (yg * W - yb * B) * sth,
    )


def rigid_body_mass(m: float, r_g: np.ndarray, I_g: np.ndarray) -> np.ndarray:
    """Rigid-body mass matrix M_RB (6x6) about the body origin (Fossen eq. 3.44).

    ``I_g`` are the principal inertias (kg m^2) about axes through the CG; the inertia
    about the origin follows from the parallel-axis theorem, ``I_o = I_g - m S(r_g)^2``.
    """
    S = skew(np.asarray(r_g, dtype=float))
    I_o = np.diag(I_g) - m * S @ S
    return np.block([[m * np.eye(3), -m * S], [m * S, I_o]])


def rk4(f: Callable[..., Sym], x: Sym, h: float | Sym, substeps: int, *args: Sym) -> Sym:
    """``substeps`` classical Runge-Kutta steps of ``x_dot = f(x, *args)`` over time ``h`` (s)."""
    hs = h / substeps
    for _ in range(substeps):
        k1 = f(x, *args)
        k2 = f(x + hs / 2 * k1, *args)
        k3 = f(x + hs / 2 * k2, *args)
        k4 = f(x + hs * k3, *args)
        x = x + hs / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


class VehicleModel:
    """The symbolic 6-DOF model of one vehicle (paper eqs. 1, 2, 4, 6).

    Numeric matrices (numpy): ``M_RB``, ``M_A``, ``M`` (6x6), ``D_lin`` and ``D_quad``
    (6-vectors of diagonal coefficients), ``B`` (6 x n allocation).  Symbolic pieces work on
    CasADi SX or MX and are used by the simulator, every MPC and the estimator.
    """

    def __init__(self, params: VehicleParams) -> None:
        self.params = params
        p = params
        self.M_RB = rigid_body_mass(p.mass_kg, p.r_g_m, p.inertia_kg_m2)
        self.M_A = np.diag(p.added_mass)
        self.M = self.M_RB + self.M_A
        self.M_inv = np.linalg.inv(self.M)
        self.D_lin = np.asarray(p.linear_damping, dtype=float)
        self.D_quad = np.asarray(p.quadratic_damping, dtype=float)
        self.B = allocation_matrix(p.thruster_positions_m, p.thruster_directions)
        #: Dimensions: state, input (thrusters) and wrench.
        self.nx, self.nu, self.nw = NX, int(self.B.shape[1]), 6
        self._functions: dict[str, ca.Function] = {}

    # --- pieces -------------------------------------------------------------------------
    def rotation(self, eta: Sym) -> Sym:
        """R(Theta), {b} -> {n} (3x3)."""
        return Rzyx(eta[3], eta[4], eta[5])

    def coriolis_rb(self, nu: Sym) -> Sym:
        """C_RB(nu) (6x6), m2c form."""
        return m2c(self.M_RB, nu)

    def coriolis_added(self, nu_r: Sym) -> Sym:
        """C_A(nu_r) (6x6), m2c form."""
        return m2c(self.M_A, nu_r)

    def damping(self, nu_r: Sym) -> Sym:
        """``D(nu_r) = diag(D_lin) + diag(D_quad) |nu_r|`` (6x6)."""
        return ca.diag(self.D_lin + self.D_quad * ca.fabs(nu_r))

    def restoring(self, eta: Sym) -> Sym:
        """g(eta) (6,)."""
        p = self.params
        return gvect(p.weight_N, p.buoyancy_N, eta[4], eta[3], p.r_g_m, p.r_b_m)

    def wrench(self, u: Sym) -> Sym:
        """Body wrench tau = g B u (6,) from commanded thrusts u (n,) in N; g the
        ``thruster_gain`` (1 unless a plant's model error scales it)."""
        g = float(self.params.thruster_gain)
        return ca.mtimes(self.B, u) if g == 1.0 else g * ca.mtimes(self.B, u)

    def body_flow(self, eta: Sym, flow_ned: Sym) -> Sym:
        """Flow in {b}: nu_c1 = R^T v_c (3,)."""
        return ca.mtimes(self.rotation(eta).T, flow_ned)

    # --- equations of motion ------------------------------------------------------------
    @property
    def displaced_mass_kg(self) -> float:
        """rho V = B / g, kg: the mass of the water the vehicle displaces (Froude-Krylov), with
        standard gravity (the vehicle file's ``weight_N / mass_kg`` need not be g)."""
        return float(self.params.buoyancy_N) / GRAVITY_M_S2

    def accelerations(
        self, x: Sym, tau: Sym, flow_ned: Sym, flow_ned_dot: Sym, water_accel_ned: Sym | None = None
    ) -> tuple[Sym, Sym]:
        """Body accelerations (nu_dot, nu_r_dot), each (6,), of eq. (2) under wrench ``tau``.

        ``water_accel_ned`` (3,, m/s^2 in {n}): the water's acceleration for the Froude-Krylov
        force (see the module docstring); None leaves the term out."""
        eta, nu = x[ETA], x[NU]
        R = self.rotation(eta)
        nu_c1 = ca.mtimes(R.T, flow_ned)
        nu_c = ca.vertcat(nu_c1, 0, 0, 0)
        nu_r = nu - nu_c
        nu_c_dot = ca.vertcat(-ca.mtimes(Smtrx(x[ANG]), nu_c1) + ca.mtimes(R.T, flow_ned_dot), 0, 0, 0)
        rhs = (
            tau
            - ca.mtimes(self.coriolis_rb(nu), nu)
            - ca.mtimes(self.coriolis_added(nu_r), nu_r)
            - ca.mtimes(self.damping(nu_r), nu_r)
            - self.restoring(eta)
            + ca.mtimes(self.M_A, nu_c_dot)
        )
        if water_accel_ned is not None:
            rhs = rhs + ca.vertcat(self.displaced_mass_kg * ca.mtimes(R.T, water_accel_ned), 0, 0, 0)
        nu_dot = ca.mtimes(self.M_inv, rhs)
        return nu_dot, nu_dot - nu_c_dot

    def dynamics(
        self,
        x: Sym,
        u: Sym,
        flow_ned: Sym,
        flow_ned_dot: Sym | None = None,
        tau_extra: Sym | None = None,
        water_accel_ned: Sym | None = None,
    ) -> Sym:
        """State derivative x_dot (12,) of eqs. (1)-(2): truth, Oracle and Naive (flow = 0) models.

        ``u``: thrusts (n,) in N; ``flow_ned``: water velocity in {n} (3,) m/s;
        ``flow_ned_dot``: its rate of change along the path (3,) m/s^2, zero if omitted;
        ``tau_extra``: an extra body wrench (6,) [N, N m] (an offset-free MPC's disturbance
        estimate), zero if omitted; ``water_accel_ned``: the water's acceleration (3,) m/s^2 in {n}
        for the Froude-Krylov force of waves, left out if omitted.
        """
        if flow_ned_dot is None:
            flow_ned_dot = ca.DM.zeros(3)
        tau = self.wrench(u) if tau_extra is None else self.wrench(u) + tau_extra
        nu_dot, _ = self.accelerations(x, tau, flow_ned, flow_ned_dot, water_accel_ned)
        eta_dot = ca.mtimes(Jeta(x[ETA]), x[NU])
        return ca.vertcat(eta_dot, nu_dot)

    def relative_dynamics(self, x_r: Sym, u: Sym, flow_ned: Sym, tau_extra: Sym | None = None) -> Sym:
        """Derivative of ``x_r = [eta; nu_r]`` (12,) for the Kinematic MPC's model.

        The current enters the kinematics only, ``eta_dot = J(Theta)(nu_r + nu_c)``, and the
        dynamics are eq. (6) with no flow terms:
        ``M nu_r_dot + C_RB(nu_r) nu_r + C_A(nu_r) nu_r + D(nu_r) nu_r + g(eta) = tau``
        (``tau = B u + tau_extra``, ``tau_extra`` zero if omitted).
        """
        eta, nu_r = x_r[ETA], x_r[NU]
        nu_c = ca.vertcat(self.body_flow(eta, flow_ned), 0, 0, 0)
        eta_dot = ca.mtimes(Jeta(eta), nu_r + nu_c)
        tau = self.wrench(u) if tau_extra is None else self.wrench(u) + tau_extra
        rhs = (
            tau
            - ca.mtimes(self.coriolis_rb(nu_r) + self.coriolis_added(nu_r) + self.damping(nu_r), nu_r)
            - self.restoring(eta)
        )
        return ca.vertcat(eta_dot, ca.mtimes(self.M_inv, rhs))

    # --- compiled functions ---------------------------------------------------------------
    def function(self, name: str) -> ca.Function:
        """Cached SX CasADi functions of the model.

        * ``"xdot"``: (x[12], u[n], flow_ned[3], flow_ned_dot[3]) -> x_dot[12]
        * ``"xdot_relative"``: (x_r[12], u[n], flow_ned[3]) -> x_r_dot[12]
        * ``"xdot_sea"``: (x[12], u[n], flow_ned[3], flow_ned_dot[3], water_accel_ned[3]) -> x_dot[12],
          with the Froude-Krylov force of the water's acceleration (the truth in a sea)
        * ``"accel"``: (x[12], u[n], flow_ned[3], flow_ned_dot[3]) -> (nu_dot[6], nu_r_dot[6])
        * ``"rotation"``: (angles[3] = phi, theta, psi) -> R[3x3], {b} -> {n}
        """
        if name not in self._functions:
            x = ca.SX.sym("x", self.nx)
            u = ca.SX.sym("u", self.nu)
            vc = ca.SX.sym("flow_ned", 3)
            vcd = ca.SX.sym("flow_ned_dot", 3)
            if name == "xdot":
                f = ca.Function(
                    "xdot",
                    [x, u, vc, vcd],
                    [self.dynamics(x, u, vc, vcd)],
                    ["x", "u", "flow_ned", "flow_ned_dot"],
                    ["xdot"],
                )
            elif name == "xdot_sea":
                aw = ca.SX.sym("water_accel_ned", 3)
                f = ca.Function(
                    "xdot_sea",
                    [x, u, vc, vcd, aw],
                    [self.dynamics(x, u, vc, vcd, water_accel_ned=aw)],
                    ["x", "u", "flow_ned", "flow_ned_dot", "water_accel_ned"],
                    ["xdot"],
                )
            elif name == "xdot_relative":
                f = ca.Function(
                    "xdot_relative",
                    [x, u, vc],
                    [self.relative_dynamics(x, u, vc)],
                    ["x_r", "u", "flow_ned"],
                    ["x_r_dot"],
                )
            elif name == "rotation":
                ang = ca.SX.sym("angles", 3)
                f = ca.Function("rotation", [ang], [Rzyx(ang[0], ang[1], ang[2])], ["angles"], ["R"])
            elif name == "accel":
                nd, nrd = self.accelerations(x, self.wrench(u), vc, vcd)
                f = ca.Function(
                    "accel",
                    [x, u, vc, vcd],
                    [nd, nrd],
                    ["x", "u", "flow_ned", "flow_ned_dot"],
                    ["nu_dot", "nu_r_dot"],
                )
            else:
                raise KeyError(f"unknown model function {name!r}")
            self._functions[name] = f
        return self._functions[name]
