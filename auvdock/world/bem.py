"""Heave tables of a vertical-cylinder buoy computed by capytaine (the optional ``bem`` extra).

:func:`compute_heave_table` meshes the buoy, solves capytaine's radiation and diffraction
problems for heave and returns a :class:`~auvdock.world.wec_table.HeaveCoefficients`
(``auvdock dock-table`` writes it as a table file).  capytaine is imported inside the
function only: without it the rest of auvdock works, and the shipped tables
(``auvdock/world/data/``) need nothing but numpy.  Install it with ``pip install
"auvdock[bem]"`` (capytaine 3.0 or later, about 360 MB with its dependencies).

Conventions are capytaine's, and those of :mod:`auvdock.world.wec_table`: z up from the still
water line on the buoy's axis, complex amplitudes with ``exp(-i omega t)``, the excitation per
metre of incident-wave amplitude (wave direction 0; a vertical cylinder's heave does not
depend on it).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from auvdock.world.wec_table import HeaveCoefficients

__all__ = ["BemUnavailableError", "compute_heave_table", "default_omegas", "default_faces_max_radius",
           "MIN_CAPYTAINE"]  # fmt: skip

#: The oldest capytaine this module is written for (its 3.0 API).
MIN_CAPYTAINE = (3, 0)

#: The extra that installs capytaine.
INSTALL_HINT = 'pip install "auvdock[bem]"'


class BemUnavailableError(ImportError):
    """capytaine (3.0 or later) is not installed: the message says how to install it."""


def _capytaine() -> Any:
    """The capytaine module, or :class:`BemUnavailableError` naming the extra that installs it."""
    try:
        import capytaine as cpt
    except ImportError as e:
        raise BemUnavailableError(
            f"capytaine (3.0 or later) is needed to compute a heave table: {INSTALL_HINT}"
        ) from e
    version = tuple(int(p) for p in cpt.__version__.split(".")[:2] if p.isdigit())
    if version < MIN_CAPYTAINE:
        raise BemUnavailableError(
            f"capytaine {cpt.__version__} is installed; 3.0 or later is needed: {INSTALL_HINT}"
        )
    return cpt


def default_omegas(omega_min: float = 0.2, omega_max: float = 6.0, n: int = 40) -> np.ndarray:
    """``n`` frequencies evenly spaced from ``omega_min`` to ``omega_max``, rad/s."""
    return np.linspace(omega_min, omega_max, n)


def default_faces_max_radius(
    radius_m: float, draft_m: float, omega_max: float, g_m_s2: float = 9.80665
) -> float:
    """The panel size (capytaine's ``faces_max_radius``, m) used unless one is given: a tenth of
    the smaller of the radius and the draft, and at most a sixteenth of the shortest deep-water
    wavelength ``2 pi g / omega_max**2`` (half capytaine's own limit of a wavelength of 8
    panel radii)."""
    shortest = 2.0 * math.pi * g_m_s2 / omega_max**2
    return min(0.1 * min(radius_m, draft_m), shortest / 16.0)


def _cylinder_resolution(radius_m: float, draft_m: float, faces_max_radius: float) -> tuple[int, int, int]:
    """(nr, ntheta, nz) of a cylinder of length ``2 draft`` whose panels are at most
    ``faces_max_radius`` (capytaine's rule), nz even so that the waterline is a row of nodes."""
    h = math.sqrt(2.0) * faces_max_radius
    nr = max(1, math.ceil(radius_m / h))
    ntheta = 2 * max(4, math.ceil(math.pi * radius_m / h))
    nz = 2 * max(1, math.ceil(draft_m / h))
    return nr, ntheta, nz


def compute_heave_table(
    radius_m: float,
    draft_m: float,
    *,
    mass_kg: float | None = None,
    water_depth_m: float = math.inf,
    omegas: Sequence[float] | np.ndarray | None = None,
    rho_kg_m3: float = 1025.0,
    g_m_s2: float = 9.80665,
    name: str = "buoy",
    faces_max_radius_m: float | None = None,
    refine: int = 0,
    refine_halfwidth: float = 0.25,
    command: str = "",
    note: str = "",
    progress: Callable[[str], None] | None = None,
    chunk: int = 5,
) -> HeaveCoefficients:
    """The heave added mass, radiation damping and excitation of a vertical cylinder, by capytaine.

    The buoy is a vertical circular cylinder of ``radius_m`` floating with ``draft_m`` below the
    still water line.  Its wetted hull is meshed (``capytaine.mesh_vertical_cylinder``, clipped
    at z = 0), with a lid on its waterplane (``Mesh.generate_lid``) that removes the irregular
    frequencies of the boundary integral equation (the first near ``omega**2 / g = 2.405 /
    radius * coth(2.405 draft / radius)``: 4.9 rad/s for the default buoy).  One heave degree
    of freedom (``rigid_body_dofs(only=["Heave"])``); ``BEMSolver().fill_dataset`` solves the
    radiation and diffraction problems (wave direction 0) at every frequency; the hydrostatic
    stiffness K33 is capytaine's ``compute_hydrostatic_stiffness`` of the same mesh; the
    excitation is the Froude-Krylov plus the diffraction force.

    Parameters
    ----------
    radius_m, draft_m : float
        Radius and draft of the cylinder, m (> 0).
    mass_kg : float, optional
        The buoy's mass, kg.  Default: the displaced mass of the mesh (free floating).
    water_depth_m : float, optional
        Water depth, m (> draft), or ``math.inf`` (default) for deep water.
    omegas : sequence of float, optional
        Wave angular frequencies, rad/s (> 0; sorted and made unique).  Default:
        :func:`default_omegas`.
    rho_kg_m3, g_m_s2 : float, optional
        Water density (kg/m^3, default 1025) and gravity (m/s^2, default 9.80665).
    name : str, optional
        The table's name.
    faces_max_radius_m : float, optional
        Largest panel radius, m.  Default: :func:`default_faces_max_radius`.
    refine : int, optional
        After solving ``omegas``, solve this many more frequencies spread evenly over
        ``omega_n (1 +- refine_halfwidth)``, omega_n the natural frequency found from the
        first pass (the resonance peak is the part of the RAO that needs points).  Default 0.
    refine_halfwidth : float, optional
        The relative half-width of the refined band (default 0.25).
    command : str, optional
        Recorded in the table: the command that computed it.
    note : str, optional
        Recorded in the table.
    progress : callable, optional
        Called with one line of text at each stage (mesh, each group of frequencies solved).
    chunk : int, optional
        Frequencies solved per call of ``fill_dataset`` (between two progress lines).

    Returns
    -------
    HeaveCoefficients
        The table; its ``source`` names capytaine's version, the solver and the mesh.

    Raises
    ------
    BemUnavailableError
        capytaine 3.0 or later is not installed (an ImportError saying ``pip install
        "auvdock[bem]"``).
    ValueError
        A non-positive radius, draft, mass, density, gravity or frequency; a water depth not
        below the draft; ``refine`` negative.
    """
    for key, v in (
        ("radius_m", radius_m),
        ("draft_m", draft_m),
        ("rho_kg_m3", rho_kg_m3),
        ("g_m_s2", g_m_s2),
    ):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{key}: must be positive (got {v})")
    if mass_kg is not None and not (math.isfinite(mass_kg) and mass_kg > 0):
        raise ValueError(f"mass_kg: must be positive (got {mass_kg})")
    if math.isnan(water_depth_m) or not water_depth_m > draft_m:
        raise ValueError(
            f"water_depth_m: must be deeper than the draft {draft_m:g} m, or inf (got {water_depth_m:g})"
        )
    w_first = np.unique(np.asarray(default_omegas() if omegas is None else omegas, dtype=float))
    if w_first.size < 2 or not np.all(np.isfinite(w_first)) or not w_first[0] > 0:
        raise ValueError("omegas: need at least 2 distinct, positive, finite frequencies")
    if refine < 0:
        raise ValueError(f"refine: must be at least 0 (got {refine})")
    say = progress or (lambda _line: None)

    cpt = _capytaine()
    import xarray as xr

    fmr = faces_max_radius_m or default_faces_max_radius(radius_m, draft_m, float(w_first[-1]), g_m_s2)
    nr, ntheta, nz = _cylinder_resolution(radius_m, draft_m, fmr)
    full = cpt.mesh_vertical_cylinder(
        length=2.0 * draft_m, radius=radius_m, center=(0.0, 0.0, 0.0), resolution=(nr, ntheta, nz), name=name
    )
    depth_kw = {} if math.isinf(water_depth_m) else {"water_depth": water_depth_m}
    hull = full.immersed_part(**depth_kw)
    lid = hull.generate_lid(z=0.0)
    # capytaine 3.0 computes the hydrostatics (the stiffness included) only for a body with a
    # centre of mass, even for heave alone, which does not depend on it: the cylinder's centroid
    body = cpt.FloatingBody(
        mesh=hull,
        lid_mesh=lid,
        dofs=cpt.rigid_body_dofs(only=["Heave"]),
        center_of_mass=(0.0, 0.0, -draft_m / 2.0),
        mass=mass_kg,
        name=name,
    )
    k33 = float(np.asarray(body.compute_hydrostatic_stiffness(rho=rho_kg_m3, g=g_m_s2)).squeeze())
    mass = float(mass_kg) if mass_kg is not None else float(body.disp_mass(rho=rho_kg_m3))
    say(
        f"mesh: {hull.nb_faces} hull panels ({nr} radial, {ntheta} around, {nz // 2} down) and "
        f"{lid.nb_faces} lid panels, at most {fmr:.3g} m; K33 {k33 / 1e3:.2f} kN/m, mass {mass / 1e3:.3f} t"
    )
    solver = cpt.BEMSolver()

    def solve(ws: np.ndarray, done: int, total: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a_out, b_out, f_out = [], [], []
        for i in range(0, ws.size, chunk):
            part = ws[i : i + chunk]
            problems = xr.Dataset(
                coords={
                    "omega": part,
                    "wave_direction": [0.0],
                    "radiating_dof": ["Heave"],
                    "influenced_dof": ["Heave"],
                    "water_depth": [water_depth_m],
                    "rho": [rho_kg_m3],
                    "g": [g_m_s2],
                }
            )
            ds = solver.fill_dataset(problems, body, progress_bar=False)
            heave = {"radiating_dof": "Heave", "influenced_dof": "Heave"}
            a_out.append(np.asarray(ds["added_mass"].sel(**heave).values, dtype=float).reshape(-1))
            b_out.append(np.asarray(ds["radiation_damping"].sel(**heave).values, dtype=float).reshape(-1))
            exc = (ds["Froude_Krylov_force"] + ds["diffraction_force"]).sel(
                influenced_dof="Heave", wave_direction=0.0
            )
            f_out.append(np.asarray(exc.values, dtype=complex).reshape(-1))
            done += part.size
            say(f"solved {done}/{total} frequencies (up to {part[-1]:.3g} rad/s)")
        return np.concatenate(a_out), np.concatenate(b_out), np.concatenate(f_out)

    total = w_first.size + refine
    a, b, f = solve(w_first, 0, total)
    omegas_all = w_first
    settings = solver.exportable_settings
    source = (
        f"capytaine {cpt.__version__} BEMSolver ({settings.get('green_function', '?')} Green function, "
        f"{settings.get('method', '?')} method), heave only; hull "
        f"{hull.nb_faces} panels (mesh_vertical_cylinder resolution {nr}x{ntheta}x{nz} clipped at z=0), "
        f"lid {lid.nb_faces} panels at z=0 against irregular frequencies"
    )

    def table(ws: np.ndarray, aa: np.ndarray, bb: np.ndarray, ff: np.ndarray) -> HeaveCoefficients:
        return HeaveCoefficients(
            name=name, radius_m=radius_m, draft_m=draft_m, mass_kg=mass, rho_kg_m3=rho_kg_m3, g_m_s2=g_m_s2,
            water_depth_m=water_depth_m, hydrostatic_stiffness_N_m=k33, omega_rad_s=ws, added_mass_kg=aa,
            radiation_damping_N_s_m=bb, excitation_N_m=ff, source=source, command=command, note=note,
        )  # fmt: skip

    if refine:
        w_n = table(omegas_all, a, b, f).natural_frequency_rad_s()
        lo = max(w_n * (1.0 - refine_halfwidth), float(w_first[0]))
        hi = min(w_n * (1.0 + refine_halfwidth), float(w_first[-1]))
        extra = np.linspace(lo, hi, refine + 2)[1:-1]
        extra = extra[np.min(np.abs(extra[:, None] - w_first[None, :]), axis=1) > 1e-9]
        say(f"natural frequency {w_n:.3f} rad/s: {extra.size} more frequencies, {lo:.3f} to {hi:.3f} rad/s")
        if extra.size:
            a2, b2, f2 = solve(extra, w_first.size, w_first.size + extra.size)
            omegas_all = np.concatenate([w_first, extra])
            order = np.argsort(omegas_all)
            omegas_all = omegas_all[order]
            a, b, f = (np.concatenate([a, a2])[order], np.concatenate([b, b2])[order],
                       np.concatenate([f, f2])[order])  # fmt: skip
    return table(omegas_all, a, b, f)
