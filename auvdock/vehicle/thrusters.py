"""Thrusters: the allocation matrix B (tau = B u) and the Blue Robotics T200 curves.

Thruster i at position r_i (m, {b}) pushing along unit direction e_i contributes the
wrench ``[e_i; r_i x e_i]`` per newton, so ``B = [e_i; r_i x e_i]`` column by column
(6 x 8).  ArduSub's VECTORED_6DOF motor factors equal ``-B`` column for column
(docs/parameter-sources.md section 1).

T200 force-to-PWM fits (16 V, Blue Robotics performance data 2019; docs/parameter-sources.md section 1)::

    forward  (F > 0): PWM = 1534.13 + 11.9405 F - 0.17247 F^2 + 0.00150 F^3
    reverse  (F < 0): PWM = 1467.58 + 15.4759 F + 0.29830 F^2 + 0.00347 F^3
    F = 0:            PWM = 1500 (centre of the dead band)

:class:`ThrusterCurve` is a vehicle's PWM -> force curve, per thruster: ``T200`` (the fit above,
inverted on a 5 mN grid) or ``quadratic`` (``F = max_N q |q|``, ``q = (PWM - 1500) / 400``, zero
within ``deadband_us`` of 1500: ArduPilot SITL's own submarine, ``libraries/SITL/SIM_Submarine.cpp``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "allocation_matrix",
    "t200_force_to_pwm",
    "t200_pwm_to_force",
    "ThrusterCurve",
    "T200",
    "PWM_NEUTRAL_US",
    "PWM_MIN_US",
    "PWM_MAX_US",
]

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


_F_GRID = np.linspace(-60.0, 60.0, 24001)
_PWM_GRID = t200_force_to_pwm(_F_GRID)
# the two branches of the curve, cut once (each is monotonic in PWM)
_FWD_PWM, _FWD_F = _PWM_GRID[_F_GRID > 0], _F_GRID[_F_GRID > 0]
_REV_PWM, _REV_F = _PWM_GRID[_F_GRID < 0], _F_GRID[_F_GRID < 0]


def t200_pwm_to_force(pwm_us: np.ndarray | float) -> np.ndarray:
    """Force (N) of a T200 at 16 V for a PWM pulse width: the inverse of ``t200_force_to_pwm``.

    Zero inside the dead band (about 1467.6..1534.1 us), saturating at -39.9 / +51.4 N.
    Interpolated on a 5 mN grid of the fitted curve (docs/parameter-sources.md section 1).
    """
    p = np.asarray(pwm_us, dtype=float)
    fwd = np.interp(p, _FWD_PWM, _FWD_F, left=0.0)
    rev = np.interp(p, _REV_PWM, _REV_F, right=0.0)
    return np.where(p > PWM_NEUTRAL_US, fwd, np.where(p < PWM_NEUTRAL_US, rev, 0.0))


def _t200_slope(pwm_us: np.ndarray, force_N: np.ndarray | None = None) -> np.ndarray:
    """dF/dPWM (N/us) of the T200 curve; inside the dead band the slope at its edge (bridges it).
    ``force_N``: the curve's force at ``pwm_us`` when the caller has it (not recomputed)."""
    f = t200_pwm_to_force(pwm_us) if force_N is None else np.asarray(force_N, dtype=float)
    fwd = _FWD[1] + 2 * _FWD[2] * f + 3 * _FWD[3] * f**2
    rev = _REV[1] + 2 * _REV[2] * f + 3 * _REV[3] * f**2
    dpwm_df = np.where(f > 0, fwd, np.where(f < 0, rev, np.where(pwm_us >= PWM_NEUTRAL_US, _FWD[1], _REV[1])))
    return 1.0 / dpwm_df


@dataclass(frozen=True)
class ThrusterCurve:
    """A vehicle's thruster curve: PWM pulse width (us) -> force (N), per thruster.

    Attributes
    ----------
    kind : str
        ``"T200"`` (Blue Robotics T200 at 16 V) or ``"quadratic"``.
    max_N : tuple of float
        quadratic: the force at full command (PWM 1900), per thruster (N).
    deadband_us : float
        quadratic: no force within this many us of 1500.
    """

    kind: str = "T200"
    max_N: tuple[float, ...] = ()
    deadband_us: float = 0.0

    def force(self, pwm_us: np.ndarray) -> np.ndarray:
        """Force (N) of each thruster at its PWM (us), shape of ``pwm_us``."""
        if self.kind == "T200":
            return t200_pwm_to_force(pwm_us)
        p = np.asarray(pwm_us, dtype=float)
        q = (p - PWM_NEUTRAL_US) / 400.0
        f = np.asarray(self.max_N, dtype=float) * q * np.abs(q)
        return np.where(np.abs(p - PWM_NEUTRAL_US) > self.deadband_us, f, 0.0)

    def slope(self, pwm_us: np.ndarray, force_N: np.ndarray | None = None) -> np.ndarray:
        """dF/dPWM (N/us) at each PWM; inside a dead band the slope at its edge (so that a Newton
        iteration on the channels crosses the band instead of stalling in it).  ``force_N``,
        optional: :meth:`force` at ``pwm_us``, when the caller has it already (saves computing it
        again; the result is the same)."""
        if self.kind == "T200":
            return _t200_slope(np.asarray(pwm_us, dtype=float), force_N)
        p = np.asarray(pwm_us, dtype=float)
        dq = np.maximum(np.abs(p - PWM_NEUTRAL_US), self.deadband_us) / 400.0
        return np.asarray(self.max_N, dtype=float) * 2.0 * dq / 400.0


#: The T200 curve (the BlueROV2 presets).
T200 = ThrusterCurve()
