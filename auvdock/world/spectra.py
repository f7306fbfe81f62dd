"""Sea spectra and their realisation as wave components.

* :func:`jonswap` -- the JONSWAP spectrum in the IEC TS 62600-2 form (as mhkit's
  ``jonswap_spectrum``), normalised so that ``4 sqrt(m0)`` is Hs::

      S(w) = (1 - 0.287 ln gamma) (5/16) Hs^2 wp^4 w^-5 exp(-1.25 (wp/w)^4) gamma^r,
      r = exp(-(w - wp)^2 / (2 s^2 wp^2)),  s = 0.07 (w <= wp), 0.09 (w > wp)

  (m^2 s/rad; ``wp = 2 pi / Tp``);
* :func:`spreading_weights` -- the cos-2s directional spreading
  ``D(b) = G(s+1) / (2 sqrt(pi) G(s+1/2)) cos^{2s}((b - b0)/2)`` with ``s = 2 / sigma^2 - 1`` for a
  spread (circular standard deviation) ``sigma``: 30 degrees gives s = 6.3;
* :func:`load_spectrum` -- a measured or modelled spectrum from a CSV file;
* :func:`realise` -- the random-phase realisation: frequency bins of width ``dw`` with one
  frequency drawn uniformly inside each bin (so that the record does not repeat every
  ``2 pi / dw``), directions j, amplitudes ``a_ij = sqrt(2 S(w_i) D(b_j) dw db)`` and phases uniform in
  [0, 2 pi), all from one seeded generator.

References
----------
IEC TS 62600-2:2019, Marine energy -- Design requirements for marine energy systems, annex;
K. Hasselmann et al. (1973), the JONSWAP report; Y. Goda, *Random Seas and Design of Maritime
Structures* (2000), ch. 2 (the cos-2s spreading); T. I. Fossen, *Handbook of Marine Craft
Hydrodynamics and Motion Control*, 2nd ed. (2021), ch. 10 (the realisation, the MSS
toolbox's ``waveDirectionalSpectrum``).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from auvdock.world.waves import GRAVITY_M_S2, WaveComponents

__all__ = [
    "jonswap",
    "spreading_exponent",
    "spreading_weights",
    "Spectrum",
    "load_spectrum",
    "realise",
    "regular_wave",
    "SpectrumFileError",
]


def jonswap(omega_rad_s: np.ndarray, hs_m: float, tp_s: float, gamma: float = 3.3) -> np.ndarray:
    """The JONSWAP spectral density S(w) (m^2 s/rad) at angular frequencies ``omega_rad_s`` (rad/s).

    Parameters
    ----------
    omega_rad_s : ndarray (n,)
        Angular frequencies, rad/s (> 0).
    hs_m : float
        Significant wave height Hs, m.
    tp_s : float
        Peak period Tp, s.
    gamma : float
        Peak enhancement factor (1: Pierson-Moskowitz; 3.3: the North Sea mean).
    """
    w = np.asarray(omega_rad_s, dtype=float)
    wp = 2.0 * math.pi / tp_s
    sig = np.where(w <= wp, 0.07, 0.09)
    r = np.exp(-((w - wp) ** 2) / (2.0 * sig**2 * wp**2))
    norm = 1.0 - 0.287 * math.log(gamma)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        S = norm * (5.0 / 16.0) * hs_m**2 * wp**4 * w**-5 * np.exp(-1.25 * (wp / w) ** 4) * gamma**r
    return np.where(w > 0, S, 0.0)


def spreading_exponent(spread_deg: float) -> float:
    """The cos-2s exponent s of a directional spread (circular standard deviation, degrees)."""
    sig = math.radians(spread_deg)
    return 2.0 / sig**2 - 1.0


def spreading_weights(
    n_directions: int, spread_deg: float, mean_direction_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """Directions b_j (rad) and weights ``D(b_j) db`` (summing to 1) of a cos-2s spreading.

    ``n_directions`` equal bins over ``b0 +- min(180, 3 spread)`` degrees; one direction
    (``n_directions = 1`` or ``spread_deg = 0``) is a long-crested sea at ``b0``.
    """
    if n_directions <= 1 or spread_deg <= 0:
        return np.array([mean_direction_rad]), np.array([1.0])
    s = spreading_exponent(spread_deg)
    half = min(math.pi, 3.0 * math.radians(spread_deg))
    db = 2.0 * half / n_directions
    rel = -half + db * (np.arange(n_directions) + 0.5)
    D = (
        math.exp(math.lgamma(s + 1.0) - math.lgamma(s + 0.5))
        / (2.0 * math.sqrt(math.pi))
        * np.cos(rel / 2.0) ** (2 * s)
    )
    weights = D * db
    return mean_direction_rad + rel, weights / weights.sum()


class SpectrumFileError(ValueError):
    """A spectrum file that cannot be used (the message names the file and the problem)."""


class Spectrum:
    """A spectral density given as a table, interpolated linearly (zero outside the table).

    Parameters
    ----------
    omega_rad_s : ndarray (n,)
        Strictly increasing angular frequencies, rad/s.
    density_m2_s_rad : ndarray (n,)
        S(w) >= 0, m^2 s/rad.
    label : str
        Where it came from.
    """

    def __init__(
        self, omega_rad_s: np.ndarray, density_m2_s_rad: np.ndarray, label: str = "spectrum"
    ) -> None:
        self.omega_rad_s = np.asarray(omega_rad_s, dtype=float)
        self.density_m2_s_rad = np.asarray(density_m2_s_rad, dtype=float)
        self.label = label

    def __call__(self, omega_rad_s: np.ndarray) -> np.ndarray:
        return np.interp(omega_rad_s, self.omega_rad_s, self.density_m2_s_rad, left=0.0, right=0.0)

    @property
    def hm0_m(self) -> float:
        """``4 sqrt(m0)`` of the table (trapezoidal m0), m."""
        return 4.0 * math.sqrt(float(np.trapezoid(self.density_m2_s_rad, self.omega_rad_s)))

    @property
    def peak_period_s(self) -> float:
        """The period of the table's largest density, s."""
        return 2.0 * math.pi / float(self.omega_rad_s[int(np.argmax(self.density_m2_s_rad))])


def load_spectrum(path: str | Path) -> Spectrum:
    """A spectrum from a CSV file with a header row.

    Columns ``omega_rad_s, S_m2_s_rad`` (angular frequency and density per rad/s), or
    ``frequency_hz, S_m2_hz`` (frequency and density per Hz, converted with
    ``S(w) = S(f) / 2 pi``); lines starting with ``#`` are comments.

    Raises
    ------
    SpectrumFileError
        One line naming the file and the problem (no such file, wrong columns, a value that is
        not a number, frequencies not increasing, a negative density, fewer than 3 rows).
    """
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as exc:
        raise SpectrumFileError(f"{p}: cannot read the spectrum file ({exc.strerror or exc})") from None
    rows = [
        r
        for r in csv.reader(
            line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")
        )
    ]
    if not rows:
        raise SpectrumFileError(f"{p}: empty spectrum file")
    header = [h.strip() for h in rows[0]]
    kinds = {("omega_rad_s", "S_m2_s_rad"): 1.0, ("frequency_hz", "S_m2_hz"): 2.0 * math.pi}
    key = tuple(header)
    if key not in kinds:
        raise SpectrumFileError(
            f"{p}: columns {', '.join(header) or '(none)'}; "
            "expected omega_rad_s,S_m2_s_rad or frequency_hz,S_m2_hz"
        )
    try:
        data = np.array([[float(v) for v in r] for r in rows[1:]], dtype=float)
    except ValueError as exc:
        raise SpectrumFileError(f"{p}: a value is not a number ({exc})") from None
    if data.ndim != 2 or data.shape[0] < 3 or data.shape[1] != 2:
        raise SpectrumFileError(
            f"{p}: need at least 3 rows of 2 numbers, got {data.shape[0] if data.ndim == 2 else 0}"
        )
    if not np.all(np.isfinite(data)):
        raise SpectrumFileError(f"{p}: values must be finite")
    x = data[:, 0] * (kinds[key] if key[0] == "frequency_hz" else 1.0)
    S = data[:, 1] / (kinds[key] if key[0] == "frequency_hz" else 1.0)
    if np.any(x <= 0) or np.any(np.diff(x) <= 0):
        raise SpectrumFileError(f"{p}: {header[0]} must be positive and strictly increasing")
    if np.any(S < 0):
        raise SpectrumFileError(f"{p}: {header[1]} must be >= 0")
    return Spectrum(x, S, label=f"spectrum {p.name}")


def realise(
    density: Callable[[np.ndarray], np.ndarray],
    omega_min_rad_s: float,
    omega_max_rad_s: float,
    n_frequencies: int,
    rng: np.random.Generator,
    *,
    mean_direction_rad: float = 0.0,
    spread_deg: float = 0.0,
    n_directions: int = 1,
    water_depth_m: float = math.inf,
    current_ned_m_s: tuple[float, float] = (0.0, 0.0),
    label: str = "sea",
    g: float = GRAVITY_M_S2,
) -> WaveComponents:
    """A random-phase realisation of a (directional) spectrum (see the module docstring).

    The density ``density(w)`` (m^2 s/rad) is sampled at a frequency drawn uniformly inside
    each of ``n_frequencies`` equal bins of [omega_min, omega_max] (rad/s); each frequency gets
    ``n_directions`` directions (:func:`spreading_weights`); components of zero amplitude are
    dropped.  The draws (frequency jitter, then phases) come from ``rng`` in a fixed order, so
    a seed gives one sea.
    """
    if not 0 < omega_min_rad_s < omega_max_rad_s:
        raise ValueError("need 0 < omega_min_rad_s < omega_max_rad_s")
    dw = (omega_max_rad_s - omega_min_rad_s) / n_frequencies
    w = omega_min_rad_s + dw * (np.arange(n_frequencies) + rng.uniform(0.0, 1.0, n_frequencies))
    S = np.asarray(density(w), dtype=float)
    dirs, weights = spreading_weights(n_directions, spread_deg, mean_direction_rad)
    a = np.sqrt(2.0 * np.outer(S * dw, weights)).ravel()
    ww = np.repeat(w, dirs.size)
    bb = np.tile(dirs, w.size)
    phases = rng.uniform(0.0, 2.0 * math.pi, a.size)
    keep = a > 0
    return WaveComponents(
        amplitude_m=a[keep],
        omega_rad_s=ww[keep],
        direction_rad=bb[keep],
        phase_rad=phases[keep],
        water_depth_m=water_depth_m,
        current_ned_m_s=current_ned_m_s,
        g=g,
        label=label,
    )


def regular_wave(
    height_m: float,
    period_s: float,
    *,
    direction_rad: float = 0.0,
    phase_rad: float = 0.0,
    water_depth_m: float = math.inf,
    current_ned_m_s: tuple[float, float] = (0.0, 0.0),
    label: str | None = None,
    g: float = GRAVITY_M_S2,
) -> WaveComponents:
    """One component: a regular wave of height H = 2a (m) and fixed-point period T (s)."""
    return WaveComponents(
        amplitude_m=np.array([height_m / 2.0]),
        omega_rad_s=np.array([2.0 * math.pi / period_s]),
        direction_rad=np.array([direction_rad]),
        phase_rad=np.array([phase_rad]),
        water_depth_m=water_depth_m,
        current_ned_m_s=current_ned_m_s,
        g=g,
        label=label or f"regular wave H {height_m:g} m, T {period_s:g} s",
    )
