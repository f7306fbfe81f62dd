"""auvdock.runtime.clock: the wall clock, and the simulated clock that runs threads in lockstep."""

from __future__ import annotations

import socket
import threading

import pytest
from pymavlink import mavutil

from auvdock.runtime.clock import Clock, ClockClosedError, ClockDeadlockError, SimClock, WallClock, wall_clock

HOST = "127.0.0.1"


def test_both_clocks_are_clocks() -> None:
    assert isinstance(wall_clock, Clock) and isinstance(SimClock(), Clock)
    assert not WallClock.simulated and SimClock.simulated


def test_wall_clock_basics() -> None:
    c = WallClock()
    t0 = c.now()
    c.sleep(0.001)
    assert c.now() > t0
    ev = c.event()
    assert not ev.wait(0.0)
    ev.set()
    assert ev.wait(0.0)
    with (
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as a,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as b,
    ):
        a.bind((HOST, 0))
        assert not c.wait_readable(a, 0.0)
        b.sendto(b"x", a.getsockname())
        assert c.wait_readable(a, 5.0)
    done = []
    th = c.start_thread(lambda: done.append(1), "w")
    assert c.join(th, 5.0) and done == [1]


def test_sleeping_advances_simulated_time_only() -> None:
    with SimClock(start=10.0) as c:
        c.sleep(3600.0)
        assert c.now() == 3610.0
        c.sleep_until(3600.0)  # in the past: returns at once
        assert c.now() == 3610.0
        assert c.time() == pytest.approx(1.7e9 + 3610.0)


def test_participants_take_turns_in_time_order_then_first_come() -> None:
    with SimClock() as c:
        log: list[tuple[str, float]] = []

        def worker(name: str, period: float, n: int) -> None:
            for _ in range(n):
                c.sleep(period)
                log.append((name, c.now()))

        a = c.start_thread(lambda: worker("a", 0.3, 4), "a")
        b = c.start_thread(lambda: worker("b", 0.5, 3), "b")
        c.join(a)
        c.join(b)
        assert [t for _, t in log] == sorted(t for _, t in log)
        assert log[:4] == [("a", 0.3), ("b", 0.5), ("a", 0.6), ("a", 0.8999999999999999)]
        # a tie (a at 1.2, b at 1.0, 1.5 ...): the one that went to sleep first runs first
        assert log == sorted(log, key=lambda e: e[1])


def test_only_one_participant_runs_at_a_time() -> None:
    with SimClock() as c:
        running = [0]
        worst = [0]

        def busy() -> None:
            for _ in range(200):
                running[0] += 1
                worst[0] = max(worst[0], running[0])
                x = 0
                for i in range(200):  # give another thread a chance to run, if it could
                    x += i
                running[0] -= 1
                c.sleep(0.001)

        threads = [c.start_thread(busy, f"busy{i}") for i in range(4)]
        for th in threads:
            c.join(th)
        assert worst[0] == 1


def test_event_set_wakes_a_waiter_at_the_same_instant() -> None:
    with SimClock() as c:
        ev = c.event()
        woke: list[float] = []

        def waiter() -> None:
            assert ev.wait(10.0)
            woke.append(c.now())

        th = c.start_thread(waiter, "waiter")
        c.sleep(2.5)
        ev.set()
        c.join(th)
        assert woke == [2.5]
        ev2 = c.event()
        assert not ev2.wait(1.0) and c.now() == 3.5  # a timeout is simulated time too


def test_condition_wait_for_and_notify() -> None:
    with SimClock() as c:
        cond = c.condition()
        items: list[int] = []
        got: list[tuple[int, float]] = []

        def consumer() -> None:
            with cond:
                while len(got) < 3:
                    assert cond.wait_for(lambda: items, timeout=5.0)
                    got.append((items.pop(0), c.now()))

        th = c.start_thread(consumer, "consumer")
        for k in range(3):
            c.sleep(1.0)
            with cond:
                items.append(k)
                cond.notify_all()
        c.join(th)
        assert got == [(0, 1.0), (1, 2.0), (2, 3.0)]
        with cond:
            assert not cond.wait_for(lambda: False, timeout=0.5)
        assert c.now() == 3.5


def test_join_times_out_in_simulated_time() -> None:
    with SimClock() as c:
        th = c.start_thread(lambda: c.sleep(100.0), "sleeper")
        assert not c.join(th, timeout=1.0) and c.now() == 1.0
        assert c.join(th) and c.now() == 100.0


def test_waiting_forever_alone_is_a_deadlock_not_a_hang() -> None:
    with SimClock() as c:
        with pytest.raises(ClockDeadlockError, match="every participant waits with no deadline"):
            c.event().wait()


def test_a_thread_outside_the_clock_cannot_wait_on_it() -> None:
    with SimClock() as c:
        errors: list[BaseException] = []

        def outsider() -> None:
            try:
                c.sleep(1.0)
            except RuntimeError as e:
                errors.append(e)

        th = threading.Thread(target=outsider)
        th.start()
        th.join(10.0)
        assert errors and "not a participant" in str(errors[0])


def test_close_releases_waiting_participants() -> None:
    c = SimClock()
    errors: list[BaseException] = []
    ev = c.event()

    def waiter() -> None:
        try:
            ev.wait()
        except ClockClosedError as e:
            errors.append(e)
            raise

    th = c.start_thread(waiter, "waiter")
    c.sleep(1.0)  # the waiter runs and waits forever on ev
    c.close()
    th.join(10.0)
    assert not th.is_alive() and len(errors) == 1
    with pytest.raises(ClockClosedError):
        c.sleep(1.0)


def test_a_datagram_is_read_at_the_instant_it_was_sent() -> None:
    """Two pymavlink UDP ends on the clock: the receiver wakes at the simulated time of the send."""
    with SimClock() as c:
        rx = mavutil.mavlink_connection(f"udpin:{HOST}:0", source_system=1)
        port = rx.port.getsockname()[1]
        tx = mavutil.mavlink_connection(f"udpout:{HOST}:{port}", source_system=255)
        c.attach(rx)
        c.attach(tx)
        got: list[tuple[str, float]] = []

        def receiver() -> None:
            while len(got) < 5:
                if not c.wait_readable(rx, 10.0):
                    return
                while (m := rx.recv_match(blocking=False)) is not None:
                    got.append((m.get_type(), c.now()))

        th = c.start_thread(receiver, "rx")
        for _ in range(5):
            c.sleep(0.7)
            tx.mav.heartbeat_send(6, 8, 0, 0, 0)
        c.join(th)
        assert got == [("HEARTBEAT", pytest.approx(0.7 * (k + 1))) for k in range(5)]
        assert not c.wait_readable(rx, 2.0) and c.now() == pytest.approx(5.5)
        rx.close()
        tx.close()


def test_only_udp_connections_run_in_simulated_time() -> None:
    class Serialish:
        port = None

    with SimClock() as c, pytest.raises(ValueError, match="only UDP connections"):
        c.attach(Serialish())


def test_a_scaled_clock_runs_its_base_at_a_rate() -> None:
    """ScaledClock (``auvdock --clock-rate``): its seconds last 1 / rate of its base's, in every wait."""
    from auvdock.runtime.clock import ScaledClock

    with SimClock(start=10.0) as base:
        c = ScaledClock(base, 0.5)
        assert isinstance(c, Clock) and c.simulated and c.now() == 10.0
        c.sleep(1.0)  # one second of the scaled clock: two of its base
        assert base.now() == 12.0 and c.now() == 11.0
        c.sleep_until(12.0)
        assert base.now() == 14.0 and c.now() == 12.0
        assert c.time() == pytest.approx(1.7e9 + 10.0 + 2.0)  # the epoch's seconds scaled too
        ev = c.event()
        assert not ev.wait(0.25) and base.now() == 14.5  # a timeout of 0.25 s lasts 0.5 s of the base
        cond = c.condition()
        with cond:
            assert not cond.wait_for(lambda: False, timeout=1.0)
        assert base.now() == 16.5 and c.now() == 13.25
    with pytest.raises(ValueError, match="rate must be positive"):
        ScaledClock(wall_clock, 0.0)
