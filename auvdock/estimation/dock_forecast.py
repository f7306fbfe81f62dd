"""Forecast the dock's motion from the vehicle's own fixes of it (no Assumption 2).

The camera fixes the dock's position (NED, m) about 15 times a second, 0.1 s late, with noise of a
few mm to a few cm, and loses frames at random or for seconds when the dock leaves the view.  From
these noisy, irregular samples :class:`DockForecaster` predicts where the dock will be at future
times, with an uncertainty that grows with the horizon, and :class:`ForecastDock` offers that
prediction to a controller as a :class:`auvdock.world.dock.DockMotion` in place of the true dock.

Model
-----
Each NED axis is forecast on its own as::

    p(t) = level(t) + x(t) + noise

* ``level(t) = l + s (t - t_ref)``: the dock's anchor and a slow drift (the buoy on its mooring, or
  the vehicle's own navigation drifting under the fixes), a straight line fitted by least squares to
  the last ``level_window_s`` (whose waves average out), held after the latest fix;
* ``x(t)``: the wave motion, a zero-mean stationary Gaussian process with the covariance
  ``c(tau) = integral S(w) cos(w tau) dw`` of the spectrum ``S`` (m^2 s/rad, one-sided) estimated
  from the fixes;
* ``noise``: the camera's, independent between fixes, with the standard deviation each fix reports.

Given the last ``past_s`` of fixes (at most ``max_points``: all of the last ``dense_s``, older ones
thinned evenly in time), the forecast at any time is the conditional mean and standard deviation of
the process (kriging: the Wiener-Kolmogorov predictor for irregular samples)::

    mean(t) = level(t) + k(t)^T (K + R)^-1 (y - level(t_i)),
    var(t)  = c(0) - k(t)^T (K + R)^-1 k(t),
    K_ij = c(t_i - t_j) + level_std_m^2,  k_i(t) = c(t - t_i) + level_std_m^2,  R = diag(std_i^2),

and the velocity is the derivative of that mean (``c'`` for ``c``), so that the two are consistent.
The std is that of the dock, not of a fix; it grows with the horizon from what the fixes leave
unknown towards the signal's ``sqrt(c(0))`` (the climatology, reached beyond ``covariance_span_s``).
The level's own error (about 1 cm for a 5 min window of swell) is not in it.  A gap needs nothing
special: the forecast runs on from the fixes before it, and the fixes after it enter the next solve.

The spectrum and the level are estimated again every ``refit_interval_s`` from the last ``window_s``:
the fixes are interpolated onto a grid of ``grid_step_s``, points that no two fixes less than
``max_bridge_s`` apart bracket are unmeasured and filled by the previous estimate's conditional mean
given the measured points around them (straight lines before the first); the spectrum is the Welch
average over Hann-windowed, linearly detrended segments of ``segment_s`` (each at least
``min_valid_fraction`` measured), zero-padded to twice their length so that its covariance is the mean
of their windowed autocorrelations (no periodic wrap); the fixes' noise floor ``mean(std^2)
grid_step_s / pi``, raised by ``noise_threshold`` standard errors of the estimate, is subtracted and
the rest clipped at zero; the covariance (its inverse transform) is tapered to zero at
``covariance_span_s`` by a Parzen lag window and tabulated with its derivative every
``grid_step_s / 5``, read by cubic Hermite interpolation.  Before the first estimate
(``min_history_s`` of fixes: :attr:`DockForecaster.ready` False) the forecast is the climatology of
the fixes so far.  A fix outside ``outlier_gate`` of the forecast is rejected; ``max_rejections`` in a
row mean the dock (or the frame it is measured in) has moved, and the forecaster starts again from them.

Why this method
---------------
Measured with ``benchmarks/dock_forecast.py``'s camera on the missions' docks and a gamma 7 JONSWAP,
2 cm noise, 5 % frames lost and bursts; errors as fractions of the heave's std at 0.5 / 1 / 2 / 3 / 5 s
ahead.

* The best linear predictor of a stationary Gaussian process is fixed by its covariance and takes
  irregular times, gaps and each fix's noise as they come.  PacWave's common sea: 0.13 / 0.26 / 0.47 /
  0.45 / 0.64 (persistence, the last fix held: 0.51 / 0.89 / 1.46 / 1.72 / 1.79).  Given the *true*
  covariance of the realised sea in place of the estimate, the same predictor does no better on the
  PacWave docks (ratio 0.97-1.01 over 3 seeds each): what limits it is the camera's noise and the sea's
  own randomness, not the estimate.
* The predictor tolerates smooth errors of the covariance (a peak broadened by 0.05 rad/s, the
  frequencies 5 % off or the tail by a factor of 2 cost a few %), not rough ones: a kernel with a cusp
  at zero lag believes in fast motion that is not there.  A bank of 24 first-order (Lorentzian)
  resonators in a Kalman filter erred 0.21 / 0.39 / 0.59 / 0.56 / 0.71 on the PacWave dock; the
  positive part of a Blackman-Tukey estimate from the gapped record did as well there but 20 % worse
  at 0.5-1 s on the narrow sea (its covariance 4 times too curved at zero lag).  Hence Welch
  (non-negative by construction), the noise threshold, the gap fill and the smooth taper.  Filling the
  gaps with straight lines instead doubled the error at 0.5 s on the basin's sinusoid and made its std
  3 times too large.
* An autoregressive model fitted on the grid (direct multi-step least squares, order 48 at 0.25 s; as
  Fusco and Ringwood 2010) erred 0.22 / 0.47 / 0.84 / 0.56 / 1.0 on the same fixes away from gaps and
  more after them (its grid has to be filled across a burst before it can predict).
* The level comes from the long window: a constant offset free inside the kernel (``level_std_m``)
  lets 10 s of fixes confuse the level with the swell (2 cm: 10 % worse at 2-3 s).  The drift costs
  under 3 % without one and keeps a drift of 1 cm/s harmless (without it the fixes leave the gate).

Cost: ``update`` about 50 us (a refit, every ``refit_interval_s``, several ms); ``forecast`` after new
fixes about 0.4 ms (a 3 x 48 x 48 inverse; at most 64, so that a multi-threaded BLAS on a loaded
machine stays single-threaded: a batched 96 x 96 product took 48 ms there, measured).

Frames and units: positions NED in m, standard deviations per axis in m, velocities NED in m/s, times
in s on the clock the fixes are stamped with (when the image was taken, not when the fix arrived).

References
----------
N. Wiener, *Extrapolation, Interpolation, and Smoothing of Stationary Time Series* (1949); C. E.
Rasmussen and C. K. I. Williams, *Gaussian Processes for Machine Learning* (2006), ch. 2 and 4;
P. D. Welch, "The use of fast Fourier transform for the estimation of power spectra", IEEE Trans.
Audio Electroacoust. 15 (1967); M. B. Priestley, *Spectral Analysis and Time Series* (1981), ch. 6
(lag windows, Parzen's; the equivalent degrees of freedom of a spectral estimate); F. Fusco and J. V.
Ringwood, "Short-term wave forecasting for real-time control of wave energy converters", IEEE Trans.
Sustain. Energy 1(2) (2010) (autoregressive forecasts of the sea at a buoy); DNV-RP-C205 (2021),
sec. 3.3 (a sea state is stationary over 20 min to 3 h: a 5 min window sees one sea).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated

import numpy as np
from pydantic import Field, model_validator

from auvdock.schema.strict import Strict
from auvdock.world.dock import TranslatingDock

__all__ = ["DockForecastSettings", "DockForecast", "DockForecaster", "ForecastDock"]

#: Covariance table points per spectral grid step (the table's lag step is ``grid_step_s / 5``:
#: 0.05 s, where cubic Hermite interpolation errs by ``(w dtau)^4 / 384`` < 4e-6 of c(0) up to 4 rad/s).
_TABLE_UPSAMPLE = 5
#: Samples before the cold-start climatology gates outliers.
_MIN_GATE_SAMPLES = 20
#: Measured data on either side of a gap that its fill is conditioned on, s (about half a 10 s swell).
_FILL_CONTEXT_S = 6.0


class DockForecastSettings(Strict):
    """How :class:`DockForecaster` learns and forecasts the dock's motion (defaults: see the numbers'
    sources in each description and the module docstring)."""

    window_s: Annotated[float, Field(gt=0)] = Field(
        default=300.0,
        description="data the spectrum is estimated from, s: 5 min, a few dozen swell periods of one "
        "stationary sea state (DNV-RP-C205: stationary over 20 min to 3 h)",
    )
    segment_s: Annotated[float, Field(gt=0)] = Field(
        default=150.0,
        description="Welch segment, s: resolution 2 pi / 150 = 0.042 rad/s, 6 % of a 9 s swell's "
        "frequency; three segments overlapping by half fill window_s (96 s segments cost 2-5 % at 2-5 s "
        "ahead on the PacWave seas and 20-40 % on the basin's sinusoid, measured)",
    )
    grid_step_s: Annotated[float, Field(gt=0, le=0.5)] = Field(
        default=0.25,
        description="grid the spectrum is estimated on, s: Nyquist pi / 0.25 = 12.6 rad/s, periods down "
        "to 0.5 s (the shortest wave a run resolves, auvdock.config.sea.PERIODS_PER_WAVE); grid points "
        "0.25 s apart never share a 15 Hz fix, so their noise is independent",
    )
    max_bridge_s: Annotated[float, Field(gt=0)] = Field(
        default=0.25,
        description="largest interval between two fixes that the spectral grid interpolates across, s "
        "(two or three lost frames at 15 Hz; at least 2.5 median intervals, for a slower camera); longer "
        "gaps are filled from the previous fit's covariance",
    )
    min_valid_fraction: Annotated[float, Field(gt=0, le=1)] = Field(
        default=0.7, description="share of a Welch segment that must be measured for it to be used"
    )
    covariance_span_s: Annotated[float, Field(gt=0)] = Field(
        default=150.0,
        description="lag at which the Parzen taper brings the covariance to zero, s, at most segment_s (the "
        "spectrum knows no longer lag); beyond it the dock is forecast at its level with the signal's "
        "variance (climatology).  150 s keeps 97 % of the covariance at 10 s lag; 75 s made the basin's "
        "sinusoid 30 % worse 3-5 s ahead and changed the seas by 1 % (measured)",
    )
    refit_interval_s: Annotated[float, Field(gt=0)] = Field(
        default=10.0, description="time between two estimates of the spectrum and the level, s"
    )
    min_history_s: Annotated[float, Field(gt=0)] = Field(
        default=60.0,
        description="data span before the first fit (``ready``), s: six 10 s swell periods, two Welch "
        "segments of 40 s",
    )
    past_s: Annotated[float, Field(gt=0)] = Field(
        default=10.0,
        description="fixes a forecast is conditioned on, s: about one swell period (15 s and 64 fixes "
        "gained up to 7 % at 3 s ahead, for twice the cost: measured)",
    )
    max_points: Annotated[int, Field(ge=4, le=256)] = Field(
        default=48,
        description="fixes a forecast is conditioned on at most: all of the last dense_s, older ones "
        "thinned evenly in time (48 loses < 2 % against all 150 of 10 s at 15 Hz, measured; below 64 a "
        "multi-threaded BLAS stays single-threaded)",
    )
    dense_s: Annotated[float, Field(ge=0)] = Field(
        default=1.0, description="the newest fixes kept without thinning, s"
    )
    level_window_s: Annotated[float, Field(gt=0)] = Field(
        default=300.0,
        description="data the level (and its drift) is fitted to, s: 30 swell periods, whose waves "
        "average out (a line through 120 s errs enough at its end to cost 15-25 % at 3 s ahead, measured)",
    )
    level_trend: bool = Field(
        default=True,
        description="fit the level as a straight line (a drift: the buoy on its mooring, the vehicle's "
        "navigation drifting under the fixes) rather than a constant; held after the latest fix.  "
        "Without it a drift of 1 cm/s costs 0.9 of the heave's std at 0.5 s ahead (measured); with "
        "it and no drift, under 3 %",
    )
    zero_mean: bool = Field(
        default=False,
        description="the fixes are displacements from the dock's mean (a motion unit's: its high-pass filter "
        "makes its output zero-mean), so the level is zero, not fitted: a line through fixes that carry a "
        "slow error would hold that error's 300 s average (2 cm of a 5 cm, 20 s error) as the dock's level",
    )
    noise_threshold: Annotated[float, Field(ge=0)] = Field(
        default=2.0,
        description="the spectrum's noise floor is raised by this many standard errors of the estimate "
        "before it is subtracted (2: a bin of noise alone survives with 2-5 % probability)",
    )
    level_std_m: Annotated[float, Field(ge=0)] = Field(
        default=0.0,
        description="prior standard deviation of the level around its fit, m (a constant term in the "
        "covariance, which 10 s of data can move; 0 keeps the long window's level)",
    )
    outlier_gate: Annotated[float, Field(gt=0)] = Field(
        default=5.0,
        description="a fix whose Mahalanobis distance from the forecast (3 axes, forecast and fix "
        "variance) exceeds this is rejected: chi-square with 3 dof above 25 has probability 1.5e-5",
    )
    max_rejections: Annotated[int, Field(ge=1)] = Field(
        default=15,
        description="consecutive rejected fixes after which the forecaster concludes the dock moved (or "
        "the navigation jumped) and starts again from those fixes (15: 1 s at 15 Hz)",
    )
    slow_error_std_m: Annotated[float, Field(ge=0)] = Field(
        default=0.0,
        description="std of a slow error of the heave fixes (down axis), m: a motion unit's (a first-order "
        "Gauss-Markov process, sensors.dock_telemetry's heave_error_std_m); its covariance joins the fixes' "
        "and its spectrum is taken out of the estimate (0: none, white noise only)",
    )
    slow_error_tau_s: Annotated[float, Field(gt=0)] = Field(
        default=20.0, description="correlation time of that slow error, s"
    )
    max_rate_points: Annotated[int, Field(ge=0, le=128)] = Field(
        default=24,
        description="rate fixes (update_rate: a motion unit's heave rate) a forecast is "
        "conditioned on at most, "
        "spread evenly over past_s",
    )
    min_std_m: Annotated[float, Field(gt=0)] = Field(
        default=1e-3,
        description="floor of a fix's standard deviation, m (1 mm: keeps the solve well conditioned)",
    )

    @model_validator(mode="after")
    def _consistent(self) -> DockForecastSettings:
        if self.segment_s > self.window_s:
            raise ValueError(
                f"segment_s ({self.segment_s:g} s) must not exceed window_s ({self.window_s:g} s)"
            )
        if self.covariance_span_s > self.segment_s + 1e-9:
            raise ValueError(
                f"covariance_span_s ({self.covariance_span_s:g} s) must not exceed segment_s "
                f"({self.segment_s:g} s): the spectrum knows no lag longer than a segment"
            )
        if self.segment_s < 8 * self.grid_step_s:
            raise ValueError("segment_s must span at least 8 grid steps")
        if self.min_history_s < 4 * self.grid_step_s:
            raise ValueError("min_history_s must span at least 4 grid steps")
        if self.dense_s > self.past_s:
            raise ValueError(f"dense_s ({self.dense_s:g} s) must not exceed past_s ({self.past_s:g} s)")
        return self


@dataclass(frozen=True)
class DockForecast:
    """A forecast of the dock at ``n`` times (NED).

    Attributes
    ----------
    times_s : ndarray (n,)
        The times, s.
    position_ned_m : ndarray (n, 3)
        Expected position, m.
    std_m : ndarray (n, 3)
        Standard deviation of the position per axis, m (of the dock, not of a fix: no camera noise).
    velocity_ned_m_s : ndarray (n, 3)
        Derivative of the expected position, m/s.
    ready : bool
        False: the cold-start climatology (mean and spread of the fixes so far, zero velocity).
    """

    times_s: np.ndarray
    position_ned_m: np.ndarray
    std_m: np.ndarray
    velocity_ned_m_s: np.ndarray
    ready: bool


class _Fit:
    """One estimate of the spectra, covariance tables and levels of the three axes."""

    def __init__(
        self,
        omega: np.ndarray,
        spectrum: np.ndarray,
        cov: np.ndarray,
        dcov: np.ndarray,
        lag_step: float,
        level: np.ndarray,
        slope: np.ndarray,
        t_ref: float,
        ddcov: np.ndarray | None = None,
    ) -> None:
        self.omega = omega  # (nf,) rad/s
        self.spectrum = spectrum  # (3, nf) m^2 s/rad, one-sided, noise floor removed
        self.cov = cov  # (3, nt) m^2 at lags j * lag_step
        self.dcov = dcov  # (3, nt) m^2/s, d cov / d tau
        self.ddcov = ddcov  # (3, nt) m^2/s^2, d^2 cov / d tau^2
        self.lag_step = lag_step
        self.level = level  # (3,) m at t_ref
        self.slope = slope  # (3,) m/s
        self.t_ref = t_ref

    def level_at(self, t: np.ndarray, t_hold: float) -> np.ndarray:
        """(n, 3) level at times t (n,), the drift held after ``t_hold`` (the latest fix)."""
        s = np.minimum(t, t_hold) - self.t_ref
        return self.level[None, :] + s[:, None] * self.slope[None, :]

    def slope_at(self, t: np.ndarray, t_hold: float) -> np.ndarray:
        """(n, 3) the level's rate at times t (n,): zero after ``t_hold``."""
        on = (t <= t_hold).astype(float)
        return on[:, None] * self.slope[None, :]

    def lookup2(self, lags: np.ndarray) -> np.ndarray:
        """c''(lags) of the three axes, (3,) + lags.shape: the derivative of the cubic Hermite interpolant of
        (c', c'') -- so that a rate's covariance with a rate is the derivative of its covariance with a
        displacement; zero beyond the span."""
        assert self.ddcov is not None
        a = np.abs(lags) / self.lag_step
        last = self.cov.shape[1] - 1
        i = np.minimum(a.astype(np.int64), last - 1)
        s = a - i
        c0, c1 = self.dcov[:, i], self.dcov[:, i + 1]
        d0, d1 = self.ddcov[:, i] * self.lag_step, self.ddcov[:, i + 1] * self.lag_step
        s2 = s * s
        out = (6.0 * s2 - 6.0 * s) * (c0 - c1) + (3.0 * s2 - 4.0 * s + 1.0) * d0 + (3.0 * s2 - 2.0 * s) * d1
        out /= self.lag_step  # c'' is even: no sign
        out[:, a >= last] = 0.0
        return out

    def lookup(self, lags: np.ndarray, derivative: bool = False) -> np.ndarray:
        """c(lags), or its derivative, of the three axes: shape (3,) + lags.shape; zero beyond the span.

        Cubic Hermite interpolation of the tables of c and c' (error ``(w dtau)^4 / 384`` of c(0)); the
        derivative is that interpolant's own, so a forecast's velocity is exactly the derivative of its
        position (linear interpolation of c made them differ by 10 %: the kriging weights are large
        when the noise is small, and they amplify the interpolant's kinks)."""
        a = np.abs(lags) / self.lag_step
        last = self.cov.shape[1] - 1
        i = np.minimum(a.astype(np.int64), last - 1)
        s = a - i
        c0, c1 = self.cov[:, i], self.cov[:, i + 1]
        d0, d1 = self.dcov[:, i] * self.lag_step, self.dcov[:, i + 1] * self.lag_step
        s2 = s * s
        if derivative:
            out = (
                (6.0 * s2 - 6.0 * s) * (c0 - c1) + (3.0 * s2 - 4.0 * s + 1.0) * d0 + (3.0 * s2 - 2.0 * s) * d1
            )
            out *= np.sign(lags) / self.lag_step
        else:
            s3 = s2 * s
            out = (
                (2.0 * s3 - 3.0 * s2 + 1.0) * c0
                + (s3 - 2.0 * s2 + s) * d0
                + (3.0 * s2 - 2.0 * s3) * c1
                + (s3 - s2) * d1
            )
        out[:, a >= last] = 0.0
        return out


class DockForecaster:
    """Learns the dock's motion from its measured positions and forecasts it (see the module docstring).

    Parameters
    ----------
    settings : DockForecastSettings, optional
        Defaults: ``DockForecastSettings()``.

    Use: :meth:`update` with each fix (time-ordered), :meth:`forecast` (or :meth:`predict`, which adds
    the velocity) whenever a prediction is needed, :attr:`ready` to know whether the spectrum has been
    learnt (before that the forecast is the climatology of the fixes so far).
    """

    def __init__(self, settings: DockForecastSettings | None = None) -> None:
        self.settings = settings if settings is not None else DockForecastSettings()
        self.reset()

    # --- state ---------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget every fix and the fitted spectrum."""
        cap = 4096
        self._t = np.empty(cap)
        self._y = np.empty((cap, 3))
        self._r = np.empty((cap, 3))  # variances, m^2
        self._n = 0
        self._tr = np.empty(cap)  # rate fixes (update_rate): times, values (m/s), variances
        self._yr = np.empty((cap, 3))
        self._rr = np.empty((cap, 3))
        self._nr = 0
        self._fit: _Fit | None = None
        self._t_fit = -math.inf
        self._solve: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = (
            None  # t_i, t_r, alpha, K^-1
        )
        self._dirty = True  # fixes arrived since the solve
        self._pending: list[tuple[float, np.ndarray, np.ndarray]] = []  # the current run of rejections
        #: Fixes accepted, rejected (outliers, out of order, not finite), and restarts after a run of
        #: ``max_rejections`` outliers.
        self.accepted = 0
        self.rejected = 0
        self.restarts = 0

    @property
    def ready(self) -> bool:
        """True once the spectrum has been estimated (``min_history_s`` of fixes)."""
        return self._fit is not None

    @property
    def n_measurements(self) -> int:
        """Fixes held: at least those of the last ``window_s`` (older ones are dropped when the buffer
        fills)."""
        return self._n

    @property
    def last_time_s(self) -> float:
        """Time of the latest accepted fix, s (-inf before any)."""
        return float(self._t[self._n - 1]) if self._n else -math.inf

    @property
    def spectrum(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The last estimate: angular frequencies (nf,) rad/s and one-sided spectra (3, nf) m^2 s/rad
        (noise floor removed); None before the first fit."""
        if self._fit is None:
            return None
        return self._fit.omega.copy(), self._fit.spectrum.copy()

    @property
    def signal_std_m(self) -> np.ndarray:
        """Standard deviation of the dock's motion about its level per axis (3,), m: ``sqrt(c(0))``
        after the first fit, the spread of the fixes before (nan without fixes)."""
        if self._fit is not None:
            return np.sqrt(np.maximum(self._fit.cov[:, 0], 0.0))
        if self._n < 2:
            return np.full(3, math.nan)
        return np.asarray(self._y[: self._n].std(axis=0))

    def level(self, t: float) -> np.ndarray:
        """The dock's anchor (level, NED m) at time t (3,): the fitted line, or the mean of the fixes
        before the first fit."""
        if self._fit is not None:
            return np.asarray(self._fit.level_at(np.array([float(t)]), self.last_time_s)[0])
        if self._n == 0:
            raise RuntimeError("no dock fix yet")
        return np.asarray(self._y[: self._n].mean(axis=0))

    # --- measurements ------------------------------------------------------------------------------
    def update(self, t: float, position_ned: np.ndarray, std: np.ndarray) -> bool:
        """Add one fix of the dock: position (3,) NED m taken at time t (s), per-axis std (3,) m.

        Returns True if the fix was used, False if it was rejected: an outlier (outside
        ``outlier_gate`` of the forecast), not later than the previous fix, or not finite.  After
        ``max_rejections`` outliers in a row the forecaster starts again from them (``restarts``).
        """
        p = np.asarray(position_ned, dtype=float).reshape(3)
        s = np.maximum(np.asarray(std, dtype=float).reshape(3), self.settings.min_std_m)
        t = float(t)
        if not (math.isfinite(t) and np.all(np.isfinite(p)) and np.all(np.isfinite(s))) or (
            self._n and t <= self._t[self._n - 1]
        ):
            self.rejected += 1
            return False
        r = s * s
        if not self._gate(t, p, r):
            self.rejected += 1
            self._pending.append((t, p, r))
            if len(self._pending) >= self.settings.max_rejections:
                self._restart()
            return False
        self._pending.clear()
        self._append(t, p, r)
        self.accepted += 1
        st = self.settings
        span = t - float(self._t[0])
        if span >= st.min_history_s and t - self._t_fit >= st.refit_interval_s:
            self._refit()
        return True

    def update_rate(self, t: float, rate_ned: np.ndarray, std: np.ndarray) -> bool:
        """Add one fix of the dock's rate (a motion unit's heave rate): (3,) NED m/s taken at time t
        (s), per-axis std (3,) m/s.  The forecast conditions on ``max_rate_points`` of them, spread over
        ``past_s``, with the covariances the spectrum implies (a rate's with a displacement ``-c'``, with a
        rate ``-c''``).  False if rejected (not finite, or not later than the previous rate fix)."""
        v = np.asarray(rate_ned, dtype=float).reshape(3)
        sd = np.maximum(np.asarray(std, dtype=float).reshape(3), 1e-4)
        t = float(t)
        if not (math.isfinite(t) and np.all(np.isfinite(v)) and np.all(np.isfinite(sd))) or (
            self._nr and t <= self._tr[self._nr - 1]
        ):
            return False
        if self._nr == self._tr.size:  # keep the newer half
            h = self._nr // 2
            self._tr[: self._nr - h] = self._tr[h : self._nr]
            self._yr[: self._nr - h] = self._yr[h : self._nr]
            self._rr[: self._nr - h] = self._rr[h : self._nr]
            self._nr -= h
        self._tr[self._nr], self._yr[self._nr], self._rr[self._nr] = t, v, sd * sd
        self._nr += 1
        self._dirty = True
        return True

    def _restart(self) -> None:
        """Forget everything but the run of rejected fixes and start again from them (the dock, or the
        frame it is measured in, has moved: the old level and fixes no longer apply)."""
        fixes = self._pending
        counts = (self.accepted + len(fixes), self.rejected - len(fixes), self.restarts + 1)
        self.reset()
        for t, p, r in fixes:
            self._append(t, p, r)
        self.accepted, self.rejected, self.restarts = counts

    def _append(self, t: float, p: np.ndarray, r: np.ndarray) -> None:
        if self._n == self._t.size:
            keep = self._t[: self._n] >= t - self.settings.window_s - 1.0
            k = int(np.argmax(keep)) if keep.any() else self._n
            m = self._n - k
            if m > self._t.size // 2:  # still more than half full after trimming: grow
                grow = self._t.size * 2
                t2, y2, r2 = np.empty(grow), np.empty((grow, 3)), np.empty((grow, 3))
                t2[:m], y2[:m], r2[:m] = self._t[k : self._n], self._y[k : self._n], self._r[k : self._n]
                self._t, self._y, self._r = t2, y2, r2
            else:
                self._t[:m] = self._t[k : self._n]
                self._y[:m] = self._y[k : self._n]
                self._r[:m] = self._r[k : self._n]
            self._n = m
        self._t[self._n] = t
        self._y[self._n] = p
        self._r[self._n] = r
        self._n += 1
        self._dirty = True

    def _gate(self, t: float, p: np.ndarray, r: np.ndarray) -> bool:
        """Whether the fix lies within ``outlier_gate`` of the forecast at its time."""
        if self._fit is None:
            if self._n < _MIN_GATE_SAMPLES:
                return True
            y = self._y[: self._n]
            mean, var = y.mean(axis=0), y.var(axis=0) + r
        else:
            f = self._posterior(np.array([t]), velocity=False, fresh=False)
            mean, var = f[0][0], f[1][0] ** 2 + r
            var = var + self._slow_cov(np.zeros(1))[:, 0]  # the fix carries its slow error too
        d2 = float(np.sum((p - mean) ** 2 / var))
        return d2 <= self.settings.outlier_gate**2

    # --- the spectrum ------------------------------------------------------------------------------
    def _refit(self) -> None:
        """Estimate the spectra, covariance tables and levels from the last ``window_s`` of fixes."""
        st = self.settings
        g = st.grid_step_s
        t_all, y_all, r_all = self._t[: self._n], self._y[: self._n], self._r[: self._n]
        t_end = float(t_all[-1])
        t0 = max(float(t_all[0]), t_end - st.window_s)
        n_grid = int((t_end - t0) / g) + 1
        tg = t_end - g * np.arange(n_grid)[::-1]
        j = np.clip(np.searchsorted(t_all, tg), 1, t_all.size - 1)
        ta, tb = t_all[j - 1], t_all[j]
        wb = np.clip((tg - ta) / np.maximum(tb - ta, 1e-12), 0.0, 1.0)[:, None]
        x = (1.0 - wb) * y_all[j - 1] + wb * y_all[j]  # (n_grid, 3)
        noise = (1.0 - wb) ** 2 * r_all[j - 1] + wb**2 * r_all[j]
        # bridge single lost frames at any rate: at least 2.5 median intervals between fixes
        bridge = max(st.max_bridge_s, 2.5 * float(np.median(np.diff(t_all[t_all >= t0 - 1.0]))))
        valid = (tb - ta) <= bridge + 1e-9
        if valid.sum() < 8:
            return
        # the level: a line through the valid grid points of the last level_window_s
        lv = valid & (tg >= t_end - st.level_window_s)
        if lv.sum() < 4:
            lv = valid
        s = tg[lv] - t_end
        if st.zero_mean:
            level, slope = np.zeros(3), np.zeros(3)
        elif st.level_trend:
            A = np.stack([np.ones_like(s), s], axis=1)
            coef, *_ = np.linalg.lstsq(A, x[lv], rcond=None)
            level, slope = coef[0], coef[1]
        else:
            level, slope = x[lv].mean(axis=0), np.zeros(3)
        # Welch segments (bridged where invalid), Hann window, linear detrend
        L = int(round(min(st.segment_s, (t_end - t0) / 1.5) / g))
        L -= L % 2
        if L < 8:
            return
        xf = self._fill_gaps(tg, x, noise, valid)
        step = L // 2
        starts = np.arange(n_grid - L, -1, -step)[::-1]
        frac = np.array([valid[k : k + L].mean() for k in starts]) if starts.size else np.zeros(0)
        starts = starts[frac >= st.min_valid_fraction]
        if starts.size == 0:
            return
        win = np.hanning(L)
        U = float(np.sum(win**2))
        u = np.arange(L) - 0.5 * (L - 1)
        P = np.zeros((L + 1, 3))
        for k in starts:
            seg = xf[k : k + L]
            c1 = seg.mean(axis=0)
            c2 = (u @ (seg - c1)) / float(u @ u)
            det = seg - c1 - u[:, None] * c2
            P += np.abs(np.fft.rfft(det * win[:, None], n=2 * L, axis=0)) ** 2  # zero-padded: no wrap
        P /= starts.size
        S = 2.0 * g * P / (2.0 * math.pi * U)  # one-sided, m^2 s/rad: sum S dw = variance
        # the white floor of the fixes' noise, raised by noise_threshold standard errors of a Welch
        # estimate of nu = 1.9 K degrees of freedom (K Hann segments overlapping by half: Welch 1967),
        # so that bins of noise alone vanish instead of leaving their positive part as false motion
        nu = 1.9 * starts.size
        n0 = noise[valid].mean(axis=0) * g / math.pi * (1.0 + st.noise_threshold * math.sqrt(2.0 / nu))
        S = S - n0[None, :]
        dw = math.pi / (L * g)
        if st.slow_error_std_m > 0.0:  # the fixes' known slow error (heave): its spectrum is not the dock's
            wgrid = dw * np.arange(S.shape[0])
            tau_e = st.slow_error_tau_s
            S[:, 2] -= 2.0 * st.slow_error_std_m**2 * tau_e / math.pi / (1.0 + (wgrid * tau_e) ** 2)
        S = np.maximum(S, 0.0)
        S[0] = 0.0
        S[-1] = 0.0
        omega = dw * np.arange(L + 1)
        # covariance and its derivative on a fine lag grid (exact: the band-limited cosine sums); with
        # the segments zero-padded to twice their length it is the mean of their windowed
        # autocorrelations, which vanish beyond one segment (no periodic wrap)
        n_fft = 2 * L * _TABLE_UPSAMPLE
        lag_step = g / _TABLE_UPSAMPLE
        X = np.zeros((3, n_fft // 2 + 1), dtype=complex)
        X[:, : S.shape[0]] = (S * dw).T * (n_fft / 2.0)
        w_full = dw * np.arange(n_fft // 2 + 1)
        cov = np.fft.irfft(X, n_fft, axis=1)
        dcov = np.fft.irfft(1j * w_full[None, :] * X, n_fft, axis=1)
        d2cov = np.fft.irfft(-(w_full[None, :] ** 2) * X, n_fft, axis=1)
        n_tab = min(int(math.ceil(st.covariance_span_s / lag_step)) + 1, n_fft // 2)
        tau = lag_step * np.arange(n_tab)
        span = min(st.covariance_span_s, tau[-1])
        uu = tau / span
        pz = np.where(uu <= 0.5, 1.0 - 6.0 * uu**2 + 6.0 * uu**3, 2.0 * np.clip(1.0 - uu, 0.0, None) ** 3)
        dpz = np.where(uu <= 0.5, -12.0 * uu + 18.0 * uu**2, -6.0 * np.clip(1.0 - uu, 0.0, None) ** 2) / span
        d2pz = np.where(uu <= 0.5, -12.0 + 36.0 * uu, 12.0 * np.clip(1.0 - uu, 0.0, None)) / span**2
        c_tab = cov[:, :n_tab] * pz
        dc_tab = dcov[:, :n_tab] * pz + cov[:, :n_tab] * dpz
        d2c_tab = d2cov[:, :n_tab] * pz + 2.0 * dcov[:, :n_tab] * dpz + cov[:, :n_tab] * d2pz
        self._fit = _Fit(omega, S.T.copy(), c_tab, dc_tab, lag_step, level, slope, t_end, d2c_tab)
        self._t_fit = t_end
        self._solve = None

    def _fill_gaps(self, tg: np.ndarray, x: np.ndarray, noise: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """The grid (n, 3) with its unmeasured points filled: by the previous fit's conditional mean given
        the measured points within ``_FILL_CONTEXT_S`` on either side (a Gaussian-process smoother), or
        by straight lines before the first fit.  Lines across a gap of seconds would put false power
        into the spectrum (4 % of a 0.6 Hz sinusoid's variance below 3 rad/s, measured)."""
        xf = x.copy()
        if valid.all():
            return xf
        iv = np.flatnonzero(valid)
        fit = self._fit
        if fit is None:
            bad = np.flatnonzero(~valid)
            for a in range(3):
                xf[bad, a] = np.interp(bad, iv, x[iv, a])
            return xf
        g = self.settings.grid_step_s
        nc = max(2, int(round(_FILL_CONTEXT_S / g)))
        edges = np.flatnonzero(np.diff(np.concatenate([[0], (~valid).astype(np.int8), [0]])))
        for i0, i1 in zip(edges[0::2], edges[1::2], strict=True):
            ctx = iv[(iv >= i0 - nc) & (iv < i1 + nc)]
            if ctx.size > self.settings.max_points:
                ctx = ctx[np.linspace(0, ctx.size - 1, self.settings.max_points).round().astype(np.int64)]
            if ctx.size < 2:
                for a in range(3):
                    xf[i0:i1, a] = np.interp(np.arange(i0, i1), iv, x[iv, a])
                continue
            tc = tg[ctx]
            mu = x[ctx].mean(axis=0)
            K = fit.lookup(tc[:, None] - tc[None, :])
            d = np.arange(ctx.size)
            K[:, d, d] += noise[ctx].T + 1e-12
            k = fit.lookup(tg[i0:i1, None] - tc[None, :])  # (3, gap, m)
            w = np.linalg.solve(K, (x[ctx] - mu).T[:, :, None])[:, :, 0]  # (3, m)
            xf[i0:i1] = mu + np.einsum("agm,am->ga", k, w)
        return xf

    # --- the forecast ------------------------------------------------------------------------------
    def _regressors(self) -> np.ndarray:
        """Indices of the fixes the forecast is conditioned on."""
        st = self.settings
        t = self._t[: self._n]
        t_last = float(t[-1])
        k = int(np.searchsorted(t, t_last - st.past_s))
        n = self._n - k
        if n <= st.max_points:
            return np.arange(k, self._n)
        kd = max(int(np.searchsorted(t, t_last - st.dense_s)), self._n - st.max_points // 2)
        n_old = st.max_points - (self._n - kd)
        if n_old <= 0 or kd <= k:
            return np.arange(self._n - st.max_points, self._n)
        target = np.linspace(t[k], t[kd - 1], n_old)
        pick = np.unique(np.clip(np.searchsorted(t[k:kd], target), 0, kd - k - 1)) + k
        return np.concatenate([pick, np.arange(kd, self._n)])

    def _rate_regressors(self) -> np.ndarray:
        """Indices of the rate fixes the forecast is conditioned on: ``max_rate_points`` spread over the last
        ``past_s`` before the latest displacement fix, the newest included (none before a fit: the
        rate needs the
        spectrum's c'')."""
        st = self.settings
        if self._nr == 0 or st.max_rate_points == 0 or self._fit is None or self._fit.ddcov is None:
            return np.zeros(0, dtype=np.int64)
        t = self._tr[: self._nr]
        k = int(np.searchsorted(t, self.last_time_s - st.past_s))
        n = self._nr - k
        if n <= st.max_rate_points:
            return np.arange(k, self._nr)
        # spread evenly over past_s (what tells a slow error from the heave is the rate's whole record), the
        # newest always in
        return np.unique(np.linspace(k, self._nr - 1, st.max_rate_points).round().astype(np.int64))

    def _slow_cov(self, lags: np.ndarray) -> np.ndarray:
        """The fixes' slow error's covariance at ``lags`` on each axis, (3,) + lags.shape (heave only)."""
        st = self.settings
        out = np.zeros((3,) + lags.shape)
        if st.slow_error_std_m > 0.0:
            out[2] = st.slow_error_std_m**2 * np.exp(-np.abs(lags) / st.slow_error_tau_s)
        return out

    def _solved(self, fit: _Fit, fresh: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(t_i, t_r, alpha, K^-1) of the displacement and rate fixes the forecast is conditioned on.
        ``fresh=False`` (the outlier gate) accepts a solve that misses the fixes of the last second."""
        stale = self._solve is None or (
            self._dirty and (fresh or float(self._solve[0][-1]) < self.last_time_s - 1.0)
        )
        if stale:
            idx = self._regressors()
            ti = self._t[idx]
            t_hold = self.last_time_s
            resid = self._y[idx] - fit.level_at(ti, t_hold)  # (m, 3)
            lv = self.settings.level_std_m**2
            K = fit.lookup(ti[:, None] - ti[None, :]) + lv + self._slow_cov(ti[:, None] - ti[None, :])
            m = ti.size
            diag = np.arange(m)
            K[:, diag, diag] += self._r[idx].T
            ridx = self._rate_regressors()
            tr = self._tr[ridx]
            if tr.size:
                mr = tr.size
                Kf = np.empty((3, m + mr, m + mr))
                Kf[:, :m, :m] = K
                Khr = -fit.lookup(ti[:, None] - tr[None, :], derivative=True)  # E[h(t_i) h'(t_r)] = -c'
                Kf[:, :m, m:] = Khr
                Kf[:, m:, :m] = np.transpose(Khr, (0, 2, 1))
                Kf[:, m:, m:] = -fit.lookup2(tr[:, None] - tr[None, :])
                dr = m + np.arange(mr)
                Kf[:, dr, dr] += self._rr[ridx].T
                K = Kf
                resid = np.concatenate([resid, self._yr[ridx] - fit.slope_at(tr, t_hold)], axis=0)
            Kinv = np.linalg.inv(K)
            alpha = np.einsum("aij,ja->ai", Kinv, resid)  # (3, m + mr)
            self._solve = (ti, tr, alpha, Kinv)
            self._dirty = False
        assert self._solve is not None
        return self._solve

    def _posterior(
        self, times: np.ndarray, velocity: bool, fresh: bool = True
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Mean (n, 3), std (n, 3) and (optionally) velocity (n, 3) at times (n,)."""
        fit = self._fit
        assert fit is not None
        ti, tr, alpha, Kinv = self._solved(fit, fresh)
        t_hold = self.last_time_s
        lags = times[:, None] - ti[None, :]  # (n, m)
        k = fit.lookup(lags) + self.settings.level_std_m**2  # (3, n, m)
        if tr.size:
            lags_r = times[:, None] - tr[None, :]
            k = np.concatenate([k, -fit.lookup(lags_r, derivative=True)], axis=2)
        mean = fit.level_at(times, t_hold) + np.einsum("anm,am->na", k, alpha)
        Kk = np.einsum("aij,anj->ani", Kinv, k)
        var = fit.cov[:, 0][None, :] + self.settings.level_std_m**2 - np.einsum("ani,ani->na", k, Kk)
        std = np.sqrt(np.maximum(var, 0.0))
        vel = None
        if velocity:
            dk = fit.lookup(lags, derivative=True)
            if tr.size:
                dk = np.concatenate([dk, -fit.lookup2(lags_r)], axis=2)
            vel = fit.slope_at(times, t_hold) + np.einsum("anm,am->na", dk, alpha)
        return mean, std, vel

    def predict(self, times: np.ndarray | float) -> DockForecast:
        """Position, its std and velocity at absolute times (n,) s (or a scalar: n = 1).

        Raises RuntimeError before the first fix."""
        tt = np.atleast_1d(np.asarray(times, dtype=float)).ravel()
        if self._n == 0:
            raise RuntimeError("no dock fix yet: nothing to forecast from")
        if self._fit is None:
            y = self._y[: self._n]
            mean = y.mean(axis=0)
            noise = self._r[: self._n].mean(axis=0)
            spread = np.sqrt(y.var(axis=0) + noise) if self._n > 1 else np.sqrt(noise)
            n = tt.size
            return DockForecast(tt, np.tile(mean, (n, 1)), np.tile(spread, (n, 1)), np.zeros((n, 3)), False)
        mean, std, vel = self._posterior(tt, velocity=True)
        assert vel is not None
        return DockForecast(tt, mean, std, vel, True)

    def forecast(self, t_now: float, times: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Expected position (n, 3) NED m and its std (n, 3) m at absolute times (n,) s.

        ``t_now`` (s) is when the forecast is made: it must not precede the latest fix (a fix from the
        future is an error of the caller's clocks).  Times before ``t_now`` are allowed (a smoothed
        estimate).  Before :attr:`ready` this is the climatology of the fixes so far."""
        if self._n and float(t_now) < self.last_time_s - 1e-9:
            raise ValueError(
                f"t_now {float(t_now):.3f} s precedes the latest fix at {self.last_time_s:.3f} s"
            )
        f = self.predict(times)
        return f.position_ned_m, f.std_m

    def velocity(self, times: np.ndarray | float) -> np.ndarray:
        """Expected velocity (n, 3) NED m/s at absolute times (n,) s (zero before :attr:`ready`)."""
        return self.predict(times).velocity_ned_m_s


class ForecastDock(TranslatingDock):
    """The forecast dock as a :class:`auvdock.world.dock.DockMotion`: what a controller tracks in place of
    the true dock when it knows only the camera's fixes.

    ``position(t)`` and ``velocity(t)`` (shape ``t.shape + (3,)``, NED m and m/s) are the forecaster's
    expected position and its derivative given the fixes so far; ``std(t)`` its uncertainty.  Every
    call forecasts from the latest fit and fixes (it holds no copy of its own).

    Parameters
    ----------
    forecaster : DockForecaster
        The forecaster fed with the fixes.
    heading_rad : float
        Heading of a docked vehicle, rad (fixed; a position fix does not measure it).
    """

    def __init__(self, forecaster: DockForecaster, heading_rad: float = 0.0) -> None:
        self.forecaster = forecaster
        self.heading_rad = float(heading_rad)

    @property
    def position_ned_m(self) -> tuple[float, float, float]:
        """The dock's anchor: the level at the latest fix, NED m."""
        f = self.forecaster
        n, e, d = (float(v) for v in f.level(f.last_time_s))
        return n, e, d

    def _predict(self, t: float | np.ndarray) -> tuple[DockForecast, tuple[int, ...]]:
        tt = np.asarray(t, dtype=float)
        return self.forecaster.predict(tt.ravel()), tt.shape

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Expected dock position (north, east, down), m, at time(s) t (s); shape (..., 3)."""
        f, shape = self._predict(t)
        return f.position_ned_m.reshape(shape + (3,))

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        """Expected dock velocity (north, east, down), m/s, at time(s) t (s); shape (..., 3)."""
        f, shape = self._predict(t)
        return f.velocity_ned_m_s.reshape(shape + (3,))

    def std(self, t: float | np.ndarray) -> np.ndarray:
        """Standard deviation of the dock's position per axis, m, at time(s) t (s); shape (..., 3)."""
        f, shape = self._predict(t)
        return f.std_m.reshape(shape + (3,))

    def trajectory(self, t0: float, dt: float, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Dock motion at ``t0 + k dt`` for k = 0..n_steps (one forecast for both position and velocity):
        times (n_steps + 1,) s, positions and velocities (n_steps + 1, 3) NED m and m/s."""
        t = t0 + dt * np.arange(n_steps + 1)
        f = self.forecaster.predict(t)
        return t, f.position_ned_m, f.velocity_ned_m_s
