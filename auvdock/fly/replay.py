"""``auvdock replay``: rerun a recorded flight's estimator and controller at a desk.

A ``fly`` session takes the vehicle's messages from its link once per step
(:meth:`auvdock.fly.link.MavlinkLink.drain`) and marks each such moment in its tlog with
a NAMED_VALUE_INT ``auvd_*`` record from its own system id (written to the tlog, never
sent).  :class:`ReplayLink` reads the tlog back and plays the vehicle's part: each drain of
the replayed session returns exactly the messages the flight's drain returned, with the
same time stamps, and its clock stands at the marker's time.  :func:`replay` then runs the
**same** :class:`auvdock.fly.session.FlySession` on it (the same telemetry mapping, the same
estimation stage, the same controller step, the same safety checks and results file), so
the replayed controller outputs equal the flight's, to rounding, with the same code.

Nothing is sent anywhere: arming, modes and RC overrides are no-ops, and the results file
records the channels the controller asked for (a dry-run flight recorded neutral ones).  The
vehicle moved under the flight's channels, so those are what went to it in a replay too: the
estimation stage is moved by the thrust of the flight's RC_CHANNELS_OVERRIDE at each step, and a
replay with another mission or controller (what a desk debugger tries: another filter setting,
another controller) estimates on the data as flown, to the flight's end.

Limits: ``dock.source: camera`` flights are not replayable (the dock fixes come from camera
frames, which the tlog does not hold); a tlog written before this marking (auvdock before
issue 15) has no markers and is refused; the tlog of a flight that ended before its first
control step (no vehicle answered, a check refused to arm, ...) has nothing to replay, and
the error says so and where it stopped.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil

from auvdock.config.mission import Mission
from auvdock.fly.link import for_session
from auvdock.fly.session import FlyAbortError, FlyResult, FlySession

__all__ = ["ReplayError", "ReplayLink", "ReplayClock", "FlightTag", "read_tag", "replay"]

MARKER_PREFIX = "auvd_"
#: The marker of a control step: a tlog without one ended before its first step.
STEP_MARKER = "auvd_step"
#: Where a flight that ended before its first step stopped, by the last stage's marker it wrote
#: (:class:`auvdock.fly.session.FlySession`; the latest stage first).
_STAGES = (
    ("auvd_arm", "while arming"),
    ("auvd_mode", "while setting the vehicle's mode to MANUAL"),
    ("auvd_frame", "after the telemetry wait, before arming (camera start or pre-flight checks)"),
    ("auvd_wait", "waiting for telemetry"),
    ("auvd_param", "reading the vehicle's parameters"),
)
_NUM = r"[0-9.eE+-]+"
_TAG = re.compile(rf"^auvdock fly (?P<controller>\w+) dt=(?P<dt>{_NUM})(?: timeout=(?P<timeout>{_NUM}))?")


class ReplayError(ValueError):
    """The tlog cannot be replayed (the message says why)."""


class ReplayClock:
    """The replay's clock: it stands at the time of the last marker read (s); nothing waits."""

    simulated = True

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def time(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        return None

    def sleep_until(self, t: float) -> None:
        return None


@dataclass(frozen=True)
class FlightTag:
    """What the flight wrote about itself at its start (a STATUSTEXT in the tlog)."""

    controller: str
    dt: float
    timeout_s: float | None


def _messages(path: Path) -> list[tuple[int, Any]]:
    """Every message of a tlog with its stamp (us), in order."""
    conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega", robust_parsing=True)
    out = []
    try:
        while (msg := conn.recv_match()) is not None:
            if msg.get_type() == "BAD_DATA":
                continue
            out.append((int(round(msg._timestamp * 1e6)), msg))
    finally:
        conn.close()
    return out


def _is_marker(msg: Any) -> bool:
    return msg.get_type() == "NAMED_VALUE_INT" and str(msg.name).startswith(MARKER_PREFIX)


def _is_vehicle_heartbeat(msg: Any) -> bool:
    sub, apm = mavutil.mavlink.MAV_TYPE_SUBMARINE, mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
    return msg.get_type() == "HEARTBEAT" and msg.type == sub and msg.autopilot == apm


def _only_ground_station(messages: list[tuple[int, Any]]) -> bool:
    """Whether the tlog holds nothing but a ground station's own messages: what ``fly`` records
    when no vehicle ever answered (its GCS heartbeat every second while it waits, the neutral
    overrides it sends on the way out)."""
    gcs = mavutil.mavlink.MAV_TYPE_GCS
    ours = {m.get_srcSystem() for _, m in messages if m.get_type() == "HEARTBEAT" and m.type == gcs}
    return bool(ours) and all(m.get_srcSystem() in ours for _, m in messages)


def _ended_before_first_step(messages: list[tuple[int, Any]]) -> str:
    """Why a flight's tlog has nothing to replay (the flight ended before its first control step)."""
    text = "the flight ended before its first control step (nothing to replay)"
    if not any(_is_vehicle_heartbeat(m) for _, m in messages):
        return text + ": no vehicle ever answered (no ArduSub heartbeat in the tlog)"
    reached = {str(m.name) for _, m in messages if _is_marker(m)}
    for marker, stage in _STAGES:
        if marker in reached:
            return text + f": it stopped {stage}"
    return text


def read_tag(messages: list[tuple[int, Any]]) -> FlightTag | None:
    """The flight's tag (controller, dt, timeout), or None if the tlog has none."""
    for _, msg in messages:
        if msg.get_type() == "STATUSTEXT":
            m = _TAG.match(str(msg.text))
            if m:
                timeout = None if m.group("timeout") is None else float(m.group("timeout"))
                return FlightTag(m.group("controller"), float(m.group("dt")), timeout)
    return None


class ReplayLink:
    """A :class:`~auvdock.fly.link.MavlinkLink` look-alike that plays a recorded flight.

    Parameters
    ----------
    path : Path
        The flight's tlog.
    messages : list, optional
        Its messages (:func:`_messages`), if already read.
    """

    def __init__(self, path: Path, messages: list[tuple[int, Any]] | None = None) -> None:
        self.path = Path(path)
        self.port = f"replay:{self.path.name}"
        self.clock = ReplayClock()
        #: A replay (the session hands a camera flight the fixes recorded in the tlog).
        self.replaying = True
        self.on_event: Callable[[str], None] | None = None
        self._msgs = _messages(self.path) if messages is None else messages
        self._i = 0
        #: The channels the flight sent after the latest marker (:meth:`send_override`).
        self._flown: tuple[int, ...] | None = None
        self.target_system = 1
        self.markers = 0
        own = [m.get_srcSystem() for _, m in self._msgs if _is_marker(m)]
        #: The flight's own system id (the one that wrote the markers).
        self.sysid = own[0] if own else 255
        steps = any(_is_marker(m) and str(m.name) == STEP_MARKER for _, m in self._msgs)
        if not steps and (own or _only_ground_station(self._msgs) or read_tag(self._msgs) is not None):
            raise ReplayError(f"{self.path}: {_ended_before_first_step(self._msgs)}")
        if not own:
            raise ReplayError(
                f"{self.path}: no auvdock step markers (not written by auvdock fly, or by a version "
                "before replay existed)"
            )

    # -- the vehicle's side --------------------------------------------------------------------
    def connect(self, timeout_s: float = 10.0) -> Any:
        """The flight's first ArduSub HEARTBEAT (the one its link accepted)."""
        sub, apm = mavutil.mavlink.MAV_TYPE_SUBMARINE, mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
        while self._i < len(self._msgs):
            stamp, msg = self._msgs[self._i]
            self._i += 1
            if msg.get_type() == "HEARTBEAT" and msg.type == sub and msg.autopilot == apm:
                self.target_system = msg.get_srcSystem()
                self.clock.t = stamp * 1e-6
                if self.on_event is not None:
                    self.on_event(f"replaying {self.path.name}: vehicle system {self.target_system}")
                return msg
        raise FlyAbortError(f"{self.path}: no ArduSub heartbeat in the tlog")

    def drain(self, marker: str, value: int = 0) -> tuple[int, list[tuple[int, Any]]]:
        """The vehicle's messages up to the flight's next marker, and the marker's stamp (us).

        Raises :class:`~auvdock.fly.session.FlyAbortError` at the end of the tlog, or if the
        flight's next marker is not the one the replayed session asks for (the replay has
        diverged from the flight: same tlog, different code or mission)."""
        taken: list[tuple[int, Any]] = []
        while self._i < len(self._msgs):
            stamp, msg = self._msgs[self._i]
            self._i += 1
            if _is_marker(msg) and msg.get_srcSystem() != self.target_system:
                name, val = str(msg.name), int(msg.value)
                if name != marker or (marker == "auvd_step" and val != int(value)):
                    raise FlyAbortError(
                        f"replay diverged from the flight: the flight's next marker is {name} {val}, "
                        f"the replay asks for {marker} {value} (another mission or controller?)"
                    )
                self.clock.t = stamp * 1e-6
                self.markers += 1
                self._flown = self._flown_after(self._i)
                return stamp, taken
            if for_session(msg, self.target_system, self.sysid):
                taken.append((stamp, msg))
        raise FlyAbortError("the tlog ends here (where the flight ended)")

    def _flown_after(self, i: int) -> tuple[int, ...] | None:
        """Channels 1..6 of the flight's first RC_CHANNELS_OVERRIDE from message ``i`` on, before its next
        marker (None: it sent none there)."""
        for _, msg in self._msgs[i:]:
            if msg.get_srcSystem() != self.sysid:
                continue
            if _is_marker(msg):
                return None
            if msg.get_type() == "RC_CHANNELS_OVERRIDE":
                return tuple(int(getattr(msg, f"chan{k}_raw")) for k in range(1, 7))
        return None

    # -- what a session sends: nothing, in a replay ---------------------------------------------
    def request_rate(self, message_id: int, rate_hz: float) -> int:
        return int(mavutil.mavlink.MAV_RESULT_ACCEPTED)

    def send_rate(self, message_id: int, rate_hz: float) -> None:
        return None

    def send_command(self, command: int, *params: float) -> None:
        return None

    def send_timesync(self, ts1_ns: int) -> None:
        return None

    def send_arm(self, arm: bool) -> None:
        return None

    def send_mode(self, name: str) -> None:
        return None

    def request_parameters(self, names: Any) -> None:
        return None

    def note(self, text: str) -> None:
        return None

    def record_rows(self, name: str, rows: Any) -> None:
        return None

    def send_neutral(self) -> None:
        return None

    def send_override(self, channels_us: Any) -> tuple[int, ...]:
        """Nothing is sent; the channels that went to the vehicle at this step are the flight's (its first
        RC_CHANNELS_OVERRIDE after the step's marker), else those asked for.  A replay of another mission
        or controller thus moves its estimator with the thrust that moved the vehicle."""
        flown, self._flown = self._flown, None
        return flown if flown is not None else tuple(int(round(c)) for c in channels_us)

    def release_overrides(self) -> None:
        return None

    def set_mode(self, name: str, timeout_s: float = 3.0) -> None:
        return None

    def arm(self, timeout_s: float = 3.0) -> None:
        return None

    def disarm(self, timeout_s: float = 3.0) -> bool:
        return True

    def close(self) -> None:
        return None


def replay(
    tlog: str | Path,
    mission: Mission,
    out: str | Path,
    *,
    controller: str | None = None,
    timeout_s: float | None = None,
) -> tuple[FlyResult, FlightTag | None]:
    """Rerun the flight recorded in ``tlog`` with ``mission``; results to ``out`` (HDF5).

    ``controller`` / ``timeout_s`` default to what the flight wrote in its tlog (its tag),
    else the mission's.

    Raises
    ------
    ReplayError
        A tlog without auvdock's markers, or a camera-docked mission (``dock.source: camera``; the dock
        camera as a sensor replays: its fixes are in the tlog).
    MissionError
        As :class:`~auvdock.fly.session.FlySession`.
    """
    path = Path(tlog)
    if mission.dock.source == "camera":
        raise ReplayError(
            "dock.source camera: the dock's fixes came from camera frames, which a tlog does not hold"
        )
    messages = _messages(path)
    link = ReplayLink(path, messages)
    tag = read_tag(messages)
    if controller is None and tag is not None:
        controller = tag.controller
    if timeout_s is None and tag is not None:
        timeout_s = tag.timeout_s
    session = FlySession(
        mission,
        link,  # type: ignore[arg-type]
        arm=True,
        out=out,
        controller=controller,
        timeout_s=timeout_s,
        connect_timeout_s=float("inf"),
    )
    if tag is not None and not np.isclose(tag.dt, session.dt):
        raise ReplayError(f"the flight ran at dt = {tag.dt:g} s, the mission says {session.dt:g} s")
    return session.run(), tag
