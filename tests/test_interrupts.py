"""Ctrl-C at any moment of ``auvdock sim``: exit 130, one line, no traceback, a readable file.

Each moment of the command's life gets a real SIGINT at a chosen point of the program
(tests/helpers/ctrl_c.py runs the command the way the console script does and signals
itself there): while the command line loads its commands, while the controller is built,
as the run starts, after control steps drawn once from a fixed seed (plus the first), while
the outcome is written, and while the summary is printed.  So every moment is exercised at
any machine load, none can come "too late", and the test asserts outcomes, never durations.
"""

from __future__ import annotations

import os
import random
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from auvdock.results.store import read_run

ROOT = Path(__file__).resolve().parents[1]
CTRL_C = ROOT / "tests" / "helpers" / "ctrl_c.py"
TIMEOUT_S = 3  # diagonal / naive docks after 19 s: an uninterrupted run ends by timeout, 60 steps
STEPS = sorted(random.Random(1234).sample(range(1, 60), 3))  # [8, 29, 50]

MOMENTS = [
    pytest.param("import:auvdock.cli.campaign", id="loading-the-commands"),
    pytest.param("call:auvdock.loop.assemble:build_autopilot", id="building-the-controller"),
    pytest.param("call:auvdock.loop.simulation:run_simulation", id="starting-the-run"),
    *[pytest.param(f"sim-step:{k}", id=f"after-step-{k}") for k in [0, *STEPS]],
    pytest.param("call:auvdock.results.store:RunWriter.finish", id="writing-the-outcome"),
    pytest.param("call:auvdock.cli.sim:_summary_table", id="printing-the-summary"),
]


def _sim_interrupted(moment: str, out: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "AUVDOCK_COMPILE": "never", "PYTHONUNBUFFERED": "1"}
    args = ["sim", "diagonal", "-c", "naive", "--timeout", str(TIMEOUT_S), "--no-plots", "--out", str(out)]
    cmd = [sys.executable, str(CTRL_C), moment, *args]
    return subprocess.run(cmd, cwd=out.parent, env=env, capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("moment", MOMENTS)
def test_sim_sigint_at_every_moment(moment: str, tmp_path: Path) -> None:
    out = tmp_path / "runs"
    res = _sim_interrupted(moment, out)
    what = f"{moment}:\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 130, what
    assert "Traceback" not in res.stderr + res.stdout, what
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted"), what
    h5 = out / "diagonal_naive.h5"
    for named in re.findall(r"\S+\.h5", lines[0]):  # the message names only files that are there
        assert Path(named).is_file(), what
        if "complete = False" in lines[0]:
            assert not read_run(named).complete, what
    if h5.exists():  # whatever the moment, what is on disk reads back
        r = read_run(h5)
        assert r.state.shape == (r.n_steps, 12) and np.all(np.isfinite(r.state)), what
    if moment.startswith(("import:", "call:auvdock.loop.assemble:")):  # before the run: no file
        assert lines == ["interrupted"] and not h5.exists(), what
    elif moment == "call:auvdock.loop.simulation:run_simulation":
        assert lines == ["interrupted before the first step: no results file was written"], what
        assert not h5.exists(), what
    elif moment.startswith("sim-step:"):  # every finished step, then incomplete
        k = int(moment.split(":")[1])
        r = read_run(h5)
        assert not r.complete and r.n_steps == k + 1, what
        assert lines == [f"interrupted: the steps so far are in {h5} (complete = False)"], what
    elif moment == "call:auvdock.results.store:RunWriter.finish":  # held back until the outcome is in
        assert lines == [f"interrupted after the run ended: its results are complete in {h5}"], what
        assert read_run(h5).complete, what
    elif moment == "call:auvdock.cli.sim:_summary_table":  # the run had ended whole
        assert lines == ["interrupted"] and read_run(h5).complete, what


def test_sim_sigint_before_the_run_does_not_take_an_earlier_file_for_its_own(tmp_path: Path) -> None:
    out = tmp_path / "runs"
    env = {**os.environ, "AUVDOCK_COMPILE": "never"}
    args = ["sim", "diagonal", "-c", "naive", "--timeout", "1", "--no-plots", "--out", str(out)]
    first = subprocess.run([sys.executable, "-m", "auvdock", *args], env=env, capture_output=True)
    assert first.returncode == 1, first.stderr  # ran whole, did not dock in 1 s
    res = _sim_interrupted("call:auvdock.loop.simulation:run_simulation", out)  # before this run's first step
    what = f"stdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 130, what
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted"), what
    assert "results are complete" not in lines[0], what  # this run wrote nothing
    assert read_run(out / "diagonal_naive.h5").complete  # the earlier run's file, left as it was


def test_importing_the_command_line_leaves_ctrl_c_to_the_importer() -> None:
    """A library user (a notebook) who imports ``auvdock.cli`` and presses Ctrl-C while it loads gets
    Python's KeyboardInterrupt, not an exit of the whole process (the console script's quiet exit 130
    is installed by ``auvdock.__main__``, the program's entry, only)."""
    code = (
        "import os, signal, sys\n"
        "class Finder:\n"
        "    @staticmethod\n"
        "    def find_spec(name, path=None, target=None):\n"
        "        if name == 'auvdock.cli.campaign':\n"
        "            os.kill(os.getpid(), signal.SIGINT)\n"
        "sys.meta_path.insert(0, Finder())\n"
        "try:\n"
        "    import auvdock.cli\n"
        "except KeyboardInterrupt:\n"
        "    print('KeyboardInterrupt')\n"
        "print(signal.getsignal(signal.SIGINT) is signal.default_int_handler)\n"
        "print(signal.getsignal(signal.SIGINT))\n"
    )

    def sigint_as_python_starts_it() -> None:
        # a process born with SIGINT ignored (as a test runner's child can be: twice in four suite runs the
        # child printed "False" with no KeyboardInterrupt, which SIG_IGN inherited through exec gives
        # exactly) gets no handler from Python, whatever it imports: the claim is about one that has it
        signal.signal(signal.SIGINT, signal.SIG_DFL)

    r = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT,
        preexec_fn=sigint_as_python_starts_it,
    )  # fmt: skip
    lines = r.stdout.splitlines()
    assert (r.returncode, lines[:2], r.stderr) == (0, ["KeyboardInterrupt", "True"], ""), r.stdout
