"""One closed-loop run held in memory: :class:`Run`, and :class:`MemoryRecorder` that records one.

A :class:`Run` has every per-step series of a run as numpy arrays (one row per control step,
the layout, units and frames of :mod:`auvdock.results.store`), its outcome, its events and
what it was: mission, controller, metadata.  It comes from :func:`auvdock.simulate`, from a
:class:`MemoryRecorder` that a run recorded into step by step, or from a results file
(:meth:`Run.from_file`); it goes to a file in exactly the layout ``auvdock sim`` writes
(:meth:`Run.save`), to an :class:`xarray.Dataset` (:meth:`Run.to_xarray`) or to a
:class:`pandas.DataFrame` (:meth:`Run.to_dataframe`).

Components
----------
Every stored series with a component axis has names for its components, in these tables (a
series not catalogued gets ``0, 1, ...`` and the unit its name's suffix says):

=========================================================  ===================  ===========================
series                                                     components           unit
=========================================================  ===================  ===========================
``state``, ``estimated_state``, ``estimated_state_std``    x y z phi theta psi  m m m rad rad rad
                                                           u v w p q r          m/s m/s m/s rad/s (x3)
``thrust_N``                                               T1 .. Tn             N
``wrench``, ``perception_wrench``                          X Y Z K M N          N N N N m N m N m
``innovation`` (flow filter; accelerometer, depth rate)    accel_u accel_v      m/s^2 m/s^2
                                                           accel_w depth_rate   m/s^2 m/s
``flow_ned_m_s``, ``dock_position_m``, ...  (NED vectors)  north east down      m/s or m
``flow_estimate_m_s``, ``flow_body_true_m_s`` (body {b})   u v w                m/s
``flow_covariance``  (body {b}, 3 x 3)                     u v w  x  u v w      m^2/s^2
``information`` (F = lambda_min of the flow gramian)       (scalar)             s^2/m^2 = (m/s)^-2
=========================================================  ===================  ===========================

:meth:`Run.to_dataframe` names its columns by these components (``state.x``, ``wrench.K``) with
the units in ``df.attrs["units"]``.  :meth:`Run.to_xarray` splits each series whose components
have several units into one variable per unit (``state`` -> ``position``, ``attitude``,
``velocity``, ``angular_rate``; ``wrench`` -> ``force``, ``moment``; ``innovation`` ->
``innovation_accel``, ``innovation_depth_rate``; ...), so that every variable has one ``units``
attribute and a plot of it is labelled right.

pandas and xarray are imported only by :meth:`Run.to_dataframe` and :meth:`Run.to_xarray`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.config.guidance import GUIDANCE_PHASES
from auvdock.estimation.settings import FORECAST_HORIZONS_S
from auvdock.results.store import (
    _RESERVED_ATTRS,
    BASE_SERIES,
    RunResults,
    RunWriter,
    _attr_value,
    _decode,
    checked_row,
    read_run,
)

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

    from auvdock.config.mission import Mission

__all__ = ["Run", "MemoryRecorder", "STATE_COMPONENTS", "STATE_UNITS", "series_info"]

#: Names of the 12 state components (:mod:`auvdock.vehicle.state`): NED position, ZYX Euler
#: angles, body velocity over ground, body angular rate.
STATE_COMPONENTS = ("x", "y", "z", "phi", "theta", "psi", "u", "v", "w", "p", "q", "r")
#: Unit of each state component.
STATE_UNITS = ("m", "m", "m", "rad", "rad", "rad", "m/s", "m/s", "m/s", "rad/s", "rad/s", "rad/s")
_WRENCH = ("X", "Y", "Z", "K", "M", "N")
_WRENCH_UNITS = ("N", "N", "N", "N m", "N m", "N m")
_NED = ("north", "east", "down")
_BODY = ("u", "v", "w")
_EULER = ("roll", "pitch", "yaw")
_RATE = ("p", "q", "r")
#: The rows of the FSE flow filter's ``innovation`` (:mod:`auvdock.estimation.flow_filter`): the
#: accelerometer's three (body axes) and the depth rate's.
INNOVATION_COMPONENTS = ("accel_u", "accel_v", "accel_w", "depth_rate")
_INNOVATION_UNITS = ("m/s^2", "m/s^2", "m/s^2", "m/s")
# their labels 0p5s, 1s, ...: as the outcome's keys (a dot would split a DataFrame's column name)
_HORIZON_LABELS = tuple(f"{h:g}s".replace(".", "p") for h in FORECAST_HORIZONS_S)
# the code names of fly's older camera tracker's states (auvdock.fly.camera.CAMERA_STATES; not imported:
# the fly package loads the MAVLink session; a test keeps them equal)
_CAMERA_STATES = ("searching", "tracking", "holding", "lost")
#: A stand-in's truth rows' contact codes (auvdock.standins.truth_record.CONTACT_STATUSES, copied: the
#: stand-ins' package loads MAVLink; kept equal by tests/test_library_views.py).
_CONTACT_STATUSES = ("free", "captured", "collided")
#: The information's unit: the flow filter's gramian G sums H^T R^-1 H, (m/s)^-2.
INFORMATION_UNITS = "s^2/m^2"

_N = "in the local North-East-Down frame {n}"
_B = "in the body frame {b} (u forward, v starboard, w down)"

# component axis (dimension) -> its labels' long_name and description (the coordinate's attrs)
_AXES: dict[str, tuple[str, str]] = {
    "ned": ("NED axis", "axis of the local North-East-Down frame {n}: north, east, down"),
    "body": (
        "body axis",
        "axis of the body frame {b}: u along x_b (forward), v along y_b (starboard), w along z_b (down)",
    ),
    "euler": ("Euler angle", "ZYX Euler angle of {b} relative to {n}: roll phi, pitch theta, yaw psi"),
    "body_rate": (
        "body rate axis",
        "angular rate about x_b (p, roll rate), y_b (q, pitch rate), z_b (r, yaw rate)",
    ),
    "force_component": ("force axis", "force along the body axes x_b, y_b, z_b (SNAME X, Y, Z)"),
    "moment_component": ("moment axis", "moment about the body axes x_b, y_b, z_b (SNAME K, M, N)"),
    "state_component": ("state component", "component of the 12-state x = [x y z phi theta psi u v w p q r]"),
    "wrench_component": ("wrench component", "body wrench component: forces X Y Z, moments K M N"),
    "thruster": ("thruster", "thruster of the vehicle, T1..Tn in the order of its parameter file"),
    "body_i": ("body axis (row)", "row of a 3 x 3 matrix over the body axes u, v, w"),
    "body_j": ("body axis (column)", "column of a 3 x 3 matrix over the body axes u, v, w"),
    "innovation_row": (
        "innovation row",
        "row of the flow filter's innovation: accelerometer u v w, depth rate",
    ),
    "forecast_horizon_s": ("forecast horizon", "how far ahead of t_k the dock's position is forecast"),
    "telemetry_message": ("telemetry message", "the MAVLink message whose age is given"),
    "channel": ("RC override channel", "ArduSub's manual-control override channels 1..6, in order"),
    "dock_axis": ("dock frame axis", "axis of the dock frame {d}"),
}


@dataclass(frozen=True)
class _Info:
    """How a stored series is labelled (see :func:`series_info`)."""

    axes: tuple[tuple[str, tuple[str, ...]], ...]
    units: str | tuple[str, ...]
    frame: str
    long_name: str
    description: str
    flags: tuple[str, ...] = ()


@dataclass(frozen=True)
class _Part:
    """One variable of the xarray view of a stored series with components of several units."""

    name: str
    rows: slice
    axis: tuple[str, tuple[str, ...]] | None
    units: str
    frame: str
    long_name: str
    description: str


def _state_parts(prefix: str, whose: str, of: str = "") -> tuple[_Part, ...]:
    """The four variables of a 12-state series: position, attitude, velocity, angular rate."""
    return (
        _Part(
            f"{prefix}position{of}",
            slice(0, 3),
            ("ned", _NED),
            "m",
            "NED {n}",
            f"{whose}position",
            f"{whose}position of the vehicle {_N} (state x, y, z)",
        ),
        _Part(
            f"{prefix}attitude{of}",
            slice(3, 6),
            ("euler", _EULER),
            "rad",
            "{b} relative to NED {n}",
            f"{whose}attitude",
            f"{whose}attitude: ZYX Euler angles roll phi, pitch theta, yaw psi of the body frame {{b}} "
            "relative to {n} (state phi, theta, psi)",
        ),
        _Part(
            f"{prefix}velocity{of}",
            slice(6, 9),
            ("body", _BODY),
            "m/s",
            "body {b}",
            f"{whose}velocity",
            f"{whose}velocity of the vehicle over ground (not relative to the water), {_B} (state u, v, w)",
        ),
        _Part(
            f"{prefix}angular_rate{of}",
            slice(9, 12),
            ("body_rate", _RATE),
            "rad/s",
            "body {b}",
            f"{whose}angular rate",
            f"{whose}angular rate of {{b}} relative to {{n}}, about the body axes (state p, q, r)",
        ),
    )


def _wrench_parts(prefix: str, of: str) -> tuple[_Part, ...]:
    """The two variables of a body wrench: force (N) and moment (N m)."""
    label = prefix.replace("_", " ")
    return (
        _Part(
            f"{prefix}force",
            slice(0, 3),
            ("force_component", _WRENCH[:3]),
            "N",
            "body {b}",
            f"{label}force",
            f"force {of} on the vehicle, along the body axes x_b, y_b, z_b (X, Y, Z)",
        ),
        _Part(
            f"{prefix}moment",
            slice(3, 6),
            ("moment_component", _WRENCH[3:]),
            "N m",
            "body {b}",
            f"{label}moment",
            f"moment {of} on the vehicle, about the body axes x_b, y_b, z_b (K, M, N)",
        ),
    )


_STATE_AXIS = (("state_component", STATE_COMPONENTS),)
_WRENCH_AXIS = (("wrench_component", _WRENCH),)
_NED_AXIS = (("ned", _NED),)
_BODY_AXIS = (("body", _BODY),)
_INFORMATION_TEXT = (
    "F = lambda_min(G): the smallest eigenvalue of the FSE flow filter's information gramian G "
    "(paper eq. 8; auvdock.estimation.flow_filter), which starts at I (1 s^2/m^2) and each step turns "
    "with the vehicle and adds H^T R^-1 H of the accelerometer and depth-rate readings: the Fisher "
    "information they give about the body-frame current in its least-observed direction; 1/sqrt(F) "
    "is the flow uncertainty (m/s) left in that direction"
)
_INNOVATION_TEXT = (
    "innovation z - H f of the FSE flow filter's last accelerometer and depth-rate update: the "
    "accelerometer rows (mean body acceleration over the last period minus the model's, m/s^2, body "
    "axes) and the depth-rate row (measured depth rate minus e3^T R nu_r, m/s, down); 0 where no "
    "reading was used"
)

# stored name -> how it is labelled (its row shape must match, else it is labelled as unknown)
_KNOWN: dict[str, _Info] = {
    "time_s": _Info((), "s", "", "time", "time t_k of the step since the run's start"),
    "state": _Info(
        _STATE_AXIS,
        STATE_UNITS,
        "NED {n} / body {b}",
        "vehicle state",
        "vehicle state at t_k: NED position, ZYX Euler angles, body velocity over ground, body rate",
    ),
    "wrench": _Info(
        _WRENCH_AXIS, _WRENCH_UNITS, "body {b}", "body wrench", "body wrench B u of the thrusts, in {b}"
    ),
    "flow_ned_m_s": _Info(
        _NED_AXIS,
        "m/s",
        "NED {n}",
        "true water velocity",
        f"true water velocity at the vehicle (the current, plus the waves' orbital velocity in a sea), {_N}; "
        "NaN where unknown (fly, replay)",
    ),
    "dock_position_m": _Info(
        _NED_AXIS, "m", "NED {n}", "dock position", f"position of the docking point {_N}"
    ),
    "dock_velocity_m_s": _Info(
        _NED_AXIS, "m/s", "NED {n}", "dock velocity", f"velocity of the docking point {_N}"
    ),
    "distance_m": _Info(
        (), "m", "", "distance to the dock", "distance from the vehicle to the docking point"
    ),
    "solve_time_s": _Info(
        (),
        "s",
        "",
        "controller step time",
        "wall-clock time of the controller step (NaN in the final-state row)",
    ),
    "solver_status": _Info(
        (), "", "", "controller status", "outcome code of the controller step (flag_meanings)"
    ),
    # extra series of the FSE controllers (auvdock.controllers.fse)
    "flow_estimate_m_s": _Info(
        _BODY_AXIS,
        "m/s",
        "body {b}",
        "estimated water velocity",
        f"the flow filter's estimate of the current {_B}",
    ),
    "flow_body_true_m_s": _Info(
        _BODY_AXIS,
        "m/s",
        "body {b}",
        "true water velocity (body)",
        f"true water velocity at the vehicle {_B}",
    ),
    "flow_estimate_ned_m_s": _Info(
        _NED_AXIS,
        "m/s",
        "NED {n}",
        "estimated water velocity (NED)",
        f"the flow filter's estimate of the current {_N}",
    ),
    "flow_covariance": _Info(
        (("body_i", _BODY), ("body_j", _BODY)),
        "m^2/s^2",
        "body {b}",
        "flow estimate covariance",
        "covariance P of the flow filter's estimate of the current, over the body axes",
    ),
    "information": _Info((), INFORMATION_UNITS, "body {b}", "flow information F", _INFORMATION_TEXT),
    "perception_wrench": _Info(
        _WRENCH_AXIS,
        _WRENCH_UNITS,
        "body {b}",
        "perception wrench",
        "wrench the Sequential FSE-MPC's perception law adds to excite the flow filter, in {b}",
    ),
    "innovation": _Info(
        (("innovation_row", INNOVATION_COMPONENTS),),
        _INNOVATION_UNITS,
        "body {b} / down",
        "flow filter innovation",
        _INNOVATION_TEXT,
    ),
    # the navigation filter (estimation: filter; auvdock.estimation.stage)
    "estimated_state": _Info(
        _STATE_AXIS,
        STATE_UNITS,
        "NED {n} / body {b}",
        "estimated state",
        "the navigation filter's state estimate",
    ),
    "estimated_state_std": _Info(
        _STATE_AXIS,
        STATE_UNITS,
        "NED {n} / body {b}",
        "estimated state std",
        "standard deviation of the navigation filter's state estimate",
    ),
    "estimated_flow_ned_m_s": _Info(
        _NED_AXIS,
        "m/s",
        "NED {n}",
        "estimated current",
        f"the navigation filter's estimate of the current {_N}",
    ),
    "estimated_flow_std_m_s": _Info(
        _NED_AXIS,
        "m/s",
        "NED {n}",
        "estimated current std",
        "standard deviation of the navigation filter's estimate of the current, per NED axis",
    ),
    "estimated_dock_position_m": _Info(
        _NED_AXIS,
        "m",
        "NED {n}",
        "estimated dock position",
        f"where the navigation filter places the docking point {_N}",
    ),
    "relative_position_std_m": _Info(
        _NED_AXIS,
        "m",
        "NED {n}",
        "relative position std",
        "standard deviation of the vehicle's position relative to the dock, per NED axis",
    ),
    "estimated_wave_velocity_ned_m_s": _Info(
        _NED_AXIS,
        "m/s",
        "NED {n}",
        "estimated wave velocity",
        f"the navigation filter's wave-frequency water velocity at the vehicle {_N}",
    ),
    "estimated_wave_velocity_std_m_s": _Info(
        _NED_AXIS,
        "m/s",
        "NED {n}",
        "estimated wave velocity std",
        "standard deviation of the navigation filter's wave-frequency water velocity, per NED axis",
    ),
    "dock_forecast_m": _Info(
        (("forecast_horizon_s", _HORIZON_LABELS), ("ned", _NED)),
        "m",
        "NED {n}",
        "dock forecast",
        f"where the dock's forecast places the docking point each horizon ahead, {_N}",
    ),
    "dock_forecast_std_m": _Info(
        (("forecast_horizon_s", _HORIZON_LABELS), ("ned", _NED)),
        "m",
        "NED {n}",
        "dock forecast std",
        "standard deviation of the dock's forecast position, per horizon and NED axis",
    ),
    # guidance with a dock camera (auvdock.loop.guidance)
    "guidance_phase": _Info(
        (), "", "", "guidance phase", "phase of the guidance (flag_meanings)", GUIDANCE_PHASES
    ),
    "dock_fix_age_s": _Info((), "s", "", "dock fix age", "age of the newest camera fix of the dock"),
    # a run in a sea (auvdock.loop.simulated_plant)
    "wave_velocity_ned_m_s": _Info(
        _NED_AXIS, "m/s", "NED {n}", "wave velocity", f"the waves' orbital water velocity at the vehicle {_N}"
    ),
    "water_acceleration_ned_m_s2": _Info(
        _NED_AXIS, "m/s^2", "NED {n}", "water acceleration", f"acceleration of the water at the vehicle {_N}"
    ),
    "sea_elevation_at_dock_m": _Info(
        (), "m", "", "sea elevation at the dock", "sea surface elevation above the dock (up)"
    ),
    "dock_pose": _Info(
        (("dock_pose_component", ("north", "east", "down", "roll", "pitch", "yaw")),),
        ("m", "m", "m", "rad", "rad", "rad"),
        "NED {n}",
        "dock pose",
        "the dock's pose: NED position and ZYX Euler angles",
    ),
    "dock_twist": _Info(
        (("dock_twist_component", ("north", "east", "down", "p", "q", "r")),),
        ("m/s", "m/s", "m/s", "rad/s", "rad/s", "rad/s"),
        "NED {n}",
        "dock twist",
        "the dock's NED velocity and angular rate",
    ),
    "nose_dock_m": _Info(
        (("dock_axis", ("x", "y", "z")),),
        "m",
        "dock {d}",
        "nose in the dock frame",
        "position of the vehicle's nose in the dock frame {d}",
    ),
    # actuators: ardusub, and fly (auvdock.fly.plant, auvdock.fly.camera)
    "channels_us": _Info(
        (("channel", ("pitch", "roll", "throttle", "yaw", "forward", "lateral")),),
        "us",
        "",
        "RC override",
        "ArduSub RC override channels 1..6 sent (pulse width; 1500 us neutral)",
    ),
    "telemetry_age_s": _Info(
        (("telemetry_message", ("ATTITUDE", "LOCAL_POSITION_NED")),),
        "s",
        "",
        "telemetry age",
        "age of the newest ATTITUDE and LOCAL_POSITION_NED messages at the step",
    ),
    "imu_specific_force_m_s2": _Info(
        _BODY_AXIS,
        "m/s^2",
        "body {b}",
        "IMU specific force",
        f"the IMU's specific force {_B} (NaN without a new IMU message)",
    ),
    "armed": _Info((), "", "", "armed", "1 while the vehicle is armed, 0 disarmed"),
    "vehicle_time_s": _Info(
        (), "s", "", "vehicle time", "the vehicle's own clock (since its boot) of the newest ATTITUDE"
    ),
    "link_round_trip_s": _Info((), "s", "", "link round trip", "round-trip time of the MAVLink link"),
    "link_loss": _Info((), "1", "", "link loss", "fraction of the vehicle's messages lost on the link"),
    "camera_fix_age_s": _Info((), "s", "", "camera fix age", "age of the camera's newest dock fix"),
    "camera_state": _Info(
        (), "", "", "camera state", "the dock camera's tracking state (flag_meanings)", _CAMERA_STATES
    ),
    "camera_markers": _Info((), "", "", "camera markers", "markers seen in the camera's newest fix"),
    "camera_latency_s": _Info((), "s", "", "camera latency", "latency of the camera's newest fix"),
    "camera_dock_position_m": _Info(
        _NED_AXIS,
        "m",
        "NED {n}",
        "camera dock position",
        f"the dock position the camera's newest fix gives, {_N}",
    ),
    "camera_fixes": _Info((), "", "", "camera fixes", "camera fixes received during the step"),
    "camera_frames": _Info((), "", "", "camera frames", "camera frames the detection took during the step"),
    "flow_model_ned_m_s": _Info(
        _NED_AXIS,
        "m/s",
        "NED {n}",
        "flow model",
        "the mission's flow model at the vehicle's estimated position (a vehicle: the true water is unknown)",
    ),
    "loop_late_s": _Info(
        (), "s", "", "step lateness", "how late the control step started on the session's clock (0 on time)"
    ),
    "dock_telemetry_age_s": _Info(
        (), "s", "", "dock telemetry age", "since the dock's newest ODOMETRY arrived (sensors.dock_telemetry)"
    ),
    "contact_status": _Info(
        (), "", "", "contact", "the truth's contact with the dock's body (flag_meanings)", _CONTACT_STATUSES
    ),
}

# stored series whose components have several units -> the variables of the xarray view
_SPLIT: dict[str, tuple[_Part, ...]] = {
    "state": _state_parts("", ""),
    "estimated_state": _state_parts("estimated_", "estimated "),
    "estimated_state_std": _state_parts("estimated_", "standard deviation of the estimated ", "_std"),
    "wrench": _wrench_parts("", "of the thrusts (the body wrench B u, {b})"),
    "perception_wrench": _wrench_parts("perception_", "of the Sequential FSE-MPC's perception input ({b})"),
    "innovation": (
        _Part(
            "innovation_accel",
            slice(0, 3),
            ("body", _BODY),
            "m/s^2",
            "body {b}",
            "accelerometer innovation",
            "innovation of the FSE flow filter's accelerometer rows: the mean body acceleration over the "
            "last period minus the vehicle model's prediction minus H f, along the body axes (0 where no "
            "reading)",
        ),
        _Part(
            "innovation_depth_rate",
            slice(3, 4),
            None,
            "m/s",
            "NED down",
            "depth-rate innovation",
            "innovation of the FSE flow filter's depth-rate row: measured depth rate minus e3^T R nu_r minus "
            "e3^T R f (down positive; 0 where no reading)",
        ),
    ),
    "dock_pose": (
        _Part(
            "dock_pose_position",
            slice(0, 3),
            ("ned", _NED),
            "m",
            "NED {n}",
            "dock pose position",
            f"the dock's position {_N}",
        ),
        _Part(
            "dock_pose_attitude",
            slice(3, 6),
            ("euler", _EULER),
            "rad",
            "{d} relative to NED {n}",
            "dock attitude",
            "the dock's ZYX Euler angles roll, pitch, yaw relative to {n}",
        ),
    ),
    "dock_twist": (
        _Part(
            "dock_twist_velocity",
            slice(0, 3),
            ("ned", _NED),
            "m/s",
            "NED {n}",
            "dock twist velocity",
            f"the dock's velocity {_N}",
        ),
        _Part(
            "dock_twist_angular_rate",
            slice(3, 6),
            ("body_rate", _RATE),
            "rad/s",
            "dock {d}",
            "dock angular rate",
            "the dock's angular rate (zero for the docks modelled: they do not turn)",
        ),
    ),
}
# unit from a name's suffix, longest first
_SUFFIX_UNITS = (
    ("_m_s2", "m/s^2"),
    ("_rad_s", "rad/s"),
    ("_m_s", "m/s"),
    ("_rad", "rad"),
    ("_deg", "deg"),
    ("_us", "us"),
    ("_m", "m"),
    ("_s", "s"),
    ("_N", "N"),
)


def series_info(name: str, row_shape: tuple[int, ...]) -> dict[str, Any]:
    """How a stored series is labelled: its component axes, units, frame and description.

    Parameters
    ----------
    name : str
        Dataset name (``state``, ``thrust_N``, an extra series, ...).
    row_shape : tuple of int
        Shape of one row, e.g. ``(12,)``.

    Returns
    -------
    dict
        ``axes``: list of ``(dimension name, component labels)``, one per row axis;
        ``units``: one unit string per component of the first axis, or one for all (``""``:
        none, e.g. a code or a count without unit); ``frame``, ``long_name`` (short, for a
        plot's label) and ``description``; ``flags``: the names of an integer code's values
        (``()`` for a quantity).  A series not in the catalogue gets components ``0, 1, ...``,
        the unit its name's suffix says (``_m_s`` m/s, ...) and a description saying so.
    """
    if name == "thrust_N":
        n = row_shape[0] if row_shape else 0
        return {
            "axes": [("thruster", tuple(f"T{i + 1}" for i in range(n)))],
            "units": "N",
            "frame": "thruster axes",
            "long_name": "thrust",
            "description": "thruster forces commanded for [t_k, t_k + dt), each along its thruster's axis",
            "flags": (),
        }
    known = _KNOWN.get(name)
    if known is not None and tuple(len(labels) for _, labels in known.axes) == tuple(row_shape):
        return {
            "axes": list(known.axes),
            "units": known.units,
            "frame": known.frame,
            "long_name": known.long_name,
            "description": known.description,
            "flags": known.flags,
        }
    unit = next((u for suffix, u in _SUFFIX_UNITS if name.endswith(suffix)), "")
    stem = name.removesuffix(next((s for s, _ in _SUFFIX_UNITS if name.endswith(s)), ""))
    axes = [(f"{name}_dim{i}", tuple(str(j) for j in range(n))) for i, n in enumerate(row_shape)]
    return {
        "axes": axes,
        "units": unit,
        "frame": "",
        "long_name": stem.replace("_", " "),
        "description": f"series {name} of the run (not in auvdock's catalogue: unit from its name's suffix)",
        "flags": (),
    }


def _component_unit(units: str | tuple[str, ...], index: tuple[int, ...]) -> str:
    if isinstance(units, str):
        return units
    return units[index[0]] if index else ""


def _same(a: Any, b: Any) -> bool:
    """Equal values, NaN equal to NaN, arrays compared elementwise."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape:
            return False
        if a.dtype.kind in "fc" or b.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b) and type(a) is type(b)


def _stored(key: str, value: Any) -> Any:
    """``value`` as a results file gives it back (None -> NaN or "", numpy -> Python)."""
    return _decode(_attr_value(key, value))


# ----------------------------------------------------------------------------- Run


@dataclass(eq=False, repr=False)
class Run:
    """One closed-loop run in memory.

    Every per-step array has one row per recorded step k (T rows): the control steps and,
    last, the final-state row (status ``no_step``: the state the run ended in, no control).
    Units and frames are those of :mod:`auvdock.results.store`.

    Attributes
    ----------
    time_s : ndarray, shape (T,)
        Time t_k of each step, s.
    state : ndarray, shape (T, 12)
        Vehicle state at t_k: x y z (NED position, m), phi theta psi (ZYX Euler angles,
        rad), u v w (body velocity over ground, m/s), p q r (body angular rate, rad/s);
        :data:`STATE_COMPONENTS`.
    thrust_N : ndarray, shape (T, n)
        The n thruster forces commanded for [t_k, t_k + dt), N (the controller's, or the hold's while
        it holds); what the thrusters push follows from ``channels_us`` on ArduSub's path.
    wrench : ndarray, shape (T, 6)
        Body wrench B u = [X Y Z K M N] in {b}, N and N m.
    flow_ned_m_s : ndarray, shape (T, 3)
        True water velocity at the vehicle, NED, m/s; NaN where unknown (a flight: its extra
        ``flow_model_ned_m_s`` is the mission's flow model).
    dock_position_m : ndarray, shape (T, 3)
        Dock position, NED, m.
    dock_velocity_m_s : ndarray, shape (T, 3)
        Dock velocity, NED, m/s.
    distance_m : ndarray, shape (T,)
        Vehicle-to-dock distance, m.
    solve_time_s : ndarray, shape (T,)
        Wall time of the controller step, s (NaN in the final-state row).
    solver_status : ndarray of int8, shape (T,)
        Controller step outcome codes; names in ``status_names`` (and :attr:`status`).
    extras : dict of str to ndarray, shape (T, ...)
        Every extra series by name, e.g. ``flow_estimate_m_s`` (T, 3) in {b}, m/s;
        also readable as attributes (``run.flow_estimate_m_s``) and by ``run["name"]``.
    outcome : dict
        The outcome figures (``docked``, ``time_to_dock_s``, ``reason``, ...; see
        :mod:`auvdock.results.store`), ``{}`` for an unfinished run.
    mission_name, mission_yaml, controller : str
        What was run: the mission's name, the full resolved mission as YAML text, and the
        controller's name.
    attrs : dict
        Metadata of the run (``tolerance_m``, ``timeout_s``, ``dt_s``, ``flow``,
        ``vehicle``, ``solver``, ...).
    status_names : dict of int to str
        Solver status code -> name.
    complete : bool
        True once the run finished (False after an interruption or a crash).
    source : str
        ``"<file>:<group>"`` the run was read from, ``""`` for one never written.
    """

    time_s: np.ndarray
    state: np.ndarray
    thrust_N: np.ndarray
    wrench: np.ndarray
    flow_ned_m_s: np.ndarray
    dock_position_m: np.ndarray
    dock_velocity_m_s: np.ndarray
    distance_m: np.ndarray
    solve_time_s: np.ndarray
    solver_status: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    outcome: dict[str, Any] = field(default_factory=dict)
    mission_name: str = ""
    mission_yaml: str = ""
    controller: str = ""
    attrs: dict[str, Any] = field(default_factory=dict)
    status_names: dict[int, str] = field(default_factory=dict)
    complete: bool = False
    source: str = ""

    # -- construction

    @classmethod
    def from_results(cls, results: RunResults) -> Run:
        """The run of a :class:`~auvdock.results.store.RunResults` (as :func:`read_run` gives)."""
        raw = dict(results.attrs)
        outcome = results.outcome()
        attrs = {k: v for k, v in raw.items() if k not in _RESERVED_ATTRS and k not in outcome}
        return cls(
            **{name: np.asarray(getattr(results, name)) for name in BASE_SERIES},
            extras={name: np.asarray(a) for name, a in results.extras.items()},
            outcome=outcome,
            mission_name=results.mission_name,
            mission_yaml=results.mission_yaml,
            controller=results.controller,
            attrs=attrs,
            status_names=results.status_names,
            complete=results.complete,
            source=f"{results.source}:{results.group}" if results.source else "",
        )

    @classmethod
    def from_file(cls, path: str | Path, group: str = "/") -> Run:
        """Read a run from an HDF5 results file.

        Parameters
        ----------
        path : str or Path
            A file written by ``auvdock sim`` / ``fly`` / ``compare`` or :meth:`save`.
        group : str
            The run group: ``"/"`` for a single-run file, ``"/runs/<case>/<controller>"``
            in a campaign file (:func:`auvdock.results.store.list_runs` lists them).

        Raises
        ------
        FileNotFoundError, ValueError
            As :func:`auvdock.results.store.read_run`.
        """
        return cls.from_results(read_run(path, group))

    # -- reading

    @property
    def n_steps(self) -> int:
        """Number of recorded rows T (control steps and the final-state row)."""
        return int(self.time_s.shape[0])

    @property
    def n_thrusters(self) -> int:
        """Number of thrusters n (columns of ``thrust_N``)."""
        return int(self.thrust_N.shape[1]) if self.thrust_N.ndim == 2 else 0

    @property
    def docked(self) -> bool:
        """Whether the vehicle docked."""
        return bool(self.outcome.get("docked", False))

    @property
    def status(self) -> np.ndarray:
        """Status names per row, shape (T,), e.g. ``"ok"``, ``"no_step"``."""
        names = self.status_names
        return np.array([names.get(int(c), str(int(c))) for c in self.solver_status], dtype=object)

    @property
    def events(self) -> list[tuple[float, str]]:
        """Events of the run as ``(time s, text)`` (a ``fly`` session's; ``[]`` for a simulation)."""
        raw = self.outcome.get("events_json") or self.attrs.get("events_json")
        if not raw:
            return []
        return [(float(t), str(text)) for t, text in json.loads(raw)]

    @property
    def series(self) -> dict[str, np.ndarray]:
        """Every per-step series by name: the base datasets, then the extras."""
        return {**{name: getattr(self, name) for name in BASE_SERIES}, **self.extras}

    def __getitem__(self, name: str) -> np.ndarray:
        series = self.series
        if name not in series:
            raise KeyError(f"no series {name!r} (this run has: {', '.join(series)})")
        return series[name]

    def __getattr__(self, name: str) -> Any:
        # only called when normal lookup fails: the extra series as attributes
        extras = self.__dict__.get("extras")
        if extras is not None and not name.startswith("_") and name in extras:
            return extras[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def control_rows(self) -> np.ndarray:
        """Mask (T,) of the control-step rows: all but the final-state row (``no_step``)."""
        no_step = [code for code, name in self.status_names.items() if name == "no_step"]
        return ~np.isin(self.solver_status, no_step)

    def mission(self) -> Mission:
        """The mission the run flew, parsed from :attr:`mission_yaml`."""
        import yaml

        from auvdock.config.mission import parse_mission

        return parse_mission(yaml.safe_load(self.mission_yaml))

    def to_results(self) -> RunResults:
        """The run as :class:`~auvdock.results.store.RunResults` (what ``plot_run`` takes)."""
        attrs: dict[str, Any] = dict(self.attrs)
        attrs.update(self.outcome)
        attrs.update(
            mission_name=self.mission_name,
            mission_yaml=self.mission_yaml,
            controller=self.controller,
            complete=self.complete,
            solver_status_codes=json.dumps({str(k): v for k, v in self.status_names.items()}),
            extra_series=json.dumps({k: list(v.shape[1:]) for k, v in self.extras.items()}),
            outcome_keys=json.dumps(list(self.outcome)),
        )
        file, _, group = self.source.rpartition(":")
        return RunResults(
            **{name: getattr(self, name) for name in BASE_SERIES},
            extras=dict(self.extras),
            attrs=attrs,
            source=file,
            group=group or "/",
        )

    def equals(self, other: Run) -> bool:
        """Same series (NaN equal to NaN), outcome, metadata, mission and controller."""
        if not isinstance(other, Run):
            return False
        mine, theirs = self.series, other.series
        if mine.keys() != theirs.keys() or any(not _same(mine[k], theirs[k]) for k in mine):
            return False
        for a, b in ((self.outcome, other.outcome), (self.attrs, other.attrs)):
            if a.keys() != b.keys() or any(not _same(a[k], b[k]) for k in a):
                return False
        return (
            self.mission_name == other.mission_name
            and self.mission_yaml == other.mission_yaml
            and self.controller == other.controller
            and self.status_names == other.status_names
            and self.complete == other.complete
        )

    # -- writing

    def save(self, path: str | Path, group: str = "/", *, overwrite: bool = True) -> Path:
        """Write the run to an HDF5 results file, in exactly the layout ``auvdock sim`` writes.

        ``auvdock plot``, :func:`auvdock.results.store.read_run` and :meth:`from_file` read
        it back.  An unfinished run (``complete`` False) is written unfinished.

        Parameters
        ----------
        path : str or Path
            The file (created with its folders; an existing single-run file is replaced).
        group : str
            Run group, ``"/"`` for one run per file.
        overwrite : bool
            As :class:`~auvdock.results.store.RunWriter`.

        Returns
        -------
        Path
            ``path``.
        """
        writer = RunWriter(
            Path(path),
            group,
            mission_yaml=self.mission_yaml,
            mission_name=self.mission_name,
            controller=self.controller,
            extra_series={name: tuple(a.shape[1:]) for name, a in self.extras.items()},
            flush_every=max(1, self.n_steps),
            overwrite=overwrite,
            attrs=self.attrs,
            status_names=self.status_names or None,
            n_thrusters=self.n_thrusters,
        )
        with writer:
            series = self.series
            for k in range(self.n_steps):
                writer.append(**{name: a[k] for name, a in series.items()})
            if self.complete:
                writer.finish(self.outcome)
        return Path(path)

    def to_xarray(self) -> xr.Dataset:
        """The run as an :class:`xarray.Dataset`: every variable in one unit, every name described.

        Returns
        -------
        xarray.Dataset
            Dimension ``time_s`` (s) and one dimension per component axis, its components named
            in a coordinate.  A series whose components have several units is split into one
            variable per unit, so that ``ds[name].sel(...).plot()`` labels the axis with the
            right unit:

            - ``state``: ``position`` (m, NED {n}; dimension ``ned``: north, east, down),
              ``attitude`` (rad, ZYX Euler angles; ``euler``: roll, pitch, yaw), ``velocity``
              (m/s, over ground, body {b}; ``body``: u, v, w), ``angular_rate`` (rad/s, {b};
              ``body_rate``: p, q, r);
            - ``wrench``: ``force`` (N, {b}; ``force_component``: X, Y, Z) and ``moment`` (N m;
              ``moment_component``: K, M, N);
            - ``innovation``: ``innovation_accel`` (m/s^2, {b}; ``body``: u, v, w) and
              ``innovation_depth_rate`` (m/s).

            Likewise ``estimated_state`` (``estimated_position``, ...), ``estimated_state_std``
            (``estimated_position_std``, ...), ``perception_wrench`` (``perception_force``,
            ``perception_moment``), ``dock_pose`` and ``dock_twist``.  The other series keep
            their names and dimensions: ``thrust_N`` (N, ``thruster`` T1..Tn),
            ``flow_ned_m_s`` (m/s, ``ned``), ``flow_estimate_m_s`` (m/s, ``body``),
            ``flow_covariance`` (m^2/s^2, ``body_i`` x ``body_j``), ``information`` (s^2/m^2),
            ``distance_m``, ``solver_status``, ... (see the module docstring).

            Every variable has ``long_name`` (what a plot's axis says), ``description`` (with its
            frame), ``frame`` where it has one and ``units`` where it has one (none for a code or
            a count, ``1`` for a fraction); an integer code (``solver_status``,
            ``guidance_phase``, ``camera_state``) has CF ``flag_values`` / ``flag_meanings``.
            Every coordinate has ``long_name`` and ``description`` (``time_s`` and
            ``forecast_horizon_s`` also ``units`` s).  The dataset's attrs hold ``title``,
            ``mission_name``, ``controller``, ``mission_yaml``, ``complete`` (0/1), the metadata
            and the outcome, all of netCDF's types (booleans as 0/1, None as ``""``, lists and
            mappings as JSON text): ``ds.to_netcdf("run.nc")`` writes it (engine ``h5netcdf``,
            installed with auvdock).
        """
        import xarray as xr

        time = _KNOWN["time_s"]
        coords: dict[str, Any] = {
            "time_s": (
                "time_s",
                self.time_s,
                {"units": "s", "long_name": time.long_name, "description": time.description},
            )
        }
        data_vars: dict[str, Any] = {}

        def axis(name: str, dim: str, labels: tuple[str, ...]) -> str:
            if dim not in coords:
                long_name, description = _AXES.get(
                    dim, (f"component of {name}", f"component index of the series {name}")
                )
                attrs = {"long_name": long_name, "description": description}
                if dim == "forecast_horizon_s":
                    coords[dim] = (dim, np.array(FORECAST_HORIZONS_S), {**attrs, "units": "s"})
                else:
                    coords[dim] = (dim, list(labels), attrs)
            return dim

        for name, a in self.series.items():
            if name == "time_s":
                continue
            info = series_info(name, a.shape[1:])
            parts = _SPLIT.get(name) if _is_known(name, a.shape[1:]) else None
            if parts is not None:
                for part in parts:
                    if part.axis is None:
                        dims, values = ["time_s"], a[:, part.rows.start]
                    else:
                        dims, values = ["time_s", axis(name, *part.axis)], a[:, part.rows]
                    data_vars[part.name] = (
                        dims,
                        values,
                        _variable_attrs(part.units, part.long_name, part.description, part.frame),
                    )
                continue
            units = info["units"] if isinstance(info["units"], str) else ""  # a mixed series is split
            var_attrs = _variable_attrs(units, info["long_name"], info["description"], info["frame"])
            if name == "solver_status" and self.status_names:
                codes = sorted(self.status_names)
                var_attrs["flag_values"] = np.array(codes, dtype=a.dtype)
                var_attrs["flag_meanings"] = " ".join(self.status_names[c] for c in codes)
            elif info["flags"]:
                var_attrs["flag_values"] = np.arange(len(info["flags"])).astype(a.dtype)
                var_attrs["flag_meanings"] = " ".join(info["flags"])
            dims = ["time_s", *(axis(name, dim, labels) for dim, labels in info["axes"])]
            data_vars[name] = (dims, a, var_attrs)
        attrs: dict[str, Any] = {
            "title": f"auvdock run: mission {self.mission_name}, controller {self.controller}",
            "mission_name": self.mission_name,
            "controller": self.controller,
            "complete": int(self.complete),
            "mission_yaml": self.mission_yaml,
        }
        for key, value in {**self.attrs, **self.outcome}.items():
            attrs[key] = _netcdf_attr(value)
        return xr.Dataset(data_vars=data_vars, coords=coords, attrs=attrs)

    def to_dataframe(self, *, units_in_names: bool = False) -> pd.DataFrame:
        """The per-step series as a :class:`pandas.DataFrame`, one row per step.

        Parameters
        ----------
        units_in_names : bool
            Put each column's unit in its name, ``"state.x [m]"``, ``"wrench.K [N m]"`` (a
            column without unit keeps its name): for a CSV file, which keeps no ``attrs``.

        Returns
        -------
        pandas.DataFrame
            Index ``time_s`` (s).  One column per scalar component, named
            ``<series>.<component>``: ``state.x`` .. ``state.r``, ``thrust_N.T1`` ..,
            ``wrench.X`` .., ``flow_ned_m_s.north`` .., ``flow_covariance.u.v``,
            ``innovation.accel_u`` .. ``innovation.depth_rate``, and the scalar series by their
            own name (``distance_m``, ``solve_time_s``, ``solver_status``, ``information``),
            plus ``status`` (the status names, categorical).  ``df.attrs["units"]`` maps every
            column to its unit (``""``: none) and ``df.attrs["descriptions"]`` to what it is;
            ``df.attrs`` also holds ``mission_name``, ``controller`` and ``outcome``.
        """
        import pandas as pd

        columns: dict[str, np.ndarray] = {}
        units: dict[str, str] = {}
        descriptions: dict[str, str] = {}
        for name, a in self.series.items():
            if name == "time_s":
                continue
            info = series_info(name, a.shape[1:])
            labels = [labels for _, labels in info["axes"]]
            for index in np.ndindex(*a.shape[1:]):
                col = ".".join([name, *(labels[i][j] for i, j in enumerate(index))])
                columns[col] = a[(slice(None), *index)]
                units[col] = _component_unit(info["units"], index)
                descriptions[col] = info["description"]
        columns["status"] = pd.Categorical(
            self.status, categories=list(dict.fromkeys(self.status_names.values()))
        )
        units["status"] = ""
        descriptions["status"] = "name of the controller step's outcome (solver_status)"
        if units_in_names:
            named = {col: f"{col} [{units[col]}]" if units[col] else col for col in columns}
            columns = {named[col]: v for col, v in columns.items()}
            units = {named[col]: u for col, u in units.items()}
            descriptions = {named[col]: d for col, d in descriptions.items()}
        df = pd.DataFrame(columns, index=pd.Index(self.time_s, name="time_s"))
        df.attrs.update(
            units=units,
            descriptions=descriptions,
            mission_name=self.mission_name,
            controller=self.controller,
            outcome=dict(self.outcome),
        )
        return df

    # -- display

    def _outcome_text(self) -> str:
        if not self.complete:
            return "unfinished"
        o = self.outcome
        if self.docked:
            t = o.get("time_to_dock_s")
            return f"docked at {t:.2f} s" if isinstance(t, int | float) and math.isfinite(t) else "docked"
        text = f"not docked ({o.get('reason') or 'no reason'}"
        closest = o.get("closest_approach_m")
        if isinstance(closest, int | float) and math.isfinite(closest):
            text += f", closest {closest:.3f} m"
        return text + ")"

    def __repr__(self) -> str:
        return (
            f"Run(mission={self.mission_name!r}, controller={self.controller!r}, "
            f"{self._outcome_text()}, {self.n_steps} steps)"
        )

    def _repr_html_(self) -> str:  # notebooks: the short repr, not the arrays
        import html

        return f"<pre>{html.escape(repr(self))}</pre>"


def _is_known(name: str, row_shape: tuple[int, ...]) -> bool:
    """Whether ``name`` is a catalogued series of this row shape."""
    known = _KNOWN.get(name)
    return known is not None and tuple(len(labels) for _, labels in known.axes) == tuple(row_shape)


def _variable_attrs(units: str, long_name: str, description: str, frame: str) -> dict[str, Any]:
    attrs: dict[str, Any] = {"long_name": long_name, "description": description}
    if units:
        attrs["units"] = units
    if frame:
        attrs["frame"] = frame
    return attrs


def _netcdf_attr(value: Any) -> Any:
    """``value`` as a netCDF attribute: a string, a number or a 1-D numeric array."""
    if isinstance(value, bool | np.bool_):
        return int(value)
    if value is None:
        return ""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, str | int | float):
        return value
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, list | tuple | np.ndarray):
        arr = np.asarray(value)
        if arr.dtype.kind == "b":
            arr = arr.astype(np.int8)
        if arr.dtype.kind in "iuf" and arr.ndim == 1 and arr.size:
            return arr
        value = arr.tolist() if arr.dtype.kind in "biuf" else list(value)
    return json.dumps(value, default=str)


# ----------------------------------------------------------------------------- recorder


class MemoryRecorder:
    """Record a run step by step in memory: :class:`~auvdock.results.store.RunWriter`'s
    interface without a file, and :meth:`run` to get the :class:`Run`.

    It checks every row exactly as the writer does (same names, shapes and status names),
    and keeps the outcome and metadata as a results file gives them back (None as NaN, or
    as ``""`` for the string keys; numpy scalars as Python numbers), so a run recorded here
    equals the same run written to a file and read back.

    Parameters
    ----------
    mission_yaml, mission_name, controller : str
        As :class:`~auvdock.results.store.RunWriter` (keyword-only, like all parameters).
    extra_series : dict of str to tuple of int, optional
        Extra per-step series, name -> per-row shape; required in every :meth:`append`.
    flush_every : int
        Accepted for the writer's interface; there is nothing to flush.
    attrs : dict, optional
        Metadata (``tolerance_m``, ``dt_s``, ...); not the writer's own attribute names.
    status_names : dict of int to str, optional
        Status code -> name (default :data:`auvdock.controllers.status.STATUS_NAMES`).
    n_thrusters : int
        Row length of ``thrust_N``.

    Examples
    --------
    >>> rec = MemoryRecorder(mission_yaml=m.to_yaml(), mission_name=m.name, controller="oracle")
    >>> rec.append(time_s=0.0, state=x, ...)            # once per step
    >>> rec.finish({"docked": True, "time_to_dock_s": 41.2, "reason": "docked"})
    >>> run = rec.run()
    """

    def __init__(
        self,
        *,
        mission_yaml: str,
        mission_name: str,
        controller: str,
        extra_series: dict[str, tuple[int, ...]] | None = None,
        flush_every: int = 1,
        attrs: dict[str, Any] | None = None,
        status_names: dict[int, str] | None = None,
        n_thrusters: int = 8,
    ) -> None:
        if status_names is None:
            from auvdock.controllers import status

            status_names = status.STATUS_NAMES
        self._status_names = dict(status_names)
        self._status_codes = {name: code for code, name in self._status_names.items()}
        if isinstance(flush_every, bool) or not isinstance(flush_every, int | np.integer) or flush_every < 1:
            raise ValueError(f"flush_every must be an integer >= 1, got {flush_every!r}")
        self._series = RunWriter._declare_series(dict(extra_series or {}), int(n_thrusters))
        meta = dict(attrs or {})
        clash = sorted(_RESERVED_ATTRS.intersection(meta))
        if clash:
            raise ValueError(f"attrs may not set the writer's own attributes: {', '.join(clash)}")
        self._attrs = {str(k): _stored(str(k), v) for k, v in meta.items()}
        self._mission_yaml = str(mission_yaml)
        self._mission_name = str(mission_name)
        self._controller = str(controller)
        self._rows: dict[str, list[np.ndarray]] = {name: [] for name in self._series}
        self._outcome: dict[str, Any] = {}
        self._finished = False
        self._closed = False

    @property
    def n_steps(self) -> int:
        """Number of rows appended so far."""
        return len(self._rows["time_s"])

    @property
    def group(self) -> str:
        """Always ``"/"`` (the writer's run group; here for its interface)."""
        return "/"

    @property
    def filename(self) -> str:
        """Always ``""``: no file."""
        return ""

    def append(self, **row: Any) -> None:
        """Append one step's row; the same keywords and checks as :meth:`RunWriter.append`.

        Raises
        ------
        ValueError
            Naming the series, for a missing or unknown key, a wrong shape or a value
            that is not numeric.  Nothing is appended then.
        RuntimeError
            If the run is finished.
        """
        self._check_open("append")
        converted = checked_row(row, self._series, self._status_codes, "<memory>")
        for name, value in converted.items():
            self._rows[name].append(value)

    def flush(self) -> None:
        """Nothing to do (the writer's interface)."""

    def finish(self, outcome: dict[str, Any]) -> None:
        """Keep the outcome and mark the run complete; as :meth:`RunWriter.finish`.

        Raises
        ------
        ValueError
            If a key is one of the writer's own attribute names.
        TypeError
            For a value a results file cannot store.
        RuntimeError
            If the run is already finished.
        """
        self._check_open("finish")
        clash = sorted(_RESERVED_ATTRS.intersection(outcome))
        if clash:
            raise ValueError(f"outcome may not set the writer's own attributes: {', '.join(clash)}")
        self._outcome = {str(k): _stored(str(k), v) for k, v in outcome.items()}
        self._finished = True

    def close(self) -> None:
        """Stop recording (the run stays unfinished unless :meth:`finish` was called).  Idempotent."""
        self._closed = True

    def _check_open(self, what: str) -> None:
        if self._closed:
            raise RuntimeError(f"<memory>: cannot {what}(): the recorder is closed")
        if self._finished:
            raise RuntimeError(f"<memory>: cannot {what}(): the run is already finished")

    def __enter__(self) -> MemoryRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def run(self) -> Run:
        """The run recorded so far (the arrays are stacked anew on every call)."""
        arrays = {
            name: np.stack(rows) if rows else np.zeros((0, *shape), dtype=dtype)
            for (name, (shape, dtype)), rows in zip(self._series.items(), self._rows.values(), strict=True)
        }
        # Any: one dict of arrays spread over Run's typed fields (mypy checks each value against all)
        base: dict[str, Any] = {name: arrays.pop(name) for name in BASE_SERIES}
        return Run(
            **base,
            extras=arrays,
            outcome=dict(self._outcome),
            mission_name=self._mission_name,
            mission_yaml=self._mission_yaml,
            controller=self._controller,
            attrs=dict(self._attrs),
            status_names=dict(self._status_names),
            complete=self._finished,
        )
