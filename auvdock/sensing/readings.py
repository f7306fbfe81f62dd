"""What the sensors hand the estimation stage: one control instant's :class:`Readings`.

The closed loop (:func:`auvdock.loop.closed_loop.run_closed_loop`) never hands a controller
a sensor value: it hands the estimation stage (:mod:`auvdock.estimation.stage`) the readings
of one instant, and the stage hands every controller a typed
:class:`auvdock.estimation.estimate.Estimate`.  Readings come from a simulated sensor source
(:mod:`auvdock.sensing.simulated`) or from a vehicle's telemetry
(:class:`auvdock.fly.telemetry.TelemetrySensors`), in the same types.

Frames: NED world {n}, body FRD {b}; states ``[eta; nu]`` (12,) as in
:mod:`auvdock.vehicle.state`, body velocity over ground.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Reading", "FlowSensing", "Readings"]


@dataclass
class Reading:
    """One reading of one navigation sensor.

    Attributes
    ----------
    kind : str
        A key of :data:`auvdock.sensing.measurements.KINDS` (``attitude``, ``gyro``, ``accel``,
        ``depth``, ``position``, ``dvl``, ``dock``: what the navigation filter reads), or
        ``dock_motion``: the dock's own telemetry of its displacement from its mean (NED, m), which
        the dock's forecaster reads (:mod:`auvdock.estimation.dock_knowledge`).
    t : float
        Sample time, s (mission clock).
    value : ndarray (KINDS[kind],)
        The reading, in the kind's units (:mod:`auvdock.sensing.measurements`).
    std : ndarray (KINDS[kind],) or float
        Noise standard deviation of each component, same units.
    """

    kind: str
    t: float
    value: np.ndarray
    std: np.ndarray


@dataclass(frozen=True)
class FlowSensing:
    """The sensing the FSE controllers' flow filter reads (paper section IV.A).

    Attributes
    ----------
    pose : ndarray (6,)
        eta: NED position (m) and ZYX Euler angles (rad).
    gyro_rad_s : ndarray (3,)
        Body angular rate nu_2, rad/s.
    relative_velocity_m_s : ndarray (3,)
        Linear velocity through the water in {b}, ``nu_1 - R^T v_c``, m/s.
    depth_rate_m_s : float
        Rate of the depth, ``e3^T R nu_1``, m/s.
    accel_m_s2 : ndarray (3,) or None
        Mean body acceleration over the last period, gravity removed, m/s^2; None at the
        first instant of a run (no period behind it).
    """

    pose: np.ndarray
    gyro_rad_s: np.ndarray
    relative_velocity_m_s: np.ndarray
    depth_rate_m_s: float
    accel_m_s2: np.ndarray | None = None


@dataclass
class Readings:
    """Everything the sensors deliver at one control instant.

    Attributes
    ----------
    t : float
        The control instant, s (mission clock: 0 at the start).
    suite : list of Reading
        The navigation sensors' readings delivered since the last instant (read by the
        navigation filter, ``estimation: filter``).
    state : ndarray (12,) or None
        The state as given to the controllers under the paper's Assumption 1 (``estimation:
        truth``): the true state in simulation, the autopilot's own estimate on a vehicle.
        None where no such source exists.
    flow_sensing : FlowSensing or None
        The paper's simulated sensing of ``[eta; nu_r]`` (``estimation: truth``), for the FSE
        flow filter.  None where no such sensor exists (every real vehicle).
    flow_ned : ndarray (3,) or None
        The water velocity at the vehicle in {n}, m/s, as an exteroceptive sensor would give it
        (the paper's Assumption 3): the true flow in simulation, the mission's flow model on a
        vehicle.  Only the controllers whose definition reads it (Kinematic, Oracle) get it.
    state_t : float or None
        When ``state`` was sampled, s (mission clock): a vehicle's telemetry is older than the
        instant that reads it (its age on the vehicle's clock, ``fly``); None: at ``t``.
    """

    t: float
    suite: list[Reading] = field(default_factory=list)
    state: np.ndarray | None = None
    flow_sensing: FlowSensing | None = None
    flow_ned: np.ndarray | None = None
    state_t: float | None = None
