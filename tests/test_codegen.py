"""The compiled-solver cache (auvdock.runtime.codegen): build once, load after, rebuild when needed."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from auvdock.config.mission import load_mission
from auvdock.controllers import build_controller
from auvdock.runtime import codegen
from auvdock.vehicle import Vehicle

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("AUVDOCK_COMPILE", "wait")
    monkeypatch.setenv("AUVDOCK_CACHE_DIR", str(tmp_path / "cache"))
    if codegen.find_compiler() is None:
        pytest.skip("no C compiler")
    return tmp_path / "cache" / "solvers"


QUICK_CFLAGS = ("-O0", "-fPIC", "-shared")


@pytest.fixture
def quick(monkeypatch):
    """-O0 for the tests of the cache's mechanics (what is built, kept, rebuilt): the generated C
    compiles in about 5 s instead of 23 s; the flags are part of the cache key, so nothing mixes.
    The claim about the shipped flags (same bits as uncompiled) keeps them."""
    monkeypatch.setattr(codegen, "CFLAGS", QUICK_CFLAGS)


def _small(**updates):
    # a short horizon keeps the generated C small (a few seconds to compile)
    m = load_mission(ROOT / "missions" / "diagonal.yaml").with_updates(
        **{"controller.horizon_steps": 2, **updates}
    )
    # a vehicle of its own, as a later process has: nothing built before in this one (what a process
    # built it keeps, auvdock.vehicle.Vehicle.built; here the cache on disk is under test)
    return m, Vehicle(m.vehicle_params()), m.build_dock()


def _first_move(c, m) -> np.ndarray:
    return c.mpc.solve(0.0, m.start_state(), np.zeros(8), np.array([0.5, 0.5, 0.0])).thrust


def _oracle(m, v, d):
    return build_controller(m.with_controller("oracle").controller, v, d)


# Compiling is most of these tests' time, so what several tests need is compiled once per module
# (each test that changes a cache works on its own copy): the small problem at the quick flags
# into a fresh cache, and the auto mode's first use at the shipped flags.


@pytest.fixture(scope="module")
def quick_build(tmp_path_factory):
    """The small problem's first build into an empty cache at the quick flags (wait mode):
    (its cache's ``solvers`` folder, the build's ``mpc.build``)."""
    if codegen.find_compiler() is None:
        pytest.skip("no C compiler")
    root = tmp_path_factory.mktemp("quick_cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("AUVDOCK_COMPILE", "wait")
        mp.setenv("AUVDOCK_CACHE_DIR", str(root))
        mp.setattr(codegen, "CFLAGS", QUICK_CFLAGS)
        build = _oracle(*_small()).mpc.build
    return root / "solvers", build


@pytest.fixture(scope="module")
def auto_first_use(tmp_path_factory) -> dict:
    """The auto mode's first use of the small problem, into an empty cache at the shipped flags:
    a first build (uncompiled, compiling in the background), a second one while that compiles,
    the wait for the background builds, and a build after them; what each saw, and the first
    move of the first and the last build."""
    if codegen.find_compiler() is None:
        pytest.skip("no C compiler")
    root = tmp_path_factory.mktemp("auto_cache")
    notices: list[str] = []
    seen: dict = {"cache": root / "solvers"}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("AUVDOCK_COMPILE", "auto")
        mp.setenv("AUVDOCK_CACHE_DIR", str(root))
        mp.setattr(codegen, "_notifier", notices.append)
        m, v, d = _small()
        seen["c1"] = c1 = _oracle(m, v, d)
        seen["notices_after_first"] = sorted(notices)
        seen["second_build"] = _oracle(m, v, d).mpc.build
        seen["notices_after_second"] = len(notices)
        seen["waited"] = codegen.wait_for_background(timeout_s=600)
        seen["returncodes"] = [p.returncode for p in codegen.background_builds()]
        seen["so"] = sorted(p.name for p in seen["cache"].glob("*.so"))
        seen["building"] = sorted(p.name for p in seen["cache"].glob("*.building"))
        seen["c3"] = c3 = _oracle(m, v, d)
        seen["first_moves"] = (_first_move(c1, m), _first_move(c3, m))
        seen["cflags"] = codegen.CFLAGS
    return seen


@pytest.mark.slow
def test_build_once_then_load_and_same_answer(quick_build, quick, monkeypatch) -> None:
    cache, first_build = quick_build
    assert first_build == "compiled"
    # the RTI's whole step (QP data and HPIPM) and the offset-free observer's one-step model
    assert sorted(p.name.split("-")[0] for p in cache.glob("*.so")) == ["mpc_model_step", "rti_ocp_qp"]
    monkeypatch.setenv("AUVDOCK_COMPILE", "wait")
    monkeypatch.setenv("AUVDOCK_CACHE_DIR", str(cache.parent))
    m, v, d = _small()
    c2 = build_controller(m.with_controller("oracle").controller, v, d)
    assert c2.mpc.build == "cache"
    # the compiled solver gives the uncompiled one's answer
    u_compiled = _first_move(c2, m)
    monkeypatch.setenv("AUVDOCK_COMPILE", "never")
    c3 = build_controller(m.with_controller("oracle").controller, v, d)
    assert c3.mpc.build == "uncompiled"
    assert np.allclose(u_compiled, _first_move(c3, m), atol=1e-6)


@pytest.mark.slow
def test_changed_parameter_builds_anew(cache, quick, quick_build) -> None:
    shutil.copytree(quick_build[0], cache)  # the problem built once (a copy: this test adds to it)
    m, v, d = _small()
    assert build_controller(m.with_controller("oracle").controller, v, d).mpc.build == "cache"
    m2, v2, d2 = _small(**{"controller.weights.R": 20.0})
    assert build_controller(m2.with_controller("oracle").controller, v2, d2).mpc.build == "compiled"
    assert len(list(cache.glob("rti_ocp_qp-*.so"))) == 2  # the model step did not change
    assert len(list(cache.glob("mpc_model_step-*.so"))) == 1
    assert {p.name for p, _ in codegen.cache_entries()} == {p.name for p in cache.glob("*.so")}
    assert codegen.clear_cache() == 3
    assert codegen.cache_entries() == []


@pytest.mark.slow
def test_corrupted_cache_file_is_rebuilt_with_a_warning(cache, quick, quick_build) -> None:
    shutil.copytree(quick_build[0], cache)  # the problem built once (a copy: this test breaks it)
    m, v, d = _small()
    (so,) = cache.glob("rti_ocp_qp-*.so")
    so.write_bytes(b"not a shared library")
    with pytest.warns(UserWarning, match="does not load"):
        c = build_controller(m.with_controller("oracle").controller, v, d)
    assert c.mpc.build == "compiled"
    assert so.stat().st_size > 1000


def test_no_compiler_runs_uncompiled_with_a_warning(cache, monkeypatch) -> None:
    monkeypatch.setattr(codegen, "find_compiler", lambda: None)
    monkeypatch.setattr(codegen, "_warned_no_compiler", False)
    m, v, d = _small()
    with pytest.warns(UserWarning, match="no C compiler found"):
        c = build_controller(m.with_controller("oracle").controller, v, d)
    assert c.mpc.build == "uncompiled"
    assert np.all(np.isfinite(_first_move(c, m)))


def test_compile_notice_is_plain_lines_when_redirected(capsys) -> None:
    """With stderr not a terminal (a log file, a pipe) the compile notice is one plain line before
    and one after (a spinner would print nothing there: a minute of silence in a log)."""
    from auvdock.cli.app import _compile_notice

    with _compile_notice("compiling the mpc solver once (cached in /tmp/x)"):
        pass
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "compiling the mpc solver once (cached in /tmp/x) - about a minute, once"
    assert re.fullmatch(r"compiled in \d+ s", err[1])
    assert len(err) == 2


@pytest.mark.slow
def test_auto_mode_runs_uncompiled_and_compiles_in_the_background(auto_first_use) -> None:
    """First use never waits: the uncompiled function runs, a detached process builds the library
    (one notice), and the next build loads it.  Both give the same bits, so a run's results do not
    depend on the state of the cache."""
    seen = auto_first_use
    assert seen["c1"].mpc.build == "uncompiled"
    assert seen["notices_after_first"] == [
        f"compiling {name} in the background for later runs (cached in {seen['cache']}); "
        "this run evaluates it uncompiled, with the same results"
        for name in ("mpc_model_step", "rti_ocp_qp")
    ]
    # a second build while the first compiles neither waits nor starts another one
    assert seen["second_build"] in ("uncompiled", "cache") and seen["notices_after_second"] == 2
    assert seen["waited"]
    assert all(code == 0 for code in seen["returncodes"])
    assert len(seen["so"]) == 2 and not seen["building"]
    assert seen["c3"].mpc.build == "cache"
    uncompiled, loaded = seen["first_moves"]
    assert np.array_equal(uncompiled, loaded)


@pytest.mark.slow
def test_compiled_and_uncompiled_functions_give_the_same_bits(auto_first_use) -> None:
    """The claim the background compile rests on, on the MPC's own QP (its data the largest function):
    the whole step the auto mode's first use built at the shipped flags (the data function's generated
    C and HPIPM's OCP-QP interface), loaded from the cache, against the step that first use ran (the
    data function uncompiled, HPIPM through CasADi's plugin), on random iterates and parameters."""
    assert auto_first_use["cflags"] == codegen.CFLAGS  # built at the shipped flags
    c, c_plain = auto_first_use["c3"], auto_first_use["c1"]
    assert c.mpc.build == "cache" and c_plain.mpc.build == "uncompiled"
    compiled, plain = c.mpc._solver._rti, c_plain.mpc._solver._rti
    assert compiled.ocp is not None and plain.ocp is None
    rng = np.random.default_rng(7)
    nw = compiled.ocp.nw
    lbx, ubx = np.full(nw, -np.inf), np.full(nw, np.inf)
    ix0 = c.mpc._ix[0]
    for _ in range(20):
        w = rng.normal(size=nw) * 0.1
        p = rng.normal(size=c.mpc._n_params) * 0.5
        lbx[ix0] = ubx[ix0] = w[ix0]
        a, b = compiled.step(w, p, lbx, ubx, 0.0, 0.0), plain.step(w, p, lbx, ubx, 0.0, 0.0)
        assert np.array_equal(a[0], b[0]) and a[1:3] == b[1:3]


@pytest.mark.parametrize(
    "moment",
    [
        pytest.param("call:auvdock.runtime.codegen:_generate", id="writing-the-C"),
        pytest.param("call:subprocess:Popen.communicate@{cache}", id="compiler-running"),
    ],
)
def test_ctrl_c_while_compiling_stops_the_compiler_and_says_so(moment: str, tmp_path) -> None:
    """AUVDOCK_COMPILE=wait: Ctrl-C during the first-use compile -- while its C is written, or while
    the C compiler runs -- ends the run (exit 130, one line) and takes the C compiler with it;
    nothing half-built is left in the cache.  The SIGINT comes at that point of the program
    (tests/helpers/ctrl_c.py: entering the code generation / the wait for the compiler), whatever
    the machine's load."""
    import os
    import subprocess
    import sys

    if codegen.find_compiler() is None:
        pytest.skip("no C compiler")
    cache_root = tmp_path / "cache"
    env = {
        **os.environ,
        "AUVDOCK_COMPILE": "wait",
        "AUVDOCK_CACHE_DIR": str(cache_root),
        "PYTHONUNBUFFERED": "1",
    }
    ctrl_c = ROOT / "tests" / "helpers" / "ctrl_c.py"
    args = ["sim", "still", "--no-plots", "--out", str(tmp_path / "out")]
    res = subprocess.run(
        [sys.executable, str(ctrl_c), moment.format(cache=cache_root), *args],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        timeout=300,
    )
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 130, res.stderr
    assert lines[-1] == "interrupted", res.stderr
    assert re.match(r"compiling \w+ once \(cached in ", lines[0]), res.stderr  # it had started
    assert "Traceback" not in res.stderr
    left = subprocess.run(["pgrep", "-f", str(cache_root)], capture_output=True, text=True)
    assert left.stdout.strip() == "", "a compiler is still running"
    solvers = cache_root / "solvers"
    assert not solvers.exists() or list(solvers.iterdir()) == []  # nothing built, nothing half-built
