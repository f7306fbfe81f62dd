"""One run, in whatever process runs it: :func:`execute_run`.

It builds the run's nominal and truth missions, the autopilot from the nominal one
(:func:`auvdock.loop.assemble.build_autopilot`, timed: that is where solvers are built and
compiled), flies the truth plant with it (:func:`auvdock.loop.simulation.run_simulation`), and
returns plain data: the run's table row and, when the spec names a run group, the run as
an HDF5 file image (bytes), which the driver copies into the results file.  Nothing here
writes to the results file and nothing needs a file system shared with the driver.
"""

from __future__ import annotations

import math
import os
import socket
import time
import traceback
from collections.abc import Callable
from typing import Any

from auvdock.campaign.spec import OUTCOME_COLUMNS, RunSpec, apply_overrides, empty_row

__all__ = ["RUN_GROUP", "ProgressFn", "execute_run", "worker_name"]

#: ``progress(t_s, timeout_s, distance_m)``, called about 5 times per second.
ProgressFn = Callable[[float, float, float], None]

#: The run's group inside the file image a worker returns.
RUN_GROUP = "run"


def worker_name() -> str:
    """``host:pid`` of this process."""
    return f"{socket.gethostname()}:{os.getpid()}"


def execute_run(spec: RunSpec, progress: ProgressFn | None = None) -> dict[str, Any]:
    """Run one spec and return ``{"run_id", "row", "image"}``.

    ``row`` has every outcome column (:data:`auvdock.campaign.spec.OUTCOME_COLUMNS`) and
    the spec's labels; ``image`` is the run group as HDF5 file bytes (group ``/run``) when
    ``spec.group`` is set, else None.  Never raises for a failure of the run itself: an
    exception becomes ``status = "failed"`` with ``error = "Type: message"`` (and the
    traceback under ``"traceback"``).
    """
    import h5py

    from auvdock.loop.assemble import build_autopilot
    from auvdock.loop.simulation import run_simulation

    row = empty_row(spec, {**OUTCOME_COLUMNS})
    row["worker"] = worker_name()
    row["attempts"] = 1
    image: bytes | None = None
    last = [0.0]

    def on_step(p) -> None:
        now = time.monotonic()
        if progress is not None and now - last[0] > 0.2:
            last[0] = now
            progress(p.t, p.timeout_s, p.distance_m)

    try:
        nominal = apply_overrides(spec.mission, spec.overrides, spec.run_id)
        truth = nominal
        if spec.truth_overrides:
            truth = apply_overrides(
                nominal.resolved(),
                {f"vehicle.overrides.{k}": v for k, v in spec.truth_overrides.items()},
                spec.run_id,
            )
        t0 = time.perf_counter()
        autopilot = build_autopilot(nominal, nominal.build_vehicle(), nominal.build_dock(), spec.controller)
        setup = time.perf_counter() - t0
        if spec.group is not None:
            with h5py.File(f"{spec.run_id}.h5", "w", driver="core", backing_store=False) as f:
                s = run_simulation(truth, autopilot=autopilot, out=f, group=f"/{RUN_GROUP}", progress=on_step)
                f.flush()
                image = f.id.get_file_image()
        else:
            s = run_simulation(truth, autopilot=autopilot, progress=on_step)
        o = s.outcome
        for name in OUTCOME_COLUMNS:
            if name in o and name not in ("controller", "seed", "status", "error", "worker", "attempts"):
                row[name] = o[name]
        row["docked"] = bool(o.get("docked", False))
        row["timeout_s"] = float(truth.docking.timeout_s)
        row["tolerance_m"] = float(truth.docking.tolerance_m)
        reported = o.get("setup_time_s")  # the autopilot's own build time, when simulate reports it
        row["setup_time_s"] = float(reported) if reported is not None and math.isfinite(reported) else setup
        row["status"], row["error"] = "done", ""
    except Exception as e:  # noqa: BLE001 -- recorded in the row, never stops the campaign
        row["status"], row["reason"], row["docked"] = "failed", "error", False
        row["error"] = f"{type(e).__name__}: {e}"
        row["traceback"] = traceback.format_exc()
        image = None
    return {"run_id": spec.run_id, "row": row, "image": image}
