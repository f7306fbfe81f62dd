"""What the simulated ArduSub vehicle does with the messages it receives: commands, parameters,
modes, arming, pilot input and the pilot-input failsafe.

:class:`CommandHandler` holds the state those messages change (armed, the mode, the pilot's
channels, the events) and answers through an :class:`auvdock.standins.telemetry_out.Outbox`;
:class:`auvdock.standins.vehicle_sim.VehicleSim` feeds it every message it receives and steps
its failsafe.  Times are simulated s (``t``); :class:`SimEvent` also carries the clock's time.

Messages handled
----------------
* ``COMMAND_LONG`` and ``COMMAND_INT`` whose target_system is 1 or 0 (broadcast), from any
  system; the ``COMMAND_ACK`` carries the command, the result and the sender as target:

  - ``MAV_CMD_COMPONENT_ARM_DISARM``: param1 = 1 arms, 0 disarms -> ``MAV_RESULT_ACCEPTED``
    (also when already in that state); arming with ``refuse_arm`` -> ``MAV_RESULT_FAILED``;
    arming while a pre-arm check fails (:attr:`CommandHandler.prearm_failure`) ->
    ``MAV_RESULT_FAILED`` and STATUSTEXT "Arm: REASON", as ArduPilot reports it; other
    param1 -> ``MAV_RESULT_DENIED``.
  - ``MAV_CMD_DO_SET_MODE``: param1 = base mode (must have
    ``MAV_MODE_FLAG_CUSTOM_MODE_ENABLED``, else ``MAV_RESULT_DENIED`` as in ArduPilot),
    param2 = custom mode -> ``MAV_RESULT_ACCEPTED``; a number not in
    :data:`auvdock.vehicle.ardusub.MODES` -> ``MAV_RESULT_DENIED`` (real ArduPilot answers
    FAILED).
  - ``MAV_CMD_SET_MESSAGE_INTERVAL``: the telemetry's rates
    (:meth:`auvdock.standins.telemetry_out.StreamSchedule.set_interval`).
  - any other command -> ``MAV_RESULT_UNSUPPORTED``.
* ``PARAM_REQUEST_READ`` and ``PARAM_REQUEST_LIST`` (target_system 1 or 0) -> ``PARAM_VALUE``
  (:mod:`auvdock.standins.ardusub_params`).
* ``SET_MODE`` (target_system 1 or 0): as ``MAV_CMD_DO_SET_MODE`` with base_mode and
  custom_mode; acknowledged, like ArduPilot, by a ``COMMAND_ACK`` whose command is 11 (the
  message id of SET_MODE).
* ``RC_CHANNELS_OVERRIDE`` and ``MANUAL_CONTROL``: pilot input
  (:mod:`auvdock.standins.pilot_input`), accepted **only** from system ``gcs_sysid``
  (ArduSub's ``SYSID_MYGCS``, default 255) **and** with target 1; others are ignored and
  counted (:attr:`CommandHandler.ignored`).
* Anything else is left alone.

Vehicle behaviour
-----------------
* Arming: by command only (no pre-arm checks but :attr:`CommandHandler.prearm_failure`).
  Every mode (STABILIZE, ALT_HOLD, POSHOLD, ...) is accepted and reported but flown like
  MANUAL (simplification: no attitude, depth or position controllers).
* Pilot input failsafe (``FS_PILOT_INPUT`` = disarm, ``FS_PILOT_TIMEOUT`` = 3 s,
  :meth:`CommandHandler.check_failsafe`): while armed, 3 s without an accepted
  ``RC_CHANNELS_OVERRIDE`` / ``MANUAL_CONTROL`` -> neutral channels, disarm, STATUSTEXT "Lost
  manual control" (severity CRITICAL); events ``failsafe`` then ``disarm``.  The 3 s are
  counted from the later of the last pilot input and the arming (real ArduSub latches the
  failsafe once per loss and so may not disarm a vehicle armed during a loss; SITL builds of
  ArduSub skip this failsafe altogether).
* Arming and disarming send STATUSTEXT "Arming motors" / "Disarming motors" (severity INFO).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auvdock.runtime.clock import Clock
from auvdock.standins.ardusub_params import OVERRIDE_TIMEOUT_S, SYSTEM_ID, answer_list, answer_read
from auvdock.standins.pilot_input import PilotInput, channels_from_manual_control, channels_from_override
from auvdock.standins.telemetry_out import Outbox, StreamSchedule
from auvdock.vehicle.ardusub import MODES

__all__ = ["SimEvent", "CommandHandler", "MODE_NAMES"]

M = mavlink2

#: ArduSub mode number (custom_mode) -> name.
MODE_NAMES: dict[int, str] = {v: k for k, v in MODES.items()}


def _for_this_vehicle(msg: mavlink2.MAVLink_message) -> bool:
    """Whether a command or request is addressed to this vehicle (its system id, or 0: broadcast)."""
    return msg.target_system in (0, SYSTEM_ID)


@dataclass(frozen=True)
class SimEvent:
    """Something the vehicle did: ``kind`` is "arm", "disarm", "mode" or "failsafe".

    ``wall_time`` is the clock's ``time()`` (s since the epoch; ``time.time()`` on the wall
    clock), ``t`` the simulated time (s), ``detail`` free text
    (e.g. "gcs command", "pilot input failsafe", "MANUAL -> ALT_HOLD").
    """

    wall_time: float
    t: float
    kind: str
    detail: str


class CommandHandler:
    """The vehicle's side of every message it receives (see the module docstring).

    Not thread-safe on its own: :class:`auvdock.standins.vehicle_sim.VehicleSim` calls it
    under its lock.

    Parameters
    ----------
    params : dict
        The parameters the vehicle reports (:func:`auvdock.standins.ardusub_params.vehicle_parameters`);
        ``RC_OVERRIDE_TIME`` (s) is the override's lapse.
    gcs_sysid : int
        The only system whose RC_CHANNELS_OVERRIDE / MANUAL_CONTROL are obeyed (SYSID_MYGCS).
    joystick_gain : float
        Pilot gain applied to MANUAL_CONTROL axes (ArduSub default 0.5).
    refuse_arm : bool
        Answer arming commands with MAV_RESULT_FAILED (for tests).
    streams : StreamSchedule
        The telemetry's rates, which MAV_CMD_SET_MESSAGE_INTERVAL sets.
    out : Outbox
        Where acknowledgements, PARAM_VALUE and STATUSTEXT go.
    clock : Clock
        Stamps the events (``clock.time()``).
    on_output_change : callable
        Called when what the motors should do may have changed (armed or disarmed, new pilot input).
    """

    def __init__(
        self,
        params: dict[str, float],
        *,
        gcs_sysid: int,
        joystick_gain: float,
        refuse_arm: bool,
        streams: StreamSchedule,
        out: Outbox,
        clock: Clock,
        on_output_change: Callable[[], None],
    ) -> None:
        self.params = params
        self.gcs_sysid = int(gcs_sysid)
        self.joystick_gain = float(joystick_gain)
        self.refuse_arm = bool(refuse_arm)
        self.streams = streams
        self.out = out
        self.clock = clock
        self._on_output_change = on_output_change
        self.pilot = PilotInput(float(params.get("RC_OVERRIDE_TIME", OVERRIDE_TIMEOUT_S)))
        #: Whether the motors are armed, and since when (simulated s).
        self.armed = False
        self.armed_at = 0.0
        #: The mode number (custom_mode); boots in MANUAL.
        self.mode = MODES["MANUAL"]
        #: A failing pre-arm check (None: all pass).
        self.prearm_failure: str | None = None
        #: Arm, disarm, mode and failsafe events, oldest first.
        self.events: list[SimEvent] = []
        #: RC_CHANNELS_OVERRIDE / MANUAL_CONTROL ignored (wrong sender or target).
        self.ignored = 0
        self._handlers: dict[str, Callable[[mavlink2.MAVLink_message, float], None]] = {
            "COMMAND_LONG": self._on_command,
            "COMMAND_INT": self._on_command,
            "SET_MODE": self._on_set_mode,
            "RC_CHANNELS_OVERRIDE": self._on_rc_override,
            "MANUAL_CONTROL": self._on_manual_control,
            "PARAM_REQUEST_READ": self._on_param_request_read,
            "PARAM_REQUEST_LIST": self._on_param_request_list,
            "TIMESYNC": self._on_timesync,
        }

    def channels(self, t: float) -> np.ndarray:
        """The pilot channels (6,, us) in effect at ``t`` (s) (:meth:`PilotInput.channels`)."""
        return self.pilot.channels(t)

    def handle(self, msg: mavlink2.MAVLink_message, t: float) -> bool:
        """Act on a received message at ``t`` (s); False when it is malformed (CRC-valid, but with a
        field its handler cannot use)."""
        handler = self._handlers.get(msg.get_type())
        if handler is not None:
            try:
                handler(msg, t)
            except (ValueError, TypeError, OverflowError, AttributeError):  # malformed but CRC-valid
                return False
        return True

    def check_failsafe(self, t: float) -> None:
        """The pilot-input failsafe at ``t`` (s): disarm once the pilot has been silent for too long."""
        if not self.armed or not self.pilot.lost(t, self.armed_at):
            return
        self._event("failsafe", "pilot input: no RC_CHANNELS_OVERRIDE / MANUAL_CONTROL for 3 s", t)
        self.out.statustext(M.MAV_SEVERITY_CRITICAL, "Lost manual control")
        self.pilot.release()
        self._set_armed(False, "pilot input failsafe", t)

    # --- commands ----------------------------------------------------------------------------
    def _on_command(self, msg: mavlink2.MAVLink_message, t: float) -> None:
        if not _for_this_vehicle(msg):
            return
        cmd = int(msg.command)
        if cmd == M.MAV_CMD_COMPONENT_ARM_DISARM:
            result = self._cmd_arm(float(msg.param1), t)
        elif cmd == M.MAV_CMD_DO_SET_MODE:
            if math.isfinite(msg.param1) and math.isfinite(msg.param2):
                result = self._set_mode(int(msg.param1), int(msg.param2), t)
            else:
                result = M.MAV_RESULT_DENIED
        elif cmd == M.MAV_CMD_SET_MESSAGE_INTERVAL:
            result = self.streams.set_interval(msg.param1, msg.param2, t)
        else:
            result = M.MAV_RESULT_UNSUPPORTED
        self._ack(cmd, result, msg)

    def _on_set_mode(self, msg: mavlink2.MAVLink_message, t: float) -> None:
        if not _for_this_vehicle(msg):
            return
        result = self._set_mode(int(msg.base_mode), int(msg.custom_mode), t)
        self._ack(M.MAVLINK_MSG_ID_SET_MODE, result, msg)

    def _ack(self, command: int, result: int, msg: mavlink2.MAVLink_message) -> None:
        self.out.send(
            M.MAVLink_command_ack_message(
                command,
                result,
                target_system=msg.get_srcSystem(),
                target_component=msg.get_srcComponent(),
            )
        )

    def _cmd_arm(self, param1: float, t: float) -> int:
        if param1 == 1.0:
            if self.refuse_arm:
                return M.MAV_RESULT_FAILED
            if self.prearm_failure is not None and not self.armed:
                self.out.statustext(M.MAV_SEVERITY_CRITICAL, f"Arm: {self.prearm_failure}")
                return M.MAV_RESULT_FAILED
            self._set_armed(True, "gcs command", t)
            return M.MAV_RESULT_ACCEPTED
        if param1 == 0.0:
            self._set_armed(False, "gcs command", t)
            return M.MAV_RESULT_ACCEPTED
        return M.MAV_RESULT_DENIED

    def _set_armed(self, armed: bool, reason: str, t: float) -> None:
        if armed == self.armed:
            return
        self.armed = armed
        if armed:
            self.armed_at = t
        self._event("arm" if armed else "disarm", reason, t)
        self.out.statustext(M.MAV_SEVERITY_INFO, "Arming motors" if armed else "Disarming motors")
        self._on_output_change()

    def _set_mode(self, base_mode: int, custom_mode: int, t: float) -> int:
        if not base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED or custom_mode not in MODE_NAMES:
            return M.MAV_RESULT_DENIED
        if custom_mode != self.mode:
            self._event("mode", f"{MODE_NAMES[self.mode]} -> {MODE_NAMES[custom_mode]}", t)
            self.mode = custom_mode
        return M.MAV_RESULT_ACCEPTED

    def _event(self, kind: str, detail: str, t: float) -> None:
        self.events.append(SimEvent(self.clock.time(), t, kind, detail))

    # --- parameters --------------------------------------------------------------------------
    def _on_param_request_read(self, msg: mavlink2.MAVLink_message, t: float) -> None:
        if not _for_this_vehicle(msg):
            return
        self.out.send_all(answer_read(self.params, int(msg.param_index), msg.param_id))

    def _on_param_request_list(self, msg: mavlink2.MAVLink_message, t: float) -> None:
        if not _for_this_vehicle(msg):
            return
        self.out.send_all(answer_list(self.params))

    def _on_timesync(self, msg: mavlink2.MAVLink_message, t: float) -> None:
        """A TIMESYNC request (``tc1`` 0) answered as ArduPilot does: ``tc1`` the vehicle's time of its
        arrival (ns since boot, here ``t``), ``ts1`` echoed; an answer (``tc1`` not 0) is not ours."""
        if int(msg.tc1) != 0:
            return
        self.out.send(M.MAVLink_timesync_message(int(round(t * 1e9)), int(msg.ts1)))

    # --- pilot input -------------------------------------------------------------------------
    def _pilot_input_allowed(self, msg: mavlink2.MAVLink_message, target: int) -> bool:
        if msg.get_srcSystem() != self.gcs_sysid or target != SYSTEM_ID:
            self.ignored += 1
            return False
        return True

    def _on_rc_override(self, msg: mavlink2.MAVLink_message, t: float) -> None:
        if not self._pilot_input_allowed(msg, int(msg.target_system)):
            return
        raw = [int(getattr(msg, f"chan{i}_raw")) for i in range(1, 7)]
        self._set_override(channels_from_override(raw), t)

    def _on_manual_control(self, msg: mavlink2.MAVLink_message, t: float) -> None:
        if not self._pilot_input_allowed(msg, int(msg.target)):
            return
        ch = channels_from_manual_control(int(msg.x), int(msg.y), int(msg.z), int(msg.r), self.joystick_gain)
        self._set_override(ch, t)

    def _set_override(self, channels: np.ndarray, t: float) -> None:
        self.pilot.set(channels, t)
        self._on_output_change()
