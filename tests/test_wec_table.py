"""The WEC buoy's heave table (auvdock.world.wec_table) against analytic facts, its file format,
and ``auvdock dock-table``'s input checks.  Everything but the last test runs on the committed
table ``wec_buoy_2m``, without capytaine (an optional extra, which CI need not have)."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.world.wec_table import (
    COLUMNS,
    DEFAULT_TABLE,
    HeaveCoefficients,
    load_heave_table,
    save_heave_table,
    shipped_tables,
    wavenumber,
)

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "auvdock" / "world" / "data" / f"{DEFAULT_TABLE}.csv"
runner = CliRunner()


@pytest.fixture(scope="module")
def buoy() -> HeaveCoefficients:
    return load_heave_table(DEFAULT_TABLE)


def _peak(t: HeaveCoefficients, **damping: float) -> tuple[float, float]:
    """(frequency, |RAO|) of the RAO's peak, on a grid of 1e-4 rad/s around the resonance."""
    w = np.arange(1.0, 3.0, 1e-4)
    r = np.abs(t.rao(w, **damping))
    i = int(np.argmax(r))
    return float(w[i]), float(r[i])


# --- the committed table ----------------------------------------------------------------------
def test_the_default_table_is_shipped_and_says_how_it_was_made(buoy: HeaveCoefficients) -> None:
    assert DEFAULT_TABLE in shipped_tables()
    assert load_heave_table(SHIPPED).omega_rad_s.tolist() == buoy.omega_rad_s.tolist()
    assert buoy.name == DEFAULT_TABLE
    assert (buoy.radius_m, buoy.draft_m, buoy.water_depth_m) == (1.0, 2.0, math.inf)
    assert buoy.command.startswith("auvdock dock-table --radius 1 --draft 2 --depth inf ")
    assert buoy.command.endswith(f"-o auvdock/world/data/{DEFAULT_TABLE}.csv")
    assert buoy.source.startswith("capytaine 3.")
    assert "20 m" in buoy.note
    # periods from about 1 s to about 31 s, denser near the natural frequency
    assert buoy.min_omega <= 0.2 and buoy.max_omega >= 6.2 and buoy.omega_rad_s.size >= 50
    w_n = buoy.natural_frequency_rad_s()
    near = np.sum(np.abs(buoy.omega_rad_s - w_n) < 0.25 * w_n)
    assert near >= 12


def test_hydrostatic_stiffness_is_rho_g_times_the_waterplane_area(buoy: HeaveCoefficients) -> None:
    analytic = buoy.rho_kg_m3 * buoy.g_m_s2 * math.pi * buoy.radius_m**2  # 31.58 kN/m
    assert buoy.hydrostatic_stiffness_N_m == pytest.approx(analytic, rel=0.01)


def test_the_buoy_floats_freely(buoy: HeaveCoefficients) -> None:
    displaced = buoy.rho_kg_m3 * math.pi * buoy.radius_m**2 * buoy.draft_m  # 6.44 t
    assert buoy.mass == pytest.approx(displaced, rel=0.01)


def test_long_waves_carry_the_buoy_with_the_surface(buoy: HeaveCoefficients) -> None:
    for period, tol in ((30.0, 0.02), (100.0, 0.002)):  # inside the table; below it (long-wave limit)
        r = complex(buoy.rao(2 * math.pi / period))
        assert abs(r) == pytest.approx(1.0, abs=tol), period
        assert abs(np.angle(r)) < tol, period
    assert complex(buoy.rao(0.0)) == pytest.approx(1.0, abs=1e-12)
    # the free-floating limit with a mooring: K33 / (K33 + K_moor)
    k = buoy.hydrostatic_stiffness_N_m
    assert complex(buoy.rao(0.0, mooring_stiffness_N_m=k)) == pytest.approx(0.5, abs=1e-12)


def test_swell_periods_are_followed_closely(buoy: HeaveCoefficients) -> None:
    w = 2 * math.pi / np.linspace(6.0, 13.0, 50)
    r = np.abs(buoy.rao(w))
    assert np.all(r > 0.99) and np.all(r < 1.06)


def test_the_natural_period_is_a_fixed_point_and_the_rao_peak(buoy: HeaveCoefficients) -> None:
    t_n = buoy.natural_period_s()
    assert 3.1 < t_n < 3.35
    a_n = float(np.interp(2 * math.pi / t_n, buoy.omega_rad_s, buoy.added_mass_kg))
    k33 = buoy.hydrostatic_stiffness_N_m
    assert t_n == pytest.approx(2 * math.pi * math.sqrt((buoy.mass + a_n) / k33), rel=1e-9)
    w_peak, peak = _peak(buoy)
    assert 2 * math.pi / w_peak == pytest.approx(t_n, rel=0.02)
    assert 8.0 < peak < 16.0  # radiation damping alone: about 12


def test_at_resonance_only_damping_limits_the_heave(buoy: HeaveCoefficients) -> None:
    """At omega_n the stiffness and the inertia cancel exactly: |RAO| = |F_ex| / (omega_n B)."""
    w_n = buoy.natural_frequency_rad_s()
    a, b, f = buoy.coefficients(w_n)
    for extra in (0.0, 500.0, 5000.0):
        r = abs(complex(buoy.rao(w_n, pto_damping_N_s_m=extra)))
        assert r == pytest.approx(abs(complex(f)) / (w_n * (float(b) + extra)), rel=1e-9)


def test_damping_lowers_the_peak(buoy: HeaveCoefficients) -> None:
    _, undamped = _peak(buoy)
    _, with_pto = _peak(buoy, pto_damping_N_s_m=2000.0)
    _, with_both = _peak(buoy, pto_damping_N_s_m=2000.0, viscous_damping_N_s_m=1000.0)
    assert with_both < with_pto < 0.5 * undamped


def test_well_above_resonance_the_buoy_barely_moves(buoy: HeaveCoefficients) -> None:
    w_n = buoy.natural_frequency_rad_s()
    w = np.linspace(1.4 * w_n, buoy.max_omega, 200)
    r = np.abs(buoy.rao(w))
    assert np.all(r < 1.0)
    assert np.all(r[w > 2 * w_n] < 0.1)


def test_haskind_relation_deep_water(buoy: HeaveCoefficients) -> None:
    """Radiation damping from the excitation (Haskind, axisymmetric body, deep water):
    B33 = k |F_ex|^2 / (4 rho g c_g), c_g = g / (2 omega).  Two independent results of the BEM
    (the radiation and the diffraction problems) agree within 1.5 % around the resonance and
    3.5 % wherever the damping is a tenth of its peak or more."""
    w = buoy.omega_rad_s
    k = w**2 / buoy.g_m_s2
    haskind = w * k * np.abs(buoy.excitation_N_m) ** 2 / (2 * buoy.rho_kg_m3 * buoy.g_m_s2**2)
    b = buoy.radiation_damping_N_s_m
    for share, rtol in ((0.5, 0.015), (0.1, 0.035)):
        keep = b > share * b.max()
        assert keep.sum() > 20
        np.testing.assert_allclose(b[keep], haskind[keep], rtol=rtol)


def test_excitation_tends_to_the_hydrostatic_force_in_long_waves(buoy: HeaveCoefficients) -> None:
    """The long-wave limit below the table (F_ex -> K33, B33 -> 0, A33 held) joins the table's
    first row continuously, and that row is within 1.5 % of the limit itself."""
    w0 = buoy.min_omega
    k33 = buoy.hydrostatic_stiffness_N_m
    assert abs(buoy.excitation_N_m[0] / k33 - 1) < 0.015
    assert w0 * buoy.radiation_damping_N_s_m[0] < 1e-3 * k33
    below = buoy.coefficients(w0 * (1 - 1e-9))
    at = buoy.coefficients(w0)
    for x, y in zip(below, at, strict=True):
        assert complex(x) == pytest.approx(complex(y), rel=1e-6)
    assert complex(buoy.rao(w0 * (1 - 1e-9))) == pytest.approx(complex(buoy.rao(w0)), rel=1e-6)
    a, b, f = buoy.coefficients(np.array([1e-6, 0.5 * w0]))
    assert complex(f[0]) == pytest.approx(k33, rel=1e-9) and float(b[0]) < 1e-6
    assert np.all(a == buoy.added_mass_kg[0])


def test_above_the_table_raises_unless_told_to_decay(buoy: HeaveCoefficients) -> None:
    top = buoy.max_omega
    with pytest.raises(ValueError) as e:
        buoy.rao([1.0, top + 1.0])
    assert str(e.value) == (
        f"omega {top + 1.0:g} rad/s is above the range of the heave table 'wec_buoy_2m' "
        f"({buoy.min_omega:g} to {top:g} rad/s; check against .max_omega, or pass above='decay')"
    )
    at = complex(buoy.rao(top))
    assert complex(buoy.rao(top * (1 + 1e-9), above="decay")) == pytest.approx(at, rel=1e-6)
    far = np.abs(buoy.rao(np.linspace(top, 3 * top, 20), above="decay"))
    assert np.all(np.diff(far) < 0) and far[-1] < 1e-6 * abs(at)
    with pytest.raises(ValueError, match="omega: must be finite and >= 0"):
        buoy.rao(-1.0)


def test_wavenumber_solves_the_dispersion_relation() -> None:
    w = np.array([0.1, 1.0, 3.0])
    assert wavenumber(w) == pytest.approx(w**2 / 9.80665)
    k = wavenumber(w, 20.0)
    np.testing.assert_allclose(9.80665 * k * np.tanh(k * 20.0), w**2, rtol=1e-10)


# --- the file format --------------------------------------------------------------------------
def test_a_table_reads_back_exactly(buoy: HeaveCoefficients, tmp_path: Path) -> None:
    path = save_heave_table(buoy, tmp_path / "copy.csv")
    back = load_heave_table(path)
    for key in ("omega_rad_s", "added_mass_kg", "radiation_damping_N_s_m", "excitation_N_m"):
        assert np.array_equal(getattr(back, key), getattr(buoy, key)), key
    for key in ("name", "radius_m", "draft_m", "mass_kg", "rho_kg_m3", "g_m_s2", "water_depth_m",
                "hydrostatic_stiffness_N_m", "source", "command", "note"):  # fmt: skip
        assert getattr(back, key) == getattr(buoy, key), key
    # the shipped file is what save_heave_table writes
    assert path.read_text() == SHIPPED.read_text()


def test_default_mass_is_the_displaced_mass() -> None:
    t = HeaveCoefficients(
        name="t", radius_m=1.0, draft_m=2.0, hydrostatic_stiffness_N_m=31500.0, omega_rad_s=[1.0, 2.0],
        added_mass_kg=[2000.0, 1900.0], radiation_damping_N_s_m=[300.0, 400.0],
        excitation_N_m=[2e4, 1e4 - 1e3j],
    )  # fmt: skip
    assert t.mass == pytest.approx(1025.0 * math.pi * 2.0)


def _lines() -> list[str]:
    return SHIPPED.read_text().splitlines()


def _write(tmp_path: Path, lines: list[str]) -> Path:
    p = tmp_path / "bad.csv"
    p.write_text("\n".join(lines) + "\n")
    return p


def _header_row() -> int:
    return next(i for i, line in enumerate(_lines()) if line.startswith("omega_rad_s,"))


def test_bad_table_missing_column(tmp_path: Path) -> None:
    lines = _lines()
    h = _header_row()
    cut = [",".join(x.split(",")[:4]) if i >= h else x for i, x in enumerate(lines)]
    p = _write(tmp_path, cut)
    with pytest.raises(ValueError) as e:
        load_heave_table(p)
    assert str(e.value) == (
        f"{p}: line {h + 1}: missing column 'excitation_im_N_m' (the header row needs {','.join(COLUMNS)})"
    )


def test_bad_table_omega_not_increasing(tmp_path: Path) -> None:
    lines = _lines()
    h = _header_row()
    lines[h + 3], lines[h + 4] = lines[h + 4], lines[h + 3]
    w3, w4 = (float(lines[h + k].split(",")[0]) for k in (3, 4))
    p = _write(tmp_path, lines)
    with pytest.raises(ValueError) as e:
        load_heave_table(p)
    assert str(e.value) == (
        f"{p}: line {h + 5}: omega_rad_s {w4:g} is not above the previous row's {w3:g} "
        "(omega must be strictly increasing)"
    )


def test_bad_table_non_finite_value(tmp_path: Path) -> None:
    lines = _lines()
    h = _header_row()
    cells = lines[h + 2].split(",")
    cells[2] = "nan"
    lines[h + 2] = ",".join(cells)
    p = _write(tmp_path, lines)
    with pytest.raises(ValueError) as e:
        load_heave_table(p)
    assert str(e.value) == f"{p}: line {h + 3}: radiation_damping_N_s_m: not a finite number (nan)"


def test_bad_table_not_a_number_and_wrong_length(tmp_path: Path) -> None:
    lines = _lines()
    h = _header_row()
    lines[h + 1] = "0.2,abc,1,2,3"
    p = _write(tmp_path, lines)
    with pytest.raises(ValueError) as e:
        load_heave_table(p)
    assert str(e.value) == f"{p}: line {h + 2}: added_mass_kg: not a number ('abc')"
    lines[h + 1] = "0.2,1,2,3"
    p = _write(tmp_path, lines)
    with pytest.raises(ValueError) as e:
        load_heave_table(p)
    assert str(e.value) == f"{p}: line {h + 2}: 4 values, the header row has 5"


def test_bad_table_missing_header_key(tmp_path: Path) -> None:
    lines = [x for x in _lines() if not x.startswith("# hydrostatic_stiffness_N_m:")]
    p = _write(tmp_path, lines)
    with pytest.raises(ValueError) as e:
        load_heave_table(p)
    assert str(e.value) == f"{p}: missing header line '# hydrostatic_stiffness_N_m: ...'"


def test_bad_table_header_value(tmp_path: Path) -> None:
    lines = [("# radius_m: one" if x.startswith("# radius_m:") else x) for x in _lines()]
    p = _write(tmp_path, lines)
    with pytest.raises(ValueError) as e:
        load_heave_table(p)
    assert str(e.value) == f"{p}: header radius_m: not a number ('one')"
    lines = [("# radius_m: -1" if x.startswith("# radius_m:") else x) for x in _lines()]
    p = _write(tmp_path, lines)
    with pytest.raises(ValueError) as e:
        load_heave_table(p)
    assert str(e.value) == f"{p}: radius_m: must be positive and finite (got -1.0)"


def test_no_such_table(tmp_path: Path) -> None:
    with pytest.raises(ValueError) as e:
        load_heave_table("no_such_buoy")
    shipped = ", ".join(shipped_tables())
    assert (
        str(e.value)
        == f"no_such_buoy: no such file (nor a shipped heave table of that name; shipped: {shipped})"
    )


# --- auvdock dock-table -----------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--radius", "-1", "--draft", "2"], "error: --radius: must be positive (got -1)"),
        (["--radius", "1", "--draft", "0"], "error: --draft: must be positive (got 0)"),
        (["--radius", "1", "--draft", "2", "--depth", "1.5"],
         "error: --depth: must be deeper than the draft 2 m, or inf (got 1.5)"),
        (["--radius", "1", "--draft", "2", "--omega-min", "3", "--omega-max", "3"],
         "error: --omega-max: must be above --omega-min 3 (got 3)"),
        (["--radius", "1", "--draft", "2", "--n", "1"], "error: --n: must be at least 2 (got 1)"),
    ],
)  # fmt: skip
def test_dock_table_bad_input(tmp_path: Path, args: list[str], message: str) -> None:
    res = runner.invoke(app, ["dock-table", *args, "-o", str(tmp_path / "t.csv")])
    assert res.exit_code == 2, res.output
    assert res.stderr.strip() == message


def test_dock_table_output_folder_must_exist(tmp_path: Path) -> None:
    out = tmp_path / "nowhere" / "t.csv"
    res = runner.invoke(app, ["dock-table", "--radius", "1", "--draft", "2", "-o", str(out)])
    assert res.exit_code == 2
    assert res.stderr.strip() == f"error: --out {out}: the folder {out.parent} does not exist"


def test_dock_table_without_capytaine_names_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "capytaine", None)  # `import capytaine` raises ImportError
    out = tmp_path / "t.csv"
    res = runner.invoke(app, ["dock-table", "--radius", "1", "--draft", "2", "-o", str(out)])
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        "error: dock-table: capytaine (3.0 or later) is needed to compute a heave table: "
        'pip install "auvdock[bem]"'
    )
    assert not out.exists()


@pytest.mark.slow  # about 7 s: capytaine's solver on 500 panels, twice
@pytest.mark.skipif(
    importlib.util.find_spec("capytaine") is None,
    reason='capytaine is not installed (the optional extra: pip install "auvdock[bem]")',
)
def test_capytaine_recomputes_the_committed_added_mass(buoy: HeaveCoefficients) -> None:
    """A coarse mesh (0.2 m panels), two frequencies: A33, B33 and |F_ex| within 5 % of the table."""
    from auvdock.world.bem import compute_heave_table

    w = [1.0, 2.0]
    coarse = compute_heave_table(1.0, 2.0, omegas=w, faces_max_radius_m=0.2, name="coarse")
    a, b, f = buoy.coefficients(np.array(w))
    np.testing.assert_allclose(coarse.added_mass_kg, a, rtol=0.05)
    np.testing.assert_allclose(coarse.radiation_damping_N_s_m, b, rtol=0.05)
    np.testing.assert_allclose(np.abs(coarse.excitation_N_m), np.abs(f), rtol=0.05)
    assert coarse.hydrostatic_stiffness_N_m == pytest.approx(buoy.hydrostatic_stiffness_N_m, rel=0.02)
