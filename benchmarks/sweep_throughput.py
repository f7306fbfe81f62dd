"""Throughput of ``auvdock sweep`` on the campaign engine: local workers, Dask, and a bare process pool.

One small sweep (still water, Naive + Oracle MPC, 2 grid points x 4 seeds = 16 runs of 3 s
simulated time by default) is run

1. through :func:`auvdock.sweep.run_sweep` with 1 and with 2 local worker processes (the
   command's default path: the processes are started by each call, so their start-up --
   interpreter, imports, the first controller build -- is included, as a user waits for it);
2. through ``run_sweep(scheduler=...)`` on a warm 2-worker Dask ``LocalCluster`` (workers
   already started and warmed up by one short run);
3. on a warm ``concurrent.futures.ProcessPoolExecutor`` with 2 spawned processes running
   :func:`auvdock.campaign.execute_run` on the same runs, results not stored (the floor).

Each measurement writes its own results file (except 3).  Measurements run in interleaved
rounds (``--repeat``) and the best round of each is kept, so that a noisy machine slows
all alike.  Printed: runs per minute, the scaling efficiency ``throughput(2) /
(2 x throughput(1))`` of the local workers, and the overhead of the engine (start-up,
HDF5 rows, progress) over the bare pool, in % and in ms per run.  On a 2-core machine the
driver shares the cores with the two workers.  Asserts nothing.

    python benchmarks/sweep_throughput.py [--seeds 4] [--timeout 3] [--repeat 3]
"""

from __future__ import annotations

import argparse
import logging
import multiprocessing as mp
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _warm(_: int = 0) -> int:
    """Import auvdock and fly one 0.05 s run in this process; returns the pid."""
    from auvdock.config.mission import load_mission
    from auvdock.loop.simulation import run_simulation

    m = load_mission(ROOT / "missions" / "still.yaml")
    for c in ("naive", "oracle"):
        run_simulation(m, controller=c, timeout_s=0.05)
    time.sleep(0.3)  # so that a pool hands the two warm-up calls to two processes
    return os.getpid()


def _sweep_file(d: Path, seeds: int, timeout: float) -> Path:
    p = d / "throughput.yaml"
    p.write_text(
        f"name: throughput\nbase: {ROOT / 'missions' / 'still.yaml'}\ncontrollers: [naive, oracle]\n"
        f"seeds: {seeds}\ngrid:\n  flow.speed_m_s: [0.0, 0.5]\n  flow.direction_deg: [90]\n"
        f"timeout_s: {timeout}\n"
    )
    return p


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4, help="seeds per point (runs = 4 x seeds)")
    ap.add_argument("--timeout", type=float, default=3.0, help="simulated seconds per run")
    ap.add_argument("--repeat", type=int, default=3, help="rounds of the measurements; the best is kept")
    args = ap.parse_args()

    from distributed import Client, LocalCluster

    from auvdock.campaign import execute_run, machine_line
    from auvdock.runtime.codegen import compile_mode
    from auvdock.sweep import expand_sweep, load_sweep, run_sweep

    print(f"machine: {machine_line()}; AUVDOCK_COMPILE={compile_mode()}")
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        sweep = _sweep_file(d, args.seeds, args.timeout)
        specs = expand_sweep(load_sweep(sweep))
        n = len(specs)
        print(
            f"sweep: {n} runs (naive, oracle; 2 points x {args.seeds} seeds), "
            f"{args.timeout:g} s simulated each; {args.repeat} rounds, best kept"
        )
        t0 = time.perf_counter()
        cluster = LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        )
        client = Client(cluster)
        client.run(_warm)
        print(f"Dask LocalCluster(2): start + warm-up {time.perf_counter() - t0:.2f} s")
        t0 = time.perf_counter()
        pool = ProcessPoolExecutor(max_workers=2, mp_context=mp.get_context("spawn"))
        pids = list(pool.map(_warm, range(2)))
        print(
            f"ProcessPoolExecutor(2): start + warm-up {time.perf_counter() - t0:.2f} s "
            f"({len(set(pids))} processes)"
        )

        counter = [0]

        def engine(**kw) -> tuple[float, float]:
            counter[0] += 1
            t1 = time.perf_counter()
            res = run_sweep(sweep, d / f"r{counter[0]}", command_line="", **kw)
            wall = time.perf_counter() - t1
            assert len(res.ran) == n and not res.errors, res.errors
            return wall, sum(r["wall_time_s"] + r["setup_time_s"] for r in res.records)

        def pooled() -> tuple[float, float]:
            t1 = time.perf_counter()
            out = [f.result() for f in as_completed([pool.submit(execute_run, s) for s in specs])]
            return time.perf_counter() - t1, sum(
                o["row"]["wall_time_s"] + o["row"]["setup_time_s"] for o in out
            )

        measurements = {
            "local1": lambda: engine(workers=1),
            "local2": lambda: engine(workers=2),
            "dask2": lambda: engine(scheduler=cluster.scheduler_address),
            "pool2": pooled,
        }
        best: dict[str, tuple[float, float]] = {}
        try:
            for _ in range(max(1, args.repeat)):
                for key, fn in measurements.items():
                    r = fn()
                    if key not in best or r[0] < best[key][0]:
                        best[key] = r
        finally:
            pool.shutdown()
            client.close()
            cluster.close()

    def rpm(w: float) -> float:
        return 60.0 * n / w

    print()
    print(f"{'measurement':<60} {'wall s':>7} {'runs/min':>9} {'s per run':>10}")
    rows = [
        ("run_sweep, 1 local worker (start-up included)", "local1"),
        ("run_sweep, 2 local workers (start-up included)", "local2"),
        ("run_sweep on a warm 2-worker Dask cluster", "dask2"),
        ("bare ProcessPoolExecutor, 2 warm processes, nothing stored", "pool2"),
    ]
    for label, key in rows:
        wall, compute = best[key]
        print(f"{label:<60} {wall:7.2f} {rpm(wall):9.1f} {compute / n:10.3f}")
    print("(s per run: the mean wall + set-up time of one run inside its worker)")
    eff = rpm(best["local2"][0]) / (2 * rpm(best["local1"][0]))
    print()
    print(f"scaling efficiency, 1 -> 2 local workers: throughput(2) / (2 x throughput(1)) = {eff:.2f}")
    for key, label in (("local2", "2 local workers"), ("dask2", "Dask, 2 warm workers")):
        over = best[key][0] - best["pool2"][0]
        print(
            f"engine overhead vs the bare pool, {label}: {100 * over / best['pool2'][0]:+.1f} % "
            f"({1000 * over / n:+.0f} ms per run)"
        )


if __name__ == "__main__":
    main()
