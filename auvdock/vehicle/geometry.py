"""Numeric (numpy) rotation and angle helpers, kept once.

The symbolic twins used inside the vehicle model (``Rzyx``, ``Smtrx``) are in
:mod:`auvdock.vehicle.model`; these serve numeric code outside CasADi (simulated sensors,
the vehicle simulator, camera geometry, fly's frame mapping).  Conventions as in Fossen
(2021), *Handbook of Marine Craft Hydrodynamics and Motion Control*, 2nd ed., ch. 2.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["wrap_angle", "rotation_zyx", "Rz", "skew"]


def wrap_angle(angle: float) -> float:
    """Angle wrapped to [-pi, pi), rad."""
    return float((angle + math.pi) % (2.0 * math.pi) - math.pi)


def rotation_zyx(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """ZYX Euler rotation ``R = Rz(yaw) Ry(pitch) Rx(roll)``, shape (3, 3) (Fossen eq. 2.31).

    With the vehicle attitude (rad) this is ``R_nb``, mapping body vectors to NED.
    """
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, -sy * cr + cy * sp * sr, sy * sr + cy * cr * sp],
            [sy * cp, cy * cr + sr * sp * sy, -cy * sr + sp * sy * cr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def Rz(yaw: float) -> np.ndarray:
    """Rotation about the z axis by ``yaw`` (rad), shape (3, 3)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def skew(a: np.ndarray) -> np.ndarray:
    """S(a), the 3x3 skew-symmetric matrix with ``S(a) b = a x b`` (numeric ``Smtrx``)."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
