"""Linear (Airy) waves: dispersion with a current, and the kinematics of a realised sea.

A realised sea is a finite sum of wave components (:class:`WaveComponents`), each with an
amplitude ``a`` (m), an angular frequency ``w`` seen at a fixed point (rad/s), a wavenumber ``k``
(rad/m), a direction of travel ``b`` (rad, clockwise from north: the direction the crests move
*to*) and a phase ``phi`` (rad).  Its elevation above the mean water level is::

    eta(n, e, t) = sum_i a_i cos(th_i),   th_i = k_i (n cos b_i + e sin b_i) - w_i t + phi_i

and the water's orbital velocity at NED depth ``d`` (m, down; the mean surface is d = 0, the
bottom d = h), relative to a uniform current ``U``::

    u_h  =  a s Fc(d) cos th      (along the direction of travel)
    w_up =  a s Fs(d) sin th      (upward; the NED down component is -w_up)
    Fc = cosh k(h - d) / sinh kh,  Fs = sinh k(h - d) / sinh kh   (both e^{-k d} in deep water)

with the intrinsic frequency ``s = w - k U cos(b - b_U)`` (the frequency in the frame moving with
the current) and ``k`` solving the Doppler-shifted dispersion relation
``(w - k U_b)^2 = g k tanh kh`` (:func:`wavenumber`).  ``U = 0`` is plain Airy theory,
``w^2 = g k tanh kh``.  Above the mean surface (``d < 0``, inside a crest) the kinematics are
those at ``d = 0`` (constant extrapolation; linear theory says nothing there).

Evaluation: :meth:`WaveComponents.kinematics` is vectorised numpy (the truth: hundreds of
components at many points at once); :meth:`WaveComponents.symbolic_velocity` is the same
formula in CasADi, for a prediction model whose definition includes the sea.

References
----------
T. Sarpkaya and M. Isaacson, *Mechanics of Wave Forces on Offshore Structures* (1981), ch. 4;
R. G. Dean and R. A. Dalrymple, *Water Wave Mechanics for Engineers and Scientists* (1991),
ch. 3-4; I. G. Jonsson, "Wave-current interactions", in *The Sea*, vol. 9A (1990) -- the
Doppler-shifted dispersion relation; capytaine's ``bem/airy_waves.py`` (the same formulas).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from auvdock.vehicle.constants import GRAVITY_M_S2

__all__ = [
    "GRAVITY_M_S2",
    "WaveComponents",
    "WaveKinematics",
    "wavenumber",
    "dispersion_residual",
    "group_speed",
]


def _tanh_kh(k: np.ndarray, depth_m: float) -> np.ndarray:
    return np.ones_like(k) if math.isinf(depth_m) else np.tanh(k * depth_m)


def wavenumber(
    omega_rad_s: np.ndarray | float,
    depth_m: float = math.inf,
    current_along_m_s: np.ndarray | float = 0.0,
    g: float = GRAVITY_M_S2,
) -> np.ndarray:
    """Wavenumber k (rad/m) of waves of fixed-point angular frequency ``omega`` in a current.

    Solves ``(w - k U)^2 = g k tanh(k h)`` for the root with a positive intrinsic frequency
    ``s = w - k U`` (the root continuous with ``U = 0``), by Newton's method on
    ``sqrt(g k tanh kh) + k U - w`` started left of the root (the function is concave and
    increasing there, so the iterates rise monotonically to it), polished to a relative step
    below 1e-15.

    Parameters
    ----------
    omega_rad_s : float or ndarray (n,)
        Angular frequency seen at a point fixed on the ground, rad/s (> 0).
    depth_m : float
        Water depth h, m (``math.inf``: deep water).
    current_along_m_s : float or ndarray (n,)
        The current's component along each wave's direction of travel, m/s (positive:
        a following current, which lengthens the waves).
    g : float
        Gravity, m/s^2.

    Returns
    -------
    ndarray (n,)
        k in rad/m.

    Raises
    ------
    ValueError
        For a non-positive frequency, or a component blocked by an opposing current
        (no root with ``s > 0``: about ``U < -g / (4 w)`` in deep water).
    """
    w = np.atleast_1d(np.asarray(omega_rad_s, dtype=float))
    U = np.broadcast_to(np.asarray(current_along_m_s, dtype=float), w.shape).astype(float)
    if np.any(~(w > 0)):
        raise ValueError("wave frequencies must be positive")
    h = float(depth_m)
    k = 0.01 * w * w / g if math.isinf(h) else np.minimum(0.01 * w * w / g, 0.01 * w / math.sqrt(g * h))
    for _ in range(200):
        th = _tanh_kh(k, h)
        s = np.sqrt(g * k * th)
        sech2 = np.zeros_like(k) if math.isinf(h) else 1.0 / np.cosh(np.minimum(k * h, 350.0)) ** 2
        ds = g * (th + (0.0 if math.isinf(h) else k * h * sech2)) / (2.0 * s)
        F = s + k * U - w
        dF = ds + U
        if np.any(dF <= 0):  # past the maximum of F with F still < 0: no root (blocking)
            bad = int(np.flatnonzero(dF <= 0)[0])
            raise ValueError(
                f"a wave of period {2 * math.pi / w[bad]:.3g} s is blocked by the opposing current "
                f"{U[bad]:.3g} m/s (no wave can travel against it)"
            )
        step = F / dF
        k = k - step
        if np.all(np.abs(step) <= 1e-15 * k):
            break
    if np.any(~np.isfinite(k)) or np.any(k <= 0) or np.any(w - k * U <= 0):
        raise ValueError("dispersion relation: no wave with a positive intrinsic frequency")
    return k


def dispersion_residual(
    k: np.ndarray,
    omega_rad_s: np.ndarray,
    depth_m: float,
    current_along_m_s: Any = 0.0,
    g: float = GRAVITY_M_S2,
) -> np.ndarray:
    """Relative residual ``((w - k U)^2 - g k tanh kh) / w^2`` of the dispersion relation (n,)."""
    k = np.asarray(k, dtype=float)
    w = np.asarray(omega_rad_s, dtype=float)
    U = np.asarray(current_along_m_s, dtype=float)
    return ((w - k * U) ** 2 - g * k * _tanh_kh(k, depth_m)) / w**2


def group_speed(k: np.ndarray, depth_m: float = math.inf, g: float = GRAVITY_M_S2) -> np.ndarray:
    """Group speed relative to the water ``c_g = (s / 2k)(1 + 2kh / sinh 2kh)`` (m/s) of wavenumbers k."""
    k = np.asarray(k, dtype=float)
    s = np.sqrt(g * k * _tanh_kh(k, depth_m))
    if math.isinf(depth_m):
        return s / (2.0 * k)
    x = np.minimum(2.0 * k * depth_m, 700.0)
    return s / (2.0 * k) * (1.0 + x / np.sinh(x))


@dataclass(frozen=True)
class WaveKinematics:
    """The water's wave motion at a set of points (shapes ``(..., 3)`` / ``(..., 3, 3)``, NED).

    Attributes
    ----------
    velocity_ned_m_s : ndarray (..., 3)
        Orbital velocity (north, east, down), m/s (the current not included).
    acceleration_ned_m_s2 : ndarray (..., 3)
        Local acceleration ``du/dt`` at the fixed points, m/s^2.
    gradient_ned_1_s : ndarray (..., 3, 3)
        ``du_i / dx_j`` (1/s), x = (north, east, down); trace zero (the field is divergence-free).
    """

    velocity_ned_m_s: np.ndarray
    acceleration_ned_m_s2: np.ndarray
    gradient_ned_1_s: np.ndarray

    def along_path(self, velocity_ned_m_s: np.ndarray) -> np.ndarray:
        """Rate of change of the orbital velocity seen by a point moving at ``velocity_ned_m_s``
        (..., 3) m/s: ``du/dt + (grad u) v`` (m/s^2)."""
        v = np.asarray(velocity_ned_m_s, dtype=float)
        return self.acceleration_ned_m_s2 + np.einsum("...ij,...j->...i", self.gradient_ned_1_s, v)


def _depth_factors(
    k: np.ndarray, depth_ned_m: np.ndarray, water_depth_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Fc = cosh k(h-d)/sinh kh and Fs = sinh k(h-d)/sinh kh, overflow-free (..., n)."""
    d = np.maximum(depth_ned_m, 0.0)[..., None]
    e1 = np.exp(-k * d)
    if math.isinf(water_depth_m):
        return e1, e1
    e2 = np.exp(-k * (2.0 * water_depth_m - d))
    den = 1.0 - np.exp(-2.0 * k * water_depth_m)
    return (e1 + e2) / den, (e1 - e2) / den


@dataclass(frozen=True)
class WaveComponents:
    """A realised linear sea: n wave components and the water they travel in.

    Parameters
    ----------
    amplitude_m : ndarray (n,)
        Elevation amplitude a of each component, m.
    omega_rad_s : ndarray (n,)
        Angular frequency seen at a fixed point, rad/s.
    direction_rad : ndarray (n,)
        Direction of travel b (towards), rad clockwise from north.
    phase_rad : ndarray (n,)
        Phase phi at the origin at t = 0, rad.
    water_depth_m : float
        Depth of the water h, m (``math.inf``: deep).
    current_ned_m_s : tuple of 2 floats
        The uniform current (north, east) the waves ride on (the Doppler shift), m/s.
    g : float
        Gravity, m/s^2.
    label : str
        What this sea is, for messages and results (``"JONSWAP Hs 1.75 m, Tp 9.4 s, ..."``).

    The wavenumbers (rad/m) and intrinsic frequencies (rad/s) follow from the dispersion
    relation (:func:`wavenumber`) at construction: ``wavenumber_rad_m``, ``intrinsic_omega_rad_s``.
    """

    amplitude_m: np.ndarray
    omega_rad_s: np.ndarray
    direction_rad: np.ndarray
    phase_rad: np.ndarray
    water_depth_m: float = math.inf
    current_ned_m_s: tuple[float, float] = (0.0, 0.0)
    g: float = GRAVITY_M_S2
    label: str = "sea"
    wavenumber_rad_m: np.ndarray = field(init=False, repr=False)
    intrinsic_omega_rad_s: np.ndarray = field(init=False, repr=False)
    _kn: np.ndarray = field(init=False, repr=False, compare=False)
    _ke: np.ndarray = field(init=False, repr=False, compare=False)
    _cb: np.ndarray = field(init=False, repr=False, compare=False)
    _sb: np.ndarray = field(init=False, repr=False, compare=False)
    _as: np.ndarray = field(init=False, repr=False, compare=False)
    _weights: np.ndarray = field(init=False, repr=False, compare=False)
    _neg_k: np.ndarray = field(init=False, repr=False, compare=False)
    _c2: np.ndarray | None = field(init=False, repr=False, compare=False)
    _inv_den: np.ndarray | None = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        arrays = {}
        for name in ("amplitude_m", "omega_rad_s", "direction_rad", "phase_rad"):
            a = np.atleast_1d(np.asarray(getattr(self, name), dtype=float)).copy()
            if a.ndim != 1:
                raise ValueError(f"{name}: expected one value per component, got shape {a.shape}")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"{name}: values must be finite")
            a.setflags(write=False)
            arrays[name] = a
        n = arrays["amplitude_m"].size
        for name, a in arrays.items():
            if a.size != n:
                raise ValueError(f"{name}: {a.size} values for {n} components")
            object.__setattr__(self, name, a)
        if np.any(arrays["amplitude_m"] < 0):
            raise ValueError("amplitude_m: amplitudes must be >= 0")
        if not self.water_depth_m > 0:
            raise ValueError(f"water_depth_m: must be positive, got {self.water_depth_m}")
        un, ue = (float(v) for v in self.current_ned_m_s)
        object.__setattr__(self, "current_ned_m_s", (un, ue))
        b = arrays["direction_rad"]
        along = un * np.cos(b) + ue * np.sin(b)
        k = wavenumber(arrays["omega_rad_s"], self.water_depth_m, along, self.g) if n else np.zeros(0)
        sig = arrays["omega_rad_s"] - k * along
        for name, a in (("wavenumber_rad_m", k), ("intrinsic_omega_rad_s", sig)):
            a = np.asarray(a, dtype=float).copy()
            a.setflags(write=False)
            object.__setattr__(self, name, a)
        # per-component constants of the kinematics
        object.__setattr__(self, "_kn", k * np.cos(b))
        object.__setattr__(self, "_ke", k * np.sin(b))
        object.__setattr__(self, "_cb", np.cos(b))
        object.__setattr__(self, "_sb", np.sin(b))
        object.__setattr__(self, "_as", arrays["amplitude_m"] * sig)
        object.__setattr__(self, "_weights", self._weight_matrix())
        object.__setattr__(self, "_neg_k", -k)
        if math.isinf(self.water_depth_m):
            object.__setattr__(self, "_c2", None)
            object.__setattr__(self, "_inv_den", None)
        else:  # e^{-k(2h - d)} = e^{-2kh} / e^{-kd}
            object.__setattr__(self, "_c2", np.exp(-2.0 * k * self.water_depth_m))
            object.__setattr__(self, "_inv_den", 1.0 / (1.0 - np.exp(-2.0 * k * self.water_depth_m)))

    # --- summary ---------------------------------------------------------------------------
    @property
    def n_components(self) -> int:
        """Number of components n."""
        return int(self.amplitude_m.size)

    @property
    def significant_height_m(self) -> float:
        """``4 sqrt(m0)`` with ``m0 = sum a^2 / 2``, m (the spectral Hs of the realised sea)."""
        return float(4.0 * math.sqrt(0.5 * float(np.sum(self.amplitude_m**2))))

    @property
    def wavelength_m(self) -> np.ndarray:
        """``2 pi / k`` per component, m (n,)."""
        return 2.0 * math.pi / self.wavenumber_rad_m

    @property
    def shortest_period_s(self) -> float:
        """The shortest fixed-point period of the components, s (inf with no component)."""
        return float(2.0 * math.pi / np.max(self.omega_rad_s)) if self.n_components else math.inf

    def describe(self) -> str:
        """One line: the label, components, depth and current."""
        depth = "deep water" if math.isinf(self.water_depth_m) else f"depth {self.water_depth_m:g} m"
        un, ue = self.current_ned_m_s
        cur = "" if un == 0 and ue == 0 else f", riding a ({un:g}, {ue:g}) m/s current"
        hm0 = self.significant_height_m
        n = self.n_components
        return f"{self.label}: {n} component{'' if n == 1 else 's'}, Hm0 {hm0:.3g} m, {depth}{cur}"

    # --- kinematics (numpy) ------------------------------------------------------------------
    def _phase(self, north: np.ndarray, east: np.ndarray, t: np.ndarray) -> np.ndarray:
        n = np.asarray(north, dtype=float)[..., None]
        e = np.asarray(east, dtype=float)[..., None]
        tt = np.asarray(t, dtype=float)[..., None]
        return self._kn * n + self._ke * e - self.omega_rad_s * tt + self.phase_rad

    def elevation(self, north: Any, east: Any, t: Any) -> np.ndarray:
        """Elevation eta (m, up) at horizontal positions (north, east) (m) and times t (s).

        The result has the broadcast shape of the three arguments."""
        n, e, tt = np.broadcast_arrays(
            np.asarray(north, float), np.asarray(east, float), np.asarray(t, float)
        )
        return np.sum(self.amplitude_m * np.cos(self._phase(n, e, tt)), axis=-1)

    def elevation_rate(self, north: Any, east: Any, t: Any) -> np.ndarray:
        """d eta / dt (m/s, up) at fixed points; broadcast shape."""
        n, e, tt = np.broadcast_arrays(
            np.asarray(north, float), np.asarray(east, float), np.asarray(t, float)
        )
        return np.sum(self.amplitude_m * self.omega_rad_s * np.sin(self._phase(n, e, tt)), axis=-1)

    def kinematics(self, p_ned: np.ndarray, t: Any) -> WaveKinematics:
        """Orbital velocity, local acceleration and velocity gradient at points and times.

        ``p_ned`` (..., 3): NED positions, m; ``t``: times, s (broadcast to ``p_ned[..., 0]``).

        See the module docstring for the formulas; the current itself is not included.  Every
        output is linear in the four per-component terms ``Fc cos th, Fc sin th, Fs cos th,
        Fs sin th``, so one matrix product (with the component constants, built once) gives
        all 15 numbers per point: a step of the truth evaluates hundreds of components at
        the cost of a few numpy calls.
        """
        p = np.asarray(p_ned, dtype=float)
        if p.shape[-1] != 3:
            raise ValueError(f"p_ned must have a last dimension of 3, got shape {p.shape}")
        th = self._phase(p[..., 0], p[..., 1], np.broadcast_to(np.asarray(t, dtype=float), p.shape[:-1]))
        c, s = np.cos(th), np.sin(th)
        Fc, Fs = _depth_factors(self.wavenumber_rad_m, p[..., 2], self.water_depth_m)
        basis = np.concatenate([Fc * c, Fc * s, Fs * c, Fs * s], axis=-1)
        out = basis @ self._weights.T
        vel = out[..., 0:3]
        acc = out[..., 3:6]
        J = out[..., 6:15].reshape(p.shape[:-1] + (3, 3))
        if np.any(p[..., 2] <= 0.0):  # above the mean surface: the kinematics of d = 0, no depth gradient
            J = J.copy()
            J[..., :, 2] = np.where((p[..., 2] > 0.0)[..., None], J[..., :, 2], 0.0)
        return WaveKinematics(vel, acc, J)

    def kinematics_at(self, p_ned: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`kinematics` at one point ``p_ned`` (3,) m and time ``t`` (s), with the fewest numpy
        calls (the truth's integrator calls it at every RK4 stage).

        Returns (velocity (3,) m/s, local acceleration (3,) m/s^2, gradient (3, 3) 1/s), NED.
        """
        n, e, d = float(p_ned[0]), float(p_ned[1]), float(p_ned[2])
        th = self._kn * n + self._ke * e + (self.phase_rad - self.omega_rad_s * t)
        c, s = np.cos(th), np.sin(th)
        e1 = np.exp(self._neg_k * max(d, 0.0))
        if self._c2 is None or self._inv_den is None:
            Fc = Fs = e1
        else:
            e2 = self._c2 / e1
            Fc, Fs = (e1 + e2) * self._inv_den, (e1 - e2) * self._inv_den
        out = self._weights @ np.concatenate((Fc * c, Fc * s, Fs * c, Fs * s))
        J = out[6:15].reshape(3, 3)
        if d <= 0.0:
            J[:, 2] = 0.0
        return out[0:3], out[3:6], J

    def _weight_matrix(self) -> np.ndarray:
        """(15, 4n): velocity (3), local acceleration (3) and gradient (9, row-major) per point as
        linear combinations of ``[Fc c, Fc s, Fs c, Fs s]`` of the n components."""
        A = self.amplitude_m * self.intrinsic_omega_rad_s
        k, w = self.wavenumber_rad_m, self.omega_rad_s
        cb, sb = np.cos(self.direction_rad), np.sin(self.direction_rad)
        n = A.size
        W = np.zeros((15, 4, n))
        FCc, FCs, FSc, FSs = 0, 1, 2, 3
        W[0, FCc], W[1, FCc], W[2, FSs] = A * cb, A * sb, -A  # u_n, u_e, u_d
        W[3, FCs], W[4, FCs], W[5, FSc] = A * w * cb, A * w * sb, A * w  # du/dt
        W[6, FCs], W[7, FCs], W[8, FSc] = -A * k * cb * cb, -A * k * cb * sb, -A * k * cb  # du_n/d(n, e, d)
        W[9, FCs], W[10, FCs], W[11, FSc] = -A * k * sb * cb, -A * k * sb * sb, -A * k * sb  # du_e/d(n, e, d)
        W[12, FSc], W[13, FSc], W[14, FCs] = -A * k * cb, -A * k * sb, A * k  # du_d/d(n, e, d)
        return W.reshape(15, 4 * n)

    def orbital_statistics(self, depth_m: float) -> tuple[float, np.ndarray]:
        """The orbital velocity's statistics at ``depth_m`` (m below the mean surface): its mean
        frequency and its standard deviation per axis, from the components' amplitudes alone (the sea
        state, as a wave buoy reports it; not the realisation's phases).

        Returns ``(omega, std)``: the velocity-variance-weighted mean of the fixed-point frequencies,
        rad/s (nan with no component), and the std (3,) of the north, east and down components, m/s:
        ``var_n = sum a^2 sigma^2 Fc^2 cos^2 b / 2`` (east: ``sin^2 b``; down: ``Fs^2``), ``sigma`` the
        intrinsic frequency and ``Fc, Fs`` the depth factors of linear theory.
        """
        if self.n_components == 0:
            return math.nan, np.zeros(3)
        Fc, Fs = _depth_factors(self.wavenumber_rad_m, np.asarray(float(depth_m)), self.water_depth_m)
        A2 = 0.5 * (self.amplitude_m * self.intrinsic_omega_rad_s) ** 2
        cb, sb = np.cos(self.direction_rad), np.sin(self.direction_rad)
        var = np.array([np.sum(A2 * (Fc * cb) ** 2), np.sum(A2 * (Fc * sb) ** 2), np.sum(A2 * Fs**2)])
        weight = A2 * (Fc**2 + Fs**2)
        total = float(np.sum(weight))
        omega = float(np.sum(weight * self.omega_rad_s) / total) if total > 0 else math.nan
        return omega, np.sqrt(var)

    def velocity(self, p_ned: np.ndarray, t: Any) -> np.ndarray:
        """Orbital velocity (..., 3) NED m/s at ``p_ned`` (..., 3) m and t (s)."""
        return self.kinematics(p_ned, t).velocity_ned_m_s

    # --- kinematics (CasADi) -----------------------------------------------------------------
    def symbolic_velocity(self, p_ned: Any, t: Any) -> Any:
        """The orbital velocity (3x1 NED, m/s) as a CasADi expression of ``p_ned`` (3x1, m) and ``t`` (s).

        The same formula as :meth:`kinematics` (the components are constants of the expression;
        the depth is clamped at the mean surface with ``fmax``).
        """
        import casadi as ca  # on first use: the sea is read and sampled (numpy) without CasADi

        if self.n_components == 0:
            return ca.vertcat(0 * p_ned[0], 0 * p_ned[0], 0 * p_ned[0])
        kn = ca.DM(self._kn)
        ke = ca.DM(self._ke)
        k = ca.DM(self.wavenumber_rad_m)
        th = kn * p_ned[0] + ke * p_ned[1] - ca.DM(self.omega_rad_s) * t + ca.DM(self.phase_rad)
        d = ca.fmax(p_ned[2], 0.0)
        e1 = ca.exp(-k * d)
        if math.isinf(self.water_depth_m):
            Fc = Fs = e1
        else:
            h = self.water_depth_m
            e2 = ca.exp(-k * (2.0 * h - d))
            den = ca.DM(1.0 - np.exp(-2.0 * self.wavenumber_rad_m * h))
            Fc, Fs = (e1 + e2) / den, (e1 - e2) / den
        A = ca.DM(self._as)
        uh = A * Fc * ca.cos(th)
        wu = A * Fs * ca.sin(th)
        return ca.vertcat(
            ca.dot(uh, ca.DM(self._cb)),
            ca.dot(uh, ca.DM(self._sb)),
            -ca.sum1(wu),
        )

    # --- the record ------------------------------------------------------------------------------
    def to_arrays(self) -> dict[str, np.ndarray]:
        """The components as arrays (what a results file stores), each (n,)."""
        return {
            "amplitude_m": np.array(self.amplitude_m),
            "omega_rad_s": np.array(self.omega_rad_s),
            "wavenumber_rad_m": np.array(self.wavenumber_rad_m),
            "direction_rad": np.array(self.direction_rad),
            "phase_rad": np.array(self.phase_rad),
        }

    def attributes(self) -> dict[str, Any]:
        """The scalars of the sea (what a results file stores beside :meth:`to_arrays`)."""
        return {
            "label": self.label,
            "water_depth_m": float(self.water_depth_m),
            "current_ned_m_s": list(self.current_ned_m_s),
            "g_m_s2": float(self.g),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, Any], attributes: dict[str, Any]) -> WaveComponents:
        """The sea stored by :meth:`to_arrays` and :meth:`attributes` (a results file's)."""
        cur = attributes.get("current_ned_m_s", (0.0, 0.0))
        return cls(
            amplitude_m=np.asarray(arrays["amplitude_m"]),
            omega_rad_s=np.asarray(arrays["omega_rad_s"]),
            direction_rad=np.asarray(arrays["direction_rad"]),
            phase_rad=np.asarray(arrays["phase_rad"]),
            water_depth_m=float(attributes.get("water_depth_m", math.inf)),
            current_ned_m_s=(float(cur[0]), float(cur[1])),
            g=float(attributes.get("g_m_s2", GRAVITY_M_S2)),
            label=str(attributes.get("label", "sea")),
        )
