"""The scripts in examples/ run as a user runs them, from another folder, and do what they say."""

from __future__ import annotations

import itertools
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from auvdock.results.store import read_run

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def run_example(name: str, *args: str, cwd: Path) -> str:
    """``python examples/<name> [args]`` from ``cwd``; its stdout (the test fails on a non-zero exit)."""
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}
    env.setdefault("AUVDOCK_COMPILE", "never")
    r = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, f"{name} failed:\n{r.stdout}\n{r.stderr}"
    assert "Traceback" not in r.stderr
    return r.stdout


def test_every_example_is_tested() -> None:
    tested = {"run_mission.py", "small_campaign.py", "plot_run.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_run_mission_prints_the_outcome_and_saves_the_run(tmp_path: Path) -> None:
    out = run_example("run_mission.py", "out", cwd=tmp_path)
    assert out.startswith("Run(mission='gyre', controller='oracle', docked at ")
    assert re.search(r"^docked: +True$", out, re.M), out
    t = float(re.search(r"^time to dock: +([0-9.]+) s$", out, re.M).group(1))
    assert 0 < t <= 10.0
    saved = tmp_path / "out" / "run.h5"
    assert re.search(r"^saved: +(.+)$", out, re.M).group(1) == "out/run.h5"
    results = read_run(saved)  # the results file auvdock sim writes: auvdock plot reads it
    assert results.complete and results.mission_name == "gyre"
    outcome = results.outcome()
    assert outcome["docked"] is True and round(outcome["time_to_dock_s"], 2) == t
    assert results.attrs["tolerance_m"] == 0.2 and results.attrs["timeout_s"] == 10.0
    assert np.allclose(results.dock_position_m[0, :2], [0.8, 0.6])


def test_small_campaign_flies_every_pair(tmp_path: Path) -> None:
    import pandas as pd

    out = run_example("small_campaign.py", str(tmp_path / "camp"), cwd=tmp_path)
    table = pd.read_csv(tmp_path / "camp" / "campaign.csv")
    pairs = set(zip(table["mission"], table["controller"], strict=True))
    assert pairs == set(itertools.product(("diagonal", "gyre"), ("naive", "oracle")))
    assert (table["steps"] == 41).all() and (~table["docked"]).all()  # 2 s at dt 0.05 s, and the final row
    assert np.allclose(table["start_distance_m"], np.hypot(2.0, 3.0))
    assert ((table["end_distance_m"] > 0) & (table["end_distance_m"] < table["start_distance_m"])).all()
    assert np.allclose(table["closed_m"], table["start_distance_m"] - table["end_distance_m"])
    for mission, controller in pairs:
        r = read_run(tmp_path / "camp" / f"{mission}_{controller}.h5")
        assert (r.mission_name, r.controller, r.n_steps) == (mission, controller, 41)
        row = table[(table["mission"] == mission) & (table["controller"] == controller)].iloc[0]
        assert np.isclose(r.distance_m[-1], row["end_distance_m"])
    assert "closest after 2 s on diagonal:" in out and "closest after 2 s on gyre:" in out
    assert out.count("\n") >= 5  # header, four rows, the verdicts


def test_plot_run_draws_a_figure_in_a_temporary_folder(tmp_path: Path) -> None:
    import matplotlib.image as mpimg

    out = run_example("plot_run.py", cwd=tmp_path)
    assert out.startswith("Run(mission='gyre', controller='oracle', not docked (timeout")
    path = Path(re.search(r"^figure: (.+)$", out, re.M).group(1))
    try:
        assert path.is_absolute() and path.name == "run.png" and not path.is_relative_to(tmp_path)
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        image = mpimg.imread(path)
        assert image.shape[:2] == (420, 1400)  # 14 x 4.2 in at 100 dpi
        assert float(np.std(image[..., :3])) > 0.05  # something is drawn
    finally:
        shutil.rmtree(path.parent, ignore_errors=True)


@pytest.mark.parametrize("name", ["run_mission.py", "small_campaign.py", "plot_run.py"])
def test_examples_have_a_usage_docstring(name: str) -> None:
    text = (EXAMPLES / name).read_text()
    assert text.startswith('"""') and f"python examples/{name}" in text
