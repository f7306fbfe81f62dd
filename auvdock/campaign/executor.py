"""Where runs execute: local worker processes (default) or a Dask cluster.

Both executors take runs with :meth:`submit` and report what happened with :meth:`poll`,
as :class:`Event` s; neither writes results nor decides about retries (the engine,
:mod:`auvdock.campaign.engine`, does both, the same way for both executors).

:class:`LocalExecutor`
    ``workers`` spawned processes, each running ONE run at a time, fed over its own pipe.
    A worker that dies (killed, out of memory, a segfault in a solver) costs only the run
    it held: the engine gets a ``"lost"`` event for it, and a new process replaces the
    dead one when there is work left.  The workers ignore SIGINT (a Ctrl-C in a terminal
    reaches the whole process group; only the driver acts on it) and write their output
    (CasADi's warnings, compile messages) to ``<log_dir>/worker-<pid>.log``.
    :meth:`close` with ``kill=True`` SIGKILLs them at once.

:class:`DaskExecutor`
    Each run is one task on a running Dask cluster (``tcp://host:8786``); the workers need
    auvdock installed.  A task whose worker died as often as the scheduler allows
    (``distributed.scheduler.allowed-failures``, Dask's default 3) comes back as
    ``KilledWorker`` and is reported ``"lost"``, as is a task whose result was lost before
    it was fetched (never dropped).  Dask cannot stop a running task: after
    :meth:`close` with ``kill=True`` the cluster's workers finish their current run and
    drop it.

The function a worker calls is ``runner(spec, progress)`` (default
:func:`auvdock.campaign.worker.execute_run`); tests pass their own (an importable
function, pickled by reference) to inject faults.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import signal
import sys
import threading
import time
import uuid
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import wait as mp_wait
from pathlib import Path
from typing import Any

from auvdock.campaign.spec import RunSpec
from auvdock.campaign.worker import execute_run

__all__ = ["Event", "Runner", "LocalExecutor", "DaskExecutor", "ExecutorError"]

#: ``runner(spec, progress) -> {"run_id", "row", "image"}``, executed in a worker.
Runner = Callable[..., dict[str, Any]]


class ExecutorError(ValueError):
    """The executor cannot start (e.g. no Dask scheduler at that address); one line."""


@dataclass
class Event:
    """What happened to a run.

    ``kind`` is ``"start"`` (a worker took it), ``"progress"`` (``data`` = (t_s, timeout_s,
    distance_m)), ``"result"`` (``data`` = the runner's dict), ``"error"`` (the runner
    raised; ``data`` = "Type: message") or ``"lost"`` (its worker died; ``data`` = why).
    """

    kind: str
    run_id: str
    data: Any = None


# ---------------------------------------------------------------------------------------
# local worker processes


def _signal_name(code: int | None) -> str:
    if code is None:
        return "no exit code"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"


def _worker_main(conn, runner: Runner, log_dir: str | None) -> None:
    """A local worker process: take runs from ``conn`` until None (or the driver is gone)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if log_dir:
        try:
            Path(log_dir).mkdir(parents=True, exist_ok=True)
            fd = os.open(
                os.path.join(log_dir, f"worker-{os.getpid()}.log"), os.O_WRONLY | os.O_CREAT | os.O_APPEND
            )
        except OSError:
            fd = -1
        if fd >= 0:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(fd, 1)
            os.dup2(fd, 2)
            os.close(fd)
    while True:
        try:
            spec = conn.recv()
        except (EOFError, OSError):
            return
        if spec is None:
            return
        rid = spec.run_id

        def progress(t: float, timeout: float, distance: float, rid: str = rid) -> None:
            conn.send(("progress", rid, (float(t), float(timeout), float(distance))))

        conn.send(("start", rid, os.getpid()))
        try:
            out = runner(spec, progress)
        except BaseException as e:  # noqa: BLE001 -- reported, the worker goes on
            conn.send(("error", rid, f"{type(e).__name__}: {e}"))
            continue
        try:
            conn.send(("result", rid, out))
        except Exception as e:  # noqa: BLE001 -- e.g. an unpicklable result
            conn.send(("error", rid, f"the result could not be sent to the driver: {type(e).__name__}: {e}"))


class _Worker:
    def __init__(self, ctx, runner: Runner, log_dir: str | None) -> None:
        self.conn, child = ctx.Pipe(duplex=True)
        self.proc = ctx.Process(target=_worker_main, args=(child, runner, log_dir), daemon=True)
        if threading.current_thread() is threading.main_thread():
            # born ignoring SIGINT (inherited through exec; Python then installs no handler), so
            # a Ctrl-C in the terminal's process group never reaches a worker while it starts
            old = signal.signal(signal.SIGINT, signal.SIG_IGN)
            try:
                self.proc.start()
            finally:
                signal.signal(signal.SIGINT, old)
        else:
            self.proc.start()
        child.close()
        self.current: RunSpec | None = None


class LocalExecutor:
    """Runs on ``workers`` local processes, one run each at a time (see the module docstring)."""

    def __init__(
        self, workers: int | None = None, *, runner: Runner = execute_run, log_dir: Path | None = None
    ):
        self.max_workers = max(1, int(workers or os.cpu_count() or 1))
        self.runner = runner
        self.log_dir = str(log_dir) if log_dir is not None else None
        self._ctx = mp.get_context("spawn")
        self._queue: deque[RunSpec] = deque()
        self._workers: list[_Worker] = []
        self.pids: list[int] = []  # every worker process started (tests, diagnostics)

    @property
    def cores(self) -> int:
        """The runs it can run at once: its worker processes (one run each)."""
        return self.max_workers

    @property
    def description(self) -> str:
        n = self.max_workers
        return f"{n} local worker process" + ("" if n == 1 else "es")

    def submit(self, spec: RunSpec) -> None:
        self._queue.append(spec)
        self._dispatch()

    def pending(self) -> int:
        """Runs submitted and not reported back yet."""
        return len(self._queue) + sum(1 for w in self._workers if w.current is not None)

    def _dispatch(self) -> None:
        busy = sum(1 for w in self._workers if w.current is not None)
        while len(self._workers) < self.max_workers and len(self._workers) < busy + len(self._queue):
            w = _Worker(self._ctx, self.runner, self.log_dir)
            self.pids.append(w.proc.pid)
            self._workers.append(w)
        for w in self._workers:
            if not self._queue:
                break
            if w.current is None and w.proc.is_alive():
                spec = self._queue.popleft()
                try:
                    w.conn.send(spec)
                except (OSError, BrokenPipeError):
                    self._queue.appendleft(spec)
                    continue
                w.current = spec

    def poll(self, timeout: float = 0.2) -> list[Event]:
        """Wait up to ``timeout`` s for something to happen; the events since the last poll."""
        self._dispatch()
        if not self._workers:
            return []
        mp_wait([w.conn for w in self._workers] + [w.proc.sentinel for w in self._workers], timeout)
        events: list[Event] = []
        for w in list(self._workers):
            dead = False
            while True:  # every message it sent before anything else (it may have died after)
                try:
                    if not w.conn.poll():
                        break
                    kind, rid, data = w.conn.recv()
                except Exception:  # noqa: BLE001 -- EOF or a message cut short by its death
                    dead = True
                    break
                if kind in ("result", "error") and w.current is not None and w.current.run_id == rid:
                    w.current = None
                events.append(Event(kind, rid, data))
            if dead or not w.proc.is_alive():
                w.proc.join(timeout=1.0)
                if w.proc.is_alive():
                    continue  # only its pipe failed; it will die or answer
                if w.current is not None:
                    why = f"its worker process (pid {w.proc.pid}) died: {_signal_name(w.proc.exitcode)}"
                    events.append(Event("lost", w.current.run_id, why))
                    w.current = None
                w.conn.close()
                self._workers.remove(w)
        self._dispatch()
        return events

    def close(self, kill: bool = False) -> None:
        """Stop the workers: at once (SIGKILL) with ``kill``, else after their current run."""
        self._queue.clear()
        for w in self._workers:
            if kill:
                w.proc.kill()
            else:
                try:
                    w.conn.send(None)
                except OSError:
                    pass
        for w in self._workers:
            w.proc.join(timeout=1.0 if kill else 10.0)
            if w.proc.is_alive():
                w.proc.kill()
                w.proc.join(timeout=1.0)
            w.conn.close()
        self._workers.clear()


# ---------------------------------------------------------------------------------------
# Dask


class DaskExecutor:
    """Runs as tasks on a running Dask cluster (see the module docstring)."""

    def __init__(self, address: str, *, runner: Runner = execute_run, connect_timeout: str = "20s") -> None:
        from distributed import Client, as_completed

        try:
            self.client = Client(address, timeout=connect_timeout)
        except (OSError, TimeoutError, ValueError) as e:
            raise ExecutorError(f"--scheduler: cannot connect to the Dask scheduler {address}: {e}") from None
        workers = self.client.scheduler_info().get("workers", {})
        n = len(workers)
        #: The runs it can run at once: the cluster's worker threads.
        self.cores = max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))
        self.address = address
        self.description = f"Dask scheduler {address} ({n} workers)"
        self.runner = runner
        self._ac = as_completed()
        self._futures: dict[str, Any] = {}  # key -> future
        self._ids: dict[str, str] = {}  # key -> run id
        self._token = uuid.uuid4().hex[:8]

    def submit(self, spec: RunSpec) -> None:
        key = f"auvdock-{spec.run_id.replace('/', '__')}-{self._token}-{uuid.uuid4().hex[:6]}"
        fut = self.client.submit(self.runner, spec, None, key=key, pure=False)
        self._futures[key] = fut
        self._ids[key] = spec.run_id
        self._ac.add(fut)

    def pending(self) -> int:
        return len(self._futures)

    def poll(self, timeout: float = 0.2) -> list[Event]:
        deadline = time.monotonic() + timeout
        while not self._ac.has_ready() and time.monotonic() < deadline:
            time.sleep(0.02)
        events: list[Event] = []
        if not self._ac.has_ready():
            return events
        for fut in self._ac.next_batch(block=False):
            key = fut.key
            if key not in self._futures:
                continue
            rid = self._ids.pop(key)
            del self._futures[key]
            if fut.status == "finished":
                try:
                    events.append(Event("result", rid, fut.result()))
                except Exception as e:  # noqa: BLE001 -- lost between finishing and fetching
                    events.append(Event("lost", rid, f"its result was lost: {type(e).__name__}: {e}"))
            elif fut.status == "error":
                exc = fut.exception()
                if type(exc).__name__ == "KilledWorker":
                    events.append(Event("lost", rid, f"its Dask worker died ({exc})"))
                else:
                    events.append(Event("error", rid, f"{type(exc).__name__}: {exc}"))
            else:  # cancelled or lost by the cluster (e.g. its worker died): never dropped silently
                events.append(Event("lost", rid, f"its Dask task ended {fut.status}"))
            fut.release()
        return events

    def close(self, kill: bool = False) -> None:
        try:
            if self._futures:
                self.client.cancel(list(self._futures.values()), force=True)
            self._futures.clear()
        finally:
            self.client.close()
