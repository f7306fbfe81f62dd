"""The vehicle: BlueROV2 Heavy parameters, the symbolic model and a numpy face.

Library use::

    from auvdock.vehicle import load_vehicle
    v = load_vehicle("bluerov2_heavy")
    xdot = v.state_derivative(x, u, flow_ned)   # ndarray (12,)
    v.allocation                                # (6, n): tau = B u, n = v.n_thrusters
    v.thrust_min, v.thrust_max                  # (n,) N

Conventions: ``x = [x, y, z, phi, theta, psi, u, v, w, p, q, r]`` -- position NED (m),
ZYX Euler angles (rad), body-frame velocity over ground (m/s, rad/s); ``u`` = thrust of
T1..Tn (N), n from the vehicle file; ``flow_ned`` = water velocity (north, east, down) at the vehicle (m/s).

==================  ==================================================================
module              what it holds
==================  ==================================================================
``params``          the parameter files and presets (:func:`load_params`), no CasADi
``state``           the state vector's layout (index slices)
``geometry``        rotations (ZYX Euler), skew matrices: numpy
``thrusters``       the thruster curve (PWM <-> force)
``model``           the one symbolic model (CasADi), :class:`VehicleModel`
``vehicle``         :class:`Vehicle` and :func:`load_vehicle`: the model with numeric helpers
==================  ==================================================================

:class:`Vehicle`, :func:`load_vehicle` and :class:`VehicleModel` are imported on first use, so
that a module which only needs the state's layout or the parameters (reading a mission) does not
load CasADi.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from auvdock.vehicle.params import VehicleParams, VehicleParamsError, preset_names

if TYPE_CHECKING:  # pragma: no cover
    from auvdock.vehicle.model import VehicleModel
    from auvdock.vehicle.vehicle import Vehicle, load_vehicle

__all__ = ["Vehicle", "VehicleModel", "VehicleParams", "VehicleParamsError", "load_vehicle", "preset_names"]

_LAZY = {"Vehicle": "auvdock.vehicle.vehicle", "load_vehicle": "auvdock.vehicle.vehicle",
         "VehicleModel": "auvdock.vehicle.model"}  # fmt: skip


def __getattr__(name: str) -> Any:
    """``Vehicle``, ``load_vehicle`` and ``VehicleModel``, imported when first asked for."""
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'auvdock.vehicle' has no attribute {name!r}")
