"""The pilot's six channels of the simulated ArduSub vehicle: RC_CHANNELS_OVERRIDE and MANUAL_CONTROL
turned into channels, the override's lapse and the pilot-input failsafe's timer.

Channels are RC PWM widths in us, channels 1..6 in
:data:`auvdock.vehicle.ardusub.CHANNELS` order (pitch, roll, throttle, yaw, forward,
lateral); 1500 us is neutral, the range 1100..1900 us.  Times are simulated s.

* ``RC_CHANNELS_OVERRIDE`` (:func:`channels_from_override`): ``chan1_raw`` ..
  ``chan6_raw``; 0 and 65535 (release / ignore) count as neutral 1500 (simplification:
  ArduPilot keeps the previous value for 65535 and releases to the RC radio, i.e. trim, for
  0); other values are clamped to 1100..1900 us.  Channels 7+ are ignored.
* ``MANUAL_CONTROL`` (:func:`channels_from_manual_control`, ArduSub's
  ``transform_manual_control_to_rc_override``): ``x`` forward, ``y`` lateral, ``r`` yaw in
  -1000..1000 and ``z`` throttle in 0..1000 (500 neutral) are scaled to [-1, 1] (x / 1000,
  y / 1000, r / 1000, (z - 500) / 500; INT16_MAX = axis invalid -> neutral), multiplied by
  the joystick gain (ArduSub's default 0.5) and become the channels
  ``trunc(1500 + 400 gain s)`` clamped to 1100..1900; pitch and roll stay 1500.  Buttons
  and the s / t / aux extensions are ignored.
* Either message replaces all six channels (:meth:`PilotInput.set`); the override lapses
  ``RC_OVERRIDE_TIME`` (default 3 s) after its last message, leaving neutral channels
  (0: overrides disabled, negative: they never lapse).
* Pilot-input failsafe (``FS_PILOT_TIMEOUT`` = 3 s, :meth:`PilotInput.lost`): 3 s without
  pilot input, counted from the later of the last input and the arming.
"""

from __future__ import annotations

import math

import numpy as np

from auvdock.standins.ardusub_params import OVERRIDE_TIMEOUT_S, PILOT_INPUT_TIMEOUT_S
from auvdock.vehicle.ardusub import NEUTRAL_CHANNELS, PWM_PER_UNIT
from auvdock.vehicle.thrusters import PWM_MAX_US, PWM_MIN_US, PWM_NEUTRAL_US

__all__ = ["channels_from_override", "channels_from_manual_control", "PilotInput"]

#: MANUAL_CONTROL's value for an axis that is not in use.
INT16_MAX = 32767


def channels_from_override(values: list[int] | np.ndarray) -> np.ndarray:
    """Channels 1..6 (us, CHANNELS order) of an RC_CHANNELS_OVERRIDE's chan1_raw..chan6_raw.

    0 and 65535 (release / ignore) give 1500; other values are clamped to 1100..1900.
    """
    v = np.asarray(values, dtype=float)[:6]
    out = np.clip(v, PWM_MIN_US, PWM_MAX_US)
    return np.where((v == 0) | (v == 65535), PWM_NEUTRAL_US, out)


def channels_from_manual_control(x: int, y: int, z: int, r: int, gain: float = 0.5) -> np.ndarray:
    """Channels 1..6 (us, CHANNELS order) of a MANUAL_CONTROL, as ArduSub's joystick code forms them.

    ``x`` forward, ``y`` lateral, ``r`` yaw in -1000..1000; ``z`` throttle in 0..1000 (500
    neutral); INT16_MAX marks an invalid axis (neutral).  Each axis becomes s in [-1, 1] and
    the channel ``trunc(1500 + 400 gain s)`` clamped to 1100..1900 us; pitch and roll are 1500.
    """

    def axis(value: int, centre: float, half: float) -> float:
        if value == INT16_MAX:
            return 0.0
        return float(np.clip((value - centre) / half, -1.0, 1.0))

    def chan(s: float) -> float:
        return float(np.clip(math.trunc(PWM_NEUTRAL_US + PWM_PER_UNIT * gain * s), PWM_MIN_US, PWM_MAX_US))

    return np.array(
        [
            PWM_NEUTRAL_US,
            PWM_NEUTRAL_US,
            chan(axis(z, 500.0, 500.0)),
            chan(axis(r, 0.0, 1000.0)),
            chan(axis(x, 0.0, 1000.0)),
            chan(axis(y, 0.0, 1000.0)),
        ]
    )


class PilotInput:
    """The pilot's last channels and when they came (see the module docstring).

    Parameters
    ----------
    lapse_s : float
        ``RC_OVERRIDE_TIME``, s: how long an override holds after its last message (0: overrides
        are disabled, the channels stay neutral; negative: an override never lapses).
    """

    def __init__(self, lapse_s: float = OVERRIDE_TIMEOUT_S) -> None:
        self.lapse_s = float(lapse_s)
        self._override = NEUTRAL_CHANNELS.astype(float).copy()
        self._last_override_t = -math.inf
        self._last_input_t = -math.inf

    def set(self, channels: np.ndarray, t: float) -> None:
        """Pilot input at simulated time ``t`` (s): ``channels`` (6,, us) replace the override."""
        self._override = np.asarray(channels, dtype=float)
        self._last_override_t = t
        self._last_input_t = t

    def release(self) -> None:
        """Drop the override now (the failsafe): neutral channels until the next pilot input."""
        self._override = NEUTRAL_CHANNELS.astype(float).copy()
        self._last_override_t = -math.inf

    def channels(self, t: float) -> np.ndarray:
        """The effective channels (6,, us) at simulated time ``t`` (s): the override, or neutral once
        lapsed (or with overrides disabled).  The override is returned as held: do not change it."""
        lapse = self.lapse_s
        if lapse == 0.0:  # overrides disabled
            return NEUTRAL_CHANNELS.astype(float)
        if lapse < 0 or t - self._last_override_t < lapse:
            return self._override
        return NEUTRAL_CHANNELS.astype(float)

    def lost(self, t: float, armed_at: float) -> bool:
        """Whether the pilot-input failsafe is due at ``t`` (s) for a vehicle armed at ``armed_at`` (s):
        ``FS_PILOT_TIMEOUT`` (3 s) without input, counted from the later of the last input and the
        arming."""
        return t - max(self._last_input_t, armed_at) >= PILOT_INPUT_TIMEOUT_S
