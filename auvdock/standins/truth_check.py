"""A rehearsed flight scored on what really happened: ``auvdock truth-check FLIGHT.h5 TRUTH.h5``.

A flight against a stand-in vehicle (``vehicle-sim --truth-out TRUTH.h5``) records with every row the
vehicle's own clock (``vehicle_time_s``: the newest ATTITUDE's ``time_boot_ms``); the stand-in's truth
file is on that clock (:mod:`auvdock.standins.truth_record`).  :func:`check_flight` interpolates the
truth at each of the flight's rows (linearly between its rows, never across an arming or a disarm) and
reports, from the two files alone:

* the flight's verdict (docked or not, how it ended) and the truth's distance from the vehicle to the
  docking point at the instant it judged (``verdict_vehicle_time_s``: the estimate's, which over a
  delayed link is older than the step that declared it; else the flight's last row): **right**
  (docked, and truly within the mission's tolerance; or not docked, and truly not) or **wrong**;
* the true closest approach while the flight ran (m), and the true speed relative to the dock at the
  verdict (m/s);
* the error over time of what fly judged on (its ``state`` rows: the vehicle's telemetry) and of what
  it flew on (the navigation filter's ``estimated_state``, with ``estimation: filter``): RMS and
  largest position error (m) against the truth.

Positions are in the mission frame in both files (the stand-in holds the vehicle at the mission's
start until armed, and fly maps the vehicle's pose at its start onto the same start).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from auvdock.results.store import RunResults, read_run
from auvdock.standins.truth_record import CONTACT_STATUSES, TRUTH_SOURCE
from auvdock.vehicle.geometry import rotation_zyx

__all__ = ["TruthCheck", "check_flight"]


@dataclass(frozen=True)
class TruthCheck:
    """A flight against its truth (see the module docstring); distances m, speeds m/s, times s."""

    flight_reason: str
    flight_docked: bool
    tolerance_m: float
    verdict_time_s: float
    truth_distance_at_verdict_m: float
    verdict_right: bool
    truth_closest_m: float
    truth_relative_speed_at_verdict_m_s: float
    telemetry_error_rms_m: float
    telemetry_error_max_m: float
    estimate_error_rms_m: float
    estimate_error_max_m: float
    rows: int
    #: ``docking.criterion: capture``: the truth's contact with the dock's body at the verdict (free,
    #: captured, collided; "collided before" when it collided earlier in the flight); "" for the point rule.
    truth_contact_at_verdict: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Every figure by name."""
        return asdict(self)

    def lines(self) -> list[str]:
        """The report, a line per figure."""
        said = "docked" if self.flight_docked else f"not docked ({self.flight_reason})"
        right = "right" if self.verdict_right else "WRONG"
        if self.truth_contact_at_verdict:
            then = (
                f"truth then: {self.truth_contact_at_verdict} (the dock's body), "
                f"{self.truth_distance_at_verdict_m:.3f} m from the docking point"
            )
        else:
            then = (
                f"truth then: {self.truth_distance_at_verdict_m:.3f} m from the docking point (tolerance "
                f"{self.tolerance_m:.3f} m)"
            )
        out = [
            f"fly's verdict: {said}, at vehicle time {self.verdict_time_s:.2f} s",
            f"{then}, {self.truth_relative_speed_at_verdict_m_s:.3f} m/s relative to the dock: "
            f"the verdict is {right}",
            f"truth's closest approach during the flight: {self.truth_closest_m:.3f} m",
            f"telemetry (what fly judged on) against the truth: {self.telemetry_error_rms_m:.3f} m RMS, "
            f"{self.telemetry_error_max_m:.3f} m at most, over {self.rows} rows",
        ]
        if math.isfinite(self.estimate_error_rms_m):
            out.append(
                f"navigation estimate (what it flew on) against the truth: {self.estimate_error_rms_m:.3f} m "
                f"RMS, {self.estimate_error_max_m:.3f} m at most"
            )
        return out


def _at(t_truth: np.ndarray, armed: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``values`` (T, m) at times ``t``: linear between the truth's rows, but never across an arming or a
    disarm (the stand-in puts a disarmed vehicle back at the start: the row before holds)."""
    i = np.clip(np.searchsorted(t_truth, t, side="right") - 1, 0, len(t_truth) - 1)
    j = np.minimum(i + 1, len(t_truth) - 1)
    span = np.where(j > i, t_truth[j] - t_truth[i], 1.0)
    w = np.clip((t - t_truth[i]) / span, 0.0, 1.0)
    w = np.where(armed[i] == armed[j], w, 0.0)[:, None]
    v = values if values.ndim == 2 else values[:, None]
    out = (1.0 - w) * v[i] + w * v[j]
    return out if values.ndim == 2 else out[:, 0]


def _read(path: str | Path, writer: str) -> RunResults:
    """The run in ``path``; a file its ``writer`` still holds open (HDF5's lock) is said to be so."""
    try:
        return read_run(path)
    except BlockingIOError:  # "unable to lock file": the writer is running
        raise ValueError(f"{path}: still being written (is {writer} still running? stop it first)") from None


def check_flight(flight: str | Path, truth: str | Path) -> TruthCheck:
    """Score the flight's results file ``flight`` on the stand-in's truth file ``truth``.

    Raises ValueError naming the file and the problem: a file still being written (its writer holds
    HDF5's lock on it until it stops), a results file that is not a fly flight (a sim run, a truth
    file), a flight without ``vehicle_time_s`` (recorded by an older auvdock), a truth file that is not
    one, no overlap of their times."""
    f = _read(flight, "fly")
    tr = _read(truth, "vehicle-sim or sitl-physics")
    source = str(f.attrs.get("source", ""))
    if source == TRUTH_SOURCE:
        raise ValueError(
            f"{flight}: a truth file (--truth-out), not a fly flight; truth-check takes the flight's "
            "results file (fly's .h5) first, then the truth file"
        )
    if not (source.startswith("fly ") or "telemetry_age_s" in f.extras):  # (the series only fly records)
        raise ValueError(
            f"{flight}: a sim results file, not a fly flight; truth-check scores the results file of a fly "
            "session flown against vehicle-sim (or sitl-physics) with --truth-out, on that truth file"
        )
    if "vehicle_time_s" not in f.extras:
        raise ValueError(f"{flight}: no vehicle_time_s rows (a flight recorded before they were)")
    if tr.attrs.get("source") != TRUTH_SOURCE:
        raise ValueError(f"{truth}: not a truth file (vehicle-sim --truth-out writes one)")
    tv = np.asarray(f.extras["vehicle_time_s"], dtype=float)
    ok = np.isfinite(tv) & (tv >= tr.time_s[0]) & (tv <= tr.time_s[-1])
    if not np.any(ok):
        raise ValueError(
            f"{flight}: its vehicle times ({np.nanmin(tv):.2f}-{np.nanmax(tv):.2f} s) are not in {truth} "
            f"({tr.time_s[0]:.2f}-{tr.time_s[-1]:.2f} s): another session's truth?"
        )
    t = tv[ok]
    armed = np.asarray(tr.extras["armed"], dtype=float)
    x_true = _at(tr.time_s, armed, tr.state, t)
    d_true = _at(tr.time_s, armed, tr.distance_m, t)
    tel_err = np.linalg.norm(f.state[ok, 0:3] - x_true[:, 0:3], axis=1)
    est = f.extras.get("estimated_state")
    if est is not None:
        est_err = np.linalg.norm(np.asarray(est)[ok, 0:3] - x_true[:, 0:3], axis=1)
        est_err = est_err[np.isfinite(est_err)]
    else:
        est_err = np.array([])
    out = f.outcome()
    tol = float(f.attrs.get("tolerance_m", math.nan))
    docked = bool(out.get("docked", False))
    # the verdict's instant: the estimate it judged (fly records it on the vehicle's clock), else the last row
    t_verdict = float(out.get("verdict_vehicle_time_s", math.nan)) if docked else math.nan
    if not (math.isfinite(t_verdict) and tr.time_s[0] <= t_verdict <= tr.time_s[-1]):
        t_verdict = float(t[-1])
    at = np.array([t_verdict])
    xe = _at(tr.time_s, armed, tr.state, at)[0]
    # the truth's speed relative to the dock at the verdict: the body velocity rotated into {n}
    v_ned = rotation_zyx(float(xe[3]), float(xe[4]), float(xe[5])) @ xe[6:9]
    speed = float(np.linalg.norm(v_ned - _at(tr.time_s, armed, tr.dock_velocity_m_s, at)[0]))
    d_end = float(_at(tr.time_s, armed, tr.distance_m, at)[0])
    right = (d_end <= tol) if docked else not (d_end <= tol)
    contact_said = ""
    status = tr.extras.get("contact_status")
    if status is not None:  # docking.criterion: capture -- the truth's contact, judged as sim judges it
        status = np.asarray(status, dtype=float)
        contact_said, right = _capture_right(tr, status, t_verdict, float(t[0]), float(t[-1]), docked)
    return TruthCheck(
        flight_reason=str(out.get("reason", "")),
        flight_docked=docked,
        tolerance_m=tol,
        verdict_time_s=t_verdict,
        truth_distance_at_verdict_m=d_end,
        verdict_right=bool(right),
        truth_closest_m=float(np.min(d_true)),
        truth_relative_speed_at_verdict_m_s=speed,
        telemetry_error_rms_m=float(np.sqrt(np.mean(tel_err**2))),
        telemetry_error_max_m=float(np.max(tel_err)),
        estimate_error_rms_m=float(np.sqrt(np.mean(est_err**2))) if est_err.size else math.nan,
        estimate_error_max_m=float(np.max(est_err)) if est_err.size else math.nan,
        truth_contact_at_verdict=contact_said,
        rows=int(t.size),
    )


def _capture_right(
    tr: RunResults, status: np.ndarray, t_verdict: float, t_first: float, t_last: float, docked: bool
) -> tuple[str, bool]:
    """(the truth's contact at the verdict, whether the verdict is right) for a capture mission, on the
    truth's rows of the flight (vehicle times ``t_first`` to ``t_last``, s; a row every 0.05 s and one at
    each change of contact, so a row's status holds until the next): docked is right when the truth is
    captured at the verdict's instant (the last row at or before it) and did not collide before it; not
    docked is right when the truth was never captured during the flight."""
    t = tr.time_s
    armed = np.asarray(tr.extras["armed"], dtype=float) > 0.5
    during = (t >= t_first - 1e-9) & (t <= t_last + 1e-9) & armed & np.isfinite(status)
    names = np.array(CONTACT_STATUSES)[np.where(np.isfinite(status), status, 0).astype(int)]
    i = int(np.clip(np.searchsorted(t, t_verdict + 1e-9, side="right") - 1, 0, len(t) - 1))
    then = str(names[i])
    collided = during & (names == "collided") & (t < t[i] - 1e-9)
    if np.any(collided) and then != "collided":
        return f"{then}, collided before (t = {float(t[collided][0]):.2f} s)", False
    if docked:
        return then, then == "captured"
    return then, not bool(np.any(during & (names == "captured")))
