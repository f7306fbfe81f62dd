"""``auvdock bench``: per-step solve time per controller x solver."""

from __future__ import annotations

from typing import Any

import typer

from auvdock.cli.app import app, console, controller_list, fail_input, positive_timeout, split_list
from auvdock.cli.tables import fitted_table


@app.command()
def bench(
    cases: list[int] | None = typer.Option(None, "--case", help="Paper case (repeat; default 1, 2 and 6)."),
    controllers: list[str] | None = typer.Option(
        None, "--controllers", "-c", help="Controllers, comma-separated or repeated (default: all five)."
    ),
    solvers: list[str] | None = typer.Option(
        None,
        "--solvers",
        "-s",
        help="Solvers: auto (rti; sqp for Sequential FSE-MPC in the paper variant), rti, sqp, ipopt; "
        "comma-separated or repeated (default: auto).",
    ),
    qps: list[str] | None = typer.Option(
        None,
        "--qp",
        help="QP solvers of rti and sqp: hpipm, hpipm_casadi, qrqp; comma-separated or repeated "
        "(default: hpipm).",
    ),
    timeout: float | None = typer.Option(
        None, "--timeout", callback=positive_timeout, help="Simulated-time limit per run, s."
    ),
    json_out: bool = typer.Option(False, "--json", help="One JSON object per run on stdout, nothing else."),
) -> None:
    """Per-step solve time (median, p95, p99, max), real-time factor and outcome per controller x
    solver, and where each step's time goes (estimation, flow filter, QP data and QP, or the
    NLP's function evaluations and solver, Python).  Solvers not yet in the cache are compiled
    before their runs (AUVDOCK_COMPILE=wait unless set to never), so the times are the compiled
    code's."""
    import json
    import os

    from auvdock.runtime.codegen import compile_mode

    if compile_mode() == "auto":
        os.environ["AUVDOCK_COMPILE"] = "wait"

    from auvdock.campaign.bench import DEFAULT_CASES, bench_rows, machine_line
    from auvdock.config.mission import SOLVER_NAMES
    from auvdock.controllers.rti import QP_SOLVERS
    from auvdock.runtime.timing import PARTS

    ctrls = controller_list(controllers)
    solv = split_list(solvers) or ["auto"]
    for s_ in solv:
        if s_ not in SOLVER_NAMES:
            fail_input(f"--solvers: unknown solver {s_!r} (known: {', '.join(SOLVER_NAMES)})")
    qp_list = split_list(qps) or ["hpipm"]
    for q in qp_list:
        if q not in QP_SOLVERS:
            fail_input(f"--qp: unknown QP solver {q!r} (known: {', '.join(QP_SOLVERS)})")
    case_list = list(cases or DEFAULT_CASES)
    for c in case_list:
        if not 1 <= c <= 6:
            fail_input(f"--case: {c} is not one of the paper's cases 1..6")

    if json_out:

        def emit(r: dict[str, Any]) -> None:  # strict JSON: NaN (not docked) as null
            clean = {k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()}
            print(json.dumps(clean), flush=True)

        bench_rows(case_list, ctrls, solv, qps=qp_list, timeout_s=timeout, on_row=emit)
        return
    console.print(f"[bold]bench[/bold] on {machine_line()}")
    header = ("case", "controller", "solver", "docked", "time to dock", "median", "p95", "p99", "max", "RTF",
              "failures")  # fmt: skip
    cells: list[list[str]] = []

    def label(r: dict[str, Any]) -> str:
        return f"{r['solver']}/{r['qp']}" if r["qp"] else r["solver"]

    def add(r: dict[str, Any]) -> None:
        ttd = f"{r['time_to_dock_s']:.2f} s" if r["docked"] else "timeout"
        console.print(
            f"  case {r['case']} {r['controller']:<10} {label(r):<9} {ttd:>9}"
            f"  median {r['median_ms']:6.2f} ms  p99 {r['p99_ms']:6.2f} ms"
        )
        cells.append([
            str(r["case"]), r["controller"], label(r), "yes" if r["docked"] else "no", ttd,
            f"{r['median_ms']:.2f}", f"{r['p95_ms']:.2f}", f"{r['p99_ms']:.2f}", f"{r['max_ms']:.2f}",
            f"{r['real_time_factor']:.1f}", str(r["solver_failures"]),
        ])  # fmt: skip

    rows = bench_rows(case_list, ctrls, solv, qps=qp_list, timeout_s=timeout, on_row=add)
    console.print(
        fitted_table(
            "per controller step, ms (full closed-loop runs)", header, cells, console.width,
            priority=[0, 1, 2, 4, 5, 7, 6, 3, 8, 9, 10], where="bench --json",
        )
    )  # fmt: skip
    # where a step's time goes: the median of each part and of what they leave (Python)
    seen = {p for r in rows for p in r["parts_median_ms"]} - {"python"}
    names = [n for n in PARTS if n in seen] + sorted(seen - set(PARTS))
    part_rows = []
    for r in rows:
        pm = r["parts_median_ms"]
        part_rows.append([str(r["case"]), r["controller"], label(r), *(f"{pm[n]:.2f}" if n in pm else "-"
                          for n in names), f"{pm['python']:.2f}", f"{r['median_ms']:.2f}"])  # fmt: skip
    console.print(
        fitted_table(
            "where a step's time goes: median ms per part (auvdock.runtime.timing)",
            ("case", "controller", "solver", *names, "python", "step"),
            part_rows,
            console.width,
            priority=[0, 1, 2, len(names) + 4, len(names) + 3, *range(3, len(names) + 3)],
            where="bench --json",
        )
    )
