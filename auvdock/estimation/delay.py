"""Delay-aware estimation: the state predicted to the instant the next command acts.

Over a link, the controller's picture is late twice.  A reading is ``age`` old when the step that
uses it runs (its sample time on the vehicle's clock against the step's), and the command the step
sends acts on the vehicle ``d`` later (its delivery delay).  A controller that plans from the
reading's state plans for a vehicle that has moved on since, and the first ``d`` of its plan never
happens: at 100 ms each way the vehicle is flown 0.2 s behind itself, and a loop tuned for none
oscillates (issue 29: Oracle left the geofence on ``tank_positioned``).

:class:`DelayCompensation` closes that gap with the one model (:meth:`auvdock.vehicle.Vehicle.
stepper_in_current`): from the estimate's instant (the newest reading's sample time, or the filter's
step time) it integrates to ``t_step + d``, under the thrust that really acts over that interval:
the commands already sent and not yet acting, each from its send time plus ``d`` (the
:class:`CommandHistory`), in the estimated current (held).  The controller then plans from the
predicted state at ``t_step + d``, where its first command starts to act (the estimate's ``t`` says
so); the FSE controllers' flow filter reads the flow sensing of the predicted state (its input over
each step is then the command sent the step before, which is what acts between two predicted
instants).  The estimation stage is also given the thrust that acted over the last period, piece by
piece (a :class:`ThrustSchedule`: each command from its send time plus ``d``), not the one just
computed: the navigation filter predicts through each piece and reads the accelerometer with the
thrust acting at the reading's instant.  (Given the period's time-weighted mean instead, the
accelerometer's model was off by the change of thrust within the period: against vehicle-sim,
tracking the tank's 0.6 Hz heave, the filter then rejected 147 of 507 depth readings as outliers,
its depth drifted 4 cm from a 2 mm sensor and its NEES averaged 34 instead of 3.)

With ``d = 0`` and an estimate at the step's instant (``sim``) nothing changes.
"""

from __future__ import annotations

import bisect
import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from auvdock.sensing.readings import FlowSensing
from auvdock.vehicle.geometry import rotation_zyx
from auvdock.vehicle.state import ANG, ETA, LIN, NX

if TYPE_CHECKING:
    from auvdock.estimation.estimate import Estimate
    from auvdock.vehicle import Vehicle

__all__ = ["CommandHistory", "DelayCompensation", "ThrustSchedule", "thrust_at", "mean_thrust"]

#: The longest integration step of the forward prediction, s (RK4 substeps inside it).
MAX_STEP_S = 0.025
#: How long the history of commands reaches back, s.
HISTORY_S = 5.0


@dataclass(frozen=True)
class ThrustSchedule:
    """The thrust that acted over an interval, piecewise constant.

    Attributes
    ----------
    pieces : tuple of (t_start, t_end, thrust)
        Consecutive pieces covering the interval (s, mission clock; thrust (n,), N), in time order,
        at least one.
    timing_std_s : float
        The std of the instant each change of thrust took effect, s (0: known).  Over a link a command
        acts at its send time plus the expected delay give or take the delivery jitter, and a lost one
        leaves its predecessor acting a period longer (:meth:`DelayCompensation.timing_std_s`); the
        navigation filter widens its velocity covariance by each change's share
        (:meth:`auvdock.estimation.navigation_filter.NavigationFilter.step`).
    changes : tuple of (t_change, step)
        Each change of thrust near the interval (within three ``timing_std_s`` of it): its expected
        instant (s) and the step of thrust (n,, N); empty where the instants are known.
    """

    pieces: tuple[tuple[float, float, np.ndarray], ...]
    timing_std_s: float = 0.0
    changes: tuple[tuple[float, np.ndarray], ...] = ()

    def __post_init__(self) -> None:
        if not self.pieces:
            raise ValueError("a thrust schedule needs at least one piece")

    def at(self, t: float) -> np.ndarray:
        """The thrust (n,, N) acting at ``t`` (s): the piece that starts at or before ``t`` (the first
        before the interval, the last after it)."""
        for a, _, u in reversed(self.pieces):
            if a <= t + 1e-12:
                return u
        return self.pieces[0][2]

    def cuts(self, t0: float, t1: float) -> list[float]:
        """The instants strictly inside ``(t0, t1)`` (s) where the thrust changes."""
        return [a for a, _, _ in self.pieces[1:] if t0 + 1e-12 < a < t1 - 1e-12]

    def unsure_at(self, t: float) -> list[tuple[float, np.ndarray]]:
        """``[(p, step)]``: for each change of thrust near ``t`` (s), the probability ``p`` that it had
        taken effect on one side of ``t`` while expected on the other (its instant normal about the
        expected one with std :attr:`timing_std_s`), and its step (n,, N).  The thrust acting at ``t``
        then differs from :meth:`at` by ``step`` with probability ``p``: a reading that depends on it
        (the accelerometer) is that much less certain."""
        sigma = self.timing_std_s
        if sigma <= 0.0:
            return []
        return [(0.5 * math.erfc(abs(t - tc) / (sigma * math.sqrt(2.0))), du) for tc, du in self.changes]

    def mean(self) -> np.ndarray:
        """The time-weighted mean thrust (n,, N) over the interval (the last piece's for an empty one)."""
        span = self.pieces[-1][1] - self.pieces[0][0]
        if span <= 0.0:
            return self.pieces[-1][2]
        return np.asarray(sum((b - a) * u for a, b, u in self.pieces), dtype=float) / span


def thrust_at(u: np.ndarray | ThrustSchedule, t: float) -> np.ndarray:
    """The thrust (n,, N) acting at ``t`` (s): ``u`` itself when it is held over the whole step."""
    return u.at(t) if isinstance(u, ThrustSchedule) else np.asarray(u, dtype=float)


def mean_thrust(u: np.ndarray | ThrustSchedule) -> np.ndarray:
    """The mean thrust (n,, N) over the step: ``u`` itself when it is held."""
    return u.mean() if isinstance(u, ThrustSchedule) else np.asarray(u, dtype=float)


class CommandHistory:
    """The thrust sent at each step (mission clock, s; thrust (n,), N), and what acts when.

    A command sent at ``t_j`` acts on the vehicle from ``t_j + d`` until the next one does (zero-order
    hold); before the first, nothing acts.
    """

    def __init__(self, n_thrusters: int) -> None:
        self.n = int(n_thrusters)
        self._t: list[float] = []
        self._u: list[np.ndarray] = []

    def clear(self) -> None:
        self._t.clear()
        self._u.clear()

    def sent(self, t: float, thrust: np.ndarray) -> None:
        """The command sent at ``t`` (s): a later one at the same instant replaces it."""
        t = float(t)
        if self._t and t <= self._t[-1] + 1e-12:
            if abs(t - self._t[-1]) <= 1e-12:
                self._u[-1] = np.asarray(thrust, dtype=float).copy()
            return
        self._t.append(t)
        self._u.append(np.asarray(thrust, dtype=float).copy())
        while len(self._t) > 2 and self._t[1] < t - HISTORY_S:
            del self._t[0]
            del self._u[0]

    def period_s(self) -> float:
        """The median spacing of the commands sent, s (0 before two)."""
        if len(self._t) < 2:
            return 0.0
        return float(np.median(np.diff(self._t)))

    def acting(self, t: float, delay_s: float) -> np.ndarray:
        """The thrust acting on the vehicle at ``t`` (s) with commands ``delay_s`` late."""
        i = bisect.bisect_right(self._t, t - delay_s + 1e-12) - 1
        return np.zeros(self.n) if i < 0 else self._u[i]

    def changes(self, t0: float, t1: float, delay_s: float) -> list[tuple[float, np.ndarray]]:
        """``[(t_c, du)]``: each command expected to take effect within ``[t0, t1]`` (s), at ``t_c``, and
        its step from the one before (n,, N; the first from none)."""
        out = []
        for j, tj in enumerate(self._t):
            tc = tj + delay_s
            if t0 <= tc <= t1:
                before = self._u[j - 1] if j > 0 else np.zeros(self.n)
                du = self._u[j] - before
                if np.any(du != 0.0):
                    out.append((tc, du))
        return out

    def segments(self, t0: float, t1: float, delay_s: float) -> list[tuple[float, float, np.ndarray]]:
        """``[(ta, tb, thrust)]`` covering ``[t0, t1]`` (s): the thrust acting over each piece."""
        if t1 <= t0:
            return []
        cuts = [t0] + [tj + delay_s for tj in self._t if t0 < tj + delay_s < t1] + [t1]
        return [(a, b, self.acting(a, delay_s)) for a, b in zip(cuts[:-1], cuts[1:], strict=True) if b > a]


class DelayCompensation:
    """The forward prediction of a delay-aware estimation stage (see the module docstring).

    Parameters
    ----------
    vehicle : Vehicle
        The one model.

    Attributes
    ----------
    command_delay_s : float
        The expected delivery delay of a command, s (``fly``: half the link's measured round trip,
        :class:`auvdock.fly.link_health.LinkHealth`; 0 in simulation).
    jitter_s, loss : float
        The link's one-way jitter (s) and the fraction of its messages lost (``fly``: measured; 0 in
        simulation): how uncertain the instant is at which each command took effect
        (:meth:`timing_std_s`).
    hold_back_s : float
        Readings are held back this long behind the newest (s; ``fly``: twice the link's one-way jitter),
        so that those the jitter delays arrive before the stage passes their time: the filter then takes
        them in order (a reading behind its time would be applied late).
    history : CommandHistory
        The commands sent.
    last_horizon_s : float
        How far the last estimate was predicted, s (its age plus the command delay).
    """

    def __init__(self, vehicle: Vehicle) -> None:
        self._step = vehicle.stepper_in_current()
        self.history = CommandHistory(vehicle.n_thrusters)
        self.command_delay_s = 0.0
        self.hold_back_s = 0.0
        self.jitter_s = 0.0
        self.loss = 0.0
        self.last_horizon_s = 0.0

    def reset(self) -> None:
        self.history.clear()
        self.last_horizon_s = 0.0

    def timing_std_s(self) -> float:
        """The std of the instant a command takes effect, s: ``sqrt(jitter^2 + loss T^2)``, the link's
        one-way jitter (:attr:`jitter_s`) and, with probability :attr:`loss` (the commands lost, taken
        as the vehicle's messages lost: the same link both ways), its predecessor acting one command
        period ``T`` longer (the median spacing of the commands sent)."""
        jitter = self.jitter_s if math.isfinite(self.jitter_s) else 0.0
        loss = self.loss if math.isfinite(self.loss) else 0.0
        period = self.history.period_s()
        # a command overtaken by the one after it (their arrivals' difference has std sqrt(2) jitter)
        # acts after it, about a period late: counted as lost
        overtaken = 0.5 * math.erfc(period / (2.0 * jitter)) if jitter > 0.0 and period > 0.0 else 0.0
        return math.sqrt(jitter**2 + (loss + overtaken) * period**2)

    def acted(self, t0: float, t1: float) -> ThrustSchedule:
        """The thrust that acted over ``[t0, t1]`` (s), piece by piece, with the uncertainty of each
        change's instant: what the estimation stage predicts the last period with (an empty interval:
        the thrust acting at ``t1``)."""
        pieces = self.history.segments(t0, t1, self.command_delay_s)
        if not pieces:
            pieces = [(t1, t1, self.history.acting(t1, self.command_delay_s))]
        sigma = self.timing_std_s()
        reach = 3.0 * sigma
        changes = self.history.changes(t0 - reach, t1 + reach, self.command_delay_s) if sigma > 0 else []
        return ThrustSchedule(tuple(pieces), sigma, tuple(changes))

    def predict(self, x: np.ndarray, t0: float, t1: float, current_ned: np.ndarray | None) -> np.ndarray:
        """The state (12,) at ``t1`` from ``x`` at ``t0`` (s) under the thrust acting in between, in the
        current ``current_ned`` (3,, m/s in {n}; None: still water), held."""
        v_c = np.zeros(3) if current_ned is None else np.asarray(current_ned, dtype=float)
        z = np.asarray(x, dtype=float).reshape(NX)
        for a, b, u in self.history.segments(t0, t1, self.command_delay_s):
            n = max(1, int(np.ceil((b - a) / MAX_STEP_S - 1e-9)))
            h = (b - a) / n
            for _ in range(n):
                z = np.asarray(self._step(z, u, v_c, h)).reshape(NX)
        return z

    def forward(self, est: Estimate, t_step: float, reads_flow: bool = False) -> Estimate:
        """``est`` predicted to ``t_step + command_delay_s`` (its state and ``t``); the same estimate
        when that is its own instant.  The current held is the stage's own estimate; without one, the
        exteroceptive flow (``est.flow_ned``) only for a controller whose definition reads it
        (``reads_flow``: Oracle, Kinematic), else still water."""
        t1 = float(t_step) + self.command_delay_s
        self.last_horizon_s = max(0.0, t1 - est.t)
        if t1 <= est.t + 1e-9:
            return est
        current = est.current_ned
        if current is None and reads_flow:
            current = est.flow_ned
        x = self.predict(est.state, est.t, t1, current)
        sensing = est.flow_sensing
        if sensing is not None:  # the FSE flow filter's input (paper IV.A), of the predicted state
            R = rotation_zyx(float(x[3]), float(x[4]), float(x[5]))
            v_c = np.zeros(3) if current is None else np.asarray(current, dtype=float)
            sensing = FlowSensing(
                pose=x[ETA].copy(),
                gyro_rad_s=x[ANG].copy(),
                relative_velocity_m_s=x[LIN] - R.T @ v_c,
                depth_rate_m_s=float(R[2] @ x[LIN]),
                accel_m_s2=sensing.accel_m_s2,
            )
        # (the dock where the stage placed it was at the estimate's own instant: not carried to t1)
        return dataclasses.replace(est, t=t1, state=x, flow_sensing=sensing, dock_position_ned=None)
