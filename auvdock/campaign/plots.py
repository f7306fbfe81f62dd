"""Summary figures of a docking campaign (``auvdock compare``): several cases x several controllers.

The figures mirror the paper's: Fig. 2 (top-view trajectories, one panel per case), Fig. 3
(time to dock), Fig. 4 (path length) and Fig. 5 (flow-estimate RMSE), each drawn as grouped
bars with one bar per controller and one group per case.

Every controller has one fixed colour (:data:`CONTROLLER_COLORS`, :func:`controller_color`)
shared by all figures, so a controller looks the same everywhere; the colours, display names
and order of the registered controllers come from the registry
(:data:`auvdock.controllers.registry.CONTROLLERS`).

Figures are drawn on :class:`matplotlib.figure.Figure` objects with an explicit Agg canvas:
no pyplot, no global backend switch, no GUI.  Saving drops the time stamps and version
strings matplotlib would otherwise embed (PNG ``Software``, PDF ``CreationDate``, SVG
``Date``), so the same inputs give byte-identical PNG and PDF files.

Frames and units follow :mod:`auvdock.results.store`: positions NED in metres, times in s,
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

from auvdock.controllers.registry import CONTROLLERS, controller_label, controller_names
from auvdock.results.store import RunResults

__all__ = [
    "CONTROLLER_ORDER",
    "CONTROLLER_COLORS",
    "CONTROLLER_LABELS",
    "FIGURE_NAMES",
    "campaign_figures",
    "controller_color",
    "controller_label",
    "plot_campaign",
]

#: Canonical order of the controllers in legends and within each bar group: the registry's
#: (:data:`auvdock.controllers.registry.CONTROLLERS`).
CONTROLLER_ORDER: tuple[str, ...] = controller_names()

#: Fixed colour per registered controller (its ``colour`` in the registry), used by every figure.
CONTROLLER_COLORS: dict[str, str] = {n: e.colour for n, e in CONTROLLERS.items() if e.colour}

#: Display name per registered controller (its ``label`` in the registry); other controllers are
#: shown by their own name.
CONTROLLER_LABELS: dict[str, str] = {n: controller_label(n) for n in CONTROLLERS}

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

_NOT_DOCKED_HATCH = "////"
_NOT_DOCKED_ALPHA = 0.35
_NOTE_FONTSIZE = 6.5
_MAX_BAR_WIDTH = 0.2  # bar width in units of the case spacing (few controllers: no fat bars)
_CHAR_WIDTH_IN = 0.06  # rough width of one character of a "small" tick label, inches
# width of a "small" legend: frame padding, plus per column a handle with its gaps and the
# longest label's characters (measured with matplotlib's default font, rounded up), inches
_LEGEND_PAD_IN = 0.3
_LEGEND_ENTRY_IN = 0.65
_LEGEND_CHAR_IN = 0.065


def controller_color(name: str) -> str:
    """The fixed colour (hex string) of controller ``name``.

    Known controllers get their entry in :data:`CONTROLLER_COLORS`; any other name gets a
    colour from a fallback palette chosen by a stable hash of the name, so it is the same
    in every figure, run and process.
    """
    if name in CONTROLLER_COLORS:
        return CONTROLLER_COLORS[name]
    return _FALLBACK_COLORS[zlib.crc32(str(name).encode("utf-8")) % len(_FALLBACK_COLORS)]


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
      vertical, metres, equal aspect): every controller's path in its colour and line
      style (later controllers thinner and dashed, so coinciding paths both show; paths
      within 1 % of the panel's span of each other are named below the panel as "same
      path"), the start (open black circle), the dock's recorded path with its final
      position (gold star) and the docking tolerance circle (run attribute
      ``tolerance_m``), and the end of each path (filled circle if docked, cross if not).
      With a tolerance, an inset in the panel's emptiest corner zooms on the dock (three
      tolerance radii), where the circle and the path ends can be seen.  Panel titles are
      the case labels; one legend for the figure, below the panels, in as many columns as
      fit its width.
    * ``fig3_travel_time`` -- grouped bars of ``time_to_dock_s`` (s).  A run that did not
      dock gets a hatched, faded bar up to its ``timeout_s`` (``end_time_s`` if that is
      not finite), annotated with why and when it ended ("timed out 75 s", from ``reason``
      and ``end_time_s``); a failed run gets no bar but a "failed" mark.
    * ``fig4_path_length`` -- grouped bars of ``path_length_m`` (m), same conventions
      (hatched and annotated if not docked, "failed" mark for failed runs).
    * ``fig5_flow_rmse`` -- grouped bars of ``flow_rmse_m_s`` (m/s) on a linear axis, each
      labelled with its value, for the controllers with a finite value in some record
      (the flow-state-estimating ones); runs that did not dock are hatched and annotated
      like fig3 (their RMSE is over the whole run, up to the timeout, so not comparable
      with docked runs').  Without any such value the figure holds a note "no
      flow-estimating controller in this campaign".

    Parameters
    ----------
    records : sequence of dict
        The campaign table, one dict per run, with keys ``case`` (mission name),
        ``case_label``, ``controller``, ``status`` (``"done"`` or ``"failed"``),
        ``error``, ``docked``, ``reason`` (optional), ``time_to_dock_s`` (s, NaN if not
        docked), ``end_time_s`` (s), ``timeout_s`` (s), ``path_length_m`` (m),
        ``flow_rmse_m_s`` (m/s, NaN without an estimator) and more that are not plotted.
        Cases are shown in the order of their first record; controllers in
        :data:`CONTROLLER_ORDER` first, then any others in the order of their first record.
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

    makers = _figure_makers(table, runs)
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


def campaign_figures(
    records: Sequence[Mapping[str, Any]], runs: Mapping[tuple[str, str], RunResults]
) -> list[tuple[str, Figure]]:
    """The figures :func:`plot_campaign` saves, built but not saved: ``(name, Figure)``.

    Names are :data:`FIGURE_NAMES`, in that order; arguments as :func:`plot_campaign`.

    Raises
    ------
    ValueError
        If ``records`` is empty.
    """
    if not records:
        raise ValueError("cannot plot a campaign without records (the campaign table is empty)")
    makers = _figure_makers(_Table(records), runs)
    return [(name, make()) for name, make in zip(FIGURE_NAMES, makers, strict=True)]


def _figure_makers(
    table: _Table, runs: Mapping[tuple[str, str], RunResults]
) -> tuple[Callable[[], Figure], ...]:
    """One figure builder per name of :data:`FIGURE_NAMES` (built one at a time when saving)."""
    return (
        lambda: _trajectories_figure(table, runs),
        lambda: _bars_figure(
            table,
            value=_travel_time,
            ylabel="time to dock [s]",
            title="Time to dock",
            hatch_label="not docked (bar = the timeout)",
        ),
        lambda: _bars_figure(
            table,
            value=lambda rec: _num(rec.get("path_length_m")),
            ylabel="path length [m]",
            title="Vehicle path length",
            hatch_label="did not dock: path up to the run's end",
        ),
        _flow_rmse_maker(table),
    )


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

# Line style of each registered controller's path in fig2, by its place in the registry's order:
# where paths coincide, the later controller's dashes (drawn on top, thinner) let the earlier one
# show through.
_REGISTERED_LINESTYLES: tuple[Any, ...] = (
    "-", "-", (0, (5, 2)), (0, (1, 1.5)), (0, (6, 2, 1, 2)), (0, (2, 1)),
)  # fmt: skip
_FALLBACK_LINESTYLES: tuple[Any, ...] = ((0, (3, 1, 1, 1)), (0, (8, 2)), (0, (2, 2)), "-")
_PATH_WIDTHS: tuple[float, ...] = (3.4, 2.6, 2.0, 1.6, 1.3)  # by drawing order (later: thinner)
_SAME_PATH_FRACTION = 0.01  # paths closer than this fraction of the panel's span count as one
_INSET_SIZE = 0.38  # the dock inset's side, fraction of the panel
_INSET_TOLERANCES = 3.0  # the dock inset shows this many tolerance radii around the dock


def _controller_linestyle(name: str, index: int) -> Any:
    """Line style of controller ``name`` (``index``: its position among the campaign's controllers)."""
    if name in CONTROLLER_ORDER and CONTROLLER_ORDER.index(name) < len(_REGISTERED_LINESTYLES):
        return _REGISTERED_LINESTYLES[CONTROLLER_ORDER.index(name)]
    return _FALLBACK_LINESTYLES[index % len(_FALLBACK_LINESTYLES)]


def _path_width(index: int) -> float:
    return _PATH_WIDTHS[min(index, len(_PATH_WIDTHS) - 1)]


def _resample_path(p: np.ndarray, n: int = 200) -> np.ndarray:
    """``n`` points evenly spaced by arc length along the polyline ``p`` (k, 2)."""
    if p.shape[0] < 2:
        return np.repeat(p[:1], n, axis=0)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    if s[-1] <= 0.0:
        return np.repeat(p[:1], n, axis=0)
    t = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])], axis=1)


def _path_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Hausdorff distance between two polylines (k, 2), m, on arc-length resamples."""
    ra, rb = _resample_path(a), _resample_path(b)
    d = np.linalg.norm(ra[:, None, :] - rb[None, :, :], axis=2)
    return float(max(d.min(axis=1).max(), d.min(axis=0).max()))


def _same_path_groups(paths: dict[str, np.ndarray], tol: float) -> list[list[str]]:
    """Groups (two or more) of controllers whose paths (k, 2) lie within ``tol`` m of the group's first."""
    groups: list[list[str]] = []
    for name, p in paths.items():
        for g in groups:
            if _path_distance(paths[g[0]], p) <= tol:
                g.append(name)
                break
        else:
            groups.append([name])
    return [g for g in groups if len(g) > 1]


def _trajectories_figure(table: _Table, runs: Mapping[tuple[str, str], RunResults]) -> Figure:
    rows, cols = _grid_shape(len(table.cases))
    fig = _new_figure((max(7.0, 0.5 + 3.9 * cols), 1.3 + 3.6 * rows))
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False)).ravel()
    plotted: set[str] = set()
    marks: set[str] = set()
    for ax, case in zip(axes, table.cases, strict=False):
        _trajectory_panel(ax, table, case, runs, plotted, marks)
    for ax in axes[len(table.cases) :]:
        ax.set_visible(False)

    ctrl_handles: list[Any] = [
        Line2D(
            [],
            [],
            color=controller_color(c),
            lw=2.0,
            ls=_controller_linestyle(c, i),
            label=controller_label(c),
        )
        for i, c in enumerate(table.controllers)
        if c in plotted
    ]
    mark_handles: list[Any] = [
        Line2D([], [], label=name, **style) for name, style in _TRAJECTORY_MARKS.items() if name in marks
    ]
    legend_rows = _legend_rows(fig, [ctrl_handles, mark_handles])
    # room for the legend's rows beyond two and the "same path" notes under the panels
    note_lines = sum(
        max((ax.get_xlabel().count("\n") for ax in axes[r * cols : (r + 1) * cols]), default=0)
        for r in range(rows)
    )
    fig.set_figheight(fig.get_figheight() + 0.2 * max(legend_rows - 2, 0) + 0.17 * note_lines)
    fig.suptitle("Docking trajectories, top view (north-east)", fontsize="large")
    return fig


class _PanelContent:
    """What one fig2 panel shows, so the panel and its dock inset draw the same things."""

    def __init__(self) -> None:
        self.paths: list[
            tuple[str, np.ndarray, bool, int]
        ] = []  # controller, (k, 2) east-north, docked, index
        self.starts: list[np.ndarray] = []
        self.dock: np.ndarray | None = None  # (T', 3) NED m
        self.tolerance = math.nan

    def draw(self, ax: Axes, marks: set[str] | None = None, *, small: bool = False) -> None:
        """Draw on ``ax`` (``small``: thinner lines, smaller marks: the inset); add marks to ``marks``."""
        thin = 0.75 if small else 1.0
        for ctrl, p, docked, z in self.paths:
            color = controller_color(ctrl)
            ax.plot(
                p[:, 0], p[:, 1], color=color, lw=_path_width(z) * thin, ls=_controller_linestyle(ctrl, z),
                alpha=0.95, solid_capstyle="round", dash_capstyle="butt", zorder=3 + 0.01 * z,
                gid=f"path {ctrl}",
            )  # fmt: skip
            end = "end (docked)" if docked else "end (not docked)"
            style = _TRAJECTORY_MARKS[end]
            ax.plot(p[-1, 0], p[-1, 1], zorder=6, **{**style, "mfc": color, "ms": style["ms"] * thin})
            if marks is not None:
                marks.add(end)
        if self.starts:
            uniq = np.unique(np.round(np.array(self.starts), 6), axis=0)
            ax.plot(uniq[:, 0], uniq[:, 1], zorder=7, **_TRAJECTORY_MARKS["start"])
            if marks is not None:
                marks.add("start")
        if self.dock is not None:
            # the dock heaves, so its recorded path is (nearly) a point in the top view
            ax.plot(self.dock[:, 1], self.dock[:, 0], color="k", lw=3.0, solid_capstyle="round", zorder=4)
            final = self.dock[-1]
            style = _TRAJECTORY_MARKS["dock"]
            ax.plot(final[1], final[0], zorder=8, **{**style, "ms": style["ms"] * thin})
            if marks is not None:
                marks.add("dock")
            if math.isfinite(self.tolerance) and self.tolerance > 0.0:
                ax.add_patch(
                    Circle(
                        (final[1], final[0]), self.tolerance, fill=False, ls="--", lw=1.2, ec="0.25",
                        zorder=9, gid="docking tolerance",
                    )
                )  # fmt: skip
                if marks is not None:
                    marks.add("docking tolerance")

    def points(self) -> np.ndarray:
        """Every drawn point (k, 2), east-north m."""
        pts = [p for _, p, _, _ in self.paths] + [s[None, :] for s in self.starts]
        if self.dock is not None:
            pts.append(self.dock[:, [1, 0]])
        return np.concatenate(pts) if pts else np.empty((0, 2))


def _trajectory_panel(
    ax: Axes,
    table: _Table,
    case: str,
    runs: Mapping[tuple[str, str], RunResults],
    plotted: set[str],
    marks: set[str],
) -> None:
    """Draw one case's panel; adds the controllers drawn to ``plotted`` and the marks drawn to ``marks``."""
    content = _PanelContent()
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
        docked = _docked(rec) if rec is not None else run.attrs.get("docked") is True
        content.paths.append((ctrl, pos[:, [1, 0]], docked, z))
        content.starts.append(pos[0, [1, 0]])
        plotted.add(ctrl)
        if content.dock is None:
            d = np.asarray(run.dock_position_m, dtype=float)
            d = d[_finite_rows(d)]
            content.dock = d if d.shape[0] else None
        if not math.isfinite(content.tolerance):
            content.tolerance = _num(run.attrs.get("tolerance_m"))
    content.draw(ax, marks)

    pts = content.points()
    span = float(np.max(np.ptp(pts, axis=0))) if pts.shape[0] else 0.0
    same = _same_path_groups({c: p for c, p, _, _ in content.paths}, _SAME_PATH_FRACTION * span)
    if content.dock is not None and math.isfinite(content.tolerance) and content.tolerance > 0.0:
        _dock_inset(ax, content, pts, lower_left=not missing)

    if missing:
        ax.text(
            0.02, 0.02, "\n".join(missing), transform=ax.transAxes, fontsize="x-small", color="0.3",
            va="bottom", ha="left", zorder=9,
            bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": "0.7", "alpha": 0.85},
        )  # fmt: skip
    if not content.paths and content.dock is None:
        ax.text(0.5, 0.5, "no trajectories recorded", transform=ax.transAxes, ha="center", color="0.4")
    xlabel = "east [m]"
    for g in same:  # below the map, so the note hides nothing
        names = " = ".join(controller_label(c) for c in g)
        note = f"same path (within {_SAME_PATH_FRACTION * span * 100:.0f} cm): {names}"
        xlabel += "\n" + textwrap.fill(note, 50)
    ax.set_xlabel(xlabel, fontsize="small" if same else None)
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.08)
    ax.grid(True, alpha=0.3)
    ax.set_title(_wrap_label(table.case_labels[case], 46), fontsize="medium")


def _emptiest_corner(pts: np.ndarray, *, lower_left: bool = True) -> tuple[float, float]:
    """Lower-left corner (axes fraction) of the inset in the panel corner with the fewest of ``pts``.

    The points (k, 2) are mapped onto the data box with the panel's 8 % margins (the equal
    aspect only widens the box, which leaves the corners emptier); ties go to lower right.
    Upper corners leave room for the inset's title; ``lower_left=False`` keeps that corner
    free (for the "failed" notes).
    """
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    f = ((pts - lo) / span + 0.08) / 1.16  # axes fraction with margins 0.08 on each side
    size, low, high, left, right = _INSET_SIZE, 0.03, 1.0 - 0.09 - _INSET_SIZE, 0.03, 0.97 - _INSET_SIZE
    corners = [(right, low), (left, high), (right, high)] + ([(left, low)] if lower_left else [])
    counts = [
        int(np.sum((f[:, 0] >= x - 0.02) & (f[:, 0] <= x + size + 0.02) & (f[:, 1] >= y - 0.02)
                   & (f[:, 1] <= y + size + 0.09)))
        for x, y in corners
    ]  # fmt: skip
    return corners[int(np.argmin(counts))]


def _dock_inset(ax: Axes, content: _PanelContent, pts: np.ndarray, *, lower_left: bool = True) -> Axes:
    """A zoom on the dock (``_INSET_TOLERANCES`` tolerance radii around it), in the emptiest corner."""
    assert content.dock is not None
    x0, y0 = _emptiest_corner(pts, lower_left=lower_left)
    inset = ax.inset_axes((x0, y0, _INSET_SIZE, _INSET_SIZE), zorder=10)
    content.draw(inset, small=True)
    final = content.dock[-1]
    r = _INSET_TOLERANCES * content.tolerance
    inset.set_xlim(final[1] - r, final[1] + r)
    inset.set_ylim(final[0] - r, final[0] + r)
    inset.set_aspect("equal", adjustable="box")
    inset.set_xticks([])
    inset.set_yticks([])
    inset.set_facecolor((1.0, 1.0, 1.0, 0.92))
    inset.set_title(f"dock ±{r * 100:.0f} cm", fontsize="x-small", pad=2)
    inset.set_gid("dock inset")
    return inset


# ----------------------------------------------------------------------------- bar figures


def _not_docked_note(rec: Mapping[str, Any]) -> str:
    """Why a done run has no docking, for the bar annotations: "timed out 75 s", "diverged 12 s"..."""
    reason = str(rec.get("reason") or "")
    end, timeout = _num(rec.get("end_time_s")), _num(rec.get("timeout_s"))
    if not reason or reason == "docked":  # older tables: infer the timeout from the times
        reason = "timeout" if math.isfinite(end) and math.isfinite(timeout) and end >= timeout - 1e-6 else ""
    text = "timed out" if reason == "timeout" else (reason or "not docked")
    if math.isfinite(end):
        text += f" {end:.3g} s"
    return text


def _flow_rmse_maker(table: _Table) -> Callable[[], Figure]:
    """The fig5 maker: bars for the controllers with a finite flow RMSE somewhere, else a note."""
    rmse = {key: _num(rec.get("flow_rmse_m_s")) for key, rec in table.by_key.items()}
    fse = [c for c in table.controllers if any(math.isfinite(v) for (_, k), v in rmse.items() if k == c)]
    if not fse:
        return _no_flow_figure
    return lambda: _bars_figure(
        table,
        value=lambda rec: _num(rec.get("flow_rmse_m_s")),
        ylabel="flow estimate RMSE [m/s]",
        title="Flow estimate RMSE (over each whole run)",
        hatch_label="did not dock: RMSE over the whole run up to its end,\nnot comparable with docked runs",
        controllers=fse,
        value_labels=True,
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
    controllers: list[str] | None = None,
    value_labels: bool = False,
) -> Figure:
    """Grouped bars on a linear axis: one group per case, one bar per controller, ``value(record)`` high.

    Docked runs: solid bar.  Not docked: faded, hatched bar annotated above with why and
    when it ended (:func:`_not_docked_note`, e.g. "timed out 75 s").  Failed runs: no bar,
    a "failed" mark at the base.  A done run whose value is not finite gets an "n/a" mark.
    ``value_labels``: every bar is also labelled with its value.
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
            if not math.isfinite(h):
                ax.text(
                    x, 0.02, "n/a", transform=base, rotation=90, ha="center", va="bottom",
                    fontsize=_NOTE_FONTSIZE, color="0.35",
                )  # fmt: skip
                any_na = True
                continue
            heights.append(h)
            note = f"{h:.3g}" if value_labels else ""
            if _docked(rec):
                ax.bar(
                    x, h, width, color=color, edgecolor="k", linewidth=0.6, zorder=3, gid=f"bar {case} {ctrl}"
                )
            else:
                ax.bar(
                    x, h, width, color=to_rgba(color, _NOT_DOCKED_ALPHA), edgecolor=color,
                    hatch=_NOT_DOCKED_HATCH, linewidth=1.0, zorder=3, gid=f"bar {case} {ctrl} not docked",
                )  # fmt: skip
                any_hatched = True
                note = f"{note}  {_not_docked_note(rec)}" if note else _not_docked_note(rec)
            if note:
                ax.annotate(
                    note, (x, h), xytext=(0, 2), textcoords="offset points", rotation=90,
                    ha="center", va="bottom", fontsize=_NOTE_FONTSIZE, color="0.25", zorder=4,
                    gid="bar note",
                )  # fmt: skip

    ax.set_xticks(np.arange(n_cases))
    chars = max(12, int((fig.get_figwidth() - 1.2) / max(n_cases, 1) / _CHAR_WIDTH_IN))
    ax.set_xticklabels([_wrap_label(table.case_labels[c], chars) for c in table.cases], fontsize="small")
    ax.set_xlim(-0.5, n_cases - 0.5)
    ax.tick_params(axis="x", length=0)
    for i in range(1, n_cases):
        ax.axvline(i - 0.5, color="0.85", lw=0.8, zorder=1)
    top = max(heights) if heights else 1.0
    # head room for the rotated notes above the bars
    ax.set_ylim(0.0, top * (1.3 if any_hatched or value_labels else 1.08) if top > 0 else 1.0)
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


def _legend_rows(fig: Figure, groups: list[list[Any]], max_cols: int = 6) -> int:
    """One figure legend below the axes, each non-empty group of handles starting a new row; returns its rows.

    As many columns (at most ``max_cols``) as fit the figure's width, estimated from the
    longest label of each column.  Matplotlib fills legend columns top to bottom, so the
    handles are laid out row-major and padded with invisible entries to get that.
    """
    groups = [g for g in groups if g]
    if not groups:
        return 0

    def layout(ncols: int) -> list[list[Any]]:
        rows: list[list[Any]] = []
        for group in groups:
            for start in range(0, len(group), ncols):
                row = group[start : start + ncols]
                rows.append(row + [Line2D([], [], ls="", label=" ")] * (ncols - len(row)))
        return rows

    def width_in(rows: list[list[Any]]) -> float:
        chars = [
            max(len(line) for r in rows for line in str(r[c].get_label()).split("\n"))
            for c in range(len(rows[0]))
        ]
        return _LEGEND_PAD_IN + sum(_LEGEND_ENTRY_IN + _LEGEND_CHAR_IN * n for n in chars)

    ncols = min(max(len(g) for g in groups), max_cols)
    while ncols > 1 and width_in(layout(ncols)) > fig.get_figwidth() - 0.2:
        ncols -= 1
    rows = layout(ncols)
    column_major = [rows[r][c] for c in range(ncols) for r in range(len(rows))]
    fig.legend(handles=column_major, loc="outside lower center", ncols=ncols, fontsize="small")
    return len(rows)
