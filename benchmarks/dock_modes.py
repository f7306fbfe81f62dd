"""The dock's heave as a bank of oscillators in a Kalman filter: the alternative to the spectral
forecaster that ``benchmarks/dock_motion_forecast.py`` measures (not used by auvdock: it forecasts
1.6-4.2 times worse than the optimal linear predictor where the spectral forecaster is within 1.09-1.43
times, measured there).

A moored WEC's heave (the buoy's answer to the sea) is a stationary, narrow-band process.  Its spectrum
``S(w)`` (m^2 s/rad, one-sided) is fitted by ``K`` independent damped oscillators, each driven by white
acceleration noise::

    p_k' = v_k,   v_k' = -w_k^2 p_k - 2 z_k w_k v_k + n_k,   E[n_k(t) n_k(s)] = q_k delta(t - s)

whose stationary variance is ``q_k / (4 z_k w_k^3)`` and whose displacement spectrum is
``q_k / (2 pi ((w_k^2 - w^2)^2 + (2 z_k w_k w)^2))`` (one-sided, per rad/s).  The heave is ``sum_k p_k``.
As states of a Kalman filter the oscillators give the optimal linear predictor *for the fitted
spectrum* (Kalman 1960; the Wiener predictor of a rational spectrum), take irregular, late and missing
samples as they come, and let every measurement that sees the dock -- its motion unit's heave, heave
rate and acceleration, the vehicle's camera fixes of the docking point -- inform the same states.

Fitting (:func:`fit_modes`): the band holding 99 % of the spectrum's variance is split into ``K`` bands of
equal relative width; a mode's variance is its band's, its frequency the band's centroid and its damping ratio
``sqrt(3) sigma_k / w_k``, ``sigma_k`` the band's spread (the half-power bandwidth ``2 z w`` of a
resonance made equal to the width ``2 sqrt(3) sigma`` of a flat band of the same spread), floored at
``min_damping`` (the spectral estimate's resolution).  A regular sea (one line) gives ``K`` modes at
its frequency, lightly damped: a sinusoid whose amplitude and phase the filter tracks.  The fit is
moments, not a least-squares search: it needs no optimiser, it is deterministic, and it cannot
diverge (a narrow spectrum is matched in its mass and centre, which a forecast over a few seconds
depends on; the shape of the tails costs little, measured in ``benchmarks/dock_motion_forecast.py``).

Frames and units: heave down (NED), m; rates m/s; frequencies rad/s; times s.

References
----------
R. E. Kalman, "A new approach to linear filtering and prediction problems", J. Basic Eng. 82 (1960);
T. I. Fossen, *Handbook of Marine Craft Hydrodynamics and Motion Control* (2011), sec. 8.2.6 (linear
wave-response models: a sea's spectrum by second-order resonances driven by white noise);
A. Papoulis, *Probability, Random Variables and Stochastic Processes* (1991), ch. 10 (the spectrum of a
linear system's response to white noise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["DockModes", "ModeBank", "expm", "fit_modes", "mode_matrices", "scalar_update"]

#: States per mode: displacement (m), rate (m/s), the driving acceleration (m/s^2).
MODE_STATES = 3


@dataclass(frozen=True)
class DockModes:
    """``K`` modes whose displacements sum to the dock's heave (module docstring).

    Attributes
    ----------
    omega_rad_s : ndarray (K,)
        Natural frequencies, rad/s.
    damping : ndarray (K,)
        Damping ratios (dimensionless, in (0, 1)).
    variance_m2 : ndarray (K,)
        Stationary variance of each mode's displacement, m^2.
    corner_ratio : float
        The driving acceleration's low-pass corner as a multiple of the mode's frequency.
    """

    omega_rad_s: np.ndarray
    damping: np.ndarray
    variance_m2: np.ndarray
    corner_ratio: float = 2.0

    @property
    def n_modes(self) -> int:
        """K."""
        return int(self.omega_rad_s.size)


def mode_matrices(omega: float, damping: float, corner_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """One mode's ``(A (3, 3), S (3, 3))``: ``x' = A x + e3 n`` for ``x = [p, v, a]`` with ``n`` white of unit
    intensity, and its stationary covariance ``S`` (``A S + S A^T + e3 e3^T = 0``), before scaling to a
    variance."""
    b = corner_ratio * omega
    A = np.array([[0.0, 1.0, 0.0], [-omega * omega, -2.0 * damping * omega, 1.0], [0.0, 0.0, -b]])
    n = MODE_STATES
    eye = np.eye(n)
    L = np.kron(eye, A) + np.kron(A, eye)
    rhs = np.zeros(n * n)
    rhs[n * n - 1] = -1.0  # e3 e3^T, column-major
    S = np.linalg.solve(L, rhs).reshape(n, n, order="F")
    return A, 0.5 * (S + S.T)


def expm(M: np.ndarray) -> np.ndarray:
    """The matrix exponential of a small square matrix (scaling and squaring of a degree-12 Taylor
    series; relative error near machine precision for the modes' 3 x 3 blocks at any horizon)."""
    norm = float(np.max(np.sum(np.abs(M), axis=1)))
    s = max(0, int(math.ceil(math.log2(norm / 0.25))) if norm > 0.25 else 0)
    X = M / (2.0**s)
    E = np.eye(M.shape[0])
    term = np.eye(M.shape[0])
    for k in range(1, 13):
        term = term @ X / k
        E = E + term
    for _ in range(s):
        E = E @ E
    return E


def fit_modes(
    omega: np.ndarray,
    spectrum: np.ndarray,
    n_modes: int,
    min_damping: float = 0.02,
    coverage: float = 0.99,
) -> DockModes | None:
    """``n_modes`` oscillators fitted to a one-sided spectrum (module docstring): ``omega`` (n,) rad/s
    ascending, ``spectrum`` (n,) m^2 s/rad.  None if the spectrum holds no variance.

    The band ``[w_a, w_b]`` that holds the central ``coverage`` of the variance is split into ``n_modes``
    bands of equal width in log frequency (equal relative bandwidth: each mode as narrow as the next, so
    that no one broad mode stands for the spectrum's tail with white acceleration it does not have); a
    band's variance, centroid and spread make its mode (bands with under 0.1 % of the variance are left
    silent), and the variance outside ``[w_a, w_b]`` joins the nearest band."""
    w = np.asarray(omega, dtype=float)
    s = np.clip(np.asarray(spectrum, dtype=float), 0.0, None)
    if w.ndim != 1 or w.shape != s.shape or w.size < 2:
        raise ValueError("omega and spectrum must be 1-D arrays of one length, at least 2")
    if n_modes < 1:
        raise ValueError(f"n_modes must be >= 1, got {n_modes}")
    dw = np.gradient(w)
    mass = s * dw
    total = float(mass.sum())
    if not total > 0.0 or not math.isfinite(total):
        return None
    cum = np.cumsum(mass) / total
    tail = 0.5 * (1.0 - coverage)
    w_a = float(w[min(int(np.searchsorted(cum, tail)), w.size - 1)])
    w_b = float(w[min(int(np.searchsorted(cum, 1.0 - tail)), w.size - 1)])
    resolution = float(np.median(dw))
    w_a = max(w_a, resolution)
    w_b = max(w_b, w_a + resolution)
    edges = np.exp(np.linspace(math.log(w_a), math.log(w_b), n_modes + 1))
    edges[0], edges[-1] = -np.inf, np.inf  # the tails join the outer bands
    band = np.clip(np.searchsorted(edges, w, side="right") - 1, 0, n_modes - 1)
    omegas, zetas, variances = [], [], []
    for k in range(n_modes):
        share = np.where(band == k, mass, 0.0)
        m0 = float(share.sum())
        if m0 <= 1e-3 * total:
            continue
        centre = float((share * w).sum() / m0)
        if not centre > 0.0:
            continue
        spread = math.sqrt(max(float((share * (w - centre) ** 2).sum() / m0), 0.0))
        # a band narrower than the estimate's resolution (a line): the resolution's width
        spread = max(spread, resolution / math.sqrt(12.0))
        omegas.append(centre)
        zetas.append(min(max(math.sqrt(3.0) * spread / centre, min_damping), 0.7))
        variances.append(m0)
    if not omegas:
        return None
    return DockModes(np.array(omegas), np.array(zetas), np.array(variances))


class ModeBank:
    """The dock's heave as ``K`` modes plus a motion unit's slow heave error, as linear Kalman-filter
    blocks: ``nm = 3K + 1`` states ``[p_1, v_1, a_1, ..., p_K, v_K, a_K, b]`` (m, m/s, m/s^2, m).

    Each mode is a damped oscillator driven by an acceleration that is itself white noise through a
    first-order low-pass at ``corner_ratio`` times the mode's frequency: a smooth motion (its spectrum
    falls as ``w^-6`` beyond the corner), whose next second a filter can forecast from its displacement,
    rate and acceleration.  (Driven by white acceleration, an oscillator fitted to a swell's spectrum
    puts 10 cm of unforecastable motion into 0.75 s: measured, ``benchmarks/dock_motion_forecast.py``.)
    ``b`` is the motion unit's slow heave error, a first-order Gauss-Markov process of standard
    deviation ``bias_std_m`` and correlation time ``bias_tau_s`` (zero std: no such error).  The process
    noise over a step is exact for a stationary process, ``Q(h) = S - Phi(h) S Phi(h)^T`` (``S`` the
    stationary covariance), so a filter started from ``S`` stays consistent whatever its steps.
    Transitions are cached per step length (a control loop uses a handful).

    Parameters
    ----------
    n_modes : int
        K.
    bias_std_m, bias_tau_s : float
        The motion unit's slow heave error.
    """

    def __init__(self, n_modes: int, bias_std_m: float = 0.0, bias_tau_s: float = 20.0) -> None:
        if n_modes < 1:
            raise ValueError(f"n_modes must be >= 1, got {n_modes}")
        self.n_modes = int(n_modes)
        self.nm = MODE_STATES * self.n_modes + 1
        self.bias_std_m = float(bias_std_m)
        self.bias_tau_s = float(bias_tau_s)
        self.modes: DockModes | None = None
        self._A = np.zeros((self.nm, self.nm))
        self._S = np.zeros((self.nm, self.nm))
        self._S[-1, -1] = self.bias_std_m**2
        self._cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        idx = np.arange(self.n_modes) * MODE_STATES
        #: Indices of the modes' displacements, rates and accelerations in the block.
        self.p_index, self.v_index, self.a_index = idx, idx + 1, idx + 2

    @property
    def ready(self) -> bool:
        """Whether the modes have been fitted (before that the heave is taken as zero, with no variance)."""
        return self.modes is not None

    def set_modes(self, modes: DockModes) -> None:
        """Use ``modes`` (from :func:`fit_modes`; fewer than K leave the rest silent)."""
        k = modes.n_modes
        if k > self.n_modes:
            raise ValueError(f"{k} modes for a bank of {self.n_modes}")
        A = np.zeros((self.nm, self.nm))
        S = np.zeros((self.nm, self.nm))
        n = MODE_STATES
        for i in range(self.n_modes):
            if i < k:
                Ai, Si = mode_matrices(
                    float(modes.omega_rad_s[i]), float(modes.damping[i]), modes.corner_ratio
                )
                scale = float(modes.variance_m2[i]) / float(Si[0, 0])
            else:  # silent: a damped mode of no variance
                Ai, Si, scale = mode_matrices(1.0, 0.5, modes.corner_ratio)[0], np.zeros((n, n)), 0.0
            A[n * i : n * i + n, n * i : n * i + n] = Ai
            S[n * i : n * i + n, n * i : n * i + n] = scale * Si
        A[-1, -1] = -1.0 / self.bias_tau_s if self.bias_tau_s > 0 else 0.0
        S[-1, -1] = self.bias_std_m**2
        self.modes, self._A, self._S = modes, A, S
        self._cache = {}

    def stationary_cov(self) -> np.ndarray:
        """(nm, nm): the modes' stationary covariance and the bias's variance (zeros before the fit)."""
        return self._S.copy()

    def _blocks(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        key = round(float(h), 9)
        hit = self._cache.get(key)
        if hit is None:
            F = np.zeros((self.nm, self.nm))
            n = MODE_STATES
            for i in range(self.n_modes):
                sl = slice(n * i, n * i + n)
                F[sl, sl] = expm(self._A[sl, sl] * key)
            F[-1, -1] = math.exp(self._A[-1, -1] * key)
            Q = self._S - F @ self._S @ F.T
            hit = (F, 0.5 * (Q + Q.T))
            if len(self._cache) > 4096:
                self._cache.clear()
            self._cache[key] = hit
        return hit

    def transition(self, h: float) -> np.ndarray:
        """Phi(h) (nm, nm): block diagonal, exact (negative ``h``: backwards)."""
        return self._blocks(h)[0]

    def process_cov(self, h: float) -> np.ndarray:
        """Q(h) (nm, nm) over a step ``h >= 0`` s: ``S - Phi S Phi^T``."""
        return self._blocks(h)[1]

    def heave_row(self, tau: float = 0.0, rate: bool = False) -> np.ndarray:
        """(nm,): the heave (or with ``rate`` its rate) ``tau`` s before the state's time as a linear function
        of the state (the bias enters the heave, not its rate; its change over ``tau`` is neglected)."""
        Phi = self.transition(-tau) if tau else None
        idx = self.v_index if rate else self.p_index
        row = np.zeros(self.nm)
        if Phi is None:
            row[idx] = 1.0
        else:
            row[:-1] = Phi[idx, :-1].sum(axis=0)
        if not rate:
            row[-1] = 1.0
        return row

    def lag_variance(self, tau: float, rate: bool = False) -> float:
        """The variance a reading ``tau`` s old adds by the sea's motion since (m^2 or m^2/s^2): the process
        noise over ``tau`` carried back, ``c Phi(-tau) Q(tau) Phi(-tau)^T c^T`` (``c`` picks the modes' heave
        or rate)."""
        if tau <= 0.0 or self.modes is None:
            return 0.0
        B = self.transition(-tau)
        M = B @ self.process_cov(tau) @ B.T
        idx = self.v_index if rate else self.p_index
        return float(max(M[np.ix_(idx, idx)].sum(), 0.0))

    def forecast(self, zm: np.ndarray, Pm: np.ndarray, ahead_s: np.ndarray) -> tuple[np.ndarray, ...]:
        """The heave (without the unit's bias), its rate and std (each (n,)) ``ahead_s`` (n,) s after the
        state's time, from the modes' mean ``zm`` (nm,) and covariance ``Pm`` (nm, nm)."""
        a = np.atleast_1d(np.asarray(ahead_s, dtype=float))
        h = np.empty(a.size)
        v = np.empty(a.size)
        s = np.empty(a.size)
        ip, iv = self.p_index, self.v_index
        for i, ti in enumerate(a):
            F, Q = self._blocks(float(ti))
            m = F @ zm
            P = F @ Pm @ F.T + (Q if ti > 0 else 0.0)
            h[i] = float(m[ip].sum())
            v[i] = float(m[iv].sum())
            s[i] = math.sqrt(max(float(P[np.ix_(ip, ip)].sum()), 0.0))
        return h, v, s


def scalar_update(z: np.ndarray, P: np.ndarray, row: np.ndarray, y: float, var: float) -> float:
    """One scalar Kalman update in place: the reading ``y`` of ``row @ z`` with noise variance ``var``
    (Joseph form); returns the normalised innovation squared (inf, and nothing changed, if the
    innovation's variance is not positive)."""
    Pr = P @ row
    s = float(row @ Pr) + var
    if not s > 0.0:
        return math.inf
    r = y - float(row @ z)
    k = Pr / s
    z += k * r
    # Joseph form for a scalar reading: (I - k c) P (I - k c)^T + k var k^T
    A = P - np.outer(k, Pr)
    P[:] = A - np.outer(A @ row, k) + var * np.outer(k, k)
    P[:] = 0.5 * (P + P.T)
    return r * r / s
