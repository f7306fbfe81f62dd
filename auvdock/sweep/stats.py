"""Statistics, figures and the Markdown summary of a sweep (:mod:`auvdock.sweep`), from its HDF5 file alone.

It reads the results file with :func:`auvdock.campaign.read_results` (the one layout of
compare and sweep results) and imports from :mod:`auvdock.sweep` only its leaf modules (rates,
exploration, station), never the package, which uses it.

Success is ``docked`` over all runs of a group, a run that failed (status ``failed``: it
raised, or its worker died twice) counting as not docked (the failure count is shown
beside it); intervals are Wilson score intervals
(:func:`wilson_interval`, 95 % by default), which stay inside [0, 1] and behave at 0 of n
and n of n, unlike the normal approximation.

:func:`report_sweep` writes, into one directory:

* ``success_by_controller.png`` -- success rate per controller with its interval (and any
  ``reference`` rates of the sweep file, e.g. the paper's 8 of 11 tank dockings, as bands);
* ``success_vs_<field>.png`` -- per varied field (and per model-error factor): one curve per
  controller with its interval band;
* ``success_map_<field a>__<field b>.png`` -- per pair of varied fields of which at least one
  is a grid field (two random fields are drawn together, not crossed): one heat map per
  controller, cells annotated ``docked/runs``;
* ``distributions.png`` -- time to dock and contact speed of the docked runs, a box per
  controller;
* ``summary.md`` -- the tables behind the figures, and the runs that failed; with waves in the base
  mission, what holding station takes per sea state beside each controller's captures there
  (:mod:`auvdock.sweep.station`).

A numeric field with more than :data:`MAX_LEVELS` distinct values (random draws) is put
into :data:`N_BINS` equal-width bins; others are shown value by value.  Figures use a fixed
colour per controller (Okabe-Ito, :data:`auvdock.campaign.plots.CONTROLLER_COLORS`) and are
saved without time stamps (Agg canvas, PNG ``Software`` metadata dropped), so the same file
gives the same bytes.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from auvdock.campaign.plots import CONTROLLER_ORDER, controller_color, controller_label
from auvdock.campaign.store import read_results
from auvdock.sweep.exploration import exploration_report
from auvdock.sweep.oracle_gap import oracle_gap_report
from auvdock.sweep.rates import Z95, failed, success_rate, wilson_interval
from auvdock.sweep.station import station_keeping_report

__all__ = [
    "Z95",
    "MAX_LEVELS",
    "N_BINS",
    "wilson_interval",
    "success_rate",
    "success_table",
    "levels",
    "report_sweep",
]

#: A numeric field with more distinct values than this is binned.
MAX_LEVELS = 12
#: Number of equal-width bins for such a field.
N_BINS = 8
DPI = 120
_MARKERS = ("o", "s", "^", "D", "v", "P", "X")


def _controllers(rows: Sequence[dict[str, Any]]) -> list[str]:
    present = {r["controller"] for r in rows}
    return [c for c in CONTROLLER_ORDER if c in present] + sorted(present - set(CONTROLLER_ORDER))


def _median(values: list[float]) -> float:
    v = [x for x in values if np.isfinite(x)]
    return float(np.median(v)) if v else math.nan


def _pct(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{100 * x:.1f} %"


def _range(lo: float, hi: float) -> str:
    return f"{100 * lo:.1f}-{100 * hi:.1f} %"


def _num(x: float, spec: str) -> str:
    return "-" if not np.isfinite(x) else format(x, spec)


SUCCESS_HEADER = (
    "controller",
    "runs",
    "docked",
    "success",
    "95 % interval",
    "failed",
    "median dock time s",
    "median contact m/s",
    "median closest m",
)


def success_table(
    rows: Sequence[dict[str, Any]], references: Sequence[dict[str, Any]] = ()
) -> tuple[tuple[str, ...], list[list[str]]]:
    """The per-controller success table (:data:`SUCCESS_HEADER`) as text, plus reference rows."""
    out = []
    for c in _controllers(rows):
        rs = [r for r in rows if r["controller"] == c]
        s = success_rate(rs)
        docked = [r for r in rs if r["docked"]]
        out.append(
            [
                c,
                str(s["n"]),
                str(s["docked"]),
                _pct(s["rate"]),
                _range(s["lo"], s["hi"]),
                str(s["errors"]),
                _num(_median([r["time_to_dock_s"] for r in docked]), ".2f"),
                _num(_median([r["contact_speed_m_s"] for r in docked]), ".3f"),
                _num(_median([r["closest_approach_m"] for r in rs]), ".3f"),
            ]
        )
    for ref in references:
        k, n = int(ref["docked"]), int(ref["runs"])
        lo, hi = wilson_interval(k, n)
        out.append(
            [f"{ref['label']} (reference)", str(n), str(k), _pct(k / n), _range(lo, hi)] + ["", "", "", ""]
        )
    return SUCCESS_HEADER, out


OUTCOME_HEADER = (
    "controller",
    "runs",
    "collided",
    "95 % interval",
    "median impact m/s",
    "gave up (lost_target)",
    "timed out",
    "losses of the dock",
    "re-acquired",
    "longest loss s",
    "relative position rmse m",
    "current rmse m/s",
)


def outcome_table(rows: Sequence[dict[str, Any]]) -> tuple[tuple[str, ...], list[list[str]]]:
    """How the runs ended beyond docking, per controller (:data:`OUTCOME_HEADER`): collisions with
    the dock's body (Wilson interval) and their median impact speed, runs that gave up finding the
    dock or timed out, the camera's losses of the dock (with a dock camera) and how many were
    re-acquired, and the navigation filter's median errors (``estimation: filter``)."""
    out = []
    for c in _controllers(rows):
        rs = [r for r in rows if r["controller"] == c]
        n = len(rs)
        k = sum(1 for r in rs if r.get("collided"))
        lo, hi = wilson_interval(k, n)
        events = sum(int(r.get("lost_track_events") or 0) for r in rs)
        back = sum(int(r.get("lost_track_reacquired") or 0) for r in rs)
        out.append(
            [
                c,
                str(n),
                f"{k} ({_pct(k / n if n else math.nan)})",
                _range(lo, hi),
                _num(_median([r.get("impact_speed_m_s", math.nan) for r in rs if r.get("collided")]), ".3f"),
                str(sum(1 for r in rs if r.get("reason") == "lost_target")),
                str(sum(1 for r in rs if r.get("reason") == "timeout")),
                str(events),
                str(back),
                _num(
                    max(
                        (g for g in (float(r.get("lost_track_longest_s") or math.nan) for r in rs) if g == g),
                        default=math.nan,
                    ),
                    ".2f",
                ),
                _num(_median([r.get("relative_position_rmse_m", math.nan) for r in rs]), ".3f"),
                _num(_median([r.get("navigation_current_rmse_m_s", math.nan) for r in rs]), ".3f"),
            ]
        )
    return OUTCOME_HEADER, out


# ---------------------------------------------------------------------------------------
# levels of a varied field


def levels(values: Sequence[Any], kind: str) -> tuple[list[str], list[float] | None, list[int]]:
    """Group a field's values: (level labels, numeric level positions or None, level of each value).

    Categorical (str, bool) and numeric fields with at most :data:`MAX_LEVELS` distinct values
    get one level per value (sorted); other numeric fields :data:`N_BINS` equal-width bins.
    """
    if kind in ("float", "int"):
        x = np.asarray(values, dtype=float)
        uniq = sorted({float(v) for v in x if np.isfinite(v)})
        if len(uniq) <= MAX_LEVELS:
            pos = {v: i for i, v in enumerate(uniq)}
            return [f"{v:.4g}" for v in uniq], uniq, [pos.get(float(v), -1) for v in x]
        lo, hi = uniq[0], uniq[-1]
        edges = np.linspace(lo, hi, N_BINS + 1)
        idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, N_BINS - 1)
        labels = [f"{edges[i]:.3g} to {edges[i + 1]:.3g}" for i in range(N_BINS)]
        centres = [float((edges[i] + edges[i + 1]) / 2) for i in range(N_BINS)]
        return labels, centres, [int(i) if np.isfinite(v) else -1 for i, v in zip(idx, x, strict=True)]
    keys = [str(v) for v in values]
    uniq_s = sorted(set(keys), key=lambda s: (s not in ("False", "True"), s))
    pos_s = {v: i for i, v in enumerate(uniq_s)}
    return uniq_s, None, [pos_s[k] for k in keys]


def _grouped(rows: Sequence[dict[str, Any]], field: str, kind: str):
    labels, xs, idx = levels([r[field] for r in rows], kind)
    table: dict[tuple[str, int], list[dict[str, Any]]] = {}
    for r, i in zip(rows, idx, strict=True):
        if i >= 0:
            table.setdefault((r["controller"], i), []).append(r)
    return labels, xs, table


# ---------------------------------------------------------------------------------------
# figures


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def _save(fig: Figure, path: Path) -> Path:
    FigureCanvasAgg(fig)
    fig.savefig(path, format="png", dpi=DPI, metadata={"Software": None})
    return path


def _fig_by_controller(rows, refs, path: Path) -> Path:
    ctrls = _controllers(rows)
    fig = Figure(figsize=(max(4.5, 1.3 * len(ctrls) + 2.0), 3.8), layout="constrained")
    ax = fig.add_subplot()
    for i, c in enumerate(ctrls):
        s = success_rate([r for r in rows if r["controller"] == c])
        ax.bar(i, s["rate"], color=controller_color(c), alpha=0.85, width=0.6)
        ax.errorbar(i, s["rate"], yerr=[[s["rate"] - s["lo"]], [s["hi"] - s["rate"]]], color="k", capsize=4)
        ax.annotate(
            f"{s['docked']}/{s['n']}", (i, s["hi"]), textcoords="offset points", xytext=(0, 4), ha="center"
        )
    ref_colors = ("#999999", "#56B4E9", "#F0E442")
    for j, ref in enumerate(refs):
        k, n = int(ref["docked"]), int(ref["runs"])
        lo, hi = wilson_interval(k, n)
        col = ref_colors[j % len(ref_colors)]
        ax.axhspan(lo, hi, color=col, alpha=0.18, zorder=0)
        ax.axhline(k / n, color=col, ls="--", lw=1.2, label=f"{ref['label']}: {k}/{n}")
    ax.set_xticks(range(len(ctrls)), [controller_label(c) for c in ctrls], rotation=15)
    ax.set_ylim(0, 1.12)
    ax.set_ylabel("success rate (docked / runs)")
    ax.set_title("Success per controller, Wilson 95 % intervals")
    if refs:
        ax.legend(loc="lower right", fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    return _save(fig, path)


def _fig_vs_field(rows, field: str, kind: str, path: Path) -> Path:
    labels, xs, table = _grouped(rows, field, kind)
    ctrls = _controllers(rows)
    fig = Figure(figsize=(6.4, 4.0), layout="constrained")
    ax = fig.add_subplot()
    numeric = xs is not None
    pos = list(xs) if numeric else list(range(len(labels)))
    width = (max(pos) - min(pos)) if len(pos) > 1 else 1.0
    for j, c in enumerate(ctrls):
        xv, rate, lo, hi = [], [], [], []
        for i, x in enumerate(pos):
            rs = table.get((c, i))
            if not rs:
                continue
            s = success_rate(rs)
            xv.append(x)
            rate.append(s["rate"])
            lo.append(s["lo"])
            hi.append(s["hi"])
        if not xv:
            continue
        col = controller_color(c)
        if numeric:
            # markers shrink along the legend, so that identical curves stay visible under each other
            ax.plot(
                xv,
                rate,
                _MARKERS[j % len(_MARKERS)] + "-",
                color=col,
                label=controller_label(c),
                lw=1.6,
                ms=max(3.0, 9.0 - 1.5 * j),
            )
            ax.fill_between(xv, lo, hi, color=col, alpha=0.12, lw=0)
        else:
            off = (j - (len(ctrls) - 1) / 2) * 0.08 * max(1.0, width / max(1, len(pos)))
            xo = [x + off for x in xv]
            err = [np.subtract(rate, lo), np.subtract(hi, rate)]
            ax.errorbar(xo, rate, yerr=err, fmt="o", color=col, capsize=3, label=controller_label(c))
    if not numeric:
        ax.set_xticks(pos, labels, rotation=20 if max(len(s) for s in labels) > 6 else 0)
    binned = numeric and len(labels) == N_BINS and " to " in labels[0]
    ax.set_xlabel(field + (" (binned, bin centres)" if binned else ""))
    ax.set_ylabel("success rate")
    ax.set_ylim(-0.03, 1.05)
    ax.set_title(f"Success vs {field} (Wilson 95 % bands)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return _save(fig, path)


def _fig_map(rows, a: str, ka: str, b: str, kb: str, path: Path) -> Path:
    la, _, ia = levels([r[a] for r in rows], ka)
    lb, _, ib = levels([r[b] for r in rows], kb)
    ctrls = _controllers(rows)
    fig = Figure(figsize=(0.6 + 3.3 * len(ctrls), 0.9 + 0.32 * len(lb) + 2.0), layout="constrained")
    axes = fig.subplots(1, len(ctrls), squeeze=False)[0]
    im = None
    for ax, c in zip(axes, ctrls, strict=True):
        k = np.zeros((len(lb), len(la)))
        n = np.zeros((len(lb), len(la)))
        for r, x, y in zip(rows, ia, ib, strict=True):
            if r["controller"] != c or x < 0 or y < 0:
                continue
            n[y, x] += 1
            k[y, x] += bool(r["docked"])
        with np.errstate(invalid="ignore", divide="ignore"):
            rate = np.where(n > 0, k / np.maximum(n, 1), np.nan)
        im = ax.imshow(rate, origin="lower", aspect="auto", vmin=0.0, vmax=1.0, cmap="viridis")
        if len(la) * len(lb) <= 120:
            for y in range(len(lb)):
                for x in range(len(la)):
                    if n[y, x] > 0:
                        ax.text(
                            x,
                            y,
                            f"{int(k[y, x])}/{int(n[y, x])}",
                            ha="center",
                            va="center",
                            fontsize=7,
                            color="white" if rate[y, x] < 0.6 else "black",
                        )
        ax.set_xticks(range(len(la)), la, rotation=45 if len(la) > 5 else 0, fontsize=7)
        ax.set_yticks(range(len(lb)), lb, fontsize=7)
        ax.set_xlabel(a)
        ax.set_title(controller_label(c), color=controller_color(c), fontsize=10)
    axes[0].set_ylabel(b)
    if im is not None:
        fig.colorbar(im, ax=list(axes), label="success rate", shrink=0.9)
    return _save(fig, path)


def _fig_distributions(rows, path: Path) -> Path:
    ctrls = _controllers(rows)
    fig = Figure(figsize=(max(6.4, 1.6 * len(ctrls) + 2.5), 3.8), layout="constrained")
    axes = fig.subplots(1, 2)
    rng = np.random.default_rng(0)  # fixed jitter: same file, same figure
    for ax, col, label in (
        (axes[0], "time_to_dock_s", "time to dock, s"),
        (axes[1], "contact_speed_m_s", "contact speed, m/s"),
    ):
        for i, c in enumerate(ctrls):
            v = np.asarray(
                [r[col] for r in rows if r["controller"] == c and r["docked"] and np.isfinite(r[col])],
                dtype=float,
            )
            if v.size == 0:
                ax.text(
                    i,
                    0.5,
                    "none\ndocked",
                    ha="center",
                    va="center",
                    fontsize=8,
                    transform=ax.get_xaxis_transform(),
                )
                continue
            bp = ax.boxplot([v], positions=[i], widths=0.55, patch_artist=True, showfliers=False)
            for box in bp["boxes"]:
                box.set_facecolor(controller_color(c))
                box.set_alpha(0.45)
            for med in bp["medians"]:
                med.set_color("k")
            ax.plot(i + rng.uniform(-0.15, 0.15, v.size), v, ".", color=controller_color(c), ms=3, alpha=0.7)
        ax.set_xticks(range(len(ctrls)), [controller_label(c) for c in ctrls], rotation=20, fontsize=8)
        ax.set_xlim(-0.6, len(ctrls) - 0.4)
        ax.set_ylabel(label)
        ax.set_title(label.split(",")[0].capitalize() + " (docked runs)")
        ax.grid(axis="y", alpha=0.3)
    return _save(fig, path)


# ---------------------------------------------------------------------------------------
# the report


def _md_table(header: Sequence[str], rows: list[list[str]]) -> str:
    esc = [[c.replace("|", "\\|") for c in row] for row in rows]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in esc]
    return "\n".join(lines) + "\n"


def _cell(s: dict[str, Any]) -> str:
    if not s["n"]:
        return "-"
    return f"{s['docked']}/{s['n']} = {_pct(s['rate'])} [{_range(s['lo'], s['hi'])}]"


def _references(attrs: dict[str, Any]) -> list[dict[str, Any]]:
    try:
        data = yaml.safe_load(attrs.get("sweep_yaml", "") or "") or {}
    except yaml.YAMLError:
        return []
    refs = data.get("reference") if isinstance(data, dict) else None
    return [r for r in refs or [] if isinstance(r, dict) and {"label", "docked", "runs"} <= set(r)]


def report_sweep(h5_path: str | Path, out_dir: str | Path) -> list[Path]:
    """Write the sweep's figures and ``summary.md`` into ``out_dir``, from the file alone.

    Returns the files written (figures first, ``summary.md`` last).  Same file, same bytes.

    Raises
    ------
    ValueError
        If ``h5_path`` is not an auvdock sweep file.
    """
    rows, attrs = read_results(h5_path, "sweep")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    columns: dict[str, str] = attrs["columns"]
    varied: list[str] = list(attrs["varied"])
    me_cols: list[str] = list(attrs["model_error_columns"])
    refs = _references(attrs)
    written: list[Path] = []
    figures: list[tuple[str, Path]] = []

    if rows:
        p = _fig_by_controller(rows, refs, out / "success_by_controller.png")
        figures.append(("success rate per controller", p))
        for f in [*varied, *me_cols]:
            p = _fig_vs_field(rows, f, columns[f], out / f"success_vs_{_slug(f)}.png")
            figures.append((f"success vs {f}", p))
        grid = set(attrs.get("grid_fields", varied))
        for i, a in enumerate(varied):
            for b in varied[i + 1 :]:
                if a not in grid and b not in grid:
                    continue  # two random fields: drawn together, not crossed
                p = _fig_map(
                    rows, a, columns[a], b, columns[b], out / f"success_map_{_slug(a)}__{_slug(b)}.png"
                )
                figures.append((f"success over {a} x {b}", p))
        p = _fig_distributions(rows, out / "distributions.png")
        figures.append(("time to dock and contact speed", p))
    written += [p for _, p in figures]

    name = attrs.get("sweep_name", "")
    total = int(attrs.get("total_runs", len(rows)))
    md = [f"# Sweep {name}\n"]
    try:
        desc = (yaml.safe_load(attrs.get("sweep_yaml", "") or "") or {}).get("description", "")
    except (yaml.YAMLError, AttributeError):
        desc = ""
    if desc:
        md.append(f"{desc}\n")
    base = ""
    try:
        base = (yaml.safe_load(attrs.get("base_mission_yaml", "") or "") or {}).get("name", "")
    except (yaml.YAMLError, AttributeError):
        pass
    errors = [r for r in rows if failed(r)]
    facts = [
        f"base mission: `{base}`" if base else "",
        f"{len(rows)} of {total} runs in the file"
        + ("" if len(rows) >= total else " (incomplete: --resume)"),
        f"{len(errors)} failed",
        "controllers: " + ", ".join(_controllers(rows)) if rows else "",
        "varied: " + ", ".join(f"`{v}`" for v in varied) if varied else "varied: nothing (one point)",
    ]
    if me_cols:
        facts.append("model-error factors: " + ", ".join(f"`{c}`" for c in me_cols))
    md.append("; ".join(f for f in facts if f) + ".\n")
    cmd = attrs.get("command_line", "")
    versions = f"auvdock {attrs.get('auvdock_version', '')}"
    if attrs.get("executor"):
        versions += f", {attrs['executor']}"
    wall = attrs.get("wall_time_s")
    made = f"Made with `{cmd}` ({versions}" if cmd else f"Made with {versions}"
    if wall is not None:
        made += f"; wall time {float(wall):.1f} s"
    md.append(made + ").\n")
    md.append(
        "Success = docked / runs (a run that failed counts as not docked); intervals are Wilson 95 % "
        "score intervals.\n"
    )
    md.append("## Success per controller\n")
    header, trs = success_table(rows, refs)
    md.append(_md_table(header, trs))
    if rows:
        md.append("## How the runs ended\n")
        header, trs = outcome_table(rows)
        md.append(_md_table(header, trs))
        lost = [r for r in rows if int(r.get("lost_track_events") or 0)]
        if lost:
            md.append(
                f"Losses of the dock, per run (the camera's last fix - the end of the loss: how it ended); "
                f"{len(lost)} runs had any:\n"
            )
            md.append(
                _md_table(
                    ["run", "controller", "reason", "losses"],
                    [
                        [r["run_id"], r["controller"], r["reason"], r.get("lost_track_log", "")]
                        for r in lost[:60]
                    ],
                )
            )
            if len(lost) > 60:
                md.append(f"... and {len(lost) - 60} more (column `lost_track_log` of `/campaign_table`).\n")
        eh, et, findings = exploration_report(rows, list(attrs.get("grid_fields", varied)))
        if et:
            md.append("## Exploration against certainty equivalence\n")
            md.append(
                "Each flow-estimating controller against Certainty-equivalent MPC (`ce`: the same flow "
                "filter and MPC, no exploration) in the same regime (a combination of the grid's values); "
                "`beats`/`loses`: its Wilson 95 % interval lies wholly above/below `ce`'s.\n"
            )
            md.append("\n".join(f"- {f}" for f in findings) + "\n")
            md.append(_md_table(eh, et))
        sh, st = station_keeping_report(rows, attrs.get("base_mission_yaml", ""), varied)
        if st:
            md.append("## Station keeping per sea state\n")
            md.append(
                "Per sea state, what holding station there takes from the one model (the thrusters' "
                "minimum-norm utilisation against the orbital drag and inertia, 99th percentile and maximum "
                "over ten minutes of the sea, the vehicle still at the dock's depth and heading; "
                "`auvdock.world.station_keeping`) and each controller's captures there: a failure in a sea "
                "the vehicle holds with margin is not the thrusters'.\n"
            )
            md.append(_md_table(sh, st))
        gh, gt, gap_findings = oracle_gap_report(rows, varied)
        if gt:
            md.append("## Oracle against the best deployable controller\n")
            md.append(
                "Per sea state (and sensor suite): Oracle (told the realised sea and the dock's true motion) "
                "against the deployable controller that captured most there (the sooner median time breaks a "
                "tie); captures with Wilson 95 % intervals, median time to capture, and the gaps (`auvdock."
                "sweep.oracle_gap`).\n"
            )
            md.append("\n".join(f"- {f}" for f in gap_findings) + "\n")
            md.append(_md_table(gh, gt))
    ctrls = _controllers(rows)
    for f in [*varied, *me_cols]:
        labels, _, table = _grouped(rows, f, columns[f])
        md.append(f"## Success vs `{f}`\n")
        body = []
        for i, lab in enumerate(labels):
            body.append([lab] + [_cell(success_rate(table.get((c, i), []))) for c in ctrls])
        md.append(_md_table([f, *ctrls], body))
    if errors:
        md.append(f"## Runs that failed ({len(errors)})\n")
        md.append(_md_table(["run", "error"], [[r["run_id"], r["error"]] for r in errors[:50]]))
        if len(errors) > 50:
            md.append(f"... and {len(errors) - 50} more (column `error` of `/campaign_table`).\n")
    if figures:
        md.append("## Figures\n")
        md.append("\n".join(f"- [{what}]({p.name})" for what, p in figures) + "\n")
    summary = out / "summary.md"
    summary.write_text("\n".join(md))
    written.append(summary)
    return written
