"""The link impairment stand-in (:class:`auvdock.standins.link_relay.LinkRelay`) in simulated time:
its statistics against the settings, reproducible from a seed, and fly through it (loopback only)."""

from __future__ import annotations

import socket

import numpy as np
import pytest
from helpers.loopback import HOST, NEUTRAL, RELEASE, Loopback, overrides
from pymavlink import mavutil

from auvdock.results.store import read_run
from auvdock.runtime.clock import SimClock
from auvdock.runtime.sim_udp import CountingSocket
from auvdock.standins.link_relay import Impairment, LinkRelay


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


def _bound(clock: SimClock) -> CountingSocket:
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    raw.bind((HOST, 0))
    raw.setblocking(False)
    return CountingSocket(raw, clock)


def _relay_run(imp: Impairment, seed: int, n: int = 400, period: float = 0.01) -> tuple[list, LinkRelay]:
    """``n`` numbered datagrams every ``period`` s from a 'vehicle' through the relay to 'fly':
    [(arrival time, number)] and the relay."""
    with SimClock() as clock:
        fly = _bound(clock)
        relay = LinkRelay(fly.local_port, to_fly=imp, seed=seed, clock=clock).start()
        vehicle = _bound(clock)
        got: list[tuple[float, int]] = []

        def send() -> None:
            for i in range(n):
                vehicle.sendto(i.to_bytes(4, "big"), (HOST, relay.port))
                clock.sleep(period)

        sender = clock.start_thread(send, "vehicle")
        end = n * period + imp.delay_s + 10 * imp.jitter_s + imp.reorder_s + 0.5
        while clock.now() < end:
            if clock.wait_readable(fly, end - clock.now()):
                while True:
                    try:
                        data, _ = fly.recvfrom(64)
                    except BlockingIOError:
                        break
                    got.append((clock.now(), int.from_bytes(data, "big")))
        clock.join(sender)
        relay.stop()
        fly.close()
        vehicle.close()
    return got, relay


def test_the_relay_delays_drops_and_duplicates_as_set_and_is_reproducible() -> None:
    imp = Impairment(delay_s=0.1, jitter_s=0.03, loss=0.05, duplicate=0.05)
    got, relay = _relay_run(imp, seed=3)
    st = relay.stats["to_fly"]
    assert st.received == 400
    # binomial bounds (4 sigma) on 400 draws of 5 %
    assert 4 <= st.lost <= 36 and 4 <= st.duplicated <= 36
    assert st.delivered == len(got) == 400 - st.lost + st.duplicated
    delays = np.asarray(st.delays_s)
    assert delays.min() >= 0.0
    assert np.mean(delays) == pytest.approx(0.1, abs=4 * 0.03 / np.sqrt(delays.size))
    assert np.std(delays) == pytest.approx(0.03, rel=0.2)
    numbers = [i for _, i in got]
    assert numbers != sorted(numbers)  # 30 ms of jitter on 10 ms spacing reorders
    again, _ = _relay_run(imp, seed=3)
    assert again == got  # to the bit, from the seed
    other, _ = _relay_run(imp, seed=4)
    assert other != got


def test_an_outage_drops_everything_in_it() -> None:
    got, relay = _relay_run(Impairment(outages=((1.0, 2.0),)), seed=0)
    numbers = {i for _, i in got}
    assert relay.stats["to_fly"].lost == 100
    assert numbers == set(range(0, 100)) | set(range(200, 400))


def test_bad_impairments_are_one_clear_error() -> None:
    with pytest.raises(ValueError, match=r"link impairment: loss must be a probability in \[0, 1\], got 1.5"):
        Impairment(loss=1.5)
    with pytest.raises(ValueError, match="link impairment: delay_s must be >= 0 s, got -0.1"):
        Impairment(delay_s=-0.1)


@pytest.mark.parametrize("seed", [0])
def test_fly_docks_through_a_lightly_impaired_link(loop, tmp_path, seed) -> None:
    """20 ms +- 5 ms each way, 2 % lost, 2 % reordered, 2 % duplicated: Oracle docks tank_positioned."""
    imp = Impairment(delay_s=0.02, jitter_s=0.005, loss=0.02, reorder=0.02, duplicate=0.02)
    sim, relay, port = loop.impaired_vehicle(to_vehicle=imp, to_fly=imp, link_seed=seed, hold_start=True)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "40")
    assert res.exit_code == 0, res.output + res.stderr
    assert "docked at t =" in res.output
    for st in relay.stats.values():
        assert st.lost > 0 and st.duplicated > 0
    print(relay.summary())


def test_an_outage_longer_than_the_limit_neutral_within_a_period_then_abort(loop, tmp_path) -> None:
    """Both directions silent from 8 s of the relay's clock: fly commands neutral once the telemetry is
    older than fly.stale_neutral_s (0.3 s), within one control period, and aborts at fly.stale_abort_s
    (2 s).  Its disarm cannot reach the vehicle either: ArduSub's own failsafe (3 s without pilot
    input) disarms it."""
    cut = Impairment(outages=((8.0, 1e9),))
    sim, relay, port = loop.impaired_vehicle(to_vehicle=cut, to_fly=cut, hold_start=True)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "40")
    assert res.exit_code == 3, res.output + res.stderr
    assert res.stderr.strip().startswith("aborted: telemetry lost: no ATTITUDE, LOCAL_POSITION_NED for")
    h5 = next(tmp_path.glob("*_fly_*.h5"))
    dt = float(read_run(h5).attrs["dt_s"])
    # what fly heard and sent, from its tlog (stamped on the session's clock)
    log = mavutil.mavlink_connection(str(h5.with_suffix(".tlog")))
    heard, sent = [], []
    while (m := log.recv_match()) is not None:
        if m.get_type() == "ATTITUDE":
            heard.append(m._timestamp)
        elif m.get_type() == "RC_CHANNELS_OVERRIDE":
            sent.append((m._timestamp, tuple(getattr(m, f"chan{i}_raw") for i in range(1, 7))))
    last = max(heard)
    after = [(t, ch) for t, ch in sent if t > last + 0.3 + 1e-9]
    assert after and after[0][0] <= last + 0.3 + dt + 1e-6  # neutral within one period of going stale
    assert all(ch in (NEUTRAL, RELEASE) for _, ch in after)
    assert any(ch != NEUTRAL for t, ch in sent if t < last)  # it was flying before
    assert after[-1][0] - last <= 2.0 + dt + 1e-6  # then the abort, at 2 s of silence
    loop.clock.sleep(4.0)  # the vehicle's own pilot-input failsafe
    assert not sim.armed
    assert any(e.kind == "failsafe" for e in sim.events)
    epoch = loop.clock.time() - loop.clock.now()
    heard = [stamp - epoch for stamp, _ in overrides(sim)]
    assert heard and max(heard) <= 8.0 + 1e-6  # the vehicle heard nothing of fly after the cut
