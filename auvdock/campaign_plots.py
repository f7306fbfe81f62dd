"""Summary figures of a docking campaign (``auvdock compare``): several cases x several controllers.

The figures mirror the paper's: Fig. 2 (top-view trajectories, one panel per case), Fig. 3
(time to dock), Fig. 4 (path length) and Fig. 5 (flow-estimate RMSE), each drawn as grouped
bars with one bar per controller and one group per case.

Every controller has one fixed colour (:data:`CONTROLLER_COLORS`, :func:`controller_color`)
shared by all figures, so a controller looks the same everywhere.

Figures are drawn on :class:`matplotlib.figure.Figure` objects with an explicit Agg canvas:
no pyplot, no global backend switch, no GUI.  Saving drops the time stamps and version
strings matplotlib would otherwise embed (PNG ``Software``, PDF ``CreationDate``, SVG
``Date``), so the same inputs give byte-identical PNG and PDF files.

Frames and units follow :mod:`auvdock.results`: positions NED in metres, times in s,
speeds in m/s.  Maps put east on the horizontal axis and north on the vertical one.
"""

from __future__ import annotations

import math
import re
import textwrap
import zlib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib as mpl
import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch

from auvdock.results import RunResults

__all__ = [
    "CONTROLLER_ORDER",
    "CONTROLLER_COLORS",
    "CONTROLLER_LABELS",
    "FIGURE_NAMES",
    "controller_color",
    "controller_label",
    "plot_campaign",
]

#: Canonical order of the controllers in legends and within each bar group.
CONTROLLER_ORDER: tuple[str, ...] = ("naive", "kinematic", "oracle", "sequential", "optimized")

#: Fixed colour per known controller (colour-blind-safe Okabe-Ito hues), used by every figure.
CONTROLLER_COLORS: dict[str, str] = {
    "naive": "#D55E00",  # vermillion
    "kinematic": "#E69F00",  # orange
    "oracle": "#009E73",  # bluish green
    "sequential": "#0072B2",  # blue
    "optimized": "#CC79A7",  # reddish purple
}

#: Display name per known controller; unknown controllers are shown by their own name.
CONTROLLER_LABELS: dict[str, str] = {
    "naive": "Naive MPC",
    "kinematic": "Kinematic MPC",
    "oracle": "Oracle MPC",
    "sequential": "Sequential FSE-MPC",
    "optimized": "Optimized FSE-MPC",
}

#: Base names of the files :func:`plot_campaign` writes, in order.
FIGURE_NAMES: tuple[str, ...] = (
    "fig2_trajectories",
    "fig3_travel_time",
    "fig4_path_length",
    "fig5_flow_rmse",
)

# Colours for controllers not in CONTROLLER_COLORS, picked by a stable hash of the name
# (zlib.crc32, not hash(): that one is salted per process).  None equals a fixed colour.
_FALLBACK_COLORS: tuple[str, ...] = ("#56B4E9", "#8C564B", "#7F7F7F", "#BCBD22", "#17BECF", "#332288")

_LOG_SPAN = 30.0  # fig5 switches to a log y-axis when max / min of the values exceeds this
_NOT_DOCKED_HATCH = "////"
_NOT_DOCKED_ALPHA = 0.35
_NOTE_FONTSIZE = 6.5
_MAX_BAR_WIDTH = 0.2  # bar width in units of the case spacing (few controllers: no fat bars)
_CHAR_WIDTH_IN = 0.06  # rough width of one character of a "small" tick label, inches


def controller_color(name: str) -> str:
    """The fixed colour (hex string) of controller ``name``.

    Known controllers get their entry in :data:`CONTROLLER_COLORS`; any other name gets a
    colour from a fallback palette chosen by a stable hash of the name, so it is the same
    in every figure, run and process.
    """
    if name in CONTROLLER_COLORS:
        return CONTROLLER_COLORS[name]
    return _FALLBACK_COLORS[zlib.crc32(str(name).encode("utf-8")) % len(_FALLBACK_COLORS)]


def controller_label(name: str) -> str:
    """Display name of controller ``name`` (e.g. ``"Oracle MPC"``); unknown names are returned as is."""
    return CONTROLLER_LABELS.get(name, str(name))


def plot_campaign(
    records: Sequence[Mapping[str, Any]],
    runs: Mapping[tuple[str, str], RunResults],
    out_dir: str | Path,
    *,
    formats: tuple[str, ...] = ("png",),
    dpi: int = 120,
) -> list[Path]:
    """Draw the campaign's summary figures and save each in every format of ``formats``.

    Written to ``out_dir`` (created if missing), as ``<name>.<ext>`` for each ``ext`` in
    ``formats``:

    * ``fig2_trajectories`` -- one top-view panel per case (east horizontal, north
      vertical, metres, equal aspect): every controller's path in its colour, the start
      (open black circle), the dock's recorded path with its final position (gold star)
      and the docking tolerance circle (run attribute ``tolerance_m``), and the end of
      each path (filled circle if docked, cross if not).  Panel titles are the case
      labels; one legend for the figure.
    * ``fig3_travel_time`` -- grouped bars of ``time_to_dock_s`` (s).  A run that did not
      dock gets a hatched, faded bar up to its ``timeout_s`` (``end_time_s`` if that is
      not finite), annotated "timeout"; a failed run gets no bar but a "failed" mark.
    * ``fig4_path_length`` -- grouped bars of ``path_length_m`` (m), same conventions
      (hatched if not docked, "failed" mark for failed runs).
    * ``fig5_flow_rmse`` -- grouped bars of ``flow_rmse_m_s`` (m/s) for the controllers
      with a finite value in some record (the flow-state-estimating ones), log y-axis if
      the values span more than a factor of 30.  Without any such value the figure holds
      a note "no flow-estimating controller in this campaign".

    Parameters
    ----------
    records : sequence of dict
        The campaign table, one dict per run, with keys ``case`` (mission name),
        ``case_label``, ``controller``, ``status`` (``"done"`` or ``"failed"``),
        ``error``, ``docked``, ``time_to_dock_s`` (s, NaN if not docked), ``end_time_s``
        (s), ``timeout_s`` (s), ``path_length_m`` (m), ``flow_rmse_m_s`` (m/s, NaN without
        an estimator) and more that are not plotted.  Cases are shown in the order of their
        first record; controllers in :data:`CONTROLLER_ORDER` first, then any others in
        the order of their first record.
    runs : mapping of (case, controller) -> RunResults
        The runs' recorded trajectories for ``fig2_trajectories``; runs may be missing
        (e.g. failed ones), they are then left out of the map.
    out_dir : str or Path
        Directory for the figure files (created if missing).
    formats : tuple of str
        File formats (extensions) to write, e.g. ``("png",)`` or ``("png", "pdf")``.
    dpi : int
        Resolution of raster formats (PNG).

    Returns
    -------
    list of Path
        The written files: for each figure in the order above, one file per format in
        the order of ``formats``.

    Raises
    ------
    ValueError
        If ``records`` is empty, ``formats`` is empty or holds a format matplotlib cannot
        write.
    """
    exts = _check_formats(formats)
    if not records:
        raise ValueError("cannot plot a campaign without records (the campaign table is empty)")
    table = _Table(records)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    makers: tuple[Callable[[], Figure], ...] = (
        lambda: _trajectories_figure(table, runs),
        lambda: _bars_figure(
            table,
            value=_travel_time,
            ylabel="time to dock [s]",
            title="Time to dock",
            hatch_label="not docked (bar = timeout)",
            annotate_not_docked="timeout",
        ),
        lambda: _bars_figure(
            table,
            value=lambda rec: _num(rec.get("path_length_m")),
            ylabel="path length [m]",
            title="Vehicle path length",
            hatch_label="not docked",
        ),
        _flow_rmse_maker(table),
    )
    paths: list[Path] = []
    for name, make in zip(FIGURE_NAMES, makers, strict=True):
        fig = make()
        try:
            for ext in exts:
                path = out / f"{name}.{ext}"
                _save(fig, path, ext, dpi)
                paths.append(path)
        finally:
            fig.clear()
    return paths


# ----------------------------------------------------------------------------- table


class _Table:
    """The campaign records indexed by (case, controller), with the case and controller orders."""

    def __init__(self, records: Sequence[Mapping[str, Any]]) -> None:
        self.cases: list[str] = []
        self.case_labels: dict[str, str] = {}
        self.by_key: dict[tuple[str, str], Mapping[str, Any]] = {}
        seen_controllers: list[str] = []
        for rec in records:
            case = str(rec.get("case", ""))
            ctrl = str(rec.get("controller", ""))
            if case not in self.case_labels:
                self.cases.append(case)
                self.case_labels[case] = str(rec.get("case_label") or case)
            if ctrl not in seen_controllers:
                seen_controllers.append(ctrl)
            self.by_key.setdefault((case, ctrl), rec)  # first record wins on duplicates
        known = [c for c in CONTROLLER_ORDER if c in seen_controllers]
        self.controllers: list[str] = known + [c for c in seen_controllers if c not in CONTROLLER_ORDER]

    def get(self, case: str, controller: str) -> Mapping[str, Any] | None:
        return self.by_key.get((case, controller))


def _num(value: Any) -> float:
    """A record value as a float; NaN for None, strings, or anything not numeric."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def _failed(rec: Mapping[str, Any]) -> bool:
    return str(rec.get("status", "done")) != "done"


def _docked(rec: Mapping[str, Any]) -> bool:
    value = rec.get("docked")
    return bool(value) if isinstance(value, bool | np.bool_ | int | np.integer) else False


def _travel_time(rec: Mapping[str, Any]) -> float:
    """Bar height of fig3: time to dock if docked, else the timeout (or the end time), s."""
    if _docked(rec):
        return _num(rec.get("time_to_dock_s"))
    timeout = _num(rec.get("timeout_s"))
    return timeout if math.isfinite(timeout) else _num(rec.get("end_time_s"))


# ----------------------------------------------------------------------------- saving


def _check_formats(formats: tuple[str, ...]) -> list[str]:
    if isinstance(formats, str):
        formats = (formats,)
    exts = [str(f).strip().lstrip(".").lower() for f in formats]
    if not exts:
        raise ValueError("formats is empty: give at least one, e.g. ('png',)")
    supported = FigureCanvasAgg(Figure()).get_supported_filetypes()
    bad = [e for e in exts if e not in supported]
    if bad:
        raise ValueError(f"unsupported figure format(s) {bad}; supported: {', '.join(sorted(supported))}")
    return list(dict.fromkeys(exts))  # drop duplicates, keep order


def _save(fig: Figure, path: Path, ext: str, dpi: int) -> None:
    """Save ``fig`` without time stamps or random ids, so reruns give identical files."""
    metadata: dict[str, Any] | None
    if ext == "png":
        metadata = {"Software": None}
    elif ext == "pdf":
        metadata = {"CreationDate": None, "ModDate": None}
    elif ext == "svg":
        metadata = {"Date": None}
    else:
        metadata = None
    if ext == "svg":  # fixed ids instead of random ones (rc_context touches global rcParams: svg only)
        with mpl.rc_context({"svg.hashsalt": "auvdock"}):
            fig.savefig(path, format=ext, dpi=dpi, metadata=metadata)
    else:
        fig.savefig(path, format=ext, dpi=dpi, metadata=metadata)


def _new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


# ----------------------------------------------------------------------------- fig 2


def _grid_shape(n: int) -> tuple[int, int]:
    """(rows, columns) of the panel grid for n panels: 1 row up to 3, then about square."""
    if n <= 3:
        return 1, max(n, 1)
    cols = math.ceil(math.sqrt(n))
    return math.ceil(n / cols), cols


def _wrap_label(label: str, width: int) -> str:
    """Wrap a case label to lines of ``width`` characters, breaking after "case N:" first.

    Parenthesised groups such as "(0.5, 0.5)" and assignments such as "T = 12 h" are kept
    on one line (their spaces become no-break spaces).
    """
    label = re.sub(r"\([^()]*\)", lambda m: m.group(0).replace(" ", "\u00a0"), label)
    label = re.sub(r"(\S+) = (\S+(?: [a-z]{1,3}\b)?)", lambda m: "\u00a0".join(m.group(0).split(" ")), label)
    head, sep, tail = label.partition(": ")
    if sep and len(head) < width and len(label) > width:
        return head + ":\n" + textwrap.fill(tail, width)
    return textwrap.fill(label, width)


def _finite_rows(a: np.ndarray) -> np.ndarray:
    """Indices of the rows of ``a`` (T, k) with all entries finite."""
    return np.flatnonzero(np.all(np.isfinite(a), axis=1))


# Legend entries of the marks in the trajectory panels, in legend order.
_TRAJECTORY_MARKS: dict[str, dict[str, Any]] = {
    "start": {"ls": "", "marker": "o", "ms": 7, "mfc": "white", "mec": "k", "mew": 1.5},
    "dock": {"ls": "", "marker": "*", "ms": 13, "mfc": "gold", "mec": "k", "mew": 0.8},
    "docking tolerance": {"ls": "--", "color": "0.25", "lw": 1.0},
    "end (docked)": {"ls": "", "marker": "o", "ms": 6, "mfc": "0.45", "mec": "k", "mew": 0.8},
    "end (not docked)": {"ls": "", "marker": "X", "ms": 8, "mfc": "0.45", "mec": "k", "mew": 0.8},
}


def _trajectories_figure(table: _Table, runs: Mapping[tuple[str, str], RunResults]) -> Figure:
    rows, cols = _grid_shape(len(table.cases))
    fig = _new_figure((0.5 + 3.9 * cols, 1.3 + 3.6 * rows))
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    plotted: set[str] = set()
    marks: set[str] = set()
    for ax, case in zip(axes, table.cases, strict=False):
        _trajectory_panel(ax, table, case, runs, plotted, marks)
    for ax in axes[len(table.cases) :]:
        ax.set_visible(False)

    ctrl_handles: list[Any] = [
        Line2D([], [], color=controller_color(c), lw=2.0, label=controller_label(c))
        for c in table.controllers
        if c in plotted
    ]
    mark_handles: list[Any] = [
        Line2D([], [], label=name, **style) for name, style in _TRAJECTORY_MARKS.items() if name in marks
    ]
    _legend_rows(fig, [ctrl_handles, mark_handles])
    fig.suptitle("Docking trajectories, top view (north-east)", fontsize="large")
    return fig


def _trajectory_panel(
    ax: Axes,
    table: _Table,
    case: str,
    runs: Mapping[tuple[str, str], RunResults],
    plotted: set[str],
    marks: set[str],
) -> None:
    """Draw one case's panel; adds the controllers drawn to ``plotted`` and the marks drawn to ``marks``."""
    starts: list[np.ndarray] = []
    dock: np.ndarray | None = None  # (T', 3) finite rows of the first recorded dock path, NED m
    tolerance = math.nan
    missing: list[str] = []
    for z, ctrl in enumerate(table.controllers):
        rec = table.get(case, ctrl)
        run = runs.get((case, ctrl))
        pos = np.empty((0, 3)) if run is None else np.asarray(run.state, dtype=float)[:, :3]
        pos = pos[_finite_rows(pos)]
        if run is None or pos.shape[0] == 0:
            if rec is not None:
                missing.append(f"{controller_label(ctrl)}: {'failed' if _failed(rec) else 'no data'}")
            continue
        color = controller_color(ctrl)
        east, north = pos[:, 1], pos[:, 0]
        # later controllers on top but thinner, so identical paths (e.g. in still water) stay visible
        lw = max(3.0 - 0.45 * z, 1.2)
        ax.plot(east, north, color=color, lw=lw, alpha=0.9, solid_capstyle="round", zorder=3 + 0.01 * z)
        plotted.add(ctrl)
        starts.append(np.array([east[0], north[0]]))
        docked = _docked(rec) if rec is not None else run.attrs.get("docked") is True
        end = "end (docked)" if docked else "end (not docked)"
        style = {**_TRAJECTORY_MARKS[end], "mfc": color}
        ax.plot(east[-1], north[-1], zorder=6, **style)
        marks.add(end)
        if dock is None:
            d = np.asarray(run.dock_position_m, dtype=float)
            d = d[_finite_rows(d)]
            dock = d if d.shape[0] else None
        if not math.isfinite(tolerance):
            tolerance = _num(run.attrs.get("tolerance_m"))

    if starts:
        uniq = np.unique(np.round(np.array(starts), 6), axis=0)
        ax.plot(uniq[:, 0], uniq[:, 1], zorder=7, **_TRAJECTORY_MARKS["start"])
        marks.add("start")
    if dock is not None:
        # the dock heaves, so its recorded path is (nearly) a point in the top view
        ax.plot(dock[:, 1], dock[:, 0], color="k", lw=3.0, solid_capstyle="round", zorder=4)
        final = dock[-1]
        ax.plot(final[1], final[0], zorder=8, **_TRAJECTORY_MARKS["dock"])
        marks.add("dock")
        if math.isfinite(tolerance) and tolerance > 0.0:
            ax.add_patch(
                Circle((final[1], final[0]), tolerance, fill=False, ls="--", lw=1.0, ec="0.25", zorder=9)
            )
            marks.add("docking tolerance")

    if missing:
        ax.text(
            0.02, 0.02, "\n".join(missing), transform=ax.transAxes, fontsize="x-small", color="0.3",
            va="bottom", ha="left", zorder=9,
            bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.7", "alpha": 0.85},
        )  # fmt: skip
    if not starts and dock is None:
        ax.text(0.5, 0.5, "no trajectories recorded", transform=ax.transAxes, ha="center", color="0.4")
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.08)
    ax.grid(True, alpha=0.3)
    ax.set_title(_wrap_label(table.case_labels[case], 46), fontsize="medium")


# ----------------------------------------------------------------------------- bar figures


def _flow_rmse_maker(table: _Table) -> Callable[[], Figure]:
    """The fig5 maker: bars for the controllers with a finite flow RMSE somewhere, else a note."""
    rmse = {key: _num(rec.get("flow_rmse_m_s")) for key, rec in table.by_key.items()}
    fse = [c for c in table.controllers if any(math.isfinite(v) for (_, k), v in rmse.items() if k == c)]
    if not fse:
        return _no_flow_figure
    finite = np.array([v for v in rmse.values() if math.isfinite(v) and v > 0.0])
    log = finite.size > 0 and float(finite.max()) > _LOG_SPAN * float(finite.min())
    return lambda: _bars_figure(
        table,
        value=lambda rec: _num(rec.get("flow_rmse_m_s")),
        ylabel="flow estimate RMSE [m/s]",
        title="Flow estimate RMSE",
        hatch_label="not docked",
        controllers=fse,
        log=log,
    )


def _no_flow_figure() -> Figure:
    fig = _new_figure((7.0, 3.5))
    ax = fig.add_subplot()
    ax.text(
        0.5, 0.5, "no flow-estimating controller in this campaign", transform=ax.transAxes,
        ha="center", va="center", fontsize="large", color="0.3",
    )  # fmt: skip
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_ylabel("flow estimate RMSE [m/s]")
    ax.set_title("Flow estimate RMSE")
    return fig


def _bars_figure(
    table: _Table,
    *,
    value: Callable[[Mapping[str, Any]], float],
    ylabel: str,
    title: str,
    hatch_label: str,
    annotate_not_docked: str | None = None,
    controllers: list[str] | None = None,
    log: bool = False,
) -> Figure:
    """Grouped bars: one group per case, one bar per controller, ``value(record)`` high.

    Docked runs: solid bar.  Not docked: faded, hatched bar (annotated above with
    ``annotate_not_docked`` if given).  Failed runs: no bar, a "failed" mark at the base.
    A done run whose value is not finite gets an "n/a" mark.
    """
    ctrls = list(table.controllers if controllers is None else controllers)
    n_cases, n_ctrl = len(table.cases), max(len(ctrls), 1)
    width = min(0.8 / n_ctrl, _MAX_BAR_WIDTH)
    group_width = width * n_ctrl
    fig = _new_figure((max(7.0, 1.4 + n_cases * max(1.6, 0.22 * n_ctrl + 0.6)), 5.0))
    ax = fig.add_subplot()
    base = ax.get_xaxis_transform()  # x in data, y in axes fraction

    heights: list[float] = []
    any_hatched = any_failed = any_na = False
    for i, case in enumerate(table.cases):
        for j, ctrl in enumerate(ctrls):
            rec = table.get(case, ctrl)
            if rec is None:
                continue
            x = i - group_width / 2 + (j + 0.5) * width
            color = controller_color(ctrl)
            if _failed(rec):
                ax.plot(
                    [x], [0.0], transform=base, ls="", marker="x", ms=6, mew=1.5, color=color, clip_on=False
                )
                ax.text(
                    x, 0.035, str(rec.get("status") or "failed"), transform=base, rotation=90, ha="center",
                    va="bottom", fontsize=_NOTE_FONTSIZE, color="0.2",
                )  # fmt: skip
                any_failed = True
                continue
            h = value(rec)
            if not math.isfinite(h) or (log and h <= 0.0):
                ax.text(
                    x, 0.02, "n/a", transform=base, rotation=90, ha="center", va="bottom",
                    fontsize=_NOTE_FONTSIZE, color="0.35",
                )  # fmt: skip
                any_na = True
                continue
            heights.append(h)
            if _docked(rec):
                ax.bar(x, h, width, color=color, edgecolor="k", linewidth=0.6, zorder=3)
            else:
                ax.bar(
                    x, h, width, color=to_rgba(color, _NOT_DOCKED_ALPHA), edgecolor=color,
                    hatch=_NOT_DOCKED_HATCH, linewidth=1.0, zorder=3,
                )  # fmt: skip
                any_hatched = True
                if annotate_not_docked:
                    ax.annotate(
                        annotate_not_docked, (x, h), xytext=(0, 2), textcoords="offset points", rotation=90,
                        ha="center", va="bottom", fontsize=_NOTE_FONTSIZE, color="0.25", zorder=4,
                    )  # fmt: skip

    ax.set_xticks(np.arange(n_cases))
    chars = max(12, int((fig.get_figwidth() - 1.2) / max(n_cases, 1) / _CHAR_WIDTH_IN))
    ax.set_xticklabels([_wrap_label(table.case_labels[c], chars) for c in table.cases], fontsize="small")
    ax.set_xlim(-0.5, n_cases - 0.5)
    ax.tick_params(axis="x", length=0)
    for i in range(1, n_cases):
        ax.axvline(i - 0.5, color="0.85", lw=0.8, zorder=1)
    top = max(heights) if heights else 1.0
    if log:
        ax.set_yscale("log")
        positive = [h for h in heights if h > 0.0]
        lo = min(positive) if positive else 1e-3
        ax.set_ylim(lo / 2.0, top * 2.0)
    else:
        # head room for the rotated notes above the bars
        ax.set_ylim(0.0, top * (1.18 if annotate_not_docked and any_hatched else 1.08) if top > 0 else 1.0)
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", which="both", alpha=0.3, zorder=0)
    ax.set_axisbelow(True)
    ax.set_title(title, fontsize="large")

    ctrl_handles: list[Any] = [
        Patch(facecolor=controller_color(c), edgecolor="k", linewidth=0.6, label=controller_label(c))
        for c in ctrls
    ]
    handles: list[Any] = []
    if any_hatched:
        handles.append(
            Patch(facecolor=(0.5, 0.5, 0.5, _NOT_DOCKED_ALPHA), edgecolor="0.3", hatch=_NOT_DOCKED_HATCH,
                  label=hatch_label)
        )  # fmt: skip
    if any_failed:
        handles.append(Line2D([], [], ls="", marker="x", ms=6, mew=1.5, color="0.3", label="run failed"))
    if any_na:
        handles.append(Line2D([], [], ls="", marker="$n/a$", ms=12, color="0.35", label="no value"))
    _legend_rows(fig, [ctrl_handles, handles])
    return fig


def _legend_rows(fig: Figure, groups: list[list[Any]], max_cols: int = 6) -> None:
    """One figure legend below the axes, each non-empty group of handles starting a new row.

    Matplotlib fills legend columns top to bottom, so the handles are laid out row-major
    and padded with invisible entries to get that.
    """
    groups = [g for g in groups if g]
    if not groups:
        return
    ncols = min(max(len(g) for g in groups), max_cols)
    rows: list[list[Any]] = []
    for group in groups:
        for start in range(0, len(group), ncols):
            row = group[start : start + ncols]
            rows.append(row + [Line2D([], [], ls="", label=" ")] * (ncols - len(row)))
    column_major = [rows[r][c] for c in range(ncols) for r in range(len(rows))]
    fig.legend(handles=column_major, loc="outside lower center", ncols=ncols, fontsize="small")
