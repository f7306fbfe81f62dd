"""The paper's findings (docs/parameter-sources.md section 5b), checked against a campaign's own table.

Each :class:`Finding` is one claim of the paper (fixed: that is what is checked), what the
campaign measured, a verdict, and -- where the verdict is not "holds" -- an explanation
made only of the campaign's figures: time to dock, closest approach against the docking
tolerance, path length, flow-estimate RMSE and final error, wall and set-up time.  No
sentence is written in advance, so none can contradict the table it is printed beside.
Only runs of the paper's six cases count (``paper_case`` 1-6) and only runs that ran
(``status == "done"``).  A campaign of some of the cases is checked on the cases it ran, and
says which (:func:`coverage_note`; "over cases 1, 2 only" in a finding's measurement).
The paper's claims are about its own formulation: where the campaign
has a controller's ``NAME@paper`` runs they are the ones checked, else its ``NAME`` runs.  The
last finding sets the robust defaults (``NAME``) beside the paper variants (``NAME@paper``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, TypeGuard

from auvdock.controllers.registry import CONTROLLERS, controller_label, controller_short_label

__all__ = ["Finding", "PAPER_COMPUTE_S", "check_findings", "covered_cases", "coverage_note"]

#: The paper's compute per 75 s case (Python + CasADi on an Intel i7-10870H laptop), s.
PAPER_COMPUTE_S = {"optimized": 5014.83, "sequential": 203.08}
#: The length of the paper's cases (their timeout), s: what its compute figures are per.
PAPER_CASE_S = 75.0
_ALL = frozenset(range(1, 7))
#: "Clearly lower" flow RMSE: at least this much below (a ratio).
CLEAR_RATIO = 0.8


@dataclass
class Finding:
    """One of the paper's findings, checked against a campaign."""

    finding: str
    measured: str
    verdict: str  # "holds", "differs", "differs (...)" or "not run"
    explanation: str = ""


def _ok(v: Any) -> TypeGuard[float]:
    """A finite number (not None, not NaN)."""
    return v is not None and isinstance(v, int | float) and math.isfinite(v)


def _runs(records: Iterable[dict[str, Any]], label: str) -> dict[int, dict[str, Any]]:
    return {
        int(r["paper_case"]): r
        for r in records
        if r.get("controller") == label and int(r.get("paper_case", 0) or 0) > 0 and r.get("status") == "done"
    }


def _by(records: Iterable[dict[str, Any]], controller: str) -> dict[int, dict[str, Any]]:
    """The paper-case runs of ``controller`` in the paper's formulation (``NAME@paper`` if the
    campaign has it, else ``NAME``), by case."""
    records = list(records)
    return _runs(records, f"{controller}@paper") or _runs(records, controller)


def _cases(cases: Iterable[int]) -> str:
    return ", ".join(str(c) for c in sorted(cases)) or "none"


def _over(ran: Iterable[int]) -> str:
    """``over cases 1, 2 only (no finished run in 3, 4, 5, 6)``: what a check on some cases covers."""
    ran = set(ran)
    s = "s" if len(ran) > 1 else ""
    return f"over case{s} {_cases(ran)} only (no finished run in {_cases(_ALL - ran)})"


def covered_cases(records: Iterable[dict[str, Any]]) -> set[int]:
    """The paper's cases (1-6) with at least one finished run in the campaign."""
    return {
        int(r["paper_case"])
        for r in records
        if int(r.get("paper_case", 0) or 0) in _ALL and r.get("status") == "done"
    }


def coverage_note(records: Iterable[dict[str, Any]]) -> str:
    """One sentence on the cases the findings are checked on; "" when the campaign ran all six."""
    ran = covered_cases(records)
    if ran == _ALL:
        return ""
    if not ran:
        return "This campaign has no finished run of the paper's six cases: no finding can be checked."
    return (
        f"This campaign ran paper case{'s' if len(ran) > 1 else ''} {_cases(ran)} only (no finished run in "
        f"{_cases(_ALL - ran)}): each finding is checked on the cases it ran, and says so."
    )


def _join(parts: Sequence[str]) -> str:
    return "; ".join(parts)


def _why_not_docked(case: int, r: dict[str, Any]) -> str:
    """One sentence on a run that did not dock, from its row alone."""
    end = r.get("end_time_s")
    reason = r.get("reason") or "timeout"
    head = f"Case {case}: {reason}" + (f" at {end:.1f} s" if _ok(end) else "")
    bits = []
    ca, tol = r.get("closest_approach_m"), r.get("tolerance_m")
    if _ok(ca):
        near = f"closest approach {ca:.3f} m"
        if _ok(tol) and float(tol) > 0:
            near += f" ({float(ca) / float(tol):.1f} times the {float(tol):.3f} m tolerance)"
        bits.append(near)
    if _ok(r.get("path_length_m")):
        bits.append(f"path {r['path_length_m']:.2f} m")
    if _ok(r.get("flow_rmse_m_s")):
        flow = f"flow estimate RMSE {r['flow_rmse_m_s']:.4f} m/s"
        if _ok(r.get("flow_final_error_m_s")):
            flow += f", {r['flow_final_error_m_s']:.4f} m/s off at the end"
        bits.append(flow)
    return head + (", " + ", ".join(bits) if bits else "") + "."


def _docking(records, ctrl: str, expected: frozenset[int]) -> Finding:
    label = controller_label(ctrl)
    text = f"{label} docks in " + ("all six cases" if expected == _ALL else "cases 1 and 5 only")
    runs = _by(records, ctrl)
    if not runs:
        return Finding(text, "cases run: none", "not run")
    ran = frozenset(runs)  # checked on the cases that ran (all six in a full campaign)
    expected = expected & ran
    docked = {c for c, r in runs.items() if r["docked"]}
    measured = f"docks in {_cases(docked)}; times out in {_cases(ran - docked)}"
    if ran != _ALL:
        measured = f"{_over(ran)}: {measured}"
    if docked == expected:
        return Finding(text, measured, "holds")
    why: list[str] = []
    extra = sorted(docked - expected)  # docks where the paper's times out
    if extra:
        times = ", ".join(f"case {c} at {runs[c]['time_to_dock_s']:.2f} s" for c in extra)
        why.append(f"Docks where the paper's times out: {times}.")
        oracle = _by(records, "oracle")
        if ctrl != "oracle" and all(c in oracle and oracle[c]["docked"] for c in extra):
            diffs = [abs(runs[c]["time_to_dock_s"] - oracle[c]["time_to_dock_s"]) for c in extra]
            worst = extra[diffs.index(max(diffs))]
            sentence = (
                f"{controller_label('oracle')} docks in the same cases at "
                + ", ".join(f"{oracle[c]['time_to_dock_s']:.2f}" for c in extra)
                + f" s, the largest difference {max(diffs):.2f} s (case {worst})"
            )
            if max(diffs) <= 0.5:
                sentence += f", so {label} flies as {controller_label('oracle')} there"
            why.append(sentence + ".")
    for c in sorted(expected - docked):
        why.append(_why_not_docked(c, runs[c]))
    return Finding(text, measured, "differs", " ".join(why))


def _travel(records) -> Finding:
    on, sn, qn = (controller_short_label(c) for c in ("optimized", "sequential", "oracle"))
    text = f"Travel time: {on} > {sn} > {qn}"
    o, s, q = _by(records, "optimized"), _by(records, "sequential"), _by(records, "oracle")
    if not (o and s and q):
        return Finding(text, "needs oracle, sequential and optimized runs", "not run")
    cases = sorted(set(o) & set(s) & set(q))
    common = [c for c in cases if o[c]["docked"] and s[c]["docked"] and q[c]["docked"]]
    left_out = []
    for c in cases:
        if c in common:
            continue
        ended = [
            f"{n} ended at {runs[c]['end_time_s']:.1f} s without docking"
            for n, runs in ((on, o), (sn, s), (qn, q))
            if not runs[c]["docked"]
        ]
        left_out.append(f"case {c} ({', '.join(ended)})")
    left = ("Left out: " + "; ".join(left_out) + ".") if left_out else ""
    if not common:
        return Finding(text, "no case where all three docked", "differs", left)

    def t(runs, c) -> float:
        return float(runs[c]["time_to_dock_s"])

    good = [c for c in common if t(o, c) > t(s, c) > t(q, c)]
    parts = [f"case {c}: {t(o, c):.1f} / {t(s, c):.1f} / {t(q, c):.1f} s" for c in common]
    measured = f"order holds in {len(good)} of {len(common)} cases (opt / seq / oracle): " + _join(parts)
    if len(good) == len(common):
        return Finding(text, measured, "holds", left)
    why = []
    for a, an, b, bn in ((o, on, s, sn), (s, sn, q, qn)):
        early = [c for c in common if not t(a, c) > t(b, c)]
        if early:
            by = ", ".join(f"{t(b, c) - t(a, c):.2f}" for c in early)
            which = f"case{'s' if len(early) > 1 else ''} {_cases(early)}"
            why.append(f"{an} docks no later than {bn} in {which} (earlier by {by} s).")
    if left:
        why.append(left)
    return Finding(text, measured, "differs", " ".join(why))


def _rmse(records) -> Finding:
    on, sn = controller_short_label("optimized"), controller_short_label("sequential")
    text = f"Flow RMSE: {on} < {sn}, clearly so in cases 2 and 4"
    o, s = _by(records, "optimized"), _by(records, "sequential")
    both = sorted(c for c in set(o) & set(s) if _ok(o[c]["flow_rmse_m_s"]) and _ok(s[c]["flow_rmse_m_s"]))
    if not both:
        return Finding(text, "needs sequential and optimized runs", "not run")

    def e(runs, c) -> float:
        return float(runs[c]["flow_rmse_m_s"])

    lower = [c for c in both if e(o, c) < e(s, c)]
    parts = [f"case {c}: {e(o, c):.4f} / {e(s, c):.4f}" for c in both]
    measured = f"{on} lower in {len(lower)} of {len(both)} cases (opt / seq, m/s): " + _join(parts)
    if covered_cases(records) != _ALL:  # checked on the cases run: "clearly" only where they ran
        unchecked = [c for c in (2, 4) if c not in both]
        if unchecked:
            measured += f"; 'clearly' not checked in case {' and '.join(map(str, unchecked))} (not run)"
        unclear = [c for c in (2, 4) if c in both and not e(o, c) < CLEAR_RATIO * e(s, c)]
    else:
        unclear = [c for c in (2, 4) if c not in both or not e(o, c) < CLEAR_RATIO * e(s, c)]
    if len(lower) == len(both) and not unclear:
        return Finding(text, measured, "holds")
    why = []
    not_lower = [c for c in both if c not in lower]
    if not_lower:
        why.append(
            f"{on} is not lower in "
            + ", ".join(f"case {c} ({e(o, c):.4f} vs {e(s, c):.4f} m/s)" for c in not_lower)
            + "."
        )
    for c in unclear:
        if c not in both:
            why.append(f"Case {c} has no pair of runs to compare.")
        elif c in lower:
            why.append(
                f"In case {c} {on} is only {100 * (1 - e(o, c) / e(s, c)):.0f} % lower "
                f"({e(o, c):.4f} vs {e(s, c):.4f} m/s; 'clearly' is taken as at least "
                f"{100 * (1 - CLEAR_RATIO):.0f} % lower)."
            )
    apart = [
        f"case {c} {on} {o[c]['end_time_s']:.1f} s ({'docked' if o[c]['docked'] else 'no dock'}), "
        f"{sn} {s[c]['end_time_s']:.1f} s ({'docked' if s[c]['docked'] else 'no dock'})"
        for c in both
        if o[c]["docked"] != s[c]["docked"]
    ]
    if apart:
        why.append("Each RMSE is averaged over its run's own duration: " + "; ".join(apart) + ".")
    return Finding(text, measured, "differs", " ".join(why))


def _compute(records) -> Finding:
    text = (
        f"Compute per 75 s case: about {PAPER_COMPUTE_S['optimized']:.0f} s "
        f"({controller_short_label('optimized')}) and "
        f"{PAPER_COMPUTE_S['sequential']:.0f} s ({controller_short_label('sequential')})"
    )
    meas, why, ratios = [], [], []
    for ctrl in ("optimized", "sequential"):
        label = controller_short_label(ctrl)
        runs = [
            r
            for r in _by(records, ctrl).values()
            if _ok(r.get("wall_time_s")) and _ok(r.get("end_time_s")) and r["end_time_s"] > 0
        ]
        if not runs:
            continue
        # the paper's figure is per 75 s case; runs here end when they dock (about 20 s) or at their
        # own timeout, so compare compute per simulated second, scaled to 75 s
        rate = sum(r["wall_time_s"] / r["end_time_s"] for r in runs) / len(runs)
        per75 = rate * PAPER_CASE_S
        meas.append(f"{label} {per75:.1f} s")
        paper = PAPER_COMPUTE_S[ctrl]
        ratios.append(paper / per75 if per75 > 0 else math.inf)
        sim_mean = sum(r["end_time_s"] for r in runs) / len(runs)
        sentence = (
            f"{label}: {rate:.3f} s of wall time per simulated second (mean of {len(runs)} "
            f"run{'s' if len(runs) > 1 else ''} of {sim_mean:.1f} s simulated on average), "
            f"{per75:.1f} s per {PAPER_CASE_S:.0f} s case, against the paper's {paper:.2f} s"
        )
        if per75 > 0:
            sentence += f", {paper / per75:.0f} times less"
        setup = [r["setup_time_s"] for r in runs if _ok(r.get("setup_time_s"))]
        if setup:
            sentence += f"; building the controller took {sum(setup) / len(setup):.1f} s more per run"
        med = [r["solve_time_median_s"] for r in runs if _ok(r.get("solve_time_median_s"))]
        if med:
            sentence += f"; median controller step {1e3 * sum(med) / len(med):.2f} ms"
        why.append(sentence + ".")
    if not meas:
        return Finding(text, "no FSE runs", "not run")
    measured = (
        f"wall time per {PAPER_CASE_S:.0f} s of simulated time here (controller set-up excluded): "
        + ", ".join(meas)
    )
    lo, hi = min(ratios), max(ratios)
    if lo >= 2:
        verdict = f"differs ({lo:.0f}-{hi:.0f}x faster)" if hi / lo >= 1.5 else f"differs ({lo:.0f}x faster)"
    elif hi <= 0.5:
        verdict = "differs (slower)"
    else:
        verdict = "holds"
    return Finding(text, measured, verdict, " ".join(why))


def _robust(records) -> Finding:
    """Where the paper variants fail and the robust defaults do not, from the rows alone."""
    text = "(not the paper's) The robust defaults dock wherever the paper variants do, and more"
    rows, parts, why, worse = list(records), [], [], []
    for ctrl in CONTROLLERS:
        label = controller_label(ctrl)
        paper, robust = _runs(rows, f"{ctrl}@paper"), _runs(rows, ctrl)
        both = sorted(set(paper) & set(robust))
        if not both:
            continue
        dp = {c for c in both if paper[c]["docked"]}
        dr = {c for c in both if robust[c]["docked"]}
        parts.append(f"{label}: paper {len(dp)}/{len(both)}, robust {len(dr)}/{len(both)}")
        for c in sorted(dr - dp):
            p = paper[c]
            bits = [f"{label} case {c}: the paper variant"]
            ca, tol = p.get("closest_approach_m"), p.get("tolerance_m")
            if _ok(ca) and _ok(tol) and float(tol) > 0:
                ratio = float(ca) / float(tol)
                bits.append(f"came no closer than {float(ca):.3f} m ({ratio:.1f} times the tolerance)")
            if _ok(p.get("flow_final_error_m_s")):
                bits.append(f"with its flow estimate {p['flow_final_error_m_s']:.3f} m/s off at the end")
            bits.append(f"; the robust default docked at {robust[c]['time_to_dock_s']:.2f} s")
            why.append(" ".join(bits[:-1]) + bits[-1] + ".")
        for c in sorted(dp - dr):
            worse.append(_why_not_docked(c, robust[c]).replace("Case", f"{label} (robust), case", 1))
    if not parts:
        return Finding(text, "needs NAME and NAME@paper runs of the same cases", "not run")
    measured = "docked: " + "; ".join(parts)
    verdict = "holds" if not worse else "differs"
    return Finding(text, measured, verdict, " ".join(why + worse))


def check_findings(records: Sequence[dict[str, Any]]) -> list[Finding]:
    """Check each finding of docs/parameter-sources.md section 5b against a campaign's table rows.

    A finding is checked on the cases the campaign ran (and says so when that is not all six);
    one with no runs to check is "not run".  Every explanation is built from the rows' own
    figures (module docstring).
    """
    return [
        _docking(records, "oracle", _ALL),
        _docking(records, "sequential", _ALL),
        _docking(records, "optimized", _ALL),
        _docking(records, "naive", frozenset({1, 5})),
        _docking(records, "kinematic", frozenset({1, 5})),
        _travel(records),
        _rmse(records),
        _compute(records),
        _robust(records),
    ]
