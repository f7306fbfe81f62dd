"""Mission files: one YAML file says everything about a run.

A mission names the vehicle, the flow, the dock, the start state, the controller, the
estimator and sensors, the docking criterion and the output.  Every value has its unit in
its name or in the field's description; every field except ``name`` has a default (the
paper's setup, docs/parameter-sources.md).  :func:`load_mission` validates a file and raises
:class:`MissionError` -- naming the file, the field path (e.g. ``dock.heave.amplitude_m``)
and the problem -- on any bad input.

Minimal mission::

    name: gyre
    flow: {case: case5}
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
import yaml
from pydantic import (
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from auvdock.config.contact import CaptureSpec, DockBodySpec
from auvdock.config.guidance import GuidanceSettings
from auvdock.config.sea import SeaSpec, WecSpec
from auvdock.controllers.registry import controller_names, settings_for, settings_union, split_controller
from auvdock.controllers.settings import MPCSettings, solver_names
from auvdock.estimation.settings import EstimatorSettings, NavigationSettings
from auvdock.schema.strict import NonNegFloat, PosFloat, Strict, Vec3, Vec12, first_error, fixed_len
from auvdock.schema.yamlio import load_yaml_strict
from auvdock.sensing.settings import SensorSettings
from auvdock.vehicle import preset_names
from auvdock.vehicle.params import VehicleParams, VehicleParamsError, load_params
from auvdock.world.dock import HeaveDock
from auvdock.world.flow import ConstantCurrent, DoubleGyre, FlowField, StillWater, flow_case, flow_case_names
from auvdock.world.spectra import SpectrumFileError

if TYPE_CHECKING:
    from auvdock.camera.model import CameraMount
    from auvdock.sensing.camera_fix import CameraFixSource
    from auvdock.vehicle import Vehicle
    from auvdock.world.dock_body import CaptureLimits, DockBody, HullBox
    from auvdock.world.waves import WaveComponents
    from auvdock.world.wec_dock import WecDock

__all__ = [
    "Mission",
    "MissionError",
    "load_mission",
    "parse_mission",
    "CONTROLLER_TYPES",
    "SOLVER_NAMES",
]

#: The registered controllers (:mod:`auvdock.controllers.registry`) and solvers, by name.
CONTROLLER_TYPES = controller_names()
SOLVER_NAMES = solver_names()


class MissionError(Exception):
    """A mission file is missing or wrong.  ``str(err)`` is the one line shown to users."""

    def __init__(self, file: str | Path, field: str, problem: str) -> None:
        self.file = str(file)
        self.field = field
        self.problem = problem
        where = f"{self.file}: {field}: " if field else f"{self.file}: "
        super().__init__(where + problem)


class VehicleSpec(Strict):
    """Which vehicle: a shipped preset or a parameter file, plus overrides."""

    preset: str | None = Field(
        default=None,
        description=(
            "shipped parameter set: bluerov2_heavy (default, 8 thrusters), "
            "bluerov2_heavy_vonbenzon or bluerov2 (standard frame, 6 thrusters)"
        ),
    )
    file: str | None = Field(
        default=None, description="path of a parameter YAML file (relative to the mission)"
    )
    overrides: dict[str, Any] = Field(
        default_factory=dict, description="parameter keys to replace, e.g. mass_kg"
    )
    thruster_voltage_V: Literal[12, 16] = Field(
        default=16, description="battery voltage; selects T200 limits"
    )

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, v: str | None) -> str | None:
        if v is not None and v not in preset_names():
            raise ValueError(f"unknown vehicle preset {v!r} (known: {', '.join(preset_names())})")
        return v

    @model_validator(mode="after")
    def _one_source(self) -> VehicleSpec:
        if self.preset is not None and self.file is not None:
            raise ValueError("give either preset or file, not both")
        if self.preset is None and self.file is None:
            self.preset = "bluerov2_heavy"
        return self


class FlowSpec(Strict):
    """The water: a paper case by name, or an explicit field."""

    case: str | None = Field(default=None, description="case1..case6 or an alias (still, gyre, ...)")
    type: Literal["still", "constant", "double_gyre"] | None = Field(
        default=None, description="explicit field"
    )
    velocity_ned_m_s: list[float] | None = Field(
        default=None, description="constant current (north, east) or (north, east, 0), m/s"
    )
    amplitude_m_s: NonNegFloat | None = Field(
        default=None, description="double gyre A (peak speed ~ pi A), m/s"
    )
    period_h: PosFloat | None = Field(default=None, description="double gyre period T, hours")
    epsilon: NonNegFloat = Field(default=0.3, description="double gyre eps")

    @field_validator("case")
    @classmethod
    def _known_case(cls, v: str | None) -> str | None:
        if v is not None:
            try:
                flow_case(v)
            except KeyError:
                raise ValueError(f"unknown flow case {v!r} (known: {', '.join(flow_case_names())})") from None
        return v

    @field_validator("velocity_ned_m_s")
    @classmethod
    def _velocity(cls, v: list[float] | None) -> list[float] | None:
        if v is None:
            return v
        if len(v) not in (2, 3):
            raise ValueError(f"must have 2 or 3 values, got {len(v)}")
        if len(v) == 3 and v[2] != 0:
            raise ValueError("the down component must be 0 (paper Assumption 4)")
        return v

    @model_validator(mode="after")
    def _one_way(self) -> FlowSpec:
        if self.case is not None and self.type is not None:
            raise ValueError("give either case or type, not both")
        if self.case is None and self.type is None:
            self.case = "case1"
        if self.type == "constant" and self.velocity_ned_m_s is None:
            raise ValueError("type constant needs velocity_ned_m_s")
        if self.type == "double_gyre" and (self.amplitude_m_s is None or self.period_h is None):
            raise ValueError("type double_gyre needs amplitude_m_s and period_h")
        return self

    def build(self) -> FlowField:
        """The flow field this spec describes."""
        if self.case is not None:
            return flow_case(self.case)
        if self.type == "still":
            return StillWater()
        if self.type == "constant":
            v = self.velocity_ned_m_s or [0.0, 0.0]
            return ConstantCurrent(float(v[0]), float(v[1]))
        if self.amplitude_m_s is None or self.period_h is None:  # _one_way's rule; for mypy
            raise ValueError("type double_gyre needs amplitude_m_s and period_h")
        return DoubleGyre(float(self.amplitude_m_s), float(self.period_h) * 3600.0, float(self.epsilon))


class HeaveSpec(Strict):
    """Dock heave z(t) = z0 + A sin(w t + phase) (paper eq. 7)."""

    amplitude_m: NonNegFloat = Field(default=0.5, description="heave amplitude A, m")
    angular_frequency_rad_s: NonNegFloat | None = Field(default=None, description="w, rad/s (default 0.1)")
    frequency_hz: NonNegFloat | None = Field(default=None, description="w / (2 pi), Hz (instead of w)")
    phase_rad: float = Field(default=0.0, description="phase at t = 0, rad")

    @model_validator(mode="after")
    def _one_frequency(self) -> HeaveSpec:
        w, f = self.angular_frequency_rad_s, self.frequency_hz
        # both are allowed only when they agree (a resolved mission written back by to_yaml)
        if (
            w is not None
            and f is not None
            and not math.isclose(w, 2 * math.pi * f, rel_tol=1e-9, abs_tol=1e-12)
        ):
            raise ValueError("give either angular_frequency_rad_s or frequency_hz, not both")
        if self.angular_frequency_rad_s is None:
            self.angular_frequency_rad_s = (
                0.1 if self.frequency_hz is None else 2 * math.pi * self.frequency_hz
            )
        return self


class DockSpec(Strict):
    """The dock (WEC) and its motion."""

    position_ned_m: Vec3 = Field(default=[2.0, 3.0, 5.0], description="mean position (north, east, down), m")
    heading_deg: float = Field(default=0.0, description="target heading of the docked vehicle, degrees")
    position_std_m: NonNegFloat = Field(
        default=0.0,
        description="in simulation the dock really is this far from position_ned_m, drawn per seed (std per "
        "horizontal axis, m: a chart's error, a moored buoy's watch circle); the vehicle believes "
        "position_ned_m (navigation.prior_dock_std_m its uncertainty) until its camera sees the dock",
    )
    heave: HeaveSpec = Field(default_factory=HeaveSpec)
    wec: WecSpec | None = Field(
        default=None,
        description="the dock hangs below a WEC buoy heaving in the mission's sea (its linear "
        "hydrodynamics); omitted: the paper's sinusoidal heave (dock.heave)",
    )
    body: DockBodySpec = Field(
        default_factory=DockBodySpec,
        description="the docking station's geometry (entry funnel, cradle, back plate, frame), for "
        "docking.criterion: capture",
    )
    source: Literal["model", "mavlink", "camera"] = Field(
        default="model",
        description=(
            "fly: where the dock's position comes from: model (this motion, placed relative to the "
            "vehicle's pose at the start as the start state is), mavlink (LANDING_TARGET messages "
            "from a positioning or vision system re-anchor this motion) or camera (the fiducial "
            "markers of dock.markers seen by the camera of the camera section re-anchor it)"
        ),
    )
    markers: dict[str, Any] | None = Field(
        default=None,
        description=(
            "fiducial markers on the dock's back panel: {dictionary: apriltag_36h11 | aruco_4x4_50 | "
            "..., markers: [{id, size_m, position_dock_m, rpy_deg}]} in the dock frame (origin at the "
            "docking point, x along the docked heading); omitted: auvdock.camera.default_layout()"
        ),
    )

    @field_validator("markers")
    @classmethod
    def _valid_layout(cls, v: dict[str, Any] | None) -> dict[str, Any] | None:
        if v is None:
            return v
        from auvdock.camera.layout import MarkerLayout

        return MarkerLayout.from_dict(v).to_dict()

    def marker_layout(self):
        """The :class:`auvdock.camera.MarkerLayout` of the dock (the default one if not given)."""
        from auvdock.camera.layout import MarkerLayout, default_layout

        return default_layout() if self.markers is None else MarkerLayout.from_dict(self.markers)

    @model_validator(mode="after")
    def _one_motion(self) -> DockSpec:
        if self.wec is not None and "heave" in self.model_fields_set and self.heave != HeaveSpec():
            raise ValueError("give either heave (the paper's sinusoid) or wec (a buoy in the sea), not both")
        return self

    def build(self) -> HeaveDock:
        """The paper's sinusoidal dock this spec describes (:meth:`Mission.build_dock` builds a WEC dock)."""
        h = self.heave
        return HeaveDock(
            position_ned_m=tuple(float(v) for v in self.position_ned_m),  # type: ignore[arg-type]
            heading_rad=math.radians(self.heading_deg),
            amplitude_m=h.amplitude_m,
            angular_frequency_rad_s=float(h.angular_frequency_rad_s or 0.0),
            phase_rad=h.phase_rad,
        )


class StartSpec(Strict):
    """Initial vehicle state."""

    state: Vec12 = Field(
        default=[0.0, 0.0, 5.0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
        description="[x y z (NED m), phi theta psi (rad), u v w (body m/s over ground), p q r (rad/s)]",
    )
    position_std_m: NonNegFloat = Field(
        default=0.0,
        description="in simulation the vehicle really starts this far from state's position, drawn per "
        "seed (std per horizontal axis, m: a vehicle placed by hand, a GPS fix at the surface); what the "
        "vehicle believes is state (navigation.prior_position_std_m its uncertainty)",
    )


class DockingSpec(Strict):
    """When a run ends."""

    criterion: Literal["point", "capture"] = Field(
        default="point",
        description="point: docked within tolerance_m of the docking point (the paper's); capture: the "
        "nose inside the dock's cradle, aligned and slow (docking.capture), or collided with its body",
    )
    tolerance_m: PosFloat = Field(
        default=0.05, description="criterion point: docked when within this distance of the dock, m"
    )
    capture: CaptureSpec = Field(default_factory=CaptureSpec)
    timeout_s: PosFloat = Field(default=75.0, description="give up after this simulated time, s")


class SimulationSpec(Strict):
    """Truth simulation settings."""

    substeps: Annotated[int, Field(ge=1)] = Field(default=4, description="RK4 substeps per control period")
    actuators: Literal["ideal", "ardusub"] = Field(
        default="ideal",
        description="actuator path: ideal (the commanded thrust applied exactly, the paper's "
        "idealisation) or ardusub (RC override channels, ArduSub's VECTORED_6DOF mixer, PWM "
        "limits and the thruster curve with its dead band, as fly flies it; 8 thrusters)",
    )


class GeofenceSpec(Strict):
    """fly: abort when the vehicle leaves this region (mission frame)."""

    max_distance_m: PosFloat = Field(default=6.0, description="largest horizontal distance from the start, m")
    min_depth_m: float = Field(default=0.1, description="shallowest allowed depth, m")
    max_depth_m: PosFloat = Field(default=10.0, description="deepest allowed depth, m")


class FlySpec(Strict):
    """Flying a real vehicle (auvdock fly): telemetry and safety limits."""

    telemetry_rate_hz: PosFloat = Field(default=25.0, description="requested telemetry rate, Hz")
    stale_neutral_s: PosFloat = Field(
        default=0.3, description="no ATTITUDE or position for this long: neutral thrust, s"
    )
    stale_abort_s: PosFloat = Field(
        default=2.0, description="no ATTITUDE or position for this long: abort, s"
    )
    max_failed_solves: Annotated[int, Field(ge=1, le=10_000)] = Field(
        default=20,
        description="abort after this many controller steps in a row without a converged solve "
        "(each one flown with the bounded fallback: the last plan briefly, then neutral)",
    )
    geofence: GeofenceSpec = Field(default_factory=GeofenceSpec)
    timesync_period_s: PosFloat = Field(
        default=0.5,
        description="send a MAVLink TIMESYNC request this often, s: the round trip and the vehicle's clock "
        "(each reading's age) are measured on the answers (auvdock.fly.link_health)",
    )
    delay_compensation: bool = Field(
        default=True,
        description="readings stamped on the vehicle's clock, and the state predicted with the one model "
        "over each reading's age plus the command's delivery delay (half the round trip), under the "
        "commands already sent (auvdock.estimation.delay); false: readings stamped on arrival, none",
    )
    max_round_trip_s: PosFloat = Field(
        default=0.8,
        description="a median TIMESYNC round trip above this refuses to arm, and in flight holds "
        "(neutral) and aborts after link_hold_s, s",
    )
    max_link_loss: Annotated[float, Field(ge=0.0, le=1.0)] = Field(
        default=0.3,
        description="a fraction of the vehicle's messages lost (MAVLink sequence gaps, last 1000) above "
        "this refuses to arm, and in flight holds and aborts after link_hold_s",
    )
    link_hold_s: PosFloat = Field(
        default=3.0,
        description="in flight, a link beyond its limits this long aborts (held neutral meanwhile), s",
    )
    telemetry_timeout_s: PosFloat = Field(
        default=60.0,
        description="wait this long for the telemetry the estimation needs (ArduSub's position "
        "estimate comes about 40 s after boot in SITL), s",
    )
    arm_timeout_s: PosFloat = Field(
        default=30.0, description="keep trying to arm (pre-arm checks may still be settling) this long, s"
    )
    start_depth_tolerance_m: PosFloat = Field(
        default=0.3,
        description="refuse to arm unless the pressure sensor's depth is this close to the mission's "
        "start depth, m",
    )
    frame_heading: Literal["auto", "vehicle", "source"] = Field(
        default="auto",
        description="how the mission frame is turned: vehicle (the mission is drawn about the vehicle's "
        "start pose: the frame turns by its measured heading, and a compass error turns every position), "
        "source (the mission is drawn in the position source's frame: positions are moved, not turned), "
        "auto (vehicle for dead-reckoned positions, sensors.position.source none or dvl_dead_reckoning; "
        "source for an outside fix: acoustic, camera, motion_capture)",
    )
    preflight_window_s: PosFloat = Field(
        default=2.0,
        description="the mission frame (the vehicle's start pose) is set on the mean of the position and "
        "heading readings over the last this long, and the pre-flight depth check reads the median of the "
        "pressure readings over it (at least 10 of each, awaited if fewer), s: one heading of a compass "
        "with 2 deg of noise turns the whole frame (7 cm at a dock 2 m away), and one reading of SITL's "
        "second barometer (0.2 m of noise by default) would refuse to arm at random",
    )
    min_battery_v: NonNegFloat = Field(
        default=13.6,
        description="abort below this battery voltage (SYS_STATUS), V (3.4 V per cell of the "
        "BlueROV2's 4S pack; 0: no floor)",
    )
    time_limit_s: PosFloat | None = Field(
        default=None,
        description="abort this long after arming (a dry run: after the start), s "
        "(default: docking.timeout_s + 60 s)",
    )
    rates_refresh_s: PosFloat = Field(
        default=5.0,
        description="re-request the telemetry rates this often (a ground station may reset them), s",
    )
    hold_bandwidth_rad_s: PosFloat = Field(
        default=1.0,
        description="the lost-camera hold's depth and attitude loop: natural frequency, rad/s "
        "(critically damped)",
    )
    parameters: dict[str, float] = Field(
        default_factory=dict,
        description="vehicle parameters that must have these values before arming (e.g. the "
        "MOT_n_DIRECTION found in a thruster test)",
    )


class CameraMountSpec(Strict):
    """Where the camera sits on the vehicle."""

    position_body_m: Vec3 = Field(default=[0.2, 0.0, 0.0], description="camera centre in {b}, m")
    rpy_deg: Vec3 = Field(
        default=[0.0, 0.0, 0.0],
        description="rotation from the forward-looking mount (optical axis = body x), deg (roll, pitch, yaw)",
    )

    def build(self) -> CameraMount:
        """The camera mount this spec describes."""
        from auvdock.camera.model import CameraMount

        x, y, z = self.position_body_m
        roll, pitch, yaw = self.rpy_deg
        return CameraMount((x, y, z), (roll, pitch, yaw))


class SyntheticCameraSpec(Strict):
    """camera.source: synthetic -- rendered views of the dock's markers (rehearsal, tests)."""

    rate_hz: PosFloat = Field(default=15.0, description="frame rate, Hz")
    noise_std: NonNegFloat = Field(default=2.0, description="additive image noise, grey levels")
    blur_px: NonNegFloat = Field(default=0.5, description="Gaussian blur sigma, px")
    dock_offset_m: Vec3 = Field(
        default=[0.0, 0.0, 0.0],
        description="where the rendered dock really is relative to the mission's dock, NED m",
    )
    dropout_s: list[Annotated[list[NonNegFloat], fixed_len(2)]] = Field(
        default_factory=list,
        description="[start, end] mission times (s) during which no marker is visible (rehearse losses)",
    )


class CameraSpec(Strict):
    """fly with dock.source: camera -- the camera, its calibration and lost-tracking limits."""

    source: str = Field(
        default="udp:5600",
        description=(
            "udp:PORT (RTP/H.264 from BlueOS), /dev/videoN or v4l2:N, a video file, a folder of "
            "images, or synthetic"
        ),
    )
    calibration: str | None = Field(
        default=None,
        description=(
            "camera file from auvdock calibrate (relative to the mission, else a shipped one: "
            "cameras/ideal_640x480_80deg.yaml); required unless the source is synthetic (then an ideal "
            "640x480, 80 deg camera)"
        ),
    )
    mount: CameraMountSpec = Field(default_factory=CameraMountSpec)
    synthetic: SyntheticCameraSpec = Field(default_factory=SyntheticCameraSpec)
    max_reprojection_px: PosFloat = Field(
        default=3.0, description="a marker whose corners miss the fused pose by more is rejected, px"
    )
    hold_s: PosFloat = Field(
        default=1.0, description="dock lost: keep flying on the filter's prediction this long, s"
    )
    abort_s: PosFloat = Field(
        default=5.0, description="dock lost this long (neutral thrust after hold_s): abort, s"
    )
    process_noise_m_s: PosFloat = Field(
        default=0.05,
        description="random walk of the dock position about its heave model (tracking filter), m/sqrt(s)",
    )

    @model_validator(mode="after")
    def _hold_before_abort(self) -> CameraSpec:
        if self.abort_s <= self.hold_s:
            raise ValueError(f"abort_s ({self.abort_s:g}) must be larger than hold_s ({self.hold_s:g})")
        return self


class OutputSpec(Strict):
    """Where results go."""

    dir: str = Field(default="runs", description="output directory (relative to the working directory)")


class Mission(Strict):
    """A complete, validated mission."""

    name: str = Field(description="mission name, used in file names")
    description: str = Field(default="", description="free text")
    vehicle: VehicleSpec = Field(default_factory=VehicleSpec)
    flow: FlowSpec = Field(default_factory=FlowSpec)
    dock: DockSpec = Field(default_factory=DockSpec)
    start: StartSpec = Field(default_factory=StartSpec)
    controller: settings_union() = Field(  # type: ignore[valid-type]
        default_factory=lambda: settings_for("oracle"),
        description="the docking controller: type (naive, kinematic, oracle, sequential, "
        "optimized, ce) and its settings; fields of other types are errors",
    )
    # One name, kept for two sources (issue 38): "truth" is the state the controller is handed without an
    # estimator of auvdock's own -- in sim the true state (the paper's Assumption 1), on a vehicle the
    # autopilot's own estimate (ArduSub's EKF: ATTITUDE, LOCAL_POSITION_NED), the nearest a vehicle has;
    # fly says which in its log.  Renaming it would break every mission written since the paper's.
    estimation: Literal["truth", "filter"] = Field(
        default="truth",
        description="what every controller takes its state from: truth (the paper's Assumption 1; on a "
        "vehicle the autopilot's own estimate) or filter (the navigation filter on the sensor suite: "
        "auvdock.estimation.stage)",
    )
    navigation: NavigationSettings = Field(default_factory=NavigationSettings)
    guidance: GuidanceSettings = Field(
        default_factory=GuidanceSettings,
        description="with a dock camera (sensors.dock_camera, estimation: filter): the approach through a "
        "standoff point and the lost-target policy (auvdock.loop.guidance)",
    )
    estimator: EstimatorSettings = Field(default_factory=EstimatorSettings)
    sensors: SensorSettings = Field(default_factory=SensorSettings)
    docking: DockingSpec = Field(default_factory=DockingSpec)
    simulation: SimulationSpec = Field(default_factory=SimulationSpec)
    sea: SeaSpec = Field(
        default_factory=SeaSpec, description="water depth and waves (omitted: no waves, as in the paper)"
    )
    fly: FlySpec = Field(default_factory=FlySpec)
    camera: CameraSpec = Field(default_factory=CameraSpec)
    seed: Annotated[int, Field(ge=0)] = Field(
        default=0, description="random seed (sensor noise; the sea's phases on a stream of their own)"
    )
    output: OutputSpec = Field(default_factory=OutputSpec)

    # where the file was read from (not part of the schema)
    _source: Path | None = None

    @model_validator(mode="before")
    @classmethod
    def _controller_type_default(cls, data: Any) -> Any:
        """A controller section without ``type`` is the default controller's (oracle)."""
        if isinstance(data, dict) and isinstance(data.get("controller"), dict):
            if "type" not in data["controller"]:
                data = {**data, "controller": {"type": "oracle", **data["controller"]}}
        return data

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        if not v.strip():
            raise ValueError("must not be empty")
        return v

    @property
    def source(self) -> Path | None:
        """The mission file this mission was read from, if any."""
        return self._source

    def vehicle_params(self) -> VehicleParams:
        """The parameters of the vehicle the mission names, with its overrides (no model built:
        what validating a mission checks, without CasADi).  Raises
        :class:`auvdock.vehicle.params.VehicleParamsError`."""
        v = self.vehicle
        if v.file is not None:
            p = Path(v.file)
            if not p.is_absolute() and self._source is not None:
                p = self._source.parent / p
            target: str | Path = p
        else:
            target = v.preset or "bluerov2_heavy"
        return load_params(target, v.overrides or None, v.thruster_voltage_V)

    def build_vehicle(self) -> Vehicle:
        """The vehicle the mission names, with its overrides."""
        from auvdock.vehicle.vehicle import shared_vehicle  # the model (CasADi): when built, not when read

        return shared_vehicle(self.vehicle_params())

    def build_camera(self):
        """The camera model (:class:`auvdock.camera.CameraModel`) of ``camera.calibration``.

        Raises
        ------
        MissionError
            No calibration file for a real camera, or a file that does not read.
        """
        from auvdock.camera.model import CameraModel, load_camera

        c = self.camera
        where = self._source or "mission"
        if c.calibration is None:
            if c.source == "synthetic":
                return CameraModel.ideal()
            raise MissionError(
                where,
                "camera.calibration",
                f"a camera file is required for source {c.source!r} (make one with auvdock calibrate)",
            )
        p = Path(c.calibration)
        if not p.is_absolute():  # beside the mission; else a shipped camera file (as missions go by name)
            from auvdock.config.catalog import missions_dir

            beside = p if self._source is None else self._source.parent / p
            shipped = missions_dir() / p
            p = beside if beside.exists() or not shipped.exists() else shipped
        try:
            return load_camera(p)
        except (OSError, ValueError) as e:
            raise MissionError(where, "camera.calibration", str(e)) from None

    def build_camera_fix(self) -> CameraFixSource:
        """The camera of ``sensors.dock_camera``: the fast model of its fixes
        (:class:`auvdock.sensing.camera_fix.CameraFixModel`) or, with ``model: rendered``, the real
        rendering + detection + pose pipeline (:class:`auvdock.sensing.camera_rendered.RenderedCameraFix`);
        the camera's intrinsics (its calibration file, else the ideal 640 x 480, 80 deg camera),
        ``camera.mount`` and the dock's markers."""
        from auvdock.camera.model import CameraModel
        from auvdock.sensing.camera_fix import CameraFixModel

        camera = self.build_camera() if self.camera.calibration is not None else CameraModel.ideal()
        s = self.sensors.dock_camera
        mount = self.camera.mount.build()
        if s.model == "rendered":
            from auvdock.sensing.camera_rendered import RenderedCameraFix

            return RenderedCameraFix(camera, mount, self.dock.marker_layout(), s)
        return CameraFixModel(
            camera,
            mount,
            self.dock.marker_layout(),
            visibility_m=s.visibility_m,
            min_side_px=s.min_side_px,
            max_view_angle_deg=s.max_view_angle_deg,
            corner_px=s.corner_px,
            dropout=s.dropout,
            marker_contrast_grey=s.marker_contrast_grey,
            min_contrast_grey=s.min_contrast_grey,
        )

    def build_flow(self) -> FlowField:
        """The true flow field."""
        return self.flow.build()

    def build_sea(self) -> WaveComponents | None:
        """The realised sea (None without waves): the same components from the same seed every call.

        The waves ride the current at the dock's mean position at t = 0 (``sea.doppler``).
        """
        if self.sea.waves is None:
            return None
        p = np.asarray(self.dock.position_ned_m, dtype=float)
        v = self.build_flow().velocity(p, 0.0)
        base = self._source.parent if self._source is not None else None
        return self.sea.build(self.seed, self.controller.dt_s, (float(v[0]), float(v[1])), base)

    def build_dock(self, sea: WaveComponents | None = None, *, truth: bool = False) -> HeaveDock | WecDock:
        """The dock: the paper's sinusoid, or a WEC buoy heaving in the sea (``dock.wec``).

        ``sea``: the realised sea (default: :meth:`build_sea`), so that the plant's water and the
        dock's motion come from one object.  ``truth``: where the simulated dock really is, moved
        by :meth:`true_dock_offset` (``dock.position_std_m``); otherwise where the mission charts it.
        """
        position = np.asarray(self.dock.position_ned_m, dtype=float)
        if truth:
            position = position + self.true_dock_offset()
        if self.dock.wec is None:
            dock = self.dock.build()
            if truth and self.dock.position_std_m > 0:
                n, e, d = (float(v) for v in position)
                dock = dataclasses.replace(dock, position_ned_m=(n, e, d))
            return dock
        from auvdock.world.wec_dock import WecDock
        from auvdock.world.wec_table import load_heave_table

        sea = self.build_sea() if sea is None else sea
        if sea is None:
            raise ValueError("dock.wec: a WEC dock moves with the waves; give sea.waves")
        w = self.dock.wec
        table = Path(w.table)
        if table.suffix == "" and not table.exists():
            coefficients = load_heave_table(w.table)
        else:
            if not table.is_absolute() and self._source is not None:
                table = self._source.parent / table
            coefficients = load_heave_table(table)
        return WecDock.from_coefficients(
            sea,
            coefficients,
            tuple(float(v) for v in position),  # type: ignore[arg-type]
            math.radians(self.dock.heading_deg),
            pto_damping_N_s_m=w.pto_damping_N_s_m,
            viscous_damping_N_s_m=w.viscous_damping_N_s_m,
            mooring_stiffness_N_m=w.mooring_stiffness_N_m,
        )

    def build_contact(self, dock: Any = None) -> tuple[DockBody, HullBox, CaptureLimits] | None:
        """The dock's body, the vehicle's hull and the capture limits (``docking.criterion: capture``),
        else None.  ``dock``: the built dock (a WEC dock's buoy becomes a solid above the cradle)."""
        if self.docking.criterion != "capture":
            return None
        from auvdock.world.dock_body import HullBox, WecBuoy

        L, W, H = (float(v) for v in self.vehicle_params().hull_box_m)
        hull = HullBox(length_m=L, width_m=W, height_m=H)
        buoy = None
        coef = getattr(dock, "coefficients", None)
        if self.dock.wec is not None and coef is not None:
            buoy = WecBuoy.above(float(self.dock.position_ned_m[2]), coef.radius_m, coef.draft_m)
        layout = self.dock.marker_layout()
        panel_x = max(float(m.position_dock_m[0]) for m in layout.markers)
        body = self.dock.body.build(hull, buoy, panel_x)
        limits = self.docking.capture.build()
        limits.check(body, hull)
        return body, hull, limits

    def world_problem(self) -> tuple[str, str] | None:
        """The first impossible setting of the sea and the dock in it, as (field path, problem), or None.

        A period the run cannot resolve, water shallower than the dock or the vehicle, a WEC
        dock without waves, a spectrum or coefficient file that does not read.
        """
        sea = self.sea
        bad = sea.check(self.controller.dt_s)
        if bad is not None:
            return bad
        h = sea.depth_m
        dock_depth = float(self.dock.position_ned_m[2])
        if dock_depth >= h:
            return ("sea.water_depth_m", f"{h:g} m, but the dock is at {dock_depth:g} m depth")
        start_depth = float(self.start.state[2])
        if start_depth >= h:
            return ("sea.water_depth_m", f"{h:g} m, but the vehicle starts at {start_depth:g} m depth")
        if self.dock.wec is not None and sea.waves is None:
            return ("dock.wec", "a WEC dock moves with the waves; give sea.waves")
        try:
            realised = self.build_sea()
        except SpectrumFileError as e:
            return ("sea.waves.file", str(e))
        except ValueError as e:
            return ("sea.waves", str(e))
        dock: Any = None
        if self.dock.wec is not None:
            try:
                dock = self.build_dock(realised)
            except ValueError as e:
                return ("dock.wec.table", str(e))
        if self.docking.criterion == "capture":
            try:
                self.build_contact(dock)
            except ValueError as e:
                return ("dock.body", str(e))
        return None

    def start_state(self) -> np.ndarray:
        """Initial state (12,): where the vehicle believes it starts."""
        return np.asarray(self.start.state, dtype=float)

    def _truth_draws(self) -> np.ndarray:
        """(start N, E, dock N, E) offsets of this seed's truth, standard normal, on a stream of
        their own (adding them changes no other draw)."""
        return np.random.default_rng([int(self.seed), 27]).standard_normal(4)

    def true_start_state(self) -> np.ndarray:
        """Where the simulated vehicle really starts (12,): ``start.state`` moved by this seed's draw
        of ``start.position_std_m`` (north, east)."""
        x = self.start_state().copy()
        x[0:2] += self.start.position_std_m * self._truth_draws()[0:2]
        return x

    def true_dock_offset(self) -> np.ndarray:
        """Where the simulated dock really is relative to ``dock.position_ned_m`` (3,, NED m): this
        seed's draw of ``dock.position_std_m`` (north, east; zero down)."""
        out = np.zeros(3)
        out[0:2] = self.dock.position_std_m * self._truth_draws()[2:4]
        return out

    def resolved(self) -> dict[str, Any]:
        """The mission with every default filled in, as plain data."""
        return self.model_dump(mode="json")

    def to_yaml(self) -> str:
        """The resolved mission as YAML text (stored in every results file)."""
        return yaml.safe_dump(self.resolved(), sort_keys=False)

    def with_controller(self, spec: str) -> Mission:
        """A copy flown by controller ``spec`` (``NAME`` or ``NAME@VARIANT``, e.g.
        ``sequential@paper``): shared settings kept, its own defaulted, the variant set if given.

        See :func:`auvdock.controllers.registry.settings_for`; ValueError for an unknown name
        or variant.
        """
        name, variant = split_controller(spec)
        m = self
        if name != self.controller.type:
            m = self.model_copy(update={"controller": settings_for(name, self.controller)})
            m._source = self._source
        if variant is not None and variant != m.controller.variant:
            c = m.controller.model_copy(update={"variant": variant})
            m = m.model_copy(update={"controller": c})
            m._source = self._source
        return m

    def with_updates(
        self, changes: dict[str, Any] | None = None, /, *, where: str | Path | None = None, **more: Any
    ) -> Mission:
        """A validated copy of the mission with some fields changed.

        Parameters
        ----------
        changes : mapping of str to any, optional
            Field path -> new value (positional only; merged with ``**more``, which wins).
        where : str or Path, optional
            What an error names as the source of the changes, e.g. ``"simulate"`` (default:
            the mission's file, or ``"<mission>"``).
        **more
            More changes, ``path=value``.

        A path names a field from the top of the mission, its parts joined by ``.`` or by
        ``__`` (the spelling a Python keyword allows): ``{"docking.timeout_s": 20}`` and
        ``docking__timeout_s=20`` are the same change.  A part that is a number indexes a
        list (``dock__position_ned_m__2=6.0``: the dock's depth).  A mapping given for a
        *section* (a group of fields: ``docking``, ``controller``, ``dock.heave``, ...)
        changes the fields it names, recursively, and keeps the others:
        ``docking={"timeout_s": 20}`` is ``docking__timeout_s=20``.  Any other value -- a
        list, or a mapping for a free-form mapping field such as ``vehicle.overrides`` --
        replaces the field whole.  Values are the mission file's (units in the field
        names); numpy arrays and scalars are taken as lists and numbers.

        ``controller.type`` switches the controller as :meth:`with_controller` does (the
        other type's own fields are dropped), before the other changes apply, so
        ``{"controller.type": "optimized", "controller.alpha": 2e-3}`` works.  Setting one
        of two alternative fields clears the other unless both are given: ``flow.case`` /
        ``flow.type``, ``dock.heave.angular_frequency_rad_s`` / ``dock.heave.frequency_hz``,
        ``vehicle.preset`` / ``vehicle.file``.

        Returns
        -------
        Mission
            The new mission (``source`` kept); this one is unchanged.

        Raises
        ------
        MissionError
            One line naming ``where``, the field path and the problem, for a field that does
            not exist (``simulate: docking.tolerence_m: no such field (did you mean
            tolerance_m?)``) or a value the mission refuses (``simulate: docking.timeout_s:
            input should be greater than 0 (got -1)``); nothing is changed.
        """
        import difflib
        from collections.abc import Mapping as _Mapping

        from pydantic import BaseModel

        from auvdock.controllers.registry import CONTROLLERS

        label: str | Path = where if where is not None else (self._source or "<mission>")
        alternatives = {
            ("flow", "case"): ("flow", "type"),
            ("flow", "type"): ("flow", "case"),
            ("dock", "heave", "angular_frequency_rad_s"): ("dock", "heave", "frequency_hz"),
            ("dock", "heave", "frequency_hz"): ("dock", "heave", "angular_frequency_rad_s"),
            ("vehicle", "preset"): ("vehicle", "file"),
            ("vehicle", "file"): ("vehicle", "preset"),
        }

        def plain(value: Any) -> Any:
            """numpy arrays / scalars, tuples and paths as the plain data a mission file holds."""
            if isinstance(value, np.ndarray):
                return value.tolist()
            if isinstance(value, np.generic):
                return value.item()
            if isinstance(value, tuple):
                return [plain(v) for v in value]
            if isinstance(value, Path):
                return str(value)
            return value

        def node_at(root: Any, parts: tuple[str, ...]) -> Any:
            """The value at ``parts`` (None where the path does not lead)."""
            node = root
            for part in parts:
                if isinstance(node, BaseModel) and part in type(node).model_fields:
                    node = getattr(node, part)
                elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
                    node = node[int(part)]
                else:
                    return None
            return node

        def flatten(prefix: tuple[str, ...], value: Any, out: dict[tuple[str, ...], Any]) -> None:
            if isinstance(value, _Mapping) and isinstance(node_at(self, prefix), BaseModel):
                for key, sub in value.items():
                    flatten((*prefix, *str(key).replace("__", ".").split(".")), sub, out)
            else:
                out[prefix] = plain(value)

        def problem_at(root: Any, parts: tuple[str, ...]) -> tuple[str, str] | None:
            """``(shown path, problem)`` if ``parts`` is not a field of ``root``, else None."""
            node = root
            for i, part in enumerate(parts):
                here = ".".join(parts[: i + 1])
                if isinstance(node, BaseModel):
                    fields = list(type(node).model_fields)
                    if part in fields:
                        node = getattr(node, part)
                        continue
                    section = ".".join(parts[:i]) or "the mission"
                    if parts[:i] == ("controller",) and isinstance(node, MPCSettings):
                        owners = [n for n, e in CONTROLLERS.items() if part in e.settings.model_fields]
                        if owners:
                            return here, (
                                f"no such field for controller type {node.type} (a setting of "
                                f"{', '.join(owners)}: set controller.type too)"
                            )
                    close = difflib.get_close_matches(part, fields, n=1, cutoff=0.6)
                    hint = f"did you mean {close[0]}?" if close else f"{section} has: {', '.join(fields)}"
                    return here, f"no such field ({hint})"
                if isinstance(node, dict):  # a free-form mapping (vehicle.overrides, ...): any key
                    return None
                if isinstance(node, list):
                    if part.isdigit() and int(part) < len(node):
                        node = node[int(part)]
                        continue
                    where_list = ".".join(parts[:i])
                    return here, f"no such element ({where_list} has {len(node)}: 0..{len(node) - 1})"
                return here, f"{'.'.join(parts[:i])} is a value, not a section: set it whole"
            return None

        flat: dict[tuple[str, ...], Any] = {}
        for key, value in {**dict(changes or {}), **more}.items():
            parts = tuple(str(key).replace("__", ".").split("."))
            if not all(parts):
                raise MissionError(label, str(key), "not a field path (parts joined by . or __)")
            flatten(parts, value, flat)

        base = self
        if ("controller", "type") in flat:
            spec = flat.pop(("controller", "type"))
            try:
                base = self.with_controller(str(spec))
            except ValueError as e:
                raise MissionError(label, "controller.type", str(e)) from None
        for parts in flat:
            bad = problem_at(base, parts)
            if bad is not None:
                raise MissionError(label, *bad)
        for parts, other in alternatives.items():
            if flat.get(parts) is not None and other not in flat:
                flat[other] = None

        data = base.resolved()
        for parts, value in flat.items():
            node: Any = data
            for k in parts[:-1]:
                node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
            last = parts[-1]
            node[int(last) if isinstance(node, list) else last] = value
        try:
            m = Mission.model_validate(data)
        except ValidationError as e:
            raise MissionError(label, *first_error(Mission, e)) from None
        m._source = self._source
        if any(p[0] == "vehicle" or p[:2] == ("controller", "weights") for p in flat) or base is not self:
            try:
                n = len(m.vehicle_params().thrust_limits_N)
            except VehicleParamsError as e:
                field = "vehicle" if e.field == "vehicle" else f"vehicle.{e.field}"
                raise MissionError(label, field, e.message) from None
            try:
                m.controller.weights.R_for(n)
            except ValueError as e:
                raise MissionError(label, "controller.weights.R", str(e)) from None
        world = ("sea", "dock", "start", "seed", "controller", "flow")
        if any(p[0] in world for p in flat) or base is not self:
            bad = m.world_problem()
            if bad is not None:
                raise MissionError(label, *bad)
        return m


def parse_mission(data: Any, source: str | Path = "<mission>") -> Mission:
    """Validate already-parsed mission data; raises :class:`MissionError`."""
    if not isinstance(data, dict):
        raise MissionError(source, "", "a mission file must hold a YAML mapping (key: value pairs)")
    try:
        m = Mission.model_validate(data)
    except ValidationError as e:
        raise MissionError(source, *first_error(Mission, e)) from None
    if isinstance(source, Path) or (isinstance(source, str) and source != "<mission>"):
        m._source = Path(source)
    # a vehicle file and its overrides are checked now, so that bad input fails early
    try:
        params = m.vehicle_params()
    except VehicleParamsError as e:
        field = "vehicle" if e.field == "vehicle" else f"vehicle.{e.field}"
        if m.vehicle.file is not None and not e.field.startswith("overrides"):
            field = "vehicle.file" if e.field == "vehicle" else f"vehicle.file ({e.field})"
        raise MissionError(source, field, e.message) from None
    n = len(params.thrust_limits_N)
    try:
        m.controller.weights.R_for(n)
    except ValueError as e:
        raise MissionError(source, "controller.weights.R", f"{e} ({params.name})") from None
    bad = m.world_problem()
    if bad is not None:
        raise MissionError(source, *bad)
    if m.simulation.actuators == "ardusub" and n != 8:
        raise MissionError(
            source,
            "simulation.actuators",
            f"ardusub: ArduSub's VECTORED_6DOF mixer drives 8 thrusters; {params.name} has {n} (use ideal)",
        )
    return m


def load_mission(path: str | Path) -> Mission:
    """Read and validate a mission file, or a shipped mission by name.

    Parameters
    ----------
    path : str or Path
        A mission file, or the name of a mission shipped with auvdock (``"gyre"``,
        ``"tank_0p6hz"``; ``auvdock missions`` lists them).  An existing file wins over a
        shipped name (:func:`auvdock.config.catalog.resolve`).

    Returns
    -------
    Mission
        The validated mission; its ``source`` is the file it was read from.

    Raises
    ------
    MissionError
        On a missing file, a YAML syntax error or any invalid field; ``str(err)`` is one
        line: ``<file>: <field.path>: <problem>``.  A bare name that is neither a file nor
        a shipped mission says so and lists the shipped ones.
    """
    from auvdock.config.catalog import resolve, shipped_missions

    p = resolve(path)
    if not p.exists() and p.parent == Path(".") and p.suffix != ".yaml":
        known = ", ".join(f.name for f in shipped_missions())
        raise MissionError(p, "", f"file not found, nor a shipped mission (shipped: {known})")
    data, _ = read_yaml_file(p)
    return parse_mission(data, p)


def read_yaml_file(path: Path, error: type[MissionError] = MissionError) -> tuple[Any, str]:
    """The parsed YAML content of a file and its text; ``error(path, "", problem)`` on a
    missing or unreadable file or a syntax error (the problem names the line and column)."""
    if not path.exists():
        raise error(path, "", "file not found")
    if not path.is_file():
        raise error(path, "", "not a file")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise error(path, "", f"cannot read: {e}") from None
    try:
        return load_yaml_strict(text), text
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise error(path, "", f"YAML syntax error: {where}{problem}") from None
