"""NEES of the navigation filter: Bar-Shalom's test, and closed-loop sim runs on the sensor suite.

    python benchmarks/navigation_consistency.py [--seeds 30] [--sim-seeds 20] [--case south]
                                                [--controller oracle] [--jobs 2] [--skip-test]
    python benchmarks/navigation_consistency.py --relative [--prior-current 1.0] [--seeds 30]

1. The consistency test (tests/test_navigation.py): the truth is the process the filter assumes
   (its prior, its model plus its process noise, current and IMU biases as random walks, the
   sensor suite's default noise figures, no latency).  Ensemble-average NEES over the seeds at
   each sampled time against the two-sided 95 % bounds chi2(N NZ)/N, and the per-seed spread.
2. Realistic: ``sim`` runs of a mission (default: paper case 3, ``south``) with
   ``estimation: filter`` and the default sensors (SensorSuite: constant per-run biases,
   rates, latencies) and the truth model in closed loop, one run per seed.  The truth NZ-state
   is the true vehicle state, the true current at the vehicle and the suite's drawn biases.
   Prints the same figures over the time all runs share, and which states dominate the NEES
   (per state, mean (e/sigma)^2, for a consistent filter 1).
3. ``--relative``: relative navigation (tests/test_navigation.py's hand-over test): no position
   fixes; the filter dead-reckons for 15 s, then the camera fixes the dock at 15 Hz.  The NEES of
   the state and of the position relative to the dock, per phase, with the filter's prior on the
   current ``--prior-current`` (m/s; the test's 0.1, the default 1.0) and on the velocity
   ``--prior-velocity``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
NAMES = (
    "x y z roll pitch yaw u v w p q r vc_n vc_e ba_x ba_y ba_z bg_x bg_y bg_z dock_n dock_e dock_d".split()
)


def _figures(title: str, t: np.ndarray, nees: np.ndarray, normed: np.ndarray, nz: int) -> None:
    """Print the ensemble NEES against its bounds, the per-seed spread and the per-state ratios."""
    from auvdock.estimation.flow_filter import chi2_quantile

    n = nees.shape[0]
    avg = nees.mean(axis=0)
    lo, hi = (chi2_quantile(p, n * nz) / n for p in (0.025, 0.975))
    inside = (avg >= lo) & (avg <= hi)
    per_seed = nees.mean(axis=1)
    print(f"\n{title}")
    print(
        f"  {n} seeds, {avg.size} times ({t[0]:.1f}-{t[-1]:.1f} s): ensemble NEES inside "
        f"[{lo:.2f}, {hi:.2f}] at {100 * inside.mean():.0f} % of the times "
        f"(below {100 * np.mean(avg < lo):.0f} %, above {100 * np.mean(avg > hi):.0f} %); "
        f"median {np.median(avg):.1f}, max {avg.max():.1f}; non-finite: {int(np.sum(~np.isfinite(nees)))}"
    )
    q = np.percentile(per_seed, [0, 25, 50, 75, 100])
    print(
        "  per-seed time-averaged NEES: min {:.1f}  p25 {:.1f}  median {:.1f}  p75 {:.1f}  max {:.1f}".format(
            *q
        )
    )
    comp = np.mean(normed**2, axis=(0, 1))
    order = np.argsort(comp)[::-1]
    print("  per state, mean (e/sigma)^2 (1 if consistent), largest first:")
    print("   " + ", ".join(f"{NAMES[i]} {comp[i]:.2f}" for i in order))
    for a, b in ((0.0, 2.0), (2.0, 10.0), (10.0, 1e9)):
        sel = (t >= a) & (t < b)
        if sel.any():
            c = np.mean(normed[:, sel] ** 2, axis=(0, 1))
            top = np.argsort(c)[::-1][:4]
            print(
                f"   t in [{a:g}, {min(b, t[-1]):g}] s: ensemble NEES {avg[sel].mean():.1f}; largest "
                + ", ".join(f"{NAMES[i]} {c[i]:.2f}" for i in top)
            )


def consistency_test(n_seeds: int, T: float) -> None:
    sys.path.insert(0, str(ROOT / "tests"))
    import casadi as ca
    from test_navigation import DT, _process_truth_run, buffered_step

    from auvdock.estimation.navigation_filter import NZ
    from auvdock.estimation.settings import NavigationSettings
    from auvdock.vehicle import load_vehicle
    from auvdock.vehicle.model import rk4
    from auvdock.vehicle.state import NX

    v = load_vehicle("bluerov2_heavy")
    x, u, vc = ca.SX.sym("x", NX), ca.SX.sym("u", v.n_thrusters), ca.SX.sym("vc", 2)
    f = lambda xx: v.model.dynamics(xx, u, ca.vertcat(vc, 0), ca.DM.zeros(3))  # noqa: E731
    step = buffered_step(ca.Function("truth", [x, u, vc], [rk4(f, x, DT, 4)]))
    t0 = time.perf_counter()
    runs = [_process_truth_run(v, step, s, NavigationSettings(), T=T, every=10) for s in range(n_seeds)]
    nees = np.array([r[0] for r in runs])
    normed = np.array([r[2] for r in runs])
    t = np.arange(nees.shape[1]) * 10 * DT
    wall = time.perf_counter() - t0
    _figures(
        f"1. truth = the filter's process (seeds 0..{n_seeds - 1}, {T:g} s, {wall:.0f} s wall)",
        t,
        nees,
        normed,
        NZ,
    )


def relative_test(n_seeds: int, prior_current: float, prior_velocity: float) -> None:
    """Section 3: dead reckoning for 15 s, then the camera's dock fixes (the test's hand-over)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import casadi as ca
    from test_navigation import DT, _process_truth_run, buffered_step

    from auvdock.estimation.flow_filter import chi2_quantile
    from auvdock.estimation.navigation_filter import NZ
    from auvdock.estimation.settings import NavigationSettings
    from auvdock.vehicle import load_vehicle
    from auvdock.vehicle.model import rk4
    from auvdock.vehicle.state import NX

    v = load_vehicle("bluerov2_heavy")
    x, u, vc = ca.SX.sym("x", NX), ca.SX.sym("u", v.n_thrusters), ca.SX.sym("vc", 2)
    f = lambda xx: v.model.dynamics(xx, u, ca.vertcat(vc, 0), ca.DM.zeros(3))  # noqa: E731
    step = buffered_step(ca.Function("truth", [x, u, vc], [rk4(f, x, DT, 4)]))
    st = NavigationSettings(prior_current_std_m_s=prior_current, prior_velocity_std_m_s=prior_velocity)
    t_cam, T = 15.0, 30.0
    t0 = time.perf_counter()
    runs = [_process_truth_run(v, step, s, st, T=T, every=10, dock_from_t=t_cam) for s in range(n_seeds)]
    times = np.arange(0.0, T + 1e-9, 10 * DT)
    print(
        f"\n3. relative navigation: dead reckoning 0-{t_cam:g} s, camera fixes of the dock after; priors "
        f"current {prior_current:g} m/s, velocity {prior_velocity:g} m/s; {n_seeds} seeds "
        f"({time.perf_counter() - t0:.0f} s wall)"
    )
    for name, values, dof in (
        ("state", np.array([r[0] for r in runs]), NZ),
        ("relative position", np.array([r[1] for r in runs]), 3),
    ):
        lo, hi = (chi2_quantile(p, n_seeds * dof) / n_seeds for p in (0.025, 0.975))
        avg = values.mean(axis=0)
        for phase, sel in (("dead reckoning", times < t_cam), ("camera", times >= t_cam + 0.5)):
            inside = float(np.mean((avg[sel] >= lo) & (avg[sel] <= hi)))
            print(
                f"  {name}, {phase}: ensemble NEES median {np.median(avg[sel]):.1f} (bounds [{lo:.2f}, "
                f"{hi:.2f}], {dof} dof), inside at {100 * inside:.0f} % of times; at the end of the phase "
                f"{avg[sel][-1]:.1f}"
            )
    normed = np.array([r[2] for r in runs])
    comp = np.mean(normed[:, times < t_cam] ** 2, axis=(0, 1))
    order = np.argsort(comp)[::-1][:6]
    print(
        "  dead reckoning, per state mean (e/sigma)^2, largest: "
        + ", ".join(f"{NAMES[i]} {comp[i]:.2f}" for i in order)
    )
    std = np.array([r[3] for r in runs])
    before = float(np.median(std[:, (times > t_cam - 1.0) & (times < t_cam)]))
    after = float(np.median(std[:, times > t_cam + 2.0]))
    print(
        f"  relative position std (largest axis): {before:.2f} m before the first fix, "
        f"{100 * after:.1f} cm after"
    )


def _sim_run(args: tuple[str, str, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """One closed-loop sim on the filter; (t, NEES, normalised errors) per control step, outcome."""
    case, controller, seed = args
    from auvdock.config.catalog import mission_path
    from auvdock.config.mission import load_mission
    from auvdock.estimation.navigation_filter import NZ
    from auvdock.loop.assemble import build_autopilot
    from auvdock.loop.simulation import run_simulation
    from auvdock.results.store import read_run
    from auvdock.sensing.simulated import SensorSuite
    from auvdock.vehicle.state import NX, POS, YAW

    m = load_mission(mission_path(case)).with_updates(estimation="filter", seed=seed)
    vehicle, dock, flow = m.build_vehicle(), m.build_dock(), m.build_flow()
    true_dock = np.asarray(m.build_dock(truth=True).position_ned_m, dtype=float)
    ap = build_autopilot(m, vehicle, dock, controller)
    # the suite run_simulation() builds draws the same biases from the same seed
    bias = {c.kind: c.bias for c in SensorSuite(m.sensors, vehicle, m.seed).channels}
    stage = ap.navigation
    assert stage is not None
    log: list[tuple[float, np.ndarray, np.ndarray]] = []
    inner = stage.step

    def step(meas, u_prev):  # type: ignore[no-untyped-def]
        out = inner(meas, u_prev)
        log.append((float(meas.t), stage.filter.z.copy(), stage.filter.P.copy()))
        return out

    stage.step = step  # type: ignore[method-assign]
    with tempfile.TemporaryDirectory() as tmp:
        summary = run_simulation(m, out=Path(tmp) / "run.h5", autopilot=ap)
        run = read_run(Path(tmp) / "run.h5")
        states = run.state[run.control_rows()]  # the true state of each control step
    assert len(states) == len(log)
    t_all, nees, normed = [], [], []
    for (t, z, P), x in zip(log, states, strict=True):
        truth = np.concatenate([x, flow.velocity(x[POS], t)[0:2], bias["accel"], bias["gyro"], true_dock])
        e = truth - z
        e[YAW] = (e[YAW] + np.pi) % (2 * np.pi) - np.pi
        t_all.append(t)
        nees.append(float(e @ np.linalg.solve(P, e)))
        normed.append(e / np.sqrt(np.diag(P)))
    assert len(e) == NZ and NX == 12
    return np.array(t_all), np.array(nees), np.array(normed), summary.outcome


def realistic(case: str, controller: str, n_seeds: int, jobs: int) -> None:
    from auvdock.estimation.navigation_filter import NZ

    t0 = time.perf_counter()
    with ProcessPoolExecutor(jobs) as ex:
        runs = list(ex.map(_sim_run, [(case, controller, s) for s in range(n_seeds)]))
    k = min(len(r[0]) for r in runs)
    t = runs[0][0][:k]
    nees = np.array([r[1][:k] for r in runs])
    normed = np.array([r[2][:k] for r in runs])
    docked = [r[3]["docked"] for r in runs]
    ends = [r[3]["end_time_s"] for r in runs]
    _figures(
        f"2. closed-loop sim: {case}, {controller} on the filter, default sensors, seeds 0..{n_seeds - 1} "
        f"({time.perf_counter() - t0:.0f} s wall); docked {sum(docked)}/{n_seeds}, "
        f"end {min(ends):.1f}-{max(ends):.1f} s",
        t[::10],
        nees[:, ::10],
        normed[:, ::10],
        NZ,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=30, help="seeds of the consistency test")
    ap.add_argument("--duration", type=float, default=40.0, help="s of each consistency-test run")
    ap.add_argument("--sim-seeds", type=int, default=20, help="seeds of the closed-loop sim runs")
    ap.add_argument("--case", default="south", help="the mission of the sim runs")
    ap.add_argument("--controller", default="oracle")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--skip-test", action="store_true", help="only the sim runs")
    ap.add_argument("--relative", action="store_true", help="only the relative-navigation test (section 3)")
    ap.add_argument("--prior-current", type=float, default=1.0, help="section 3: prior current std, m/s")
    ap.add_argument("--prior-velocity", type=float, default=0.5, help="section 3: prior velocity std, m/s")
    args = ap.parse_args()
    if args.relative:
        relative_test(args.seeds, args.prior_current, args.prior_velocity)
        return
    if not args.skip_test:
        consistency_test(args.seeds, args.duration)
    if args.sim_seeds > 0:
        realistic(args.case, args.controller, args.sim_seeds, args.jobs)


if __name__ == "__main__":
    main()
