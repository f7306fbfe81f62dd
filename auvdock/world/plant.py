"""The truth plant of auvdock's vehicle simulators: the one 6-DOF model, a crude free surface, an IMU's view.

:class:`TruthPlant` holds the true state of the vehicle and steps it with the truth
integrator of :class:`auvdock.vehicle.Vehicle` (RK4 through the mission's flow field, thrust
held over the step).  The closed loop of ``sim`` steps it
(:class:`auvdock.loop.simulated_plant.SimulatedPlant`), and both simulators that stand in for
the water fly it: :class:`auvdock.standins.vehicle_sim.VehicleSim`
(a MAVLink vehicle) and :class:`auvdock.standins.sitl_physics.SitlPhysics` (the physics
backend of ArduPilot SITL), so that they move the same vehicle the same way::

    plant = TruthPlant(mission.build_vehicle(), mission.build_flow(), mission.start_state(), dt=0.01)
    plant.step(thrust_N, t)            # t -> t + 0.01 s
    f_b, w = plant.imu()               # what an ideal IMU measured over that step

State
-----
``x = [x, y, z, phi, theta, psi, u, v, w, p, q, r]`` (12,): position NED (m), ZYX Euler
angles of {b} in {n} (rad), body-frame velocity over ground (m/s) and body rates (rad/s).

Waves
-----
With a ``sea`` (:class:`auvdock.world.waves.WaveComponents`) the water at the vehicle is the
current plus the waves' orbital velocity, and the water's acceleration adds the Froude-Krylov
force (:meth:`auvdock.vehicle.Vehicle.sea_stage`).  The step is then the same RK4 (same
substeps, thrust held) written in numpy, the sea evaluated with numpy at every stage: its
velocity, its rate of change along the vehicle's path (``du/dt + (grad u) p_dot``) for the
added-mass term, and the water's acceleration following the current (``du/dt + (grad u) U``,
linear theory's material acceleration) for the Froude-Krylov term.  Without a sea the step is
the one CasADi integrator as before, bit for bit.

Free surface
------------
The model has no free surface.  With ``surface=True`` (default) the depth is floored at
z = 0 m after each step, and there the upward velocity is removed (and, in the IMU, the
upward acceleration), so that a buoyant vehicle left alone floats at the surface instead of
flying out of the water.

IMU
---
:meth:`TruthPlant.imu` is what an ideal, noise-free IMU at the body origin read over the
last step: the **specific force** in {b} (m/s^2), ``a_b - R^T g_n`` with
``a_b = nu_1_dot + nu_2 x nu_1`` the acceleration of the body origin over ground expressed
in {b}, ``nu_1_dot`` the mean over the last step, ``(nu_1(t) - nu_1(t - dt)) / dt`` (an
IMU's averaged sample; the model's integrator is the only place the flow and its rate along
the path enter) and ``g_n = [0, 0, 9.80665]`` m/s^2 -- level and at rest it reads
(0, 0, -9.80665) m/s^2; and the body rates p, q, r (rad/s) of the current state.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from auvdock.vehicle import Vehicle
from auvdock.vehicle.constants import GRAVITY_M_S2
from auvdock.vehicle.geometry import rotation_zyx
from auvdock.vehicle.state import ANG, LIN, NX

if TYPE_CHECKING:
    from auvdock.world.flow import FlowField
    from auvdock.world.waves import WaveComponents

__all__ = ["TruthPlant"]

_G_N = np.array([0.0, 0.0, GRAVITY_M_S2])


class TruthPlant:
    """The true motion of one vehicle (see the module docstring).

    Parameters
    ----------
    vehicle : Vehicle
        The model (:meth:`auvdock.config.mission.Mission.build_vehicle`).
    flow : FlowField or None
        The true current (:meth:`auvdock.config.mission.Mission.build_flow`); None is still water.
    x0 : array_like (12,)
        Start state (see State), e.g. :meth:`auvdock.config.mission.Mission.start_state`.
    substeps : int
        RK4 substeps per step.
    surface : bool
        Floor the depth at 0 m (the crude free surface).
    dt : float, optional
        The usual step, s: its integrator (:meth:`auvdock.vehicle.Vehicle.stepper`) is built
        at once and used by :meth:`step` when no other step is given.  Other steps use one
        integrator with the step as an input (:meth:`auvdock.vehicle.Vehicle.stepper_any_dt`),
        built at once when ``dt`` is None, else on first use.
    keep_nonfinite : bool
        A step that goes non-finite keeps its non-finite state (the closed loop then ends the
        run as diverged) instead of stopping the vehicle where it was (what a stand-in vehicle
        that must go on answering does).
    sea : WaveComponents, optional
        The waves (see Waves); None: currents only.
    """

    def __init__(
        self,
        vehicle: Vehicle,
        flow: FlowField | None,
        x0: np.ndarray | list[float],
        *,
        substeps: int = 4,
        surface: bool = True,
        dt: float | None = None,
        keep_nonfinite: bool = False,
        sea: WaveComponents | None = None,
    ) -> None:
        x0 = np.array(x0, dtype=float).ravel()
        if x0.shape != (NX,):
            raise ValueError(f"x0: expected a state of {NX} numbers, got shape {x0.shape}")
        if dt is not None and not dt > 0:
            raise ValueError(f"dt: must be positive, got {dt}")
        self.vehicle = vehicle
        self.flow = flow
        self.substeps = int(substeps)
        self.surface = bool(surface)
        self.keep_nonfinite = bool(keep_nonfinite)
        self.dt = None if dt is None else float(dt)
        self.sea = sea if sea is not None and sea.n_components > 0 else None
        self._fixed: ca.Function | None = None
        self._any_dt: ca.Function | None = None
        if self.sea is not None:
            from auvdock.runtime.fastcall import BufferedFunction

            self._sea_stage = BufferedFunction(vehicle.sea_stage(flow))
            cur = self.sea.current_ned_m_s
            self._sea_stage.inputs[6][:] = (cur[0], cur[1], 0.0)
        elif dt is not None:
            self._fixed = vehicle.stepper(float(dt), self.substeps, flow)
        else:
            self._any_dt = vehicle.stepper_any_dt(self.substeps, flow)
        self._x0 = x0.copy()
        self.x = x0.copy()
        self.nu1_dot = np.zeros(3)  # mean d(nu_1)/dt over the last step, m/s^2

    # --- state ---------------------------------------------------------------------------------
    @property
    def state(self) -> np.ndarray:
        """A copy of the true state (12,) (see State)."""
        return self.x.copy()

    @staticmethod
    def rotation(x: np.ndarray) -> np.ndarray:
        """R(Theta) (3, 3) of a state: body {b} -> NED {n}."""
        return rotation_zyx(float(x[3]), float(x[4]), float(x[5]))

    def velocity_ned(self) -> np.ndarray:
        """Velocity over ground in NED (3,), m/s: ``R(Theta) nu_1``."""
        return self.rotation(self.x) @ self.x[LIN]

    def reset(self, x0: np.ndarray | list[float] | None = None) -> None:
        """Put the vehicle back at ``x0`` (default: the start state it was made with); IMU at rest."""
        self.x = (self._x0 if x0 is None else np.array(x0, dtype=float).ravel()).copy()
        self.nu1_dot = np.zeros(3)

    # --- motion --------------------------------------------------------------------------------
    def step(self, thrust_N: np.ndarray, t: float, dt: float | None = None) -> np.ndarray:
        """Move the vehicle from time ``t`` (s) to ``t + dt`` under thrusts ``thrust_N`` (n,, N).

        ``dt`` (s) defaults to the plant's ``dt``.  A step that goes non-finite (impossible
        with sane parameters) keeps the pose and stops the vehicle.  Returns the new state
        (the plant's own array: copy it to keep it).
        """
        if self.sea is not None:
            h = self.dt if dt is None else float(dt)
            if h is None or not h > 0:
                raise ValueError(f"dt: must be positive, got {dt}")
            x_new = self._sea_rk4(np.asarray(thrust_N, dtype=float), float(t), h)
        elif dt is None or (self.dt is not None and float(dt) == self.dt):
            if self._fixed is None:
                raise ValueError("step: no dt given and the plant has no fixed dt")
            h = self.dt
            x_new = np.asarray(self._fixed(self.x, thrust_N, t)).ravel()
        else:
            h = float(dt)
            if not h > 0:
                raise ValueError(f"dt: must be positive, got {dt}")
            if self._any_dt is None:
                self._any_dt = self.vehicle.stepper_any_dt(self.substeps, self.flow)
            x_new = np.asarray(self._any_dt(self.x, thrust_N, t, h)).ravel()
        if not np.all(np.isfinite(x_new)):
            if self.keep_nonfinite:
                self.nu1_dot = np.full(3, np.nan)
                self.x = x_new
                return self.x
            x_new = self.x.copy()
            x_new[6:12] = 0.0
        if self.surface and x_new[2] < 0.0:
            x_new[2] = 0.0
            R = self.rotation(x_new)
            v_ned = R @ x_new[6:9]
            if v_ned[2] < 0.0:
                v_ned[2] = 0.0
                x_new[6:9] = R.T @ v_ned
        self.nu1_dot = (x_new[6:9] - self.x[6:9]) / h
        self.x = x_new
        return self.x

    def water_at(self, x: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The waves at the vehicle in state ``x`` at ``t`` (s): (orbital velocity, rate of change
        along its path, the water's acceleration), each (3,) NED (m/s, m/s^2); zeros with no sea."""
        if self.sea is None:
            z = np.zeros(3)
            return z, z.copy(), z.copy()
        kin = self.sea.kinematics(x[0:3], t)
        p_dot = self.rotation(x) @ x[LIN]
        J = kin.gradient_ned_1_s
        a = kin.acceleration_ned_m_s2
        cur = self.sea.current_ned_m_s
        return kin.velocity_ned_m_s, a + J @ p_dot, a + J @ np.array([cur[0], cur[1], 0.0])

    def _sea_xdot(self, x: np.ndarray, u: np.ndarray, t: float) -> np.ndarray:
        assert self.sea is not None
        vel, acc, grad = self.sea.kinematics_at(x, t)
        return self._sea_stage(x, u, t, vel, acc, grad)[0]

    def _sea_rk4(self, u: np.ndarray, t: float, h: float) -> np.ndarray:
        """``substeps`` classical RK4 steps over ``h`` (s) from ``t``, the sea evaluated at each stage
        (:func:`auvdock.vehicle.model.rk4`'s formula)."""
        x = self.x.copy()
        hs = h / self.substeps
        for i in range(self.substeps):
            ti = t + i * hs
            k1 = self._sea_xdot(x, u, ti).copy()
            k2 = self._sea_xdot(x + hs / 2 * k1, u, ti + hs / 2).copy()
            k3 = self._sea_xdot(x + hs / 2 * k2, u, ti + hs / 2).copy()
            k4 = self._sea_xdot(x + hs * k3, u, ti + hs)
            x = x + hs / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return x

    def place(self, x: np.ndarray | list[float], nu1_dot: np.ndarray | None = None) -> np.ndarray:
        """A step whose motion is prescribed instead of integrated: the vehicle is put at state ``x``
        (12,) and the IMU reads the body acceleration ``nu1_dot`` (3,, m/s^2 in {b}; default at
        rest).  Returns the state (the plant's own array)."""
        self.x = np.array(x, dtype=float).ravel()
        self.nu1_dot = np.zeros(3) if nu1_dot is None else np.array(nu1_dot, dtype=float).ravel()
        return self.x

    # --- what an IMU reads ------------------------------------------------------------------
    def specific_force(self) -> np.ndarray:
        """Specific force in {b} (3,), m/s^2, over the last step (see IMU)."""
        x = self.x
        a_b = self.nu1_dot + np.cross(x[ANG], x[LIN])
        R = self.rotation(x)
        if self.surface and x[2] <= 0.0:
            a_n = R @ a_b
            if a_n[2] < 0.0:
                a_n[2] = 0.0
                a_b = R.T @ a_n
        return a_b - R.T @ _G_N

    def gyro(self) -> np.ndarray:
        """Body rates p, q, r (3,), rad/s."""
        return self.x[ANG].copy()

    def imu(self) -> tuple[np.ndarray, np.ndarray]:
        """(specific force in {b} m/s^2, body rates rad/s): an ideal IMU's reading of the last step."""
        return self.specific_force(), self.gyro()
