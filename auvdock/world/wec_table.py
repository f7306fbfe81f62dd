"""Linear heave hydrodynamics of the WEC dock's buoy: a frequency table and its heave RAO.

A :class:`HeaveCoefficients` holds what a boundary-element (BEM) solver computes for a floating
body heaving alone: the hydrostatic stiffness ``K33``, and per wave frequency the added mass
``A33``, the radiation damping ``B33`` and the complex wave-excitation force ``F_ex``.  From them
:meth:`HeaveCoefficients.rao` gives the buoy's heave per metre of wave amplitude, and
:meth:`HeaveCoefficients.natural_period_s` its heave natural period.  This module needs numpy
only; the tables are computed by :func:`auvdock.world.bem.compute_heave_table` (the optional
``bem`` extra, capytaine) and shipped in ``auvdock/world/data/`` (``wec_buoy_2m``: the default
dock's buoy), so nothing heavy is needed at run time.

Frames, units and conventions (those of capytaine 3):

- z is up, its origin on the undisturbed free surface, on the buoy's vertical axis; heave is the
  buoy's displacement along +z, in m (auvdock's NED "down" is minus this);
- SI units throughout: m, kg, s, N, rad/s;
- complex amplitudes are taken with ``exp(-i omega t)``: a quantity ``x(t) = Re[X exp(-i omega
  t)]``, so that a time derivative is a factor ``-i omega``;
- the incident wave's elevation at the origin is ``Re[a exp(-i omega t)]`` with ``a = 1 m``,
  real: ``excitation_N_m`` is the heave force per metre of wave amplitude in that phase, and
  the RAO the heave per metre of wave amplitude.

The table file is CSV with ``# key: value`` comment lines for the scalars (:data:`HEADER_KEYS`)
and one row per frequency (:data:`COLUMNS`); see :func:`load_heave_table`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Literal

import numpy as np

__all__ = [
    "HeaveCoefficients",
    "load_heave_table",
    "save_heave_table",
    "shipped_tables",
    "wavenumber",
    "DEFAULT_TABLE",
    "COLUMNS",
    "HEADER_KEYS",
]

_DATA = "auvdock.world"

#: The shipped table of the default dock's buoy (2 m diameter, 2 m draft, free floating).
DEFAULT_TABLE = "wec_buoy_2m"

#: The data columns of a table file, in this order.
COLUMNS = (
    "omega_rad_s",
    "added_mass_kg",
    "radiation_damping_N_s_m",
    "excitation_re_N_m",
    "excitation_im_N_m",
)

#: The ``# key: value`` header lines of a table file: required ones, then optional ones.
HEADER_KEYS = (
    "name",
    "radius_m",
    "draft_m",
    "mass_kg",
    "rho_kg_m3",
    "g_m_s2",
    "water_depth_m",
    "hydrostatic_stiffness_N_m",
    "source",
    "command",
)
_OPTIONAL_KEYS = ("note",)
_FLOAT_KEYS = ("radius_m", "draft_m", "mass_kg", "rho_kg_m3", "g_m_s2", "water_depth_m",
               "hydrostatic_stiffness_N_m")  # fmt: skip

Above = Literal["raise", "decay"]


def wavenumber(
    omega: float | np.ndarray, water_depth_m: float = math.inf, g_m_s2: float = 9.80665
) -> np.ndarray:
    """Wavenumber k (rad/m) of linear gravity waves of angular frequency ``omega`` (rad/s).

    The dispersion relation ``omega**2 = g k tanh(k h)``: ``k = omega**2 / g`` in deep water
    (``water_depth_m`` infinite), else solved by Newton's method (to 1e-12 relative).
    """
    w = np.asarray(omega, dtype=float)
    k_deep = w**2 / g_m_s2
    if math.isinf(water_depth_m):
        return k_deep
    h = water_depth_m
    # start from the larger of the deep-water and the shallow-water (omega / sqrt(g h)) values
    k = np.maximum(k_deep, w / math.sqrt(g_m_s2 * h))
    for _ in range(60):
        th = np.tanh(k * h)
        f = g_m_s2 * k * th - w**2
        df = g_m_s2 * (th + k * h * (1.0 - th**2))
        step = np.divide(f, df, out=np.zeros_like(k), where=df > 0)
        k = k - step
        if np.all(np.abs(step) <= 1e-12 * np.maximum(k, 1e-300)):
            break
    return k


@dataclass(frozen=True, kw_only=True, eq=False)
class HeaveCoefficients:
    """The linear heave hydrodynamics of an axisymmetric floating buoy, tabulated in frequency.

    Conventions: see the module's docstring (z up from the free surface, ``exp(-i omega t)``,
    a 1 m incident wave of real amplitude at the origin).

    Parameters
    ----------
    name : str
        What the table is of (e.g. ``wec_buoy_2m``).
    radius_m : float
        Radius of the buoy's waterline, m.
    draft_m : float
        Draft (depth of the bottom below the still water line), m.
    mass_kg : float, optional
        Mass of the buoy, kg.  Default: the displaced mass ``rho pi radius**2 draft`` of a
        vertical cylinder (free floating).  A table computed by capytaine records the mass it
        used (the displaced mass of its mesh, for a free-floating buoy).
    rho_kg_m3 : float, optional
        Water density, kg/m^3 (default 1025).
    g_m_s2 : float, optional
        Gravitational acceleration, m/s^2 (default 9.80665).
    water_depth_m : float, optional
        Water depth, m; ``math.inf`` (the default) for deep water.
    hydrostatic_stiffness_N_m : float
        Heave hydrostatic stiffness K33 = rho g (waterplane area), N/m.
    omega_rad_s : ndarray, shape (n,)
        Wave angular frequencies, rad/s, positive and strictly increasing.
    added_mass_kg : ndarray, shape (n,)
        Heave added mass A33 at each frequency, kg.
    radiation_damping_N_s_m : ndarray, shape (n,)
        Heave radiation damping B33 at each frequency, N s/m (>= 0 up to the solver's noise).
    excitation_N_m : ndarray of complex, shape (n,)
        Heave excitation force (Froude-Krylov plus diffraction) per metre of wave amplitude,
        N/m: the force is ``Re[F exp(-i omega t)]`` for the wave elevation ``Re[1 m exp(-i
        omega t)]`` at the origin.
    source : str, optional
        What computed the table (solver, version, mesh).
    command : str, optional
        The command that wrote the table file, to reproduce it.
    note : str, optional
        Free text kept with the table (e.g. why the water depth was taken infinite).

    Raises
    ------
    ValueError
        With one line naming the problem: a non-positive length, mass or stiffness; arrays of
        different lengths; frequencies not positive and strictly increasing; a non-finite value.
    """

    name: str
    radius_m: float
    draft_m: float
    mass_kg: float | None = None
    rho_kg_m3: float = 1025.0
    g_m_s2: float = 9.80665
    water_depth_m: float = math.inf
    hydrostatic_stiffness_N_m: float
    omega_rad_s: np.ndarray
    added_mass_kg: np.ndarray
    radiation_damping_N_s_m: np.ndarray
    excitation_N_m: np.ndarray
    source: str = ""
    command: str = ""
    note: str = field(default="")

    def __post_init__(self) -> None:
        for key in ("radius_m", "draft_m", "rho_kg_m3", "g_m_s2", "hydrostatic_stiffness_N_m"):
            _positive_finite(key, getattr(self, key))
        if self.mass_kg is None:
            displaced = self.rho_kg_m3 * math.pi * self.radius_m**2 * self.draft_m
            object.__setattr__(self, "mass_kg", displaced)
        _positive_finite("mass_kg", self.mass_kg)
        depth = float(self.water_depth_m)
        if not depth > 0 or math.isnan(depth):
            raise ValueError(f"water_depth_m: must be positive or inf (got {self.water_depth_m})")
        if depth <= self.draft_m:
            raise ValueError(f"water_depth_m: {depth:g} m is not below the draft of {self.draft_m:g} m")
        for key in ("radius_m", "draft_m", "rho_kg_m3", "g_m_s2", "hydrostatic_stiffness_N_m", "mass_kg"):
            object.__setattr__(self, key, float(getattr(self, key)))
        object.__setattr__(self, "water_depth_m", depth)
        arrays: dict[str, np.ndarray] = {}
        for key, dtype in (("omega_rad_s", float), ("added_mass_kg", float),
                           ("radiation_damping_N_s_m", float), ("excitation_N_m", complex)):  # fmt: skip
            a = np.array(getattr(self, key), dtype=dtype, copy=True)
            if a.ndim != 1:
                raise ValueError(f"{key}: expected a 1-D array (got shape {a.shape})")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{key}: not every value is finite")
            a.setflags(write=False)
            arrays[key] = a
            object.__setattr__(self, key, a)
        n = arrays["omega_rad_s"].size
        if n < 2:
            raise ValueError(f"omega_rad_s: need at least 2 frequencies (got {n})")
        for key, a in arrays.items():
            if a.size != n:
                raise ValueError(f"{key}: {a.size} values, omega_rad_s has {n}")
        w = arrays["omega_rad_s"]
        if not w[0] > 0:
            raise ValueError(f"omega_rad_s: the first frequency must be positive (got {w[0]:g})")
        bad = np.nonzero(np.diff(w) <= 0)[0]
        if bad.size:
            i = int(bad[0]) + 1
            raise ValueError(
                f"omega_rad_s: {w[i]:g} (entry {i + 1}) is not above the previous {w[i - 1]:g} "
                "(must be strictly increasing)"
            )

    @property
    def mass(self) -> float:
        """The buoy's mass, kg: ``mass_kg`` as given, or the displaced mass it defaults to."""
        assert self.mass_kg is not None  # set in __post_init__
        return self.mass_kg

    # --- the table's range ---------------------------------------------------------------
    @property
    def min_omega(self) -> float:
        """The table's lowest frequency, rad/s (below it: the long-wave limit, see :meth:`rao`)."""
        return float(self.omega_rad_s[0])

    @property
    def max_omega(self) -> float:
        """The table's highest frequency, rad/s: above it :meth:`rao` raises unless told to
        extrapolate (``above="decay"``).  Check a sea spectrum's components against it."""
        return float(self.omega_rad_s[-1])

    # --- interpolation ---------------------------------------------------------------------
    def coefficients(
        self, omega: float | np.ndarray, *, above: Above = "raise"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A33 (kg), B33 (N s/m) and F_ex (N/m, complex) at the frequencies ``omega`` (rad/s).

        Inside the table: linear interpolation in omega of A33, B33 and of the real and the
        imaginary parts of F_ex.  Real and imaginary parts rather than magnitude and phase: the
        phase is referred to the buoy's own axis, so it turns slowly with frequency (a chord
        between neighbouring points differs from the arc by far less than the BEM's own
        error), while at high frequency, where the magnitude of F_ex is a few newtons and
        passes close to zero, the phase jumps and an unwrapped-phase interpolation would be
        arbitrary; the real and imaginary parts stay smooth there.

        Below the table's lowest frequency ``w0``, the long-wave limit joined continuously to
        the first row: with ``s = (omega / w0)**2``, ``F_ex = K33 + s (F_ex(w0) - K33)``,
        ``B33 = s B33(w0)``, ``A33 = A33(w0)``.  As omega -> 0 the excitation tends to the
        hydrostatic force ``K33`` of a 1 m wave amplitude (in phase), the damping to 0; ``s`` follows
        the leading-order deep-water behaviour of F_ex - K33, proportional to ``k = omega**2 / g``.

        Above the table's highest frequency ``w1``: ``above="raise"`` (the default) raises;
        ``above="decay"`` extrapolates with the exponential decay of the wave's pressure at the
        buoy's bottom: ``F_ex = F_ex(w1) exp(-(k - k1) draft)``, ``B33 = B33(w1) exp(-2 (k -
        k1) draft)`` (Haskind: B33 grows as the square of F_ex), ``A33 = A33(w1)``, k the
        wavenumber at omega and k1 at w1.

        Parameters
        ----------
        omega : float or array_like
            Angular frequencies, rad/s, finite and >= 0.
        above : {"raise", "decay"}, optional
            What to do above :attr:`max_omega`.

        Returns
        -------
        added_mass : ndarray
            A33, kg, the shape of ``omega``.
        damping : ndarray
            B33, N s/m.
        excitation : ndarray of complex
            F_ex, N per m of wave amplitude.

        Raises
        ------
        ValueError
            A frequency is negative or not finite, or above :attr:`max_omega` with
            ``above="raise"`` (naming it and the table's range).
        """
        if above not in ("raise", "decay"):
            raise ValueError(f"above: must be 'raise' or 'decay' (got {above!r})")
        w = np.asarray(omega, dtype=float)
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            bad = w[~(np.isfinite(w) & (w >= 0))].ravel()[0]
            raise ValueError(f"omega: must be finite and >= 0 (got {bad:g} rad/s)")
        shape = w.shape
        w = w.reshape(-1)
        w0, w1 = self.min_omega, self.max_omega
        if above == "raise" and np.any(w > w1):
            top = float(np.max(w))
            raise ValueError(
                f"omega {top:g} rad/s is above the range of the heave table {self.name!r} "
                f"({w0:g} to {w1:g} rad/s; check against .max_omega, or pass above='decay')"
            )
        tab_w = self.omega_rad_s
        a = np.interp(w, tab_w, self.added_mass_kg)
        b = np.interp(w, tab_w, self.radiation_damping_N_s_m)
        f = np.interp(w, tab_w, self.excitation_N_m.real) + 1j * np.interp(w, tab_w, self.excitation_N_m.imag)
        low = w < w0
        if np.any(low):
            s = (w[low] / w0) ** 2
            k33 = self.hydrostatic_stiffness_N_m
            f[low] = k33 + s * (self.excitation_N_m[0] - k33)
            b[low] = s * self.radiation_damping_N_s_m[0]
            a[low] = self.added_mass_kg[0]
        high = w > w1
        if np.any(high):
            k = wavenumber(w[high], self.water_depth_m, self.g_m_s2)
            k1 = float(wavenumber(w1, self.water_depth_m, self.g_m_s2))
            decay = np.exp(-(k - k1) * self.draft_m)
            f[high] = self.excitation_N_m[-1] * decay
            b[high] = self.radiation_damping_N_s_m[-1] * decay**2
            a[high] = self.added_mass_kg[-1]
        return a.reshape(shape), b.reshape(shape), f.reshape(shape)

    # --- response --------------------------------------------------------------------------
    def rao(
        self,
        omega: float | np.ndarray,
        *,
        pto_damping_N_s_m: float = 0.0,
        viscous_damping_N_s_m: float = 0.0,
        mooring_stiffness_N_m: float = 0.0,
        above: Above = "raise",
    ) -> np.ndarray:
        """Complex heave RAO: metres of heave (up) per metre of wave amplitude.

        The heave equation ``(m + A33) z'' + (B33 + B_visc + B_pto) z' + (K33 + K_moor) z =
        F_ex(t)``, with ``z(t) = Re[Z exp(-i omega t)]`` (so ``z' -> -i omega Z``, ``z'' ->
        -omega**2 Z``), gives

        ``RAO = Z / a = F_ex / (-omega**2 (m + A33) - i omega (B33 + B_visc + B_pto) + K33 +
        K_moor)``.

        Its phase is the heave's lag behind the wave elevation at the buoy's axis: ``z(t) =
        |RAO| a cos(omega t - phase)`` for the elevation ``a cos(omega t)``, so a positive phase
        means the heave peaks ``phase / omega`` after the crest (about pi above resonance: the
        buoy moves against the wave).  As omega -> 0 the buoy follows the water surface: RAO ->
        K33 / (K33 + K_moor), 1 for a free-floating buoy.  How A33, B33 and F_ex are
        interpolated, and the long-wave limit below the table: :meth:`coefficients`.

        Parameters
        ----------
        omega : float or array_like
            Angular frequencies, rad/s, finite and >= 0.
        pto_damping_N_s_m : float, optional
            Linear power take-off damping, N s/m (default 0).
        viscous_damping_N_s_m : float, optional
            Linearised viscous damping, N s/m (default 0: potential flow only).
        mooring_stiffness_N_m : float, optional
            Heave stiffness of the mooring, N/m (default 0).
        above : {"raise", "decay"}, optional
            Above :attr:`max_omega`: raise ValueError (default) or extrapolate
            (:meth:`coefficients`).

        Returns
        -------
        ndarray of complex
            The RAO, m/m, of the shape of ``omega`` (a 0-d array for a scalar).

        Raises
        ------
        ValueError
            A negative damping or stiffness, or a frequency as :meth:`coefficients` refuses.
        """
        checked = {"pto_damping_N_s_m": pto_damping_N_s_m, "viscous_damping_N_s_m": viscous_damping_N_s_m,
                   "mooring_stiffness_N_m": mooring_stiffness_N_m}  # fmt: skip
        for key, v in checked.items():
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{key}: must be finite and >= 0 (got {v})")
        w = np.asarray(omega, dtype=float)
        a33, b33, f = self.coefficients(w, above=above)
        mass = self.mass
        impedance = (
            -(w**2) * (mass + a33)
            - 1j * w * (b33 + viscous_damping_N_s_m + pto_damping_N_s_m)
            + self.hydrostatic_stiffness_N_m
            + mooring_stiffness_N_m
        )
        return f / impedance

    def natural_frequency_rad_s(self, *, mooring_stiffness_N_m: float = 0.0) -> float:
        """Undamped heave natural frequency, rad/s: ``omega_n = sqrt((K33 + K_moor) / (m +
        A33(omega_n)))``, solved as a fixed point with the interpolated added mass (A33 held at
        its first or last entry outside the table)."""
        k = self.hydrostatic_stiffness_N_m + mooring_stiffness_N_m
        mass = self.mass
        tab_w, tab_a = self.omega_rad_s, self.added_mass_kg
        w = math.sqrt(k / (mass + float(tab_a[0])))
        for _ in range(200):
            w_next = math.sqrt(k / (mass + float(np.interp(w, tab_w, tab_a))))
            if abs(w_next - w) <= 1e-12 * w:
                return w_next
            w = w_next
        raise ValueError(f"heave table {self.name!r}: no natural frequency found")  # pragma: no cover

    def natural_period_s(self, *, mooring_stiffness_N_m: float = 0.0) -> float:
        """Undamped heave natural period, s: ``2 pi sqrt((m + A33(omega_n)) / (K33 + K_moor))``
        with the added mass at the natural frequency itself (:meth:`natural_frequency_rad_s`)."""
        return 2.0 * math.pi / self.natural_frequency_rad_s(mooring_stiffness_N_m=mooring_stiffness_N_m)


def _positive_finite(key: str, value: object) -> None:
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{key}: not a number ({value!r})") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{key}: must be positive and finite (got {value})")


# --- files -------------------------------------------------------------------------------------
def shipped_tables() -> list[str]:
    """Names of the heave tables shipped with auvdock (``auvdock/world/data/*.csv``)."""
    files = resources.files(_DATA).joinpath("data").iterdir()
    return sorted(p.name[:-4] for p in files if p.name.endswith(".csv"))


def _resolve(path_or_name: str | Path) -> tuple[str, str]:
    """(the name to report, the text) of a table file, or of a shipped table by name."""
    p = Path(path_or_name)
    if p.is_file():
        try:
            return str(p), p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise ValueError(f"{p}: cannot read ({getattr(e, 'strerror', None) or e})") from None
    s = str(path_or_name)
    if s in shipped_tables():
        res = resources.files(_DATA).joinpath("data", f"{s}.csv")
        return str(res), res.read_text(encoding="utf-8")
    if p.exists():
        raise ValueError(f"{p}: not a file")
    shipped = ", ".join(shipped_tables()) or "none"
    raise ValueError(f"{p}: no such file (nor a shipped heave table of that name; shipped: {shipped})")


def load_heave_table(path_or_name: str | Path) -> HeaveCoefficients:
    """Read a heave table file, or a shipped table by name (``wec_buoy_2m``; a file wins).

    The format (UTF-8 text): ``# key: value`` lines for the scalars -- every key of
    :data:`HEADER_KEYS` (``water_depth_m`` may be ``inf``), and optionally ``note`` -- then the
    header row ``omega_rad_s,added_mass_kg,radiation_damping_N_s_m,excitation_re_N_m,
    excitation_im_N_m`` (:data:`COLUMNS`, in any order; other columns are ignored) and one row
    of numbers per frequency, omega strictly increasing.  Blank lines, and ``#`` lines without
    a colon, are ignored.  Units and conventions: :class:`HeaveCoefficients`.

    Parameters
    ----------
    path_or_name : str or Path
        A table file, or the name of a shipped one (:func:`shipped_tables`).

    Returns
    -------
    HeaveCoefficients

    Raises
    ------
    ValueError
        One line, ``FILE: problem``: no such file, a missing or repeated header key, a header
        value that is not a number, a missing column, a row of the wrong length, a value that
        is not a finite number (naming its line and column), omega not strictly increasing.
    """
    where, text = _resolve(path_or_name)
    header: dict[str, str] = {}
    columns: list[str] | None = None
    rows: list[tuple[int, list[float]]] = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            key, sep, value = line[1:].partition(":")
            key = key.strip()
            if not sep or not key or " " in key:
                continue  # free text
            if key in header:
                raise ValueError(f"{where}: line {lineno}: header key {key!r} given twice")
            header[key] = value.strip()
            continue
        cells = [c.strip() for c in line.split(",")]
        if columns is None:
            columns = cells
            missing = [c for c in COLUMNS if c not in columns]
            if missing:
                raise ValueError(
                    f"{where}: line {lineno}: missing column {missing[0]!r} (the header row needs "
                    f"{','.join(COLUMNS)})"
                )
            continue
        if len(cells) != len(columns):
            problem = f"{len(cells)} values, the header row has {len(columns)}"
            raise ValueError(f"{where}: line {lineno}: {problem}")
        values: list[float] = []
        for col, cell in zip(columns, cells, strict=True):
            if col not in COLUMNS:
                continue
            try:
                v = float(cell)
            except ValueError:
                raise ValueError(f"{where}: line {lineno}: {col}: not a number ({cell!r})") from None
            if not math.isfinite(v):
                raise ValueError(f"{where}: line {lineno}: {col}: not a finite number ({cell})")
            values.append(v)
        rows.append((lineno, values))
    for key in HEADER_KEYS:
        if key not in header:
            raise ValueError(f"{where}: missing header line '# {key}: ...'")
    if columns is None or not rows:
        raise ValueError(
            f"{where}: no data rows (the header row {','.join(COLUMNS)}, then one per frequency)"
        )
    scalars: dict[str, float] = {}
    for key in _FLOAT_KEYS:
        try:
            scalars[key] = float(header[key])
        except ValueError:
            raise ValueError(f"{where}: header {key}: not a number ({header[key]!r})") from None
    kept = [c for c in columns if c in COLUMNS]
    data = {c: np.array([r[kept.index(c)] for _, r in rows]) for c in COLUMNS}
    w = data["omega_rad_s"]
    for i in range(1, len(rows)):
        if not w[i] > w[i - 1]:
            raise ValueError(
                f"{where}: line {rows[i][0]}: omega_rad_s {w[i]:g} is not above the previous row's "
                f"{w[i - 1]:g} (omega must be strictly increasing)"
            )
    try:
        return HeaveCoefficients(
            name=header["name"],
            radius_m=scalars["radius_m"],
            draft_m=scalars["draft_m"],
            mass_kg=scalars["mass_kg"],
            rho_kg_m3=scalars["rho_kg_m3"],
            g_m_s2=scalars["g_m_s2"],
            water_depth_m=scalars["water_depth_m"],
            hydrostatic_stiffness_N_m=scalars["hydrostatic_stiffness_N_m"],
            omega_rad_s=w,
            added_mass_kg=data["added_mass_kg"],
            radiation_damping_N_s_m=data["radiation_damping_N_s_m"],
            excitation_N_m=data["excitation_re_N_m"] + 1j * data["excitation_im_N_m"],
            source=header["source"],
            command=header["command"],
            note=header.get("note", ""),
        )
    except ValueError as e:
        raise ValueError(f"{where}: {e}") from None


def _num(x: float) -> str:
    """A number as the shortest text that reads back to the same float (``inf`` for infinity)."""
    return repr(float(x))


def save_heave_table(coefficients: HeaveCoefficients, path: str | Path) -> Path:
    """Write ``coefficients`` as a table file (the format of :func:`load_heave_table`).

    Numbers are written in full (they read back to the same floats), one row per frequency.

    Parameters
    ----------
    coefficients : HeaveCoefficients
        The table.
    path : str or Path
        The file to write (its folder must exist).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ValueError
        A text field (name, source, command, note) spans several lines.
    """
    c = coefficients
    text_fields = {"name": c.name, "source": c.source, "command": c.command, "note": c.note}
    for key, value in text_fields.items():
        if "\n" in value or "\r" in value:
            raise ValueError(f"{key}: must be one line")
    lines = [
        "# auvdock heave table - linear heave hydrodynamics of a floating buoy (auvdock.world.wec_table)",
        "# z up from the still water line on the buoy's axis; complex amplitudes with exp(-i omega t);",
        "# excitation per metre of incident-wave amplitude, the wave elevation at the axis being",
        "# Re[1 m exp(-i omega t)]",
        f"# name: {c.name}",
        f"# radius_m: {_num(c.radius_m)}",
        f"# draft_m: {_num(c.draft_m)}",
        f"# mass_kg: {_num(c.mass)}",
        f"# rho_kg_m3: {_num(c.rho_kg_m3)}",
        f"# g_m_s2: {_num(c.g_m_s2)}",
        f"# water_depth_m: {_num(c.water_depth_m)}",
        f"# hydrostatic_stiffness_N_m: {_num(c.hydrostatic_stiffness_N_m)}",
        f"# source: {c.source}",
        f"# command: {c.command}",
    ]
    if c.note:
        lines.append(f"# note: {c.note}")
    lines.append(",".join(COLUMNS))
    rows = zip(c.omega_rad_s, c.added_mass_kg, c.radiation_damping_N_s_m, c.excitation_N_m, strict=True)
    for w, a, b, f in rows:
        lines.append(",".join(_num(x) for x in (w, a, b, f.real, f.imag)))
    p = Path(path)
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p
