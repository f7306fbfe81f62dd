"""Delay-aware control (issue 29, item 1): the forward prediction against the plant, the link's health
measured on TIMESYNC and sequence numbers, and fly through a 100 ms link (loopback, simulated time)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from helpers.loopback import Loopback

from auvdock.estimation.delay import CommandHistory, DelayCompensation
from auvdock.estimation.estimate import Estimate
from auvdock.fly.link_health import LinkHealth
from auvdock.fly.telemetry import age_s
from auvdock.results.store import read_run
from auvdock.standins.link_relay import Impairment
from auvdock.vehicle import load_vehicle

DT = 0.05  # the control period, s


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


def _truth(vehicle, commands: np.ndarray, delay: float, v_c: np.ndarray, t_end: float, h: float = 0.005):
    """The plant over [0, t_end] (states every h s): the command sent at k DT acts from k DT + delay."""
    step = vehicle.stepper(h, 4)
    x = np.zeros(12)
    x[2] = 1.0
    xs = [x]
    n = int(round(t_end / h))
    for i in range(n):
        t = i * h
        k = int(math.floor((t - delay) / DT + 1e-9))
        u = np.zeros(vehicle.n_thrusters) if k < 0 else commands[min(k, len(commands) - 1)]
        x = np.asarray(step(x, u, 0.0)).ravel() if not np.any(v_c) else _in_current(vehicle, x, u, v_c, h)
        xs.append(x)
    return np.array(xs), h


def _in_current(vehicle, x, u, v_c, h):
    return np.asarray(vehicle.stepper_in_current(4)(x, u, v_c, h)).ravel()


@pytest.mark.parametrize("current", [(0.0, 0.0, 0.0), (0.2, -0.22, 0.0)], ids=["still", "current"])
def test_the_forward_prediction_matches_the_delayed_truth(current) -> None:
    """Thrust changing every period (a random sequence within the thrusters' range), commands acting
    0.1 s after they are sent, a reading 0.06 s old at the step: predicted over the reading's age plus
    the command delay (0.16 s) the state matches the plant's within 2 mm and 1 mrad, 3 mm/s; holding the
    reading (no prediction) is 10 times further off."""
    vehicle = load_vehicle()
    rng = np.random.default_rng(1)
    n_cmd = 60
    commands = rng.uniform(-15.0, 15.0, size=(n_cmd, vehicle.n_thrusters))
    delay, age = 0.1, 0.06
    v_c = np.asarray(current)
    xs, h = _truth(vehicle, commands, delay, v_c, t_end=3.0)
    comp = DelayCompensation(vehicle)
    comp.command_delay_s = delay
    worst_pos = worst_ang = worst_vel = 0.0
    worst_held = 0.0
    for k in range(20, 41):
        t = k * DT
        for j in range(k):  # what fly sent up to this step
            comp.history.sent(j * DT, commands[j])
        x_read = xs[int(round((t - age) / h))]
        est = Estimate(t - age, x_read.copy(), current_ned=v_c)
        pred = comp.forward(est, t)
        assert pred.t == pytest.approx(t + delay)
        assert comp.last_horizon_s == pytest.approx(age + delay)
        x_true = xs[int(round((t + delay) / h))]
        worst_pos = max(worst_pos, float(np.linalg.norm(pred.state[0:3] - x_true[0:3])))
        worst_ang = max(worst_ang, float(np.max(np.abs(pred.state[3:6] - x_true[3:6]))))
        worst_vel = max(worst_vel, float(np.linalg.norm(pred.state[6:9] - x_true[6:9])))
        worst_held = max(worst_held, float(np.linalg.norm(x_read[0:3] - x_true[0:3])))
    print(
        f"prediction error: {worst_pos * 1e3:.3f} mm, {worst_ang * 1e3:.3f} mrad, "
        f"{worst_vel * 1e3:.3f} mm/s; the reading held: {worst_held * 1e3:.1f} mm"
    )
    assert worst_pos < 0.002 and worst_ang < 0.001 and worst_vel < 0.003
    assert worst_held > 10 * worst_pos


def test_what_acts_when_on_the_history() -> None:
    h = CommandHistory(2)
    h.sent(0.0, np.array([1.0, 0.0]))
    h.sent(0.05, np.array([2.0, 0.0]))
    h.sent(0.10, np.array([3.0, 0.0]))
    assert h.acting(0.12, 0.1)[0] == 1.0  # sent at 0 acts from 0.1
    assert h.acting(0.16, 0.1)[0] == 2.0
    assert h.acting(0.05, 0.1)[0] == 0.0  # nothing acts before the first arrives
    segs = h.segments(0.1, 0.2, 0.1)
    assert [(round(a, 3), round(b, 3), u[0]) for a, b, u in segs] == [(0.1, 0.15, 1.0), (0.15, 0.2, 2.0)]
    comp = DelayCompensation(load_vehicle())
    comp.history = h
    comp.command_delay_s = 0.1
    acted = comp.acted(0.1, 0.2)
    assert acted.mean()[0] == pytest.approx(1.5)  # half the period each
    assert acted.cuts(0.1, 0.2) == [pytest.approx(0.15)]  # where the navigation filter ends a prediction
    assert (acted.at(0.12)[0], acted.at(0.2)[0]) == (1.0, 2.0)  # the accelerometer at 0.2 reads under 2


def _msg(mtype: str, seq: int, **fields):
    return SimpleNamespace(
        get_type=lambda: mtype,
        get_srcSystem=lambda: 1,
        get_srcComponent=lambda: 1,
        get_seq=lambda: seq,
        **fields,
    )


def test_the_link_health_from_timesync_and_sequence_numbers() -> None:
    """Round trips of 0.20-0.26 s (queueing on top of 0.1 s each way), the vehicle's clock 1000 s ahead:
    the median round trip, and the offset of the fastest answer (exact: symmetric at 0.1 s each way).
    Sequence numbers with 1 in 10 missing, some late and one duplicated, wrapping past 255: 10 % lost."""
    lh = LinkHealth()
    offset = 1000.0
    msgs = []
    for i, queue in enumerate([0.0, 0.03, 0.06, 0.01, 0.02]):
        ts1 = 10.0 + i
        t_vehicle = ts1 + 0.1 + queue + offset  # the request's arrival on the vehicle's clock
        rx = ts1 + 0.2 + 2 * queue
        msgs.append((int(rx * 1e6), _msg("TIMESYNC", i, tc1=int(t_vehicle * 1e9), ts1=int(ts1 * 1e9))))
    lh.feed(msgs, 1)
    f = lh.figures()
    assert f.rtt_s == pytest.approx(0.24, abs=1e-5)  # median of 0.20, 0.26, 0.32, 0.22, 0.24
    assert f.offset_s == pytest.approx(offset, abs=1e-5)
    assert f.one_way_s == pytest.approx(0.12, abs=1e-5)
    rtts = np.array([0.20, 0.26, 0.32, 0.22, 0.24])
    assert f.jitter_s == pytest.approx(np.std(rtts) / np.sqrt(2), abs=1e-5)  # each way independent
    assert f.hold_back_s == pytest.approx(2 * f.jitter_s)
    lh2 = LinkHealth()
    seqs = [n % 256 for n in range(200, 500) if n % 10 != 3]
    seqs[50], seqs[51] = seqs[51], seqs[50]  # late
    seqs.insert(80, seqs[79])  # duplicated
    lh2.feed([(0, _msg("ATTITUDE", s)) for s in seqs], 1)
    assert lh2.figures().loss == pytest.approx(0.1, abs=0.005)
    # a reading's age on the vehicle's clock: sampled at 1010.0 s vehicle = 10.0 s ours, used at 10.25 s
    att = SimpleNamespace(time_boot_ms=1010_000)
    assert age_s(att, int(10.2e6), int(10.25e6), offset) == pytest.approx(0.25)
    assert age_s(att, int(10.2e6), int(10.25e6), None) == pytest.approx(0.05)  # on arrival


def _timesync_answers(lh: LinkHealth, sent_s, vehicle_clock, up_s, down_s) -> list[tuple[float, float]]:
    """Feed ``lh`` the answers to TIMESYNC requests sent at ``sent_s`` (s, our clock), the vehicle's clock
    ``vehicle_clock(t)`` (s) at our ``t``, each request ``up_s[i]`` on its way and its answer ``down_s[i]``;
    after each answer, (its arrival, the estimate's error against the true offset then), and the same a
    quarter second later (s)."""
    errors = []
    for i, (ts1, up, down) in enumerate(zip(sent_s, up_s, down_s, strict=True)):
        rx = ts1 + up + down
        tc1 = vehicle_clock(ts1 + up)
        lh.feed(
            [(int(round(rx * 1e6)), _msg("TIMESYNC", i % 256, tc1=int(tc1 * 1e9), ts1=int(ts1 * 1e9)))], 1
        )
        errors.append((rx, lh.figures().offset_s - (vehicle_clock(rx) - rx)))
        later = rx + 0.25  # half-way to the next answer
        errors.append((later, lh.figures().offset_now_s(later) - (vehicle_clock(later) - later)))
    return errors


def test_the_clocks_offset_follows_a_vehicle_clock_that_runs_slow() -> None:
    """A rehearsal's simulator 20 % behind its rate (the vehicle's clock at 0.8 of ours; loopback: 0.5 ms
    each way, +- 0.2): every answer is further from the estimate (0.1 s a half-second answer) than its
    queueing allows, so the estimate restarts from it and, moved on at the rate it showed, stays within a
    millisecond of the true offset (the mean of the least-queued quarter of half a minute's answers, as
    before, was up to 0.73 s off)."""
    rng = np.random.default_rng(3)
    lh = LinkHealth()
    sent = 100.0 + 0.5 * np.arange(40)
    delays = 0.0005 + rng.uniform(-0.0002, 0.0002, size=(2, sent.size))
    errors = _timesync_answers(lh, sent, lambda t: 5.0 + 0.8 * (t - 100.0), delays[0], delays[1])
    # judged from the fifth answer (four give the link's jitter): each restarts the estimate, which then
    # moves on at the rate it showed (since the answer before: right from the sixth)
    assert max(abs(e) for _, e in errors[10:]) < 0.001
    assert lh.drift_restarts == sent.size - 4


@pytest.mark.parametrize("link", ["jitter both ways", "delay step", "half-way step"])
def test_the_clocks_offset_holds_through_jitter_and_a_changing_delay(link) -> None:
    """The vehicle's clock at our rate: 100 ms +- 30 ms each way (independent), or 1 ms each way going to
    500 ms (both ways, or an answer that came back at 500 ms on a request that went at 1 ms): no answer is
    taken for a clock at another rate, and the estimate stays within the jitter's reach of the truth."""
    rng = np.random.default_rng(4)
    lh = LinkHealth()
    sent = 50.0 + 0.5 * np.arange(80)
    if link == "jitter both ways":
        up, down = 0.07 + rng.uniform(0.0, 0.06, size=(2, sent.size))
    else:
        up = np.where(np.arange(sent.size) < 40, 0.001, 0.5)
        down = up.copy()
        if link == "half-way step":
            up[40] = 0.001
    errors = _timesync_answers(lh, sent, lambda t: t + 1234.5, up, down)
    assert lh.drift_restarts == 0
    assert max(abs(e) for _, e in errors[16:]) < (0.015 if link == "jitter both ways" else 0.001)


@pytest.mark.slow
# (and oracle with seed 1 until 2026-12-07: the suite's 8 minutes)
@pytest.mark.parametrize(("controller", "seed"), [("oracle", 0), ("sequential", 1)])
def test_fly_docks_through_100_ms_with_jitter_and_loss(loop, tmp_path, controller, seed) -> None:
    """The first figure's link: 100 ms +- 30 ms and 5 % lost each way.  With the forward prediction Oracle
    (on the autopilot's state) and Sequential FSE-MPC (on the navigation filter, its readings held back
    for the jitter) dock tank_positioned and the truth comes within the tolerance; the round trip is
    measured (about 0.2 s) and recorded with every row, and each estimate was predicted over its age plus
    the command's delay (about 0.1 s + the reading's age)."""
    from auvdock.standins.truth_check import check_flight

    imp = Impairment(delay_s=0.1, jitter_s=0.03, loss=0.05)
    truth = tmp_path / "truth.h5"
    sim, relay, port = loop.impaired_vehicle(
        to_vehicle=imp, to_fly=imp, link_seed=seed, seed=seed, noise=True, hold_start=True, truth_out=truth
    )
    extra = ["-c", controller] + ([] if controller == "oracle" else ["--estimation", "filter"])
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "60", *extra)
    sim.stop()
    assert res.exit_code == 0, res.output + res.stderr
    flight = next(tmp_path.glob("*_fly_*.h5"))
    c = check_flight(flight, truth)
    assert c.verdict_right and c.truth_closest_m <= c.tolerance_m
    r = read_run(flight)
    rtt = r.extras["link_round_trip_s"][r.control_rows()]
    assert 0.15 < float(np.median(rtt)) < 0.3
    lead = r.extras["estimate_lead_s"][r.control_rows()]
    assert 0.1 < float(np.median(lead)) < 0.3
    assert 0.0 < float(np.nanmax(r.extras["link_loss"])) < 0.15
    last = res.output.strip().splitlines()[-1]
    print(f"{controller} seed {seed}: {last}; truth closest {c.truth_closest_m:.3f} m")


def test_a_link_beyond_its_round_trip_limit_refuses_to_arm(loop, tmp_path) -> None:
    imp = Impairment(delay_s=0.45)
    sim, relay, port = loop.impaired_vehicle(to_vehicle=imp, to_fly=imp, hold_start=True)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "20")
    assert res.exit_code == 3, res.output
    line = "aborted: refusing to arm: link: round trip 900 ms, above fly.max_round_trip_s 800 ms"
    assert res.stderr.strip() == line
    assert not sim.armed


def test_a_link_going_bad_in_flight_holds_neutral_then_aborts(loop, tmp_path) -> None:
    """From 10 s the link's delay goes to 0.5 s each way: once the median round trip is above 0.8 s fly
    holds neutral (no controller step, nothing but neutral sent), and after fly.link_hold_s (3 s) aborts
    with one line saying which limit."""
    sim, relay, port = loop.impaired_vehicle(hold_start=True)
    clock = loop.clock

    def worsen() -> None:
        clock.sleep_until(10.0)
        slow = Impairment(delay_s=0.5)
        relay.impairments = {"to_vehicle": slow, "to_fly": slow}

    clock.start_thread(worsen, "worsen-link")
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "60")
    assert res.exit_code == 3, res.output + res.stderr
    assert res.stderr.strip().startswith("aborted: link: round trip ")
    assert res.stderr.strip().endswith("above fly.max_round_trip_s 800 ms for 3.0 s (fly.link_hold_s)")
    assert "holding (neutral) for up to 3 s" in res.output
    r = read_run(next(tmp_path.glob("*_fly_*.h5")))
    assert r.time_s[-1] < 30.0
