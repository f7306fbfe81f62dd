"""The ``sea`` section of a mission: linear waves, and the WEC buoy that moves with them.

Example (a PacWave-like sea at a 10 m deep dock)::

    sea:
      water_depth_m: 70
      waves: {type: jonswap, hs_m: 1.75, tp_s: 9.4, gamma: 3.3, direction_deg: 0, spread_deg: 25}

``waves.type``: ``regular`` (``height_m``, ``period_s``, ``phase_deg``), ``jonswap`` (``hs_m``,
``tp_s``, ``gamma``) or ``spectrum`` (``file``: a CSV of ``omega_rad_s, S_m2_s_rad`` or
``frequency_hz, S_m2_hz``); irregular seas take ``spread_deg``, ``n_directions`` and
``n_frequencies``.  ``direction_deg`` is where the waves travel *to*, clockwise from north.
The sea is realised from the mission's ``seed`` on a stream of its own (the sensors' draws do
not change when a sea is added).  With ``doppler: true`` (default) the waves ride the
mission's current at the dock at t = 0 (a fixed point sees the Doppler-shifted frequency).

The shortest period a run resolves is ``PERIODS_PER_WAVE`` control periods (0.5 s at the
default 20 Hz): a regular wave must be at least that long, a spectrum's peak period at least
twice that, and no component shorter is realised.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from auvdock.schema.strict import NonNegFloat, PosFloat, Strict
from auvdock.world.spectra import SpectrumFileError, jonswap, load_spectrum, realise, regular_wave
from auvdock.world.waves import WaveComponents

__all__ = ["WavesSpec", "SeaSpec", "WecSpec", "PERIODS_PER_WAVE", "SEA_STREAM"]

#: The shortest resolvable wave period, in control periods.
PERIODS_PER_WAVE = 10
#: The sea's random stream: ``np.random.default_rng([seed, SEA_STREAM])``.
SEA_STREAM = 0x5EA


class WavesSpec(Strict):
    """The waves: regular, JONSWAP, or a spectrum from a file."""

    type: Literal["regular", "jonswap", "spectrum"] = Field(description="regular, jonswap or spectrum")
    height_m: NonNegFloat | None = Field(default=None, description="regular: wave height H = 2 a, m")
    period_s: PosFloat | None = Field(default=None, description="regular: period seen at a fixed point, s")
    phase_deg: float = Field(default=0.0, description="regular: phase at the origin at t = 0, degrees")
    hs_m: NonNegFloat | None = Field(default=None, description="jonswap: significant wave height Hs, m")
    tp_s: PosFloat | None = Field(default=None, description="jonswap: peak period Tp, s")
    gamma: Annotated[float, Field(ge=1.0, le=10.0)] = Field(
        default=3.3, description="jonswap: peak enhancement"
    )
    file: str | None = Field(
        default=None, description="spectrum: CSV file (omega_rad_s,S_m2_s_rad or frequency_hz,S_m2_hz)"
    )
    direction_deg: float = Field(
        default=0.0, description="direction of travel (towards), deg clockwise from north"
    )
    spread_deg: Annotated[float, Field(ge=0.0, le=90.0)] = Field(
        default=0.0, description="irregular: directional spread (cos-2s), degrees; 0: long-crested"
    )
    n_directions: Annotated[int, Field(ge=1, le=64)] = Field(
        default=1, description="irregular: directions per frequency (>= 5 for a spread sea)"
    )
    n_frequencies: Annotated[int, Field(ge=1, le=2000)] = Field(
        default=100, description="irregular: frequency bins"
    )

    @model_validator(mode="after")
    def _fields_of_type(self) -> WavesSpec:
        need = {"regular": ("height_m", "period_s"), "jonswap": ("hs_m", "tp_s"), "spectrum": ("file",)}[
            self.type
        ]
        for name in need:
            if getattr(self, name) is None:
                raise ValueError(f"type {self.type} needs {name}")
        others = {"height_m", "period_s", "hs_m", "tp_s", "file"} - set(need)
        for name in sorted(others):
            if getattr(self, name) is not None:
                raise ValueError(f"{name} does not apply to type {self.type}")
        return self


class SeaSpec(Strict):
    """The sea: water depth and waves."""

    water_depth_m: PosFloat | Literal["deep"] = Field(
        default="deep", description="depth of the water, m, or deep (kh large everywhere)"
    )
    waves: WavesSpec | None = Field(default=None, description="the waves; omitted: no waves")
    doppler: bool = Field(
        default=True, description="the waves ride the mission's current at the dock at t = 0 (Doppler shift)"
    )

    @property
    def depth_m(self) -> float:
        """Water depth, m (``math.inf`` for deep)."""
        return math.inf if self.water_depth_m == "deep" else float(self.water_depth_m)

    def shortest_period_s(self, control_period_s: float) -> float:
        """The shortest resolvable wave period, s (``PERIODS_PER_WAVE`` control periods)."""
        return PERIODS_PER_WAVE * float(control_period_s)

    def check(self, control_period_s: float, where: str = "sea") -> tuple[str, str] | None:
        """The first impossible setting as (field path, problem), or None (needs the control period)."""
        w = self.waves
        if w is None:
            return None
        t_min = self.shortest_period_s(control_period_s)
        if w.type == "regular" and w.period_s is not None and w.period_s < t_min:
            return (
                f"{where}.waves.period_s",
                f"{w.period_s:g} s is below the shortest resolvable period {t_min:g} s "
                f"({PERIODS_PER_WAVE} control periods of {control_period_s:g} s)",
            )
        if w.type == "jonswap" and w.tp_s is not None and w.tp_s < 2 * t_min:
            return (
                f"{where}.waves.tp_s",
                f"{w.tp_s:g} s is below twice the shortest resolvable period {t_min:g} s "
                f"({PERIODS_PER_WAVE} control periods of {control_period_s:g} s)",
            )
        return None

    def build(
        self,
        seed: int,
        control_period_s: float,
        current_ned_m_s: tuple[float, float] = (0.0, 0.0),
        base: Path | None = None,
    ) -> WaveComponents | None:
        """The realised sea (None without waves).

        ``current_ned_m_s``: the current the waves ride on (used when ``doppler``); ``base``: the
        folder a relative spectrum file is read from.  Raises ValueError (the message names the
        problem; :class:`auvdock.world.spectra.SpectrumFileError` for the file).
        """
        w = self.waves
        if w is None:
            return None
        bad = self.check(control_period_s)
        if bad is not None:
            raise ValueError(f"{bad[0]}: {bad[1]}")
        cur = current_ned_m_s if self.doppler else (0.0, 0.0)
        depth = self.depth_m
        b0 = math.radians(w.direction_deg)
        w_max = 2 * math.pi / self.shortest_period_s(control_period_s)
        if w.type == "regular":
            assert w.height_m is not None and w.period_s is not None
            return regular_wave(
                w.height_m,
                w.period_s,
                direction_rad=b0,
                phase_rad=math.radians(w.phase_deg),
                water_depth_m=depth,
                current_ned_m_s=cur,
            )
        rng = np.random.default_rng([int(seed), SEA_STREAM])
        density: Callable[[np.ndarray], np.ndarray]
        if w.type == "jonswap":
            assert w.hs_m is not None and w.tp_s is not None
            hs, tp, gamma = w.hs_m, w.tp_s, w.gamma
            density = functools.partial(jonswap, hs_m=hs, tp_s=tp, gamma=gamma)
            wp = 2 * math.pi / tp
            lo, hi = 0.5 * wp, min(5.0 * wp, w_max)
            label = f"JONSWAP Hs {hs:g} m, Tp {tp:g} s, gamma {gamma:g}"
        else:
            p = Path(str(w.file))
            if not p.is_absolute() and base is not None:
                p = base / p
            spec = load_spectrum(p)
            density = spec
            lo = float(spec.omega_rad_s[0])
            hi = min(float(spec.omega_rad_s[-1]), w_max)
            if not hi > lo:
                raise SpectrumFileError(
                    f"{p}: the spectrum has no frequency below the shortest resolvable period"
                )
            label = spec.label
        if w.spread_deg > 0:
            label += f", spread {w.spread_deg:g} deg"
        return realise(
            density,
            lo,
            hi,
            w.n_frequencies,
            rng,
            mean_direction_rad=b0,
            spread_deg=w.spread_deg,
            n_directions=w.n_directions,
            water_depth_m=depth,
            current_ned_m_s=cur,
            label=label,
        )


class WecSpec(Strict):
    """dock.wec: the dock hangs below a heaving WEC buoy that moves with the mission's sea."""

    table: str = Field(
        default="wec_buoy_2m",
        description="the buoy's heave coefficients: a table shipped with auvdock by name, or a CSV "
        "file from auvdock dock-table (relative to the mission)",
    )
    pto_damping_N_s_m: NonNegFloat = Field(default=0.0, description="power take-off damping, N s/m")
    viscous_damping_N_s_m: NonNegFloat = Field(default=0.0, description="extra (viscous) damping, N s/m")
    mooring_stiffness_N_m: NonNegFloat = Field(default=0.0, description="mooring stiffness in heave, N/m")
