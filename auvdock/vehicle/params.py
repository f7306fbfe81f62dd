"""Vehicle parameter files: loading, overriding and checking.

A parameter file is YAML (see ``auvdock/vehicle/data/*.yaml`` for the shipped presets).
Every quantity carries its unit in its key; hydrodynamic coefficients are magnitudes
(the model uses ``M_A = +diag(added_mass)`` and ``D = +diag(...)``).
"""

from __future__ import annotations

import copy
import functools
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from auvdock.schema.yamlio import load_yaml_strict
from auvdock.vehicle.thrusters import ThrusterCurve

__all__ = ["VehicleParams", "VehicleParamsError", "preset_names", "load_params", "deep_merge"]

_DATA = "auvdock.vehicle"


class VehicleParamsError(ValueError):
    """A vehicle parameter file or override is wrong.  ``field`` names the offending key."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


#: The BlueROV2 Heavy's outer dimensions, length x width x height (m): a vehicle file's default hull box.
_HEAVY_HULL_M = np.array([0.457, 0.575, 0.254])


@dataclass(frozen=True)
class VehicleParams:
    """Rigid-body, hydrodynamic and thruster parameters of a 6-DOF vehicle with n thrusters.

    Attributes (units in the names): ``mass_kg``; ``weight_N`` and ``buoyancy_N``;
    ``r_g_m`` and ``r_b_m`` (CG and CB in {b}, m); ``inertia_kg_m2`` (Ix, Iy, Iz);
    ``added_mass`` (6 magnitudes: kg, kg m^2); ``linear_damping`` (N s/m, N m s/rad);
    ``quadratic_damping`` (N s^2/m^2, N m s^2/rad^2); thruster ``positions_m`` (n x 3)
    and unit ``directions`` (n x 3) in {b}; ``thrust_limits_N`` (n x 2, [reverse, forward]);
    ``thruster_gain``, the force the thrusters produce per force commanded (1: the T200 curve
    as published; optional in a file, default 1; a model-error sweep scales it in the plant);
    ``hull_box_m``, the hull as a box (length, width, height, m) centred on the body origin, for
    contact with a dock (optional in a file; default the BlueROV2 Heavy's 0.457 x 0.575 x 0.254 m).
    The number of thrusters n comes from the file (8 for the Heavy, 6 for the standard frame).
    """

    name: str
    description: str
    mass_kg: float
    weight_N: float
    buoyancy_N: float
    r_g_m: np.ndarray
    r_b_m: np.ndarray
    inertia_kg_m2: np.ndarray
    added_mass: np.ndarray
    linear_damping: np.ndarray
    quadratic_damping: np.ndarray
    thruster_positions_m: np.ndarray
    thruster_directions: np.ndarray
    thruster_voltage_V: int
    thrust_limits_N: np.ndarray
    thruster_curve: ThrusterCurve = field(default_factory=ThrusterCurve)
    thruster_gain: float = 1.0
    hull_box_m: np.ndarray = field(default_factory=lambda: _HEAVY_HULL_M.copy())
    raw: dict[str, Any] = field(repr=False, compare=False, default_factory=dict)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> VehicleParams:
        """Build and check parameters from a parsed parameter file."""

        def vec(key: str, n: int, nonneg: bool = False, positive: bool = False) -> np.ndarray:
            if key not in d:
                raise VehicleParamsError(key, "is required")
            try:
                a = np.asarray(d[key], dtype=float)
            except (TypeError, ValueError):
                raise VehicleParamsError(key, f"must be a list of {n} numbers") from None
            if a.shape != (n,):
                raise VehicleParamsError(key, f"must be a list of {n} numbers, got {d[key]!r}")
            if not np.all(np.isfinite(a)):
                raise VehicleParamsError(key, "must be finite")
            if nonneg and np.any(a < 0):
                raise VehicleParamsError(key, "must be >= 0 (magnitudes)")
            if positive and np.any(a <= 0):
                raise VehicleParamsError(key, "must be > 0")
            return a

        def num(key: str, positive: bool = True) -> float:
            if key not in d:
                raise VehicleParamsError(key, "is required")
            v = d[key]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
                raise VehicleParamsError(key, f"must be a finite number, got {v!r}")
            if positive and v <= 0:
                raise VehicleParamsError(key, "must be > 0")
            return float(v)

        th = d.get("thrusters")
        if not isinstance(th, dict):
            raise VehicleParamsError("thrusters", "is required (a mapping)")
        try:
            pos = np.asarray(th["positions_m"], dtype=float)
            dirs = np.asarray(th["directions"], dtype=float)
        except (KeyError, TypeError, ValueError):
            raise VehicleParamsError(
                "thrusters", "needs positions_m and directions (n x 3 numbers, one row per thruster)"
            ) from None
        if pos.ndim != 2 or pos.shape[1] != 3 or not 1 <= pos.shape[0] <= 16:
            raise VehicleParamsError(
                "thrusters.positions_m", f"must be n x 3 (1 to 16 thrusters), got shape {pos.shape}"
            )
        n = pos.shape[0]
        if dirs.shape != (n, 3):
            raise VehicleParamsError(
                "thrusters.directions", f"must be {n} x 3 (one per position), got shape {dirs.shape}"
            )
        norms = np.linalg.norm(dirs, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-3):
            raise VehicleParamsError("thrusters.directions", "must be unit vectors")
        dirs = dirs / norms[:, None]
        voltage = th.get("voltage_V", 16)
        limits_table = {str(k): v for k, v in (th.get("limits_N") or {}).items()}
        if str(voltage) not in limits_table:
            raise VehicleParamsError(
                "thrusters.voltage_V",
                f"no thrust limits for {voltage} V (known: {', '.join(sorted(limits_table)) or 'none'})",
            )
        lim = np.asarray(limits_table[str(voltage)], dtype=float)
        if lim.shape == (2,):
            lim = np.tile(lim, (n, 1))
        if lim.shape != (n, 2) or np.any(lim[:, 0] >= 0) or np.any(lim[:, 1] <= 0):
            raise VehicleParamsError(
                f"thrusters.limits_N.{voltage}", f"must be [reverse < 0, forward > 0] (or {n} such pairs)"
            )

        model = str(th.get("model", "T200"))
        if model == "T200":
            curve = ThrusterCurve()
        elif model == "quadratic":
            try:
                mx = np.broadcast_to(np.asarray(th["max_N"], dtype=float), (n,))
                band = float(th.get("deadband_us", 0.0))
            except (KeyError, TypeError, ValueError):
                raise VehicleParamsError(
                    "thrusters.max_N", f"model quadratic needs max_N: a number or {n} numbers (N)"
                ) from None
            if np.any(mx <= 0) or not 0 <= band < 400:
                raise VehicleParamsError("thrusters.max_N", "must be > 0 (and deadband_us in 0..400)")
            curve = ThrusterCurve("quadratic", tuple(float(v) for v in mx), band)
        else:
            raise VehicleParamsError("thrusters.model", f"must be T200 or quadratic, got {model!r}")

        return cls(
            name=str(d.get("name", "custom")),
            description=str(d.get("description", "")),
            mass_kg=num("mass_kg"),
            weight_N=num("weight_N"),
            buoyancy_N=num("buoyancy_N"),
            r_g_m=vec("r_g_m", 3),
            r_b_m=vec("r_b_m", 3),
            inertia_kg_m2=vec("inertia_kg_m2", 3, positive=True),
            added_mass=vec("added_mass", 6, nonneg=True),
            linear_damping=vec("linear_damping", 6, nonneg=True),
            quadratic_damping=vec("quadratic_damping", 6, nonneg=True),
            thruster_positions_m=pos,
            thruster_directions=dirs,
            thruster_voltage_V=int(voltage),
            thrust_limits_N=lim,
            thruster_curve=curve,
            thruster_gain=num("thruster_gain") if "thruster_gain" in d else 1.0,
            hull_box_m=vec("hull_box_m", 3, positive=True) if "hull_box_m" in d else _HEAVY_HULL_M.copy(),
            raw=copy.deepcopy(d),
        )


def preset_names() -> list[str]:
    """Names of the parameter presets shipped with auvdock."""
    files = resources.files(_DATA).joinpath("data").iterdir()
    return sorted(p.name[:-5] for p in files if p.name.endswith(".yaml"))


def deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """A copy of ``base`` with ``over`` merged in, recursively for nested mappings."""
    out = copy.deepcopy(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = copy.deepcopy(v)
    return out


def _read_raw(name_or_path: str | Path) -> dict[str, Any]:
    s = str(name_or_path)
    if s in preset_names():
        text = resources.files(_DATA).joinpath("data", f"{s}.yaml").read_text()
    else:
        p = Path(s)
        if not p.suffix and not p.exists():
            raise VehicleParamsError(
                "vehicle", f"unknown vehicle preset {s!r} (known: {', '.join(preset_names())})"
            )
        if not p.is_file():
            raise VehicleParamsError("vehicle", f"parameter file {s} does not exist")
        text = p.read_text()
    try:
        d = _parsed(text)
    except yaml.YAMLError as e:
        raise VehicleParamsError("vehicle", f"parameter file {s} is not valid YAML: {e}") from None
    if not isinstance(d, dict):
        raise VehicleParamsError("vehicle", f"parameter file {s} must hold a mapping")
    return copy.deepcopy(d)


@functools.lru_cache(maxsize=16)
def _parsed(text: str) -> Any:
    """A parameter file's YAML, parsed once per text (every run of a sweep reads the same file; the
    caller copies it)."""
    return load_yaml_strict(text)


def load_params(
    name_or_path: str | Path = "bluerov2_heavy",
    overrides: dict[str, Any] | None = None,
    thruster_voltage_V: int | None = None,
) -> VehicleParams:
    """Load a preset by name (see :func:`preset_names`) or a YAML file by path.

    Parameters
    ----------
    name_or_path : str or Path
        Preset name, e.g. ``"bluerov2_heavy"`` (default) or ``"bluerov2_heavy_vonbenzon"``,
        or the path of a parameter file of the same layout.
    overrides : dict, optional
        Keys to replace, merged recursively (e.g. ``{"mass_kg": 14.0}``).
    thruster_voltage_V : int, optional
        Battery voltage that selects the thrust limits (16 or 12 in the presets).
    """
    d = _read_raw(name_or_path)
    if overrides:
        unknown = sorted(set(overrides) - set(d))
        if unknown:
            raise VehicleParamsError(f"overrides.{unknown[0]}", "is not a vehicle parameter")
        d = deep_merge(d, overrides)
    if thruster_voltage_V is not None:
        d = deep_merge(d, {"thrusters": {"voltage_V": thruster_voltage_V}})
    return VehicleParams.from_dict(d)
