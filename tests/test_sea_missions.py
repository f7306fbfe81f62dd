"""The sea in missions and runs: bad input, the WEC dock against analytic facts, capture and collision
in the closed loop, and the realised sea in the results file."""

from __future__ import annotations

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.config.mission import MissionError, load_mission
from auvdock.loop.simulation import run_simulation
from auvdock.results.store import read_run, read_sea
from auvdock.world.dock import HeaveDock
from auvdock.world.spectra import jonswap, realise, regular_wave
from auvdock.world.waves import WaveComponents, wavenumber
from auvdock.world.wec_dock import WecDock
from auvdock.world.wec_table import load_heave_table

runner = CliRunner()


def _error(mission: str, **changes: object) -> str:
    m = load_mission(mission)
    with pytest.raises(MissionError) as e:
        m.with_updates(**changes)
    return str(e.value).split(": ", 1)[1]


def test_an_impossible_sea_is_one_line_naming_the_field():
    assert _error("pacwave_common_10m", sea__waves__hs_m=-1.0) == (
        "sea.waves.hs_m: input should be greater than or equal to 0 (got -1.0)"
    )
    assert _error("pacwave_common_10m", sea__waves__tp_s=0.7) == (
        "sea.waves.tp_s: 0.7 s is below twice the shortest resolvable period 0.5 s "
        "(10 control periods of 0.05 s)"
    )
    assert _error("basin_regular", sea__waves__period_s=0.3) == (
        "sea.waves.period_s: 0.3 s is below the shortest resolvable period 0.5 s "
        "(10 control periods of 0.05 s)"
    )
    assert _error("pacwave_common_10m", sea__water_depth_m=8.0) == (
        "sea.water_depth_m: 8 m, but the dock is at 10 m depth"
    )
    assert _error("pacwave_common_5m", dock__position_ned_m__2=80.0) == (
        "sea.water_depth_m: 70 m, but the dock is at 80 m depth"
    )
    assert _error("still", dock__wec={"table": "wec_buoy_2m"}) == (
        "dock.wec: a WEC dock moves with the waves; give sea.waves"
    )


def test_a_spectrum_file_with_the_wrong_columns_exits_2_with_one_line(tmp_path):
    (tmp_path / "bad.csv").write_text("freq,S\n0.1,1\n0.2,1\n0.3,1\n")
    (tmp_path / "m.yaml").write_text(
        "name: m\ndock: {position_ned_m: [3, 0, 10]}\nstart: {state: [0, 0, 10, 0, 0, 0, 0, 0, 0, 0, 0, 0]}\n"
        "sea: {water_depth_m: 70, waves: {type: spectrum, file: bad.csv}}\n"
    )
    res = runner.invoke(app, ["validate", str(tmp_path / "m.yaml")])
    assert res.exit_code == 2
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1
    assert lines[0] == (
        f"error: {tmp_path / 'm.yaml'}: sea.waves.file: {tmp_path / 'bad.csv'}: columns freq, S; "
        "expected omega_rad_s,S_m2_s_rad or frequency_hz,S_m2_hz"
    )


def test_one_wave_component_reproduces_the_papers_sinusoid():
    """A dock that follows the surface (RAO 1) in a regular wave of amplitude A heaves as the paper's
    z0 + A sin(w t + phase)."""
    A, f, phase, x_dock = 0.0635, 0.6, 0.4, 2.0
    w = 2 * math.pi * f
    k = wavenumber(w, 2.1)[0]
    sea = regular_wave(2 * A, 1 / f, water_depth_m=2.1, phase_rad=-phase - math.pi / 2 - k * x_dock)
    wec = WecDock(sea, (x_dock, 0.0, 1.0), 0.0, np.ones(1))
    paper = HeaveDock((x_dock, 0.0, 1.0), 0.0, A, w, phase)
    t = np.linspace(0, 20, 1001)
    np.testing.assert_allclose(wec.position(t), paper.position(t), atol=1e-12)
    np.testing.assert_allclose(wec.velocity(t), paper.velocity(t), atol=1e-12)


def test_the_buoy_heaves_with_the_sea_for_long_waves():
    """Far above the natural period (3.2 s) the buoy follows the surface: heave significant height ~ Hs,
    its record in phase with the elevation at the buoy; at the natural period it rises above it."""
    table = load_heave_table("wec_buoy_2m")
    for seed in range(3):
        sea = realise(lambda w: jonswap(w, 1.0, 20.0), 0.15, 0.6, 60, np.random.default_rng(seed))
        dock = WecDock.from_coefficients(sea, table, (0.0, 0.0, 10.0), 0.0)
        assert dock.significant_heave_m == pytest.approx(sea.significant_height_m, rel=0.02)
        t = np.linspace(0, 600, 6001)
        assert np.corrcoef(dock.heave_up(t), dock.elevation(t))[0, 1] > 0.999
    tn = table.natural_period_s()
    resonant = WecDock.from_coefficients(regular_wave(0.2, tn), table, (0, 0, 10.0), 0.0)
    assert resonant.significant_heave_m > 3 * regular_wave(0.2, tn).significant_height_m


def test_the_realised_sea_in_the_results_file_recomputes_the_water(tmp_path):
    m = load_mission("basin_regular")
    s = run_simulation(m, out=tmp_path / "r.h5", timeout_s=3.0)
    arrays, attrs = read_sea(s.path)
    sea = WaveComponents.from_arrays(arrays, attrs)
    r = read_run(s.path)
    x, t = np.asarray(r.state), np.asarray(r.time_s)
    recorded = np.asarray(r.extras["wave_velocity_ned_m_s"])
    np.testing.assert_array_equal(sea.velocity(x[:, 0:3], t), recorded)
    assert attrs["water_depth_m"] == 2.1


@pytest.mark.slow
def test_oracle_captures_in_the_basin_and_collides_from_the_side():
    """From in front of the dock the nose enters the cradle; started beside the dock, the vehicle
    steers straight at the docking point and strikes the structure around the entry."""
    m = load_mission("basin_regular")
    front = run_simulation(m, timeout_s=40.0)
    assert front.outcome["captured"] and not front.outcome["collided"], front.outcome
    assert front.outcome["reason"] == "captured"
    assert front.outcome["contact_speed_m_s"] <= 0.3
    side = run_simulation(
        m.with_updates(start__state=[2.0, -2.5, 1.0, 0, 0, 0, 0, 0, 0, 0, 0, 0]), timeout_s=40.0
    )
    o = side.outcome
    assert o["collided"] and not o["captured"], o
    assert o["reason"] == "collided"
    assert o["impact_speed_m_s"] > 0
    assert o["contact_what"] in ("structure face", "funnel wall")


def test_validate_prints_the_sea_and_the_docks_body():
    res = runner.invoke(app, ["validate", "pacwave_common_5m"], env={"COLUMNS": "400"})
    assert res.exit_code == 0, res.output
    out = res.output
    assert "sea: JONSWAP Hs 1.75 m, Tp 9.44 s, gamma 3.3, spread 25 deg: 560 components, Hm0 1.76 m" in out
    assert "dock: wec_buoy_2m buoy heaving in the sea" in out
    assert "dock body: entry funnel from a 0.9 m mouth over 0.6 m (half-angle 39.8 deg) into a cradle" in out
    assert "the buoy above (radius 1 m, draft 2 m)" in out
    assert "docking: captured with the nose 0.1 m inside the cradle, within 0.086 m of its axis" in out
    calm = runner.invoke(app, ["validate", "still"], env={"COLUMNS": "400"})
    assert "sea: no waves" in calm.output
    assert "docking: within 0.05 m of the docking point (criterion point)" in calm.output


def test_the_buoys_heave_amplitudes_are_rayleigh_distributed():
    """A narrow-band heave (S_z = |RAO|^2 S_eta): crest heights of its cycles are Rayleigh with the
    heave's standard deviation s, P(A > x) = exp(-x^2 / 2 s^2): median s sqrt(2 ln 2), and 1 crest in
    10 above s sqrt(2 ln 10)."""
    table = load_heave_table("wec_buoy_2m")
    crests = []
    for seed in range(4):
        sea = realise(lambda w: jonswap(w, 1.5, 10.0, 5.0), 0.3, 2.0, 200, np.random.default_rng(seed))
        dock = WecDock.from_coefficients(sea, table, (0.0, 0.0, 10.0), 0.0, viscous_damping_N_s_m=3300.0)
        t = np.arange(0.0, 3600.0, 0.1)
        z = dock.heave_up(t)
        up = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))  # zero up-crossings: one cycle each
        crests += [float(z[a:b].max()) / np.std(z) for a, b in zip(up[:-1], up[1:], strict=True)]
    crests_a = np.array(crests)
    assert crests_a.size > 1000
    assert np.median(crests_a) == pytest.approx(math.sqrt(2 * math.log(2)), rel=0.08)
    assert np.mean(crests_a > math.sqrt(2 * math.log(10))) == pytest.approx(0.1, abs=0.03)


@pytest.mark.slow
def test_the_sea_figures_show_the_spectrum_the_dock_and_the_path_through_the_entry(tmp_path):
    from auvdock.results.plots import run_figures

    s = run_simulation(load_mission("basin_regular"), out=tmp_path / "r.h5", timeout_s=30.0)
    assert s.outcome["captured"]
    r = read_run(s.path)
    figures = dict(run_figures(r))
    sea_ax = figures["sea"].axes
    legend = [t.get_text() for t in sea_ax[0].get_legend().get_texts()]
    assert legend == ["regular wave, a = 0.0635 m (a^2/2 in m^2)"]  # the spectrum panel: one component
    labels = [line.get_label() for ax in sea_ax for line in ax.get_lines()]
    assert "sea elevation at the dock (m, up)" in labels and "dock heave about its mean (m, up)" in labels
    assert sum(label.startswith("orbital velocity at the vehicle") for label in labels) == 3
    heave = next(
        line for ax in sea_ax for line in ax.get_lines() if line.get_label().startswith("dock heave")
    )
    y = np.asarray(heave.get_ydata())
    assert (np.max(y) - np.min(y)) / 2 == pytest.approx(0.0635, rel=0.01)  # the paper's 2.5 in heave
    top, side = figures["dock_entry"].axes[:2]
    nose = next(line for line in top.get_lines() if line.get_label() == "vehicle nose")
    x = np.asarray(nose.get_xdata())
    assert x[0] < -1.5 and x[-1] > -0.05  # from 2 m out to inside the cradle (entrance at x_d = 0.05)
    assert any(c.get_label() == "captured" for c in top.collections)


def test_fly_refuses_a_wec_dock_in_one_line(tmp_path):
    """A WEC dock's motion is the simulated sea's: no vehicle can be told it, so fly refuses before
    connecting (exit 2, one line naming the field), and writes nothing (its output in tmp_path, not the
    mission's runs/ in the clone)."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    args = ["fly", "pacwave_common_10m", "--port", f"udpin:127.0.0.1:{port}", "--out", str(tmp_path)]
    res = runner.invoke(app, args)
    assert res.exit_code == 2, res.output
    last = res.output.strip().splitlines()[-1]
    assert last.endswith(
        "pacwave_common_10m.yaml: dock.wec: oracle is told the dock's true motion in the realised sea (its "
        "definition), which no vehicle knows; fly a controller that forecasts it from the dock's telemetry "
        "(-c ce, sequential, optimized or naive)"
    )
    assert list(tmp_path.iterdir()) == []
