"""A fault-injecting runner for the campaign engine's tests.

The engine calls ``runner(spec, progress)`` in its worker processes (local or Dask);
:func:`inject` wraps :func:`auvdock.campaign.execute_run` and kills or breaks chosen runs.
Tests pass it to :func:`auvdock.campaign.run_plan` as ``functools.partial(inject, ...)``;
it is pickled by reference, so it stays an importable module-level function.  Nothing in
auvdock reads it: production code has no fault hook.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Sequence

from auvdock.campaign import execute_run


def inject(
    spec,
    progress=None,
    *,
    marker_dir: str = "",
    kill_once: Sequence[str] = (),
    kill_always: Sequence[str] = (),
    fail: Sequence[str] = (),
):
    """Run ``spec`` normally unless its id is listed.

    ``kill_once``: SIGKILL this worker the first time the run starts (a marker file in
    ``marker_dir``, ``<run id with / as __>.killed``, remembers it); ``kill_always``:
    SIGKILL it every time; ``fail``: raise RuntimeError("injected failure").
    """
    rid = spec.run_id
    if rid in kill_once:
        marker = os.path.join(marker_dir, rid.replace("/", "__") + ".killed")
        try:
            fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            pass
        else:
            os.close(fd)
            os.kill(os.getpid(), signal.SIGKILL)
    if rid in kill_always:
        os.kill(os.getpid(), signal.SIGKILL)
    if rid in fail:
        raise RuntimeError("injected failure")
    return execute_run(spec, progress)
