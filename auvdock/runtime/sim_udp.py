"""UDP datagrams in simulated time: the pymavlink socket patch behind :class:`auvdock.runtime.clock.SimClock`.

Under a SimClock, messages still travel over real UDP sockets (MAVLink on 127.0.0.1), and their delivery
must be as deterministic as the clock's waits. :func:`attach_counting` (what :meth:`SimClock.attach
<auvdock.runtime.clock.SimClock.attach>` does) replaces a pymavlink UDP connection's socket by a
:class:`CountingSocket`, which tells the clock's :class:`DatagramLedger` (``clock.datagrams``) of every
datagram it sends to a participating local port and of every one it reads: a datagram sent at simulated
time t makes its receiver's ``wait_readable`` due at t, and a read from a port with datagrams counted but
not yet delivered by the kernel waits for them, in real time (microseconds on loopback, at most the clock's
``delivery_timeout_s`` s). Ports are the receiving sockets' local UDP port numbers.
"""

from __future__ import annotations

import select
import socket
import threading
from collections import Counter
from collections.abc import Callable
from typing import Any, Protocol

__all__ = [
    "CountingSocket",
    "DatagramLedger",
    "attach_counting",
    "counting_socket",
    "port_key",
]


def port_key(port: int) -> tuple[str, int]:
    """The clock wait key notified when a counted datagram is sent to local UDP port ``port``."""
    return ("port", port)


class DatagramLedger:
    """Datagrams sent to and read from each participating UDP port of one SimClock.

    Parameters
    ----------
    lock : threading.Lock
        The clock's lock (every count is read and changed under it).
    notify : callable
        ``notify(key)``: make the clock's participants waiting on ``key`` (:func:`port_key`) due now; called
        without ``lock`` held.
    """

    def __init__(self, lock: threading.Lock, notify: Callable[[Any], None]) -> None:
        self._lock = lock
        self._notify = notify
        self._ports: set[int] = set()
        self._sent: Counter[int] = Counter()
        self._received: Counter[int] = Counter()

    def register(self, port: int) -> None:
        """Count the datagrams sent to ``port`` from now on."""
        with self._lock:
            self._ports.add(port)
            self._received[port] = self._sent[port]

    def unregister(self, port: int) -> None:
        """Stop counting for ``port`` (its socket is closed)."""
        with self._lock:
            self._ports.discard(port)

    def count_sent(self, port: int) -> None:
        """A datagram was sent to ``port``: if it is counted, wake its waiting receiver."""
        with self._lock:
            if port not in self._ports:
                return
            self._sent[port] += 1
        self._notify(port_key(port))

    def pending(self, port: int) -> int:
        """Datagrams sent to ``port`` and not yet read."""
        with self._lock:
            return self._sent[port] - self._received[port]

    def count_received(self, port: int) -> None:
        """A datagram was read from ``port``."""
        with self._lock:
            if self._received[port] < self._sent[port]:
                self._received[port] += 1

    def forget(self, port: int) -> None:
        """Consider every datagram sent to ``port`` read (one was lost)."""
        with self._lock:
            self._received[port] = self._sent[port]


class CountingClock(Protocol):
    """What a counting socket needs of its clock (:class:`auvdock.runtime.clock.SimClock` has it)."""

    @property
    def datagrams(self) -> DatagramLedger: ...

    @property
    def delivery_timeout_s(self) -> float: ...


class CountingSocket:
    """A UDP socket whose datagrams the ledger of its SimClock counts (see :func:`attach_counting`)."""

    def __init__(self, sock: socket.socket, clock: CountingClock) -> None:
        self._sock = sock
        self._clock = clock
        self._ledger = clock.datagrams
        self.local_port: int | None = None
        self._register()

    def _register(self) -> None:
        try:
            port = int(self._sock.getsockname()[1])
        except OSError:
            return
        if port:
            self.local_port = port
            self._ledger.register(port)

    def sendto(self, data: bytes, *args: Any) -> int:
        n = self._sock.sendto(data, *args)
        if self.local_port is None:
            self._register()  # an unbound (udpout) socket gets its port with the first datagram
        address = args[-1]
        if isinstance(address, tuple) and len(address) >= 2:
            self._ledger.count_sent(int(address[1]))
        return n

    def recvfrom(self, bufsize: int, *args: Any) -> tuple[bytes, Any]:
        port = self.local_port
        ledger = self._ledger
        if port is not None and ledger.pending(port) > 0:
            # counted but maybe not yet delivered by the kernel: wait for it (real time, microseconds)
            ready, _, _ = select.select([self._sock], [], [], self._clock.delivery_timeout_s)
            if not ready:
                ledger.forget(port)  # lost (never on loopback); do not wait for it again
        data, address = self._sock.recvfrom(bufsize, *args)
        if port is not None:
            ledger.count_received(port)
        return data, address

    def close(self) -> None:
        if self.local_port is not None:
            self._ledger.unregister(self.local_port)
        self._sock.close()

    def fileno(self) -> int:
        return self._sock.fileno()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._sock, name)


def attach_counting(conn: Any, clock: CountingClock) -> None:
    """Count the datagrams of a pymavlink UDP connection (``udpin:`` / ``udpout:``); idempotent.

    Raises
    ------
    ValueError
        For a connection that is not UDP (serial and TCP links are not simulated).
    """
    sock = getattr(conn, "port", None)
    if isinstance(sock, CountingSocket):
        return
    if not isinstance(sock, socket.socket) or sock.type != socket.SOCK_DGRAM:
        raise ValueError(f"SimClock: only UDP connections can run in simulated time, not {conn!r}")
    conn.port = CountingSocket(sock, clock)


def counting_socket(sock: Any) -> CountingSocket | None:
    """The :class:`CountingSocket` of ``sock`` (itself, or a pymavlink connection's), else None."""
    if isinstance(sock, CountingSocket):
        return sock
    port = getattr(sock, "port", None)
    return port if isinstance(port, CountingSocket) else None
