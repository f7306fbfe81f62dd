"""Thrusters: the allocation matrix B (tau = B u) and the Blue Robotics T200 curves.

Thruster i at position r_i (m, {b}) pushing along unit direction e_i contributes the
wrench ``[e_i; r_i x e_i]`` per newton, so ``B = [e_i; r_i x e_i]`` column by column
(6 x 8).  ArduSub's VECTORED_6DOF motor factors equal ``-B`` column for column
(parameters.md section 1).

T200 force-to-PWM fits (16 V, Blue Robotics performance data 2019; parameters.md)::

    forward  (F > 0): PWM = 1534.13 + 11.9405 F - 0.17247 F^2 + 0.00150 F^3
    reverse  (F < 0): PWM = 1467.58 + 15.4759 F + 0.29830 F^2 + 0.00347 F^3
    F = 0:            PWM = 1500 (centre of the dead band)
"""

from __future__ import annotations

import numpy as np

__all__ = ["allocation_matrix", "t200_force_to_pwm", "PWM_NEUTRAL_US", "PWM_MIN_US", "PWM_MAX_US"]

PWM_NEUTRAL_US = 1500.0
PWM_MIN_US = 1100.0
PWM_MAX_US = 1900.0

_FWD = (1534.13, 11.9405, -0.17247, 0.00150)
_REV = (1467.58, 15.4759, 0.29830, 0.00347)


def allocation_matrix(positions_m: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Thruster allocation matrix B, shape (6, n), from positions (n, 3, m) and unit directions (n, 3)."""
    r = np.asarray(positions_m, dtype=float)
    e = np.asarray(directions, dtype=float)
    return np.vstack([e.T, np.cross(r, e).T])


def t200_force_to_pwm(force_N: np.ndarray | float) -> np.ndarray:
    """PWM pulse width (us) that makes a T200 at 16 V push ``force_N`` newtons.

    Vectorised; the result is clipped to 1100..1900 us.  Zero force gives 1500 us.
    """
    f = np.asarray(force_N, dtype=float)
    fwd = _FWD[0] + f * (_FWD[1] + f * (_FWD[2] + f * _FWD[3]))
    rev = _REV[0] + f * (_REV[1] + f * (_REV[2] + f * _REV[3]))
    pwm = np.where(f > 0, fwd, np.where(f < 0, rev, PWM_NEUTRAL_US))
    return np.clip(pwm, PWM_MIN_US, PWM_MAX_US)
