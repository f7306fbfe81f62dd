"""Tests of auvdock.results.store: the HDF5 run store (writer, reader, crash safety)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
from datetime import datetime
from pathlib import Path

import h5py
import numpy as np
import pytest

import auvdock
from auvdock.controllers.status import STATUS_FAILED, STATUS_NAMES, STATUS_OK
from auvdock.results.store import (
    BASE_SERIES,
    FORMAT,
    RunWriter,
    list_runs,
    read_run,
)

MISSION_YAML = "name: unit\ndock:\n  position_ned_m: [10.0, 5.0, 2.0]\nnote: 'ünïcode ✓'\n"
EXTRAS = {"flow_estimate_m_s": (3,), "flow_covariance": (3, 3), "information": ()}
EXPECTED_SHAPES = {
    "time_s": (),
    "state": (12,),
    "thrust_N": (8,),
    "wrench": (6,),
    "flow_ned_m_s": (3,),
    "dock_position_m": (3,),
    "dock_velocity_m_s": (3,),
    "distance_m": (),
    "solve_time_s": (),
    "solver_status": (),
}


def make_row(k: int, extras: bool = False) -> dict:
    """A synthetic row whose values encode the step index k (so rows can be told apart)."""
    row = {
        "time_s": 0.1 * k,
        "state": np.arange(12.0) + 100.0 * k,
        "thrust_N": np.linspace(-5.0, 5.0, 8) + k,
        "wrench": np.arange(6.0) - k,
        "flow_ned_m_s": np.array([0.5, -0.25, 0.0]) * (k + 1),
        "dock_position_m": np.array([10.0, 5.0, 2.0 + 0.1 * k]),
        "dock_velocity_m_s": np.array([0.0, 0.0, 0.01 * k]),
        "distance_m": 20.0 - k,
        "solve_time_s": 0.001 * (k + 1),
        "solver_status": STATUS_OK if k % 2 == 0 else STATUS_FAILED,
    }
    if extras:
        row["flow_estimate_m_s"] = np.array([0.1, 0.2, 0.3]) * k
        row["flow_covariance"] = np.eye(3) * (k + 1)
        row["information"] = 2.0**k
    return row


def writer(target, group: str = "/", **kw) -> RunWriter:
    kw.setdefault("mission_yaml", MISSION_YAML)
    kw.setdefault("mission_name", "unit")
    kw.setdefault("controller", "oracle")
    return RunWriter(target, group, **kw)


OUTCOME = {
    "docked": True,
    "time_to_dock_s": 12.5,
    "contact_speed_m_s": 0.05,
    "heading_error_rad": None,
    "closest_approach_m": 0.02,
    "path_length_m": 30.0,
    "n_steps": 5,
    "solver_failures": 2,
    "wall_time_s": 1.5,
    "real_time_factor": 0.3,
    "reason": "docked",
}


def test_every_dataset_has_documented_shape_dtype_and_values(tmp_path: Path) -> None:
    path = tmp_path / "run.h5"
    rows = [make_row(k, extras=True) for k in range(5)]
    with writer(path, extra_series=EXTRAS) as w:
        for row in rows:
            w.append(**row)
        assert w.n_steps == 5
        w.finish(OUTCOME)

    with h5py.File(path, "r") as f:
        for name, shape in {**EXPECTED_SHAPES, **EXTRAS}.items():
            ds = f[name]
            assert ds.shape == (5, *shape), name
            assert ds.maxshape == (None, *shape), name
            assert ds.chunks is not None, name
            want = np.int8 if name == "solver_status" else np.float64
            assert ds.dtype == want, name
        assert set(f) == set(EXPECTED_SHAPES) | set(EXTRAS)

    r = read_run(path)
    assert r.n_steps == 5
    for name in BASE_SERIES:
        expected = np.stack([np.asarray(row[name]) for row in rows])
        np.testing.assert_array_equal(getattr(r, name), expected, err_msg=name)
    assert r.solver_status.dtype == np.int8
    assert set(r.extras) == set(EXTRAS)
    np.testing.assert_array_equal(r.extras["flow_covariance"][3], np.eye(3) * 4)
    np.testing.assert_array_equal(r.extras["information"], 2.0 ** np.arange(5))


def test_attrs_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "run.h5"
    with writer(path, mission_name="dock-east", controller="flow_mpc", attrs={"tolerance_m": 0.1}) as w:
        for k in range(3):
            w.append(**make_row(k))
        w.finish({**OUTCOME, "docked": False, "time_to_dock_s": None, "reason": None})

    r = read_run(path)
    a = r.attrs
    assert a["format"] == FORMAT == "auvdock-run"
    assert a["format_version"] == 1 and isinstance(a["format_version"], int)
    assert a["auvdock_version"] == auvdock.__version__
    created = datetime.fromisoformat(a["created_utc"])
    assert created.utcoffset() is not None and created.utcoffset().total_seconds() == 0
    assert r.mission_yaml == MISSION_YAML
    assert r.mission_name == a["mission_name"] == "dock-east"
    assert r.controller == "flow_mpc"
    assert a["tolerance_m"] == 0.1
    assert {int(k): v for k, v in json.loads(a["solver_status_codes"]).items()} == STATUS_NAMES
    assert STATUS_NAMES == {
        0: "ok",
        1: "not_converged",
        2: "failed",
        3: "fallback_zero",
        4: "no_step",
        5: "settling",
        6: "hold",
        7: "lost_target",
    }

    out = r.outcome()
    assert set(out) == set(OUTCOME)
    assert out["docked"] is False
    assert math.isnan(out["time_to_dock_s"])  # None -> NaN
    assert math.isnan(out["heading_error_rad"])
    assert out["reason"] == ""  # None -> "" for a string key
    assert out["n_steps"] == 5 and isinstance(out["n_steps"], int)
    assert out["solver_failures"] == 2
    assert out["wall_time_s"] == 1.5 and isinstance(out["wall_time_s"], float)
    for key, value in a.items():  # decoded to plain python, no numpy scalars or bytes
        assert not isinstance(value, np.generic | bytes), key


def test_complete_flag_false_until_finish(tmp_path: Path) -> None:
    path = tmp_path / "campaign.h5"
    with h5py.File(path, "w") as f:
        w = writer(f, "/runs/case1/oracle")
        for k in range(3):
            w.append(**make_row(k))
        mid = read_run(f, "/runs/case1/oracle")
        assert mid.complete is False
        assert mid.n_steps == 3
        assert mid.outcome() == {}
        w.finish(OUTCOME)
        w.close()
        assert f.id.valid, "a writer must not close a file it was given"
        assert read_run(f, "/runs/case1/oracle").complete is True
    assert read_run(path, "/runs/case1/oracle").complete is True

    # closed without finish(): stays incomplete
    path2 = tmp_path / "run.h5"
    w = writer(path2)
    w.append(**make_row(0))
    w.close()
    r = read_run(path2)
    assert r.complete is False and r.n_steps == 1


@pytest.mark.parametrize("flush_every", [1, 3])
def test_interrupted_context_manager_keeps_finished_steps(tmp_path: Path, flush_every: int) -> None:
    path = tmp_path / "run.h5"
    with pytest.raises(KeyboardInterrupt):
        with writer(path, extra_series=EXTRAS, flush_every=flush_every) as w:
            for k in range(10):
                if k == 4:
                    raise KeyboardInterrupt
                w.append(**make_row(k, extras=True))
    r = read_run(path)
    assert r.complete is False
    assert r.n_steps == 4
    np.testing.assert_allclose(r.time_s, 0.1 * np.arange(4))
    assert r.extras["flow_covariance"].shape == (4, 3, 3)


_CHILD = textwrap.dedent(
    """
    import os, sys
    sys.path.insert(0, {test_dir!r})
    from test_results import make_row, writer
    w = writer({path!r}, {group!r}, flush_every={flush_every})
    for k in range({k}):
        w.append(**make_row(k))
    os._exit(1)  # die without closing the file, like a kill -9
    """
)


@pytest.mark.parametrize(("group", "flush_every", "k", "expected"), [("/", 1, 5, 5), ("/runs/a/b", 2, 5, 4)])
def test_file_readable_after_writer_process_dies(
    tmp_path: Path, group: str, flush_every: int, k: int, expected: int
) -> None:
    path = tmp_path / "killed.h5"
    code = _CHILD.format(
        test_dir=str(Path(__file__).parent), path=str(path), group=group, flush_every=flush_every, k=k
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1, proc.stderr
    r = read_run(path, group)
    assert r.complete is False
    assert r.n_steps == expected  # every flushed step; with flush_every=2 the 5th is still buffered
    np.testing.assert_allclose(r.time_s, 0.1 * np.arange(expected))
    np.testing.assert_array_equal(r.state[-1], np.arange(12.0) + 100.0 * (expected - 1))
    assert list_runs(path) == [group]


def test_wrong_row_shape_names_the_dataset(tmp_path: Path) -> None:
    with writer(tmp_path / "run.h5", extra_series=EXTRAS) as w:
        w.append(**make_row(0, extras=True))
        bad = make_row(1, extras=True)
        bad["state"] = np.zeros(11)
        with pytest.raises(ValueError, match=r"state.*\(12,\).*\(11,\)"):
            w.append(**bad)
        bad = make_row(1, extras=True)
        bad["flow_covariance"] = np.zeros(9)
        with pytest.raises(ValueError, match="flow_covariance"):
            w.append(**bad)
        bad = make_row(1, extras=True)
        bad["time_s"] = [0.1]
        with pytest.raises(ValueError, match="time_s"):
            w.append(**bad)
        bad = make_row(1, extras=True)
        del bad["dock_velocity_m_s"]
        with pytest.raises(ValueError, match="dock_velocity_m_s"):
            w.append(**bad)
        with pytest.raises(ValueError, match="information"):  # declared extra is required
            w.append(**make_row(1))
        with pytest.raises(ValueError, match="bogus"):
            w.append(**make_row(1, extras=True), bogus=1.0)
        with pytest.raises(ValueError, match="solver_status"):
            w.append(**{**make_row(1, extras=True), "solver_status": "exploded"})
        assert w.n_steps == 1  # failed appends add nothing
        w.append(**{**make_row(1, extras=True), "solver_status": "fallback_zero"})
    r = read_run(tmp_path / "run.h5")
    assert r.n_steps == 2
    assert r.solver_status.tolist() == [0, 3]


def test_two_runs_in_one_campaign_file(tmp_path: Path) -> None:
    path = tmp_path / "campaign.h5"
    for group, controller, n in [("/runs/case1/oracle", "oracle", 3), ("runs/case2/naive", "naive", 4)]:
        with writer(path, group, controller=controller) as w:  # reopening must keep the other run
            for k in range(n):
                w.append(**make_row(k))
            w.finish({"docked": controller == "oracle"})
    assert list_runs(path) == ["/runs/case1/oracle", "/runs/case2/naive"]
    oracle = read_run(path, "/runs/case1/oracle")
    naive = read_run(path, "/runs/case2/naive")
    assert (oracle.controller, oracle.n_steps, oracle.outcome()["docked"]) == ("oracle", 3, True)
    assert (naive.controller, naive.n_steps, naive.outcome()["docked"]) == ("naive", 4, False)

    # overwrite replaces one run only; refusing to overwrite raises
    with writer(path, "/runs/case2/naive", controller="naive") as w:
        w.append(**make_row(0))
    assert read_run(path, "/runs/case2/naive").n_steps == 1
    assert read_run(path, "/runs/case1/oracle").n_steps == 3
    with pytest.raises(FileExistsError):
        writer(path, "/runs/case1/oracle", overwrite=False)
    # a single run at "/" must not wipe a campaign file
    with pytest.raises(FileExistsError, match="campaign"):
        writer(path, "/")
    assert list_runs(path) == ["/runs/case1/oracle", "/runs/case2/naive"]
    # the root of a campaign file is not a run; the error points at the runs
    with pytest.raises(ValueError, match="not an auvdock results file.*runs/case1/oracle"):
        read_run(path)


def test_single_run_file_is_listed_and_overwritten(tmp_path: Path) -> None:
    path = tmp_path / "run.h5"
    with writer(path) as w:
        for k in range(4):
            w.append(**make_row(k))
    assert list_runs(path) == ["/"]
    with writer(path, controller="second") as w:
        w.append(**make_row(0))
    r = read_run(path)
    assert (r.controller, r.n_steps) == ("second", 1)


def test_read_non_auvdock_files_raises_value_error(tmp_path: Path) -> None:
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = np.arange(3)
        f.attrs["format"] = "something-else"
    with pytest.raises(ValueError, match=r"other\.h5: not an auvdock results file \("):
        read_run(other)
    with pytest.raises(ValueError, match="not an auvdock results file.*no group"):
        read_run(other, "/runs/missing")
    text = tmp_path / "mission.yaml"
    text.write_text(MISSION_YAML)
    with pytest.raises(ValueError, match=r"mission\.yaml: not an auvdock results file"):
        read_run(text)
    with pytest.raises(FileExistsError):  # the writer never clobbers a non-HDF5 file
        writer(text)
    assert text.read_text() == MISSION_YAML
    assert list_runs(other) == []
    with pytest.raises(FileNotFoundError):
        read_run(tmp_path / "nope.h5")


def test_writer_rejects_misuse(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="flush_every"):
        writer(tmp_path / "a.h5", flush_every=0)
    with pytest.raises(ValueError, match="state"):
        writer(tmp_path / "b.h5", extra_series={"state": (12,)})
    with pytest.raises(ValueError, match="complete"):
        writer(tmp_path / "c.h5", attrs={"complete": True})
    w = writer(tmp_path / "d.h5")
    w.append(**make_row(0))
    with pytest.raises(ValueError, match="format"):
        w.finish({"format": "x"})
    with pytest.raises(TypeError, match="weird"):
        w.finish({"weird": {"a": 1}})
    w.finish({"docked": False})
    with pytest.raises(RuntimeError, match="finished"):
        w.append(**make_row(1))
    w.close()
    w.close()  # idempotent
    with pytest.raises(RuntimeError, match="closed"):
        w.finish({})
    with h5py.File(tmp_path / "d.h5", "r") as f, pytest.raises(ValueError, match="not writable"):
        writer(f, "/runs/x")


def test_rows_are_copied_at_append(tmp_path: Path) -> None:
    path = tmp_path / "run.h5"
    with writer(path, flush_every=10) as w:
        row = make_row(0)
        w.append(**row)
        row["state"][:] = -1.0  # caller reuses its buffer before the writer flushes
    np.testing.assert_array_equal(read_run(path).state[0], np.arange(12.0))
