"""The topside end of the MAVLink link to an ArduSub vehicle (pymavlink).

:class:`MavlinkLink` connects, waits for the vehicle's HEARTBEAT, sends our own HEARTBEAT
at 1 Hz as a ground station, reads every message in a background thread (keeping the
latest of each type with its arrival time), changes modes, arms and disarms with the
result checked, requests telemetry rates, streams RC_CHANNELS_OVERRIDE, and records the
whole session both ways in a MAVLink ``.tlog`` that MAVProxy and QGroundControl replay
(8-byte big-endian microseconds since the epoch, then the raw message).

Facts from ArduSub's source this follows:

* RC_CHANNELS_OVERRIDE and MANUAL_CONTROL count only from the GCS system id (parameter
  SYSID_MYGCS, default 255), so we send as 255 unless told otherwise;
* in an override, ``UINT16_MAX`` means "ignore this channel" and 0 "release it to the RC
  radio"; an override lapses 3 s after the last message;
* flight modes are custom_mode numbers (:data:`auvdock.vehicle.ardusub.MODES`);
* arming is MAV_CMD_COMPONENT_ARM_DISARM, answered with COMMAND_ACK, and shows as the
  MAV_MODE_FLAG_SAFETY_ARMED bit of HEARTBEAT.base_mode;
* telemetry rates are set with MAV_CMD_SET_MESSAGE_INTERVAL (param3 = 0).

Every wait (the heartbeat, a COMMAND_ACK, a mode or the armed bit, the reader's and the
heartbeat thread's pauses) and every time stamp (message ages, tlog records) goes through
the link's :class:`auvdock.runtime.clock.Clock`: the wall clock by default, or a
:class:`auvdock.runtime.clock.SimClock` shared with :class:`auvdock.standins.vehicle_sim.VehicleSim`
to fly in simulated time (UDP connections only).
"""

from __future__ import annotations

import inspect
import re
import socket
import struct
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auvdock.runtime.clock import Clock, ClockClosedError, wall_clock
from auvdock.vehicle.ardusub import MODES, NEUTRAL_CHANNELS

__all__ = ["LinkError", "MavlinkLink", "connection_string", "check_host", "for_session", "PILOT_INPUT_TYPES"]

mavlink = mavutil.mavlink
UINT16_MAX = 65535
GCS_COMPONENT = mavlink.MAV_COMP_ID_MISSIONPLANNER  # 190
#: Most received messages kept for :meth:`MavlinkLink.drain` (a session drains every step).
INBOX_MAX = 100_000


#: Pilot input a ground station sends; seen from another system, it means someone else is flying.
PILOT_INPUT_TYPES = ("MANUAL_CONTROL", "RC_CHANNELS_OVERRIDE")


def for_session(msg: Any, vehicle_system: int, own_system: int) -> bool:
    """Whether a received message goes to the session (:meth:`MavlinkLink.drain`): the
    vehicle's own messages, LANDING_TARGET from anyone (a positioning system on the link), ODOMETRY
    from any other system (a dock's motion unit: :mod:`auvdock.fly.dock_telemetry`), the session's own
    records in its tlog (DEBUG_FLOAT_ARRAY: the camera's fixes, :mod:`auvdock.fly.camera_sensor`),
    and pilot input (MANUAL_CONTROL, RC_CHANNELS_OVERRIDE) from any system but ours (another
    ground station taking over).  One rule for the link and for a replay of its tlog."""
    mtype = msg.get_type()
    src = msg.get_srcSystem()
    if src == vehicle_system or mtype == "LANDING_TARGET":
        return True
    if mtype == "ODOMETRY" and src != own_system:  # a dock's motion unit, its own system (fly.dock_telemetry)
        return True
    if mtype == "DEBUG_FLOAT_ARRAY" and src == own_system:  # the session's own records (a replayed tlog's)
        return True
    return mtype in PILOT_INPUT_TYPES and src != own_system


class LinkError(RuntimeError):
    """The vehicle did not answer as expected (no heartbeat, command refused, ...)."""


_SHORT_UDP = re.compile(r"^udp:(\d+)$")
_NETWORK = re.compile(r"^(udp|udpin|udpout|udpbcast|tcp|tcpin):([^:]+):([^:]*)$")
_SERIAL = re.compile(r"^(/dev/[^,\s]+|COM\d+)(?:,(\d+))?$", re.IGNORECASE)

#: What ``--port`` takes, for error messages.
PORT_FORMS = (
    "udp:PORT, udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or a serial device[,BAUD]"
)


def _port_number(text: str) -> int:
    if not text.isdigit():
        raise ValueError(f"port {text!r} is not a number")
    n = int(text)
    if not 1 <= n <= 65535:
        raise ValueError(f"port number {n} outside 1..65535")
    return n


def check_host(host: str) -> None:
    """Whether ``host`` (a name or an address) resolves, by the system's resolver (``getaddrinfo``: an
    address at once, a name by the hosts file and DNS, never a connection).  A name under ``invalid``
    never resolves (RFC 6761) and is refused without asking.

    Raises
    ------
    ValueError
        ``cannot resolve host 'HOST'``.
    """
    name = host.rstrip(".").lower()
    if name == "invalid" or name.endswith(".invalid"):
        raise ValueError(f"cannot resolve host {host!r}")
    try:
        socket.getaddrinfo(host, None)
    except (OSError, UnicodeError):  # socket.gaierror; a name IDNA cannot encode
        raise ValueError(f"cannot resolve host {host!r}") from None


def connection_string(port: str, *, resolve: bool = True) -> str:
    """The pymavlink connection string for ``--port``, checked.

    ``udp:PORT`` (the short form, which pymavlink rejects) means listen on ``0.0.0.0:PORT``,
    where BlueOS sends the vehicle's MAVLink; ``udpin:``, ``udpout:``, ``udp:``, ``udpbcast:``,
    ``tcp:`` and ``tcpin:`` with ``HOST:PORT``, and a serial device (``/dev/ttyACM0``,
    ``COM3``) with an optional ``,BAUD``, pass unchanged.  With ``resolve`` the HOST must resolve
    (:func:`check_host`), so that a mistyped name is said at once, not after the connect timeout.

    Raises
    ------
    ValueError
        Naming the problem (an empty string, an unknown form, a port that is not a number or
        outside 1..65535, a host that does not resolve, a baud rate that is not a positive number).
    """
    p = port.strip()
    if not p:
        raise ValueError("empty port")
    m = _SHORT_UDP.match(p)
    if m:
        return f"udpin:0.0.0.0:{_port_number(m.group(1))}"
    m = _NETWORK.match(p)
    if m:
        _port_number(m.group(3))
        if resolve:
            check_host(m.group(2))
        return p
    m = _SERIAL.match(p)
    if m:
        if m.group(2) is not None and int(m.group(2)) <= 0:
            raise ValueError(f"baud rate {m.group(2)} must be positive")
        return p
    raise ValueError(f"not a connection string (expected {PORT_FORMS})")


def no_heartbeat_hint(port: str) -> str:
    """What to check when no ArduSub heartbeat came on ``port`` (``--port``): the clause after
    "no ArduSub heartbeat on PORT within T s" in the error line."""
    try:
        url = connection_string(port, resolve=False)
    except ValueError:
        url = port
    m = _NETWORK.match(url)
    if m is None:  # a serial device
        return f"is the autopilot connected on {url} (and at that baud rate)?"
    kind, host, number = m.groups()
    if kind in ("udp", "udpin"):  # we listen: the vehicle must send here
        at = "this computer's" if host in ("0.0.0.0", "") else f"{host}'s"
        return (
            f"is `auvdock vehicle-sim` running (it sends to udpout:127.0.0.1:14550 unless its --port says "
            f"otherwise), or the vehicle's BlueOS sending MAVLink to {at} port {number}? (BlueOS: the "
            f"MAVLink Endpoints page, a UDP Client endpoint to the topside's address and port {number}; "
            f"--port udp:{number} listens on 0.0.0.0:{number})"
        )
    if kind == "udpbcast":
        return f"is the vehicle (or `auvdock vehicle-sim`) on the network that {host} broadcasts to?"
    return (  # udpout, tcp, tcpin: the vehicle's side must listen on (or connect to) HOST:PORT
        f"is `auvdock vehicle-sim --port udpin:{host}:{number}` running, or a BlueOS MAVLink endpoint "
        f"(the MAVLink Endpoints page) serving {host}:{number}?"
    )


class MavlinkLink:
    """GCS-side MAVLink link to one ArduSub vehicle.

    Parameters
    ----------
    port : str
        Connection string (see :func:`connection_string`).
    sysid : int
        Our system id (255: ArduSub's SYSID_MYGCS default; overrides from others are ignored).
    tlog : str or Path, optional
        Record every message, both ways, to this ``.tlog`` file.
    on_event : callable, optional
        ``on_event(text)`` for link events (connected, armed, mode changed, ...); also the
        attribute ``on_event``, which a session may set after construction.
    clock : Clock, optional
        What the link waits on and stamps with (default the wall clock).
    """

    def __init__(
        self,
        port: str,
        *,
        sysid: int = 255,
        tlog: str | Path | None = None,
        on_event: Callable[[str], None] | None = None,
        clock: Clock | None = None,
    ) -> None:
        self.clock: Clock = wall_clock if clock is None else clock
        self.port = port
        self.url = connection_string(port)
        self.sysid = int(sysid)
        self.on_event = on_event
        self._lock = threading.Lock()
        self._tlog_lock = threading.Lock()
        self._latest: dict[str, tuple[Any, float]] = {}
        self._inbox: list[tuple[int, Any]] = []  # (tlog stamp us, message) not yet drained
        self._acks: list[tuple[int, int, float]] = []
        self._stop = self.clock.event()
        self._threads: list[threading.Thread] = []
        self._tlog: Any = None
        self.target_system = 1
        self.target_component = 1
        self.conn = mavutil.mavlink_connection(
            self.url, source_system=self.sysid, source_component=GCS_COMPONENT, dialect="ardupilotmega"
        )
        # the tlog once the connection is open: a port that does not open leaves no empty tlog behind
        try:
            self._tlog = open(tlog, "wb") if tlog is not None else None  # noqa: SIM115 -- closed in close()
        except OSError:
            self.conn.close()
            raise
        # speak MAVLink 2, as ArduSub does, on this connection only (pymavlink's automatic
        # upgrade would switch the whole process and replace conn.mav, losing our callback)
        self.conn.mav = mavlink2.MAVLink(self.conn, srcSystem=self.sysid, srcComponent=GCS_COMPONENT)
        self.conn.mav.robust_parsing = True
        self.conn.WIRE_PROTOCOL_VERSION = "2.0"
        self.conn.first_byte = False
        self.conn.mav.set_send_callback(self._on_send)
        params = inspect.signature(self.conn.mav.rc_channels_override_send).parameters
        self._override_v2 = "chan18_raw" in params
        self.clock.attach(self.conn)

    # -- recording ------------------------------------------------------------------------
    def _record(self, buf: bytes, inbox: Any = None) -> None:
        """Write ``buf`` to the tlog; ``inbox``: also queue this received message for
        :meth:`drain`, with the same stamp, under the same lock (so that a drain's marker
        in the tlog separates exactly the messages it took from the later ones)."""
        with self._tlog_lock:
            stamp = int(self.clock.time() * 1e6)
            if inbox is not None:
                self._inbox.append((stamp, inbox))
                if len(self._inbox) > INBOX_MAX:  # nobody drains (a link used without a session)
                    del self._inbox[: INBOX_MAX // 2]
            if self._tlog is not None and not self._tlog.closed:
                self._tlog.write(struct.pack(">Q", stamp) + bytes(buf))

    def drain(self, marker: str, value: int = 0) -> tuple[int, list[tuple[int, Any]]]:
        """The vehicle's messages received since the last drain: ``(now, [(stamp, message)])``,
        stamps in us on the tlog's clock (``now``: the drain's).

        A NAMED_VALUE_INT ``marker`` = ``value`` from our system id is written to the tlog
        (not sent) at the drain, with the same stamp, so that a replay of the tlog
        (:class:`auvdock.fly.replay.ReplayLink`) hands its session exactly the messages and
        the time this call returned.  ``marker`` is at most 10 characters (MAVLink's name field).
        """
        with self._tlog_lock:
            now = int(self.clock.time() * 1e6)
            taken, self._inbox = self._inbox, []
            if self._tlog is not None and not self._tlog.closed:
                msg = self.conn.mav.named_value_int_encode(
                    (now // 1000) % (1 << 32), marker.encode(), int(value)
                )
                self._tlog.write(struct.pack(">Q", now) + bytes(msg.pack(self.conn.mav)))
        return now, taken

    def record_rows(self, name: str, rows: list[Any]) -> None:
        """Write each row (at most 58 floats) as a DEBUG_FLOAT_ARRAY ``name`` from our system id to the tlog
        only (what replay needs and the vehicle does not: the camera's fixes)."""
        for i, row in enumerate(rows):
            data = [float(v) for v in row][:58]
            data += [0.0] * (58 - len(data))
            stamp = int(self.clock.time() * 1e6)
            msg = self.conn.mav.debug_float_array_encode(stamp, name.encode()[:10], i, data)
            self._record(msg.pack(self.conn.mav))

    def note(self, text: str) -> None:
        """Write a STATUSTEXT (INFO, at most 50 characters) from our system id to the tlog only."""
        msg = self.conn.mav.statustext_encode(mavlink.MAV_SEVERITY_INFO, text.encode()[:50])
        self._record(msg.pack(self.conn.mav))

    def _on_send(self, msg: Any) -> None:
        try:
            self._record(msg.get_msgbuf())
        except Exception:  # noqa: BLE001 -- recording never breaks the link
            pass

    def _event(self, text: str) -> None:
        if self.on_event is not None:
            self.on_event(text)

    # -- connection -----------------------------------------------------------------------
    def connect(self, timeout_s: float = 10.0) -> Any:
        """Wait for the vehicle's HEARTBEAT (an ArduPilot submarine), then start the threads.

        Raises
        ------
        LinkError
            If no ArduSub heartbeat arrives within ``timeout_s`` (the message names the port).
        """
        clock = self.clock
        deadline = clock.now() + timeout_s
        hb = None
        next_gcs_hb = clock.now()
        while clock.now() < deadline:
            if clock.now() >= next_gcs_hb:  # udpout/tcp peers need traffic to learn about us
                self._send_heartbeat()
                next_gcs_hb = clock.now() + 1.0
            msg = self._recv(min(0.2, max(0.0, deadline - clock.now())), "HEARTBEAT")
            if msg is None:
                continue
            self._record(msg.get_msgbuf())
            if (
                msg.type == mavlink.MAV_TYPE_SUBMARINE
                and msg.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
            ):
                hb = msg
                break
        if hb is None:
            raise LinkError(
                f"no ArduSub heartbeat on {self.port} within {timeout_s:g} s: {no_heartbeat_hint(self.port)}"
            )
        self.target_system = hb.get_srcSystem()
        self.target_component = hb.get_srcComponent()
        with self._lock:
            self._latest["HEARTBEAT"] = (hb, clock.now())
        self._event(f"connected to system {self.target_system} on {self.port}")
        for fn in (self._reader, self._heartbeater):
            self._threads.append(clock.start_thread(fn, name=f"mavlink-{fn.__name__.strip('_')}"))
        return hb

    def _recv(self, timeout_s: float, mtype: str | None = None) -> Any:
        """The next message (of ``mtype`` if given; others read meanwhile are dropped), or None."""
        if not self.clock.simulated:
            return self.conn.recv_match(type=mtype, blocking=True, timeout=timeout_s)
        msg = self.conn.recv_match(type=mtype, blocking=False)
        if msg is None and self.clock.wait_readable(self.conn, timeout_s):
            msg = self.conn.recv_match(type=mtype, blocking=False)
        return msg

    def close(self) -> None:
        """Stop the threads and close the connection and the tlog."""
        self._stop.set()
        for t in self._threads:
            self.clock.join(t, timeout=2.0)
        try:
            self.conn.close()
        except Exception:  # noqa: BLE001
            pass
        with self._tlog_lock:
            if self._tlog is not None and not self._tlog.closed:
                self._tlog.close()

    def __enter__(self) -> MavlinkLink:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- threads --------------------------------------------------------------------------
    def _reader(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self._recv(0.05)
            except ClockClosedError:
                return
            except Exception:  # noqa: BLE001 -- a garbled packet or a closed socket
                if self._stop.is_set():
                    return
                self.clock.sleep(0.01)
                continue
            if msg is None:
                continue
            mtype = msg.get_type()
            if mtype == "BAD_DATA":
                continue
            # the vehicle's messages, LANDING_TARGET from anyone, other stations' pilot input
            ours = for_session(msg, self.target_system, self.sysid)
            self._record(msg.get_msgbuf(), inbox=msg if ours else None)
            if msg.get_srcSystem() != self.target_system and mtype != "LANDING_TARGET":
                continue  # not the vehicle's state (another station's input is the session's)
            now = self.clock.now()
            with self._lock:
                self._latest[mtype] = (msg, now)
                if mtype == "COMMAND_ACK":
                    self._acks.append((int(msg.command), int(msg.result), now))

    def _send_heartbeat(self) -> None:
        self.conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)

    def _heartbeater(self) -> None:
        while not self._stop.wait(1.0):
            try:
                self._send_heartbeat()
            except Exception:  # noqa: BLE001
                pass

    # -- state ----------------------------------------------------------------------------
    def latest(self, mtype: str) -> tuple[Any, float]:
        """The latest message of a type and its age (s); ``(None, inf)`` if none yet."""
        with self._lock:
            item = self._latest.get(mtype)
        if item is None:
            return None, float("inf")
        return item[0], self.clock.now() - item[1]

    @property
    def armed(self) -> bool:
        hb, _ = self.latest("HEARTBEAT")
        return hb is not None and bool(hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    @property
    def mode(self) -> int | None:
        hb, _ = self.latest("HEARTBEAT")
        return None if hb is None else int(hb.custom_mode)

    # -- commands -------------------------------------------------------------------------
    def _command(self, command: int, *params: float, timeout_s: float = 3.0) -> int:
        """Send COMMAND_LONG and wait for its COMMAND_ACK; returns the MAV_RESULT."""
        p = list(params) + [0.0] * (7 - len(params))
        clock = self.clock
        t_sent = clock.now()
        self.conn.mav.command_long_send(self.target_system, self.target_component, command, 0, *p)
        deadline = t_sent + timeout_s
        while clock.now() < deadline:
            with self._lock:
                for cmd, result, t in self._acks:
                    if cmd == command and t >= t_sent:
                        return result
            clock.sleep(0.01)
        raise LinkError(f"no COMMAND_ACK for command {command} from {self.port} within {timeout_s:g} s")

    def send_command(self, command: int, *params: float) -> None:
        """Send COMMAND_LONG without waiting: its COMMAND_ACK comes with the vehicle's messages
        (:meth:`drain`), where a session that must stay replayable looks for it."""
        p = list(params) + [0.0] * (7 - len(params))
        self.conn.mav.command_long_send(self.target_system, self.target_component, command, 0, *p)

    def send_arm(self, arm: bool) -> None:
        """MAV_CMD_COMPONENT_ARM_DISARM (param1 1 arms, 0 disarms), not waited for."""
        self.send_command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if arm else 0.0)

    def send_mode(self, name: str) -> None:
        """SET_MODE to an ArduSub mode by name (e.g. ``"MANUAL"``), not waited for."""
        self.conn.mav.set_mode_send(
            self.target_system, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES[name]
        )

    def send_rate(self, message_id: int, rate_hz: float) -> None:
        """MAV_CMD_SET_MESSAGE_INTERVAL for one message, not waited for (a periodic re-request:
        a ground station such as QGroundControl or Cockpit may have reset the rates)."""
        interval_us = -1 if rate_hz <= 0 else 1e6 / rate_hz
        self.send_command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, message_id, interval_us, 0)

    def send_timesync(self, ts1_ns: int) -> None:
        """A TIMESYNC request (``tc1`` 0, ``ts1`` our time in ns): ArduPilot answers at once with its own
        time (:mod:`auvdock.fly.link_health`)."""
        self.conn.mav.timesync_send(0, int(ts1_ns))

    def request_parameters(self, names: Any) -> None:
        """PARAM_REQUEST_READ for each name; the PARAM_VALUE answers come with the vehicle's
        messages (ArduPilot answers nothing for a name it does not have)."""
        for name in names:
            self.conn.mav.param_request_read_send(
                self.target_system, self.target_component, name.encode(), -1
            )

    def _wait(self, predicate: Callable[[], bool], timeout_s: float) -> bool:
        deadline = self.clock.now() + timeout_s
        while self.clock.now() < deadline:
            if predicate():
                return True
            self.clock.sleep(0.02)
        return predicate()

    def set_mode(self, name: str, timeout_s: float = 3.0) -> None:
        """Change the flight mode (e.g. ``"MANUAL"``) and wait until the HEARTBEAT shows it."""
        number = MODES[name]
        self.conn.mav.set_mode_send(self.target_system, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number)
        if not self._wait(lambda: self.mode == number, timeout_s):
            raise LinkError(f"vehicle did not change to {name} (mode {number}) within {timeout_s:g} s")
        self._event(f"mode {name}")

    def arm(self, timeout_s: float = 3.0) -> None:
        """Arm; checks the COMMAND_ACK and the armed bit of HEARTBEAT."""
        result = self._command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout_s=timeout_s)
        if result != mavlink.MAV_RESULT_ACCEPTED:
            raise LinkError(f"arming refused by the vehicle (MAV_RESULT {result})")
        if not self._wait(lambda: self.armed, timeout_s):
            raise LinkError("arming acknowledged but the HEARTBEAT does not show armed")
        self._event("armed")

    def disarm(self, timeout_s: float = 3.0) -> bool:
        """Disarm; True if the vehicle reports disarmed.  Never raises (it is on the way out)."""
        try:
            self._command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, timeout_s=timeout_s)
        except LinkError:
            pass
        ok = self._wait(lambda: not self.armed, timeout_s)
        self._event("disarmed" if ok else "disarm not confirmed")
        return ok

    def request_rate(self, message_id: int, rate_hz: float) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL for one message; returns the MAV_RESULT."""
        interval_us = -1 if rate_hz <= 0 else 1e6 / rate_hz
        return self._command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, message_id, interval_us, 0)

    def _override(self, ch8: list[int]) -> None:
        # MAVLink 2 has channels 9..18 (0 or UINT16_MAX = ignore there); MAVLink 1 stops at 8
        extra = [0] * 10 if self._override_v2 else []
        self.conn.mav.rc_channels_override_send(self.target_system, self.target_component, *ch8, *extra)

    def send_override(self, channels_us: Any) -> tuple[int, ...]:
        """RC_CHANNELS_OVERRIDE for channels 1..6 (us); channels 7 and 8 ignored (UINT16_MAX).  Returns the
        channels 1..6 that went to the vehicle (those sent; a replayed link's are the flight's)."""
        ch = tuple(int(round(c)) for c in channels_us)
        self._override([*ch, UINT16_MAX, UINT16_MAX])
        return ch

    def send_neutral(self) -> None:
        """Neutral overrides (1500 us on channels 1..6): zero thrust in MANUAL."""
        self.send_override(NEUTRAL_CHANNELS)

    def release_overrides(self) -> None:
        """Give channels 1..8 back to the RC radio (value 0)."""
        self._override([0] * 8)
