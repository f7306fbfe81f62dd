"""Compiled solvers, cached: CasADi-generated C built once into a shared library and reused.

Evaluating the MPC's derivatives in CasADi's virtual machine costs most of a solve;
the same functions as compiled C run several times faster.  Compiling takes tens of
seconds, so :func:`compiled_nlpsol` does it once per problem: the generated C of the
solver's functions (and of a custom Hessian) is compiled with the system's C compiler into
``<cache>/solvers/<name>-<key>.so``, ``key`` a SHA-256 of everything that defines the
problem (the NLP's expressions with the model parameters, horizon and weights folded in,
the solver plugin and its options, the CasADi version and the compiler flags), and later
builds of the same problem load it (well under a second).

* cache directory: ``$AUVDOCK_CACHE_DIR``, else ``$XDG_CACHE_HOME/auvdock``, else
  ``~/.cache/auvdock``;
* ``$AUVDOCK_COMPILE``:

  - ``auto`` (default): load the compiled library when the cache has it; when it does not,
    run this time on the uncompiled function and compile it in the background, in a detached
    process (its own session: Ctrl-C does not stop it) that puts the library in place when
    it is done, so the first step never waits and later runs load it.  Only one process
    builds a given library (a ``.building`` directory is the lock);
  - ``wait``: compile before the first step (what benchmarks want);
  - ``never``: always the uncompiled function.

  Compiled and uncompiled evaluations give the same bits (the generated C performs CasADi's
  operations in the virtual machine's order, and ``-O1`` without ``-ffast-math`` keeps IEEE
  semantics; ``tests/test_codegen.py`` checks it), so a run's results do not depend on the
  state of the cache, only its speed does.
* ``$CC`` names the compiler (default: ``cc``, then ``gcc``); without one the solver runs
  uncompiled and a warning says so once;
* a cache file that does not load (corrupted, truncated, built for another machine) is
  removed and rebuilt, with a warning.

``auvdock cache info`` lists the cache, ``auvdock cache clear`` empties it.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shlex
import shutil
import signal
import subprocess
import tempfile
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import casadi as ca

from auvdock.runtime.interrupts import sigint_pending, sigint_raises

__all__ = [
    "cache_dir",
    "compile_mode",
    "find_compiler",
    "compiled_nlpsol",
    "compiled_function",
    "compiled_library",
    "cache_entries",
    "clear_cache",
    "set_reporter",
    "background_builds",
    "background_pending",
    "environment",
    "wait_for_background",
    "COMPILE_MODES",
    "CFLAGS",
]

CFLAGS = ("-O1", "-fPIC", "-shared")
_warned_no_compiler = False
_reporter: Callable[[str], contextlib.AbstractContextManager] | None = None
_notifier: Callable[[str], None] | None = None


def set_reporter(
    fn: Callable[[str], contextlib.AbstractContextManager] | None,
    notify: Callable[[str], None] | None = None,
) -> None:
    """Show compiles: ``fn(message)`` returns a context manager held while compiling in the
    foreground; ``notify(message)`` says that a background compile started."""
    global _reporter, _notifier
    _reporter = fn
    _notifier = notify


def _notify(message: str) -> None:
    if _notifier is not None:
        _notifier(message)
    else:
        warnings.warn(message, stacklevel=4)


@contextlib.contextmanager
def _reporting(message: str) -> Iterator[None]:
    if _reporter is None:
        yield
        return
    with _reporter(message):
        yield


def cache_dir() -> Path:
    """Where compiled solvers live (``.../auvdock/solvers``)."""
    root = os.environ.get("AUVDOCK_CACHE_DIR")
    if root:
        base = Path(root)
    else:
        xdg = os.environ.get("XDG_CACHE_HOME")
        base = (Path(xdg) if xdg else Path.home() / ".cache") / "auvdock"
    return base / "solvers"


#: ``$AUVDOCK_COMPILE`` values.
COMPILE_MODES = ("auto", "wait", "never")


def compile_mode() -> str:
    """``auto``, ``wait`` or ``never`` (from ``$AUVDOCK_COMPILE``; module docstring)."""
    mode = os.environ.get("AUVDOCK_COMPILE", "auto").strip().lower()
    if mode not in COMPILE_MODES:
        raise ValueError(f"AUVDOCK_COMPILE={mode!r}: expected one of {', '.join(COMPILE_MODES)}")
    return mode


def find_compiler() -> str | None:
    """The C compiler to use, or None."""
    for name in (os.environ.get("CC"), "cc", "gcc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def _key(parts: list[bytes | str]) -> str:
    h = hashlib.sha256()
    # casadi's stub omits __version__ (set at import from CasadiMeta)
    for p in [ca.__version__, " ".join(CFLAGS), *parts]:  # type: ignore[attr-defined]
        b = p.encode() if isinstance(p, str) else bytes(p)
        h.update(len(b).to_bytes(8, "little"))
        h.update(b)
    return h.hexdigest()[:24]


def _load(name: str, plugin: str, so: Path, opts: dict[str, Any], has_hessian: bool) -> ca.Function:
    o = {k: v for k, v in opts.items() if k not in ("expand", "hess_lag")}
    if has_hessian:
        o["hess_lag"] = ca.external("nlp_hess_l", str(so))
    return ca.nlpsol(name, plugin, str(so), o)


def _compiler_or_none() -> str | None:
    """The compiler to build with, or None (compilation off, or no compiler: warned once)."""
    global _warned_no_compiler
    if compile_mode() == "never":
        return None
    cc = find_compiler()
    if cc is None and not _warned_no_compiler:
        warnings.warn("no C compiler found: MPC solvers run uncompiled (slower)", stacklevel=3)
        _warned_no_compiler = True
    return cc


def _generate(directory: Path, stem: str, write_sources: Callable[[str], list[str]]) -> list[Path]:
    """Write the C sources into ``directory`` (CasADi's code generators write into the cwd)."""
    cwd = os.getcwd()
    os.chdir(directory)
    try:
        return [directory / s for s in write_sources(stem)]
    finally:
        os.chdir(cwd)


#: A background build whose lock is older than this is taken as abandoned (s).
STALE_BUILD_S = 30 * 60
_background: list[subprocess.Popen] = []


def _start_background(
    name: str,
    key: str,
    so: Path,
    cc: str,
    write_sources: Callable[[str], list[str]],
    flags: tuple[str, ...] = (),
) -> bool:
    """Write the sources now and compile them in a detached process that puts the library in
    place when it is done (atomically); False when another process is already building it."""
    directory = so.parent
    directory.mkdir(parents=True, exist_ok=True)
    work = directory / f"{name}-{key}.building"
    try:
        work.mkdir()
    except FileExistsError:
        try:
            age = time.time() - work.stat().st_mtime
        except FileNotFoundError:  # finished meanwhile
            return False
        if age < STALE_BUILD_S:
            return False  # someone else builds it
        shutil.rmtree(work, ignore_errors=True)
        try:
            work.mkdir()
        except FileExistsError:
            return False
    try:
        sources = _generate(work, f"{name}_{key}", write_sources)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    out = work / "lib.so"
    compile_cmd = " ".join(shlex.quote(str(a)) for a in [cc, *CFLAGS, *sources, "-o", out, *flags, "-lm"])
    script = (
        f"{compile_cmd} 2> {shlex.quote(str(work / 'compile.log'))} && mv -f {shlex.quote(str(out))} "
        f"{shlex.quote(str(so))}; rm -rf {shlex.quote(str(work))}"
    )
    # its own session: a Ctrl-C in the terminal ends the run, not the build later runs will use
    proc = subprocess.Popen(
        ["sh", "-c", script],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    _background.append(proc)
    return True


def environment() -> tuple[str, str, str, str]:
    """What decides how a function is built besides its definition: ``$AUVDOCK_COMPILE``, the cache
    directory, the compiler and its flags (a caller that keeps built functions keys them by it too)."""
    return compile_mode(), str(cache_dir()), find_compiler() or "", " ".join(CFLAGS)


def background_pending() -> bool:
    """Whether a background compile this process started is still running (what runs on its function
    meanwhile is uncompiled: a caller that keeps built functions should not keep those)."""
    return any(proc.poll() is None for proc in _background)


def background_builds() -> list[subprocess.Popen]:
    """The background compiles this process started (running or finished)."""
    return list(_background)


def wait_for_background(timeout_s: float | None = None) -> bool:
    """Wait for this process's background compiles; True when none is left running."""
    deadline = None if timeout_s is None else time.monotonic() + timeout_s
    for proc in _background:
        left = None if deadline is None else max(0.0, deadline - time.monotonic())
        try:
            proc.wait(left)
        except subprocess.TimeoutExpired:
            return False
    return True


def _cached_build(
    name: str,
    parts: list[bytes | str],
    cc: str,
    write_sources: Callable[[str], list[str]],
    load: Callable[[Path], Any],
    flags: tuple[str, ...] = (),
) -> tuple[Any, str] | None:
    """Load ``<cache>/<name>-<key>.so``, or build it; None when the caller should run uncompiled
    (the build failed, warned; or, in ``auto`` mode, it goes on in the background).

    ``write_sources(stem)`` writes C files into the working directory and returns their
    names; ``load(so)`` makes the CasADi object from the library; ``flags`` are the compiler's further
    arguments (include paths, libraries to link).
    """
    key = _key([name, *parts, " ".join(flags)])
    directory = cache_dir()
    so = directory / f"{name}-{key}.so"
    if so.is_file():
        try:
            return load(so), "cache"
        except Exception as e:  # noqa: BLE001 -- a bad cache file is rebuilt, never fatal
            warnings.warn(f"compiled solver {so} does not load ({e}); rebuilding it", stacklevel=3)
            so.unlink(missing_ok=True)

    if compile_mode() == "auto":
        if _start_background(name, key, so, cc, write_sources, flags):
            _notify(
                f"compiling {name} in the background for later runs (cached in {directory}); "
                "this run evaluates it uncompiled, with the same results"
            )
        return None

    directory.mkdir(parents=True, exist_ok=True)
    with _reporting(f"compiling {name} once (cached in {directory})"):
        with tempfile.TemporaryDirectory(dir=directory) as tmp:
            tmpd = Path(tmp)
            sources = _generate(tmpd, f"{name}_{key}", write_sources)
            if sigint_pending():  # Ctrl-C while the C was written: do not start the compiler
                raise KeyboardInterrupt
            out = tmpd / "lib.so"
            # its own process group, so that stopping it stops cc1 and the assembler under the driver
            proc = subprocess.Popen(
                [cc, *CFLAGS, *[str(s) for s in sources], "-o", str(out), *flags, "-lm"],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
                start_new_session=True,
            )
            try:
                with sigint_raises():  # the compile may take a minute: Ctrl-C stops it at once
                    _, stderr = proc.communicate()
            except BaseException:  # Ctrl-C: the compiler goes with us, nothing half-built is cached
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                raise
            if proc.returncode != 0:
                warnings.warn(
                    f"compiling the {name} solver failed ({cc}: {stderr.strip()[:300]}); running uncompiled",
                    stacklevel=3,
                )
                return None
            os.replace(out, so)  # atomic: concurrent builders never see a half-written file
    return load(so), "compiled"


def compiled_nlpsol(
    name: str,
    plugin: str,
    nlp: dict[str, Any],
    opts: dict[str, Any],
    *,
    key_parts: list[bytes | str] | None = None,
) -> tuple[ca.Function, str]:
    """``ca.nlpsol(name, plugin, nlp, opts)``, compiled and cached when possible.

    Parameters
    ----------
    nlp : dict
        ``{"x", "f", "g", "p"}`` (SX expressions).
    opts : dict
        Solver options; a ``hess_lag`` Function among them is compiled too.
    key_parts : list, optional
        Anything else that defines the problem (added to the cache key).

    Returns
    -------
    (solver, how)
        ``how`` is ``"cache"`` (loaded), ``"compiled"`` (built now), or ``"uncompiled"``.
    """
    solver = ca.nlpsol(name, plugin, nlp, opts)
    cc = _compiler_or_none()
    if cc is None:
        return solver, "uncompiled"

    hess = opts.get("hess_lag")
    if hess is not None and hess.name() != "nlp_hess_l":
        raise ValueError(f"hess_lag must be named nlp_hess_l, not {hess.name()!r}")
    fn = ca.Function("nlp", [nlp["x"], nlp["p"]], [nlp["f"], nlp.get("g", ca.SX(0, 1))])
    safe_opts = {k: v for k, v in opts.items() if k != "hess_lag"}
    parts: list[bytes | str] = [plugin, repr(sorted(safe_opts.items(), key=lambda kv: kv[0])), fn.serialize()]
    if hess is not None:
        parts.append(hess.serialize())
    parts += list(key_parts or [])

    def write_sources(stem: str) -> list[str]:
        sources = [f"{stem}_deps.c"]
        solver.generate_dependencies(sources[0])
        if hess is not None:
            cg = ca.CodeGenerator(f"{stem}_hess.c")
            cg.add(hess)
            cg.generate()
            sources.append(f"{stem}_hess.c")
        return sources

    built = _cached_build(
        name, parts, cc, write_sources, lambda so: _load(name, plugin, so, opts, hess is not None)
    )
    return (solver, "uncompiled") if built is None else built


def compiled_function(
    fn: ca.Function, *, key_parts: list[bytes | str] | None = None
) -> tuple[ca.Function, str]:
    """A CasADi Function, compiled and cached when possible (same cache and rules as solvers).

    Returns ``(function, how)`` with ``how`` as in :func:`compiled_nlpsol`; the function has
    the same inputs and outputs (and name) as ``fn``.
    """
    cc = _compiler_or_none()
    if cc is None:
        return fn, "uncompiled"

    def write_sources(stem: str) -> list[str]:
        cg = ca.CodeGenerator(f"{stem}.c")
        cg.add(fn)
        cg.generate()
        return [f"{stem}.c"]

    built = _cached_build(
        fn.name(),
        [fn.serialize(), *(key_parts or [])],
        cc,
        write_sources,
        lambda so: ca.external(fn.name(), str(so)),
    )
    return (fn, "uncompiled") if built is None else built


def compiled_library(
    name: str,
    key_parts: list[bytes | str],
    write_sources: Callable[[str], list[str]],
    load: Callable[[Path], Any],
    flags: tuple[str, ...] = (),
) -> tuple[Any, str] | None:
    """A shared library of C sources, built once and cached under the same rules as the solvers
    (``$AUVDOCK_COMPILE``, the cache directory, the background build): ``(load(so), how)``, or None when
    the caller should run its uncompiled reference this time (no compiler, compilation off, the build
    failed (warned) or goes on in the background).

    ``key_parts`` is everything that defines the library; ``write_sources(stem)`` writes the C files
    into the working directory and returns their names; ``flags`` are the compiler's further arguments.
    """
    cc = _compiler_or_none()
    if cc is None:
        return None
    return _cached_build(name, key_parts, cc, write_sources, load, flags)


def cache_entries() -> list[tuple[Path, int]]:
    """The compiled solvers in the cache: (path, size in bytes)."""
    d = cache_dir()
    if not d.is_dir():
        return []
    return sorted((p, p.stat().st_size) for p in d.glob("*.so"))


def clear_cache() -> int:
    """Remove every compiled solver; returns how many were removed."""
    n = 0
    for p, _ in cache_entries():
        p.unlink(missing_ok=True)
        n += 1
    return n
