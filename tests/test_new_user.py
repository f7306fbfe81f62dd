"""What a new user tripped over (issue 37): the sea run's summary, text read as markup, warnings on
stderr, Ctrl-C while the plots are drawn, ``python -m auvdock``, the compare header, a rerun of
``sim`` into the same folder, the names ``plot`` gives, the controllers the docs list."""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from auvdock.cli.app import water_line
from auvdock.cli.campaign import controllers_text
from auvdock.cli.sim import ending_text
from auvdock.config.catalog import resolve
from auvdock.config.mission import load_mission
from auvdock.controllers import controller_specs
from auvdock.controllers.registry import controller_names

ROOT = Path(__file__).resolve().parents[1]


def _auvdock(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """The command as a user runs it (``python -m auvdock``), on a wide terminal: one row a line."""
    env = {**os.environ, "COLUMNS": "200", "AUVDOCK_COMPILE": "never", "MPLBACKEND": "Agg"}
    cmd = [sys.executable, "-m", "auvdock", *args]
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)


def _blind_basin(folder: Path, name: str = "basin_blind") -> Path:
    """The wave basin with a camera that sees only 0.3 m and a guidance that gives up after 2 s and a
    search of 0.25 s sweeps (it gives up once the search is done, or 2 + 2 x 0.25 s after the start): a sea
    run that ends ``lost_target`` with the dock never seen, in a few seconds."""
    m = load_mission(resolve("basin_regular")).with_updates(
        **{
            "sensors.dock_camera.visibility_m": 0.3,
            "guidance.give_up_s": 2.0,
            "guidance.search_period_s": 0.25,
            "name": name,
        }
    )
    path = folder / f"{name}.yaml"
    path.write_text(m.to_yaml())
    return path


def _row(text: str, label: str) -> str:
    """The value of a summary table's row ``label`` (one line on a 200-column terminal)."""
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("│").split("│")]
        if len(cells) == 2 and cells[0] == label:
            return cells[1]
    raise AssertionError(f"no row {label!r} in:\n{text}")


@pytest.fixture(scope="module")
def blind_sea_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[subprocess.CompletedProcess[str], Path]:
    folder = tmp_path_factory.mktemp("blind")
    mission = _blind_basin(folder)
    return _auvdock("sim", str(mission), "--out", "out", cwd=folder), folder


def test_a_sea_runs_header_names_its_waves() -> None:
    m = load_mission(resolve("pacwave_common_10m"))
    assert water_line(m) == (
        "no current; waves JONSWAP Hs 1.75 m, Tp 9.44 s, gamma 3.3, spread 25 deg: 560 components, "
        "Hm0 1.76 m, depth 70 m"
    )
    assert water_line(load_mission(resolve("still"))) == "still water"  # no sea: the current alone


def test_a_lost_target_sea_runs_summary_says_how_it_ended(blind_sea_run) -> None:
    r, _ = blind_sea_run
    assert r.returncode == 1, r.stderr
    first = r.stdout.splitlines()[0]
    assert first.startswith(
        "basin_blind: no current; waves regular wave H 0.127 m, T 1.66667 s: 1 component, Hm0 0.18 m, "
        "depth 2.1 m; controller oracle"
    ), first
    assert _row(r.stdout, "captured") == "no (lost_target: gave up finding the dock)"
    assert re.fullmatch(r"gave up finding the dock at 2\.\d\d s", _row(r.stdout, "time to dock"))
    assert _row(r.stdout, "losses of the dock") == "never seen by the camera"


def test_no_warning_text_on_stderr_of_a_sea_and_a_tank_sim(blind_sea_run, tmp_path: Path) -> None:
    r, folder = blind_sea_run
    assert "dock_entry.png" in r.stdout  # the figure that warned (an equal aspect on shared axes)
    assert r.stderr == "", r.stderr
    tank = _auvdock("sim", "tank_0p6hz", "--timeout", "3", "--out", "out", cwd=tmp_path)
    assert tank.returncode == 1, tank.stderr
    assert "plots:" in tank.stdout and tank.stderr == "", tank.stderr


def test_the_plots_show_the_believed_dock_and_when_the_camera_saw_it(blind_sea_run) -> None:
    from auvdock.results.plots import run_figures
    from auvdock.results.store import read_run

    _, folder = blind_sea_run
    run = read_run(folder / "out" / "basin_blind_oracle.h5")
    assert math.isnan(run.attrs["dock_first_seen_s"])
    figures = dict(run_figures(run))
    top_labels = [t.get_text() for t in figures["top_view"].legends[0].get_texts()]
    assert "dock where the vehicle believed it" in top_labels
    (distance,) = figures["distance"].axes
    assert "distance as the vehicle believed it" in [ln.get_label() for ln in distance.get_lines()]
    assert "the camera never saw the dock" in [t.get_text() for t in distance.texts]


def test_a_seen_dock_is_marked_where_and_when(tmp_path: Path) -> None:
    """tank_0p6hz: the camera finds the dock within seconds; its fixes are marked on both plots."""
    from auvdock.loop.simulation import run_simulation
    from auvdock.results.plots import run_figures
    from auvdock.results.store import read_run

    out = tmp_path / "tank.h5"
    m = load_mission(resolve("tank_0p6hz"))
    s = run_simulation(m, out=out, timeout_s=4.0)
    first = s.outcome["dock_first_seen_s"]
    assert 0.0 <= first < 4.0
    figures = dict(run_figures(read_run(out)))
    top_labels = [t.get_text() for t in figures["top_view"].legends[0].get_texts()]
    assert "where the camera saw the dock" in top_labels
    (distance,) = figures["distance"].axes
    (rug,) = [ln for ln in distance.get_lines() if ln.get_label() == "camera fixes of the dock"]
    # marked at the step the first fix arrived: the image's instant plus the camera's latency
    arrived = first + m.sensors.dock_camera.latency_s
    assert min(rug.get_xdata()) == pytest.approx(arrived, abs=m.controller.dt_s + 1e-9)


def test_ending_text_for_each_way_a_run_ends() -> None:
    nan = math.nan
    assert ending_text({"docked": True, "time_to_dock_s": 19.25, "end_time_s": 19.25}) == "19.25 s"
    assert ending_text({"docked": False, "collided": True, "end_time_s": 12.4}) == "collided at 12.40 s"
    assert ending_text({"docked": False, "reason": "timeout", "end_time_s": 75.0}, 75.0) == "timeout 75 s"
    lost = {"docked": False, "reason": "lost_target", "end_time_s": 45.05, "time_to_dock_s": nan}
    assert ending_text(lost, 75.0) == "gave up finding the dock at 45.05 s"


def test_user_text_is_printed_as_typed(tmp_path: Path) -> None:
    """A mission named with rich markup and an emoji code: printed as written, not styled or drawn."""
    m = load_mission(resolve("still")).with_updates(name="x:smile:[bold]y[/z]")
    path = tmp_path / "odd.yaml"
    path.write_text(m.to_yaml())
    r = _auvdock("sim", str(path), "--timeout", "0.2", "--no-plots", "--out", "out", cwd=tmp_path)
    assert r.returncode == 1, r.stderr
    assert r.stdout.splitlines()[0].startswith("x:smile:[bold]y[/z]: still water; controller oracle")
    assert "results: out/x:smile:[bold]y[/z]_oracle.h5" in r.stdout


def test_ctrl_c_while_the_plots_are_drawn_says_what_was_kept(tmp_path: Path, monkeypatch) -> None:
    """Ctrl-C as the third PNG is saved: exit 130, one line naming the complete results and the two
    plots written; the third is not there (not even in part)."""
    from matplotlib.figure import Figure
    from typer.testing import CliRunner

    from auvdock.cli import app

    saved: list[str] = []
    real = Figure.savefig

    def savefig(self, fname, *args, **kwargs):  # noqa: ANN001
        if len(saved) == 2:
            raise KeyboardInterrupt
        real(self, fname, *args, **kwargs)
        saved.append(str(fname))

    monkeypatch.setattr(Figure, "savefig", savefig)
    r = CliRunner().invoke(app, ["sim", "still", "--timeout", "0.3", "--out", str(tmp_path)])
    assert r.exit_code == 130
    h5 = tmp_path / "still_oracle.h5"
    a, b = tmp_path / "still_oracle_trajectory_3d.png", tmp_path / "still_oracle_top_view.png"
    line = (
        f"interrupted while drawing the plots: the results are complete in {h5}; "
        f"plots written before it: {a}, {b}"
    )
    assert " ".join(r.output.split()).endswith(line), r.output
    assert a.is_file() and b.is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([h5.name, a.name, b.name])


def test_python_dash_m_auvdock(tmp_path: Path) -> None:
    r = _auvdock("--help", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("Usage: python -m auvdock [OPTIONS] COMMAND [ARGS]...")


def test_compare_counts_controllers_and_variants_apart() -> None:
    assert controllers_text(list(controller_specs(True))) == "5 controllers x 2 variants (robust, paper)"
    assert controllers_text(["oracle", "ce"]) == "2 controllers"
    assert controllers_text(["oracle"]) == "1 controller"
    assert controllers_text(["oracle", "naive@paper"]) == "2 controllers"  # not every pair: no product


def test_a_rerun_of_sim_says_it_replaces_the_earlier_files(tmp_path: Path) -> None:
    args = ("sim", "still", "--timeout", "0.2", "--no-plots", "--out", "out")
    first = _auvdock(*args, cwd=tmp_path)
    assert "replacing" not in first.stdout + first.stderr
    second = _auvdock(*args, cwd=tmp_path)
    assert "note: replacing an earlier run's files in out: still_oracle.h5\n" in second.stdout
    assert second.stderr == ""


def test_plot_names_files_as_sim_does(tmp_path: Path) -> None:
    """A run saved under another name (``run.save("my.h5")``) is drawn as ``<mission>_<controller>_*``."""
    import auvdock

    run = auvdock.simulate("still", controller="kinematic", docking__timeout_s=0.3)
    run.save(tmp_path / "my.h5")
    r = _auvdock("plot", "my.h5", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[0] == "still_kinematic_trajectory_3d.png"
    assert (tmp_path / "still_kinematic_thrust.png").is_file() and not list(tmp_path.glob("my_*"))


def test_every_controller_is_in_the_docs_synopsis_and_the_schema() -> None:
    names = controller_names()
    synopsis = (ROOT / "docs" / "commands" / "sim.md").read_text().split("```")[1]
    assert f"--controller {'|'.join(names)}]" in synopsis
    started = (ROOT / "docs" / "getting-started.md").read_text()
    assert f"# {' | '.join(names)}\n" in started
    from auvdock.config.mission import Mission

    described = Mission.model_fields["controller"].description or ""
    assert f"({', '.join(names)})" in described


def test_a_port_with_an_emoji_code_is_printed_as_typed(tmp_path: Path) -> None:
    """``--port udp:abc``: the line ``error: --port udp:abc: not ...`` holds ``:abc:``, an emoji code
    that rich drew as a picture; printed as typed."""
    r = _auvdock("fly", "tank_positioned", "--port", "udp:abc", "--out", "out", cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr == (
        "error: --port udp:abc: not a connection string (expected udp:PORT, udpin:HOST:PORT, "
        "udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or a serial device[,BAUD])\n"
    )
    assert not (tmp_path / "out").exists()
