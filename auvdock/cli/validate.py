"""``auvdock validate`` and ``auvdock missions``: check a mission; list the shipped ones."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.padding import Padding
from rich.table import Table
from rich.text import Text

from auvdock.cli.app import app, console, load_or_exit
from auvdock.config.mission import Mission
from auvdock.world.dock import HeaveDock


def _flatten(prefix: str, value: Any, rows: list[tuple[str, str]]) -> None:
    if isinstance(value, dict):
        if not value:
            rows.append((prefix, "{}"))
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, rows)
    else:
        rows.append((prefix, str(value)))


def _describe(field_path: str) -> str:
    """The schema description of a dotted field, if any."""
    model: Any = Mission
    info = None
    for part in field_path.split("."):
        fields = getattr(model, "model_fields", None)
        if not fields or part not in fields:
            return ""
        info = fields[part]
        model = info.annotation
    return (info.description or "") if info is not None else ""


@app.command()
def validate(
    mission: Path = typer.Argument(..., help="Mission YAML file or shipped mission name (e.g. gyre)."),
) -> None:
    """Check a mission file and print it with every default filled in."""
    m = load_or_exit(mission)
    rows: list[tuple[str, str]] = []
    _flatten("", m.resolved(), rows)
    # one "field = value" line each (never cut, whatever the terminal's width), its meaning below;
    # Text, not markup: descriptions say things like "[eta; nu_r]"
    console.print(Text(f"mission {m.name} ({mission})", style="bold"))
    for k, v in rows:
        line = Text()
        line.append(k, style="cyan")
        line.append(" = ")
        line.append(v)
        console.print(line, soft_wrap=True)
        meaning = _describe(k)
        if meaning:
            console.print(Padding(Text(meaning, style="dim"), (0, 0, 0, 4), expand=False))
    flow = m.build_flow()
    sea = m.build_sea()
    dock = m.build_dock(sea)
    console.print(f"flow: {flow.describe()}", markup=False, highlight=False)
    if sea is None:
        console.print("sea: no waves")
    else:
        console.print(f"sea: {sea.describe()}", markup=False, highlight=False, soft_wrap=True)
        w = sea.omega_rad_s
        console.print(
            f"     periods {2 * np.pi / w.max():.3g}-{2 * np.pi / w.min():.3g} s, wavelengths "
            f"{sea.wavelength_m.min():.3g}-{sea.wavelength_m.max():.3g} m",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    if isinstance(dock, HeaveDock):
        console.print(
            f"dock: at {tuple(round(c, 3) for c in dock.position_ned_m)} m NED, heave "
            f"{dock.amplitude_m:g} m at {dock.angular_frequency_rad_s:g} rad/s ({dock.frequency_hz:.4g} Hz)"
        )
    else:
        console.print(f"dock: {dock.describe()}", markup=False, highlight=False, soft_wrap=True)
    contact = m.build_contact(dock)
    if contact is None:
        console.print(f"docking: within {m.docking.tolerance_m:g} m of the docking point (criterion point)")
    else:
        body, hull, limits = contact
        lines = [
            f"dock body: entry funnel from a {body.mouth_radius_m:g} m mouth over {body.funnel_length_m:g} m "
            f"(half-angle {body.half_angle_deg:.1f} deg) into a cradle of radius {body.cradle_radius_m:g} m, "
            f"{body.cradle_depth_m:g} m deep, back plate {body.back_x_m:.3f} m ahead of the docking point, "
            f"frame {2 * body.structure_half_width_m:g} m square"
            + ("" if body.buoy is None else f"; the buoy above (radius {body.buoy.radius_m:g} m")
            + ("" if body.buoy is None else f", draft {body.buoy.draft_m:g} m)"),
            f"vehicle hull: box {hull.length_m:g} x {hull.width_m:g} x {hull.height_m:g} m",
            f"docking: captured with the nose {limits.nose_inside_depth_m:g} m inside the cradle, within "
            f"{limits.radial_offset_limit_m(body, hull):.3f} m of its axis, heading within "
            f"{limits.max_heading_error_deg:g} deg, pitch and roll within "
            f"{limits.max_pitch_roll_error_deg:g} deg, "
            f"slower than {limits.max_relative_speed_m_s:g} m/s relative to the dock; collided: any hull "
            "point inside the dock's structure (criterion capture)",
        ]
        for text in lines:
            console.print(text, markup=False, highlight=False, soft_wrap=True)
    console.print("[green]valid[/green]")


@app.command()
def missions() -> None:
    """List the missions and sweeps shipped with auvdock (usable by name from any folder)."""
    from auvdock.config.catalog import missions_dir, shipped_missions, shipped_sweeps

    for title, files in (("missions", shipped_missions()), ("sweeps", shipped_sweeps())):
        t = Table(title=f"shipped {title}", show_lines=False)
        t.add_column("name", style="cyan", no_wrap=True)
        t.add_column("what it is")
        for f in files:
            t.add_row(Text(f.name), Text(f.summary))
        console.print(t)
    console.print(f"folder: {missions_dir()}", markup=False, highlight=False)
    console.print("use a name where a file is expected, e.g. auvdock sim gyre (a file of that name wins)")
