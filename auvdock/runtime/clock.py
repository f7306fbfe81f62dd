"""One clock for everything that waits or paces: ``fly``, ``vehicle-sim``, the MAVLink link, the camera.

Code that sleeps, paces a loop, waits with a timeout or stamps a time takes a :class:`Clock`
(a constructor argument, default :class:`WallClock`) instead of calling ``time.monotonic`` /
``time.sleep`` / ``select`` itself.  Two clocks:

* :class:`WallClock` -- ``time.monotonic()``, real sleeps, ``threading`` events and
  conditions, ``select`` on sockets.  Real commands (``auvdock fly``, ``auvdock vehicle-sim``,
  ``auvdock calibrate``) use it.

* :class:`SimClock` -- simulated time for tests and rehearsals in one process: a vehicle
  simulator, a fly session, the link's threads and the camera threads run in **lockstep**
  and as fast as the computer computes, deterministically, whatever the machine's load.

How :class:`SimClock` works
---------------------------
The threads that share a SimClock are its *participants*: the thread that created it, and
every thread started with :meth:`SimClock.start_thread`.  **Exactly one participant runs at a
time** (it holds the clock's token); the others are blocked in a clock wait (``sleep``,
``sleep_until``, an :meth:`~SimClock.event`'s ``wait``, a :meth:`~SimClock.condition`'s
``wait``, :meth:`~SimClock.join`, :meth:`~SimClock.wait_readable`).  When the running
participant waits, the token goes to the waiting participant due first -- the earliest
deadline, or one that was notified (event set, condition notified, datagram sent to its
socket), which is due at once -- and simulated time jumps to that moment.  Ties go to the
participant that became due first, so a run is a fixed sequence of steps: the same inputs
give the same trajectory, to the bit, at any machine load.  Computation takes no simulated
time (a controller step, a rendered frame, a marker detection are instantaneous).

Messages still travel over real sockets (MAVLink over UDP on 127.0.0.1).  For their delivery
to be deterministic too, :meth:`SimClock.attach` wraps a pymavlink UDP connection's socket so
that the clock counts the datagrams sent to each participating socket
(:mod:`auvdock.runtime.sim_udp`): a datagram sent makes its receiver's
:meth:`~SimClock.wait_readable` due at the same simulated instant, and reading from a socket
with datagrams counted but not yet readable waits (in real time, briefly) until the kernel has
delivered them.  So a message sent at simulated time t is read at t.

Rules for code that runs under a SimClock: wait only through the clock (a participant blocked
on anything else -- ``time.sleep``, a ``threading`` primitive, a blocking socket read --
stops simulated time for everyone), and never wait through the clock while holding a lock
another participant takes.

Example (what the tests do)::

    with SimClock() as clock:
        sim = VehicleSim(mission, port=f"udpout:127.0.0.1:{port}", clock=clock).start()
        link = MavlinkLink(f"udpin:127.0.0.1:{port}", clock=clock)
        result = FlySession(mission, link, arm=True, out="run.h5").run()   # link's clock
        sim.stop()
"""

from __future__ import annotations

import itertools
import math
import select
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from auvdock.runtime.sim_udp import DatagramLedger, attach_counting, counting_socket, port_key

__all__ = [
    "Clock",
    "WallClock",
    "ScaledClock",
    "SimClock",
    "ClockClosedError",
    "ClockDeadlockError",
    "wall_clock",
]


@runtime_checkable
class Clock(Protocol):
    """What waits and paces: time, sleeps, events, conditions, threads, socket readiness."""

    #: True for simulated time (nothing waits for the wall clock).
    simulated: bool

    def now(self) -> float:
        """Monotonic time, s."""
        ...

    def time(self) -> float:
        """Seconds since the epoch (for logs: tlog stamps, event records)."""
        ...

    def sleep(self, dt: float) -> None:
        """Wait ``dt`` s (``dt <= 0``: let others due now run)."""
        ...

    def sleep_until(self, t: float) -> None:
        """Wait until :meth:`now` is ``t``."""
        ...

    def event(self) -> Any:
        """A ``threading.Event`` look-alike whose ``wait(timeout)`` counts this clock's time."""
        ...

    def condition(self) -> Any:
        """A ``threading.Condition`` look-alike (``with``, ``wait``, ``wait_for``, ``notify_all``)."""
        ...

    def start_thread(self, target: Callable[[], None], name: str, daemon: bool = True) -> threading.Thread:
        """Start a thread running ``target`` that waits through this clock."""
        ...

    def join(self, thread: threading.Thread, timeout: float | None = None) -> bool:
        """Wait for a thread to end (at most ``timeout`` s); True if it has."""
        ...

    def wait_readable(self, sock: Any, timeout: float) -> bool:
        """Wait until a socket (or pymavlink connection) has data, at most ``timeout`` s."""
        ...

    def attach(self, conn: Any) -> None:
        """Prepare a pymavlink connection for this clock (SimClock: count its datagrams)."""
        ...


def _fd(sock: Any) -> Any:
    """Something ``select`` accepts: a socket, a file descriptor, or a pymavlink connection."""
    if isinstance(sock, int) or hasattr(sock, "fileno") and not hasattr(sock, "recv_match"):
        return sock
    port = getattr(sock, "port", None)  # pymavlink mavudp / mavtcp keep their socket here
    if port is not None and hasattr(port, "fileno"):
        return port
    return getattr(sock, "fd", sock)


class WallClock:
    """The wall clock: ``time.monotonic()``, real sleeps, threading primitives, ``select``."""

    simulated = False

    def now(self) -> float:
        return time.monotonic()

    def time(self) -> float:
        return time.time()

    def sleep(self, dt: float) -> None:
        if dt > 0:
            time.sleep(dt)

    def sleep_until(self, t: float) -> None:
        self.sleep(t - time.monotonic())

    def event(self) -> threading.Event:
        return threading.Event()

    def condition(self) -> threading.Condition:
        return threading.Condition()

    def start_thread(self, target: Callable[[], None], name: str, daemon: bool = True) -> threading.Thread:
        th = threading.Thread(target=target, name=name, daemon=daemon)
        th.start()
        return th

    def join(self, thread: threading.Thread, timeout: float | None = None) -> bool:
        if thread is not threading.current_thread():
            thread.join(timeout)
        return not thread.is_alive()

    def wait_readable(self, sock: Any, timeout: float) -> bool:
        ready, _, _ = select.select([_fd(sock)], [], [], max(0.0, timeout))
        return bool(ready)

    def attach(self, conn: Any) -> None:
        return None

    def __repr__(self) -> str:
        return "WallClock()"


#: The process's wall clock (stateless; any instance would do).
wall_clock = WallClock()


class _ScaledEvent:
    """An event of a :class:`ScaledClock`: ``wait(timeout)`` in the scaled clock's seconds."""

    def __init__(self, inner: Any, rate: float) -> None:
        self._inner, self._rate = inner, rate

    def set(self) -> None:
        self._inner.set()

    def clear(self) -> None:
        self._inner.clear()

    def is_set(self) -> bool:
        return bool(self._inner.is_set())

    def wait(self, timeout: float | None = None) -> bool:
        return bool(self._inner.wait(None if timeout is None else timeout / self._rate))


class _ScaledCondition:
    """A condition of a :class:`ScaledClock`: ``wait`` / ``wait_for`` timeouts in its seconds."""

    def __init__(self, inner: Any, rate: float) -> None:
        self._inner, self._rate = inner, rate

    def __enter__(self) -> Any:
        return self._inner.__enter__()

    def __exit__(self, *exc: object) -> Any:
        return self._inner.__exit__(*exc)

    def wait(self, timeout: float | None = None) -> bool:
        return bool(self._inner.wait(None if timeout is None else timeout / self._rate))

    def wait_for(self, predicate: Callable[[], Any], timeout: float | None = None) -> Any:
        return self._inner.wait_for(predicate, None if timeout is None else timeout / self._rate)

    def notify(self, n: int = 1) -> None:
        self._inner.notify(n)

    def notify_all(self) -> None:
        self._inner.notify_all()


class ScaledClock:
    """Another clock (the wall clock) run at ``rate`` times its speed: a rehearsal slower than real time.

    A machine that cannot simulate a vehicle, its firmware (ArduSub SITL) and its camera in real time can
    run them all slower, at one rate: SITL with ``--speedup RATE``, and auvdock's commands on this clock
    (``auvdock --clock-rate RATE ...``), so that every program agrees on how long a control period is.
    ``now()`` and ``time()`` advance ``rate`` seconds per second of ``base``; a wait of ``d`` s lasts
    ``d / rate`` s of ``base``.  A vehicle runs at the wall clock: ``fly`` refuses a rate other than 1
    unless the vehicle is a simulator running at the same rate (SITL's ``SIM_SPEEDUP``).

    Parameters
    ----------
    base : Clock
        The clock scaled (the wall clock; a :class:`SimClock` in tests).
    rate : float
        Seconds of this clock per second of ``base`` (> 0; 0.5: half speed).
    """

    def __init__(self, base: Clock, rate: float) -> None:
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"ScaledClock: rate must be positive, got {rate!r}")
        self.base = base
        self.rate = float(rate)
        self.simulated = base.simulated
        self._base0 = base.now()
        self._epoch0 = base.time()

    def now(self) -> float:
        return self._base0 + (self.base.now() - self._base0) * self.rate

    def time(self) -> float:
        return self._epoch0 + (self.base.time() - self._epoch0) * self.rate

    def sleep(self, dt: float) -> None:
        self.base.sleep(dt / self.rate)

    def sleep_until(self, t: float) -> None:
        self.base.sleep_until(self._base0 + (t - self._base0) / self.rate)

    def event(self) -> _ScaledEvent:
        return _ScaledEvent(self.base.event(), self.rate)

    def condition(self) -> _ScaledCondition:
        return _ScaledCondition(self.base.condition(), self.rate)

    def start_thread(self, target: Callable[[], None], name: str, daemon: bool = True) -> threading.Thread:
        return self.base.start_thread(target, name, daemon)

    def join(self, thread: threading.Thread, timeout: float | None = None) -> bool:
        return self.base.join(thread, None if timeout is None else timeout / self.rate)

    def wait_readable(self, sock: Any, timeout: float) -> bool:
        return self.base.wait_readable(sock, timeout / self.rate)

    def attach(self, conn: Any) -> None:
        self.base.attach(conn)

    def __repr__(self) -> str:
        return f"ScaledClock({self.base!r}, rate={self.rate:g})"


class ClockClosedError(RuntimeError):
    """The SimClock was closed while (or before) this thread waited on it."""


class ClockDeadlockError(RuntimeError):
    """Every participant of a SimClock waits with no deadline: nothing could ever happen."""


class _Participant:
    __slots__ = ("name", "thread", "waiting", "due", "keys", "notified", "cv")

    def __init__(self, name: str, lock: threading.Lock) -> None:
        self.name = name
        self.thread: threading.Thread | None = None
        self.waiting = False
        self.due: tuple[float, int] = (math.inf, 0)
        self.keys: tuple[Any, ...] = ()
        self.notified = False
        self.cv = threading.Condition(lock)


class SimClock:
    """Simulated time shared by threads in lockstep (see the module docstring).

    Parameters
    ----------
    start : float
        The initial :meth:`now`, s.
    epoch : float
        :meth:`time` at ``now() == 0`` (s since the epoch; a fixed date, so logs are reproducible).
    delivery_timeout_s : float
        Longest real wait for a counted datagram to become readable (it takes microseconds on
        loopback; this only bounds a lost datagram, which is then forgotten).

    The creating thread is the first participant and holds the token.  Use as a context
    manager (or call :meth:`close`) so that participants left waiting are released.
    """

    simulated = True

    def __init__(self, start: float = 0.0, *, epoch: float = 1.7e9, delivery_timeout_s: float = 10.0) -> None:
        self._now = float(start)
        self._epoch = float(epoch)
        self.delivery_timeout_s = float(delivery_timeout_s)
        self._lock = threading.Lock()
        self._seq = itertools.count()
        self._parts: list[_Participant] = []
        self._by_thread: dict[threading.Thread, _Participant] = {}
        self._closed = False
        me = _Participant(threading.current_thread().name, self._lock)
        me.thread = threading.current_thread()
        self._parts.append(me)
        self._by_thread[me.thread] = me
        self._owner: _Participant | None = me
        #: Datagram accounting of the attached sockets, by local UDP port of the receiving socket.
        self.datagrams = DatagramLedger(self._lock, self._notify)

    # -- time ----------------------------------------------------------------------------
    def now(self) -> float:
        return self._now

    def time(self) -> float:
        return self._epoch + self._now

    def sleep(self, dt: float) -> None:
        self._wait(self._now + max(0.0, float(dt)), ())

    def sleep_until(self, t: float) -> None:
        self._wait(float(t), ())

    # -- primitives ------------------------------------------------------------------------
    def event(self) -> _SimEvent:
        return _SimEvent(self)

    def condition(self) -> _SimCondition:
        return _SimCondition(self)

    def start_thread(self, target: Callable[[], None], name: str, daemon: bool = True) -> threading.Thread:
        """Start a participant thread; it first runs when the caller next waits (same instant)."""
        part = _Participant(name, self._lock)

        def run() -> None:
            with self._lock:
                while self._owner is not part and not self._closed:
                    part.cv.wait()
                part.waiting = False
                closed = self._closed
            try:
                if not closed:
                    target()
            except ClockClosedError:
                pass
            finally:
                self._leave(part)

        th = threading.Thread(target=run, name=name, daemon=daemon)
        part.thread = th
        with self._lock:
            if self._closed:
                raise ClockClosedError("the simulated clock is closed")
            part.waiting = True
            part.due = (self._now, next(self._seq))
            self._parts.append(part)
            self._by_thread[th] = part
        th.start()
        return th

    def join(self, thread: threading.Thread, timeout: float | None = None) -> bool:
        with self._lock:
            part = self._by_thread.get(thread)
        if part is None:  # not (or no longer) a participant: it runs or ends on its own
            thread.join(None if timeout is None else 5.0)
            return not thread.is_alive()
        deadline = math.inf if timeout is None else self._now + max(0.0, timeout)
        key = ("exit", part)
        while True:
            with self._lock:
                gone = part not in self._parts
            if gone or self._now >= deadline:
                break
            self._wait(deadline, (key,))
        if gone:
            thread.join(5.0)  # it has left the clock; only its last Python lines remain
        return not thread.is_alive()

    def wait_readable(self, sock: Any, timeout: float) -> bool:
        """Due when a counted datagram is sent to ``sock``'s port (or at once if data is there)."""
        csock = counting_socket(sock)
        deadline = self._now + max(0.0, timeout)
        while True:
            if csock is not None and csock.local_port is not None:
                port = csock.local_port
                if self.datagrams.pending(port) > 0:
                    return True
            else:
                port = None
            ready, _, _ = select.select([_fd(sock)], [], [], 0)  # data from senders not counted
            if ready:
                return True
            if self._now >= deadline:
                return False
            self._wait(deadline, (port_key(port),) if port is not None else ())

    def attach(self, conn: Any) -> None:
        """Count the datagrams of a pymavlink UDP connection (``udpin:`` / ``udpout:``).

        Raises
        ------
        ValueError
            For a connection that is not UDP (serial and TCP links are not simulated).
        """
        attach_counting(conn, self)

    # -- life ------------------------------------------------------------------------------
    def close(self) -> None:
        """Release every waiting participant (their clock waits raise :class:`ClockClosedError`)."""
        with self._lock:
            self._closed = True
            for p in self._parts:
                p.cv.notify_all()

    @property
    def closed(self) -> bool:
        return self._closed

    def __enter__(self) -> SimClock:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        names = ", ".join(p.name for p in self._parts)
        return f"SimClock(now={self._now:.6f}, participants=[{names}])"

    # -- scheduler -------------------------------------------------------------------------
    def _current(self) -> _Participant:
        part = self._by_thread.get(threading.current_thread())
        if part is None:
            raise RuntimeError(
                f"thread {threading.current_thread().name!r} is not a participant of this SimClock "
                "(start threads with clock.start_thread)"
            )
        return part

    def _wait(self, deadline: float, keys: tuple[Any, ...]) -> bool:
        """Block the calling participant until ``deadline`` or a notification on one of ``keys``.

        Returns True if it was notified.
        """
        with self._lock:
            if self._closed:
                raise ClockClosedError("the simulated clock is closed")
            me = self._current()
            if self._owner is not me:  # pragma: no cover - a broken invariant
                raise RuntimeError(f"SimClock: {me.name!r} waits without holding the clock")
            me.waiting = True
            me.keys = keys
            me.notified = False
            me.due = (max(deadline, self._now), next(self._seq))
            nxt = min((p for p in self._parts if p.waiting), key=lambda p: p.due)
            if nxt.due[0] == math.inf:
                me.waiting = False
                me.keys = ()
                waiting = ", ".join(p.name for p in self._parts)
                raise ClockDeadlockError(f"SimClock: every participant waits with no deadline ({waiting})")
            self._hand_to(nxt)
            interrupted: BaseException | None = None
            while self._owner is not me and not self._closed:
                try:
                    me.cv.wait()
                except BaseException as e:  # Ctrl-C in the main thread: raise it in turn, in lockstep
                    interrupted = e
            me.waiting = False
            me.keys = ()
            if interrupted is not None:
                raise interrupted
            if self._closed:
                raise ClockClosedError("the simulated clock is closed")
            return me.notified

    def _hand_to(self, part: _Participant) -> None:
        """Give the token to ``part`` (lock held), advancing time to its due instant."""
        if part.due[0] > self._now and part.due[0] != math.inf:
            self._now = part.due[0]
        self._owner = part
        part.cv.notify_all()

    def _notify(self, key: Any) -> None:
        """Make the participants waiting on ``key`` due now (callable from any thread)."""
        with self._lock:
            for p in self._parts:
                if p.waiting and key in p.keys:
                    p.notified = True
                    p.due = min(p.due, (self._now, next(self._seq)))

    def _leave(self, part: _Participant) -> None:
        with self._lock:
            if part in self._parts:
                self._parts.remove(part)
            if part.thread is not None:
                self._by_thread.pop(part.thread, None)
            key = ("exit", part)
            for p in self._parts:
                if p.waiting and key in p.keys:
                    p.notified = True
                    p.due = min(p.due, (self._now, next(self._seq)))
            if self._owner is part:
                self._owner = None
                waiting = [p for p in self._parts if p.waiting]
                if waiting:
                    self._hand_to(min(waiting, key=lambda p: p.due))


class _SimEvent:
    """``threading.Event`` in simulated time."""

    def __init__(self, clock: SimClock) -> None:
        self._clock = clock
        self._flag = False

    def is_set(self) -> bool:
        return self._flag

    def set(self) -> None:
        self._flag = True
        self._clock._notify(self)

    def clear(self) -> None:
        self._flag = False

    def wait(self, timeout: float | None = None) -> bool:
        clock = self._clock
        deadline = math.inf if timeout is None else clock.now() + max(0.0, timeout)
        while not self._flag and clock.now() < deadline:
            clock._wait(deadline, (self,))
        return self._flag


class _SimCondition:
    """``threading.Condition`` in simulated time (its lock is a plain, non-reentrant lock)."""

    def __init__(self, clock: SimClock) -> None:
        self._clock = clock
        self._lock = threading.Lock()

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        return self._lock.acquire(blocking, timeout)

    def release(self) -> None:
        self._lock.release()

    def __enter__(self) -> _SimCondition:
        self._lock.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self._lock.release()

    def wait(self, timeout: float | None = None) -> bool:
        clock = self._clock
        deadline = math.inf if timeout is None else clock.now() + max(0.0, timeout)
        self._lock.release()
        try:
            return clock._wait(deadline, (self,))
        finally:
            self._lock.acquire()

    def wait_for(self, predicate: Callable[[], Any], timeout: float | None = None) -> Any:
        clock = self._clock
        deadline = math.inf if timeout is None else clock.now() + max(0.0, timeout)
        result = predicate()
        while not result:
            left = deadline - clock.now()
            if left <= 0:
                break
            self.wait(None if left == math.inf else left)
            result = predicate()
        return result

    def notify(self, n: int = 1) -> None:
        self._clock._notify(self)

    def notify_all(self) -> None:
        self._clock._notify(self)
