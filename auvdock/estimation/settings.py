"""The estimators' settings: the FSE controllers' flow filter (:class:`EstimatorSettings`) and the
navigation filter (:class:`NavigationSettings`), the mission's ``estimator`` and ``navigation``
sections.  Data only (pydantic, no CasADi): reading a mission loads none.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from auvdock.schema.strict import PosFloat, Strict, Vec3

__all__ = ["EstimatorSettings", "NavigationSettings", "FORECAST_HORIZONS_S"]

#: How far ahead the dock's forecast is recorded (``dock_forecast_m``, with ``sensors.dock_telemetry``)
#: and scored, s (here, with no CasADi, so that the results' views name them without the stage).
FORECAST_HORIZONS_S = (0.5, 1.0, 2.0, 3.0)


class EstimatorSettings(Strict):
    """The flow Kalman filter's settings (docs/parameter-sources.md section 5)."""

    prior_flow_ned_m_s: Vec3 = Field(default=[0.0, 0.0, 0.0], description="prior flow estimate, m/s")
    prior_std_m_s: Annotated[float, Field(gt=0)] = Field(
        default=3.0, description="prior standard deviation per axis, m/s (contains the 2 m/s of case 4)"
    )
    process_noise_m2_s2: Annotated[float, Field(ge=0)] = Field(
        default=1e-12, description="Q_f per axis per step, (m/s)^2"
    )
    accel_noise_var: Annotated[float, Field(gt=0)] = Field(
        default=2.029e-5, description="R: accelerometer variance, (m/s^2)^2"
    )
    depth_rate_noise_var: Annotated[float, Field(gt=0)] = Field(
        default=2e-6, description="R: depth-rate variance, (m/s)^2"
    )
    forgetting_factor: Annotated[float, Field(gt=0, le=1)] = Field(
        default=1.0, description="gramian forgetting factor in (0, 1]; 1 = no forgetting"
    )


class NavigationSettings(Strict):
    """Noise model of the navigation filter (standard deviations; densities per sqrt(s)).

    The process noise is the model's error, per state group, as white noise on the state
    derivative: over a step of h seconds a group's variance grows by ``q^2 h``.  For a filter
    whose model equals the truth it can be small (the defaults); unmodelled dynamics
    (damping, buoyancy, thruster errors) go into the velocity and rate terms.
    """

    position_noise_m_sqrt_s: PosFloat = Field(
        default=1e-3, description="process noise of the position, m/sqrt(s)"
    )
    attitude_noise_rad_sqrt_s: PosFloat = Field(
        default=1e-3, description="process noise of the Euler angles, rad/sqrt(s)"
    )
    velocity_noise_m_s_sqrt_s: PosFloat = Field(
        default=0.02, description="process noise of the body linear velocity, m/s/sqrt(s)"
    )
    rate_noise_rad_s_sqrt_s: PosFloat = Field(
        default=0.02, description="process noise of the body angular rate, rad/s/sqrt(s)"
    )
    current_walk_m_s_sqrt_s: PosFloat = Field(
        default=0.005, description="random-walk density of the horizontal current, m/s/sqrt(s)"
    )
    prior_current_std_m_s: PosFloat = Field(
        default=1.0, description="prior standard deviation of each current component (mean zero), m/s"
    )
    accel_bias_walk_m_s2_sqrt_s: PosFloat = Field(
        default=1e-4, description="random-walk density of the accelerometer bias, m/s^2/sqrt(s)"
    )
    gyro_bias_walk_rad_s_sqrt_s: PosFloat = Field(
        default=1e-5, description="random-walk density of the gyro bias, rad/s/sqrt(s)"
    )
    prior_accel_bias_std_m_s2: PosFloat = Field(
        default=0.05, description="prior std of each accelerometer bias component (mean zero), m/s^2"
    )
    prior_gyro_bias_std_rad_s: PosFloat = Field(
        default=0.005, description="prior std of each gyro bias component (mean zero), rad/s"
    )
    dock_walk_m_sqrt_s: PosFloat = Field(
        default=0.005,
        description="random-walk density of the dock's anchor (a moored dock's slow drift), m/sqrt(s)",
    )
    prior_dock_std_m: PosFloat = Field(
        default=0.5,
        description="prior std of the dock's anchor about its charted position (dock.position_ned_m), per "
        "axis, m: how well the vehicle knows where the dock is before its camera sees it",
    )
    prior_position_std_m: PosFloat = Field(default=1.0, description="prior position std, m")
    prior_attitude_std_rad: PosFloat = Field(default=0.1, description="prior Euler-angle std, rad")
    prior_velocity_std_m_s: PosFloat = Field(default=0.5, description="prior body linear velocity std, m/s")
    prior_rate_std_rad_s: PosFloat = Field(default=0.2, description="prior body angular rate std, rad/s")
    substeps: int = Field(default=1, ge=1, le=20, description="RK4 steps per prediction period")
    second_order_prediction: bool = Field(
        default=True,
        description="add the second-order term of the model to the predicted covariance (the "
        "model's rates are worth little while the velocity through the water is uncertain)",
    )
    waves: Literal["auto", "off"] = Field(
        default="auto",
        description="auto: in a mission with waves (sea.waves) the water is a slow current plus a "
        "wave-frequency velocity, a damped oscillator per axis at the sea's mean frequency with the sea "
        "state's orbital spread at the start depth (the statistics a wave buoy reports, not the "
        "realised sea); off: a current only",
    )
    wave_damping_ratio: float = Field(
        default=0.1,
        gt=0.0,
        lt=1.0,
        description="relative damping of the wave oscillators (Fossen 2011, 8.2: 0.05-0.1)",
    )
    dock_heave_error: Literal["auto", "off"] = Field(
        default="auto",
        description="auto: where the dock's motion is forecast from its telemetry (sensors.dock_telemetry), "
        "the filter also estimates the docking point's heave beyond that forecast and its rate (a damped "
        "oscillator at the heave's mean frequency, as large as the forecast's own uncertainty now), so that "
        "the camera's fixes and the motion unit's heave rate correct the forecast at the wave's time scale; "
        "off: the forecast is taken as the dock's motion (the anchor alone is estimated)",
    )
    dock_heave_error_damping: float = Field(
        default=0.5,
        gt=0.0,
        lt=1.0,
        description="relative damping of the dock's heave error oscillator (0.5: a broad band about the "
        "heave's mean frequency; the forecast's error has no one period)",
    )
    settle_s: float = Field(
        default=2.0,
        ge=0.0,
        description="the controllers hold zero thrust for this long while the filter settles "
        "from its prior (its first estimates can be metres per second off), s",
    )
