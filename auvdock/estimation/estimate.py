"""What every controller receives: the estimation stage's :class:`Estimate` of one instant."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from auvdock.estimation.water_ahead import WaterAhead
from auvdock.sensing.readings import FlowSensing

if TYPE_CHECKING:
    from auvdock.estimation.dock_heave_error import DockErrorModel
    from auvdock.estimation.wave_model import WaveModel

__all__ = ["Estimate", "HeaveError"]


@dataclass(frozen=True)
class HeaveError:
    """The docking point's heave beyond the motion forecast from the dock's telemetry, as the
    navigation filter
    estimates it at ``t`` (s): ``state`` (2,) the error (down, m) and its rate (m/s), run forward on ``model``
    (:class:`auvdock.estimation.dock_heave_error.DockErrorModel`: it decays back to the forecast)."""

    t: float
    state: np.ndarray
    model: DockErrorModel

    def ahead(self, times: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The expected error (m, down) and its rate (m/s) at absolute ``times`` (s), each ``times.shape``
        (the estimate itself at times before ``t``)."""
        return self.model.ahead(self.state, np.asarray(times, dtype=float) - self.t)


@dataclass
class Estimate:
    """The estimation stage's view of the vehicle at one control instant.

    Attributes
    ----------
    t : float
        Time, s (mission clock: 0 at the start).
    state : ndarray (12,)
        The state estimate ``[eta; nu]``: NED position (m), ZYX Euler angles (rad), body
        velocity over ground (m/s) and angular rate (rad/s); :mod:`auvdock.vehicle.state`.
        Under ``estimation: truth`` (Assumption 1) the state as given.
    state_cov : ndarray (12, 12) or None
        Its covariance where the stage knows it (the navigation filter), else None.
    flow_ned : ndarray (3,) or None
        The water velocity at the vehicle in {n}, m/s, from an exteroceptive source
        (Assumption 3), for the controllers whose definition reads it (Kinematic, Oracle);
        None for every other controller (:class:`auvdock.loop.autopilot.Autopilot` strips it).
    flow_sensing : FlowSensing or None
        The FSE flow filter's input (paper IV.A): the paper's simulated sensing under
        ``estimation: truth``, or derived from the navigation filter's estimate.
    current_ned : ndarray (3,) or None
        The estimation stage's own estimate of the current in {n}, m/s (the navigation
        filter's), where it has one.
    dock_offset_ned : ndarray (3,) or None
        Where the stage believes the dock is, relative to the mission's dock (its charted
        position and known motion), NED m: the navigation filter's estimate of the dock's
        anchor minus the charted one.  None: the mission's dock as it is (Assumption 2).
    relative_cov : ndarray (3, 3) or None
        Covariance of the vehicle's position relative to the dock, m^2 (the navigation filter's).
    dock_position_ned : ndarray (3,) or None
        Where the stage places the docking point at ``t``, NED m: the point ``state``'s position and
        ``relative_cov`` are relative to (the navigation filter's anchor moved as the dock it knows moves:
        the chart's motion, or the motion forecast from the dock's telemetry).  None: the mission's dock
        at ``t`` plus ``dock_offset_ned``.
    dock_fix_t : float or None
        Sample time (s) of the newest camera fix of the dock the stage has used; None before the
        first (or without a dock camera).
    current_uncertainty : float or None
        How much of its prior uncertainty about the current the navigation filter still has:
        ``sqrt(lambda_max(P_current)) / prior std``, capped at 1 (1: nothing learnt; None without a
        navigation filter).  What an information reward is measured on (the filter really run).
    wave_velocity_ned : ndarray (3,) or None
        The water's wave-frequency velocity at the vehicle in {n}, m/s: the navigation filter's
        estimate with a wave model (``navigation.waves``), else None.  The current (``current_ned``,
        and what a flow filter estimates) is the slow part of the water; the controllers' prediction
        adds this to it, run forward over the horizon on the wave model (:meth:`water_ahead`).
    wave_accel_ned : ndarray (3,) or None
        Its rate of change, m/s^2 (the filter's second oscillator state), with a wave model.
    wave_model : WaveModel or None
        The filter's wave oscillators (frequency, damping), with a wave model.
    dock_heave_error : HeaveError or None
        The docking point's heave beyond the forecast dock's (:class:`HeaveError`), where the navigation
        filter estimates it (``navigation.dock_heave_error``); ``dock_position_ned`` includes it.
    """

    t: float
    state: np.ndarray
    state_cov: np.ndarray | None = None
    flow_ned: np.ndarray | None = None
    flow_sensing: FlowSensing | None = None
    current_ned: np.ndarray | None = None
    dock_offset_ned: np.ndarray | None = None
    relative_cov: np.ndarray | None = None
    dock_position_ned: np.ndarray | None = None
    dock_fix_t: float | None = None
    current_uncertainty: float | None = None
    wave_velocity_ned: np.ndarray | None = None
    wave_accel_ned: np.ndarray | None = None
    wave_model: WaveModel | None = None
    dock_heave_error: HeaveError | None = None

    def water_ahead(self, current_ned: np.ndarray, offsets_s: np.ndarray) -> WaterAhead:
        """The water a controller's prediction meets at its stages' starts ``offsets_s`` (N,) s from now:
        its ``current_ned`` (3,) estimate held, plus the wave-frequency velocity run forward on the wave
        model where the stage estimates it (:meth:`WaterAhead.from_waves`); else the current held."""
        if self.wave_velocity_ned is None or self.wave_accel_ned is None or self.wave_model is None:
            return WaterAhead.held(current_ned, len(offsets_s))
        return WaterAhead.from_waves(
            current_ned, self.wave_velocity_ned, self.wave_accel_ned, self.wave_model, offsets_s
        )

    def without_flow(self) -> Estimate:
        """The same estimate with ``flow_ned`` removed (for controllers that may not read it)."""
        return dataclasses.replace(self, flow_ned=None)
