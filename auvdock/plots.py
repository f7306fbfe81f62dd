"""Matplotlib figures of one closed-loop run, saved as PNG (usually next to its HDF5 file).

Figures are drawn on :class:`matplotlib.figure.Figure` objects with an explicit Agg
canvas: no pyplot, no global backend switch, no GUI, safe to call from worker threads.

Frames and units follow :mod:`auvdock.results`: positions NED in metres, velocities in
m/s, forces in N, time in s.  Plots of positions put east on the horizontal axis and
north on the vertical one (a map), and the 3-D view draws "down" downwards.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from auvdock.results import RunResults
from auvdock.vehicle.state import POS

__all__ = ["plot_run", "FlowFieldLike"]

_GRID_ARROWS = 17  # quiver arrows along the longer side of the top view's grid
_PATH_ARROWS = 20  # recorded-flow arrows along the path when no flow field is given
_BODY_AXES = ("body x (surge)", "body y (sway)", "body z (heave)")


class FlowFieldLike(Protocol):
    """Anything with the :meth:`auvdock.flow.FlowField.velocity` signature."""

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
) -> list[Path]:
    """Draw the standard figures of one run and save them as PNG files.

    Always written (names prefixed with ``prefix``):

    * ``trajectory_3d.png`` -- 3-D vehicle path (start and end marked) and the dock's
      recorded heave path; axes east, north, down (drawn downwards).
    * ``top_view.png`` -- north-east map of the path and the dock with the current as
      arrows: of ``flow_field`` on a grid at the run's final time if given, otherwise
      the recorded ``flow_ned_m_s`` sub-sampled along the path.
    * ``distance.png`` -- vehicle-to-dock distance vs time, with the docking tolerance
      (attribute ``tolerance_m``) as a horizontal line if recorded.
    * ``thrust.png`` -- the thruster forces (N) vs time, held over each step.

    Written when the extras exist:

    * ``flow_estimate.png`` -- extras ``flow_estimate_m_s`` and ``flow_body_true_m_s``
      (T, 3), body frame, true vs estimated, with a 2-sigma band from the diagonal of
      ``flow_covariance`` (T, 3, 3) if present.
    * ``information.png`` -- extra ``information`` (T,), log y-axis if all positive.

    Parameters
    ----------
    results : RunResults
        The run, from :func:`auvdock.results.read_run`.
    out_dir : str or Path
        Directory for the PNG files (created if missing).
    prefix : str
        Prefix of every file name, e.g. ``"case1_oracle_"``.
    flow_field : FlowFieldLike, optional
        The true flow field (e.g. :func:`auvdock.flow.flow_case` ``("case2")``) for the
        top view's arrow grid.
    dpi : int
        Resolution of the PNG files.

    Returns
    -------
    list of Path
        The written files, in the order above.

    Raises
    ------
    ValueError
        If the run has no steps, or an extra series has the wrong shape.
    """
    n = results.n_steps
    if n == 0:
        where = f"{results.source}:{results.group}" if results.source else "the run"
        raise ValueError(f"cannot plot {where}: it has no recorded steps (0 rows)")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    figures: list[tuple[str, Figure]] = [
        ("trajectory_3d", _trajectory_3d(results)),
        ("top_view", _top_view(results, flow_field)),
        ("distance", _distance(results)),
        ("thrust", _thrust(results)),
    ]
    ex = results.extras
    if "flow_estimate_m_s" in ex and "flow_body_true_m_s" in ex:
        figures.append(("flow_estimate", _flow_estimate(results)))
    if "information" in ex:
        figures.append(("information", _information(results)))

    paths = []
    for name, fig in figures:
        path = out / f"{prefix}{name}.png"
        fig.savefig(path, dpi=dpi)
        paths.append(path)
    return paths


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


def _trajectory_3d(results: RunResults) -> Figure:
    fig = _new_figure((8.0, 6.5))
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
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_zlabel("down [m]")
    ax.invert_zaxis()
    ax.legend(loc="upper left", fontsize="small")
    ax.set_title(_title(results, "Vehicle trajectory (3-D, NED)"), fontsize="medium")
    return fig


def _top_view(results: RunResults, flow_field: FlowFieldLike | None) -> Figure:
    fig = _new_figure((8.0, 7.0))
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
        label = f"current at t = {t_end:.1f} s (flow field)"
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
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small", framealpha=0.9)
    ax.set_title(_title(results, "Top view (north-east)"), fontsize="medium")
    return fig


def _quiver(
    ax: Axes, x: np.ndarray, y: np.ndarray, u: np.ndarray, v: np.ndarray, length: float, label: str
) -> None:
    """Arrows (u, v) at (x, y), the fastest drawn ``0.9 * length`` data units long.

    The legend entry states the largest speed (the arrow length scale).
    """
    speed = np.hypot(u, v)
    vmax = float(np.nanmax(speed)) if speed.size else 0.0
    if not np.isfinite(vmax) or vmax <= 0.0:
        ax.text(0.02, 0.02, "no current", transform=ax.transAxes, fontsize="small", color="0.3")
        return
    ax.quiver(
        x, y, u, v,
        angles="xy", scale_units="xy", scale=vmax / (0.9 * length),
        color="tab:cyan", width=0.003, zorder=2, label=f"{label}, max {vmax:.2g} m/s",
    )  # fmt: skip


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
    ax.set_xlabel("time [s]")
    ax.set_ylabel("distance to dock [m]")
    ax.set_ylim(bottom=0.0)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    ax.set_title(_title(results, "Distance to dock"), fontsize="medium")
    return fig


def _thrust(results: RunResults) -> Figure:
    fig = _new_figure((9.0, 5.0))
    ax = fig.add_subplot()
    thrust = results.thrust_N
    for i in range(thrust.shape[1]):
        ax.plot(results.time_s, thrust[:, i], drawstyle="steps-post", lw=1.2, label=f"T{i + 1}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("thruster force [N]")
    ax.grid(True, alpha=0.3)
    fig.legend(loc="outside right upper", fontsize="small")
    ax.set_title(_title(results, "Thruster forces"), fontsize="medium")
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
    if sigma is not None:
        ax.plot(t, 2 * np.linalg.norm(sigma, axis=1), color="tab:orange", lw=1.0, ls="--", label="2σ (norm)")
    if np.all(err[np.isfinite(err)] > 0):
        ax.set_yscale("log")
    ax.set_ylabel("error\n[m/s]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(_title(results, "Water velocity in the body frame: true vs estimated"), fontsize="medium")
    return fig


def _information(results: RunResults) -> Figure:
    info = _extra(results, "information", ())
    fig = _new_figure((8.0, 4.5))
    ax = fig.add_subplot()
    ax.plot(results.time_s, info, color="tab:purple")
    finite = info[np.isfinite(info)]
    if finite.size and np.all(finite > 0):
        ax.set_yscale("log")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("information F")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(_title(results, "Flow information F"), fontsize="medium")
    return fig
