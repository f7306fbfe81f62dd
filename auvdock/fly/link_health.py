"""The link's health, measured: round trip, the vehicle's clock, loss (``fly``).

* **Round trip and the vehicle's clock** (MAVLink TIMESYNC): fly sends ``TIMESYNC(tc1=0, ts1=its time
  in ns)`` every ``fly.timesync_period_s``; ArduPilot answers at once with ``tc1`` = its own time since
  boot (ns) and ``ts1`` echoed.  On the answer's arrival at ``t_rx``: round trip ``rtt = t_rx - ts1``,
  and the vehicle's clock minus ours ``offset = tc1 - (ts1 + t_rx) / 2`` (the answer taken as made half
  way).  Jitter is filtered: the round trip is the median of the last :data:`WINDOW` answers; the
  offset the mean offset of the least-queued quarter (:data:`OFFSET_QUANTILE`, the shortest round
  trips) of the last :data:`OFFSET_WINDOW` answers.  On a link whose delays only ever add queueing (a
  busy Wi-Fi hop) the least-queued answers are the true ones, as NTP's minimum filter takes them; on
  one whose jitter goes both ways the mean of many halves the error of one.  (NTP's filter, the
  offset of the one least-queued of the last 16 answers, moved the offset by up to 64 ms within a
  flight over a 100 ms +- 30 ms link: every reading's instant moved as much against the commands, a
  centimetre of the dock's heave.)  An answer more than :data:`REBOOT_JUMP_S` off the estimate says
  the vehicle's clock restarted: the answers before it are forgotten.  So are they when an answer's
  offset is further from the estimate than the queueing of both and the link's jitter allow (half the
  round trip beyond the shortest, twice the one-way jitter, and :data:`DRIFT_MARGIN_S`): the vehicle's
  clock has run at another rate than ours (judged once four answers give the jitter; the round trip and
  the jitter are the link's: its last answers', whether the clock's were forgotten or not); until the
  next answer the offset then moves on at the rate that answer showed (:meth:`LinkFigures.offset_now_s`).
  In the field both run with the wall clock; a rehearsal's simulator falls behind its rate when the
  machine cannot keep up (ArduSub SITL's lockstep on a busy 2-core machine lost up to 0.9 s against
  fly's clock in a flight), and a flight paces and dates on the vehicle's clock
  (:class:`auvdock.fly.mission_clock.MissionClock`), so the offset must follow it.
* **Loss**: MAVLink's sequence number (one byte per sending component, unwrapped) counts every message
  the vehicle sent: of the last :data:`LOSS_WINDOW` received, the distinct numbers against the span they
  cover (a late or duplicated message is not a lost one).
* **Reading ages**: a message stamped with the vehicle's ``time_boot_ms`` was sampled at
  ``time_boot - offset`` on our clock; its age when used is ``now - that``.

The expected delivery delay of a command is half the median round trip (the link taken as symmetric).
Times are on the session's clock (the tlog's, s since the epoch), so a replay of the tlog measures the
same figures from the same messages.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["LinkHealth", "LinkFigures", "WINDOW", "OFFSET_WINDOW", "LOSS_WINDOW", "DRIFT_MARGIN_S"]

#: TIMESYNC answers the round trip and jitter are filtered over.
WINDOW = 16
#: TIMESYNC answers the clocks' offset is filtered over (32 s at the default 0.5 s period: two
#: clocks 50 ppm apart drift 1.6 ms in that time).
OFFSET_WINDOW = 64
#: The share of those answers, the least queued, whose offsets are averaged.
OFFSET_QUANTILE = 0.25
#: An answer whose offset differs from the estimate by more than this (s) says the vehicle's clock
#: restarted (a reboot): the answers before it are forgotten.
REBOOT_JUMP_S = 1.0
#: An answer whose offset differs from the estimate by more than the queueing of both allows (half the
#: round trip beyond the link's shortest: how far the delays' asymmetry can move an answer's offset), twice
#: the link's one-way jitter and this (s) says the
#: vehicle's clock ran at another rate than ours (a rehearsal's simulator falling behind its rate on a busy
#: machine): the answers before it are forgotten, and the offset follows the vehicle's clock.
DRIFT_MARGIN_S = 0.002
#: Messages the loss rate is counted over (about 10 s of a session's streams).
LOSS_WINDOW = 1000


@dataclass(frozen=True)
class LinkFigures:
    """The link's health at one instant (NaN where not measured yet): the median round trip (s), the
    vehicle's clock minus the session's (s), the fraction of the vehicle's messages lost, answers counted,
    the newest round trip (s: a sudden change shows here first), the one-way jitter (s: the round
    trips' std over sqrt 2, each way taken as independent), and the offset's rate of change (s/s: the
    vehicle's clock's rate less ours, 0 while they agree) from the newest answer's arrival (s)."""

    rtt_s: float
    offset_s: float
    loss: float
    answers: int
    rtt_latest_s: float = math.nan
    jitter_s: float = math.nan
    offset_rate: float = 0.0
    offset_at_s: float = math.nan

    def offset_now_s(self, now_s: float) -> float:
        """The clocks' offset at session time ``now_s`` (s): :attr:`offset_s`, moved at :attr:`offset_rate`
        (the vehicle's clock's rate less ours, found when its answers restarted) since the newest answer
        (:attr:`offset_at_s`)."""
        if self.offset_rate == 0.0 or not math.isfinite(self.offset_at_s):
            return self.offset_s
        return self.offset_s + self.offset_rate * max(0.0, now_s - self.offset_at_s)

    @property
    def hold_back_s(self) -> float:
        """How long a reading is held back so that those jitter delays behind it arrive first (s): twice the
        one-way jitter (0 before it is measured)."""
        return 0.0 if not math.isfinite(self.jitter_s) else 2.0 * self.jitter_s

    @property
    def one_way_s(self) -> float:
        """Expected delivery delay of a command, s: half the round trip (0 before one is measured)."""
        return 0.0 if not math.isfinite(self.rtt_s) else 0.5 * self.rtt_s

    def describe(self) -> str:
        """``"round trip 203 ms, 4.8 % of the vehicle's messages lost"``."""
        if math.isfinite(self.rtt_s):
            rtt = f"round trip {1e3 * self.rtt_s:.0f} ms"
        else:
            rtt = "round trip not measured (no TIMESYNC answer)"
        if not math.isfinite(self.loss):
            return rtt
        return f"{rtt}, {100 * self.loss:.1f} % of the vehicle's messages lost"


class LinkHealth:
    """TIMESYNC round trips, the vehicle's clock and message loss (see the module docstring)."""

    def __init__(self) -> None:
        self._sync: deque[tuple[float, float]] = deque(maxlen=OFFSET_WINDOW)  # (rtt s, offset s)
        self._rtts: deque[float] = deque(maxlen=WINDOW)  # the link's: kept when the clock's answers are not
        self._last: dict[tuple[int, int], int] = {}  # per sender, the newest unwrapped sequence number
        self._seen: dict[tuple[int, int], deque[int]] = {}  # per sender, the unwrapped numbers received
        self._figures: LinkFigures | None = None  # computed once per feed
        #: How often the answers were forgotten because the vehicle's clock ran at another rate.
        self.drift_restarts = 0
        self._rate = 0.0  # the offset's rate of change found at the newest answer (s/s)
        self._answer_at = -math.inf  # the newest answer's arrival (s)

    @staticmethod
    def request_ns(now_s: float) -> int:
        """The ``ts1`` of a TIMESYNC request sent at ``now_s`` (s): our time in ns."""
        return int(round(now_s * 1e9))

    def feed(self, messages: list[tuple[int, Any]], vehicle_sysid: int) -> None:
        """Take the vehicle's messages received since the last call (``(stamp us, message)``)."""
        if messages:
            self._figures = None
        for stamp, msg in messages:
            if msg.get_srcSystem() != vehicle_sysid:
                continue
            key = (msg.get_srcSystem(), msg.get_srcComponent())
            seq = int(msg.get_seq())
            last = self._last.get(key)
            if last is None:
                n = seq
            else:  # unwrapped: the nearest number with this byte (late or duplicated ones fall behind)
                step = (seq - last) % 256
                n = last + step if step < 128 else last - (256 - step)
            self._last[key] = max(n, last) if last is not None else n
            self._seen.setdefault(key, deque(maxlen=LOSS_WINDOW)).append(n)
            if msg.get_type() == "TIMESYNC" and int(msg.tc1) != 0:
                rx = stamp * 1e-6
                ts1 = int(msg.ts1) * 1e-9
                rtt = rx - ts1
                if -1e-6 <= rtt < 60.0:  # an answer to one of ours (not another station's)
                    rtt, offset = max(0.0, rtt), int(msg.tc1) * 1e-9 - 0.5 * (ts1 + rx)
                    self._rate = 0.0
                    if self._sync:
                        moved = offset - self._offset()
                        if abs(moved) > REBOOT_JUMP_S:
                            self._sync.clear()  # the vehicle's clock restarted
                        elif len(self._rtts) >= 4 and abs(moved) > self._drift_bound(rtt):  # (jitter known)
                            self._sync.clear()  # it ran at another rate than ours: from this answer on
                            self.drift_restarts += 1
                            if rx > self._answer_at:  # and runs on so, until an answer says otherwise
                                self._rate = moved / (rx - self._answer_at)
                    self._sync.append((rtt, offset))
                    self._rtts.append(rtt)
                    self._answer_at = rx

    def figures(self) -> LinkFigures:
        """The health now (computed once per :meth:`feed` that brought messages)."""
        if self._figures is None:
            self._figures = self._compute()
        return self._figures

    def _compute(self) -> LinkFigures:
        offset = self._offset() if self._sync else math.nan
        if self._rtts:
            rtts = np.array(self._rtts)
            rtt = float(np.median(rtts))
            latest = float(rtts[-1])
            jitter = float(np.std(rtts)) / math.sqrt(2.0) if rtts.size >= 4 else math.nan
        else:
            rtt = latest = jitter = math.nan
        got = sent = 0
        for seen in self._seen.values():
            if len(seen) > 1:
                got += len(set(seen))
                sent += max(seen) - min(seen) + 1
        loss = 1.0 - got / sent if sent > 0 else math.nan
        at = self._answer_at if math.isfinite(self._answer_at) else math.nan
        return LinkFigures(rtt, float(offset), loss, len(self._sync), latest, jitter, self._rate, at)

    def _drift_bound(self, rtt: float) -> float:
        """How far (s) an answer of round trip ``rtt`` (s) may be from the estimate with the vehicle's clock
        at our rate: half its queueing (its round trip beyond the shortest of the link's last answers), half
        the most queued of the answers the estimate averages, twice the one-way jitter, and
        :data:`DRIFT_MARGIN_S`."""
        rtts = np.array(self._rtts)
        averaged = self._least_queued()
        least = min(float(rtts.min()), rtt, averaged[0][0])
        jitter = float(np.std(rtts)) / math.sqrt(2.0)
        queued = averaged[-1][0] - least
        return 0.5 * (rtt - least) + 0.5 * queued + 2.0 * jitter + DRIFT_MARGIN_S

    def _least_queued(self) -> list[tuple[float, float]]:
        """The answers the offset averages: the least-queued quarter of those kept."""
        answers = sorted(self._sync)
        return answers[: max(1, int(math.ceil(OFFSET_QUANTILE * len(answers))))]

    def _offset(self) -> float:
        """The vehicle's clock minus ours (s): the mean offset of the least-queued answers kept."""
        return float(np.mean([offset for _, offset in self._least_queued()]))

    def sample_time(self, time_boot_s: float, figures: LinkFigures) -> float:
        """When (s, the session's clock) a message stamped ``time_boot_s`` on the vehicle's clock was
        sampled; NaN before the offset is measured."""
        return time_boot_s - figures.offset_s
