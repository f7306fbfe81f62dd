"""The HDF5 results store of a closed-loop run: :class:`RunWriter` and :func:`read_run`.

One run lives in one HDF5 *run group*: the root group ``/`` of a file written by
``auvdock sim`` (one file per run), or ``/runs/<case>/<controller>/`` of a campaign
file written by ``auvdock compare`` (many runs in one file; :func:`list_runs` finds them).

Per-step datasets
-----------------
One row per control step k, at time t_k.  Every dataset is chunked and resizable along
axis 0 (``maxshape[0] = None``) and grows as the run goes; the writer flushes the file at
least every ``flush_every`` steps (default 1; ``sim``, ``compare`` and ``fly`` flush every
:data:`FLUSH_PERIOD_S` of control steps, :func:`flush_steps`), so after a crash or a killed
process the file still holds every flushed step; Ctrl-C and every other ending write the
rest.  T is the number of rows.

=====================  ==========  =========  ===========  ==============================================
name                   shape       unit       frame        meaning
=====================  ==========  =========  ===========  ==============================================
``time_s``             (T,)        s          --           time t_k of the step
``state``              (T, 12)     m, rad,    NED / body   vehicle state at t_k: [x y z (NED position, m),
                                   m/s,                    phi theta psi (ZYX Euler angles, rad),
                                   rad/s                   u v w (body velocity over ground, m/s),
                                                           p q r (body angular rate, rad/s)]
``thrust_N``           (T, n)      N          thruster     the n thruster forces commanded for [t_k, t_k+dt)
``wrench``             (T, 6)      N, N m     body {b}     body wrench B u = [X Y Z K M N]
``flow_ned_m_s``       (T, 3)      m/s        NED          true water velocity at the vehicle (NaN: unknown)
``dock_position_m``    (T, 3)      m          NED          dock position at t_k
``dock_velocity_m_s``  (T, 3)      m/s        NED          dock velocity at t_k
``distance_m``         (T,)        m          --           vehicle-to-dock distance at t_k
``solve_time_s``       (T,)        s          --           wall time of the controller step
``solver_status``      (T,)        int8 code  --           controller outcome; see ``solver_status_codes``
``<extra>``            (T, ...)    any        any          optional series declared by ``extra_series``,
                                                           e.g. ``flow_estimate_m_s`` (T, 3),
                                                           ``flow_covariance`` (T, 3, 3), ``information`` (T,)
=====================  ==========  =========  ===========  ==============================================

All per-step datasets are float64 except ``solver_status`` (int8; the codes of
:mod:`auvdock.controllers.status`, stored with the file as ``solver_status_codes``).

Group attributes
----------------
=======================  =========  ===========================================================
name                     type       meaning
=======================  =========  ===========================================================
``format``               str        always ``"auvdock-run"`` (marks a run group)
``format_version``       int        layout version, currently 1
``auvdock_version``      str        ``auvdock.__version__`` of the writer
``created_utc``          str        ISO 8601 UTC time the run group was created
``mission_yaml``         str        the full resolved mission, YAML text
``mission_name``         str        the mission's name
``controller``           str        the controller's name
``solver_status_codes``  str        JSON object mapping code (as a string) -> status name
``extra_series``         str        JSON object mapping extra dataset name -> per-row shape
``complete``             bool       False until :meth:`RunWriter.finish` is called
``outcome_keys``         str        JSON list of the names of the outcome attributes (written by
                                    :meth:`RunWriter.finish`)
(metadata)               any        optional ``attrs`` given to the writer, e.g. ``tolerance_m``
(outcome)                any        the outcome given to :meth:`RunWriter.finish`, e.g. ``docked``
                                    (bool), ``time_to_dock_s`` (s, NaN if not docked),
                                    ``contact_speed_m_s``, ``heading_error_rad``,
                                    ``closest_approach_m``, ``path_length_m``, ``n_steps``,
                                    ``solver_failures``, ``wall_time_s``, ``real_time_factor``,
                                    ``reason`` (str)
=======================  =========  ===========================================================

Attribute values that are None are stored as ``""`` for the string-valued keys in
:data:`STRING_ATTRS` (e.g. ``reason``) and as NaN otherwise.

Crash safety
------------
The file uses the HDF5 default (oldest compatible) file format.  Do *not* switch to
``libver="latest"``: its superblock records "file open for writing", and a file whose
writer was killed then refuses to open (until ``h5clear -s``).  With the default format a
flushed file stays readable whatever happens to the writer process.  A reader truncates
all per-step datasets to the shortest one, so a crash between two datasets' writes never
yields ragged arrays.  While the writer is running, HDF5 file locking keeps other
processes from opening the file.
"""

from __future__ import annotations

import json
import posixpath
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from types import TracebackType
from typing import Any

import h5py
import numpy as np

from auvdock._version import __version__

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "BASE_SERIES",
    "STRING_ATTRS",
    "RunWriter",
    "checked_row",
    "RunResults",
    "read_run",
    "read_sea",
    "open_format",
    "list_runs",
    "FLUSH_PERIOD_S",
    "flush_steps",
]

#: Rows reach the file at least this often (s of control steps): a crash loses at most this
#: much; every ending (Ctrl-C included) writes the rest.  A flush per step cost a third of a
#: simulation's wall time (h5py resizes and writes every dataset).
FLUSH_PERIOD_S = 1.0


def flush_steps(dt_s: float) -> int:
    """``flush_every`` for a control period ``dt_s`` (s): :data:`FLUSH_PERIOD_S` worth of steps."""
    return max(1, round(FLUSH_PERIOD_S / float(dt_s)))


#: Value of the ``format`` attribute that marks a run group.
FORMAT = "auvdock-run"
#: Layout version written by this module; readers accept versions up to this one.
FORMAT_VERSION = 1

#: The per-step datasets every run has: name -> (per-row shape, dtype).
BASE_SERIES: dict[str, tuple[tuple[int, ...], np.dtype]] = {
    "time_s": ((), np.dtype(np.float64)),
    "state": ((12,), np.dtype(np.float64)),
    "thrust_N": ((8,), np.dtype(np.float64)),
    "wrench": ((6,), np.dtype(np.float64)),
    "flow_ned_m_s": ((3,), np.dtype(np.float64)),
    "dock_position_m": ((3,), np.dtype(np.float64)),
    "dock_velocity_m_s": ((3,), np.dtype(np.float64)),
    "distance_m": ((), np.dtype(np.float64)),
    "solve_time_s": ((), np.dtype(np.float64)),
    "solver_status": ((), np.dtype(np.int8)),
}
_EXTRA_DTYPE = np.dtype(np.float64)

#: Attribute keys whose None value is stored as "" (all other None values become NaN).
STRING_ATTRS: frozenset[str] = frozenset({"reason", "mission_name", "controller", "mission_yaml"})

# Attributes the writer owns; callers' metadata and outcome may not overwrite them.
_RESERVED_ATTRS = frozenset(
    {
        "format",
        "format_version",
        "auvdock_version",
        "created_utc",
        "mission_yaml",
        "mission_name",
        "controller",
        "solver_status_codes",
        "extra_series",
        "complete",
        "outcome_keys",
    }
)

# Rows per HDF5 chunk: big enough that long runs are not chunk-bound, small enough that
# flushing a partly filled chunk every step stays cheap (< 100 kB for a (3, 3) series).
_CHUNK_ROWS = 256


# ----------------------------------------------------------------------------- helpers


def _normalize_group(group: str) -> str:
    """Absolute, normalised HDF5 group path ("/", "/runs/a/b")."""
    if not isinstance(group, str) or not group.strip():
        raise ValueError(f"group must be a non-empty string, got {group!r}")
    g = posixpath.normpath("/" + group.strip().strip("/"))
    return "/" if g in ("/", "//") else g


def _is_run_group(obj: Any) -> bool:
    return isinstance(obj, h5py.Group) and _decode(obj.attrs.get("format")) == FORMAT


def _attr_value(key: str, value: Any) -> Any:
    """Convert a Python value to something h5py stores as an attribute and reads back unchanged."""
    if value is None:
        return "" if key in STRING_ATTRS else np.nan
    if isinstance(value, bool | np.bool_):
        return np.bool_(value)
    if isinstance(value, int | np.integer):
        return np.int64(value)
    if isinstance(value, float | np.floating):
        return np.float64(value)
    if isinstance(value, str):
        return value
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, list | tuple | np.ndarray):
        arr = np.asarray(value)
        if arr.dtype.kind in "biuf":
            return arr
    raise TypeError(
        f"attribute {key!r}: cannot store a value of type {type(value).__name__} "
        "(use bool, int, float, str, None or a numeric array)"
    )


def _decode(value: Any) -> Any:
    """An attribute value as plain Python: bytes -> str, numpy scalars -> int/float/bool."""
    if isinstance(value, bytes | np.bytes_):
        return value.decode("utf-8", errors="replace")
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return _decode(value[()])
        if value.dtype.kind in "OSU":
            return [_decode(v) for v in value.tolist()]
        return value
    if isinstance(value, np.generic):
        return value.item()
    return value


def _decode_attrs(attrs: h5py.AttributeManager) -> dict[str, Any]:
    return {key: _decode(attrs[key]) for key in attrs}


# ----------------------------------------------------------------------------- writer


def checked_row(
    row: dict[str, Any],
    series: dict[str, tuple[tuple[int, ...], np.dtype]],
    status_codes: dict[str, int],
    label: str,
) -> dict[str, np.ndarray]:
    """One row checked against the declared ``series`` (name -> (row shape, dtype)) and converted,
    copied: what every sink of a run (:class:`RunWriter`, :class:`auvdock.results.run.MemoryRecorder`)
    appends.  ``solver_status`` takes an int code or a status name (``status_codes``).

    Raises
    ------
    ValueError
        Naming ``label`` and the dataset, for a missing or unknown key, a wrong shape or a value
        that is not numeric.
    """
    missing = [name for name in series if name not in row]
    if missing:
        raise ValueError(f"{label}: append() is missing dataset(s): {', '.join(missing)}")
    unknown = sorted(set(row) - set(series))
    if unknown:
        raise ValueError(
            f"{label}: append() got unknown dataset(s): {', '.join(unknown)} "
            "(declare extras with extra_series=...)"
        )
    return {
        name: _converted(name, row[name], shape, dtype, status_codes)
        for name, (shape, dtype) in series.items()
    }


def _converted(
    name: str, value: Any, shape: tuple[int, ...], dtype: np.dtype, status_codes: dict[str, int]
) -> np.ndarray:
    if name == "solver_status":
        if isinstance(value, str):
            if value not in status_codes:
                known = ", ".join(status_codes)
                raise ValueError(f"solver_status: unknown status name {value!r}; known: {known}")
            value = status_codes[value]
        try:
            raw = np.asarray(value)
        except Exception as exc:  # pragma: no cover - numpy rarely fails here
            raise ValueError(f"solver_status: not an integer code: {value!r}") from exc
        if raw.shape != shape:
            raise ValueError(f"solver_status: expected a scalar code, got shape {raw.shape}")
        if raw.dtype.kind not in "biu" and not (
            raw.dtype.kind == "f" and np.isfinite(raw) and float(raw) == int(raw)
        ):
            raise ValueError(f"solver_status: not an integer code: {value!r}")
        code = int(raw)
        if not -128 <= code <= 127:
            raise ValueError(f"solver_status: code {code} does not fit int8")
        return np.array(code, dtype=dtype)
    try:
        arr = np.array(value, dtype=dtype, copy=True)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: value is not numeric with row shape {shape}: {exc}") from exc
    if arr.shape != shape:
        raise ValueError(f"{name}: expected row shape {shape}, got shape {arr.shape}")
    return arr


class RunWriter:
    """Write one closed-loop run, step by step, into an HDF5 run group.

    Parameters
    ----------
    target : str, Path or h5py.File
        File to write.  A path is opened (and created, with its parent directories) by
        the writer and closed by :meth:`close`.  An open, writable ``h5py.File`` is used
        as is and left open by :meth:`close`.
    group : str
        Run group inside the file, e.g. ``"/"`` (one run per file) or
        ``"/runs/case1/oracle"`` (campaign file); intermediate groups are created.
    mission_yaml : str
        The full resolved mission as YAML text (keyword-only, like all that follow).
    mission_name : str
        Mission name.
    controller : str
        Controller name.
    extra_series : dict of str -> tuple of int, optional
        Extra per-step datasets, name -> per-row shape, e.g.
        ``{"flow_estimate_m_s": (3,), "flow_covariance": (3, 3), "information": ()}``.
        They are float64 and required in every :meth:`append`.
    flush_every : int
        Write buffered rows to the file and flush it every this many steps (>= 1).
        After a crash the file holds at least every step up to the last flush;
        :meth:`close` (also on an exception inside a ``with`` block) writes the rest.
    overwrite : bool
        Replace an existing run at ``group``.  Even with True, the writer never deletes
        other data: a group that is neither a run nor empty (e.g. the root of a campaign
        file), or an existing file that is not HDF5, raises :class:`FileExistsError`.
        With False, any existing run or data at ``group`` raises FileExistsError.
    attrs : dict, optional
        Extra metadata attributes written at creation, e.g. ``{"tolerance_m": 0.1,
        "dt_s": 0.1, "flow_case": "case2"}`` (plots read ``tolerance_m``).
    status_names : dict of int -> str, optional
        The step-outcome codes stored as ``solver_status_codes`` and accepted by name in
        :meth:`append` (default: :data:`auvdock.controllers.status.STATUS_NAMES`).
    n_thrusters : int
        Number of thrusters, the row length of ``thrust_N`` (the vehicle's; 8 for the Heavy).

    Examples
    --------
    >>> with RunWriter("run.h5", mission_yaml=text, mission_name="m", controller="oracle") as w:
    ...     for k in range(n):
    ...         w.append(time_s=t, state=x, ...)
    ...     w.finish({"docked": True, "time_to_dock_s": 41.2, "reason": "docked"})

    Leaving the ``with`` block closes the file; if an exception (including
    KeyboardInterrupt) is propagating, the run stays marked ``complete = False``.
    """

    def __init__(
        self,
        target: str | Path | h5py.File,
        group: str = "/",
        *,
        mission_yaml: str,
        mission_name: str,
        controller: str,
        extra_series: dict[str, tuple[int, ...]] | None = None,
        flush_every: int = 1,
        overwrite: bool = True,
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
        self._flush_every = int(flush_every)
        self._series = self._declare_series(extra_series or {}, int(n_thrusters))
        meta = dict(attrs or {})
        clash = sorted(_RESERVED_ATTRS.intersection(meta))
        if clash:
            raise ValueError(f"attrs may not set the writer's own attributes: {', '.join(clash)}")
        meta_values = {key: _attr_value(key, value) for key, value in meta.items()}
        self._group_path = _normalize_group(group)

        if isinstance(target, h5py.File):
            if not target.id.valid:
                raise ValueError("the given h5py.File is closed")
            if target.mode != "r+":
                raise ValueError(
                    f"{target.filename}: the given h5py.File is not writable (mode {target.mode!r})"
                )
            self._file: h5py.File = target
            self._owns_file = False
        else:
            self._file = self._open_path(Path(target), self._group_path, overwrite)
            self._owns_file = True
        self._label = f"{self._file.filename}:{self._group_path}"

        try:
            self._group = self._prepare_group(overwrite)
            g = self._group
            g.attrs["format"] = FORMAT
            g.attrs["format_version"] = np.int64(FORMAT_VERSION)
            g.attrs["auvdock_version"] = str(__version__)
            g.attrs["created_utc"] = datetime.now(UTC).isoformat(timespec="seconds")
            g.attrs["mission_yaml"] = str(mission_yaml)
            g.attrs["mission_name"] = str(mission_name)
            g.attrs["controller"] = str(controller)
            g.attrs["solver_status_codes"] = json.dumps({str(k): v for k, v in self._status_names.items()})
            g.attrs["extra_series"] = json.dumps(
                {name: list(shape) for name, (shape, _) in self._series.items() if name not in BASE_SERIES}
            )
            g.attrs["complete"] = np.bool_(False)
            for key, value in meta_values.items():
                g.attrs[key] = value
            self._datasets: dict[str, h5py.Dataset] = {}
            for name, (shape, dtype) in self._series.items():
                self._datasets[name] = g.create_dataset(
                    name,
                    shape=(0, *shape),
                    maxshape=(None, *shape),
                    chunks=(_CHUNK_ROWS, *shape),
                    dtype=dtype,
                )
            self._file.flush()
        except BaseException:
            if self._owns_file:
                self._file.close()
            raise

        # (rows written to the file, rows still buffered): replaced as ONE object, so that an
        # interrupt (SIGINT raises KeyboardInterrupt between any two bytecodes) never leaves
        # a count that disagrees with the buffer; see flush().
        self._log: tuple[int, list[dict[str, np.ndarray]]] = (0, [])
        self._finished = False
        self._closed = False

    # -- construction helpers

    @staticmethod
    def _declare_series(
        extra: dict[str, tuple[int, ...]], n_thrusters: int
    ) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
        series = dict(BASE_SERIES)
        series["thrust_N"] = ((n_thrusters,), np.dtype(np.float64))
        for name, shape in extra.items():
            if not isinstance(name, str) or not name or "/" in name or name.startswith("."):
                raise ValueError(f"extra series name must be a non-empty string without '/', got {name!r}")
            if name in BASE_SERIES:
                raise ValueError(f"extra series {name!r} clashes with a base dataset of the same name")
            shp = (shape,) if isinstance(shape, int | np.integer) else tuple(shape)
            if not all(isinstance(n, int | np.integer) and n >= 0 for n in shp):
                raise ValueError(f"extra series {name!r}: shape must be a tuple of ints >= 0, got {shape!r}")
            series[name] = (tuple(int(n) for n in shp), _EXTRA_DTYPE)
        return series

    @staticmethod
    def _open_path(path: Path, group: str, overwrite: bool) -> h5py.File:
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.exists() and not h5py.is_hdf5(path):
            raise FileExistsError(f"{path}: exists and is not an HDF5 file; refusing to overwrite it")
        if group == "/" and overwrite and path.exists():
            # One run per file: truncate, but only a file that holds one run (or nothing).
            with h5py.File(path, "r") as f:
                if not (_is_run_group(f) or (len(f) == 0 and len(f.attrs) == 0)):
                    raise FileExistsError(
                        f"{path}: holds data other than a single run (e.g. a campaign file); "
                        "refusing to overwrite it with a run at '/'"
                    )
            return h5py.File(path, "w")
        return h5py.File(path, "a")

    def _prepare_group(self, overwrite: bool) -> h5py.Group:
        f, gp = self._file, self._group_path
        if gp != "/" and gp not in f:
            return f.create_group(gp)
        g = f[gp]
        if not isinstance(g, h5py.Group):
            raise FileExistsError(f"{self._label}: exists and is not a group")
        empty = len(g) == 0 and len(g.attrs) == 0
        if empty:
            return g
        if not overwrite:
            raise FileExistsError(f"{self._label}: already holds data; pass overwrite=True to replace a run")
        if not _is_run_group(g):
            raise FileExistsError(
                f"{self._label}: holds data that is not an auvdock run; refusing to overwrite it"
            )
        if gp == "/":
            for name in list(g):
                del g[name]
            for key in list(g.attrs):
                del g.attrs[key]
            return g
        del f[gp]
        return f.create_group(gp)

    # -- public API

    @property
    def n_steps(self) -> int:
        """Number of rows appended so far (written to the file or still buffered)."""
        written, pending = self._log
        return written + len(pending)

    @property
    def group(self) -> str:
        """Absolute path of the run group in the file."""
        return self._group_path

    @property
    def filename(self) -> str:
        """Path of the HDF5 file."""
        return str(self._file.filename)

    def append(self, **row: Any) -> None:
        """Append one step's row.

        Parameters
        ----------
        **row
            One value per dataset, keyed by dataset name: every base dataset (see the
            module docstring) and every declared extra series.  Each value must have
            exactly the per-row shape of its dataset (``time_s`` a scalar, ``state``
            shape (12,), ...).  ``solver_status`` takes an int code or a status name
            (``"ok"``, ``"failed"``, ...).  Values are copied.

        Raises
        ------
        ValueError
            Naming the dataset, for a missing or unknown key, a wrong shape or a value
            that is not numeric.  Nothing is appended then.
        RuntimeError
            If the writer is closed or the run is finished.
        """
        self._check_open("append")
        converted = checked_row(row, self._series, self._status_codes, self._label)
        pending = self._log[1]
        pending.append(converted)  # one atomic list operation: the row is in, or not
        if len(pending) >= self._flush_every:
            self.flush()

    def flush(self) -> None:
        """Write buffered rows to the datasets and flush the HDF5 file to the OS."""
        if self._closed:
            return
        n0, pending = self._log
        m = len(pending)
        if m:
            rows = pending[:m]
            # Idempotent: an interrupt anywhere in this loop leaves the log as it was, and
            # the next flush (close() does one) writes the same rows to the same places.
            for name, ds in self._datasets.items():
                if ds.shape[0] < n0 + m:
                    ds.resize(n0 + m, axis=0)
                ds[n0 : n0 + m] = np.stack([r[name] for r in rows])
            # rows appended meanwhile (none in one thread) stay pending
            self._log = (n0 + m, pending[m:])
        self._file.flush()

    def write_sea(self, arrays: dict[str, np.ndarray], attrs: dict[str, Any]) -> None:
        """Store the realised sea in the run's ``sea`` subgroup: one dataset per component array
        (``amplitude_m``, ``omega_rad_s``, ``wavenumber_rad_m``, ``direction_rad``, ``phase_rad``,
        each (n,)) and its scalars as attributes (:meth:`auvdock.world.waves.WaveComponents.to_arrays`,
        ``attributes``), so that the kinematics can be recomputed from the file alone
        (:func:`read_sea`)."""
        self._check_open("write_sea")
        g = self._group.require_group("sea")
        for name, a in arrays.items():
            if name in g:
                del g[name]
            g.create_dataset(name, data=np.asarray(a, dtype=float))
        for key, value in attrs.items():
            g.attrs[key] = json.dumps(value) if isinstance(value, list | dict) else value
        self._file.flush()

    def finish(self, outcome: dict[str, Any]) -> None:
        """Write the outcome attributes, mark the run complete and flush.

        Parameters
        ----------
        outcome : dict
            Outcome attributes, e.g. ``docked`` (bool), ``time_to_dock_s`` (float, NaN
            if not docked), ``reason`` (str).  None values are stored as NaN, or as ""
            for keys in :data:`STRING_ATTRS`.  Values must be bool, int, float, str,
            None or numeric arrays.

        Raises
        ------
        ValueError
            If a key is one of the writer's own attributes (``format``, ``complete``, ...).
        TypeError
            For a value that cannot be stored.
        RuntimeError
            If the writer is closed or the run is already finished.
        """
        self._check_open("finish")
        clash = sorted(_RESERVED_ATTRS.intersection(outcome))
        if clash:
            raise ValueError(f"outcome may not set the writer's own attributes: {', '.join(clash)}")
        values = {str(key): _attr_value(str(key), value) for key, value in outcome.items()}
        self.flush()
        g = self._group
        for key, value in values.items():
            g.attrs[key] = value
        g.attrs["outcome_keys"] = json.dumps(list(values))
        g.attrs["complete"] = np.bool_(True)
        self._finished = True
        self._file.flush()

    def close(self) -> None:
        """Write buffered rows, flush, and close the file if the writer opened it.

        Does not mark the run complete (only :meth:`finish` does).  Idempotent.
        """
        if self._closed:
            return
        try:
            if self._file.id.valid:
                self.flush()
        finally:
            self._closed = True
            if self._owns_file and self._file.id.valid:
                self._file.close()

    def _check_open(self, what: str) -> None:
        if self._closed:
            raise RuntimeError(f"{self._label}: cannot {what}(): the writer is closed")
        if self._finished:
            raise RuntimeError(f"{self._label}: cannot {what}(): the run is already finished")

    def __enter__(self) -> RunWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        # Either way the run is closed as is; only finish() marks it complete, so an
        # exception (Ctrl-C included) leaves complete = False with every finished step.
        self.close()


# ----------------------------------------------------------------------------- reader


@dataclass
class RunResults:
    """One run read back from HDF5 (see the module docstring for units and frames).

    Attributes
    ----------
    time_s : ndarray, shape (T,)
    state : ndarray, shape (T, 12)
    thrust_N : ndarray, shape (T, n), n the number of thrusters
    wrench : ndarray, shape (T, 6)
    flow_ned_m_s : ndarray, shape (T, 3)
    dock_position_m : ndarray, shape (T, 3)
    dock_velocity_m_s : ndarray, shape (T, 3)
    distance_m : ndarray, shape (T,)
    solve_time_s : ndarray, shape (T,)
    solver_status : ndarray of int8, shape (T,)
    extras : dict of str -> ndarray, shape (T, ...)
        The extra series, by dataset name.
    attrs : dict
        All group attributes, decoded to plain Python (str, bool, int, float) or arrays.
    source : str
        File the run was read from.
    group : str
        Run group in that file.
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
    attrs: dict[str, Any] = field(default_factory=dict)
    source: str = ""
    group: str = "/"

    @property
    def n_steps(self) -> int:
        """Number of recorded steps T."""
        return int(self.time_s.shape[0])

    @property
    def complete(self) -> bool:
        """True if the writer finished the run (False after a crash or interruption)."""
        return bool(self.attrs.get("complete", False))

    @property
    def mission_yaml(self) -> str:
        """The full resolved mission, YAML text."""
        return str(self.attrs.get("mission_yaml", ""))

    @property
    def mission_name(self) -> str:
        """The mission's name."""
        return str(self.attrs.get("mission_name", ""))

    @property
    def controller(self) -> str:
        """The controller's name."""
        return str(self.attrs.get("controller", ""))

    @property
    def status_names(self) -> dict[int, str]:
        """Solver status code -> name, as stored in the file."""
        raw = self.attrs.get("solver_status_codes")
        if not raw:
            return {}
        return {int(k): str(v) for k, v in json.loads(raw).items()}

    def control_rows(self) -> np.ndarray:
        """Mask (T,) of the rows that are control steps: all but the final-state row
        (status ``no_step``), which holds the state the run ended in and no control."""
        no_step = [code for code, name in self.status_names.items() if name == "no_step"]
        return ~np.isin(self.solver_status, no_step)

    def outcome(self) -> dict[str, Any]:
        """The outcome attributes given to :meth:`RunWriter.finish` ({} if the run is incomplete)."""
        keys = json.loads(self.attrs.get("outcome_keys") or "[]")
        return {key: self.attrs[key] for key in keys if key in self.attrs}


def read_run(source: str | Path | h5py.File, group: str = "/") -> RunResults:
    """Read one run group into memory.

    Parameters
    ----------
    source : str, Path or h5py.File
        Results file (opened read-only and closed again) or an open ``h5py.File``.
    group : str
        The run group, ``"/"`` for a single-run file; see :func:`list_runs`.

    Returns
    -------
    RunResults
        All per-step datasets truncated to the shortest one (a crash may leave one
        dataset a row longer than another), extras and decoded attributes.

    Raises
    ------
    FileNotFoundError
        If ``source`` does not exist.
    ValueError
        ``"<path>: not an auvdock results file (...)"`` if the file is not HDF5, has no
        such group, the group is not an auvdock run, or a base dataset is missing.
    """
    gp = _normalize_group(group)
    if isinstance(source, h5py.File | h5py.Group):
        return _read_group(source.file, gp, str(source.file.filename))
    path = _checked_path(source)
    with h5py.File(path, "r") as f:
        return _read_group(f, gp, str(path))


def read_sea(
    source: str | Path | h5py.File, group: str = "/"
) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
    """The realised sea of a run (:meth:`RunWriter.write_sea`) as (arrays, attributes), or None
    for a run without waves; ``auvdock.world.waves.WaveComponents.from_arrays(*read_sea(...))``
    rebuilds it."""
    own = not isinstance(source, h5py.File)
    f = source if isinstance(source, h5py.File) else h5py.File(_checked_path(source), "r")
    try:
        g = f[_normalize_group(group)]
        if "sea" not in g:
            return None
        sg = g["sea"]
        arrays = {name: np.asarray(sg[name]) for name in sg}
        attrs: dict[str, Any] = {}
        for key, value in sg.attrs.items():
            v = _decode(value)
            if isinstance(v, str) and v[:1] in "[{":
                v = json.loads(v)
            attrs[key] = v
        return arrays, attrs
    finally:
        if own:
            f.close()


def open_format(path: str | Path, fmt: str, what: str) -> tuple[h5py.File, dict[str, Any]]:
    """Open an auvdock HDF5 file read-only and check its ``format`` attribute.

    Returns the open file and its attributes (bytes decoded).  ``what`` names the writer in
    the error, e.g. ``"campaign file (written by auvdock compare)"``.

    Raises
    ------
    ValueError
        ``<path>: not an HDF5 file (...)`` or ``<path>: not an auvdock <what>``.
    """
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise ValueError(f"{path}: not an HDF5 file ({e})") from None
    if f.attrs.get("format") != fmt:
        f.close()
        raise ValueError(f"{path}: not an auvdock {what}")
    return f, {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}


def _checked_path(source: str | Path) -> Path:
    """``source`` as a Path to an existing HDF5 file, else FileNotFoundError / ValueError."""
    path = Path(source)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such results file")
    if path.is_dir() or not h5py.is_hdf5(path):
        raise ValueError(f"{path}: not an auvdock results file (not an HDF5 file)")
    return path


def _read_group(f: h5py.File, gp: str, label: str) -> RunResults:
    def bad(why: str) -> ValueError:
        return ValueError(f"{label}: not an auvdock results file ({why})")

    if gp not in f:
        raise bad(f"no group {gp!r}")
    g = f[gp]
    if not isinstance(g, h5py.Group):
        raise bad(f"{gp!r} is not a group")
    fmt = _decode(g.attrs.get("format"))
    if fmt != FORMAT:
        runs = list_runs(f)
        hint = f"; run groups in this file: {', '.join(runs)}" if runs else ""
        raise bad(f"group {gp!r} has format={fmt!r}, expected {FORMAT!r}{hint}")
    version = _decode(g.attrs.get("format_version"))
    if not isinstance(version, int) or version > FORMAT_VERSION:
        raise ValueError(
            f"{label}: unsupported auvdock results format_version {version!r} "
            f"(this auvdock reads up to {FORMAT_VERSION})"
        )
    missing = [name for name in BASE_SERIES if not isinstance(g.get(name), h5py.Dataset)]
    if missing:
        raise bad(f"group {gp!r} lacks dataset(s) {', '.join(missing)}")
    datasets = {name: obj for name, obj in g.items() if isinstance(obj, h5py.Dataset) and obj.ndim >= 1}
    n = min(ds.shape[0] for ds in datasets.values())
    data = {name: ds[:n] for name, ds in datasets.items()}
    base = {name: data.pop(name) for name in BASE_SERIES}
    return RunResults(
        **base,
        extras=data,
        attrs=_decode_attrs(g.attrs),
        source=label,
        group=gp,
    )


def list_runs(path: str | Path | h5py.File) -> list[str]:
    """Group paths of all run groups in a file, sorted (``["/"]`` for a single-run file).

    A run group is any group whose ``format`` attribute is ``"auvdock-run"``.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If it is not an HDF5 file.
    """
    if isinstance(path, h5py.File | h5py.Group):
        return _list_runs(path.file)
    with h5py.File(_checked_path(path), "r") as f:
        return _list_runs(f)


def _list_runs(f: h5py.File) -> list[str]:
    found: list[str] = ["/"] if _is_run_group(f) else []

    def visit(name: str, obj: Any) -> None:
        if _is_run_group(obj):
            found.append("/" + name)

    f.visititems(visit)
    return sorted(found)
