"""Outcome codes of one controller step, recorded per step as ``solver_status`` (int8).

=====  ==================  ===============================================================
code   name                meaning
=====  ==================  ===============================================================
0      ``ok``              the step's optimisation converged; its first input is applied
1      ``not_converged``   it stopped early (iteration limit); a fallback input is applied
2      ``failed``          it failed (or was not attempted: non-finite input); fallback
3      ``fallback_zero``   it failed, with no plan to fall back on or after ``fallback_steps``
                           failures in a row (mpc.FALLBACK_RULE): zero thrust (neutral)
4      ``no_step``         no controller step: the row records the run's final state
5      ``settling``        no controller step: the navigation filter is settling, thrust zero
6      ``hold``            no controller step: the dock is out of sight (fly's camera); depth
                           and attitude held (auvdock.controllers.hold)
7      ``lost_target``     no controller step: the guidance gave up finding the dock
                           (auvdock.loop.guidance); zero thrust, and the run ends
=====  ==================  ===============================================================

A controller that is not an optimiser reports ``ok``.  Results files store this table as
JSON (``solver_status_codes``), so a reader never depends on this module's numbering.
"""

from __future__ import annotations

__all__ = [
    "STATUS_OK",
    "STATUS_NOT_CONVERGED",
    "STATUS_FAILED",
    "STATUS_FALLBACK_ZERO",
    "STATUS_NO_STEP",
    "STATUS_SETTLING",
    "STATUS_HOLD",
    "STATUS_LOST_TARGET",
    "STATUS_NAMES",
    "FAILURE_CODES",
]

STATUS_OK = 0
STATUS_NOT_CONVERGED = 1
STATUS_FAILED = 2
STATUS_FALLBACK_ZERO = 3
STATUS_NO_STEP = 4
STATUS_SETTLING = 5
STATUS_HOLD = 6
STATUS_LOST_TARGET = 7

#: Code -> name.
STATUS_NAMES: dict[int, str] = {
    STATUS_OK: "ok",
    STATUS_NOT_CONVERGED: "not_converged",
    STATUS_FAILED: "failed",
    STATUS_FALLBACK_ZERO: "fallback_zero",
    STATUS_NO_STEP: "no_step",
    STATUS_SETTLING: "settling",
    STATUS_HOLD: "hold",
    STATUS_LOST_TARGET: "lost_target",
}

#: The codes that count as solver trouble (``solver_failures`` of a run).
FAILURE_CODES = (STATUS_NOT_CONVERGED, STATUS_FAILED, STATUS_FALLBACK_ZERO)
