"""Matplotlib figures of one closed-loop run, saved as PNG (usually next to its HDF5 file).

Figures are drawn on :class:`matplotlib.figure.Figure` objects with an explicit Agg
canvas: no pyplot, no global backend switch, no GUI, safe to call from worker threads.

Frames and units follow :mod:`auvdock.results.store`: positions NED in metres, velocities in
m/s, forces in N, time in s.  Plots of positions put east on the horizontal axis and
north on the vertical one (a map), and the 3-D view draws "down" downwards.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.quiver import Quiver
from matplotlib.ticker import MaxNLocator

from auvdock.results.store import RunResults
from auvdock.vehicle.state import POS

__all__ = ["plot_run", "save_run_plots", "run_figures", "thrust_limits_of", "FlowFieldLike"]

_GRID_ARROWS = 17  # quiver arrows along the longer side of the top view's grid
_PATH_ARROWS = 20  # recorded-flow arrows along the path when no flow field is given
_BODY_AXES = ("body x (surge)", "body y (sway)", "body z (heave)")

# 3-D view: every axis is shown over at least this span (m), and at least this fraction of
# the largest data span, so a degenerate axis (a 2-D path: east spans 1e-17 m) is drawn as a
# short stretch of empty space at the common scale, not blown up to fill the box.
_MIN_SPAN_M = 0.2
_MIN_SPAN_FRACTION = 0.25
_SPAN_MARGIN = 0.05  # margin on each side of every 3-D axis, fraction of the largest span

# Top view: the reference arrow of the quiver key is a "nice" speed (1, 2 or 5 x 10^k m/s),
# the smallest not below the strongest current; it is drawn this fraction of a grid step long.
_KEY_FRACTION = 0.9

# Thrust plot: series equal within this (N) are drawn as one line labelled "T1 = T2".
_SAME_THRUST_N = 1e-6
_THRUST_STYLES: tuple[Any, ...] = ("-", "--", "-.", ":", (0, (5, 1)), (0, (3, 1, 1, 1, 1, 1)), (0, (1, 3)))


class FlowFieldLike(Protocol):
    """Anything with the :meth:`auvdock.world.flow.FlowField.velocity` signature."""

    def velocity(self, p_ned: np.ndarray, t: float) -> np.ndarray:
        """Water velocity (north, east, down) in m/s, shape (..., 3), at NED positions (..., 3) m."""
        ...


def plot_run(
    results: RunResults,
    out_dir: str | Path,
    *,
    prefix: str = "",
    flow_field: FlowFieldLike | None = None,
    dpi: int = 120,
    thrust_limits: tuple[np.ndarray, np.ndarray] | None = None,
) -> list[Path]:
    """Draw the standard figures of one run and save them as PNG files.

    Always written (names prefixed with ``prefix``):

    * ``trajectory_3d.png`` -- 3-D vehicle path (start and end marked) and the dock's
      recorded heave path; axes east, north, down (drawn downwards), all three at the same
      scale (box aspect proportional to the axis spans; an axis the path barely moves
      along is shown over at least 0.2 m and a quarter of the largest span).
    * ``top_view.png`` -- north-east map of the path and the dock with the current as
      arrows proportional to its speed, with a quiver key (reference arrow and its m/s):
      of ``flow_field`` on a grid at the run's final time if given, otherwise the
      recorded ``flow_ned_m_s`` sub-sampled along the path.  Legend outside the map.
    * ``distance.png`` -- vehicle-to-dock distance vs time, with the docking tolerance
      (attribute ``tolerance_m``) as a horizontal line if recorded.
    * ``thrust.png`` -- the thruster forces (N) vs time, held over each step; thrusters
      with identical series share one line (labelled e.g. ``T1 = T2``), lines differ in
      colour and style, and the thrust limits are drawn as horizontal lines (from
      ``thrust_limits``, else :func:`thrust_limits_of`).

    Written when the extras exist:

    * ``flow_estimate.png`` -- extras ``flow_estimate_m_s`` and ``flow_body_true_m_s``
      (T, 3), body frame, true vs estimated, with a 2-sigma band from the diagonal of
      ``flow_covariance`` (T, 3, 3) if present; the error panel is on a log axis scaled to the
      settled error (the prior's 2-sigma spike above it, rounding-level errors and exact zeros
      below it, off the axis and counted in a note).
    * ``information.png`` -- extra ``information`` (T,): the flow filter's information metric
      F = lambda_min(G) (paper eq. 8; s^2/m^2, defined in a caption), log y-axis if all positive.

    Parameters
    ----------
    results : RunResults
        The run, from :func:`auvdock.results.store.read_run`.
    out_dir : str or Path
        Directory for the PNG files (created if missing).
    prefix : str
        Prefix of every file name, e.g. ``"case1_oracle_"``.
    flow_field : FlowFieldLike, optional
        The true flow field (e.g. :func:`auvdock.world.flow.flow_case` ``("case2")``) for the
        top view's arrow grid.
    dpi : int
        Resolution of the PNG files.
    thrust_limits : (ndarray, ndarray), optional
        Per-thruster reverse (negative) and forward limits, N, each (n,), for the thrust
        plot; default: :func:`thrust_limits_of` ``(results)``.

    Returns
    -------
    list of Path
        The written files, in the order above.

    Raises
    ------
    ValueError
        If the run has no steps, or an extra series has the wrong shape.
    """
    return list(
        save_run_plots(
            results, out_dir, prefix=prefix, flow_field=flow_field, dpi=dpi, thrust_limits=thrust_limits
        )
    )


def save_run_plots(
    results: RunResults,
    out_dir: str | Path,
    *,
    prefix: str = "",
    flow_field: FlowFieldLike | None = None,
    dpi: int = 120,
    thrust_limits: tuple[np.ndarray, np.ndarray] | None = None,
) -> Iterator[Path]:
    """:func:`plot_run`, one file at a time: yields each PNG's path once it is complete on disk.

    Each file is written beside its name and then renamed onto it, so an interruption (Ctrl-C)
    leaves every file either whole or not there (an earlier file of that name untouched), and the
    caller knows which were written: the ones yielded.  Parameters and errors as :func:`plot_run`.
    """
    figures = run_figures(results, flow_field=flow_field, thrust_limits=thrust_limits)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for name, fig in figures:
        path = out / f"{prefix}{name}.png"
        part = path.with_name(f".{path.name}.part")
        try:
            fig.savefig(part, dpi=dpi, format="png")
            os.replace(part, path)
        finally:
            part.unlink(missing_ok=True)
        yield path


def run_figures(
    results: RunResults,
    *,
    flow_field: FlowFieldLike | None = None,
    thrust_limits: tuple[np.ndarray, np.ndarray] | None = None,
) -> list[tuple[str, Figure]]:
    """The figures :func:`plot_run` saves, built but not saved: ``(name, Figure)`` in file order.

    ``name`` is the file name without prefix and ``.png`` (``"trajectory_3d"``, ``"top_view"``,
    ``"distance"``, ``"thrust"``, then ``"flow_estimate"`` and ``"information"`` if the run
    has those extras, then ``"sea"`` and ``"dock_entry"`` for a run in a sea and one judged on
    capture: :mod:`auvdock.results.sea_plots`).  Parameters and errors as :func:`plot_run`.
    """
    if results.n_steps == 0:
        where = f"{results.source}:{results.group}" if results.source else "the run"
        raise ValueError(f"cannot plot {where}: it has no recorded steps (0 rows)")
    figures: list[tuple[str, Figure]] = [
        ("trajectory_3d", _trajectory_3d(results)),
        ("top_view", _top_view(results, flow_field)),
        ("distance", _distance(results)),
        ("thrust", _thrust(results, thrust_limits)),
    ]
    ex = results.extras
    if "flow_estimate_m_s" in ex and "flow_body_true_m_s" in ex:
        figures.append(("flow_estimate", _flow_estimate(results)))
    if "information" in ex:
        figures.append(("information", _information(results)))
    from auvdock.results.sea_plots import sea_figures

    figures.extend(sea_figures(results))
    return figures


def thrust_limits_of(results: RunResults) -> tuple[np.ndarray, np.ndarray] | None:
    """The vehicle's per-thruster thrust limits (reverse, forward), N, each (n,), or None if unknown.

    From the run attributes ``thrust_min_N`` and ``thrust_max_N`` if recorded, otherwise
    from the vehicle of the mission stored with the run (``mission_yaml``: preset or
    parameter file, overrides, battery voltage).  None when neither gives ``n`` limits
    for the ``n`` recorded thrusters (e.g. a relative vehicle file that is not found).
    """
    n = results.thrust_N.shape[1]
    lo, hi = results.attrs.get("thrust_min_N"), results.attrs.get("thrust_max_N")
    if lo is None or hi is None:
        try:
            import yaml

            from auvdock.config.mission import parse_mission
            from auvdock.vehicle.params import load_params

            spec = parse_mission(yaml.safe_load(results.mission_yaml), "mission_yaml").vehicle
            target = spec.file if spec.file is not None else (spec.preset or "bluerov2_heavy")
            limits = load_params(target, spec.overrides or None, spec.thruster_voltage_V).thrust_limits_N
            lo, hi = limits[:, 0], limits[:, 1]
        except Exception:  # no stored mission, an unreadable vehicle file...: no limits to draw
            return None
    try:
        lo_n = np.broadcast_to(np.asarray(lo, dtype=float), (n,)).copy()
        hi_n = np.broadcast_to(np.asarray(hi, dtype=float), (n,)).copy()
    except ValueError:  # limits of another vehicle (another thruster count)
        return None
    return lo_n, hi_n


# ----------------------------------------------------------------------------- helpers


def _new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _title(results: RunResults, what: str) -> str:
    mission = results.mission_name or "unnamed mission"
    controller = results.controller or "unknown controller"
    return f"{what}\nmission: {mission}   controller: {controller}   ({_outcome_text(results)})"


def _outcome_text(results: RunResults) -> str:
    if not results.complete:
        return f"incomplete run, {results.n_steps} steps"
    docked = results.attrs.get("docked")
    t_dock = _finite_attr(results, "time_to_dock_s")
    if docked is True:
        return f"docked at t = {t_dock:.1f} s" if t_dock is not None else "docked"
    if docked is False:
        reason = results.attrs.get("reason") or ""
        return f"not docked: {reason}" if reason else "not docked"
    return "complete"


def _finite_attr(results: RunResults, key: str) -> float | None:
    value = results.attrs.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def _finite_rows(a: np.ndarray) -> np.ndarray:
    """Indices of the rows of ``a`` (T, k) with all entries finite."""
    return np.flatnonzero(np.all(np.isfinite(a), axis=1))


def _extra(results: RunResults, name: str, shape: tuple[int, ...]) -> np.ndarray:
    a = np.asarray(results.extras[name], dtype=float)
    want = (results.n_steps, *shape)
    if a.shape != want:
        raise ValueError(f"extra series {name!r}: expected shape {want}, got {a.shape}")
    return a


def _mark_ends(ax: Axes, *coords: np.ndarray, three_d: bool = False) -> None:
    """Mark the first and last finite points of a path given as coordinate arrays."""
    pts = np.stack(coords, axis=1)
    ok = _finite_rows(pts)
    if ok.size == 0:
        return
    start, end = pts[ok[0]], pts[ok[-1]]
    kw: dict[str, Any] = {"s": 60, "zorder": 5, "edgecolors": "k"}
    if three_d:
        kw.pop("zorder")
    ax.scatter(*[[v] for v in start], marker="o", color="tab:green", label="start", **kw)
    ax.scatter(*[[v] for v in end], marker="X", color="tab:red", label="end", **kw)


# ----------------------------------------------------------------------------- figures


def _equal_limits(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axis limits (lo, hi), each (3,), around the finite ``points`` (k, 3), for one common scale.

    Each axis spans its data plus a margin; an axis whose data span is smaller than
    ``_MIN_SPAN_M`` or ``_MIN_SPAN_FRACTION`` of the largest span is widened (about its
    centre) to that, so rounding noise on a degenerate axis stays invisible.
    """
    pts = points[_finite_rows(points)] if points.size else points
    if pts.shape[0] == 0:
        return np.full(3, -0.5), np.full(3, 0.5)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre, span = (lo + hi) / 2.0, hi - lo
    largest = max(float(span.max()), _MIN_SPAN_M)
    span = np.maximum(span, max(_MIN_SPAN_FRACTION * largest, _MIN_SPAN_M)) + 2.0 * _SPAN_MARGIN * largest
    return centre - span / 2.0, centre + span / 2.0


def _trajectory_3d(results: RunResults) -> Figure:
    fig = _new_figure((9.0, 6.5))
    ax = fig.add_subplot(projection="3d")
    north, east, down = results.state[:, POS].T
    ax.plot(east, north, down, color="tab:blue", lw=1.5, label="vehicle")
    _mark_ends(ax, east, north, down, three_d=True)
    dock = results.dock_position_m
    ax.plot(
        dock[:, 1], dock[:, 0], dock[:, 2], color="k", lw=4, solid_capstyle="butt", label="dock heave path"
    )
    ok = _finite_rows(dock)
    if ok.size:
        d = dock[ok[-1]]
        ax.scatter(
            [d[1]], [d[0]], [d[2]], marker="*", s=160, color="gold", edgecolors="k", label="dock (final)"
        )
    # one scale on all three axes: equal-scale limits and a box whose sides are the axis spans
    enu = np.concatenate([results.state[:, POS], dock])[:, [1, 0, 2]]  # (east, north, down)
    lo, hi = _equal_limits(enu)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.invert_zaxis()
    ax.set_box_aspect(tuple(hi - lo))
    for axis, span in zip((ax.xaxis, ax.yaxis, ax.zaxis), hi - lo, strict=True):
        # about one tick per sixth of the largest span: short axes do not crowd their labels
        axis.set_major_locator(MaxNLocator(nbins=max(2, round(6 * span / float(np.max(hi - lo))))))
    ax.set_xlabel("east [m]", labelpad=8)
    ax.set_ylabel("north [m]", labelpad=12)
    ax.set_zlabel("down [m]", labelpad=8)
    fig.legend(loc="outside right upper", fontsize="small")
    ax.set_title(_title(results, "Vehicle trajectory (3-D, NED, equal scale on all axes)"), fontsize="medium")
    return fig


def _nice_speed(v: float) -> float:
    """The smallest of 1, 2, 5 x 10^k (m/s) not below ``v`` > 0."""
    exp = math.floor(math.log10(v))
    for m in (1.0, 2.0, 5.0, 10.0):
        ref = m * 10.0**exp
        if ref >= v * (1.0 - 1e-9):
            return ref
    return 10.0 ** (exp + 1)


def _top_view(results: RunResults, flow_field: FlowFieldLike | None) -> Figure:
    fig = _new_figure((9.5, 7.0))
    ax = fig.add_subplot()
    pos = results.state[:, POS]
    dock = results.dock_position_m
    pts = np.concatenate([pos[_finite_rows(pos)], dock[_finite_rows(dock)]])

    if flow_field is not None and pts.size:
        lo, hi = pts[:, :2].min(axis=0), pts[:, :2].max(axis=0)  # (north, east)
        margin = max(0.1 * float(np.max(hi - lo)), 1.0)
        lo, hi = lo - margin, hi + margin
        span = hi - lo
        step = float(np.max(span)) / (_GRID_ARROWS - 1)
        n_north = max(int(round(span[0] / step)) + 1, 3)
        n_east = max(int(round(span[1] / step)) + 1, 3)
        nn, ee = np.meshgrid(
            np.linspace(lo[0], hi[0], n_north), np.linspace(lo[1], hi[1], n_east), indexing="ij"
        )
        depth = float(np.mean(pts[:, 2]))
        grid = np.stack([nn, ee, np.full_like(nn, depth)], axis=-1)
        t_end = float(results.time_s[-1])
        v = np.asarray(flow_field.velocity(grid, t_end), dtype=float)
        label = f"current (flow field at t = {t_end:.1f} s)"
        _quiver(ax, ee, nn, v[..., 1], v[..., 0], step, label)
    else:
        idx = np.unique(np.linspace(0, results.n_steps - 1, min(results.n_steps, _PATH_ARROWS)).astype(int))
        p, v = pos[idx], results.flow_ned_m_s[idx]
        keep = np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(v), axis=1)
        p, v = p[keep], v[keep]
        extent = float(np.max(np.ptp(pts[:, :2], axis=0))) if pts.size else 1.0
        _quiver(
            ax, p[:, 1], p[:, 0], v[:, 1], v[:, 0], max(extent, 1.0) / 15.0, "recorded current at vehicle"
        )

    ax.plot(pos[:, 1], pos[:, 0], color="tab:blue", lw=1.5, label="vehicle", zorder=3)
    _mark_ends(ax, pos[:, 1], pos[:, 0])
    ok = _finite_rows(dock)
    if ok.size:
        d = dock[ok[-1]]
        ax.scatter([d[1]], [d[0]], marker="*", s=250, color="gold", edgecolors="k", zorder=4, label="dock")
    believed = _believed_dock(results)
    if believed is not None:
        ax.plot(
            believed[:, 1], believed[:, 0], color="darkorange", ls="--", lw=1.2, zorder=3,
            label="dock where the vehicle believed it",
        )  # fmt: skip
        ax.scatter(
            [believed[-1, 1]], [believed[-1, 0]], marker="*", s=250, facecolors="none",
            edgecolors="darkorange", linewidths=1.5, zorder=4, label="believed dock (final)",
        )  # fmt: skip
    seen = _new_fix_rows(results)
    if seen is not None and seen.any():
        ax.scatter(
            pos[seen, 1],
            pos[seen, 0],
            s=10,
            color="tab:green",
            zorder=4,
            label="where the camera saw the dock",
        )
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    # outside the map, so it covers no arrow or path
    fig.legend(loc="outside right upper", fontsize="small", framealpha=0.9)
    ax.set_title(_title(results, "Top view (north-east)"), fontsize="medium")
    return fig


def _quiver(
    ax: Axes, x: np.ndarray, y: np.ndarray, u: np.ndarray, v: np.ndarray, length: float, label: str
) -> Quiver | None:
    """Arrows (u, v) m/s at (x, y) m, their lengths proportional to the speed, with a quiver key.

    The key's reference speed is the "nice" speed (:func:`_nice_speed`) at or above the
    fastest arrow; its arrow is ``_KEY_FRACTION * length`` data units long, and every arrow
    is ``speed / reference`` times that.  The key sits just right of the map, below the
    legend.  Returns the quiver, or None (and a "no current" note) if there is no current.
    """
    speed = np.hypot(u, v)
    vmax = float(np.nanmax(speed)) if speed.size else 0.0
    if not np.isfinite(vmax) or vmax <= 0.0:
        ax.text(0.02, 0.02, "no current", transform=ax.transAxes, fontsize="small", color="0.3")
        return None
    ref = _nice_speed(vmax)
    q = ax.quiver(
        x, y, u, v,
        angles="xy", scale_units="xy", scale=ref / (_KEY_FRACTION * length),
        color="tab:cyan", width=0.003, zorder=2, label=label,
    )  # fmt: skip
    # the key right of the map's lower corner (the arrow, at most 1/16 of the map wide, is centred
    # on X): the reference arrow, its speed, the largest speed
    ax.quiverkey(
        q, 1.08, 0.03, ref, f"{ref:g} m/s", labelpos="N", coordinates="axes", color="tab:cyan",
        fontproperties={"size": "small"},
    )  # fmt: skip
    ax.text(
        1.03, 0.09, f"current, to scale\n(max here {vmax:.2g} m/s)", transform=ax.transAxes,
        fontsize="small", ha="left", va="bottom", color="0.25",
    )  # fmt: skip
    return q


def _distance(results: RunResults) -> Figure:
    fig = _new_figure((8.0, 4.5))
    ax = fig.add_subplot()
    ax.plot(results.time_s, results.distance_m, color="tab:blue", label="distance to dock")
    tol = _finite_attr(results, "tolerance_m")
    if tol is not None:
        ax.axhline(tol, color="tab:red", ls="--", label=f"docking tolerance {tol:g} m")
    t_dock = _finite_attr(results, "time_to_dock_s")
    if t_dock is not None:
        ax.axvline(t_dock, color="tab:green", ls=":", label=f"docked at {t_dock:.1f} s")
    believed = _believed_distance(results)
    if believed is not None:
        ax.plot(
            results.time_s,
            believed,
            color="darkorange",
            ls="--",
            lw=1.0,
            label="distance as the vehicle believed it",
        )
    seen = _new_fix_rows(results)
    if seen is not None and seen.any():
        t = results.time_s[seen]
        ax.plot(
            t, np.zeros_like(t), "|", color="tab:green", ms=12, mew=1.0, clip_on=False,
            label="camera fixes of the dock",
        )  # fmt: skip
    elif seen is not None:
        ax.text(
            0.02,
            0.04,
            "the camera never saw the dock",
            transform=ax.transAxes,
            fontsize="small",
            color="tab:red",
        )
    ax.set_xlabel("time [s]")
    ax.set_ylabel("distance to dock [m]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(_title(results, "Distance to dock"), fontsize="medium")
    return fig


def _believed_dock(results: RunResults) -> np.ndarray | None:
    """The docking point where the navigation filter placed it (extra ``estimated_dock_position_m``,
    NED m), its finite rows (k, 3); None without it."""
    if "estimated_dock_position_m" not in results.extras:
        return None
    est = _extra(results, "estimated_dock_position_m", (3,))
    ok = _finite_rows(est)
    return est[ok] if ok.size else None


def _believed_distance(results: RunResults) -> np.ndarray | None:
    """The distance to the dock by the estimate (T,), m: the estimated position (extra
    ``estimated_state``) to the believed docking point; NaN where either is unknown."""
    ex = results.extras
    if "estimated_dock_position_m" not in ex or "estimated_state" not in ex:
        return None
    est_dock = _extra(results, "estimated_dock_position_m", (3,))
    est_pos = np.asarray(ex["estimated_state"], dtype=float)[:, POS]
    if est_pos.shape != est_dock.shape:
        return None
    d = np.linalg.norm(est_pos - est_dock, axis=1)
    return d if np.isfinite(d).any() else None


def _new_fix_rows(results: RunResults) -> np.ndarray | None:
    """Rows (T,) bool at which a new camera fix of the dock had arrived (the extra ``dock_fix_age_s``
    fell, or became known); None for a run without the dock camera's guidance (no losses counted)."""
    if "dock_fix_age_s" not in results.extras or "lost_track_events" not in results.attrs:
        return None
    age = _extra(results, "dock_fix_age_s", ())
    before = np.concatenate([[np.nan], age[:-1]])
    newer = np.isfinite(age) & (~np.isfinite(before) | (age < before))
    return np.asarray(newer, dtype=bool)


def _same_series_groups(a: np.ndarray, atol: float) -> list[list[int]]:
    """Columns of ``a`` (T, n) grouped by equal series (within ``atol``; NaN equals NaN), in column order."""
    groups: list[list[int]] = []
    for i in range(a.shape[1]):
        for g in groups:
            first = a[:, g[0]]
            col = a[:, i]
            both_nan = np.isnan(first) & np.isnan(col)
            close = np.abs(first - col) <= atol
            if np.all(both_nan | close):
                g.append(i)
                break
        else:
            groups.append([i])
    return groups


def _thrust(results: RunResults, limits: tuple[np.ndarray, np.ndarray] | None = None) -> Figure:
    fig = _new_figure((9.5, 5.0))
    ax = fig.add_subplot()
    thrust = np.asarray(results.thrust_N, dtype=float)
    groups = _same_series_groups(thrust, _SAME_THRUST_N)
    for k, g in enumerate(groups):
        label = " = ".join(f"T{i + 1}" for i in g)
        ax.plot(
            results.time_s, thrust[:, g[0]], drawstyle="steps-post", color=f"C{k % 10}",
            ls=_THRUST_STYLES[k % len(_THRUST_STYLES)], lw=1.8 if len(groups) <= 4 else 1.4,
            label=label, gid="thrust " + label,
        )  # fmt: skip
    if limits is None:
        limits = thrust_limits_of(results)
    if limits is not None:
        for side, values, ls in (("max", limits[1], (0, (8, 3))), ("min", limits[0], (0, (3, 2)))):
            for value in np.unique(values[np.isfinite(values)]):
                which = [i for i in range(values.size) if values[i] == value]
                who = "" if len(which) == values.size else " (" + ", ".join(f"T{i + 1}" for i in which) + ")"
                text = f"thrust limit {side} {value:g} N{who}"
                ax.axhline(value, color="0.15", ls=ls, lw=1.2, label=text, gid=f"thrust_limit_{side}")
                ax.annotate(
                    f"{side} {value:g} N{who}", (0.995, value), xycoords=("axes fraction", "data"),
                    xytext=(0, 2 if side == "max" else -2), textcoords="offset points", ha="right",
                    va="bottom" if side == "max" else "top", fontsize="small", color="0.15",
                )  # fmt: skip
    else:
        ax.text(
            0.01, 0.01, "thrust limits unknown (no vehicle with the run)", transform=ax.transAxes,
            fontsize="small", color="0.3",
        )  # fmt: skip
    ax.set_xlabel("time [s]")
    ax.set_ylabel("thruster force [N]")
    ax.grid(True, alpha=0.3)
    title = "Thruster forces"
    if any(len(g) > 1 for g in groups):
        title += " (thrusters with identical forces share a line)"
    fig.legend(loc="outside right upper", fontsize="small")
    ax.set_title(_title(results, title), fontsize="medium")
    return fig


def _flow_estimate(results: RunResults) -> Figure:
    t = results.time_s
    est = _extra(results, "flow_estimate_m_s", (3,))
    true = _extra(results, "flow_body_true_m_s", (3,))
    sigma = None
    if "flow_covariance" in results.extras:
        cov = _extra(results, "flow_covariance", (3, 3))
        sigma = np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2), 0.0, None))
    fig = _new_figure((8.5, 9.5))
    axes = fig.subplots(4, 1, sharex=True)
    for i, ax in enumerate(axes[:3]):
        # limits from the curves, not the band: the prior's 2 sigma (6 m/s) would flatten them
        both = np.concatenate([true[:, i], est[:, i]])
        both = both[np.isfinite(both)]
        lo, hi = (float(both.min()), float(both.max())) if both.size else (-1.0, 1.0)
        pad = max(0.1, 0.15 * (hi - lo))
        ax.set_ylim(lo - pad, hi + pad)
        ax.plot(t, true[:, i], color="k", lw=1.5, label="true")
        ax.plot(t, est[:, i], color="tab:orange", lw=1.2, label="estimate")
        if sigma is not None:
            ax.fill_between(
                t, est[:, i] - 2 * sigma[:, i], est[:, i] + 2 * sigma[:, i],
                color="tab:orange", alpha=0.25, lw=0, label="estimate ± 2σ",
            )  # fmt: skip
        ax.set_ylabel(f"{_BODY_AXES[i]}\n[m/s]")
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="best", fontsize="small")
    err = np.linalg.norm(est - true, axis=1)
    ax = axes[3]
    ax.plot(t, err, color="tab:red", lw=1.2, label="|estimate - true|")
    band = None
    if sigma is not None:
        band = 2 * np.linalg.norm(sigma, axis=1)
        ax.plot(t, band, color="tab:orange", lw=1.0, ls="--", label="2σ (norm)")
    _scale_error_axis(ax, t, err, band)
    ax.set_ylabel("error\n[m/s]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(_title(results, "Water velocity in the body frame: true vs estimated"), fontsize="medium")
    return fig


def _scale_error_axis(ax: Axes, t: np.ndarray, err: np.ndarray, band: np.ndarray | None) -> None:
    """The estimate-error panel on a log axis whose bottom comes from the SETTLED error.

    The first samples hold the prior's 2σ (about 10 m/s) and often an error of exactly 0 (a zero
    prior in still water): on a linear axis, or a log axis stretched down to a rounding-level
    error, the error that matters (mm/s once the filter has converged) is a flat line on the
    bottom.  The bottom is half the 5th percentile of the positive error after the first
    :data:`_SETTLE_S` s (or quarter of the run); what lies below it (exact zeros included) is
    off the axis, and a note on the panel says how many samples and why.
    """
    ok = np.isfinite(err) & (err > 0)
    if not ok.any():
        return  # no error to show (all zero or unknown): matplotlib's linear default
    top = [float(err[ok].max())]
    if band is not None and np.isfinite(band).any() and np.nanmax(band) > 0:
        top.append(float(np.nanmax(band)))
    finite_t = t[np.isfinite(t)]
    t0, t1 = (float(finite_t.min()), float(finite_t.max())) if finite_t.size else (0.0, 0.0)
    settled = ok & (t >= t0 + min(_SETTLE_S, 0.25 * (t1 - t0)))
    low = 0.5 * float(np.percentile(err[settled if settled.any() else ok], 5))
    high = 2.0 * max(top)
    ax.set_yscale("log", nonpositive="mask")
    ax.set_ylim(low, max(high, 10 * low))
    below = np.isfinite(err) & (err < low)
    if below.any():
        zeros = int(np.sum(np.isfinite(err) & (err == 0)))
        ax.text(
            0.5, 0.97,
            f"{int(below.sum())} sample{'s' if below.sum() > 1 else ''} below {low:.2g} m/s off the axis"
            + (f" ({zeros} exactly 0)" if zeros else ""),
            transform=ax.transAxes, fontsize="x-small", color="0.3", ha="center", va="top",
        )  # fmt: skip


#: The error panel's bottom is set by the error after this long (s): past the prior's spike.
_SETTLE_S = 2.0

#: What the information figure's F is (auvdock.estimation.flow_filter, paper eq. 8), and its unit.
_INFORMATION_CAPTION = (
    "F = λmin(G): the smallest eigenvalue of the flow filter's information gramian G (paper eq. 8), which "
    "starts at I and each step turns with the vehicle\nand adds Hᵀ R⁻¹ H (H, R: the model and noise of the "
    "accelerometer and depth-rate readings): what the readings say about the current in its\n"
    "least-observed direction.  Unit (m/s)⁻² = s²/m²; 1/√F is the flow uncertainty (m/s) the readings leave "
    "in that direction."
)


def _information(results: RunResults) -> Figure:
    info = _extra(results, "information", ())
    fig = _new_figure((8.0, 5.0))
    ax = fig.add_subplot()
    ax.plot(results.time_s, info, color="tab:purple")
    finite = info[np.isfinite(info)]
    if finite.size and np.all(finite > 0):
        ax.set_yscale("log")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("information F = λmin(G) [s²/m²]")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(_title(results, "Flow information F"), fontsize="medium")
    fig.text(0.01, 0.005, _INFORMATION_CAPTION, fontsize="x-small", color="0.25", ha="left", va="bottom")
    engine = fig.get_layout_engine()
    if engine is not None:  # constrained layout: keep the caption's strip free
        engine.set(rect=(0, 0.09, 1, 0.91))  # type: ignore[call-arg]  # ConstrainedLayoutEngine.set takes rect
    return fig
