"""One closed-loop run held in memory: :class:`Run`, and :class:`MemoryRecorder` that records one.

A :class:`Run` has every per-step series of a run as numpy arrays (one row per control step,
the layout, units and frames of :mod:`auvdock.results.store`), its outcome, its events and
what it was: mission, controller, metadata.  It comes from :func:`auvdock.simulate`, from a
:class:`MemoryRecorder` that a run recorded into step by step, or from a results file
(:meth:`Run.from_file`); it goes to a file in exactly the layout ``auvdock sim`` writes
(:meth:`Run.save`), to an :class:`xarray.Dataset` (:meth:`Run.to_xarray`) or to a
:class:`pandas.DataFrame` (:meth:`Run.to_dataframe`).

Components
----------
Every series with a component axis has names for its components, in these tables (extra
series not listed get ``0, 1, ...``):

=========================================================  ===================  ===========================
series                                                     components           unit
=========================================================  ===================  ===========================
``state``, ``estimated_state``, ``estimated_state_std``    x y z phi theta psi  m m m rad rad rad
                                                           u v w p q r          m/s m/s m/s rad/s (x3)
``thrust_N``                                               T1 .. Tn             N
``wrench``, ``perception_wrench``                          X Y Z K M N          N N N N m N m N m
``flow_ned_m_s``, ``dock_position_m``, ...  (NED vectors)  north east down      m/s or m
``flow_estimate_m_s``, ``flow_body_true_m_s`` (body {b})   u v w                m/s
``flow_covariance``  (body {b}, 3 x 3)                     u v w  x  u v w      m^2/s^2
=========================================================  ===================  ===========================

pandas and xarray are imported only by :meth:`Run.to_dataframe` and :meth:`Run.to_xarray`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.results.store import (
    _RESERVED_ATTRS,
    BASE_SERIES,
    RunResults,
    RunWriter,
    _attr_value,
    _decode,
    checked_row,
    read_run,
)

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd
    import xarray as xr

    from auvdock.config.mission import Mission

__all__ = ["Run", "MemoryRecorder", "STATE_COMPONENTS", "STATE_UNITS", "series_info"]

#: Names of the 12 state components (:mod:`auvdock.vehicle.state`): NED position, ZYX Euler
#: angles, body velocity over ground, body angular rate.
STATE_COMPONENTS = ("x", "y", "z", "phi", "theta", "psi", "u", "v", "w", "p", "q", "r")
#: Unit of each state component.
STATE_UNITS = ("m", "m", "m", "rad", "rad", "rad", "m/s", "m/s", "m/s", "rad/s", "rad/s", "rad/s")
_WRENCH = ("X", "Y", "Z", "K", "M", "N")
_WRENCH_UNITS = ("N", "N", "N", "N m", "N m", "N m")
_NED = ("north", "east", "down")
_BODY = ("u", "v", "w")

# name -> (component dimension(s) with their labels, unit(s), frame, description)
_AxisSpec = tuple[str, tuple[str, ...]]
_KNOWN: dict[str, tuple[tuple[_AxisSpec, ...], str | tuple[str, ...], str, str]] = {
    "time_s": ((), "s", "", "time t_k of the step"),
    "state": (
        (("state_component", STATE_COMPONENTS),),
        STATE_UNITS,
        "NED / body {b}",
        "vehicle state at t_k: NED position, ZYX Euler angles, body velocity over ground, body rate",
    ),
    "wrench": ((("wrench_component", _WRENCH),), _WRENCH_UNITS, "body {b}", "body wrench B u"),
    "flow_ned_m_s": ((("ned", _NED),), "m/s", "NED", "true water velocity at the vehicle"),
    "dock_position_m": ((("ned", _NED),), "m", "NED", "dock position"),
    "dock_velocity_m_s": ((("ned", _NED),), "m/s", "NED", "dock velocity"),
    "distance_m": ((), "m", "", "vehicle-to-dock distance"),
    "solve_time_s": ((), "s", "", "wall time of the controller step"),
    "solver_status": ((), "1", "", "controller step outcome code (see flag_meanings)"),
    # extra series of the FSE controllers and the estimation stage
    "flow_estimate_m_s": ((("body", _BODY),), "m/s", "body {b}", "estimated water velocity"),
    "flow_body_true_m_s": ((("body", _BODY),), "m/s", "body {b}", "true water velocity"),
    "flow_estimate_ned_m_s": ((("ned", _NED),), "m/s", "NED", "estimated water velocity"),
    "flow_covariance": (
        (("body_i", _BODY), ("body_j", _BODY)),
        "m^2/s^2",
        "body {b}",
        "covariance of the flow estimate",
    ),
    "information": ((), "", "", "information metric F of the flow estimate"),
    "perception_wrench": (
        (("wrench_component", _WRENCH),),
        _WRENCH_UNITS,
        "body {b}",
        "perception wrench of the FSE-MPC",
    ),
    "estimated_state": (
        (("state_component", STATE_COMPONENTS),),
        STATE_UNITS,
        "NED / body {b}",
        "navigation filter's state estimate",
    ),
    "estimated_state_std": (
        (("state_component", STATE_COMPONENTS),),
        STATE_UNITS,
        "NED / body {b}",
        "navigation filter's standard deviation of the state estimate",
    ),
    "estimated_flow_ned_m_s": ((("ned", _NED),), "m/s", "NED", "navigation filter's water velocity"),
    "camera_dock_position_m": ((("ned", _NED),), "m", "NED", "dock position seen by the camera"),
}
# unit from a name's suffix, longest first
_SUFFIX_UNITS = (
    ("_m_s2", "m/s^2"),
    ("_rad_s", "rad/s"),
    ("_m_s", "m/s"),
    ("_rad", "rad"),
    ("_deg", "deg"),
    ("_us", "us"),
    ("_m", "m"),
    ("_s", "s"),
    ("_N", "N"),
)


def series_info(name: str, row_shape: tuple[int, ...]) -> dict[str, Any]:
    """How a series is labelled: its component axes, units, frame and description.

    Parameters
    ----------
    name : str
        Dataset name (``state``, ``thrust_N``, an extra series, ...).
    row_shape : tuple of int
        Shape of one row, e.g. ``(12,)``.

    Returns
    -------
    dict
        ``axes``: list of ``(dimension name, component labels)``, one per row axis;
        ``units``: one unit string per component of the first axis, or one for all;
        ``frame`` and ``description`` (``""`` where unknown).
    """
    if name == "thrust_N":
        n = row_shape[0] if row_shape else 0
        return {
            "axes": [("thruster", tuple(f"T{i + 1}" for i in range(n)))],
            "units": "N",
            "frame": "thruster",
            "description": "thruster forces applied on [t_k, t_k + dt)",
        }
    known = _KNOWN.get(name)
    if known is not None and tuple(len(labels) for _, labels in known[0]) == tuple(row_shape):
        known_axes, units, frame, description = known
        return {"axes": list(known_axes), "units": units, "frame": frame, "description": description}
    unit = next((u for suffix, u in _SUFFIX_UNITS if name.endswith(suffix)), "")
    axes = [(f"{name}_dim{i}", tuple(str(j) for j in range(n))) for i, n in enumerate(row_shape)]
    return {"axes": axes, "units": unit, "frame": "", "description": ""}


def _unit_text(units: str | tuple[str, ...]) -> str:
    return units if isinstance(units, str) else ", ".join(units)


def _component_unit(units: str | tuple[str, ...], index: tuple[int, ...]) -> str:
    if isinstance(units, str):
        return units
    return units[index[0]] if index else ""


def _same(a: Any, b: Any) -> bool:
    """Equal values, NaN equal to NaN, arrays compared elementwise."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape:
            return False
        if a.dtype.kind in "fc" or b.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b) and type(a) is type(b)


def _stored(key: str, value: Any) -> Any:
    """``value`` as a results file gives it back (None -> NaN or "", numpy -> Python)."""
    return _decode(_attr_value(key, value))


# ----------------------------------------------------------------------------- Run


@dataclass(eq=False, repr=False)
class Run:
    """One closed-loop run in memory.

    Every per-step array has one row per recorded step k (T rows): the control steps and,
    last, the final-state row (status ``no_step``: the state the run ended in, no control).
    Units and frames are those of :mod:`auvdock.results.store`.

    Attributes
    ----------
    time_s : ndarray, shape (T,)
        Time t_k of each step, s.
    state : ndarray, shape (T, 12)
        Vehicle state at t_k: x y z (NED position, m), phi theta psi (ZYX Euler angles,
        rad), u v w (body velocity over ground, m/s), p q r (body angular rate, rad/s);
        :data:`STATE_COMPONENTS`.
    thrust_N : ndarray, shape (T, n)
        The n thruster forces applied on [t_k, t_k + dt), N.
    wrench : ndarray, shape (T, 6)
        Body wrench B u = [X Y Z K M N] in {b}, N and N m.
    flow_ned_m_s : ndarray, shape (T, 3)
        True water velocity at the vehicle, NED, m/s.
    dock_position_m : ndarray, shape (T, 3)
        Dock position, NED, m.
    dock_velocity_m_s : ndarray, shape (T, 3)
        Dock velocity, NED, m/s.
    distance_m : ndarray, shape (T,)
        Vehicle-to-dock distance, m.
    solve_time_s : ndarray, shape (T,)
        Wall time of the controller step, s (NaN in the final-state row).
    solver_status : ndarray of int8, shape (T,)
        Controller step outcome codes; names in ``status_names`` (and :attr:`status`).
    extras : dict of str to ndarray, shape (T, ...)
        Every extra series by name, e.g. ``flow_estimate_m_s`` (T, 3) in {b}, m/s;
        also readable as attributes (``run.flow_estimate_m_s``) and by ``run["name"]``.
    outcome : dict
        The outcome figures (``docked``, ``time_to_dock_s``, ``reason``, ...; see
        :mod:`auvdock.results.store`), ``{}`` for an unfinished run.
    mission_name, mission_yaml, controller : str
        What was run: the mission's name, the full resolved mission as YAML text, and the
        controller's name.
    attrs : dict
        Metadata of the run (``tolerance_m``, ``timeout_s``, ``dt_s``, ``flow``,
        ``vehicle``, ``solver``, ...).
    status_names : dict of int to str
        Solver status code -> name.
    complete : bool
        True once the run finished (False after an interruption or a crash).
    source : str
        ``"<file>:<group>"`` the run was read from, ``""`` for one never written.
    """

    time_s: np.ndarray
    state: np.ndarray
    thrust_N: np.ndarray
    wrench: np.ndarray
    flow_ned_m_s: np.ndarray
    dock_position_m: np.ndarray
    dock_velocity_m_s: np.ndarray
    distance_m: np.ndarray
    solve_time_s: np.ndarray
    solver_status: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)
    outcome: dict[str, Any] = field(default_factory=dict)
    mission_name: str = ""
    mission_yaml: str = ""
    controller: str = ""
    attrs: dict[str, Any] = field(default_factory=dict)
    status_names: dict[int, str] = field(default_factory=dict)
    complete: bool = False
    source: str = ""

    # -- construction

    @classmethod
    def from_results(cls, results: RunResults) -> Run:
        """The run of a :class:`~auvdock.results.store.RunResults` (as :func:`read_run` gives)."""
        raw = dict(results.attrs)
        outcome = results.outcome()
        attrs = {k: v for k, v in raw.items() if k not in _RESERVED_ATTRS and k not in outcome}
        return cls(
            **{name: np.asarray(getattr(results, name)) for name in BASE_SERIES},
            extras={name: np.asarray(a) for name, a in results.extras.items()},
            outcome=outcome,
            mission_name=results.mission_name,
            mission_yaml=results.mission_yaml,
            controller=results.controller,
            attrs=attrs,
            status_names=results.status_names,
            complete=results.complete,
            source=f"{results.source}:{results.group}" if results.source else "",
        )

    @classmethod
    def from_file(cls, path: str | Path, group: str = "/") -> Run:
        """Read a run from an HDF5 results file.

        Parameters
        ----------
        path : str or Path
            A file written by ``auvdock sim`` / ``fly`` / ``compare`` or :meth:`save`.
        group : str
            The run group: ``"/"`` for a single-run file, ``"/runs/<case>/<controller>"``
            in a campaign file (:func:`auvdock.results.store.list_runs` lists them).

        Raises
        ------
        FileNotFoundError, ValueError
            As :func:`auvdock.results.store.read_run`.
        """
        return cls.from_results(read_run(path, group))

    # -- reading

    @property
    def n_steps(self) -> int:
        """Number of recorded rows T (control steps and the final-state row)."""
        return int(self.time_s.shape[0])

    @property
    def n_thrusters(self) -> int:
        """Number of thrusters n (columns of ``thrust_N``)."""
        return int(self.thrust_N.shape[1]) if self.thrust_N.ndim == 2 else 0

    @property
    def docked(self) -> bool:
        """Whether the vehicle docked."""
        return bool(self.outcome.get("docked", False))

    @property
    def status(self) -> np.ndarray:
        """Status names per row, shape (T,), e.g. ``"ok"``, ``"no_step"``."""
        names = self.status_names
        return np.array([names.get(int(c), str(int(c))) for c in self.solver_status], dtype=object)

    @property
    def events(self) -> list[tuple[float, str]]:
        """Events of the run as ``(time s, text)`` (a ``fly`` session's; ``[]`` for a simulation)."""
        raw = self.outcome.get("events_json") or self.attrs.get("events_json")
        if not raw:
            return []
        return [(float(t), str(text)) for t, text in json.loads(raw)]

    @property
    def series(self) -> dict[str, np.ndarray]:
        """Every per-step series by name: the base datasets, then the extras."""
        return {**{name: getattr(self, name) for name in BASE_SERIES}, **self.extras}

    def __getitem__(self, name: str) -> np.ndarray:
        series = self.series
        if name not in series:
            raise KeyError(f"no series {name!r} (this run has: {', '.join(series)})")
        return series[name]

    def __getattr__(self, name: str) -> Any:
        # only called when normal lookup fails: the extra series as attributes
        extras = self.__dict__.get("extras")
        if extras is not None and not name.startswith("_") and name in extras:
            return extras[name]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def control_rows(self) -> np.ndarray:
        """Mask (T,) of the control-step rows: all but the final-state row (``no_step``)."""
        no_step = [code for code, name in self.status_names.items() if name == "no_step"]
        return ~np.isin(self.solver_status, no_step)

    def mission(self) -> Mission:
        """The mission the run flew, parsed from :attr:`mission_yaml`."""
        import yaml

        from auvdock.config.mission import parse_mission

        return parse_mission(yaml.safe_load(self.mission_yaml))

    def to_results(self) -> RunResults:
        """The run as :class:`~auvdock.results.store.RunResults` (what ``plot_run`` takes)."""
        attrs: dict[str, Any] = dict(self.attrs)
        attrs.update(self.outcome)
        attrs.update(
            mission_name=self.mission_name,
            mission_yaml=self.mission_yaml,
            controller=self.controller,
            complete=self.complete,
            solver_status_codes=json.dumps({str(k): v for k, v in self.status_names.items()}),
            extra_series=json.dumps({k: list(v.shape[1:]) for k, v in self.extras.items()}),
            outcome_keys=json.dumps(list(self.outcome)),
        )
        file, _, group = self.source.rpartition(":")
        return RunResults(
            **{name: getattr(self, name) for name in BASE_SERIES},
            extras=dict(self.extras),
            attrs=attrs,
            source=file,
            group=group or "/",
        )

    def equals(self, other: Run) -> bool:
        """Same series (NaN equal to NaN), outcome, metadata, mission and controller."""
        if not isinstance(other, Run):
            return False
        mine, theirs = self.series, other.series
        if mine.keys() != theirs.keys() or any(not _same(mine[k], theirs[k]) for k in mine):
            return False
        for a, b in ((self.outcome, other.outcome), (self.attrs, other.attrs)):
            if a.keys() != b.keys() or any(not _same(a[k], b[k]) for k in a):
                return False
        return (
            self.mission_name == other.mission_name
            and self.mission_yaml == other.mission_yaml
            and self.controller == other.controller
            and self.status_names == other.status_names
            and self.complete == other.complete
        )

    # -- writing

    def save(self, path: str | Path, group: str = "/", *, overwrite: bool = True) -> Path:
        """Write the run to an HDF5 results file, in exactly the layout ``auvdock sim`` writes.

        ``auvdock plot``, :func:`auvdock.results.store.read_run` and :meth:`from_file` read
        it back.  An unfinished run (``complete`` False) is written unfinished.

        Parameters
        ----------
        path : str or Path
            The file (created with its folders; an existing single-run file is replaced).
        group : str
            Run group, ``"/"`` for one run per file.
        overwrite : bool
            As :class:`~auvdock.results.store.RunWriter`.

        Returns
        -------
        Path
            ``path``.
        """
        writer = RunWriter(
            Path(path),
            group,
            mission_yaml=self.mission_yaml,
            mission_name=self.mission_name,
            controller=self.controller,
            extra_series={name: tuple(a.shape[1:]) for name, a in self.extras.items()},
            flush_every=max(1, self.n_steps),
            overwrite=overwrite,
            attrs=self.attrs,
            status_names=self.status_names or None,
            n_thrusters=self.n_thrusters,
        )
        with writer:
            series = self.series
            for k in range(self.n_steps):
                writer.append(**{name: a[k] for name, a in series.items()})
            if self.complete:
                writer.finish(self.outcome)
        return Path(path)

    def to_xarray(self) -> xr.Dataset:
        """The run as an :class:`xarray.Dataset`.

        Returns
        -------
        xarray.Dataset
            Dimension ``time_s`` (coordinate: time, s) and one dimension per component axis,
            with the component names as coordinates: ``state_component`` (x .. r, with the
            coordinate ``state_unit`` giving each one's unit), ``thruster`` (T1 .. Tn),
            ``wrench_component`` (X .. N), ``ned`` (north, east, down), ``body`` (u, v, w), ...
            (see the module docstring).  Every variable's attrs hold ``units`` (one unit, or
            the units of its components in order, comma-separated), ``frame`` and
            ``description``; ``solver_status`` also has CF ``flag_values`` /
            ``flag_meanings``.  The dataset's attrs hold ``mission_name``, ``controller``,
            ``mission_yaml``, ``complete``, the metadata and the outcome (booleans as 0/1
            and None as "", so that ``to_netcdf`` takes them).
        """
        import xarray as xr

        data_vars: dict[str, Any] = {}
        coords: dict[str, Any] = {"time_s": ("time_s", self.time_s, {"units": "s", "long_name": "time"})}
        for name, a in self.series.items():
            if name == "time_s":
                continue
            info = series_info(name, a.shape[1:])
            dims = ["time_s"]
            for dim, labels in info["axes"]:
                dims.append(dim)
                coords.setdefault(dim, (dim, list(labels)))
            var_attrs: dict[str, Any] = {"units": _unit_text(info["units"])}
            if info["frame"]:
                var_attrs["frame"] = info["frame"]
            if info["description"]:
                var_attrs["description"] = info["description"]
            if name == "solver_status" and self.status_names:
                codes = sorted(self.status_names)
                var_attrs["flag_values"] = np.array(codes, dtype=np.int8)
                var_attrs["flag_meanings"] = " ".join(self.status_names[c] for c in codes)
            data_vars[name] = (dims, a, var_attrs)
        if "state_component" in coords:
            coords["state_unit"] = ("state_component", list(STATE_UNITS))
        attrs: dict[str, Any] = {
            "mission_name": self.mission_name,
            "controller": self.controller,
            "complete": int(self.complete),
            "mission_yaml": self.mission_yaml,
        }
        for key, value in {**self.attrs, **self.outcome}.items():
            attrs[key] = _netcdf_attr(value)
        return xr.Dataset(data_vars=data_vars, coords=coords, attrs=attrs)

    def to_dataframe(self) -> pd.DataFrame:
        """The per-step series as a :class:`pandas.DataFrame`, one row per step.

        Returns
        -------
        pandas.DataFrame
            Index ``time_s`` (s).  One column per scalar component, named
            ``<series>.<component>``: ``state.x`` .. ``state.r``, ``thrust_N.T1`` ..,
            ``wrench.X`` .., ``flow_ned_m_s.north`` .., ``flow_covariance.u.v``, and the
            scalar series by their own name (``distance_m``, ``solve_time_s``,
            ``solver_status``), plus ``status`` (the status names, categorical).
            ``df.attrs["units"]`` maps every column to its unit; ``df.attrs`` also holds
            ``mission_name``, ``controller`` and ``outcome``.
        """
        import pandas as pd

        columns: dict[str, np.ndarray] = {}
        units: dict[str, str] = {}
        for name, a in self.series.items():
            if name == "time_s":
                continue
            info = series_info(name, a.shape[1:])
            if a.ndim == 1:
                columns[name] = a
                units[name] = _unit_text(info["units"])
                continue
            labels = [labels for _, labels in info["axes"]]
            for index in np.ndindex(*a.shape[1:]):
                col = ".".join([name, *(labels[i][j] for i, j in enumerate(index))])
                columns[col] = a[(slice(None), *index)]
                units[col] = _component_unit(info["units"], index)
        df = pd.DataFrame(columns, index=pd.Index(self.time_s, name="time_s"))
        df["status"] = pd.Categorical(self.status, categories=list(dict.fromkeys(self.status_names.values())))
        units["status"] = ""
        df.attrs.update(
            units=units,
            mission_name=self.mission_name,
            controller=self.controller,
            outcome=dict(self.outcome),
        )
        return df

    # -- display

    def _outcome_text(self) -> str:
        if not self.complete:
            return "unfinished"
        o = self.outcome
        if self.docked:
            t = o.get("time_to_dock_s")
            return f"docked at {t:.2f} s" if isinstance(t, int | float) and math.isfinite(t) else "docked"
        text = f"not docked ({o.get('reason') or 'no reason'}"
        closest = o.get("closest_approach_m")
        if isinstance(closest, int | float) and math.isfinite(closest):
            text += f", closest {closest:.3f} m"
        return text + ")"

    def __repr__(self) -> str:
        return (
            f"Run(mission={self.mission_name!r}, controller={self.controller!r}, "
            f"{self._outcome_text()}, {self.n_steps} steps)"
        )

    def _repr_html_(self) -> str:  # notebooks: the short repr, not the arrays
        import html

        return f"<pre>{html.escape(repr(self))}</pre>"


def _netcdf_attr(value: Any) -> Any:
    if isinstance(value, bool | np.bool_):
        return int(value)
    if value is None:
        return ""
    return value


# ----------------------------------------------------------------------------- recorder


class MemoryRecorder:
    """Record a run step by step in memory: :class:`~auvdock.results.store.RunWriter`'s
    interface without a file, and :meth:`run` to get the :class:`Run`.

    It checks every row exactly as the writer does (same names, shapes and status names),
    and keeps the outcome and metadata as a results file gives them back (None as NaN, or
    as ``""`` for the string keys; numpy scalars as Python numbers), so a run recorded here
    equals the same run written to a file and read back.

    Parameters
    ----------
    mission_yaml, mission_name, controller : str
        As :class:`~auvdock.results.store.RunWriter` (keyword-only, like all parameters).
    extra_series : dict of str to tuple of int, optional
        Extra per-step series, name -> per-row shape; required in every :meth:`append`.
    flush_every : int
        Accepted for the writer's interface; there is nothing to flush.
    attrs : dict, optional
        Metadata (``tolerance_m``, ``dt_s``, ...); not the writer's own attribute names.
    status_names : dict of int to str, optional
        Status code -> name (default :data:`auvdock.controllers.status.STATUS_NAMES`).
    n_thrusters : int
        Row length of ``thrust_N``.

    Examples
    --------
    >>> rec = MemoryRecorder(mission_yaml=m.to_yaml(), mission_name=m.name, controller="oracle")
    >>> rec.append(time_s=0.0, state=x, ...)            # once per step
    >>> rec.finish({"docked": True, "time_to_dock_s": 41.2, "reason": "docked"})
    >>> run = rec.run()
    """

    def __init__(
        self,
        *,
        mission_yaml: str,
        mission_name: str,
        controller: str,
        extra_series: dict[str, tuple[int, ...]] | None = None,
        flush_every: int = 1,
        attrs: dict[str, Any] | None = None,
        status_names: dict[int, str] | None = None,
        n_thrusters: int = 8,
    ) -> None:
        if status_names is None:
            from auvdock.controllers import status

            status_names = status.STATUS_NAMES
        self._status_names = dict(status_names)
        self._status_codes = {name: code for code, name in self._status_names.items()}
        if isinstance(flush_every, bool) or not isinstance(flush_every, int | np.integer) or flush_every < 1:
            raise ValueError(f"flush_every must be an integer >= 1, got {flush_every!r}")
        self._series = RunWriter._declare_series(dict(extra_series or {}), int(n_thrusters))
        meta = dict(attrs or {})
        clash = sorted(_RESERVED_ATTRS.intersection(meta))
        if clash:
            raise ValueError(f"attrs may not set the writer's own attributes: {', '.join(clash)}")
        self._attrs = {str(k): _stored(str(k), v) for k, v in meta.items()}
        self._mission_yaml = str(mission_yaml)
        self._mission_name = str(mission_name)
        self._controller = str(controller)
        self._rows: dict[str, list[np.ndarray]] = {name: [] for name in self._series}
        self._outcome: dict[str, Any] = {}
        self._finished = False
        self._closed = False

    @property
    def n_steps(self) -> int:
        """Number of rows appended so far."""
        return len(self._rows["time_s"])

    @property
    def group(self) -> str:
        """Always ``"/"`` (the writer's run group; here for its interface)."""
        return "/"

    @property
    def filename(self) -> str:
        """Always ``""``: no file."""
        return ""

    def append(self, **row: Any) -> None:
        """Append one step's row; the same keywords and checks as :meth:`RunWriter.append`.

        Raises
        ------
        ValueError
            Naming the series, for a missing or unknown key, a wrong shape or a value
            that is not numeric.  Nothing is appended then.
        RuntimeError
            If the run is finished.
        """
        self._check_open("append")
        converted = checked_row(row, self._series, self._status_codes, "<memory>")
        for name, value in converted.items():
            self._rows[name].append(value)

    def flush(self) -> None:
        """Nothing to do (the writer's interface)."""

    def finish(self, outcome: dict[str, Any]) -> None:
        """Keep the outcome and mark the run complete; as :meth:`RunWriter.finish`.

        Raises
        ------
        ValueError
            If a key is one of the writer's own attribute names.
        TypeError
            For a value a results file cannot store.
        RuntimeError
            If the run is already finished.
        """
        self._check_open("finish")
        clash = sorted(_RESERVED_ATTRS.intersection(outcome))
        if clash:
            raise ValueError(f"outcome may not set the writer's own attributes: {', '.join(clash)}")
        self._outcome = {str(k): _stored(str(k), v) for k, v in outcome.items()}
        self._finished = True

    def close(self) -> None:
        """Stop recording (the run stays unfinished unless :meth:`finish` was called).  Idempotent."""
        self._closed = True

    def _check_open(self, what: str) -> None:
        if self._closed:
            raise RuntimeError(f"<memory>: cannot {what}(): the recorder is closed")
        if self._finished:
            raise RuntimeError(f"<memory>: cannot {what}(): the run is already finished")

    def __enter__(self) -> MemoryRecorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def run(self) -> Run:
        """The run recorded so far (the arrays are stacked anew on every call)."""
        arrays = {
            name: np.stack(rows) if rows else np.zeros((0, *shape), dtype=dtype)
            for (name, (shape, dtype)), rows in zip(self._series.items(), self._rows.values(), strict=True)
        }
        # Any: one dict of arrays spread over Run's typed fields (mypy checks each value against all)
        base: dict[str, Any] = {name: arrays.pop(name) for name in BASE_SERIES}
        return Run(
            **base,
            extras=arrays,
            outcome=dict(self._outcome),
            mission_name=self._mission_name,
            mission_yaml=self._mission_yaml,
            controller=self._controller,
            attrs=dict(self._attrs),
            status_names=dict(self._status_names),
            complete=self._finished,
        )
