"""Figures of a run in a sea: the sea and the dock's motion, and the path through the dock's entry.

* ``sea.png`` (a run with waves): the realised spectrum (each component's ``a^2 / 2`` per
  rad/s, summed in frequency bins) with the dock's heave spectrum through its RAO; the sea's
  elevation at the dock and the dock's heave over the run; the orbital velocity at the vehicle.
* ``dock_entry.png`` (``docking.criterion: capture``): the vehicle's nose in the dock frame,
  seen from above (x along the docked heading, y to starboard) and from the side (x, z down),
  over the outline of the entry funnel, the cradle, the back plate and the frame, with where the
  run ended (captured, collided, timed out).

Both read only the results file: the realised sea (:func:`auvdock.results.store.read_sea`),
the recorded series and the resolved mission (for the dock's body).
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from auvdock.results.store import RunResults, read_sea

__all__ = ["sea_figures"]


def _new_figure(figsize: tuple[float, float]) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _binned_spectrum(
    omega: np.ndarray, energy: np.ndarray, n_bins: int = 40
) -> tuple[np.ndarray, np.ndarray]:
    """Bin centres (rad/s) and density (m^2 s/rad) of components' energies ``a^2 / 2`` (m^2)."""
    if omega.size == 1:
        return omega, energy
    edges = np.linspace(omega.min() * 0.98, omega.max() * 1.02, n_bins + 1)
    sums, _ = np.histogram(omega, edges, weights=energy)
    return 0.5 * (edges[1:] + edges[:-1]), sums / np.diff(edges)


def _sea_figure(results: RunResults) -> Figure | None:
    if results.source is None:
        return None
    stored = read_sea(results.source, results.group)
    if stored is None:
        return None
    arrays, attrs = stored
    a = np.asarray(arrays["amplitude_m"])
    w = np.asarray(arrays["omega_rad_s"])
    fig = _new_figure((10.0, 8.0))
    ax1, ax2, ax3 = fig.subplots(3, 1)
    hm0 = 4 * math.sqrt(0.5 * float(np.sum(a**2)))
    depth = attrs.get("water_depth_m", math.inf)
    where = "deep water" if not np.isfinite(depth) else f"{depth:g} m of water"
    fig.suptitle(f"{attrs.get('label', 'sea')} ({where}); mission {results.mission_name}")
    x, S = _binned_spectrum(w, 0.5 * a**2)
    if w.size == 1:
        ax1.stem(x, S, basefmt=" ", label=f"regular wave, a = {a[0]:.3g} m (a^2/2 in m^2)")
        ax1.set_ylabel("a^2 / 2 (m^2)")
    else:
        ax1.step(
            x, S, where="mid", color="tab:blue", label=f"realised sea, Hm0 {hm0:.3g} m, {a.size} components"
        )
        ax1.set_ylabel("S (m^2 s/rad)")
    ax1.set_xlabel("angular frequency seen at a fixed point (rad/s)")
    ax1.legend(loc="upper right", fontsize="small")
    t = np.asarray(results.time_s)
    ex = results.extras
    if "sea_elevation_at_dock_m" in ex:
        eta = np.asarray(ex["sea_elevation_at_dock_m"], dtype=float)
        ax2.plot(t, eta, color="tab:blue", label="sea elevation at the dock (m, up)")
    dz = np.asarray(results.dock_position_m, dtype=float)[:, 2]
    ok = np.isfinite(dz)
    if ok.any():
        ax2.plot(t, -(dz - np.nanmean(dz)), color="k", lw=1.2, label="dock heave about its mean (m, up)")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("m")
    ax2.legend(loc="upper right", fontsize="small")
    if "wave_velocity_ned_m_s" in ex:
        v = np.asarray(ex["wave_velocity_ned_m_s"], dtype=float)
        for i, name in enumerate(("north", "east", "down")):
            ax3.plot(t, v[:, i], lw=1.0, label=f"orbital velocity at the vehicle, {name}")
    ax3.set_xlabel("time (s)")
    ax3.set_ylabel("m/s")
    ax3.legend(loc="upper right", fontsize="small")
    return fig


def _dock_entry_figure(results: RunResults) -> Figure | None:
    ex = results.extras
    if "nose_dock_m" not in ex or not results.mission_yaml:
        return None
    from auvdock.config.mission import parse_mission
    from auvdock.schema.yamlio import load_yaml_strict

    try:
        m = parse_mission(load_yaml_strict(results.mission_yaml), "<results>")
        contact = m.build_contact()
    except Exception:  # a results file written by another version: no geometry to draw
        return None
    if contact is None:
        return None
    body, _, _ = contact
    nose = np.asarray(ex["nose_dock_m"], dtype=float)
    fig = _new_figure((10.0, 7.5))
    top, side = fig.subplots(2, 1, sharex=True)
    fig.suptitle(f"the nose's path through the dock's entry; mission {results.mission_name}")
    x_mouth, x_cradle, x_back = body.mouth_x_m, body.cradle_entrance_x_m, body.back_x_m
    xs = np.array([x_mouth, x_cradle, x_back])
    rs = np.array([body.mouth_radius_m, body.cradle_radius_m, body.cradle_radius_m])
    W = body.structure_half_width_m
    x_end = body.back_end_x_m
    ok = np.all(np.isfinite(nose), axis=1)
    # one vertical span for both panels (their boxes then line up under the shared x axis)
    span = max(W, float(np.nanmax(np.abs(nose[ok, 1:3]))) if ok.any() else W) + 0.2
    for ax, j, lab in ((top, 1, "y_d, starboard (m)"), (side, 2, "z_d, down (m)")):
        ax.fill_between([x_mouth, x_end], [-W, -W], [W, W], color="0.85", label="frame (solid)")
        ax.fill_between(xs, -rs, rs, color="white")
        ax.plot(xs, rs, color="k", lw=1.5)
        ax.plot(xs, -rs, color="k", lw=1.5, label="funnel and cradle walls")
        ax.fill_between([x_back, x_end], [-W, -W], [W, W], color="0.45", label="back plate")
        ax.plot(nose[ok, 0], nose[ok, j], color="tab:blue", lw=1.5, label="vehicle nose")
        if ok.any():
            last = nose[np.flatnonzero(ok)[-1]]
            captured = results.attrs.get("captured") is True
            collided = results.attrs.get("collided") is True
            marker, colour, text = (
                ("*", "gold", "captured")
                if captured
                else ("X", "tab:red", "collided")
                if collided
                else ("o", "0.3", "end")
            )
            ax.scatter(
                [last[0]], [last[j]], marker=marker, s=140, color=colour, edgecolors="k", zorder=5, label=text
            )
        ax.set_ylabel(lab)
        lo = min(float(np.nanmin(nose[ok, 0])) if ok.any() else x_mouth, x_mouth) - 0.3
        ax.set_xlim(lo, x_end + 0.2)
        ax.set_ylim(-span, span)
        # equal scale with both limits kept: the panels shrink to fit (not the shared x limits
        # moved, which matplotlib warned about on every figure), to the same box as the spans agree
        ax.set_aspect("equal", adjustable="box")
    side.invert_yaxis()
    side.set_xlabel("x_d along the docked heading (m)")
    top.legend(loc="upper left", fontsize="small", bbox_to_anchor=(1.01, 1.0))
    return fig


def sea_figures(results: RunResults) -> list[tuple[str, Figure]]:
    """The figures of a run in a sea that it has data for: ``("sea", fig)`` and ``("dock_entry", fig)``."""
    out: list[tuple[str, Figure]] = []
    for name, build in (("sea", _sea_figure), ("dock_entry", _dock_entry_figure)):
        fig = build(results)
        if fig is not None:
            out.append((name, fig))
    return out
