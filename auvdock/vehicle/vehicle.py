"""The vehicle (:class:`Vehicle`): its parameters, its one symbolic model and a numpy face.

Library use::

    from auvdock.vehicle import load_vehicle
    v = load_vehicle("bluerov2_heavy")
    xdot = v.state_derivative(x, u, flow_ned)   # ndarray (12,)
    v.allocation                                # (6, n): tau = B u, n = v.n_thrusters
    v.thrust_min, v.thrust_max                  # (n,) N

Conventions: ``x = [x, y, z, phi, theta, psi, u, v, w, p, q, r]`` -- position NED (m),
ZYX Euler angles (rad), body-frame velocity over ground (m/s, rad/s); ``u`` = thrust of
T1..Tn (N), n from the vehicle file; ``flow_ned`` = water velocity (north, east, down) at the vehicle (m/s).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, TypeVar

import casadi as ca
import numpy as np

from auvdock.runtime.codegen import background_pending, environment
from auvdock.runtime.fingerprint import Memo, digest
from auvdock.vehicle.model import VehicleModel, rk4
from auvdock.vehicle.params import VehicleParams, load_params
from auvdock.vehicle.state import ETA, LIN, NX, POS
from auvdock.vehicle.thrusters import ThrusterCurve

T = TypeVar("T")

#: Truth steppers a vehicle keeps (per step length, substeps and flow field).
_STEPPERS = 16


def _flow_key(flow: Any) -> Any:
    """A flow field by value where it is data (a frozen dataclass of numbers: every run's still water or
    constant current is one key), else by identity."""
    if flow is None:
        return None
    try:
        return digest(flow)
    except TypeError:
        return ("id", id(flow))


class FlowField(Protocol):
    """The current as the model reads it: a field in CasADi (:class:`auvdock.world.flow.FlowField`)."""

    def symbolic(self, p_ned: Any, t: Any) -> Any:
        """The current (3,) in {n}, m/s, at position ``p_ned`` (3,) in {n}, m, and time ``t``, s (CasADi)."""
        ...


__all__ = ["Vehicle", "load_vehicle", "shared_vehicle"]


class Vehicle:
    """A vehicle: its parameters, its one symbolic model and numeric helpers."""

    def __init__(self, params: VehicleParams) -> None:
        self.params = params
        self.model = VehicleModel(params)
        self._steppers: dict[tuple[Any, ...], ca.Function] = {}
        self._flow_refs: dict[tuple[Any, ...], Any] = {}
        self._built = Memo(32)

    def built(self, name: str, parts: Any, build: Callable[[], T]) -> T:
        """What a controller or a filter builds from this vehicle's model (CasADi functions, compiled or
        not, and solvers without state of their own), kept: ``build()`` the first time ``name`` with
        ``parts`` (everything else that defines it: numbers, arrays, settings;
        :func:`auvdock.runtime.fingerprint.digest`) is asked for in this thread, the same object later.
        A sweep's or a comparison's runs of one vehicle (:func:`shared_vehicle`) thus build them once.
        Not kept while a background compile runs (``AUVDOCK_COMPILE=auto`` on a cold cache: the functions
        are uncompiled until it ends; the runs after it load the compiled ones)."""
        defining = (parts, environment())  # AUVDOCK_COMPILE, the cache, the compiler: how it is built
        return self._built.get(name, defining, build, keep=lambda: not background_pending())

    @property
    def name(self) -> str:
        return self.params.name

    @property
    def allocation(self) -> np.ndarray:
        """Thruster allocation matrix B (6 x n): body wrench (N, N m) = B @ thrusts (N)."""
        return self.model.B

    @property
    def thruster_curve(self) -> ThrusterCurve:
        """PWM (us) -> force (N) of each thruster (the T200's, or the parameter file's)."""
        return self.params.thruster_curve

    @property
    def thrust_min(self) -> np.ndarray:
        """Per-thruster reverse limits (n,), N (negative)."""
        return self.params.thrust_limits_N[:, 0].copy()

    @property
    def thrust_max(self) -> np.ndarray:
        """Per-thruster forward limits (n,), N."""
        return self.params.thrust_limits_N[:, 1].copy()

    @property
    def n_thrusters(self) -> int:
        """Number of thrusters n (the input dimension; 8 for the Heavy, 6 for the standard frame)."""
        return self.model.nu

    @property
    def nx(self) -> int:
        """State dimension (12: [eta; nu])."""
        return NX

    def state_derivative(
        self,
        x: np.ndarray,
        u: np.ndarray,
        flow_ned: np.ndarray | None = None,
        flow_ned_dot: np.ndarray | None = None,
    ) -> np.ndarray:
        """x_dot (12,) of paper eqs. (1)-(2) at state ``x`` (12,) with thrusts ``u`` (n,, N).

        ``flow_ned`` is the water velocity at the vehicle in {n} (m/s, default still water);
        ``flow_ned_dot`` its rate of change along the vehicle's path (m/s^2, default zero).
        """
        f = self.model.function("xdot")
        vc = np.zeros(3) if flow_ned is None else np.asarray(flow_ned, dtype=float)
        vcd = np.zeros(3) if flow_ned_dot is None else np.asarray(flow_ned_dot, dtype=float)
        return np.asarray(f(np.asarray(x, float), np.asarray(u, float), vc, vcd)).ravel()

    def stepper(self, dt: float, substeps: int = 4, flow: FlowField | None = None) -> ca.Function:
        """Truth integrator ``(x[12], u[n], t) -> x(t + dt)`` through a flow field.

        RK4 with ``substeps`` steps; thrust held constant (zero-order hold).  ``flow`` is a
        :class:`auvdock.world.flow.FlowField` (None: still water); the field is evaluated at the
        vehicle's position and time inside every RK4 stage, and its rate of change along
        the path, ``dv_c/dt = dv/dt + (dv/dp) R nu_1``, enters the added-mass term.
        """
        key = (float(dt), int(substeps), _flow_key(flow))
        if key in self._steppers:
            return self._steppers[key]
        x, u, t, z = self._truth_rk4(float(dt), substeps, flow)
        fn = ca.Function("truth_step", [x, u, t], [z[0:NX]], ["x", "u", "t"], ["x_next"])
        self._keep_stepper(key, fn, flow)
        return fn

    def stepper_any_dt(self, substeps: int = 4, flow: FlowField | None = None) -> ca.Function:
        """The integrator of :meth:`stepper` with the step as an input: ``(x, u, t, dt) -> x(t + dt)``.

        One function for every step length ``dt`` (s), for a caller whose step changes from
        one call to the next (ArduPilot SITL's frame rate); same model, same RK4.
        """
        key = ("any_dt", int(substeps), _flow_key(flow))
        if key in self._steppers:
            return self._steppers[key]
        h = ca.SX.sym("dt")
        x, u, t, z = self._truth_rk4(h, substeps, flow)
        fn = ca.Function("truth_step_dt", [x, u, t, h], [z[0:NX]], ["x", "u", "t", "dt"], ["x_next"])
        self._keep_stepper(key, fn, flow)
        return fn

    def _keep_stepper(self, key: tuple[Any, ...], fn: ca.Function, flow: FlowField | None) -> None:
        """Keep a truth stepper; the vehicle serves many runs (:func:`shared_vehicle`), so a flow known only
        by identity is kept alive with it (its id stays valid) and the oldest go beyond :data:`_STEPPERS`."""
        self._steppers[key] = fn
        self._flow_refs[key] = flow
        while len(self._steppers) > _STEPPERS:
            old = next(iter(self._steppers))
            del self._steppers[old]
            self._flow_refs.pop(old, None)

    def stepper_in_current(self, substeps: int = 2) -> ca.Function:
        """``(x[12], u[n], v_c[3], dt) -> x(t + dt)``: the truth model's RK4 (``substeps`` steps over
        ``dt`` s, thrust held) in a uniform, steady current ``v_c`` (m/s in {n}).  What a prediction that
        holds its current estimate integrates (:mod:`auvdock.estimation.delay`)."""
        key = ("in_current", int(substeps))
        if key in self._steppers:
            return self._steppers[key]
        x = ca.SX.sym("x", NX)
        u = ca.SX.sym("u", self.n_thrusters)
        v_c = ca.SX.sym("v_c", 3)
        h = ca.SX.sym("dt")
        m = self.model
        x_next = rk4(lambda z: m.dynamics(z, u, v_c, ca.DM.zeros(3)), x, h, int(substeps))
        fn = ca.Function("step_in_current", [x, u, v_c, h], [x_next], ["x", "u", "v_c", "dt"], ["x_next"])
        self._steppers[key] = fn
        return fn

    def sea_stage(self, flow: FlowField | None = None) -> ca.Function:
        """The truth's state derivative in a sea, for an integrator that evaluates the waves itself.

        ``(x[12], u[n], t, wave_velocity_ned[3], wave_accel_ned[3], wave_gradient_ned[3x3],
        wave_current_ned[3]) -> x_dot[12]``: the waves' orbital velocity at the vehicle, its local
        rate of change and its gradient ``du_i/dx_j`` (:class:`auvdock.world.waves.WaveKinematics`),
        and the current the waves ride on (the Doppler shift's).  The current ``flow`` is
        evaluated inside (at the vehicle's position and ``t``, with its rate along the path, as
        in :meth:`stepper`).  The water velocity is the current's plus the orbital velocity; its
        rate along the vehicle's path ``p_dot = R nu_1`` adds ``du/dt + (grad u) p_dot``; the
        water's own acceleration (linear theory's material acceleration, ``du/dt + (grad u) U``)
        drives the Froude-Krylov force (:meth:`auvdock.vehicle.model.VehicleModel.dynamics`).
        :class:`auvdock.world.plant.TruthPlant` integrates it with RK4, evaluating the sea with
        numpy at every stage.
        """
        key = ("sea_stage", _flow_key(flow))
        if key in self._steppers:
            return self._steppers[key]
        m = self.model
        x = ca.SX.sym("x", NX)
        u = ca.SX.sym("u", self.n_thrusters)
        t = ca.SX.sym("t")
        vw = ca.SX.sym("wave_velocity_ned", 3)
        aw = ca.SX.sym("wave_accel_ned", 3)
        Jw = ca.SX.sym("wave_gradient_ned", 3, 3)
        Uw = ca.SX.sym("wave_current_ned", 3)
        p_dot = ca.mtimes(m.rotation(x[ETA]), x[LIN])
        vc: ca.SX | ca.DM
        vc_dot: ca.SX | ca.DM
        if flow is None:
            vc, vc_dot = ca.DM.zeros(3), ca.DM.zeros(3)
        else:
            vc = flow.symbolic(x[POS], t)
            vc_dot = ca.jacobian(vc, t) + ca.mtimes(ca.jacobian(vc, x[POS]), p_dot)
        wave_path = aw + ca.mtimes(Jw, p_dot)
        water_accel = aw + ca.mtimes(Jw, Uw)
        xdot = m.dynamics(x, u, vc + vw, vc_dot + wave_path, water_accel_ned=water_accel)
        fn = ca.Function(
            "truth_xdot_sea",
            [x, u, t, vw, aw, Jw, Uw],
            [xdot],
            ["x", "u", "t", "wave_velocity_ned", "wave_accel_ned", "wave_gradient_ned", "wave_current_ned"],
            ["xdot"],
        )
        self._keep_stepper(key, fn, flow)
        return fn

    def _truth_rk4(
        self, dt: float | ca.SX, substeps: int, flow: FlowField | None
    ) -> tuple[ca.SX, ca.SX, ca.SX, ca.SX]:
        """Symbols x, u, t and the augmented state [x; t] after ``substeps`` RK4 steps over ``dt``."""
        x = ca.SX.sym("x", NX)
        u = ca.SX.sym("u", self.n_thrusters)
        t = ca.SX.sym("t")
        m = self.model

        def xdot(xs: ca.SX, ts: ca.SX) -> ca.SX:
            if flow is None:
                return m.dynamics(xs, u, ca.DM.zeros(3), ca.DM.zeros(3))
            p = ca.SX.sym("p", 3)
            tt = ca.SX.sym("tt")
            v = flow.symbolic(p, tt)
            field = ca.Function("field", [p, tt], [v, ca.jacobian(v, p), ca.jacobian(v, tt)])
            vc, dv_dp, dv_dt = field(xs[POS], ts)
            p_dot = ca.mtimes(m.rotation(xs[ETA]), xs[LIN])
            return m.dynamics(xs, u, vc, dv_dt + ca.mtimes(dv_dp, p_dot))

        def f(z: ca.SX) -> ca.SX:  # augmented state [x; t]
            return ca.vertcat(xdot(z[0:NX], z[NX]), 1)

        return x, u, t, rk4(f, ca.vertcat(x, t), dt, substeps)


_VEHICLES = Memo(8)


def shared_vehicle(params: VehicleParams) -> Vehicle:
    """The vehicle of ``params``: one object per set of parameters (by value) and thread, so that the
    functions its controllers and filters build (:meth:`Vehicle.built`) serve every run of it."""
    return _VEHICLES.get("vehicle", params, lambda: Vehicle(params))


def load_vehicle(
    name_or_path: str | Path = "bluerov2_heavy",
    overrides: dict[str, Any] | None = None,
    thruster_voltage_V: int | None = None,
) -> Vehicle:
    """Load a vehicle by preset name or parameter-file path; see :func:`load_params`."""
    return shared_vehicle(load_params(name_or_path, overrides, thruster_voltage_V))
