"""The parameters the simulated ArduSub vehicle reports, and how it answers for them on MAVLink.

:func:`default_parameters` is what a BlueROV2 Heavy's ArduSub reports, as far as ``fly``
checks it (:mod:`auvdock.fly.conformance`); :func:`vehicle_parameters` applies a simulator's
changes to it.  :class:`auvdock.standins.vehicle_sim.VehicleSim` answers from that table:

* ``PARAM_REQUEST_READ`` (by ``param_index`` in name order, or, with ``param_index`` -1, by
  ``param_id``) -> one ``PARAM_VALUE``; like ArduPilot, nothing for a name the vehicle does
  not have or an index past the end (:func:`answer_read`).
* ``PARAM_REQUEST_LIST`` -> a ``PARAM_VALUE`` for every parameter, in name order
  (:func:`answer_list`).
* ``PARAM_VALUE``: ``param_id`` the name, ``param_value`` the value (float),
  ``param_type`` ``MAV_PARAM_TYPE_REAL32``, ``param_count`` the number of parameters,
  ``param_index`` the name's place in name order (from 0).

Units are ArduPilot's: times in s, pressures in Pa, ids and enumerations as numbers.
"""

from __future__ import annotations

from collections.abc import Mapping

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auvdock.fly.units import ATMOSPHERE_HPA, WATER_DENSITY

__all__ = [
    "SYSTEM_ID",
    "COMPONENT_ID",
    "OVERRIDE_TIMEOUT_S",
    "PILOT_INPUT_TIMEOUT_S",
    "default_parameters",
    "vehicle_parameters",
    "answer_read",
    "answer_list",
]

M = mavlink2

#: The vehicle's MAVLink system id (ArduPilot's SYSID_THISMAV default).
SYSTEM_ID = 1
#: The vehicle's component id, MAV_COMP_ID_AUTOPILOT1.
COMPONENT_ID = 1
#: ArduPilot's RC_OVERRIDE_TIME default: an override lapses this long after its last message, s.
OVERRIDE_TIMEOUT_S = 3.0
#: ArduSub's FS_PILOT_TIMEOUT default: the pilot-input failsafe's time-out, s.
PILOT_INPUT_TIMEOUT_S = 3.0


def default_parameters(gcs_sysid: int = 255) -> dict[str, float]:
    """The parameters a BlueROV2 Heavy's ArduSub reports, as far as ``fly`` checks them
    (:mod:`auvdock.fly.conformance`): ArduSub's defaults with FRAME_CONFIG 2 (Vectored_6DOF),
    motors 1..8 on outputs 1..8 (SERVOn_FUNCTION 33..40), every MOT_n_DIRECTION 1."""
    params: dict[str, float] = {
        "SYSID_MYGCS": float(gcs_sysid),
        "FRAME_CONFIG": 2.0,
        "RC_OVERRIDE_TIME": OVERRIDE_TIMEOUT_S,
        "FS_PILOT_INPUT": 2.0,
        "FS_PILOT_TIMEOUT": PILOT_INPUT_TIMEOUT_S,
        "FS_GCS_ENABLE": 2.0,
        "FS_GCS_TIMEOUT": 5.0,
        # the depth calibration its SCALED_PRESSURE2 follows: standard atmosphere, sea water
        "BARO1_GND_PRESS": ATMOSPHERE_HPA * 100.0,
        "BARO2_GND_PRESS": ATMOSPHERE_HPA * 100.0,
        "BARO_SPEC_GRAV": WATER_DENSITY / 1000.0,
    }
    for n in range(1, 9):
        params[f"MOT_{n}_DIRECTION"] = 1.0
        params[f"SERVO{n}_FUNCTION"] = float(32 + n)
    return params


def vehicle_parameters(
    changes: Mapping[str, float | None] | None, gcs_sysid: int = 255
) -> tuple[dict[str, float], int]:
    """(parameters, GCS system id) of a simulated vehicle: :func:`default_parameters` of
    ``gcs_sysid`` with ``changes`` applied (a value replaces or adds a parameter; None removes
    it, as if the firmware had no such parameter), and ``gcs_sysid`` unless ``changes`` sets
    ``SYSID_MYGCS`` or ``MAV_GCS_SYSID`` (the later of the two when both)."""
    params = default_parameters(gcs_sysid)
    changes = changes or {}
    for name, value in changes.items():
        if value is None:
            params.pop(name, None)
        else:
            params[name] = float(value)
    for name in ("SYSID_MYGCS", "MAV_GCS_SYSID"):
        value = changes.get(name)
        if value is not None:
            gcs_sysid = int(value)
    return params, int(gcs_sysid)


def _param_value(params: Mapping[str, float], names: list[str], name: str) -> mavlink2.MAVLink_message:
    """PARAM_VALUE of parameter ``name``; ``names`` is every parameter's name, sorted."""
    return M.MAVLink_param_value_message(
        name.encode(), float(params[name]), M.MAV_PARAM_TYPE_REAL32, len(names), names.index(name)
    )


def answer_read(
    params: Mapping[str, float], param_index: int, param_id: bytes | str
) -> list[mavlink2.MAVLink_message]:
    """The answer to a PARAM_REQUEST_READ: the PARAM_VALUE of parameter ``param_index`` (name
    order, from 0) or, when ``param_index`` is negative, of the name ``param_id`` (NUL padding
    stripped); no message for an index past the end or a name the vehicle does not have."""
    names = sorted(params)
    if param_index >= 0:
        return [_param_value(params, names, names[param_index])] if param_index < len(names) else []
    name = param_id.decode() if isinstance(param_id, bytes) else str(param_id)
    name = name.rstrip("\x00")
    return [_param_value(params, names, name)] if name in params else []


def answer_list(params: Mapping[str, float]) -> list[mavlink2.MAVLink_message]:
    """The answer to a PARAM_REQUEST_LIST: every parameter's PARAM_VALUE, in name order."""
    names = sorted(params)
    return [_param_value(params, names, name) for name in names]
