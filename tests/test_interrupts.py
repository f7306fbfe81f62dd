"""Ctrl-C at any moment of ``auvdock sim``: exit 130, one line, no traceback, a readable file.

The moments are drawn at random over the command's whole life (loading, building the
controller, the run, writing), six of them; the test asserts outcomes, never durations.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from auvdock.results.store import read_run

ROOT = Path(__file__).resolve().parents[1]


def _interrupt_after(delay_s: float, out: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "AUVDOCK_COMPILE": "never", "PYTHONUNBUFFERED": "1"}
    cmd = [sys.executable, "-m", "auvdock.cli", "sim", "diagonal", "-c", "naive", "--timeout", "75"]
    cmd += ["--no-plots", "--out", str(out)]
    p = subprocess.Popen(
        cmd, cwd=out.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    time.sleep(delay_s)
    if p.poll() is None:
        p.send_signal(signal.SIGINT)
    stdout, stderr = p.communicate(timeout=120)
    return subprocess.CompletedProcess(cmd, p.returncode, stdout, stderr)


@pytest.mark.parametrize("k", range(6))
def test_sim_sigint_at_a_random_moment(k: int, tmp_path: Path) -> None:
    delay = float(np.random.default_rng(1000 + k).uniform(0.3, 3.0))
    out = tmp_path / "runs"
    res = _interrupt_after(delay, out)
    if res.returncode in (0, 1):  # it finished first (a fast machine): then it must have finished whole
        r = read_run(out / "diagonal_naive.h5")
        assert r.complete
        pytest.skip(f"the run ended before the signal at {delay:.2f} s")
    assert res.returncode == 130, res.stderr
    assert "Traceback" not in res.stderr and "Traceback" not in res.stdout
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted"), (delay, res.stderr, res.stdout)
    h5 = out / "diagonal_naive.h5"
    if h5.exists():  # interrupted after the run started: every finished step is readable
        r = read_run(h5)
        assert not r.complete
        assert r.state.shape == (r.n_steps, 12)
        assert np.all(np.isfinite(r.state))
