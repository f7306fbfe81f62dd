"""Ocean flow fields: still water, constant currents and the double gyre.

Every field answers two ways from ONE formula:

* :meth:`FlowField.velocity` -- vectorised numpy evaluation (plots, the simulator's
  bookkeeping, tests), and
* :meth:`FlowField.symbolic` -- a CasADi expression of position and time, so the truth
  simulator can integrate through a field that varies in space and time and the MPC
  can predict with it.

Units and frames: position ``p`` is NED in metres, time ``t`` in seconds, and the
returned velocity is the water velocity (north, east, down) in m/s in the inertial
frame {n}.  The vertical component is zero everywhere (paper Assumption 4).

The six flow cases of the paper (section VII.A, docs/parameter-sources.md section 2) are available
by name through :func:`flow_case`: ``case1`` .. ``case6`` and readable aliases.

References
----------
S. C. Shadden, F. Lekien, J. E. Marsden, "Definition and properties of Lagrangian coherent
structures from finite-time Lyapunov exponents in two-dimensional aperiodic flows",
Physica D 212 (2005) -- the double gyre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any, overload

import numpy as np

if TYPE_CHECKING:
    import casadi as ca

__all__ = [
    "FlowField",
    "StillWater",
    "ConstantCurrent",
    "DoubleGyre",
    "FLOW_CASES",
    "flow_case",
    "flow_case_names",
]

# Math "libraries" through which the one formula of each field is evaluated.
_NP = SimpleNamespace(sin=np.sin, cos=np.cos, zeros_like=np.zeros_like, stack=np.stack, pi=np.pi)


def _ca_stack(parts: list[Any], axis: int = -1) -> ca.SX:
    import casadi as ca

    return ca.vertcat(*parts)


def _casadi_lib() -> SimpleNamespace:
    """The functions :meth:`FlowField._formula` takes, as CasADi's (imported on first use: a
    mission is read, and the numpy face used, without CasADi)."""
    import casadi as ca

    return SimpleNamespace(sin=ca.sin, cos=ca.cos, zeros_like=lambda x: 0 * x, stack=_ca_stack, pi=math.pi)




class FlowField:
    """Base class of a water velocity field v_c(p, t) in {n} (NED), in m/s."""

    name: str = "flow"

    def _formula(self, north: Any, east: Any, t: Any, lib: SimpleNamespace) -> tuple[Any, Any]:
        """Return (v_north, v_east) from NED north/east position (m) and time (s)."""
        raise NotImplementedError

    def velocity(self, p_ned: np.ndarray, t: float | np.ndarray = 0.0) -> np.ndarray:
        """Water velocity in {n}.

        Parameters
        ----------
        p_ned : array_like, shape (..., 3)
            Positions (north, east, down) in metres.
        t : float or array_like broadcastable to ``p_ned[..., 0]``
            Time in seconds.

        Returns
        -------
        ndarray, shape (..., 3)
            Water velocity (north, east, down) in m/s; the down component is zero.
        """
        p = np.asarray(p_ned, dtype=float)
        if p.shape[-1] != 3:
            raise ValueError(f"p_ned must have a last dimension of 3, got shape {p.shape}")
        north, east = p[..., 0], p[..., 1]
        t_arr = np.broadcast_to(np.asarray(t, dtype=float), north.shape)
        vn, ve = self._formula(north, east, t_arr, _NP)
        vn = np.broadcast_to(vn, north.shape)
        ve = np.broadcast_to(ve, north.shape)
        return np.stack([vn, ve, np.zeros_like(north)], axis=-1)

    @overload
    def symbolic(self, p_ned: ca.SX, t: ca.SX | float) -> ca.SX: ...

    @overload
    def symbolic(self, p_ned: ca.MX, t: ca.MX | float) -> ca.MX: ...

    def symbolic(self, p_ned: ca.SX | ca.MX, t: ca.SX | ca.MX | float) -> ca.SX | ca.MX:
        """CasADi expression of the water velocity (3x1, NED, m/s) at ``p_ned`` (3x1, m), ``t`` (s)."""
        import casadi as ca

        vn, ve = self._formula(p_ned[0], p_ned[1], t, _casadi_lib())
        return ca.vertcat(vn + 0 * p_ned[0], ve + 0 * p_ned[0], 0 * p_ned[0])

    def describe(self) -> str:
        """One-line human description with units."""
        return self.name


@dataclass(frozen=True)
class ConstantCurrent(FlowField):
    """A current uniform in space and constant in time.

    Parameters
    ----------
    north_m_s, east_m_s : float
        Water velocity components in {n}, m/s.
    """

    north_m_s: float = 0.0
    east_m_s: float = 0.0

    @property
    def name(self) -> str:  # type: ignore[override]
        return "constant"

    def _formula(self, north, east, t, lib):
        return self.north_m_s + lib.zeros_like(north), self.east_m_s + lib.zeros_like(north)

    def describe(self) -> str:
        return f"constant current ({self.north_m_s:g}, {self.east_m_s:g}, 0) m/s NED"


class StillWater(ConstantCurrent):
    """No current anywhere."""

    def __init__(self) -> None:
        super().__init__(0.0, 0.0)

    @property
    def name(self) -> str:  # type: ignore[override]
        return "still"

    def describe(self) -> str:
        return "still water"


@dataclass(frozen=True)
class DoubleGyre(FlowField):
    """The time-periodic double gyre of Shadden et al. (2005), mapped onto NED metres.

    On the unit domain [0, 2] x [0, 1]::

        f(x, t)  = a x^2 + b x,  a = eps sin(w t),  b = 1 - 2 eps sin(w t)
        u_g      = -pi A sin(pi f) cos(pi y)
        v_g      =  pi A (2 a x + b) cos(pi f) sin(pi y),      w = 2 pi / T

    with gyre coordinates x_g = (East + east_offset_m) / scale_m and
    y_g = (North + north_offset_m) / scale_m (defaults: the paper's domain East in
    [-7.5, 12.5] km, North in [-7.5, 2.5] km).  The flow in {n} is
    (north, east, down) = (v_g, u_g, 0) in m/s; speeds are not rescaled (peak about
    pi A).  These are the authors' conventions (docs/parameter-sources.md section 2).

    Parameters
    ----------
    amplitude : float
        A, the stream-function amplitude (m/s in the paper's usage).
    period_s : float
        T, the period of the gyre's oscillation, seconds.
    epsilon : float
        eps, the amplitude of the oscillation of the gyre separatrix (default 0.3).
    """

    amplitude: float
    period_s: float
    epsilon: float = 0.3
    east_offset_m: float = 7500.0
    north_offset_m: float = 7500.0
    scale_m: float = 10000.0

    @property
    def name(self) -> str:  # type: ignore[override]
        return "double_gyre"

    def _formula(self, north, east, t, lib):
        A, eps = self.amplitude, self.epsilon
        w = 2.0 * math.pi / self.period_s
        x = (east + self.east_offset_m) / self.scale_m
        y = (north + self.north_offset_m) / self.scale_m
        a = eps * lib.sin(w * t)
        b = 1.0 - 2.0 * eps * lib.sin(w * t)
        f = a * x * x + b * x
        u_g = -lib.pi * A * lib.sin(lib.pi * f) * lib.cos(lib.pi * y)
        v_g = lib.pi * A * (2.0 * a * x + b) * lib.cos(lib.pi * f) * lib.sin(lib.pi * y)
        return v_g, u_g

    def describe(self) -> str:
        return (
            f"double gyre, A = {self.amplitude:.4g}, T = {self.period_s / 3600:.4g} h, eps = {self.epsilon:g}"
        )


#: The paper's six flow cases (section VII.A), by canonical name.
FLOW_CASES: dict[str, FlowField] = {
    "case1": StillWater(),
    "case2": ConstantCurrent(0.5, 0.5),
    "case3": ConstantCurrent(-1.0, 0.0),
    "case4": ConstantCurrent(0.0, 2.0),
    "case5": DoubleGyre(amplitude=0.1 / math.pi, period_s=12 * 3600.0),
    "case6": DoubleGyre(amplitude=0.5, period_s=6 * 3600.0),
}

#: Readable aliases of the six cases.
FLOW_CASE_ALIASES: dict[str, str] = {
    "still": "case1",
    "still_water": "case1",
    "diagonal": "case2",
    "constant_0.5_0.5": "case2",
    "south": "case3",
    "constant_-1_0": "case3",
    "east_strong": "case4",
    "constant_0_2": "case4",
    "gyre": "case5",
    "double_gyre": "case5",
    "gyre_fast": "case6",
    "double_gyre_fast": "case6",
}


def flow_case_names() -> list[str]:
    """All accepted case names (canonical first, then aliases)."""
    return list(FLOW_CASES) + list(FLOW_CASE_ALIASES)


def flow_case(name: str) -> FlowField:
    """The flow field of one of the paper's six cases, by name or alias.

    Raises
    ------
    KeyError
        With the list of known names, if ``name`` is not a case.
    """
    key = FLOW_CASE_ALIASES.get(name, name)
    if key not in FLOW_CASES:
        raise KeyError(f"unknown flow case {name!r}; known: {', '.join(flow_case_names())}")
    return FLOW_CASES[key]
