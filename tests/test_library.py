"""The library a researcher uses from a notebook: auvdock.simulate, load_mission, Run, MemoryRecorder."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

import auvdock
from auvdock import api
from auvdock.config.mission import MissionError
from auvdock.results.run import STATE_COMPONENTS, MemoryRecorder, Run
from auvdock.results.store import RunWriter, list_runs, read_run

ROOT = Path(__file__).resolve().parents[1]
SHORT_S = 0.5  # simulated seconds of the shared run: 10 control steps and the final row


@pytest.fixture(scope="module")
def short_run() -> Run:
    """One short run of the FSE controller (extra series: flow estimate, covariance, ...)."""
    return auvdock.simulate("gyre", "sequential", docking__timeout_s=SHORT_S)


@pytest.fixture
def mission_of(monkeypatch: pytest.MonkeyPatch) -> list:
    """simulate() returns the mission it would fly instead of flying it (no closed loop)."""
    flown: list = []

    def fake(mission):
        flown.append(mission)
        return mission

    monkeypatch.setattr(api, "_run", fake)
    return flown


# ----------------------------------------------------------------------------- simulate


def test_simulate_by_name_path_and_mission() -> None:
    by_name = auvdock.simulate("tank_0p6hz", docking__timeout_s=0.2)
    assert isinstance(by_name, Run)
    assert by_name.mission_name == "tank_0p6hz" and by_name.controller == "oracle"
    assert by_name.complete and by_name.outcome["reason"] == "timeout"
    assert by_name.n_steps == 5 and math.isclose(by_name.time_s[-1], 0.2)
    assert by_name.source == ""  # held in memory: no file behind it

    by_path = auvdock.simulate(ROOT / "missions" / "gyre.yaml", docking__timeout_s=0.1)
    assert by_path.mission_name == "gyre" and by_path.n_steps == 3

    m = auvdock.load_mission("still")
    by_mission = auvdock.simulate(m, "naive", docking__timeout_s=0.1)
    assert by_mission.mission_name == "still" and by_mission.controller == "naive"
    assert m.controller.type == "oracle" and m.docking.timeout_s == 75.0  # the given mission is unchanged
    flown = yaml.safe_load(by_mission.mission_yaml)
    assert flown["controller"]["type"] == "naive" and flown["docking"]["timeout_s"] == 0.1
    assert by_mission.attrs["timeout_s"] == 0.1 and by_mission.attrs["dt_s"] == 0.05


def test_simulate_takes_mission_data(mission_of: list) -> None:
    auvdock.simulate({"name": "mine", "flow": {"case": "case2"}}, seed=4)
    assert mission_of[-1].name == "mine" and mission_of[-1].flow.case == "case2" and mission_of[-1].seed == 4
    with pytest.raises(TypeError, match="mission must be"):
        auvdock.simulate(42)


def test_nested_overrides_three_spellings_agree(mission_of: list) -> None:
    auvdock.simulate("gyre", docking__timeout_s=20, dock__heave__amplitude_m=0.2)
    auvdock.simulate("gyre", docking={"timeout_s": 20}, dock={"heave": {"amplitude_m": 0.2}})
    auvdock.simulate("gyre", **{"docking.timeout_s": 20, "dock.heave.amplitude_m": 0.2})
    a, b, c = (m.resolved() for m in mission_of)
    assert a == b == c
    docking = {k: a["docking"][k] for k in ("tolerance_m", "timeout_s", "criterion")}
    assert docking == {"tolerance_m": 0.05, "timeout_s": 20.0, "criterion": "point"}  # the rest kept
    assert a["dock"]["heave"]["angular_frequency_rad_s"] == 0.1 and a["dock"]["position_ned_m"] == [2, 3, 5]


def test_overrides_controller_lists_and_numpy(mission_of: list) -> None:
    auvdock.simulate("gyre", "optimized", controller__alpha=2e-3)
    m = mission_of[-1]
    assert m.controller.type == "optimized" and m.controller.alpha == 2e-3
    assert m.controller.horizon_steps == 10  # the mission's shared settings kept
    auvdock.simulate("gyre", controller={"type": "sequential", "horizon_steps": 12})
    assert mission_of[-1].controller.type == "sequential" and mission_of[-1].controller.horizon_steps == 12
    auvdock.simulate("gyre", "oracle@paper")
    assert mission_of[-1].controller.variant == "paper"
    auvdock.simulate("gyre", dock__position_ned_m__2=np.float64(6.0), start__state=np.zeros(12))
    assert mission_of[-1].dock.position_ned_m == [2.0, 3.0, 6.0] and mission_of[-1].start.state == [0.0] * 12


def test_overrides_clear_the_alternative_field(mission_of: list) -> None:
    # tank_0p6hz gives frequency_hz; its resolved form holds angular_frequency_rad_s as well
    auvdock.simulate("tank_0p6hz", dock__heave__frequency_hz=0.8)
    assert math.isclose(mission_of[-1].dock.heave.angular_frequency_rad_s, 2 * math.pi * 0.8)
    auvdock.simulate("gyre", flow={"type": "constant", "velocity_ned_m_s": [0.3, 0.0]})
    assert mission_of[-1].flow.case is None and mission_of[-1].flow.type == "constant"


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        (
            {"docking__tolerence_m": 0.1},
            "simulate: docking.tolerence_m: no such field (did you mean tolerance_m?)",
        ),
        (
            {"docking": {"tolerence_m": 0.1}},
            "simulate: docking.tolerence_m: no such field (did you mean tolerance_m?)",
        ),
        ({"sed": 3}, "simulate: sed: no such field (did you mean seed?)"),
        ({"docking__timeout_s": -1}, "simulate: docking.timeout_s: input should be greater than 0 (got -1)"),
        ({"seed__x": 1}, "simulate: seed.x: seed is a value, not a section: set it whole"),
        (
            {"dock__position_ned_m__3": 1.0},
            "simulate: dock.position_ned_m.3: no such element (dock.position_ned_m has 3: 0..2)",
        ),
        (
            {"controller__alpha": 1e-3},
            "simulate: controller.alpha: no such field for controller type oracle "
            "(a setting of optimized: set controller.type too)",
        ),
        (
            {"controller": "nope"},
            "simulate: controller.type: unknown controller 'nope' "
            "(known: naive, kinematic, oracle, sequential, optimized, ce)",
        ),
    ],
    ids=[
        "typo",
        "typo-in-mapping",
        "top-level-typo",
        "bad-value",
        "not-a-section",
        "index",
        "other-type",
        "controller",
    ],
)
def test_override_errors_are_one_mission_error(mission_of: list, overrides: dict, message: str) -> None:
    with pytest.raises(MissionError) as ei:
        auvdock.simulate("gyre", **overrides)
    assert type(ei.value) is MissionError  # not a raw pydantic ValidationError
    assert str(ei.value) == message
    assert ei.value.file == "simulate"
    assert not mission_of  # nothing ran


def test_with_updates_error_names_the_mission_file() -> None:
    m = auvdock.load_mission("gyre")
    with pytest.raises(MissionError) as ei:
        m.with_updates(docking__tolerence_m=0.1)
    assert str(ei.value) == f"{m.source}: docking.tolerence_m: no such field (did you mean tolerance_m?)"
    with pytest.raises(MissionError, match=r"^<mission>: vehicle\.overrides\.mass_kgg: "):
        auvdock.Mission(name="x").with_updates({"vehicle.overrides": {"mass_kgg": 3.0}})


# ----------------------------------------------------------------------------- load_mission


def test_load_mission_names_paths_and_unknown_names(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from auvdock.config.mission import load_mission

    assert auvdock.load_mission("gyre").name == "gyre"
    assert load_mission("gyre").name == "gyre"  # the config-level function takes names too
    assert load_mission("tank_0p6hz.yaml").name == "tank_0p6hz"
    assert load_mission(ROOT / "missions" / "south.yaml").name == "south"
    with pytest.raises(MissionError) as ei:
        load_mission("no_such_mission")
    assert str(ei.value).startswith(
        "no_such_mission: file not found, nor a shipped mission (shipped: basin_regular, diagonal,"
    )
    assert "gyre" in str(ei.value)
    with pytest.raises(MissionError, match="nope.yaml: file not found$"):
        load_mission(tmp_path / "nope.yaml")
    monkeypatch.chdir(tmp_path)  # an existing file wins over a shipped name
    Path("gyre").write_text("name: mine\n")
    assert auvdock.load_mission("gyre").name == "mine"


def test_import_auvdock_is_light() -> None:
    code = (
        "import sys, auvdock\n"
        "heavy = [m for m in ('pandas', 'xarray', 'casadi', 'h5py', 'pydantic') if m in sys.modules]\n"
        "print(heavy)\n"
        "print(auvdock.simulate.__module__, auvdock.Run.__module__, auvdock.Mission.__name__)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == ["[]", "auvdock.api auvdock.results.run Mission"]
    assert {"simulate", "load_mission", "Run", "Mission", "MissionError"} <= set(dir(auvdock))
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        auvdock.nothing  # noqa: B018


# ----------------------------------------------------------------------------- Run


def test_run_arrays_and_repr(short_run: Run) -> None:
    r = short_run
    n = r.n_steps
    assert n == 11 and r.time_s.shape == (n,) and r.state.shape == (n, 12)
    assert r.thrust_N.shape == (n, 8) and r.wrench.shape == (n, 6) and r.flow_ned_m_s.shape == (n, 3)
    assert r.dock_position_m.shape == (n, 3) and r.dock_velocity_m_s.shape == (n, 3)
    assert r.distance_m.shape == r.solve_time_s.shape == r.solver_status.shape == (n,)
    assert r.extras["flow_covariance"].shape == (n, 3, 3)
    assert r.flow_estimate_m_s is r.extras["flow_estimate_m_s"] and r["information"].shape == (n,)
    assert list(r.status[-2:]) == ["ok", "no_step"] and r.control_rows().sum() == n - 1
    assert r.outcome["n_steps"] == 10 and r.outcome["docked"] is False and r.events == []
    assert r.attrs["tolerance_m"] == 0.05 and r.mission().name == "gyre"
    text = repr(r)
    assert text == "Run(mission='gyre', controller='sequential', not docked (timeout, closest " + (
        f"{r.outcome['closest_approach_m']:.3f} m), 11 steps)"
    )
    assert str(r) == text and len(text) < 120 and "array" not in text
    with pytest.raises(KeyError, match="no series 'nope'"):
        r["nope"]
    with pytest.raises(AttributeError):
        r.nope  # noqa: B018


def test_repr_of_a_docked_and_an_unfinished_run() -> None:
    rec = MemoryRecorder(mission_yaml="name: m\n", mission_name="m", controller="oracle", n_thrusters=8)
    assert repr(rec.run()) == "Run(mission='m', controller='oracle', unfinished, 0 steps)"
    rec.finish({"docked": True, "time_to_dock_s": 41.234})
    assert repr(rec.run()) == "Run(mission='m', controller='oracle', docked at 41.23 s, 0 steps)"


def test_to_xarray_dims_coords_units(short_run: Run) -> None:
    ds = short_run.to_xarray()
    assert ds.sizes["time_s"] == 11
    np.testing.assert_array_equal(ds["time_s"].values, short_run.time_s)
    assert ds["time_s"].attrs["units"] == "s"
    # state and wrench split by unit (tests/test_library_views.py checks every unit)
    assert ds["position"].dims == ("time_s", "ned") and ds["velocity"].dims == ("time_s", "body")
    np.testing.assert_array_equal(ds["position"].sel(ned="down").values, short_run.state[:, 2])
    assert [ds[n].attrs["units"] for n in ("position", "attitude", "velocity", "angular_rate")] == [
        "m",
        "rad",
        "m/s",
        "rad/s",
    ]
    assert ds["thrust_N"].dims == ("time_s", "thruster") and list(ds["thruster"].values)[:2] == ["T1", "T2"]
    assert ds["moment"].dims == ("time_s", "moment_component") and ds["moment"].attrs["units"] == "N m"
    assert ds["flow_ned_m_s"].dims == ("time_s", "ned") and list(ds["ned"].values) == [
        "north",
        "east",
        "down",
    ]
    assert ds["flow_covariance"].dims == ("time_s", "body_i", "body_j")
    assert ds["flow_estimate_m_s"].attrs["frame"] == "body {b}"
    expected_units = {
        "thrust_N": "N",
        "flow_ned_m_s": "m/s",
        "dock_position_m": "m",
        "dock_velocity_m_s": "m/s",
        "distance_m": "m",
        "solve_time_s": "s",
        "flow_estimate_m_s": "m/s",
        "flow_covariance": "m^2/s^2",
    }
    for name, unit in expected_units.items():
        assert ds[name].attrs["units"] == unit, name
    assert all("units" in ds[name].attrs for name in ds.data_vars if name != "solver_status")
    assert ds["solver_status"].attrs["flag_meanings"].split()[:2] == ["ok", "not_converged"]
    assert ds.attrs["mission_name"] == "gyre" and ds.attrs["controller"] == "sequential"
    assert ds.attrs["docked"] == 0 and ds.attrs["tolerance_m"] == 0.05 and "mission_yaml" in ds.attrs


def test_to_dataframe_columns(short_run: Run) -> None:
    df = short_run.to_dataframe()
    assert df.index.name == "time_s" and len(df) == 11
    cols = list(df.columns)
    assert cols[:12] == [f"state.{c}" for c in STATE_COMPONENTS]
    for col in (
        "thrust_N.T1",
        "thrust_N.T8",
        "wrench.X",
        "wrench.N",
        "flow_ned_m_s.north",
        "dock_position_m.down",
        "dock_velocity_m_s.east",
        "distance_m",
        "solve_time_s",
        "solver_status",
        "status",
        "flow_covariance.u.v",
        "flow_estimate_m_s.w",
        "information",
        "innovation.depth_rate",
    ):
        assert col in cols, col
    assert "thrust_N.T9" not in cols
    np.testing.assert_array_equal(df["state.psi"].to_numpy(), short_run.state[:, 5])
    np.testing.assert_array_equal(
        df["flow_covariance.u.v"].to_numpy(), short_run.extras["flow_covariance"][:, 0, 1]
    )
    assert df.attrs["units"]["state.u"] == "m/s" and df.attrs["units"]["wrench.K"] == "N m"
    assert df["status"].iloc[-1] == "no_step" and df.attrs["outcome"]["reason"] == "timeout"


def test_save_reads_back_equal(short_run: Run, tmp_path: Path) -> None:
    path = short_run.save(tmp_path / "sub" / "run.h5")
    back = Run.from_file(path)
    assert back.equals(short_run)
    assert back.source == f"{path}:/"
    results = read_run(path)  # what auvdock plot reads
    np.testing.assert_array_equal(results.state, short_run.state)
    assert results.complete and results.controller == "sequential" and results.outcome()["n_steps"] == 10
    assert set(results.extras) == set(short_run.extras)
    # a campaign-style group of a shared file
    short_run.save(tmp_path / "many.h5", "/runs/gyre/sequential")
    assert list_runs(tmp_path / "many.h5") == ["/runs/gyre/sequential"]
    assert Run.from_file(tmp_path / "many.h5", group="/runs/gyre/sequential").equals(short_run)
    # one thing differs: not equal
    other = Run.from_file(path)
    other.state[3, 0] += 1e-9
    assert not other.equals(short_run)


def test_saved_run_plots(short_run: Run, tmp_path: Path) -> None:
    from auvdock.results.plots import plot_run

    pngs = plot_run(Run.from_file(short_run.save(tmp_path / "run.h5")).to_results(), tmp_path)
    assert pngs and all(Path(p).stat().st_size > 1000 for p in pngs)


# ----------------------------------------------------------------------------- MemoryRecorder


def _rows(run: Run):
    series = run.series
    for k in range(run.n_steps):
        yield {name: a[k] for name, a in series.items()}


def test_memory_recorder_equals_the_writer(short_run: Run, tmp_path: Path) -> None:
    """The same rows, outcome and metadata recorded in memory and written and read back agree."""
    kwargs = dict(
        mission_yaml=short_run.mission_yaml,
        mission_name=short_run.mission_name,
        controller=short_run.controller,
        extra_series={name: a.shape[1:] for name, a in short_run.extras.items()},
        status_names=short_run.status_names,
        n_thrusters=8,
        attrs={**short_run.attrs, "note": None, "n_max": np.int64(7), "flag": np.bool_(True)},
        flush_every=3,
    )
    outcome = {**short_run.outcome, "reason": None, "closest_approach_m": None, "n_steps": np.int32(10)}
    with MemoryRecorder(**kwargs) as rec, RunWriter(tmp_path / "w.h5", **kwargs) as writer:
        for row in _rows(short_run):
            rec.append(**row)
            writer.append(**row)
        assert rec.n_steps == writer.n_steps == 11
        rec.finish(outcome)
        writer.finish(outcome)
    memory, written = rec.run(), Run.from_file(tmp_path / "w.h5")
    assert memory.equals(written) and written.equals(memory)
    assert memory.outcome["reason"] == "" and math.isnan(memory.outcome["closest_approach_m"])
    assert (
        type(memory.outcome["n_steps"]) is int
        and memory.attrs["flag"] is True
        and math.isnan(memory.attrs["note"])
    )
    assert memory.complete and memory.source == ""
    path = memory.save(tmp_path / "m.h5")
    assert Run.from_file(path).equals(memory)


def test_memory_recorder_checks_like_the_writer(short_run: Run) -> None:
    rec = MemoryRecorder(mission_yaml="name: m\n", mission_name="m", controller="oracle", n_thrusters=8)
    row = {name: a[0] for name, a in short_run.series.items() if name not in short_run.extras}
    with pytest.raises(ValueError, match="missing dataset"):
        rec.append(**{k: v for k, v in row.items() if k != "wrench"})
    with pytest.raises(ValueError, match="unknown dataset.*information"):
        rec.append(**row, information=1.0)
    with pytest.raises(ValueError, match=r"state: expected row shape \(12,\)"):
        rec.append(**{**row, "state": np.zeros(11)})
    with pytest.raises(ValueError, match="unknown status name 'great'"):
        rec.append(**{**row, "solver_status": "great"})
    assert rec.n_steps == 0  # nothing appended by a bad row
    rec.append(**{**row, "solver_status": "failed"})
    assert rec.run().status.tolist() == ["failed"] and not rec.run().complete
    with pytest.raises(ValueError, match="own attributes: complete"):
        rec.finish({"complete": True})
    with pytest.raises(ValueError, match="own attributes: format"):
        MemoryRecorder(mission_yaml="", mission_name="m", controller="c", attrs={"format": "x"})
    with pytest.raises(TypeError, match="cannot store"):
        rec.finish({"bad": {"a": 1}})
    rec.finish({"docked": False})
    with pytest.raises(RuntimeError, match="already finished"):
        rec.append(**row)
    rec.close()
    rec.close()  # idempotent
    run = rec.run()
    assert run.complete and run.n_steps == 1 and run.state.shape == (1, 12)
    assert json.loads(json.dumps(run.outcome)) == {"docked": False}
