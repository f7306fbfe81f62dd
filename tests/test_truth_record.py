"""A stand-in's truth file keeps the instant a contact begins, and truth-check judges a capture verdict at
its own instant on it (:mod:`auvdock.standins.truth_record`, :mod:`auvdock.standins.truth_check`)."""

from __future__ import annotations

import numpy as np
from helpers.loopback import ROOT

from auvdock.config.mission import load_mission
from auvdock.results.store import read_run
from auvdock.standins.truth_check import _capture_right
from auvdock.standins.truth_record import CONTACT_STATUSES, TruthRecord

TANK_0P6 = ROOT / "missions" / "tank_0p6hz.yaml"
CAPTURED_AT_S = 1.03  # between two 0.05 s rows


def _truth(tmp_path):
    """A truth file of 2 s of a 100 Hz simulator, the truth captured from :data:`CAPTURED_AT_S` on."""
    m = load_mission(TANK_0P6)
    columns = {"armed": (), "contact_status": (), "nose_dock_m": (3,)}
    path = tmp_path / "truth.h5"
    rec = TruthRecord.for_stand_in(path, "vehicle-sim", m, columns, 8)
    zeros = {"thrust_N": np.zeros(8), "wrench": np.zeros(6), "flow_ned_m_s": np.zeros(3)}
    for k in range(201):
        t = 0.01 * k
        captured = t >= CAPTURED_AT_S - 1e-9
        rec.append(
            time_s=t,
            state=np.zeros(12),
            dock_position_m=np.zeros(3),
            dock_velocity_m_s=np.zeros(3),
            distance_m=1.0,
            solve_time_s=0.0,
            solver_status=0,
            armed=1.0,
            contact_status=float(CONTACT_STATUSES.index("captured" if captured else "free")),
            nose_dock_m=np.zeros(3),
            **zeros,
        )
    rec.end(False, "", 2.0)
    return read_run(path)


def test_the_truth_keeps_the_physics_step_a_capture_begins(tmp_path) -> None:
    tr = _truth(tmp_path)
    t = np.round(tr.time_s, 6)
    assert CAPTURED_AT_S in t  # not a multiple of 0.05 s: kept for the change
    assert np.all(np.isin(np.round(np.arange(0.0, 2.0001, 0.05), 6), t))  # and every 0.05 s
    assert len(t) == 41 + 1
    assert tr.outcome()["first_captured_armed_t_s"] == CAPTURED_AT_S


def test_a_capture_verdict_is_judged_at_its_instant(tmp_path) -> None:
    """A verdict 5 ms before the capture is wrong, 5 ms after it right (the nearest 0.05 s row would
    have judged both on the row at 1.05 s: right)."""
    tr = _truth(tmp_path)
    status = np.asarray(tr.extras["contact_status"], dtype=float)
    before = _capture_right(tr, status, CAPTURED_AT_S - 0.005, 0.0, 2.0, docked=True)
    after = _capture_right(tr, status, CAPTURED_AT_S + 0.005, 0.0, 2.0, docked=True)
    assert before == ("free", False)
    assert after == ("captured", True)
    assert _capture_right(tr, status, 0.5, 0.0, 2.0, docked=False) == ("free", False)  # captured later
