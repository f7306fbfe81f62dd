"""The house rules that a reader cannot see at a glance: no import cycles between modules, the
subpackages in floors (each imports only from the floors below it), and the missions and sweeps
installed with the package."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "auvdock"


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path, name: str, modules: set[str]) -> set[str]:
    """auvdock modules that ``name`` imports anywhere: at module level, inside functions (lazy) and
    under ``if TYPE_CHECKING`` (for the types only).  ``from pkg import sub`` counts as importing
    ``pkg.sub``."""
    tree = ast.parse(path.read_text())
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("auvdock"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if not mod.startswith("auvdock"):
                continue
            subs = {f"{mod}.{a.name}" for a in node.names} & modules
            out.update(subs)
            if len(subs) < len(node.names):
                out.add(mod)
    return out & modules


def _graph() -> dict[str, set[str]]:
    """Every auvdock module -> the auvdock modules it imports (see :func:`_imports`)."""
    files = {_module_name(p): p for p in PKG.rglob("*.py")}
    names = set(files)
    return {name: _imports(path, name, names) - {name} for name, path in files.items()}


def test_no_import_cycles() -> None:
    """No module depends on itself through others, deferred (function-level) and type-only imports
    included.

    A package's ``__init__`` may re-export its submodules, so a submodule never imports its
    own package back (it imports the sibling that holds the name)."""
    graph = _graph()
    cycles: list[list[str]] = []
    state: dict[str, int] = {}
    stack: list[str] = []

    def dfs(n: str) -> None:
        state[n] = 1
        stack.append(n)
        for m in sorted(graph[n]):
            if state.get(m) == 1:
                cycles.append(stack[stack.index(m) :] + [m])
            elif m not in state:
                dfs(m)
        stack.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            dfs(n)
    assert not cycles, "import cycles:\n" + "\n".join(" -> ".join(c) for c in cycles)


#: The subpackages in floors, the ground first: a module imports only from its own subpackage and from
#: the floors below (lazy and type-only imports included).  ``auvdock`` itself (the library's entry,
#: ``api``, ``__main__``) stands on top.
FLOORS: list[set[str]] = [
    {"runtime", "schema"},  # the clock, Ctrl-C, compiled code; strict YAML and the settings' base
    {"vehicle"},  # the one model
    {"world", "camera"},  # the current, the sea, the dock; the camera's model, images and poses
    {"sensing"},  # each measurement once, and the simulated sensors
    {"estimation"},  # the estimation stage
    {"controllers"},  # the controllers
    {"config"},  # the mission: every stage's settings gathered, validated, built
    {"results"},  # results files and the run type
    {"loop"},  # the stages, the one closed loop, the assembler, sim
    {"campaign", "fly"},  # many runs; a vehicle over MAVLink
    {"sweep", "standins"},  # sweeps; the stand-in vehicles
    {"cli"},  # the command line
]


def test_the_subpackages_stand_in_floors() -> None:
    """No subpackage knot: every import between subpackages goes down the floors."""
    floor = {pkg: i for i, names in enumerate(FLOORS) for pkg in names}
    subpackages = {p.name for p in PKG.iterdir() if (p / "__init__.py").exists()}
    assert subpackages == set(floor), f"subpackages without a floor: {subpackages ^ set(floor)}"
    wrong = []
    for module, imported in sorted(_graph().items()):
        mine = module.split(".")[1] if module.count(".") else ""
        if mine not in floor:
            continue  # the top: auvdock, auvdock.api, auvdock.__main__, auvdock._version
        for other in sorted(imported):
            theirs = other.split(".")[1] if other.count(".") else ""
            if theirs == mine or theirs == "_version":  # its own subpackage; the version string (a leaf)
                continue
            if theirs not in floor or floor[theirs] >= floor[mine]:
                wrong.append(f"{module} -> {other}")
    assert not wrong, "imports that do not go down the floors:\n" + "\n".join(wrong)


def test_shipped_missions_are_in_the_package() -> None:
    from auvdock.config.catalog import PAPER_MISSIONS, missions_dir, resolve, shipped_missions, shipped_sweeps

    names = {f.name for f in shipped_missions()}
    assert set(PAPER_MISSIONS) <= names and {"tank_0p6hz", "tank_bluerov2"} <= names
    assert {f.name for f in shipped_sweeps()} >= {"current_speed", "tank_trials"}
    assert missions_dir().parent == PKG
    assert resolve("gyre") == missions_dir() / "gyre.yaml"
    assert resolve("no_such_mission") == Path("no_such_mission")


def _see_this_environment(py: Path) -> None:
    """Let the venv of ``py`` import the packages of the environment running the suite: its
    site-packages folders listed in a ``.pth`` file of the venv's own site-packages.  (A venv made
    with ``system_site_packages`` would see the *base* interpreter's packages instead, which in a
    venv of the user's are not the ones ``pip install -e ".[test]"`` put there.)  Folders named in
    a ``.pth`` file are added after the venv's own, and their own ``.pth`` files are not run, so
    the editable install of the checkout stays invisible and the installed auvdock comes first."""
    import site

    own = subprocess.run(
        [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    theirs = [*site.getsitepackages(), *([site.getusersitepackages()] if site.ENABLE_USER_SITE else [])]
    folders = [p for p in dict.fromkeys(theirs) if Path(p).is_dir() and Path(p).resolve() != ROOT]
    (Path(own) / "suite_environment.pth").write_text("".join(f"{p}\n" for p in folders))


@pytest.mark.skipif(os.environ.get("AUVDOCK_SKIP_INSTALL_TEST") == "1", reason="AUVDOCK_SKIP_INSTALL_TEST=1")
@pytest.mark.slow
def test_plain_install_runs_shipped_missions_from_any_folder(tmp_path: Path) -> None:
    """``pip install .`` (not editable) into a fresh venv, then from another folder
    ``auvdock missions`` lists them and ``auvdock sim gyre`` docks.  The venv sees the packages
    of the environment the suite runs in (no network needed), pip among them (so the venv gets no
    copy of its own: ensurepip takes about 8 s); auvdock itself comes from the install."""
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=False)
    py = env_dir / "bin" / "python"
    _see_this_environment(py)
    build = tmp_path / "src"  # a copy, so the install does not write into the checkout
    subprocess.run(
        ["git", "-C", str(ROOT), "ls-files", "-z"], check=True, capture_output=True
    )  # tracked files only
    files = subprocess.run(
        ["git", "-C", str(ROOT), "ls-files", "-z"], check=True, capture_output=True
    ).stdout.split(b"\0")
    for f in files:
        if not f:
            continue
        src = ROOT / f.decode()
        if src.is_symlink() or not src.is_file():
            continue
        dst = build / f.decode()
        dst.parent.mkdir(parents=True, exist_ok=True)
        dst.write_bytes(src.read_bytes())
    r = subprocess.run(
        [str(py), "-m", "pip", "install", "--no-deps", "--no-build-isolation", "-q", str(build)],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {**os.environ, "AUVDOCK_COMPILE": "never", "PYTHONPATH": ""}
    where = subprocess.run(
        [str(py), "-c", "import auvdock; print(auvdock.__file__)"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
    )
    assert str(env_dir) in where.stdout, where
    auvdock = env_dir / "bin" / "auvdock"
    listing = subprocess.run(
        [str(auvdock), "missions"], cwd=elsewhere, env=env, capture_output=True, text=True
    )
    assert listing.returncode == 0, listing.stderr
    assert "gyre" in listing.stdout and "current_speed" in listing.stdout
    sim = subprocess.run(
        [str(auvdock), "sim", "gyre", "--no-plots", "--out", "out"],
        cwd=elsewhere,
        env=env,
        capture_output=True,
        text=True,
    )
    assert sim.returncode == 0, sim.stdout + sim.stderr
    assert (elsewhere / "out" / "gyre_oracle.h5").is_file()
    # the library, as the README shows it: a run held in memory, its xarray view
    code = "import auvdock; r = auvdock.simulate('gyre'); print(r.outcome['docked'], r.to_xarray())"
    lib = subprocess.run([str(py), "-c", code], cwd=elsewhere, env=env, capture_output=True, text=True)
    assert lib.returncode == 0, lib.stderr
    assert lib.stdout.startswith("True <xarray.Dataset>") and "time_s" in lib.stdout, lib.stdout
    assert sys.executable  # the test's own interpreter is untouched


def test_reading_every_shipped_mission_loads_no_casadi_opencv_or_dask() -> None:
    """Reading and validating a mission (``auvdock.load_mission``) needs the settings only: no
    CasADi (the models, the controllers), no OpenCV or PyAV (the camera), no Dask (campaigns).  In a
    fresh interpreter, since this one has them loaded."""
    code = (
        "import sys, auvdock\n"
        "from auvdock.config.catalog import shipped_missions\n"
        "names = [f.name for f in shipped_missions()]\n"
        "for n in names:\n"
        "    auvdock.load_mission(n).with_updates(seed=1)\n"
        "heavy = ('casadi', 'cv2', 'av', 'dask', 'distributed')\n"
        "print(len(names), sorted(k for k in heavy if k in sys.modules))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0, r.stderr
    n, loaded = r.stdout.split(" ", 1)
    assert int(n) >= 15 and loaded.strip() == "[]", r.stdout
