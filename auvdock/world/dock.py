"""The docking station: a wave-energy converter (WEC) that heaves sinusoidally.

Paper eq. (7): ``z_W_dot = w A cos(w t)``, i.e. ``z_W(t) = z_0 + A sin(w t + phase)``.
The dock does not translate horizontally nor rotate; its heading is fixed.

Frames and units: positions NED in metres, velocities NED in m/s, heading in radians
(clockwise from north, ZYX yaw), time in seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from auvdock.vehicle.state import LIN, NX, POS, YAW

__all__ = ["DockMotion", "TranslatingDock", "HeaveDock", "ClockedDock", "ShiftedDock", "TrackedDock"]


class DockMotion(Protocol):
    """What a controller and the docking rule know of a dock: its motion (NED, m, m/s, s).

    :class:`HeaveDock` (the paper's sinusoid), :class:`TrackedDock` (re-anchored by
    measurements in ``fly``) and :class:`auvdock.world.wec_dock.WecDock` (a WEC buoy in the sea).
    """

    @property
    def heading_rad(self) -> float: ...

    @property
    def position_ned_m(self) -> tuple[float, float, float]:
        """The dock's anchor: the point its motion is about (the docking point's mean), NED m."""
        ...

    def position(self, t: float | np.ndarray) -> np.ndarray: ...

    def velocity(self, t: float | np.ndarray) -> np.ndarray: ...

    def trajectory(self, t0: float, dt: float, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def reference_state(self, t: float | np.ndarray) -> np.ndarray: ...


class TranslatingDock:
    """What every dock that translates without rotating derives from its motion.

    A subclass gives ``position(t)`` and ``velocity(t)`` (NED, m and m/s, shape (..., 3)) and a
    fixed ``heading_rad``; this gives the horizon's ``trajectory``, the dock's state in the
    vehicle's layout (``reference_state``) and its 6-DOF ``pose``.
    """

    heading_rad: float

    def position(self, t: float | np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def trajectory(self, t0: float, dt: float, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Dock motion at ``t0 + k dt`` for k = 0..n_steps.

        Returns
        -------
        t : ndarray, shape (n_steps + 1,)
            Times in s.
        position : ndarray, shape (n_steps + 1, 3)
            NED positions in m.
        velocity : ndarray, shape (n_steps + 1, 3)
            NED velocities in m/s.
        """
        t = t0 + dt * np.arange(n_steps + 1)
        return t, self.position(t), self.velocity(t)

    def pose(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The dock's 6-DOF pose and twist at t (s).

        Pose: north, east, down (m), roll, pitch, yaw (rad); twist: NED velocity (m/s), rates (rad/s)."""
        pose = np.zeros(6)
        pose[0:3] = self.position(t)
        pose[5] = self.heading_rad
        twist = np.zeros(6)
        twist[0:3] = self.velocity(t)
        return pose, twist

    def reference_state(self, t: float | np.ndarray) -> np.ndarray:
        """The dock's state x_W in the vehicle's state layout, shape (..., 12).

        ``[x, y, z, 0, 0, heading, vn, ve, vd, 0, 0, 0]``; the velocity part is the
        dock's NED velocity (equal to its body velocity, as the dock is level and does
        not rotate apart from its fixed heading, up to that heading's rotation).
        """
        p = self.position(t)
        v = self.velocity(t)
        out = np.zeros(p.shape[:-1] + (NX,))
        out[..., POS] = p
        out[..., YAW] = self.heading_rad
        out[..., LIN] = v
        return out


@dataclass(frozen=True)
class HeaveDock(TranslatingDock):
    """A dock heaving as ``z(t) = z0 + A sin(w t + phase)``.

    Parameters
    ----------
    position_ned_m : tuple of 3 floats
        Mean dock position (north, east, down) in metres; ``down`` is z0.
    heading_rad : float
        Target heading of a docked vehicle, radians.
    amplitude_m : float
        Heave amplitude A in metres (>= 0).
    angular_frequency_rad_s : float
        Heave angular frequency w in rad/s (>= 0).
    phase_rad : float
        Phase of the heave at t = 0, radians.
    """

    position_ned_m: tuple[float, float, float]
    heading_rad: float = 0.0
    amplitude_m: float = 0.0
    angular_frequency_rad_s: float = 0.0
    phase_rad: float = 0.0

    @property
    def frequency_hz(self) -> float:
        """Heave frequency in Hz."""
        return self.angular_frequency_rad_s / (2.0 * math.pi)

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Dock position (north, east, down) in m at time(s) ``t`` (s); shape (..., 3)."""
        t = np.asarray(t, dtype=float)
        n, e, z0 = self.position_ned_m
        z = z0 + self.amplitude_m * np.sin(self.angular_frequency_rad_s * t + self.phase_rad)
        return np.stack([np.full_like(z, n), np.full_like(z, e), z], axis=-1)

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        """Dock velocity (north, east, down) in m/s at time(s) ``t`` (s); shape (..., 3)."""
        t = np.asarray(t, dtype=float)
        w = self.angular_frequency_rad_s
        zd = w * self.amplitude_m * np.cos(w * t + self.phase_rad)
        return np.stack([np.zeros_like(zd), np.zeros_like(zd), zd], axis=-1)


class ClockedDock(TranslatingDock):
    """A dock's motion on another clock: ``position(t) = dock.position(t + offset_s)``.

    ``fly`` gives a dock whose motion the mission states (Assumption 2) on the vehicle's clock
    (ArduSub's ``time_boot_ms``): the mission's phase is the dock's phase at the vehicle's boot, and
    ``offset_s`` (s) is the vehicle's time at the mission's t = 0, set when the control loop starts.
    A rehearsal's stand-in moves its dock on the same clock, so both see one dock.

    Parameters
    ----------
    dock : HeaveDock
        The motion on the other clock.
    offset_s : float
        The other clock's time at this one's t = 0, s.
    """

    def __init__(self, dock: HeaveDock, offset_s: float = 0.0) -> None:
        self.dock = dock
        self.offset_s = float(offset_s)
        self.heading_rad = dock.heading_rad

    @property
    def position_ned_m(self) -> tuple[float, float, float]:
        """The dock's anchor, NED m."""
        return self.dock.position_ned_m

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Dock position (NED, m) at time(s) ``t`` (s) of this clock, shape (..., 3)."""
        return self.dock.position(np.asarray(t, dtype=float) + self.offset_s)

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        """Dock velocity (NED, m/s) at time(s) ``t`` (s) of this clock, shape (..., 3)."""
        return self.dock.velocity(np.asarray(t, dtype=float) + self.offset_s)


class ShiftedDock(TranslatingDock):
    """A dock moved by a constant offset: ``position(t) = dock.position(t) + offset_ned_m``.

    ``sitl-physics`` renders the dock where the camera sees it, ``camera.synthetic.dock_offset_m`` from
    where the mission charts it (so that only the camera can lead the vehicle there): that is the true
    dock, which its distances and its truth file measure against.

    Parameters
    ----------
    dock : TranslatingDock
        The motion shifted.
    offset_ned_m : array_like (3,)
        The shift, NED m.
    """

    def __init__(self, dock: TranslatingDock, offset_ned_m: np.ndarray | tuple[float, ...]) -> None:
        self.dock = dock
        self.offset_ned_m = np.asarray(offset_ned_m, dtype=float).reshape(3)
        self.heading_rad = dock.heading_rad

    @property
    def position_ned_m(self) -> tuple[float, float, float]:
        """The shifted dock's mean position, NED m."""
        mean = getattr(self.dock, "position_ned_m", (0.0, 0.0, 0.0))
        n, e, d = (np.array([float(v) for v in mean]) + self.offset_ned_m).tolist()
        return (n, e, d)

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Dock position (NED, m) at time(s) ``t`` (s), shape (..., 3)."""
        return self.dock.position(t) + self.offset_ned_m

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        """Dock velocity (NED, m/s) at time(s) ``t`` (s), shape (..., 3)."""
        return self.dock.velocity(t)


class TrackedDock:
    """A heave dock whose mean position is re-anchored by measurements (``auvdock fly``).

    Between measurements the dock moves as its heave model says (Assumption 2); each
    measured position ``p_meas`` at time ``t`` moves the model's mean position by
    ``gain * (p_meas - position(t))``.  Same interface as :class:`HeaveDock` for the
    controllers (``position``, ``velocity``, ``trajectory``, ``reference_state``,
    ``heading_rad``).

    With a ``process_noise`` and measurements that carry a covariance (the camera's), the
    blend is a Kalman filter on the offset: a random walk of ``process_noise`` m/sqrt(s)
    about the heave model, each measurement weighed by its covariance.

    Parameters
    ----------
    model : HeaveDock or ClockedDock
        The mission's dock motion (its mean position is the first guess).
    gain : float
        Weight of a new measurement without covariance, in (0, 1] (1: jump to it).
    process_noise : float, optional
        Random-walk intensity of the offset, m/sqrt(s) (Kalman mode).
    """

    def __init__(
        self, model: HeaveDock | ClockedDock, gain: float = 0.3, process_noise: float | None = None
    ) -> None:
        if not 0.0 < gain <= 1.0:
            raise ValueError(f"gain must be in (0, 1], got {gain}")
        if process_noise is not None and process_noise <= 0:
            raise ValueError(f"process_noise must be positive, got {process_noise}")
        self.model = model
        self.gain = float(gain)
        self.process_noise = process_noise
        self.offset = np.zeros(3)
        self.offset_covariance = np.eye(3) * 1e6  # nothing known before the first measurement
        self._t_cov = 0.0
        self.measurements = 0

    @property
    def heading_rad(self) -> float:
        return self.model.heading_rad

    @property
    def position_ned_m(self) -> tuple[float, float, float]:
        """The model's mean position moved by the measured offset (NED, m)."""
        n, e, d = np.asarray(self.model.position_ned_m, dtype=float) + self.offset
        return float(n), float(e), float(d)

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Dock position (NED, m) at time(s) t (s), shape (..., 3)."""
        return self.model.position(t) + self.offset

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        """Dock velocity (NED, m/s) at time(s) t (s), shape (..., 3)."""
        return self.model.velocity(t)

    def trajectory(self, t0: float, dt: float, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """As :meth:`HeaveDock.trajectory`, shifted by the measured offset."""
        t, p, v = self.model.trajectory(t0, dt, n_steps)
        return t, p + self.offset, v

    def reference_state(self, t: float | np.ndarray) -> np.ndarray:
        out = self.model.reference_state(t)
        out[..., 0:3] += self.offset
        return out

    def update(
        self, t: float, measured_position_ned: np.ndarray, covariance: np.ndarray | None = None
    ) -> None:
        """Blend in one measured dock position (NED, m) taken at time t (s).

        ``covariance`` (3, 3) of the measurement in m^2: a Kalman update when the dock has
        a ``process_noise``; otherwise the fixed-gain blend (the first measurement is taken
        as it is).
        """
        err = np.asarray(measured_position_ned, dtype=float) - self.position(t)
        if covariance is not None and self.process_noise is not None:
            dt = max(0.0, t - self._t_cov)
            P = self.offset_covariance + np.eye(3) * self.process_noise**2 * dt
            S = P + np.asarray(covariance, dtype=float)
            K = P @ np.linalg.inv(S)
            self.offset = self.offset + K @ err
            self.offset_covariance = (np.eye(3) - K) @ P
            self._t_cov = t
        else:
            self.offset = self.offset + (1.0 if self.measurements == 0 else self.gain) * err
        self.measurements += 1
