"""The actuator path: what the controller commands -> what the thrusters push.

Every closed loop sends the controller's thrust through one :class:`ActuatorPath`:

* :class:`IdealActuators` (``simulation.actuators: ideal``): the thrust commanded is the
  thrust applied, exactly -- the paper's idealisation, kept by its six missions so that their
  reproduction stays bit-identical;
* :class:`ArduSubActuators` (``ardusub``): the path a BlueROV2 flies, as ``fly`` sends it:
  the eight thrusts' wrench ``B u`` -> six RC override channels (whole microseconds,
  1100..1900 us; :func:`auvdock.vehicle.ardusub.channels_for_wrench`) -> ArduSub's
  VECTORED_6DOF mixer with its per-group normalisation and clipping -> motor PWM -> the
  vehicle's thruster curve with its dead band (:mod:`auvdock.vehicle.thrusters`).  Six
  channels cannot set eight thrusts, only their wrench; the applied thrust is what the
  thrusters really produce from those channels.

Shapes: thrust (n,) N along each thruster's +e_i; wrench (6,) [X Y Z (N), K M N (N m)] in {b};
channels (6,) us in :data:`auvdock.vehicle.ardusub.CHANNELS` order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from auvdock.vehicle.ardusub import (
    NEUTRAL_CHANNELS,
    channels_for_wrench,
    thrust_from_channels,
)

if TYPE_CHECKING:
    from auvdock.vehicle import Vehicle

__all__ = [
    "ACTUATOR_PATHS",
    "ActuatorCommand",
    "ActuatorPath",
    "IdealActuators",
    "ArduSubActuators",
    "build_actuators",
]

#: ``simulation.actuators`` values and what each means.
ACTUATOR_PATHS: dict[str, str] = {
    "ideal": "the commanded thrust is applied exactly (the paper's idealisation)",
    "ardusub": "ArduSub's RC override channels, VECTORED_6DOF mixer, PWM limits and the thruster "
    "curve with its dead band, as fly flies it",
}


@dataclass
class ActuatorCommand:
    """One period's command through the actuator path.

    Attributes
    ----------
    thrust_N : ndarray (n,)
        The thrust the controller asked for, N.
    channels_us : ndarray (6,) or None
        The RC override channels that carry it (ArduSub path), us; None for ideal actuators.
    applied_N : ndarray (n,)
        The thrust the thrusters push from that command, N.
    """

    thrust_N: np.ndarray
    channels_us: np.ndarray | None
    applied_N: np.ndarray


class ActuatorPath(Protocol):
    """Turns a controller's thrust (or a wanted wrench) into what the thrusters push."""

    #: ``simulation.actuators`` value.
    name: str

    def command(self, thrust_N: np.ndarray) -> ActuatorCommand:
        """The command for the controller's thrust (n,, N)."""
        ...

    def command_wrench(self, wrench: np.ndarray) -> ActuatorCommand:
        """The command for a wanted body wrench (6,) (a hold controller's)."""
        ...

    def from_channels(self, channels_us: np.ndarray) -> ActuatorCommand:
        """The command of six RC channels (us) a pilot sends."""
        ...

    def neutral(self) -> ActuatorCommand:
        """No thrust (neutral channels)."""
        ...


class IdealActuators:
    """The commanded thrust is the applied thrust (the paper's idealisation)."""

    name = "ideal"

    def __init__(self, vehicle: Vehicle) -> None:
        self.vehicle = vehicle
        self._B_pinv = np.linalg.pinv(np.asarray(vehicle.allocation, dtype=float))

    def command(self, thrust_N: np.ndarray) -> ActuatorCommand:
        u = np.asarray(thrust_N, dtype=float)
        return ActuatorCommand(u, None, u)

    def command_wrench(self, wrench: np.ndarray) -> ActuatorCommand:
        u = np.clip(
            self._B_pinv @ np.asarray(wrench, dtype=float), self.vehicle.thrust_min, self.vehicle.thrust_max
        )
        return ActuatorCommand(u, None, u)

    def neutral(self) -> ActuatorCommand:
        u = np.zeros(self.vehicle.n_thrusters)
        return ActuatorCommand(u, None, u)

    def from_channels(self, channels_us: np.ndarray) -> ActuatorCommand:
        raise ValueError("ideal actuators take thrust, not RC channels (use the ardusub path)")


class ArduSubActuators:
    """ArduSub's manual thrust path (module docstring), with the vehicle's thruster curve.

    Raises
    ------
    ValueError
        For a vehicle that is not an 8-thruster VECTORED_6DOF frame (the mixer's).
    """

    name = "ardusub"

    def __init__(self, vehicle: Vehicle) -> None:
        if vehicle.n_thrusters != 8:
            raise ValueError(
                f"ArduSub's VECTORED_6DOF mixer drives 8 thrusters (BlueROV2 Heavy); "
                f"{vehicle.name} has {vehicle.n_thrusters}"
            )
        self.vehicle = vehicle
        self.B = np.asarray(vehicle.allocation, dtype=float)
        self.curve = vehicle.thruster_curve

    def _from_channels(self, thrust_N: np.ndarray, channels: np.ndarray) -> ActuatorCommand:
        return ActuatorCommand(
            np.asarray(thrust_N, dtype=float), channels, thrust_from_channels(channels, self.curve)
        )

    def command(self, thrust_N: np.ndarray) -> ActuatorCommand:
        u = np.asarray(thrust_N, dtype=float)
        return self._from_channels(u, channels_for_wrench(self.B @ u, self.B, curve=self.curve))

    def command_wrench(self, wrench: np.ndarray) -> ActuatorCommand:
        channels = channels_for_wrench(np.asarray(wrench, dtype=float), self.B, curve=self.curve)
        applied = thrust_from_channels(channels, self.curve)
        return ActuatorCommand(applied, channels, applied)

    def neutral(self) -> ActuatorCommand:
        return self._from_channels(np.zeros(self.vehicle.n_thrusters), NEUTRAL_CHANNELS.copy())

    def from_channels(self, channels_us: np.ndarray) -> ActuatorCommand:
        ch = np.asarray(channels_us, dtype=float)
        applied = thrust_from_channels(ch, self.curve)
        return ActuatorCommand(applied, ch, applied)


def build_actuators(name: str, vehicle: Vehicle) -> ActuatorPath:
    """The actuator path ``name`` (a key of :data:`ACTUATOR_PATHS`) for ``vehicle``."""
    if name == "ideal":
        return IdealActuators(vehicle)
    if name == "ardusub":
        return ArduSubActuators(vehicle)
    raise ValueError(f"unknown actuator path {name!r} (known: {', '.join(ACTUATOR_PATHS)})")
