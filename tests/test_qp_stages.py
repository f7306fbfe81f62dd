"""The QP's data stage by stage (:mod:`auvdock.controllers.qp_stages`) against the whole problem's
derivatives (CasADi's Jacobians and Gauss-Newton matrix of the whole NLP, the reference): the same
Hessian, gradient, gap Jacobian, gaps and cost, on random linearisation points, for every prediction
model, a fine-then-coarse grid, the entry corridor and a cost of the whole path."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from auvdock.controllers.mpc import DockingMPC
from auvdock.controllers.qp_stages import blocks_function
from auvdock.controllers.settings import DEFAULT_Q
from auvdock.vehicle import load_vehicle
from auvdock.world.dock import HeaveDock


def _rtis(monkeypatch, **kw):
    """The stage-wise RTI and the whole-problem reference of one MPC (uncompiled, both)."""
    from auvdock.controllers.entry import EntryCorridor

    monkeypatch.setenv("AUVDOCK_COMPILE", "never")
    v = load_vehicle("bluerov2_heavy")
    dock = HeaveDock((2.0, 0.0, 1.0), amplitude_m=0.05, angular_frequency_rad_s=2.0)
    if kw.pop("entry", False):
        kw["entry"] = EntryCorridor(
            cradle_x_m=0.15, face_x_m=-0.3, side_radius_m=0.6, cradle_radius_m=0.25, taper=0.4,
            contact_speed_m_s=0.15, deceleration_1_s=0.5, heading_margin_rad=0.1, heading_slope_rad_m=0.2,
            weights=(50.0, 20.0, 5.0),
        )  # fmt: skip
    out = []
    for qp in ("hpipm", "hpipm_casadi"):
        mpc = DockingMPC(v, dock, Q=DEFAULT_Q, R=[1e-3] * 8, P=DEFAULT_Q, solver="rti", qp=qp, **kw)
        out.append((mpc, mpc._solver._rti))  # type: ignore[attr-defined]
    return out


def _dense(M) -> np.ndarray:
    return np.array(ca.DM(M).full()) if isinstance(M, ca.DM) else np.asarray(M, dtype=float)


def _random_point(mpc: DockingMPC, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    nw, n_p = mpc._nw, mpc._n_params
    w = rng.normal(size=nw) * 0.3
    w[mpc._iu] = rng.uniform(-30, 30, size=mpc._iu.shape)
    w[mpc._iv] = rng.uniform(-30, 30, size=mpc._iv.shape)
    p = rng.normal(size=n_p) * 0.5
    p[-1] = float(rng.integers(0, 2))  # the entry corridor active or not
    p[-2] = rng.uniform(0.0, 1.0)  # its standoff
    return w, p


CASES = {
    "full": {"prediction": "full"},
    "kinematic": {"prediction": "kinematic"},
    "naive, offset-free": {"prediction": "naive", "offset_free": True},
    "fine then coarse, entry": {"horizon": 3, "coarse_steps": 3, "coarse_dt": 0.15, "entry": True},
    "a cost of the whole path": {
        "horizon": 4,
        "coarse_steps": 2,
        "coarse_dt": 0.1,
        "objective_extra": lambda X, U, params, extra, stage_dt: extra[0] * ca.sumsqr(ca.sin(X[9:12, :])),
        "objective_key": "a test's path cost",
        "extra_params": 1,
        "extra_hessian": False,
    },
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_stage_wise_data_are_the_whole_problems(case, monkeypatch) -> None:
    kw = dict(CASES[case])
    kw.setdefault("horizon", 5)
    (mpc, fast), (_, ref) = _rtis(monkeypatch, **kw)
    assert fast.stages is not None and ref.stages is None  # stage-wise, and the whole-problem reference
    rng = np.random.default_rng(11)
    for _ in range(4):
        w, p = _random_point(mpc, rng)
        a, b = fast._data(w, p), ref._data(w, p)
        for name, x, y in zip(("H", "grad", "Jg", "g", "f"), a, b, strict=True):
            x, y = _dense(x), _dense(y)
            scale = max(1.0, float(np.max(np.abs(y))))
            assert x.shape == y.shape or x.size == y.size, name
            np.testing.assert_allclose(x.reshape(y.shape), y, rtol=0, atol=1e-10 * scale, err_msg=name)


def test_the_generated_code_does_not_grow_with_the_horizon(tmp_path, monkeypatch) -> None:
    """The stages' functions are generated once and called in a loop: the C for a 40-stage horizon is
    about that of a 4-stage one (the whole problem's derivatives grew tenfold)."""
    sizes = {}
    for N in (4, 40):
        (_, fast), _ = _rtis(monkeypatch, horizon=N)
        assert fast.stages is not None
        path = tmp_path / f"blocks_{N}.c"
        cg = ca.CodeGenerator(str(path.name))
        cg.add(blocks_function(fast.stages))
        monkeypatch.chdir(tmp_path)
        cg.generate()
        sizes[N] = path.stat().st_size
    assert sizes[40] < 1.1 * sizes[4], sizes


def test_a_stage_qp_without_a_gap_before_its_last_stage_is_refused(monkeypatch) -> None:
    from dataclasses import replace

    (mpc, fast), _ = _rtis(monkeypatch, horizon=3)
    qp = fast.stages
    assert qp is not None
    stages = [replace(s, gap=None) if k == 1 else s for k, s in enumerate(qp.stages)]
    broken = replace(qp, stages=stages)
    with pytest.raises(ValueError) as e:
        blocks_function(broken)
    assert str(e.value) == "stage 1: every stage but the last has a gap function, the last none"
