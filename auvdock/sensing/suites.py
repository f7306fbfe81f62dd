"""Named sensor suites: what a vehicle carries to find its way to the dock, as mission field values.

A suite is a set of mission fields (``estimation`` and the ``sensors`` section); sweeps vary it as
one derived field, ``sensors.suite`` (:mod:`auvdock.sweep.expand`), so that the comparison "which
sensors does a controller need" is one axis of a table.  Every suite runs the navigation filter
(``estimation: filter``); the figures of each sensor are its defaults
(:mod:`auvdock.sensing.settings`, with their sources).

=================  ==========================================================================
suite              the vehicle has
=================  ==========================================================================
motion_capture     a tank's motion capture (1 mm, 50 Hz), which tracks the dock too: its position is
                   known (``dock.position_std_m`` 0)
acoustic           acoustic positioning (Water Linked UGPS G2: 0.1 m, 2 Hz, 0.5 s latency)
acoustic+camera    acoustic positioning, and the camera's fixes of the dock's markers
dvl+camera         a DVL (velocity over ground, 10 Hz), and the camera's fixes of the dock
camera             the camera's fixes of the dock's markers only: dead reckoning on the IMU and
                   the model until the dock is in view (the paper's premise: no DVL, no
                   acoustic positioning)
=================  ==========================================================================
"""

from __future__ import annotations

from typing import Any

__all__ = ["SENSOR_SUITES", "suite_updates"]

#: Suite name -> (mission field updates, one line describing it).
SENSOR_SUITES: dict[str, tuple[dict[str, Any], str]] = {}


def _suite(name: str, position: str, dvl: bool, camera: bool, what: str, **more: Any) -> None:
    fields = {"sensors.position.source": position, "sensors.dvl.enabled": dvl}
    SENSOR_SUITES[name] = ({**fields, "sensors.dock_camera.enabled": camera, **more}, what)


_suite(
    "motion_capture", "motion_capture", False, False, "motion capture of the vehicle and the dock",
    **{"dock.position_std_m": 0.0, "navigation.prior_dock_std_m": 0.001},
)  # fmt: skip
_suite("acoustic", "acoustic", False, False, "acoustic positioning and the dock's charted position")
_suite("acoustic+camera", "acoustic", False, True, "acoustic positioning and the camera's fixes of the dock")
_suite("dvl+camera", "none", True, True, "a DVL and the camera's fixes of the dock")
_suite("camera", "none", False, True, "the camera's fixes of the dock only (dead reckoning until in view)")


def suite_updates(name: str) -> dict[str, Any]:
    """The mission field updates of suite ``name`` (``estimation: filter`` included); ValueError
    naming the known suites for an unknown one."""
    if name not in SENSOR_SUITES:
        raise ValueError(f"unknown sensor suite {name!r} (known: {', '.join(SENSOR_SUITES)})")
    return {"estimation": "filter", **SENSOR_SUITES[name][0]}
