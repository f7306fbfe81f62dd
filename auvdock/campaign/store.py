"""The results file of a campaign or sweep: one HDF5 layout for both.

::

    /                   attrs: format = "auvdock-campaign", format_version = 2,
                               kind ("compare" or "sweep"), auvdock_version, created_utc,
                               command_line (and resumed_with), machine (JSON), executor,
                               workers, total_runs, plan (JSON list of the run ids in
                               order), wall_time_s (summed over resumes), and the plan's
                               own attributes (a sweep: sweep_name, sweep_yaml, varied, ...;
                               lists and dicts as JSON text, named in json_attrs)
    /campaign_table     compound dataset, one row per run that ended (done or failed),
                        in the order they ended; attrs: columns (JSON name -> kind)
    /runs/...           run groups in the layout of ``auvdock sim`` (:mod:`auvdock.results.store`):
                        ``/runs/<case>/<controller>`` (compare), ``/runs/<run id>`` (a sweep
                        with --trajectories)

Only the driver process writes the file: a row (and its run group, copied from the file
image the worker returned) is written and the file flushed as each run ends, with SIGINT
held back for the few milliseconds of the write, so a Ctrl-C or a crash of the driver
leaves a readable file with every run that ended.  A run written again (a failed run
retried by ``--resume``) replaces its row.

An existing file is never replaced silently: :class:`ResultsStore` raises
:class:`ResultsFileError` unless the caller resumes or forces.
"""

from __future__ import annotations

import datetime as _dt
import io
import json
import math
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from auvdock._version import __version__
from auvdock.campaign.spec import Plan, RunSpec
from auvdock.results.store import list_runs, open_format, read_run
from auvdock.runtime.interrupts import SigintDeferred

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "TABLE",
    "ResultsFileError",
    "check_output",
    "check_resume",
    "ResultsStore",
    "read_results",
    "read_run_groups",
]

FORMAT = "auvdock-campaign"
FORMAT_VERSION = 2
TABLE = "campaign_table"
_WHAT = {"compare": "campaign", "sweep": "sweep"}


class ResultsFileError(ValueError):
    """The output file is already there, or cannot be used; ``str(err)`` is the one line to show."""


def check_output(path: str | Path, kind: str, *, resume: bool = False, force: bool = False) -> bool:
    """Whether ``path`` holds results to resume or replace; raise if it may not be used.

    Returns False when there is no file (start a new one), True when there is an auvdock
    results file and ``resume`` or ``force`` says what to do with it.

    Raises
    ------
    ResultsFileError
        ``<path>: a campaign is already there; use --resume to continue it or --force to
        start again`` (``a sweep`` for kind "sweep") when neither is given; or the file is
        not an auvdock results file (never overwritten, even with ``force``).
    """
    path = Path(path)
    if resume and force:
        raise ResultsFileError("--resume and --force: give one of them")
    if not path.exists():
        return False
    try:
        with h5py.File(path, "r") as f:
            fmt = _attr(f.attrs.get("format"))
    except OSError as e:
        raise ResultsFileError(
            f"{path}: exists and is not a readable HDF5 file ({e}); not overwriting it"
        ) from None
    if fmt != FORMAT:
        raise ResultsFileError(f"{path}: exists and is not an auvdock results file; not overwriting it")
    if not resume and not force:
        raise ResultsFileError(
            f"{path}: a {_WHAT.get(kind, kind)} is already there; use --resume to continue it or --force to "
            "start again"
        )
    return True


def _made_with(f: h5py.File, attr: str, column: str) -> list[str] | None:
    """The values of list attribute ``attr`` a results file was made with; for a file written
    before it was recorded, the distinct values of its table's ``column``; None if neither."""
    raw = f.attrs.get(attr)
    if raw is not None:
        try:
            return [str(v) for v in json.loads(_attr(raw))]
        except (TypeError, ValueError):
            return None
    if TABLE not in f or column not in (f[TABLE].dtype.names or ()):
        return None
    return list(dict.fromkeys(_decode("str", v) for v in f[TABLE][column][()]))


def _resume_mismatch(f: h5py.File, path: Path, plan: Plan) -> str | None:
    """The one line that refuses resuming ``f`` with ``plan`` (other values of an attribute of
    ``plan.same_on_resume``), or None."""
    differ = []  # (attribute, the file's values, this plan's values)
    for attr, column in plan.same_on_resume.items():
        old = _made_with(f, attr, column)
        new = [str(v) for v in plan.attrs.get(attr, [])]
        if old is not None and set(old) != set(new):
            differ.append((attr, ",".join(old) or "none", ",".join(new) or "none"))
    if not differ:
        return None
    was = " and ".join(f"{attr} {old}" for attr, old, _ in differ)
    # one difference: "this run asks for oracle"; two: "... asks for missions still and controllers oracle"
    asks = differ[0][2] if len(differ) == 1 else " and ".join(f"{attr} {new}" for attr, _, new in differ)
    where = f"{path.parent}/" if path.name in ("campaign.h5", "sweep.h5") else str(path)
    return f"--resume: {where} was made with {was}; this run asks for {asks}"


def check_resume(path: str | Path, plan: Plan) -> None:
    """Raise :class:`ResultsFileError` if resuming the results file ``path`` with ``plan`` would mix
    two campaigns: the file was made with other values of an attribute of ``plan.same_on_resume``
    (a compare campaign: other missions or other controllers).  One line, naming what differs::

        --resume: out/ was made with controllers oracle,sequential; this run asks for oracle

    A missing or unreadable file passes (:func:`check_output` says what is wrong with it).
    """
    path = Path(path)
    if not plan.same_on_resume or not path.is_file():
        return
    try:
        with h5py.File(path, "r") as f:
            problem = _resume_mismatch(f, path, plan)
    except OSError:
        return
    if problem is not None:
        raise ResultsFileError(problem)


def _dtype(columns: dict[str, str]) -> np.dtype:
    kinds = {"str": h5py.string_dtype(), "bool": np.bool_, "int": np.int64, "float": np.float64}
    return np.dtype([(name, kinds[kind]) for name, kind in columns.items()])


def _cell(kind: str, v: Any) -> Any:
    if kind == "str":
        if v is None:
            return ""
        return v if isinstance(v, str) else json.dumps(v)
    if kind == "bool":
        return bool(v)
    if kind == "int":
        try:
            return int(v)
        except (TypeError, ValueError, OverflowError):
            return 0
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _decode(kind: str, v: Any) -> Any:
    if kind == "str":
        return v.decode() if isinstance(v, bytes) else str(v)
    if kind == "bool":
        return bool(v)
    if kind == "int":
        return int(v)
    return float(v)


def _attr(v: Any) -> Any:
    return v.decode() if isinstance(v, bytes) else v


class ResultsStore:
    """The driver's handle on a results file.

    Parameters
    ----------
    path : Path
        The file (``campaign.h5`` / ``sweep.h5``).
    plan : Plan
        What will run (its kind, columns and attributes are recorded).
    resume : bool
        Continue the file that is there: its rows stay; :meth:`done` says which runs to skip.
    force : bool
        Start again: an existing results file of ours is deleted.

    Raises
    ------
    ResultsFileError
        The file exists and neither ``resume`` nor ``force`` is given; or it is not an
        auvdock results file (never overwritten, even with ``force``); or it holds the
        other kind of results, or a table with other columns.
    """

    def __init__(
        self,
        path: str | Path,
        plan: Plan,
        *,
        resume: bool = False,
        force: bool = False,
    ) -> None:
        self.path = Path(path)
        self.plan = plan
        self.columns = plan.columns
        what = _WHAT.get(plan.kind, plan.kind)
        f: h5py.File | None = None
        if check_output(self.path, plan.kind, resume=resume, force=force):
            if force:
                self.path.unlink()
            else:
                f = h5py.File(self.path, "r+")
            if f is not None and _attr(f.attrs.get("kind", "")) != plan.kind:
                kind = _attr(f.attrs.get("kind", ""))
                f.close()
                raise ResultsFileError(
                    f"{self.path}: holds auvdock {kind} results, not a {what}; use another --out or --force"
                )
            if f is not None and json.loads(f[TABLE].attrs.get("columns", "{}")) != self.columns:
                f.close()
                raise ResultsFileError(
                    f"{self.path}: was written by a different {what} (its table columns differ); use "
                    "another --out or --force"
                )
            if f is not None and (problem := _resume_mismatch(f, self.path, plan)) is not None:
                f.close()
                raise ResultsFileError(problem)
        if f is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            f = h5py.File(self.path, "w")
            a = f.attrs
            a["format"] = FORMAT
            a["format_version"] = np.int64(FORMAT_VERSION)
            a["kind"] = plan.kind
            a["created_utc"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
            a["wall_time_s"] = 0.0
            ds = f.create_dataset(
                TABLE, shape=(0,), maxshape=(None,), dtype=_dtype(self.columns), chunks=(64,)
            )
            ds.attrs["columns"] = json.dumps(self.columns)
            ds.attrs["units"] = "s, m, m/s as in the column names; NaN where not applicable"
            f.require_group("runs")
        self.f = f
        self.table = f[TABLE]
        self.index: dict[str, int] = {}
        for i, rid in enumerate(self.table["run_id"][()]):
            self.index[_decode("str", rid)] = i

    def begin(
        self, *, command_line: str = "", executor: str = "", workers: int = 0, resume: bool = False
    ) -> None:
        """Record this session: command line (``resumed_with`` when resuming), machine, executor, plan."""
        from auvdock.campaign.machine import machine_info

        a = self.f.attrs
        if resume and "command_line" in a:
            a["resumed_with"] = command_line
        else:
            a["command_line"] = command_line
        a["auvdock_version"] = str(__version__)
        a["machine"] = json.dumps(machine_info())
        a["executor"] = executor
        a["workers"] = np.int64(workers)
        old_plan = json.loads(_attr(a.get("plan", "[]")))
        ids = [s.run_id for s in self.plan.specs]
        known = set(ids)
        a["plan"] = json.dumps(ids + [i for i in old_plan if i not in known])
        a["total_runs"] = np.int64(len(self.plan.specs))
        json_attrs = []
        for k, v in self.plan.attrs.items():
            if isinstance(v, list | dict):
                v = json.dumps(v)
                json_attrs.append(k)
            a[k] = v
        a["json_attrs"] = json.dumps(json_attrs)
        self.f.flush()

    # -- reading ------------------------------------------------------------------

    def row(self, run_id: str) -> dict[str, Any]:
        rec = self.table[self.index[run_id]]
        return {name: _decode(kind, rec[name]) for name, kind in self.columns.items()}

    def done(self, spec: RunSpec) -> bool:
        """True if ``spec`` is in the file as done, made from the same spec, with its run group.

        Raises
        ------
        ResultsFileError
            The file holds this run id made from another spec (other mission, seed, timeout
            or model error): resuming would mix two campaigns.
        """
        if spec.run_id not in self.index:
            return False
        row = self.row(spec.run_id)
        if row["spec_sha"] != spec.sha:
            what = _WHAT.get(self.plan.kind, self.plan.kind)
            raise ResultsFileError(
                f"{self.path}: run {spec.run_id} there was made with other settings than this {what} "
                "gives (mission, seed, timeout or model error); use another --out or --force"
            )
        if row["status"] != "done":
            return False
        if spec.group is not None:
            g = self.f.get(spec.group)
            if g is None or not bool(g.attrs.get("complete", False)):
                return False
        return True

    # -- writing ------------------------------------------------------------------

    def put(self, row: dict[str, Any], image: bytes | None, group: str | None) -> None:
        """Write one run: its run group (from the worker's file image) first, then its row; flush."""
        from auvdock.campaign.worker import RUN_GROUP

        with SigintDeferred():
            if group is not None:
                if group in self.f:
                    del self.f[group]
                if image is not None:
                    parent, _, name = group.rstrip("/").rpartition("/")
                    with h5py.File(io.BytesIO(image), "r") as src:
                        src.copy(src[RUN_GROUP], self.f.require_group(parent or "/"), name=name)
            arr = np.zeros(1, dtype=self.table.dtype)
            for name, kind in self.columns.items():
                arr[name][0] = _cell(kind, row.get(name))
            rid = str(row["run_id"])
            i = self.index.get(rid)
            if i is None:
                i = self.table.shape[0]
                self.table.resize((i + 1,))
                self.index[rid] = i
            self.table[i : i + 1] = arr
            self.f.flush()

    def close(self, wall_time_s: float) -> None:
        """Add this session's wall time and close the file."""
        if not self.f.id.valid:
            return
        with SigintDeferred():
            try:
                self.f.attrs["wall_time_s"] = float(self.f.attrs.get("wall_time_s", 0.0)) + float(wall_time_s)
                self.f.flush()
            finally:
                self.f.close()


def read_results(path: str | Path, kind: str | None = None) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The run table (rows in plan order) and the file's attributes of a results file.

    ``attrs["columns"]`` is the table's columns (name -> kind), ``attrs["plan"]`` the run
    ids in order; the plan's list and dict attributes (stored as JSON) are decoded.
    ``kind`` ("compare" or "sweep") checks the kind.

    Raises
    ------
    ValueError
        ``<path>: not an auvdock ...`` if the file is not a results file (of that kind).
    """
    what = {
        None: "campaign or sweep file (written by auvdock compare or auvdock sweep)",
        "compare": "campaign file (written by auvdock compare)",
        "sweep": "sweep file (written by auvdock sweep)",
    }[kind]
    f, attrs = open_format(path, FORMAT, what)
    with f:
        version = int(attrs.get("format_version", 0))
        if version != FORMAT_VERSION or TABLE not in f:
            raise ValueError(
                f"{path}: an auvdock results file of format version {version}; this auvdock reads version "
                f"{FORMAT_VERSION} (run the campaign again)"
            )
        if kind is not None and attrs.get("kind") != kind:
            raise ValueError(f"{path}: not an auvdock {what}")
        ds = f[TABLE]
        columns = json.loads(_attr(ds.attrs["columns"]))
        arr = ds[()]
    rows = [{name: _decode(kind_, rec[name]) for name, kind_ in columns.items()} for rec in arr]
    order = {rid: i for i, rid in enumerate(json.loads(attrs.get("plan", "[]")))}
    rows.sort(key=lambda r: order.get(r["run_id"], len(order)))
    for k in json.loads(attrs.pop("json_attrs", "[]")):
        attrs[k] = json.loads(attrs[k])
    attrs["columns"] = columns
    attrs["plan"] = list(order)
    return rows, attrs


def read_run_groups(path: str | Path) -> dict[str, Any]:
    """Every run group of a results file, read into memory: group path (without ``/runs/``) -> RunResults."""
    out = {}
    with h5py.File(path, "r") as f:
        for g in list_runs(f):
            if g.startswith("/runs/"):
                out[g[len("/runs/") :]] = read_run(f, g)
    return out
