"""Hold depth and attitude while the dock is out of sight: :class:`DepthAttitudeHold`.

When ``fly``'s camera loses the dock's markers, the MPC has nothing to steer to.  Neutral
thrust is not a hold: the BlueROV2 Heavy is about 2 N buoyant and rises (0.84 to 0.53 m in
3 s, measured against ArduSub SITL), and a current carries it off.  The hold computes the
body wrench (Fossen 2021, ch. 12, PD control with restoring-force compensation)

    tau = [ g_1..3(eta) + R^T f_n ; m_b ]
    f_n = -M_11 2 zeta w v_xy  (horizontal, NED)  and  -M_33 (w^2 (z - z_h) + 2 zeta w z_dot)  (down)
    m_b = -diag(M_44, M_55, M_66) (w^2 e_Theta + 2 zeta w nu_2),  e_Theta = [phi, theta, psi - psi_h]

with g_1..3(eta) the force part of the one model's restoring forces
(:meth:`auvdock.vehicle.model.VehicleModel.restoring`): the net buoyancy is cancelled, not fought
by the depth loop.  The righting moments are kept: the metacentric moment (about 2.3 N m/rad
for the Heavy) holds roll and pitch better than a loop of this bandwidth would (0.29 N m/rad at
1 rad/s), and cancelling it would only weaken the hold.  ``w`` is the loop's
natural frequency (``fly.hold_bandwidth_rad_s``) and ``zeta = 1`` (critically damped): depth
and heading are held where the hold began, roll and pitch at zero, the horizontal motion
over ground damped.  The wrench goes to the thrusters through
:func:`auvdock.vehicle.ardusub.channels_for_wrench` like every other command.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from auvdock.vehicle import Vehicle
from auvdock.vehicle.geometry import rotation_zyx, wrap_angle

__all__ = ["DepthAttitudeHold"]


class DepthAttitudeHold:
    """PD hold of depth and attitude with restoring-force compensation.

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle (its one model: mass matrix, restoring forces).
    bandwidth_rad_s : float
        Natural frequency of each loop, rad/s.
    damping : float
        Damping ratio (1: critically damped).
    """

    def __init__(self, vehicle: Vehicle, bandwidth_rad_s: float = 1.0, damping: float = 1.0) -> None:
        self.model = vehicle.model
        self.w = float(bandwidth_rad_s)
        self.zeta = float(damping)
        self._M = np.diag(self.model.M).copy()
        self._eta = ca.SX.sym("eta", 6)
        self._g = ca.Function("g", [self._eta], [self.model.restoring(self._eta)])
        self.target: tuple[float, float] | None = None  # (depth m, heading rad)

    @property
    def active(self) -> bool:
        """Whether a hold target is set (:meth:`start` called, :meth:`stop` not since)."""
        return self.target is not None

    def start(self, x: np.ndarray) -> None:
        """Hold the depth and heading of state ``x`` (12,), from now on."""
        self.target = (float(x[2]), float(x[5]))

    def stop(self) -> None:
        """Forget the target (the next :meth:`start` takes a new one)."""
        self.target = None

    def wrench(self, x: np.ndarray) -> np.ndarray:
        """The body wrench (6,) [X Y Z (N), K M N (N m)] that holds the target from state ``x`` (12,)."""
        if self.target is None:
            self.start(x)
        z_h, psi_h = self.target  # type: ignore[misc]
        w, zeta, M = self.w, self.zeta, self._M
        R = rotation_zyx(float(x[3]), float(x[4]), float(x[5]))
        v_n = R @ np.asarray(x[6:9], dtype=float)
        f_n = np.array(
            [
                -M[0] * 2 * zeta * w * v_n[0],
                -M[1] * 2 * zeta * w * v_n[1],
                -M[2] * (w * w * (float(x[2]) - z_h) + 2 * zeta * w * v_n[2]),
            ]
        )
        e_att = np.array([float(x[3]), float(x[4]), wrap_angle(float(x[5]) - psi_h)])
        m_b = -M[3:6] * (w * w * e_att + 2 * zeta * w * np.asarray(x[9:12], dtype=float))
        g = np.asarray(self._g(np.asarray(x[0:6], dtype=float))).ravel()
        return np.concatenate([g[0:3] + R.T @ f_n, m_b])
