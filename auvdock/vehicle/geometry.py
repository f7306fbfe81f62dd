"""Numeric (numpy) rotation and angle helpers, kept once.

The symbolic twins used inside the vehicle model (``Rzyx``, ``Smtrx``) are in
:mod:`auvdock.vehicle.model`; these serve numeric code outside CasADi (simulated sensors,
the vehicle simulator, camera geometry, fly's frame mapping).  :func:`point_in_sensor_frame`
is written with ``@`` and ``.T`` only, so the same formula serves numpy and CasADi.  Conventions as in Fossen
(2021), *Handbook of Marine Craft Hydrodynamics and Motion Control*, 2nd ed., ch. 2.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["wrap_angle", "zyx_entries", "rotation_zyx", "rotation_of", "Rz", "skew", "point_in_sensor_frame"]


def wrap_angle(angle: float) -> float:
    """Angle wrapped to [-pi, pi), rad."""
    return float((angle + math.pi) % (2.0 * math.pi) - math.pi)


def zyx_entries(roll: Any, pitch: Any, yaw: Any, cos: Any = math.cos, sin: Any = math.sin) -> tuple[Any, ...]:
    """The nine entries of ``R = Rz(yaw) Ry(pitch) Rx(roll)``, row-major (Fossen eq. 2.31): the one
    formula of the ZYX rotation, in numbers (``math``'s cos and sin, the default) or in CasADi's
    (:func:`auvdock.vehicle.model.Rzyx`)."""
    cr, sr = cos(roll), sin(roll)
    cp, sp = cos(pitch), sin(pitch)
    cy, sy = cos(yaw), sin(yaw)
    return (
        cy * cp, -sy * cr + cy * sp * sr, sy * sr + cy * cr * sp,
        sy * cp, cy * cr + sr * sp * sy, -cy * sr + sp * sy * cr,
        -sp, cp * sr, cp * cr,
    )  # fmt: skip


def rotation_zyx(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """ZYX Euler rotation ``R = Rz(yaw) Ry(pitch) Rx(roll)``, shape (3, 3) (Fossen eq. 2.31).

    With the vehicle attitude (rad) this is ``R_nb``, mapping body vectors to NED.
    """
    return np.array(zyx_entries(roll, pitch, yaw)).reshape(3, 3)


def rotation_of(angles: np.ndarray) -> np.ndarray:
    """:func:`rotation_zyx` of an attitude given as one array ``(roll, pitch, yaw)`` (rad; e.g. the
    state's ``x[ATT]``), shape (3, 3): ``R_nb``, body vectors to NED."""
    return rotation_zyx(float(angles[0]), float(angles[1]), float(angles[2]))


def Rz(yaw: float) -> np.ndarray:
    """Rotation about the z axis by ``yaw`` (rad), shape (3, 3)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def skew(a: np.ndarray) -> np.ndarray:
    """S(a), the 3x3 skew-symmetric matrix with ``S(a) b = a x b`` (numeric ``Smtrx``)."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def point_in_sensor_frame(R_nb, p_nb, point_n, R_bs, t_bs):  # noqa: ANN001, ANN201 -- numpy or CasADi
    """A point of {n} in the frame {s} of a sensor on the body: ``R_bs^T (R_nb^T (point_n - p_nb) - t_bs)``.

    Parameters
    ----------
    R_nb : (3, 3)
        Body attitude, {b} -> {n} (``rotation_zyx`` of the Euler angles).
    p_nb : (3,)
        Body origin in {n}, m.
    point_n : (3,)
        The point in {n}, m (the dock's docking point, for the camera's fix).
    R_bs : (3, 3)
        Sensor axes in {b} (:meth:`auvdock.camera.model.CameraMount.R_bc` for the camera).
    t_bs : (3,)
        Sensor origin in {b}, m.

    numpy arrays or CasADi expressions (the navigation filter's measurement model): the one
    formula of the camera's relative fix, for the simulated camera
    (:mod:`auvdock.sensing.camera_fix`), the filter (:mod:`auvdock.sensing.measurements`, kind
    ``dock``) and :func:`auvdock.camera.model.camera_from_dock`.
    """
    return R_bs.T @ (R_nb.T @ (point_n - p_nb) - t_bs)
