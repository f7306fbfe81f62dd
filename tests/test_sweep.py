"""Monte Carlo sweeps (:mod:`auvdock.sweep`, :mod:`auvdock.sweep.stats`) on the campaign engine.

The sweeps here are short (2.5 s of simulated time, still water, 8 runs): nothing docks,
which is fine -- the sweep machinery is under test, the controllers are tested elsewhere.
They run on 2 local worker processes, and once on a 2-worker Dask cluster (``--scheduler``),
closed by the test that started it.  Faults come from tests/helpers/campaign_faults.py.
"""

from __future__ import annotations

import functools
import json
import math
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers.campaign_faults import inject
from typer.testing import CliRunner

from auvdock.campaign import ResultsFileError, execute_run
from auvdock.cli import app
from auvdock.config.mission import MissionError, load_mission
from auvdock.loop.simulation import run_simulation
from auvdock.results.store import read_run
from auvdock.sweep import SweepError, expand_sweep, load_sweep, read_sweep, run_sweep
from auvdock.sweep.stats import report_sweep, wilson_interval

ROOT = Path(__file__).resolve().parents[1]
STILL = ROOT / "missions" / "still.yaml"
TIMEOUT = 2.5

SMALL = f"""\
name: {{name}}
base: {STILL}
controllers: [naive, optimized]
seeds: 2
grid:
  flow.speed_m_s: [0.0, 0.5]
  flow.direction_deg: [90]
timeout_s: {TIMEOUT}
"""


def _write(tmp: Path, name: str, text: str | None = None) -> Path:
    p = tmp / f"{name}.yaml"
    p.write_text(text if text is not None else SMALL.format(name=name))
    return p


def _table(path: Path) -> np.ndarray:
    with h5py.File(path, "r") as f:
        return f["campaign_table"][()]


# ------------------------------------------------------------------------------ statistics


def _wilson_formula(k: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    p = k / n
    denom = 1 + z**2 / n
    centre = (p + z**2 / (2 * n)) / denom
    half = z / denom * math.sqrt(p * (1 - p) / n + z**2 / (4 * n**2))
    return centre - half, centre + half


def test_wilson_interval_known_values_and_edges() -> None:
    lo, hi = wilson_interval(8, 11)
    assert (lo, hi) == pytest.approx(_wilson_formula(8, 11), abs=1e-12)
    assert lo == pytest.approx(0.434, abs=1e-3) and hi == pytest.approx(0.903, abs=1e-3)
    # 0 of n: the lower end is exactly 0, the upper one z^2 / (n + z^2)
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and hi == pytest.approx(1.959964**2 / (10 + 1.959964**2), abs=1e-12)
    assert hi == pytest.approx(_wilson_formula(0, 10)[1], abs=1e-12)
    # n of n: mirror image
    lo, hi = wilson_interval(10, 10)
    assert hi == 1.0 and lo == pytest.approx(10 / (10 + 1.959964**2), abs=1e-12)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    assert wilson_interval(5, 10)[0] == pytest.approx(1 - wilson_interval(5, 10)[1], abs=1e-12)
    with pytest.raises(ValueError):
        wilson_interval(3, 2)


# ------------------------------------------------------------------------------ sweep files


def _values(r) -> dict:
    return {k: v for k, v in r.labels.items() if k not in ("point", "model_error_draw")}


def test_shipped_sweeps_expand(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)  # a shipped sweep is found by name from any folder
    s = load_sweep("current_speed")
    assert s.path == ROOT / "auvdock" / "missions" / "sweeps" / "current_speed.yaml"
    runs = expand_sweep(s)
    assert len(runs) == s.n_runs == 6 * 8 * 5
    assert len({r.run_id for r in runs}) == len(runs)
    r = next(r for r in runs if _values(r) == {"flow.speed_m_s": 2.0, "flow.direction_deg": 90})
    assert r.mission["flow"]["type"] == "constant" and r.mission["flow"]["case"] is None
    assert r.mission["flow"]["velocity_ned_m_s"] == pytest.approx([0.0, 2.0], abs=1e-12)
    assert r.mission["docking"]["timeout_s"] == 75.0

    assert r.overrides == {"seed": r.seed} and r.mission["controller"]["type"] == r.controller
    assert r.group is None

    t = load_sweep("tank_trials")
    runs = expand_sweep(t)
    assert len(runs) == t.n_runs == 4 * 4 * 4 * 2 * 3
    assert t.model_error.n > 0 and {r.controller for r in runs} == {"oracle", "ce", "sequential", "optimized"}
    r = next(r for r in runs if r.labels["dock.heave.frequency_hz"] == 0.8)
    heave = r.mission["dock"]["heave"]
    assert heave["angular_frequency_rad_s"] == pytest.approx(2 * math.pi * 0.8)
    assert all(r.truth_overrides for r in runs)
    assert [x["docked"] for x in t.model_dump()["reference"]] == [8]


def test_the_horizon_sweep_flies_each_grid_with_each_controller() -> None:
    s = load_sweep("pacwave_horizon")
    runs = expand_sweep(s)
    assert len(runs) == s.n_runs == 4 * 2 * 10
    grids = {
        (r.mission["controller"]["horizon_steps"], r.mission["controller"]["coarse"]["steps"], r.controller)
        for r in runs
    }
    assert grids == {(n, c, k) for n in (10, 40) for c in (0, 8) for k in ("oracle", "ce")}
    assert {r.mission["controller"]["coarse"]["dt_s"] for r in runs} == {0.5}


def test_the_white_unit_sweep_flies_ce_on_the_camera_with_the_white_motion_unit() -> None:
    s = load_sweep("pacwave_white_unit")
    runs = expand_sweep(s)
    assert len(runs) == s.n_runs == 50
    assert {r.controller for r in runs} == {"ce"}
    assert {r.mission["sensors"]["dock_telemetry"]["motion_unit"] for r in runs} == {"white"}
    assert {r.mission["sensors"]["dock_camera"]["enabled"] for r in runs} == {True}


def test_expansion_ids_derived_flow_and_reproducible_draws(tmp_path: Path) -> None:
    text = f"""\
name: draws
base: {ROOT / "missions" / "diagonal.yaml"}
controllers: [oracle]
seeds: 2
grid:
  flow.speed_m_s: [1.0, 2.0]
random:
  n: 3
  fields:
    dock.heave.amplitude_m: {{uniform: [0.0, 0.5]}}
    controller.horizon_steps: {{choice: [8, 10, 12]}}
sweep_seed: 7
"""
    runs = expand_sweep(load_sweep(_write(tmp_path, "draws", text)))
    assert len(runs) == 2 * 3 * 2
    assert runs[0].run_id == "p0000-oracle-s0-m0" and runs[-1].run_id == "p0005-oracle-s1-m0"
    # only the speed varies: the direction is the base's (case 2 flows towards 45 deg)
    v = runs[-1].mission["flow"]["velocity_ned_m_s"]
    assert v == pytest.approx([2.0 / math.sqrt(2), 2.0 / math.sqrt(2)], abs=1e-9)
    assert all(isinstance(r.labels["controller.horizon_steps"], int) for r in runs)
    assert runs[0].mission["controller"]["horizon_steps"] == runs[0].labels["controller.horizon_steps"]
    # the same file gives the same draws; adding a field leaves the others' draws alone
    again = expand_sweep(load_sweep(_write(tmp_path, "draws", text)))
    assert [r.labels for r in again] == [r.labels for r in runs]
    assert [r.sha for r in again] == [r.sha for r in runs]
    more = text.replace("sweep_seed: 7", "") + "    sensors.accel_std_m_s2: {normal: [0.0045, 0.001]}\n"
    more = more.replace("name: draws", "name: draws\nsweep_seed: 7")
    plus = expand_sweep(load_sweep(_write(tmp_path, "more", more)))
    assert [r.labels["dock.heave.amplitude_m"] for r in plus] == [
        r.labels["dock.heave.amplitude_m"] for r in runs
    ]


BAD = [
    (
        "grid: {flow.speedd_m_s: [1.0]}",
        "grid.flow.speedd_m_s: unknown mission field (flow has: case, type, velocity_ned_m_s, amplitude_m_s, "
        "period_h, epsilon; derived by the sweep: speed_m_s, direction_deg)",
    ),
    (
        "random: {n: 2, fields: {dock.heave.amplitude_m: {uniform: [0.5, 0.1]}}}",
        "random.fields.dock.heave.amplitude_m.uniform: low 0.5 is above high 0.1",
    ),
    (
        "random: {n: 2, fields: {dock.heave.amplitude_m: {gauss: [0.5, 0.1]}}}",
        "random.fields.dock.heave.amplitude_m.gauss: unknown key (allowed: uniform, normal, choice)",
    ),
    (
        "grid: {dock.heave.amplitude_m: [0.1, -0.2]}",
        "grid.dock.heave.amplitude_m: input should be greater than or equal to 0 (got -0.2)",
    ),
    (
        "model_error: {n: 1, scale: {added_mas: 0.1}}",
        "model_error.scale.added_mas: is not a numeric vehicle parameter (scalable: added_mass, buoyancy_N, "
        "inertia_kg_m2, linear_damping, mass_kg, quadratic_damping, r_b_m, r_g_m, thruster_gain, weight_N)",
    ),
    (
        "grid: {controller.alpah: [0.001]}",
        "grid.controller.alpah: unknown mission field (controller has: type, ",
    ),
    ("grid: {seed: [1, 2]}", "grid.seed: is set by the sweep's 'seeds' and cannot be varied"),
    (
        "grid: {sensors.suite: [sonar]}",
        "grid.sensors.suite: unknown sensor suite 'sonar' (known: motion_capture, acoustic, acoustic+camera, "
        "dvl+camera, camera)",
    ),
    ("grid: {dock.distance_m: [0]}", "grid.dock.distance_m: must be a positive number (got 0)"),
    ("fixed: {docking.timeout_s: -1}", "fixed.docking.timeout_s: input should be greater than 0 (got -1)"),
    ("fixed: {dockng.timeout_s: 1}", "fixed.dockng: no such field (did you mean docking?)"),
    ("grid: {dock.heave: [1]}", "grid.dock.heave: "),
]


@pytest.mark.parametrize("body, message", BAD, ids=[m.split(":")[0] for _, m in BAD])
def test_bad_sweep_file_names_the_field(tmp_path: Path, body: str, message: str) -> None:
    p = _write(tmp_path, "bad", f"base: {STILL}\n{body}\n")
    with pytest.raises(SweepError) as e:
        load_sweep(p)
    if message.endswith(": ") or message.endswith(", "):
        assert str(e.value).startswith(f"{p}: {message}")
    else:
        assert str(e.value) == f"{p}: {message}"
    assert isinstance(e.value, MissionError)  # same shape: the CLI prints either the same way


def test_sensor_suites_distances_and_fixed_fields(tmp_path: Path) -> None:
    """``sensors.suite`` sets what the named suite carries, ``dock.distance_m`` moves the dock along the
    base mission's bearing (case 2's dock is 3.61 m north-east of the start), ``fixed`` sets a field
    for every run without varying it."""
    text = f"""\
name: suites
base: {ROOT / "missions" / "diagonal.yaml"}
controllers: [ce]
fixed: {{docking.timeout_s: 9.0}}
grid:
  sensors.suite: [camera, acoustic+camera]
  dock.distance_m: [7.2111]
"""
    runs = expand_sweep(load_sweep(_write(tmp_path, "suites", text)))
    assert len(runs) == 2 and all(r.mission["docking"]["timeout_s"] == 9.0 for r in runs)
    cam, acoustic = (r.mission for r in runs)
    assert cam["estimation"] == acoustic["estimation"] == "filter"
    assert cam["sensors"]["position"]["source"] == "none" and cam["sensors"]["dock_camera"]["enabled"]
    assert acoustic["sensors"]["position"]["source"] == "acoustic"
    assert cam["dock"]["position_ned_m"] == pytest.approx([4.0, 6.0, 5.0], abs=1e-4)  # twice as far
    assert "docking.timeout_s" not in runs[0].labels


def test_controller_fields_are_checked_per_controller(tmp_path: Path) -> None:
    """``controller.alpha`` exists (for Optimized FSE-MPC): a sweep may vary it."""
    p = _write(
        tmp_path,
        "alpha",
        f"base: {STILL}\ncontrollers: [optimized]\ngrid: {{controller.alpha: [0.001, 0.002]}}\n",
    )
    runs = expand_sweep(load_sweep(p))
    assert [r.mission["controller"]["alpha"] for r in runs] == [0.001, 0.002]


def test_missing_base_file(tmp_path: Path) -> None:
    p = _write(tmp_path, "nobase", "base: ../nope.yaml\n")
    with pytest.raises(SweepError) as e:
        load_sweep(p)
    assert str(e.value) == f"{p}: base: mission file not found: {tmp_path / '../nope.yaml'}"
    assert e.value.field == "base"


# ------------------------------------------------------------------------------ model error


def test_model_error_reaches_the_truth_model_only(tmp_path: Path, monkeypatch) -> None:
    import auvdock.loop.autopilot as autopilot_mod
    from auvdock.vehicle import Vehicle

    text = f"""\
name: me
base: {STILL}
controllers: [oracle]
model_error:
  n: 2
  scale:
    added_mass: {{uniform: [1.5, 1.5]}}
    linear_damping: {{uniform: [0.5, 0.5]}}
    mass_kg: 0.05
timeout_s: 1.0
"""
    runs = expand_sweep(load_sweep(_write(tmp_path, "me", text)))
    assert [r.run_id for r in runs] == ["p0000-oracle-s0-m0", "p0000-oracle-s0-m1"]
    nominal = load_mission(STILL).build_vehicle().params
    spec = runs[0]
    factors = {k.split(".", 1)[1]: v for k, v in spec.labels.items() if k.startswith("model_error.")}
    other = runs[1].labels["model_error.mass_kg"]
    assert factors["added_mass"] == 1.5 and factors["linear_damping"] == 0.5
    assert 0.85 <= factors["mass_kg"] <= 1.15 and factors["mass_kg"] != other

    plant, model = [], []
    real_stepper, real_build = Vehicle.stepper, autopilot_mod.build_controller

    def stepper(self, *a, **k):
        plant.append(self.params)
        return real_stepper(self, *a, **k)

    def build_controller(settings, vehicle, *a, **k):
        model.append(vehicle.params)
        return real_build(settings, vehicle, *a, **k)

    monkeypatch.setattr(Vehicle, "stepper", stepper)
    monkeypatch.setattr(autopilot_mod, "build_controller", build_controller)
    out = execute_run(spec)
    assert out["row"]["error"] == "" and out["row"]["status"] == "done"
    assert len(plant) == 1 and len(model) == 1
    np.testing.assert_allclose(plant[0].added_mass, 1.5 * nominal.added_mass, rtol=1e-12)
    np.testing.assert_allclose(plant[0].linear_damping, 0.5 * nominal.linear_damping, rtol=1e-12)
    assert plant[0].mass_kg == pytest.approx(factors["mass_kg"] * nominal.mass_kg, rel=1e-12)
    np.testing.assert_array_equal(plant[0].quadratic_damping, nominal.quadratic_damping)
    # the controller (and its estimator) keep the nominal model
    np.testing.assert_array_equal(model[0].added_mass, nominal.added_mass)
    np.testing.assert_array_equal(model[0].linear_damping, nominal.linear_damping)
    assert model[0].mass_kg == nominal.mass_kg
    assert out["row"]["model_error.added_mass"] == 1.5

    # and the truth model changes the run: the same run without model error moves differently
    m = load_mission(STILL).with_updates(**{"docking.timeout_s": 1.0})
    ref = run_simulation(m).outcome
    assert abs(ref["path_length_m"] - out["row"]["path_length_m"]) > 1e-4


def test_a_run_that_raises_is_recorded_not_raised(tmp_path: Path, monkeypatch) -> None:
    import auvdock.loop.simulation

    spec = expand_sweep(load_sweep(_write(tmp_path, "oops")))[0]

    def boom(*a, **k):
        raise FloatingPointError("solver blew up")

    monkeypatch.setattr(auvdock.loop.simulation, "run_simulation", boom)
    out = execute_run(spec)
    row = out["row"]
    assert row["error"] == "FloatingPointError: solver blew up" and row["status"] == "failed"
    assert row["docked"] is False and row["reason"] == "error" and math.isnan(row["closest_approach_m"])


# ------------------------------------------------------------------------------ a sweep on local workers


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    d = tmp_path_factory.mktemp("sweep")
    path = _write(d, "small")
    seen: list[tuple[str, str]] = []
    res = run_sweep(
        path,
        d / "out",
        workers=2,
        trajectories=True,
        on_event=lambda kind, spec, info: seen.append((kind, spec.run_id if spec else "")),
        command_line="auvdock sweep small.yaml",
    )
    return path, res, seen


@pytest.mark.slow
def test_worker_runs_equal_runs_in_this_process(small) -> None:
    path, res, seen = small
    assert res.total == 8 and len(res.ran) == 8 and not res.errors and not res.skipped
    assert seen[0] == ("plan", "") and sum(k == "done" for k, _ in seen) == 8
    assert res.executor == "2 local worker processes"
    rows, _ = read_sweep(res.path)
    assert [r["run_id"] for r in rows] == [r.run_id for r in expand_sweep(load_sweep(path))]
    assert all(r["worker"] and not r["error"] and r["status"] == "done" for r in rows)
    base = load_mission(STILL)
    for r in rows:
        m = base.with_updates(
            **{
                "flow.case": None,
                "flow.type": "constant",
                "flow.velocity_ned_m_s": [0.0, r["flow.speed_m_s"]],
                "controller.type": r["controller"],
                "seed": r["seed"],
            }
        )
        o = run_simulation(m, timeout_s=TIMEOUT).outcome
        assert r["docked"] == o["docked"]
        assert r["closest_approach_m"] == pytest.approx(o["closest_approach_m"], abs=1e-9), r["run_id"]
        assert r["path_length_m"] == pytest.approx(o["path_length_m"], abs=1e-9), r["run_id"]
        assert r["end_time_s"] == pytest.approx(TIMEOUT)
    # the FSE controller reads the (seeded) sensors: its two seeds differ
    opt = [r for r in rows if r["controller"] == "optimized" and r["point"] == 1]
    assert opt[0]["path_length_m"] != opt[1]["path_length_m"]


def test_results_file_layout(small) -> None:
    path, res, _ = small
    with h5py.File(res.path, "r") as f:
        a = f.attrs
        assert a["format"] == "auvdock-campaign" and a["kind"] == "sweep"
        assert a["sweep_yaml"] == path.read_text()
        assert a["command_line"] == "auvdock sweep small.yaml"
        assert "cpu_count" in json.loads(a["machine"])
        assert a["wall_time_s"] > 0 and int(a["total_runs"]) == 8
        names = f["campaign_table"].dtype.names
        assert names[:5] == ("run_id", "point", "model_error_draw", "flow.speed_m_s", "flow.direction_deg")
        for col in ("controller", "seed", "status", "docked", "time_to_dock_s", "closest_approach_m"):
            assert col in names
        assert {"flow_rmse_m_s", "solver_failures", "wall_time_s", "setup_time_s", "worker", "error"} <= set(
            names
        )
        for rid in f["campaign_table"]["run_id"]:
            run = read_run(f, f"/runs/{rid.decode()}")  # the run-group layout of auvdock sim
            assert run.state.shape == (51, 12) and run.time_s.shape == (51,)  # 50 steps + the final state
    assert len(list((res.out_dir / "logs").glob("worker-*.log"))) == 2  # the local workers' output
    rows, attrs = read_sweep(res.path)
    assert attrs["varied"] == ["flow.speed_m_s", "flow.direction_deg"] and attrs["controllers"] == [
        "naive",
        "optimized",
    ]
    fse = [r for r in rows if r["controller"] == "optimized"]
    assert all(np.isfinite(r["flow_rmse_m_s"]) for r in fse)


def test_resume_on_a_finished_sweep_runs_nothing(small) -> None:
    path, res, _ = small
    before = _table(res.path)
    again = run_sweep(path, res.out_dir, workers=2, resume=True, trajectories=True)
    assert again.ran == [] and len(again.skipped) == 8 and again.executor.startswith("none")
    after = _table(res.path)
    assert after.dtype == before.dtype and len(after) == 8
    for name in before.dtype.names:
        a, b = before[name], after[name]
        assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name
    with pytest.raises(ResultsFileError, match="a sweep is already there"):
        run_sweep(path, res.out_dir, workers=2)


@pytest.mark.slow
def test_report_writes_figures_and_summary(small, tmp_path: Path) -> None:
    _, res, _ = small
    paths = report_sweep(res.path, tmp_path / "a")
    names = [p.name for p in paths]
    assert names == [
        "success_by_controller.png",
        "success_vs_flow.speed_m_s.png",
        "success_vs_flow.direction_deg.png",
        "success_map_flow.speed_m_s__flow.direction_deg.png",
        "distributions.png",
        "summary.md",
    ]
    for p in paths[:-1]:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = paths[-1].read_text()
    assert "| naive | 4 | 0 | 0.0 % | 0.0-49.0 % | 0 |" in md
    assert "## Success vs `flow.speed_m_s`" in md and "0/2 = 0.0 % [0.0-65.8 %]" in md
    again = report_sweep(res.path, tmp_path / "b")  # the same file gives the same bytes
    assert [p.read_bytes() for p in again] == [p.read_bytes() for p in paths]
    # auvdock report knows a sweep file by its kind
    shutil.copy(res.path, tmp_path / "sweep.h5")
    out = CliRunner().invoke(app, ["report", str(tmp_path / "sweep.h5")])
    assert out.exit_code == 0, out.output
    assert (tmp_path / "summary.md").read_bytes() == md.encode()


# ------------------------------------------------------------------------------ the command


@pytest.mark.slow
def test_sweep_command_twice_resume_and_force(tmp_path: Path) -> None:
    path = _write(tmp_path, "cli", SMALL.format(name="cli").replace("seeds: 2", "seeds: 1"))
    out = tmp_path / "out"
    cli = CliRunner()
    args = ["sweep", str(path), "--out", str(out), "--workers", "2"]
    res = cli.invoke(app, args)
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())  # the console wraps at 80 columns
    assert "sweep cli: 2 points x 2 controllers x 1 seed = 4 runs" in text
    assert "success per controller" in text
    # the console also breaks a path longer than a line (a deep tmp_path: pytest-xdist's workers have
    # longer ones) inside the path, where no space belongs: compare with all whitespace removed
    assert "".join(f"results: {out / 'sweep.h5'}".split()) in "".join(res.output.split())
    assert (out / "summary.md").is_file() and (out / "success_by_controller.png").is_file()
    res = cli.invoke(app, args)
    assert res.exit_code == 2
    assert res.stderr == (
        f"error: {out / 'sweep.h5'}: a sweep is already there; use --resume to continue it or --force to "
        "start again\n"
    )
    res = cli.invoke(app, [*args, "--resume"])
    assert res.exit_code == 0 and "resumed: 4 runs already complete, 0 run now" in res.output
    res = cli.invoke(app, [*args, "--force"])
    assert res.exit_code == 0 and "resumed" not in res.output
    with h5py.File(out / "sweep.h5", "r") as f:
        assert "--force" in f.attrs["command_line"] and len(f["campaign_table"]) == 4


def test_bad_sweep_file_exits_2(tmp_path: Path) -> None:
    p = _write(tmp_path, "bad", f"base: {STILL}\ngrid: {{flow.speedd_m_s: [1.0]}}\n")
    res = CliRunner().invoke(app, ["sweep", str(p), "--out", str(tmp_path)])
    assert res.exit_code == 2 and len(res.stderr.strip().splitlines()) == 1
    assert res.stderr.startswith(f"error: {p}: grid.flow.speedd_m_s: unknown mission field")


# ------------------------------------------------------------------------------ faults


@pytest.mark.slow
def test_killed_worker_is_retried_and_a_raising_run_is_recorded(tmp_path: Path) -> None:
    path = _write(tmp_path, "faulty")
    faults = functools.partial(
        inject, marker_dir=str(tmp_path), kill_once=["p0001-naive-s0-m0"], fail=["p0000-optimized-s1-m0"]
    )
    res = run_sweep(path, tmp_path / "out", workers=2, runner=faults)
    assert (tmp_path / "p0001-naive-s0-m0.killed").exists()  # its worker was SIGKILLed
    ids = [str(x, "utf-8") for x in _table(res.path)["run_id"]]
    assert len(ids) == 8 and sorted(ids) == sorted(r.run_id for r in expand_sweep(load_sweep(path)))
    rows = {r["run_id"]: r for r in read_sweep(res.path)[0]}
    killed = rows["p0001-naive-s0-m0"]
    assert (
        killed["status"] == "done" and killed["attempts"] == 2 and np.isfinite(killed["closest_approach_m"])
    )
    raised = rows["p0000-optimized-s1-m0"]
    assert raised["status"] == "failed" and raised["docked"] is False and raised["reason"] == "error"
    assert raised["error"] == "RuntimeError: injected failure"
    assert list(res.errors) == ["p0000-optimized-s1-m0"]
    assert all(r["status"] == "done" for k, r in rows.items() if k != "p0000-optimized-s1-m0")
    # a resume retries the failed run only
    again = run_sweep(path, tmp_path / "out", workers=1, resume=True)
    assert again.ran == ["p0000-optimized-s1-m0"] and not again.errors


@pytest.mark.slow
def test_ctrl_c_keeps_finished_rows_and_resume_completes(tmp_path: Path) -> None:
    path = _write(tmp_path, "interrupted")
    done = []

    def stop(kind, spec, info):
        if kind == "done":
            done.append(spec.run_id)
            if len(done) >= 2:
                raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(path, tmp_path / "out", workers=2, on_event=stop)
    rows, attrs = read_sweep(tmp_path / "out" / "sweep.h5")  # readable, with the rows so far
    assert 2 <= len(rows) < 8 and attrs["wall_time_s"] > 0
    first = {r["run_id"] for r in rows}
    res = run_sweep(path, tmp_path / "out", workers=2, resume=True)
    assert set(res.skipped) == first and len(res.ran) == 8 - len(first)
    ids = [str(x, "utf-8") for x in _table(res.path)["run_id"]]
    assert len(ids) == 8 == len(set(ids))


# ------------------------------------------------------------------------------ on a Dask cluster


@pytest.mark.slow
def test_sweep_on_a_dask_cluster(tmp_path: Path) -> None:
    """The same sweep through --scheduler: a run whose Dask worker dies every time is retried once
    and recorded as failed; a raising run is recorded; the others are done."""
    import dask
    from distributed import LocalCluster

    path = _write(tmp_path, "dask", SMALL.format(name="dask").replace("seeds: 2", "seeds: 1"))
    faults = functools.partial(inject, kill_always=["p0001-naive-s0-m0"], fail=["p0000-optimized-s0-m0"])
    # no retries inside Dask (the engine retries once), and one task at a time per worker, so that
    # a dying worker holds only the run that killed it
    config = {"distributed.scheduler.allowed-failures": 0, "distributed.scheduler.worker-saturation": 1.0}
    with dask.config.set(config):
        with LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=50
        ) as cluster:
            res = run_sweep(path, tmp_path / "out", scheduler=cluster.scheduler_address, runner=faults)
    assert res.executor.startswith(f"Dask scheduler {cluster.scheduler_address}")
    rows = {r["run_id"]: r for r in read_sweep(res.path)[0]}
    assert len(rows) == 4
    assert rows["p0001-naive-s0-m0"]["status"] == "failed" and rows["p0001-naive-s0-m0"]["attempts"] == 2
    assert "Dask worker died" in rows["p0001-naive-s0-m0"]["error"]
    assert rows["p0000-optimized-s0-m0"]["error"] == "RuntimeError: injected failure"
    assert rows["p0000-naive-s0-m0"]["status"] == rows["p0001-optimized-s0-m0"]["status"] == "done"
