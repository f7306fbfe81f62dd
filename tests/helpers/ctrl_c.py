"""Run an ``auvdock`` command in this process with Ctrl-C (SIGINT) at a chosen moment.

    python tests/helpers/ctrl_c.py MOMENT sim diagonal -c naive --out runs

runs ``auvdock sim diagonal -c naive --out runs`` exactly as the console script does
(:func:`auvdock.__main__.main`), and sends the process a real SIGINT (``os.kill``) once, at MOMENT:

``import:MODULE``
    when MODULE is first imported (``import:auvdock.cli.campaign``: while the command line
    loads its commands);
``call:MODULE:NAME[@TEXT]``
    on entering the first call of the function or method NAME of MODULE
    (``call:auvdock.results.store:RunWriter.finish``), or the first call with TEXT in one of its
    arguments (or in an argument's ``args``, such as a ``Popen``'s command line);
``sim-step:K``
    in ``auvdock sim``, just after control step K (0 = the first): from
    :func:`auvdock.loop.simulation.run_simulation`'s ``progress`` callback;
``fly-step:K``
    in ``auvdock fly``, just after control step K (``FlySession.run``'s ``progress``);
``fly-event:TEXT``
    in ``auvdock fly``, just after the session's first event that starts with TEXT
    (``connected``, ``armed``, ...; ``FlySession.run``'s ``on_event``).

The signal lands at that point of the program whatever the machine's load, so a test can
exercise every moment of a command's life without timing anything.  If the moment never
comes, the process says so on stderr as it exits (``ctrl_c.py: the moment ... never came``).
"""

from __future__ import annotations

import atexit
import functools
import importlib
import os
import signal
import sys
from typing import Any

_fired: list[str] = []


def ctrl_c(moment: str) -> None:
    """SIGINT to this process (the first time only); the signal named by the environment variable
    ``CTRL_C_SIGNAL`` instead (``SIGTERM``), where it is set."""
    if not _fired:
        _fired.append(moment)
        os.kill(os.getpid(), getattr(signal, os.environ.get("CTRL_C_SIGNAL", "SIGINT")))


def _mentions(args: tuple[Any, ...], kwargs: dict[str, Any], text: str) -> bool:
    values = [*args, *kwargs.values()]
    return any(text in str(v) or text in str(getattr(v, "args", "")) for v in values)


def _on_call(moment: str, spec: str) -> None:
    target, _, text = spec.partition("@")
    module_name, _, qualname = target.partition(":")
    owner: Any = importlib.import_module(module_name)
    *path, name = qualname.split(".")
    for part in path:
        owner = getattr(owner, part)
    real = getattr(owner, name)  # an AttributeError here: the moment names nothing

    @functools.wraps(real)
    def hooked(*args: Any, **kwargs: Any) -> Any:
        if not text or _mentions(args, kwargs, text):
            ctrl_c(moment)
        return real(*args, **kwargs)

    setattr(owner, name, hooked)


def _on_import(moment: str, module_name: str) -> None:
    class Finder:
        @staticmethod
        def find_spec(name: str, path: Any = None, target: Any = None) -> None:
            if name == module_name:
                ctrl_c(moment)

    sys.meta_path.insert(0, Finder())


def _on_sim_step(moment: str, k: int) -> None:
    import auvdock.loop.simulation as simulation

    real = simulation.run_simulation

    @functools.wraps(real)
    def simulate(*args: Any, progress: Any = None, **kwargs: Any) -> Any:
        def each(p: Any) -> None:
            if progress is not None:
                progress(p)
            if p.step == k:
                ctrl_c(moment)

        return real(*args, progress=each, **kwargs)

    simulation.run_simulation = simulate


def _on_fly(moment: str, kind: str, value: str) -> None:
    from auvdock.fly.session import FlySession

    real = FlySession.run
    steps = [0]

    @functools.wraps(real)
    def run(self: Any, progress: Any = None, on_event: Any = None) -> Any:
        def each_step(*a: Any) -> None:
            if progress is not None:
                progress(*a)
            if kind == "fly-step" and steps[0] == int(value):
                ctrl_c(moment)
            steps[0] += 1

        def each_event(t: float, text: str) -> None:
            if on_event is not None:
                on_event(t, text)
            if kind == "fly-event" and text.startswith(value):
                ctrl_c(moment)

        return real(self, progress=each_step, on_event=each_event)

    FlySession.run = run


def install(moment: str) -> None:
    """Arrange the SIGINT at ``moment`` (see the module docstring)."""
    kind, _, value = moment.partition(":")

    @atexit.register
    def say_if_it_never_came() -> None:
        if not _fired:
            sys.stderr.write(f"ctrl_c.py: the moment {moment} never came\n")

    if kind == "import":
        _on_import(moment, value)
    elif kind == "call":
        _on_call(moment, value)
    elif kind == "sim-step":
        _on_sim_step(moment, int(value))
    elif kind in ("fly-step", "fly-event"):
        _on_fly(moment, kind, value)
    else:
        raise SystemExit(f"ctrl_c.py: unknown moment {moment!r}")


if __name__ == "__main__":
    install(sys.argv[1])
    sys.argv = ["auvdock", *sys.argv[2:]]
    from auvdock.__main__ import main  # the console script's entry

    main()
