"""Fly a real BlueROV2 (ArduSub) to the dock: the sim's controller step on MAVLink telemetry.

One session (:class:`FlySession`, :mod:`auvdock.fly.session`)::

    connect (wait for the ArduSub HEARTBEAT) -> request telemetry rates -> wait for pose
    -> [--arm: MANUAL mode, arm]
    -> every dt, the one closed loop: telemetry -> Readings -> Autopilot.step
    -> thrust -> RC override channels (ArduSub's mixer inverted) -> send
    -> end: neutral overrides, release, disarm if we armed, results closed

Only where measurements come from and where commands go differ from ``auvdock sim``: the
controller-and-estimator step is the same :class:`auvdock.loop.autopilot.Autopilot`, built by
:func:`auvdock.loop.assemble.build_autopilot`.

Modules: :mod:`~auvdock.fly.session` (the session's sequence and its ending),
:mod:`~auvdock.fly.plant` (the vehicle as the closed loop's plant), :mod:`~auvdock.fly.safety`
(the safety rules on measured values), :mod:`~auvdock.fly.vehicle_state` (what the vehicle said,
folded from its messages), :mod:`~auvdock.fly.dock_source` (the LANDING_TARGET dock),
:mod:`~auvdock.fly.telemetry` (the mission frame, sensors from telemetry, the geofence),
:mod:`~auvdock.fly.camera` (camera dock tracking in a session), :mod:`~auvdock.fly.record`
(the results file), :mod:`~auvdock.fly.link` (the MAVLink link), :mod:`~auvdock.fly.replay`.

Frames.  The mission is written in its own NED frame, in which the vehicle starts at
``start.state``; at the start the session maps the vehicle's pose onto the mission's start
pose (:class:`auvdock.fly.telemetry.MissionFrame`), so the dock (``dock.source: model``) is
where the mission puts it relative to the start, as in the paper's tank trials.

The controllers that need the flow (Kinematic, Oracle) are given the mission's flow model
(still water in the tank).  The flow-estimating controllers get the accelerometer
(SCALED_IMU2), the depth rate and the relative velocity ``nu_1 - R^T v_c(model)``.

Time.  A session waits and paces on its link's :class:`auvdock.runtime.clock.Clock`: the wall clock
for a real vehicle, a :class:`auvdock.runtime.clock.SimClock` shared with
:class:`auvdock.standins.vehicle_sim.VehicleSim` to fly in simulated time (tests).
"""

from auvdock.fly.camera import CAMERA_SERIES, CAMERA_STATES
from auvdock.fly.session import FlyAbortError, FlyResult, FlySession
from auvdock.fly.telemetry import TELEMETRY_MESSAGES

__all__ = ["FlySession", "FlyResult", "FlyAbortError", "TELEMETRY_MESSAGES", "CAMERA_STATES", "CAMERA_SERIES"]
