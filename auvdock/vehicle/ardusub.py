"""ArduSub's manual thrust path, both ways: thruster forces <-> RC override channels.

In MANUAL mode ArduSub (``ArduSub/mode_manual.cpp``, ``AP_Motors6DOF.cpp``) turns the six
pilot channels into motor outputs:

1. each override channel (1100..1900 us, 1500 neutral) becomes an input in [-1, 1],
   ``(pwm - 1500) / 400`` (``norm_input``, no dead zone, no joystick gain), in the channel
   order of :data:`CHANNELS` (1 pitch, 2 roll, 3 throttle, 4 yaw, 5 forward, 6 lateral);
2. the VECTORED_6DOF mixer (``output_armed_stabilizing_vectored_6dof``) forms, per motor,
   ``rpt = roll f_r + pitch f_p + throttle f_t`` (vertical thrusters) and
   ``yfl = yaw f_y + forward f_f + lateral f_l`` (horizontal thrusters), divides each group by
   its largest magnitude only when that exceeds 1, and clips ``rpt + yfl`` to [-1, 1];
3. each motor command m becomes ``PWM = 1500 + 400 m`` (``calc_thrust_to_pwm``).

The motor factors (:data:`MOTOR_FACTORS`) have the signs of ``-B`` column for column
(docs/parameter-sources.md section 1): a positive motor command pushes along ``-e_i``.  Thruster force
``u_i`` in this package is along ``+e_i`` and its strong direction (51.4 N at 16 V) is
positive, so motor ``i`` at command ``m`` pushes ``u_i = T200(1500 - 400 m)``, with ``T200``
the inverse of :func:`auvdock.vehicle.thrusters.t200_force_to_pwm` (the propeller spins
the way that makes the T200's forward thrust point along ``e_i``).

:func:`channels_for_wrench` inverts the chain: the six channel values whose mixed,
PWM-mapped, T200-produced thrusts give a wanted body wrench (Newton iterations on the
six inputs); :func:`channels_for_thrust` does it for the wrench ``B u`` of the
controller's eight thrusts (six channels cannot set eight thrusts, only their wrench).
"""

from __future__ import annotations

import math

import numpy as np

from auvdock.vehicle.thrusters import (
    PWM_MAX_US,
    PWM_MIN_US,
    PWM_NEUTRAL_US,
    T200,
    ThrusterCurve,
    t200_pwm_to_force,
)

__all__ = [
    "CHANNELS",
    "MOTOR_FACTORS",
    "PWM_PER_UNIT",
    "MODES",
    "mix",
    "motor_pwm",
    "t200_pwm_to_force",
    "thrust_from_channels",
    "channels_for_wrench",
    "channels_for_thrust",
    "NEUTRAL_CHANNELS",
]

PWM_PER_UNIT = 400.0

#: RC override channels 1..6 of ArduSub's manual control, in order.
CHANNELS = ("pitch", "roll", "throttle", "yaw", "forward", "lateral")
NEUTRAL_CHANNELS = np.full(6, PWM_NEUTRAL_US)

#: ArduSub flight modes by custom_mode number.
MODES = {"STABILIZE": 0, "ACRO": 1, "ALT_HOLD": 2, "GUIDED": 4, "POSHOLD": 16, "MANUAL": 19}

# AP_Motors6DOF::setup_motors, SUB_FRAME_VECTORED_6DOF:
#   add_motor_raw_6dof(motor, roll, pitch, yaw, throttle, forward, lateral, order)
_RAW = np.array(
    [
        [0, 0, 1, 0, -1, 1],
        [0, 0, -1, 0, -1, -1],
        [0, 0, -1, 0, 1, 1],
        [0, 0, 1, 0, 1, -1],
        [1, -1, 0, -1, 0, 0],
        [-1, -1, 0, -1, 0, 0],
        [1, 1, 0, -1, 0, 0],
        [-1, 1, 0, -1, 0, 0],
    ],
    dtype=float,
)
#: Motor factors (8 x 6), columns in :data:`CHANNELS` order (pitch, roll, throttle, yaw, forward, lateral).
MOTOR_FACTORS = _RAW[:, [1, 0, 3, 2, 4, 5]]
_VERTICAL = (0, 1, 2)  # pitch, roll, throttle: the "rpt" group
_HORIZONTAL = (3, 4, 5)  # yaw, forward, lateral: the "yfl" group
# the groups' factor columns, cut once (C-contiguous, as the fancy indexing made them)
_F_VERTICAL = np.ascontiguousarray(MOTOR_FACTORS[:, _VERTICAL])
_F_HORIZONTAL = np.ascontiguousarray(MOTOR_FACTORS[:, _HORIZONTAL])
# for rows of inputs: the factors transposed (6, 8); the horizontal group drives motors 0-3 and
# the vertical group motors 4-7, each motor's factors being zero in the other group
_F_T = np.ascontiguousarray(MOTOR_FACTORS.T)
assert not np.any(MOTOR_FACTORS[:4, list(_VERTICAL)]) and not np.any(MOTOR_FACTORS[4:, list(_HORIZONTAL)])


def mix(inputs: np.ndarray) -> np.ndarray:
    """ArduSub's VECTORED_6DOF mixer: six inputs in [-1, 1] (CHANNELS order) -> 8 motor commands."""
    c = np.clip(np.asarray(inputs, dtype=float), -1.0, 1.0)
    rpt = _F_VERTICAL @ c[:3]
    yfl = _F_HORIZONTAL @ c[3:]
    rpt_max = max(1.0, float(np.max(np.abs(rpt))))
    yfl_max = max(1.0, float(np.max(np.abs(yfl))))
    return np.clip(rpt / rpt_max + yfl / yfl_max, -1.0, 1.0)


def _mix_rows(c: np.ndarray) -> np.ndarray:
    """:func:`mix` of rows of inputs (k, 6) already in [-1, 1] -> (k, 8) motor commands, the same bits.

    Each motor's sum runs over the inputs in order (three +-1 factors, the rest zero: the same
    sum as the mixer's), whatever the number of rows; motors 0-3 are the "yfl" group, 4-7 "rpt".
    """
    g = (c[:, :, None] * _F_T).sum(axis=1).reshape(-1, 2, 4)
    g_max = np.maximum(np.abs(g).max(axis=2, keepdims=True), 1.0)
    return np.minimum(np.maximum(g / g_max, -1.0), 1.0).reshape(-1, 8)


def motor_pwm(commands: np.ndarray) -> np.ndarray:
    """Motor PWM (us) of motor commands in [-1, 1]: ``1500 + 400 m`` clipped to 1100..1900."""
    m = np.asarray(commands, dtype=float)
    return np.clip(PWM_NEUTRAL_US + PWM_PER_UNIT * m, PWM_MIN_US, PWM_MAX_US)


def thrust_from_channels(channels_us: np.ndarray, curve: ThrusterCurve = T200) -> np.ndarray:
    """Thruster forces u (8, N, along +e_i) that ArduSub produces from six override channels (us),
    through the vehicle's thruster ``curve`` (default the T200's)."""
    c = (np.asarray(channels_us, dtype=float) - PWM_NEUTRAL_US) / PWM_PER_UNIT
    pwm = motor_pwm(mix(c))
    return curve.force(2 * PWM_NEUTRAL_US - pwm)


#: the line search's step sizes: the Newton step, halved up to 11 times
_STEP_SIZES = 0.5 ** np.arange(12)


def _inputs_to_channels(c: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(PWM_NEUTRAL_US + PWM_PER_UNIT * c), PWM_MIN_US, PWM_MAX_US)


def channels_for_wrench(
    wrench: np.ndarray,
    B: np.ndarray,
    *,
    curve: ThrusterCurve = T200,
    iterations: int = 40,
    tol_N: float = 1e-3,
) -> np.ndarray:
    """The six override channels (us, integers, CHANNELS order) that make ArduSub push ``wrench``.

    Parameters
    ----------
    wrench : ndarray (6,)
        Wanted body wrench [X Y Z (N), K M N (N m)] in {b}.
    B : ndarray (6, 8)
        Thruster allocation matrix.

    Solves ``B u(c) = wrench`` for the six inputs c by damped Newton iterations, ``u(c)``
    being the mixer + PWM + T200 chain of :func:`thrust_from_channels` before the rounding
    to whole microseconds.  The Jacobian ``B diag(-400 dT/dPWM) F`` uses the curve's slope at
    the edge of the dead band inside it, so the iteration crosses the band instead of
    stalling in it.  A wrench the chain cannot produce (beyond the thrusters, or needing
    thrust inside a dead band) is met in the least-squares sense as far as the iteration gets;
    zero wrench gives neutral channels exactly.
    """
    w = np.asarray(wrench, dtype=float)
    if not np.any(w):
        return NEUTRAL_CHANNELS.copy()
    B = np.asarray(B, dtype=float)
    # The line search halves the Newton step until the residual does not grow (at most 12
    # sizes).  The chain runs once for all 12 candidate inputs, as rows; the residuals are then
    # formed one candidate at a time, in order, up to the first one taken, each as ``B @ u - w``
    # (the same arithmetic as trying the candidates one by one: the same result, bit for bit).

    def thrusts(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # rows of inputs (k, 6) in [-1, 1] -> thrust (k, 8) and thruster PWM (k, 8), as
        # motor_pwm and thrust_from_channels form them (np.clip's bits, fewer calls)
        pwm = 2 * PWM_NEUTRAL_US - np.minimum(
            np.maximum(PWM_NEUTRAL_US + PWM_PER_UNIT * _mix_rows(c), PWM_MIN_US), PWM_MAX_US
        )
        return curve.force(pwm), pwm

    c = np.zeros(6)
    u_rows, pwm_rows = thrusts(c[None])
    u, pwm = u_rows[0], pwm_rows[0]
    r = B @ u - w
    r_norm = math.sqrt(r @ r)
    for _ in range(iterations):
        if np.abs(r).max() < tol_N:
            break
        J = B @ ((-PWM_PER_UNIT * curve.slope(pwm, u))[:, None] * MOTOR_FACTORS)
        step = np.linalg.lstsq(J, -r, rcond=None)[0]
        c_new = np.minimum(np.maximum(c + _STEP_SIZES[:, None] * step, -1.0), 1.0)  # np.clip's bits
        moved = (c_new != c).any(axis=1)
        u_new, pwm_new = thrusts(c_new)
        for k in range(len(_STEP_SIZES)):  # the step, its half, its quarter, ...
            r_new = B @ u_new[k] - w
            r_new_norm = math.sqrt(r_new @ r_new)
            # not worse: inside a dead band the thrust (so the residual) stays put while the
            # inputs walk towards the band's edge, so equal is progress too
            if r_new_norm <= r_norm and moved[k]:
                break
        else:
            break
        c, u, pwm, r, r_norm = c_new[k], u_new[k], pwm_new[k], r_new, r_new_norm
    return _inputs_to_channels(c)


def channels_for_thrust(thrust_N: np.ndarray, B: np.ndarray, curve: ThrusterCurve = T200) -> np.ndarray:
    """Override channels (us) for the wrench ``B u`` of eight thrusts (see channels_for_wrench)."""
    return channels_for_wrench(B @ np.asarray(thrust_N, dtype=float), B, curve=curve)
