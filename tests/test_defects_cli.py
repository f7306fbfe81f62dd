"""Command-line defects: one format for every option error, shipped mission names in ``markers``,
Ctrl-C (SIGINT) for a command started with SIGINT ignored.

Option errors go through :func:`auvdock.cli.main` (what the console script runs), as a user sees them:
one line ``error: --OPTION: <problem in plain words>`` and exit 2.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from auvdock.campaign import read_campaign
from auvdock.cli import app, main

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def _main(argv: list[str], capsys) -> tuple[int, str]:
    """(exit status, stderr) of the console script on ``argv``, in this process."""
    previous = signal.getsignal(signal.SIGINT)
    try:
        with pytest.raises(SystemExit) as e:
            main(argv)
    finally:  # main() sets SIGINT as it enters and ignores a late one as it exits: give it back
        signal.signal(signal.SIGINT, previous)
    return e.value.code, capsys.readouterr().err


# ----------------------------------------------------------------------- 6: one format of option errors


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        # sim: typer's own checks (pydantic messages, in plain words) and the command's
        (["sim", "still", "--seed", "abc"], "error: --seed: expected a whole number (got 'abc')"),
        (["sim", "still", "--seed", "-1"], "error: --seed: must be at least 0 (got -1)"),
        (["sim", "still", "--timeout", "soon"], "error: --timeout: expected a number (got 'soon')"),
        (
            ["sim", "still", "--timeout", "-3"],
            "error: --timeout: must be a positive number of seconds (got -3.0)",
        ),
        (["sim", "still", "--seed"], "error: --seed: needs a value"),
        (["sim", "still", "--bogus"], "error: --bogus: no such option (did you mean --out?)"),
        (["sim"], "error: MISSION: required, not given"),
        (["sim", "still", "extra"], "error: extra: unexpected argument (no more arguments are taken)"),
        # compare
        (["compare", "--jobs", "0"], "error: --jobs: must be at least 1 (got 0)"),
        (["compare", "-j", "two"], "error: -j: expected a whole number (got 'two')"),
        (["compare", "--jobs", "1.5"], "error: --jobs: expected a whole number (got 1.5)"),
        (["compare", "still", "--seed", "-1"], "error: --seed: must be at least 0 (got -1)"),
        (["compare", "--pdf=yes"], "error: --pdf: takes no value"),
        # sweep: the name the user typed (--workers is --jobs's older name)
        (["sweep", "model_error", "--jobs", "0"], "error: --jobs: must be at least 1 (got 0)"),
        (["sweep", "model_error", "--workers", "0"], "error: --workers: must be at least 1 (got 0)"),
        # fly
        (["fly", "tank_positioned", "--sysid", "0"], "error: --sysid: must be at least 1 (got 0)"),
        (["fly", "tank_positioned", "--sysid", "256"], "error: --sysid: must be at most 255 (got 256)"),
        (
            ["fly", "tank_positioned", "--connect-timeout", "0"],
            "error: --connect-timeout: must be at least 0.1 (got 0)",
        ),
        # bench
        (["bench", "--case", "two"], "error: --case: expected a whole number (got 'two')"),
        (["bench", "--case", "9"], "error: --case: 9 is not one of the paper's cases 1..6"),
        (["bench", "--timeout", "x"], "error: --timeout: expected a number (got 'x')"),
    ],
)
def test_every_option_error_is_one_line_in_one_format(argv, line, capsys) -> None:
    code, err = _main(argv, capsys)
    assert code == 2, err
    assert err == line + "\n"


def test_no_option_error_names_the_program_or_pydantic(capsys) -> None:
    for argv in (
        ["sim", "still", "--seed", "x"],
        ["compare", "--jobs", "0"],
        ["fly", "tank_positioned", "--sysid", "x"],
    ):
        _, err = _main(argv, capsys)
        assert re.fullmatch(r"error: --[a-z-]+: [^\n]+\n", err), err
        assert "auvdock" not in err and "Input should" not in err and "/-" not in err


# ------------------------------------------------------------------------------ 3: shipped names in markers


def test_markers_takes_a_shipped_mission_name(tmp_path) -> None:
    out = tmp_path / "sheet.pdf"
    res = runner.invoke(app, ["markers", "tank_camera", "-o", str(out)])
    assert res.exit_code == 0, res.output + res.stderr
    assert out.read_bytes()[:5] == b"%PDF-"
    by_file = tmp_path / "by_file.pdf"
    res = runner.invoke(app, ["markers", str(ROOT / "missions" / "tank_camera.yaml"), "-o", str(by_file)])
    assert res.exit_code == 0 and by_file.stat().st_size == out.stat().st_size  # the same sheet


def test_markers_with_an_unknown_name_exits_2_with_one_line(tmp_path) -> None:
    res = runner.invoke(app, ["markers", "no_such_mission", "-o", str(tmp_path / "m.pdf")])
    assert res.exit_code == 2
    assert res.stderr == "error: no_such_mission: no such file (nor a shipped mission of that name)\n"


# ------------------------------------------------------------------------------ 7: Ctrl-C with SIGINT ignored


def _started_ignoring_sigint(args: list[str], cwd: Path) -> subprocess.Popen:
    """``auvdock ARGS`` as a background job of a script starts it: with SIGINT ignored (inherited)."""
    env = {**os.environ, "AUVDOCK_COMPILE": "never", "COLUMNS": "200"}
    return subprocess.Popen(
        [sys.executable, "-m", "auvdock", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
    )


def _read_until(p: subprocess.Popen, pattern: str, lines: list[str]) -> None:
    """Read the command's stdout (in a thread, on and on) until a line matches ``pattern``."""
    seen = threading.Event()

    def read() -> None:
        for line in p.stdout:
            lines.append(line)
            if re.search(pattern, line):
                seen.set()
        seen.set()

    threading.Thread(target=read, daemon=True).start()
    assert seen.wait(300), "".join(lines)
    assert any(re.search(pattern, x) for x in lines), "".join(lines)


def _workers(pid: int) -> list[int]:
    import psutil

    return [
        c.pid for c in psutil.Process(pid).children(recursive=True) if "spawn_main" in " ".join(c.cmdline())
    ]


def _alive(pid: int) -> bool:
    import psutil

    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def _interrupt(p: subprocess.Popen) -> tuple[int, str]:
    p.send_signal(signal.SIGINT)
    try:
        err = p.stderr.read()
        return p.wait(120), err
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()


def test_compare_started_with_sigint_ignored_stops_on_sigint(tmp_path) -> None:
    # 10 s runs (about 2 s each): when the first has finished, six are still to start, so the
    # SIGINT lands while the campaign runs; no run needs to dock
    args = ["compare", "still", "diagonal", "south", "east_strong", "-c", "oracle,naive", "--timeout", "10"]
    p = _started_ignoring_sigint([*args, "--jobs", "2", "--out", str(tmp_path), "--no-plots"], tmp_path)
    lines: list[str] = []
    _read_until(p, r"(docked|timeout) [\d.]+ s\s+\(wall", lines)  # a run has finished: workers are busy
    workers = _workers(p.pid)
    code, err = _interrupt(p)
    assert code == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == (
        f"interrupted: the finished runs are in {tmp_path / 'campaign.h5'}; continue with --resume"
    )
    records, _ = read_campaign(tmp_path / "campaign.h5")  # readable, with the runs that ended
    assert 1 <= len(records) < 8 and all(r["status"] == "done" for r in records)
    assert workers and not any(_alive(pid) for pid in workers)  # stopped with the driver


def test_sweep_started_with_sigint_ignored_stops_on_sigint(tmp_path) -> None:
    from auvdock.sweep import read_sweep

    sweep = tmp_path / "ignored.yaml"
    sweep.write_text(
        f"name: ignored\nbase: {ROOT / 'missions' / 'still.yaml'}\ncontrollers: [naive, oracle]\nseeds: 3\n"
        "timeout_s: 40\n"
    )
    p = _started_ignoring_sigint(
        ["sweep", str(sweep), "--jobs", "2", "--out", str(tmp_path / "out")], tmp_path
    )
    lines: list[str] = []
    _read_until(p, r"^sweep ignored: ", lines)
    deadline = time.monotonic() + 300  # waits for a condition (the workers started), not a duration
    while not _workers(p.pid) and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.05)
    workers = _workers(p.pid)
    assert workers, "".join(lines)
    code, err = _interrupt(p)
    assert code == 130, err
    assert "Traceback" not in err
    path = tmp_path / "out" / "sweep.h5"
    assert (
        err.strip().splitlines()[-1]
        == f"interrupted: the finished runs are in {path}; continue with --resume"
    )
    rows, _ = read_sweep(path)  # readable
    assert len(rows) < 6
    assert not any(_alive(pid) for pid in workers)


def test_fly_refuses_a_wec_dock_before_connecting(capsys, tmp_path) -> None:
    """pacwave_common_10m with its Oracle, told the WEC buoy's true motion in the realised sea, which no
    vehicle knows: fly refuses before connecting: exit 2, one line naming the field and what is missing,
    nothing written (the output in tmp_path, not the mission's runs/ in the clone).  (It was tank_0p6hz's
    dock camera, then basin_regular's dock telemetry, then the WEC dock itself, which fly now flies.)"""
    args = ["fly", "pacwave_common_10m", "--port", "udpin:127.0.0.1:9", "--out", str(tmp_path)]
    code, err = _main(args, capsys)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    assert "pacwave_common_10m.yaml: dock.wec: " in lines[0]
    assert lines[0].endswith(
        "oracle is told the dock's true motion in the realised sea (its definition), which no vehicle knows; "
        "fly a controller that forecasts it from the dock's telemetry (-c ce, sequential, optimized or naive)"
    )
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("rate", "line"),
    [
        ("2", "error: --clock-rate 2: expected a rate in [0.01, 1] (slower than real time)"),
        ("0", "error: --clock-rate 0: expected a rate in [0.01, 1] (slower than real time)"),
        ("abc", "error: --clock-rate: expected a number (got 'abc')"),
    ],
)
def test_a_clock_rate_outside_what_a_rehearsal_can_use_is_one_line(capsys, rate: str, line: str) -> None:
    """``auvdock --clock-rate R``: a rehearsal slower than real time (0.01 <= R <= 1); anything else is one
    line naming the option, exit 2, before any command runs."""
    code, err = _main(["--clock-rate", rate, "missions"], capsys)
    assert code == 2 and err.strip() == line
