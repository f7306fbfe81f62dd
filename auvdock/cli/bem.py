"""``auvdock dock-table``: the heave hydrodynamics table of a WEC dock's buoy, by capytaine."""

from __future__ import annotations

import math
import shlex
import time
from pathlib import Path

import typer

from auvdock.cli.app import app, console, err_console, fail_input


def _num(x: float) -> str:
    """A number as typed back: short (``1``, ``0.2``, ``inf``) when that reads back the same."""
    short = f"{x:g}"
    return short if float(short) == x else repr(float(x))


def _quote(arg: str) -> str:
    """``arg`` as a POSIX shell word: as it is, in single quotes, or (holding a single quote and
    nothing a shell expands in double quotes) in double quotes."""
    quoted = shlex.quote(arg)
    if "'" in arg and not any(c in arg for c in '"$`\\!'):
        return f'"{arg}"'
    return quoted


def _say(line: str) -> None:
    err_console.print(line, markup=False, highlight=False, soft_wrap=True)


def _check_output(out: Path) -> None:
    if out.is_dir():
        fail_input(f"--out {out}: is a directory (give a file name, e.g. {out / 'buoy.csv'})")
    folder = out.parent
    if not folder.is_dir():
        fail_input(f"--out {out}: the folder {folder} does not exist")


@app.command("dock-table")
def dock_table(
    radius: float = typer.Option(..., "--radius", help="Radius of the buoy (a vertical cylinder), m."),
    draft: float = typer.Option(..., "--draft", help="Draft of the buoy, m."),
    mass: float | None = typer.Option(
        None, "--mass", help="Mass of the buoy, kg (default: the displaced mass, free floating)."
    ),
    depth: float = typer.Option(math.inf, "--depth", help="Water depth, m, or inf for deep water."),
    omega_min: float = typer.Option(0.2, "--omega-min", help="Lowest wave frequency, rad/s."),
    omega_max: float = typer.Option(6.0, "--omega-max", help="Highest wave frequency, rad/s."),
    n: int = typer.Option(40, "--n", help="Frequencies evenly spaced from --omega-min to --omega-max."),
    refine: int = typer.Option(
        0, "--refine", help="More frequencies within 25 % of the natural frequency found from the first --n."
    ),
    name: str | None = typer.Option(None, "--name", help="The table's name (default: the output file stem)."),
    panel: float | None = typer.Option(
        None,
        "--panel",
        help="Largest panel radius of the mesh, m (default: min(radius, draft) / 10, at most 1/16 of the "
        "shortest wavelength).",
    ),
    rho: float = typer.Option(1025.0, "--rho", help="Water density, kg/m^3."),
    note: str = typer.Option("", "--note", help="A line of text kept in the table's header."),
    out: Path = typer.Option(..., "--out", "-o", help="The table file to write (CSV)."),
) -> None:
    """Compute the linear heave hydrodynamics of a vertical-cylinder buoy with capytaine (added
    mass, radiation damping, wave excitation per frequency; hydrostatic stiffness) and write them
    as a heave table (needs the optional extra: pip install "auvdock[bem]")."""
    for option, value in (("--radius", radius), ("--draft", draft), ("--rho", rho)):
        if not (math.isfinite(value) and value > 0):
            fail_input(f"{option}: must be positive (got {value:g})")
    if mass is not None and not (math.isfinite(mass) and mass > 0):
        fail_input(f"--mass: must be positive (got {mass:g})")
    if math.isnan(depth) or not depth > draft:
        fail_input(f"--depth: must be deeper than the draft {draft:g} m, or inf (got {depth:g})")
    if not (math.isfinite(omega_min) and omega_min > 0):
        fail_input(f"--omega-min: must be positive (got {omega_min:g})")
    if not (math.isfinite(omega_max) and omega_max > omega_min):
        fail_input(f"--omega-max: must be above --omega-min {omega_min:g} (got {omega_max:g})")
    if n < 2:
        fail_input(f"--n: must be at least 2 (got {n})")
    if refine < 0:
        fail_input(f"--refine: must be at least 0 (got {refine})")
    if panel is not None and not (math.isfinite(panel) and panel > 0):
        fail_input(f"--panel: must be positive (got {panel:g})")
    _check_output(out)
    if "\n" in note or "\r" in note:
        fail_input("--note: must be one line")
    table_name = name or out.stem

    from auvdock.world.bem import BemUnavailableError, _capytaine, compute_heave_table, default_omegas
    from auvdock.world.wec_table import save_heave_table

    try:
        cpt = _capytaine()
    except BemUnavailableError as e:
        fail_input(f"dock-table: {e}")
    args = ["auvdock", "dock-table", "--radius", _num(radius), "--draft", _num(draft)]
    if mass is not None:
        args += ["--mass", _num(mass)]
    args += ["--depth", _num(depth), "--omega-min", _num(omega_min), "--omega-max", _num(omega_max)]
    args += ["--n", str(n)]
    if refine:
        args += ["--refine", str(refine)]
    args += ["--name", table_name]
    if panel is not None:
        args += ["--panel", _num(panel)]
    if rho != 1025.0:
        args += ["--rho", _num(rho)]
    if note:
        args += ["--note", note]
    args += ["-o", str(out)]
    command = " ".join(_quote(a) for a in args)

    _say(
        f"dock-table: capytaine {cpt.__version__}, {n + refine} frequencies, a second or two each; the first "
        "run of a capytaine version also tabulates its Green function (about 30 s, then kept in capytaine's "
        "cache folder)"
    )
    t0 = time.monotonic()
    try:
        table = compute_heave_table(
            radius, draft, mass_kg=mass, water_depth_m=depth, omegas=default_omegas(omega_min, omega_max, n),
            rho_kg_m3=rho, name=table_name, faces_max_radius_m=panel, refine=refine, command=command,
            note=note, progress=_say,
        )  # fmt: skip
    except ValueError as e:
        fail_input(str(e))
    try:
        save_heave_table(table, out)
    except OSError as e:
        fail_input(f"--out {out}: cannot write ({e.strerror or e})")
    elapsed = time.monotonic() - t0

    t_n = table.natural_period_s()
    raos = []
    for period in (t_n, 6.0, 10.0):
        w = 2.0 * math.pi / period
        if w <= table.max_omega:
            label = f"{period:.2f} s (resonance, undamped)" if period == t_n else f"{period:g} s"
            raos.append(f"{abs(complex(table.rao(w))):.2f} at {label}")
    a33 = table.added_mass_kg
    console.print(
        f"wrote {out} in {elapsed:.0f} s: {table.omega_rad_s.size} frequencies {table.min_omega:.3g} to "
        f"{table.max_omega:.3g} rad/s; K33 {table.hydrostatic_stiffness_N_m / 1e3:.2f} kN/m; mass "
        f"{table.mass / 1e3:.3f} t; A33 {a33.min() / 1e3:.3f} to {a33.max() / 1e3:.3f} t; natural period "
        f"{t_n:.3f} s; |RAO| " + ", ".join(raos),
        markup=False,
        highlight=False,
        soft_wrap=True,
    )
