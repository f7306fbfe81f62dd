"""Named slices of the 12-state vector, so code says ``x[POS]`` instead of ``x[0:3]``.

``x = [eta; nu]`` (Fossen 2021, ch. 6): ``eta = [x, y, z, phi, theta, psi]`` the NED
position (m) and ZYX Euler angles (rad); ``nu = [u, v, w, p, q, r]`` the body-frame linear
velocity (m/s, over ground in the truth state, through the water in the Kinematic MPC's
``[eta; nu_r]``) and angular rate (rad/s).  The same slices index the MPC's plan states,
the results files' ``state`` rows and every estimator.
"""

from __future__ import annotations

__all__ = ["NX", "ETA", "NU", "POS", "ATT", "LIN", "ANG", "ROLL", "PITCH", "YAW", "DEPTH"]

#: Length of the state vector.
NX = 12
#: Pose eta (6): position and attitude.
ETA = slice(0, 6)
#: Body velocity nu (6): linear and angular.
NU = slice(6, 12)
#: NED position (3), m.
POS = slice(0, 3)
#: ZYX Euler angles phi, theta, psi (3), rad.
ATT = slice(3, 6)
#: Body linear velocity u, v, w (3), m/s.
LIN = slice(6, 9)
#: Body angular rate p, q, r (3), rad/s.
ANG = slice(9, 12)
#: Single components.
ROLL, PITCH, YAW = 3, 4, 5
#: Depth (NED down), m.
DEPTH = 2
