"""Does the autopilot do what ``fly``'s commands assume?  ArduSub's parameters checked before arming.

``fly`` drives the thrusters through MANUAL-mode RC overrides, mapped with ArduSub's
VECTORED_6DOF mixer inverted (:mod:`auvdock.vehicle.ardusub`).  That is right only if the
vehicle is set up the way the map assumes, and safe only if the autopilot stops the
thrusters when ``fly`` goes silent.  :func:`check_parameters` reads the answer from the
vehicle's parameters (PARAM_VALUE) and returns one line per problem, each naming the
parameter, what it is, why it matters and the fix; a session refuses to arm while any
remains (a dry run reports them and goes on).

=====================  ===============================  ==========================================
parameter              required                         why (ArduSub / ArduPilot source)
=====================  ===============================  ==========================================
SYSID_MYGCS            our system id (``fly --sysid``)  overrides from any other system are
(MAV_GCS_SYSID since                                    dropped (GCS_MAVLink_Sub.cpp); its
ArduPilot 4.7)                                          heartbeats feed the GCS failsafe
FRAME_CONFIG           2 (Vectored_6DOF)                the mixer the channel map inverts
SERVOn_FUNCTION        32 + n (Motor n), n = 1..8       motor n on output n, as the map assumes;
                                                        RCPassThru would bypass the mixer (and
                                                        disarming would not stop the thrusters)
MOT_n_DIRECTION        1 or -1 (``fly.parameters``)     a thruster test fixes them per vehicle;
                                                        pin the found values in the mission
RC_OVERRIDE_TIME       > 3 control periods, <= 3 s      0 disables overrides; -1 never lapses (the
                                                        last thrust stays on if the link drops)
FS_PILOT_INPUT /       timeout > 3 control periods      the pilot-input failsafe must not disarm
FS_PILOT_TIMEOUT       when FS_PILOT_INPUT is 2         between two of our overrides
FS_GCS_ENABLE          2, 3 or 4                        a lost link must disarm, hold depth or
                                                        surface, not only warn
=====================  ===============================  ==========================================

Every parameter read, with its value, is also recorded in the session's events, so a
results file says what the vehicle was set to.
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = [
    "PARAMETER_GROUPS",
    "MAX_OVERRIDE_TIME_S",
    "FRAME_VECTORED_6DOF",
    "parameter_names",
    "resolve",
    "check_parameters",
]

#: ArduSub's FRAME_CONFIG value of the BlueROV2 Heavy's frame.
FRAME_VECTORED_6DOF = 2
#: The longest RC_OVERRIDE_TIME accepted, s: after a lost link the last thrust lasts this long.
MAX_OVERRIDE_TIME_S = 3.0
#: SERVOn_FUNCTION of motor n is MOTOR_n_FUNCTION_BASE + n.
MOTOR_FUNCTION_BASE = 32
_FRAMES = {0: "BlueROV1", 1: "Vectored", 2: "Vectored_6DOF", 3: "Vectored_6DOF_90", 4: "SimpleROV-3",
           5: "SimpleROV-4", 6: "SimpleROV-5", 7: "Custom"}  # fmt: skip
_GCS_FAILSAFE = {0: "disabled", 1: "warn only", 2: "disarm", 3: "depth hold", 4: "surface"}

#: What is read, in groups of alternative names (the first a vehicle reports is used).
PARAMETER_GROUPS: tuple[tuple[str, ...], ...] = (
    ("SYSID_MYGCS", "MAV_GCS_SYSID"),
    ("FRAME_CONFIG",),
    ("RC_OVERRIDE_TIME",),
    ("FS_PILOT_INPUT",),
    ("FS_PILOT_TIMEOUT",),
    ("FS_GCS_ENABLE",),
    *((f"SERVO{n}_FUNCTION",) for n in range(1, 9)),
    *((f"MOT_{n}_DIRECTION",) for n in range(1, 9)),
)


def parameter_names(extra: Mapping[str, float] | None = None) -> list[str]:
    """Every name to request: :data:`PARAMETER_GROUPS` and the mission's ``fly.parameters``."""
    names = [n for group in PARAMETER_GROUPS for n in group]
    names += [n for n in (extra or {}) if n not in names]
    return names


def resolve(params: Mapping[str, float], group: tuple[str, ...]) -> tuple[str, float | None]:
    """(name, value) of the first name of ``group`` the vehicle reported; (first name, None) if none."""
    for name in group:
        if name in params:
            return name, float(params[name])
    return group[0], None


def _fmt(v: float) -> str:
    return f"{v:g}"


def check_parameters(
    params: Mapping[str, float],
    *,
    sysid: int,
    dt: float,
    expected: Mapping[str, float] | None = None,
) -> list[str]:
    """The problems with the vehicle's parameters for flying ``fly``'s commands, one line each.

    Parameters
    ----------
    params : mapping
        The vehicle's parameters (name -> value) as read (PARAM_VALUE).
    sysid : int
        ``fly``'s own MAVLink system id.
    dt : float
        The control period, s (overrides are sent every ``dt``).
    expected : mapping, optional
        The mission's ``fly.parameters``: values the vehicle must have.

    Returns
    -------
    list of str
        Empty if the vehicle is fit to fly; else each line names the parameter, its value, the
        consequence and the fix.
    """
    out: list[str] = []
    if not params:
        return ["parameters: the vehicle answered no PARAM_REQUEST_READ (is it ArduSub?)"]
    periods = 3.0 * dt

    name, v = resolve(params, PARAMETER_GROUPS[0])
    if v is None:
        out.append(
            "SYSID_MYGCS: not reported (nor MAV_GCS_SYSID); cannot tell whether ArduSub obeys our overrides"
        )
    elif int(v) != sysid:
        out.append(
            f"{name} is {int(v)}, but fly sends as system {sysid}: ArduSub would ignore every "
            f"override; set {name} = {sysid} or run fly --sysid {int(v)}"
        )

    def value(pname: str) -> float | None:
        return None if pname not in params else float(params[pname])

    frame = value("FRAME_CONFIG")
    if frame is None:
        out.append("FRAME_CONFIG: not reported; fly's channel map is for ArduSub's frame 2 (Vectored_6DOF)")
    elif int(frame) != FRAME_VECTORED_6DOF:
        label = _FRAMES.get(int(frame), "unknown")
        out.append(
            f"FRAME_CONFIG is {int(frame)} ({label}), but fly's channel map inverts frame 2 "
            "(Vectored_6DOF, the BlueROV2 Heavy): set FRAME_CONFIG = 2 and reboot"
        )

    for n in range(1, 9):
        fn = value(f"SERVO{n}_FUNCTION")
        want = MOTOR_FUNCTION_BASE + n
        if fn is None:
            out.append(f"SERVO{n}_FUNCTION: not reported; fly needs motor {n} on output {n} ({want})")
        elif int(fn) != want:
            out.append(
                f"SERVO{n}_FUNCTION is {int(fn)}, but fly's channel map needs motor {n} on output {n}: "
                f"set SERVO{n}_FUNCTION = {want} (Motor{n})"
            )
        d = value(f"MOT_{n}_DIRECTION")
        if d is not None and d not in (1.0, -1.0):
            out.append(f"MOT_{n}_DIRECTION is {_fmt(d)}: must be 1 or -1 (set it from a thruster test)")

    rc = value("RC_OVERRIDE_TIME")
    if rc is None:
        out.append("RC_OVERRIDE_TIME: not reported; cannot tell whether overrides lapse when fly stops")
    elif rc == 0:
        out.append("RC_OVERRIDE_TIME is 0: ArduSub ignores RC overrides; set RC_OVERRIDE_TIME = 1 (s)")
    elif rc < 0:
        out.append(
            f"RC_OVERRIDE_TIME is {_fmt(rc)}: overrides never lapse, so the last thrust stays on if "
            "fly's link drops; set RC_OVERRIDE_TIME = 1 (s)"
        )
    elif rc < periods:
        out.append(
            f"RC_OVERRIDE_TIME is {_fmt(rc)} s, shorter than 3 control periods ({periods:g} s): "
            "overrides would lapse between fly's commands; set RC_OVERRIDE_TIME = 1 (s)"
        )
    elif rc > MAX_OVERRIDE_TIME_S:
        out.append(
            f"RC_OVERRIDE_TIME is {_fmt(rc)} s: after a lost link the last thrust stays on that long; "
            f"set RC_OVERRIDE_TIME to at most {MAX_OVERRIDE_TIME_S:g} s"
        )

    fs_pilot = value("FS_PILOT_INPUT")
    fs_timeout = value("FS_PILOT_TIMEOUT")
    if fs_pilot is not None and int(fs_pilot) == 2 and fs_timeout is not None and fs_timeout < periods:
        out.append(
            f"FS_PILOT_TIMEOUT is {_fmt(fs_timeout)} s, shorter than 3 control periods ({periods:g} s): "
            "the pilot-input failsafe would disarm between fly's commands; set FS_PILOT_TIMEOUT = 3"
        )

    fs_gcs = value("FS_GCS_ENABLE")
    if fs_gcs is None:
        out.append("FS_GCS_ENABLE: not reported; cannot tell what the vehicle does when fly's link drops")
    elif int(fs_gcs) in (0, 1):
        out.append(
            f"FS_GCS_ENABLE is {int(fs_gcs)} ({_GCS_FAILSAFE[int(fs_gcs)]}): a lost link would leave "
            "the vehicle to itself; set FS_GCS_ENABLE = 2 (disarm) or 3 (depth hold)"
        )

    for pname, want_v in (expected or {}).items():
        got = value(pname)
        if got is None:
            out.append(f"{pname}: not reported, but the mission requires {_fmt(want_v)} (fly.parameters)")
        elif abs(got - float(want_v)) > 1e-6 * max(1.0, abs(float(want_v))):
            out.append(
                f"{pname} is {_fmt(got)}, but the mission requires {_fmt(want_v)} (fly.parameters): "
                f"set {pname} = {_fmt(want_v)}"
            )
    return out


def describe(params: Mapping[str, float]) -> str:
    """One line of what was read, for the events (``NAME=value`` in request order)."""
    names = [n for g in PARAMETER_GROUPS for n in g] + sorted(
        set(params) - {n for g in PARAMETER_GROUPS for n in g}
    )
    return "parameters: " + " ".join(f"{n}={_fmt(params[n])}" for n in names if n in params)
