"""The mission's ``sensors:`` section: each sensor's rate, latency, noise and biases, with sources.

Two ways of knowing the vehicle's state, chosen by the mission's ``estimation``:

* ``truth`` (the paper's Assumption 1, the default, to reproduce it): the controllers get the
  true state; the FSE controllers' flow filter reads the paper's sensing of [eta; nu_r] with
  the noise levels of the top-level fields of :class:`SensorSettings`, simulated by
  :class:`SensorModel`.
* ``filter`` (what a BlueROV2 really knows): the sensor suite of :class:`SensorSettings`
  (``imu``, ``ahrs``, ``depth``, ``position``, ``dvl``, ``dock_camera``; defaults from the manufacturers'
  figures, each with its source) is simulated by :class:`SensorSuite` as asynchronous
  :class:`auvdock.estimation.navigation_filter.Reading` s, one definition per measurement
  (:mod:`auvdock.sensing.measurements`), and the navigation filter
  (:mod:`auvdock.estimation.navigation_filter`)
  estimates the state and the current from them.

Seeded: the same seed gives the same readings.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from auvdock.schema.strict import NonNegFloat, PosFloat, Strict

__all__ = [
    "SensorSettings",
    "ImuSettings",
    "AhrsSettings",
    "DepthSettings",
    "PositionSettings",
    "DvlSettings",
    "POSITION_SOURCES",
    "DockCameraSettings",
    "DockTelemetrySettings",
]


class ImuSettings(Strict):
    """The autopilot's IMU (BlueROV2 Navigator: TDK InvenSense ICM-20602), read as ArduSub reports it."""

    rate_hz: PosFloat = Field(
        default=50.0, description="samples used per second, Hz (at most one per control step)"
    )
    latency_s: NonNegFloat = Field(
        default=0.0,
        description="sample to use, s (fly stamps each reading this much before its message's time_boot_ms)",
    )
    accel_noise_m_s2: NonNegFloat = Field(
        default=0.0044,
        description="accelerometer noise std, m/s^2 (ICM-20602 datasheet: 100 ug/sqrt(Hz), "
        "times sqrt(20 Hz), ArduPilot's INS_ACCEL_FILTER)",
    )
    accel_bias_m_s2: NonNegFloat = Field(
        default=0.02,
        description="std of a constant accelerometer bias per run, m/s^2 (assumed: residual after "
        "ArduPilot's accelerometer calibration; ICM-20602 zero-g offset before it: 25 mg)",
    )
    gyro_noise_rad_s: NonNegFloat = Field(
        default=3.1e-4,
        description="gyro noise std, rad/s (ICM-20602 datasheet: 0.004 deg/s/sqrt(Hz), times "
        "sqrt(20 Hz), ArduPilot's INS_GYRO_FILTER)",
    )
    gyro_bias_rad_s: NonNegFloat = Field(
        default=1e-3,
        description="std of a constant gyro bias per run, rad/s (assumed: residual after the gyro "
        "calibration ArduPilot does at boot; ICM-20602 offset before it: 1 deg/s)",
    )


class AhrsSettings(Strict):
    """Attitude from the autopilot's attitude estimate (ArduSub EKF3: ATTITUDE messages)."""

    rate_hz: PosFloat = Field(default=25.0, description="ATTITUDE rate, Hz (what fly requests)")
    latency_s: NonNegFloat = Field(
        default=0.0,
        description="sample to use, s (fly stamps each reading this much before its message's time_boot_ms)",
    )
    roll_pitch_std_rad: NonNegFloat = Field(
        default=0.0087, description="roll and pitch error std, rad (assumed 0.5 deg: no published figure)"
    )
    yaw_std_rad: NonNegFloat = Field(
        default=0.035,
        description="heading error std, rad (assumed 2 deg: magnetometer heading beside thrusters)",
    )


class DepthSettings(Strict):
    """Depth from the pressure sensor (Blue Robotics Bar30, MS5837-30BA: SCALED_PRESSURE2)."""

    rate_hz: PosFloat = Field(default=25.0, description="samples per second, Hz")
    latency_s: NonNegFloat = Field(
        default=0.0,
        description="sample to use, s (fly stamps each reading this much before its message's time_boot_ms)",
    )
    std_m: NonNegFloat = Field(default=0.002, description="depth noise std, m (Bar30: 2 mm resolution)")


#: Position sources and their defaults: rate (Hz), latency (s), noise std (m), source of the figures.
POSITION_SOURCES: dict[str, tuple[float, float, float, str]] = {
    "none": (1.0, 0.0, 0.0, "no position fixes: dead reckoning on the model and the IMU only"),
    "acoustic": (
        2.0,
        0.5,
        0.1,
        "acoustic positioning (Water Linked Underwater GPS G2: accuracy 1 % of range, so 0.1 m at "
        "10 m; rate and latency assumed)",
    ),
    "dvl_dead_reckoning": (
        10.0,
        0.1,
        0.02,
        "ArduSub's EKF on a DVL (Water Linked DVL A50: long-term accuracy 1.01 % of distance "
        "travelled, 2-15 Hz); noise assumed",
    ),
    "camera": (
        15.0,
        0.1,
        0.01,
        "the dock's markers (this project's pose pipeline: <= 3.1 mm at 1 m on rendered views "
        "with noise; 1 cm assumed in water); 15 Hz as the synthetic camera, latency assumed",
    ),
    "motion_capture": (
        50.0,
        0.01,
        0.001,
        "underwater motion capture in a tank (assumed 1 mm, 10 ms)",
    ),
}


#: The position sources whose positions are dead reckoned in the vehicle's own heading (none: the
#: autopilot's EKF on its IMU; a DVL's velocities integrated with the compass): a compass error turns
#: them with the vehicle.  The others (acoustic, camera, motion capture) fix the vehicle in an outside
#: frame, whatever the compass says.
DEAD_RECKONED_SOURCES = frozenset({"none", "dvl_dead_reckoning"})


class DockCameraSettings(Strict):
    """The front camera's fixes of the dock's markers, as a sensor of the simulated suite.

    With ``enabled`` the suite (``estimation: filter``) delivers a reading of kind ``dock`` --
    the dock's docking point in the camera frame (:mod:`auvdock.sensing.measurements`) -- for every
    frame in which the camera decodes at least one of the dock's markers; none otherwise.  The ``fast``
    model (:mod:`auvdock.sensing.camera_fix`) decides from the geometry and the water (field of view,
    obliquity, the marker's apparent size and its contrast, which the water's visibility attenuates),
    and draws the fix's noise from the pipeline's measured corner errors; the ``rendered`` one
    (:mod:`auvdock.sensing.camera_rendered`) renders the view and runs the real pipeline.  The
    navigation filter then estimates the dock's position as a state, anchored by these fixes (relative
    navigation).

    The defaults marked "measured" come from ``python benchmarks/camera_fix_errors.py`` (2026-12-02): the
    synthetic camera (640 x 480, 80 deg, image noise 2 grey levels, blur 0.5 px) rendering one 0.15 m
    marker in water over a grid of sizes, contrasts and obliquities, decoded by the real pipeline.
    """

    enabled: bool = Field(
        default=False,
        description="the camera's fixes of the dock's markers are a sensor (relative navigation: the "
        "dock's position becomes a state of the navigation filter)",
    )
    model: Literal["fast", "rendered"] = Field(
        default="fast",
        description="fast: the model of the pipeline's detection and errors measured on rendered views "
        "(auvdock.sensing.camera_fix); rendered: the real rendering + detection + pose pipeline in the "
        "loop (auvdock.sensing.camera_rendered), slow (10-50 ms a frame), for spot checks",
    )
    rate_hz: PosFloat = Field(default=15.0, description="frames per second, Hz (the synthetic camera's)")
    latency_s: NonNegFloat = Field(
        default=0.1,
        description="the scene to its fix, s (fly measured 98 ms median on the 2-core machine). fly stamps "
        "each frame's fix this much before it decoded the frame (the part before: exposure, encoding, the "
        "network, FFmpeg's one-frame H.264 parser delay) and its detection time comes on top, measured",
    )
    visibility_m: PosFloat = Field(
        default=8.0,
        description="the water's visibility (horizontal, black target), m: beam attenuation c = 4.8 / V "
        "(Zaneveld and Pegau 2003); a marker's contrast falls as exp(-c d) with its range d, so it is "
        "decoded out to 0.54 V at most (assumed 8 m: clear coastal water; a turbid harbour is 1-3 m)",
    )
    marker_contrast_grey: PosFloat = Field(
        default=255.0,
        description="the markers' black-to-white step in the image without water, grey levels (the "
        "synthetic camera's: black 0, white 255)",
    )
    min_contrast_grey: NonNegFloat = Field(
        default=19.5,
        description="contrast below which no marker is decoded however large, grey levels (measured: "
        "benchmarks/camera_fix_errors.py, 2026-12-02, the boundary of half decoded, fitted with "
        "min_side_px; 10 times the 2 grey level image noise, but nearly absolute: OpenCV's adaptive "
        "threshold)",
    )
    min_side_px: PosFloat = Field(
        default=12.5,
        description="apparent side (square root of the image area) below which no marker is decoded "
        "however high its contrast, px; a marker is decoded while min_contrast_grey / C + "
        "(min_side_px / side)^3 <= 1 (measured: benchmarks/camera_fix_errors.py, 2026-12-02)",
    )
    max_view_angle_deg: Annotated[float, Field(gt=0, lt=90)] = Field(
        default=78.0,
        description="largest angle between a marker's normal and the line of sight, deg (measured: "
        "benchmarks/camera_fix_errors.py, 2026-12-02: half the 60 px markers decoded at 78 deg)",
    )
    corner_px: PosFloat = Field(
        default=0.0071,
        description="corner error of well-resolved, edge-refined markers at full contrast, px; it grows as "
        "marker_contrast_grey / C with the contrast C, and small, faint or oblique markers have more "
        "(measured: benchmarks/camera_fix_errors.py, 2026-12-02: 0.0069-0.0078 px x C0 / C for contrasts "
        "of 22-160 grey levels; far below the 0.5 px assumed before, except where the edge refinement "
        "gives up, near the detection limit: 0.92 px)",
    )
    dropout: Annotated[float, Field(ge=0, lt=1)] = Field(
        default=0.02, description="probability that a frame with markers in view gives no fix (assumed)"
    )


class DockTelemetrySettings(Strict):
    """The dock's own motion sensor, sent to the vehicle's controller: what a deployable controller
    forecasts the dock's motion from (no Assumption 2).

    A WEC carries a motion reference unit (its power take-off needs the buoy's heave); its record
    reaches the shore, and the vehicle's topside computer, over the WEC's cable or radio.  With
    ``enabled`` the suite (``estimation: filter``) delivers readings of kind ``dock_motion``: the
    docking point's displacement from its mean (NED, m: heave, and surge and sway where the dock
    moves so), sampled at ``rate_hz``, ``latency_s`` late, a share ``dropout`` lost; at the start the
    last ``history_s`` of the record arrive at once (the dock has been sending all along).  Its errors
    are the ``motion_unit``'s:

    * ``mru`` (the default): a marine motion reference unit as its data sheet states it.  SBG Systems'
      Apogee series (hardware manual APOGEEHM.1.5, sec. 2.3.2.1) gives real-time heave to "5 cm or 5 %,
      whichever is greater" for periods of 0-20 s, computed at 50 Hz by double integration of the
      accelerometers through an auto-tuned high-pass filter (SBG Systems' knowledge base, "Ship motion
      measurements"); Kongsberg's MRU 5+ states the same 5 cm or 5 %.  That error is the high-pass
      filter's gain and phase and the integration's drift: slow, not white.  It is modelled as a
      first-order Gauss-Markov error of ``heave_error_std_m`` (the data sheet's 5 cm) with a correlation
      time of ``heave_error_tau_s`` (20 s, the longest period the real-time heave is specified for),
      plus white noise ``heave_noise_m`` (short-term noise is on no data sheet: 1 cm assumed; a MEMS
      accelerometer's white noise, double-integrated over a swell period, is millimetres).  The unit
      also sends the heave rate (SBG's ship-motion velocity output; readings of kind
      ``dock_motion_rate``, NED m/s) with white noise ``rate_noise_m_s`` (assumed 1 cm/s).
    * ``white``: the pessimistic variant, the data sheet's 5 cm taken as white noise (``std_m`` per
      axis, no rate): what the kriging forecaster was designed on.

    The deployable controllers then steer to the dock's motion forecast from these readings
    (:class:`auvdock.estimation.dock_knowledge.TelemetryDock`); Oracle alone is told the true motion.
    Without it every controller is told the dock's motion (Assumption 2).  The dock's position is not in
    the telemetry: the vehicle finds it with its camera or its charted position (relative navigation).
    """

    enabled: bool = Field(
        default=False,
        description="the deployable controllers forecast the dock's motion from the dock's telemetry "
        "(no Assumption 2); without it they are told the motion",
    )
    rate_hz: PosFloat = Field(
        default=10.0,
        description="samples per second, Hz (assumed: a motion unit's 10-200 Hz thinned for the link)",
    )
    latency_s: NonNegFloat = Field(
        default=0.25, description="sample to use, s (assumed: the dock's link to shore and on to the topside)"
    )
    motion_unit: Literal["mru", "white"] = Field(
        default="mru",
        description="the motion unit's errors: mru (a data sheet's unit: a slow heave error, small white "
        "noise, the heave rate too) or white (the pessimistic variant: std_m of white noise, no rate)",
    )
    std_m: NonNegFloat = Field(
        default=0.05,
        description="motion_unit white: noise of each axis of the displacement, m (a marine motion reference "
        "unit's heave accuracy, 5 cm or 5 %, whichever is larger, taken as white noise; SBG Apogee and "
        "Kongsberg MRU 5+ data sheets)",
    )
    heave_error_std_m: NonNegFloat = Field(
        default=0.05,
        description="motion_unit mru: std of the slow heave error, m (real-time heave accuracy 5 cm or 5 %: "
        "SBG Apogee hardware manual APOGEEHM.1.5, sec. 2.3.2.1)",
    )
    heave_error_tau_s: PosFloat = Field(
        default=20.0,
        description="motion_unit mru: correlation time of the slow heave error, s (the longest period the "
        "real-time heave is specified for, 20 s: the same manual)",
    )
    heave_noise_m: NonNegFloat = Field(
        default=0.01,
        description="motion_unit mru: white noise of each axis of the displacement, m (assumed: no data "
        "sheet states it)",
    )
    rate_noise_m_s: NonNegFloat = Field(
        default=0.01,
        description="motion_unit mru: white noise of each axis of the heave rate, m/s (assumed)",
    )
    dropout: Annotated[float, Field(ge=0, lt=1)] = Field(
        default=0.02, description="probability that a sample is lost on the link (assumed)"
    )
    history_s: NonNegFloat = Field(
        default=300.0,
        description="how much of the dock's record the vehicle has when the run starts, s (the "
        "forecaster estimates the sea's spectrum from it; 0: none)",
    )
    mavlink_system: Annotated[int, Field(ge=1, le=255)] = Field(
        default=2,
        description="fly: the dock's MAVLink system id, whose ODOMETRY messages (the displacement from its "
        "mean, NED m, MAV_FRAME_LOCAL_NED; stamped in UNIX time) are its telemetry; vehicle-sim sends them "
        "from this id",
    )


class PositionSettings(Strict):
    """Where position fixes come from; rate, latency and noise default to the source's figures."""

    source: Literal["none", "acoustic", "dvl_dead_reckoning", "camera", "motion_capture"] = Field(
        default="camera",
        description="none, acoustic, dvl_dead_reckoning, camera (an ideal fix of the vehicle's position at "
        "any range and angle: an idealisation) or motion_capture; the dock camera as a camera really "
        "sees is sensors.dock_camera",
    )
    rate_hz: PosFloat | None = Field(default=None, description="fixes per second, Hz (default: the source's)")
    latency_s: NonNegFloat | None = Field(default=None, description="fix to use, s (default: the source's)")
    std_m: NonNegFloat | None = Field(
        default=None, description="noise std per axis, m (default: the source's)"
    )
    bias_std_m: NonNegFloat = Field(
        default=0.0,
        description="std per axis of the fixes' slowly varying error, m: drawn once per run in simulation; "
        "a mean of readings does not average it (an EKF's GPS wander: measured 0.7-1.8 cm against "
        "ArduSub SITL, whose fixes' white part is 0.5 mm); 0: the fixes' error is white",
    )

    def figures(self) -> tuple[float, float, float]:
        """(rate Hz, latency s, noise std m): the given values, else the source's defaults
        (:data:`POSITION_SOURCES`; kept unresolved so that changing ``source`` changes them)."""
        rate, latency, std, _ = POSITION_SOURCES[self.source]
        return (
            rate if self.rate_hz is None else float(self.rate_hz),
            latency if self.latency_s is None else float(self.latency_s),
            std if self.std_m is None else float(self.std_m),
        )


class DvlSettings(Strict):
    """An optional Doppler velocity log: velocity over ground in {b} (Water Linked DVL A50)."""

    enabled: bool = Field(default=False, description="the vehicle carries a DVL with bottom lock")
    rate_hz: PosFloat = Field(default=10.0, description="velocity reports per second, Hz (A50: 2-15 Hz)")
    latency_s: NonNegFloat = Field(default=0.1, description="report to use, s (assumed)")
    std_m_s: NonNegFloat = Field(
        default=0.01,
        description="velocity noise std per axis, m/s (assumed; A50: 0.1 mm/s resolution, 1.01 % accuracy)",
    )


class SensorSettings(Strict):
    """The sensors.  The top-level noise levels are the paper's sensing of [eta; nu_r] for
    ``estimation: truth``; ``imu``, ``ahrs``, ``depth``, ``position``, ``dvl`` and ``dock_camera``
    are the BlueROV2's sensor suite, read by the navigation filter with ``estimation: filter``."""

    position_std_m: NonNegFloat = Field(default=0.002, description="pose position noise, m")
    attitude_std_rad: NonNegFloat = Field(default=0.002, description="pose attitude noise, rad")
    gyro_std_rad_s: NonNegFloat = Field(default=0.001, description="angular-rate noise, rad/s")
    accel_std_m_s2: NonNegFloat = Field(default=0.0045, description="accelerometer noise, m/s^2")
    depth_rate_std_m_s: NonNegFloat = Field(default=0.0014, description="depth-rate noise, m/s")
    relative_velocity_std_m_s: NonNegFloat = Field(
        default=0.001,
        description="noise of the velocity through the water (Assumption 1: state (eta, nu_r)), m/s",
    )
    imu: ImuSettings = Field(default_factory=ImuSettings)
    ahrs: AhrsSettings = Field(default_factory=AhrsSettings)
    depth: DepthSettings = Field(default_factory=DepthSettings)
    position: PositionSettings = Field(default_factory=PositionSettings)
    dvl: DvlSettings = Field(default_factory=DvlSettings)
    dock_camera: DockCameraSettings = Field(default_factory=DockCameraSettings)
    dock_telemetry: DockTelemetrySettings = Field(default_factory=DockTelemetrySettings)
