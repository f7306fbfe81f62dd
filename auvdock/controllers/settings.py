"""The controllers' settings: what every MPC shares (paper eq. 10; docs/parameter-sources.md
section 4) and each controller type's own.

Each controller type has its own settings class (a :class:`MPCSettings` with a literal
``type`` and its own fields, all in this module, which needs no CasADi: reading a mission loads
none); the mission's ``controller`` section is the discriminated union of them
(:func:`auvdock.controllers.registry.settings_union`), so a field of one controller type given to
another (``alpha`` to ``oracle``) is an error.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import Field, field_validator, model_validator

from auvdock.schema.strict import NonNegFloat, PosFloat, Strict, Vec3Pos, Vec6Pos, Vec12NonNeg

__all__ = [
    "WeightsSpec",
    "BoundsSpec",
    "SolverSpec",
    "EntrySpec",
    "MPCSettings",
    "DEFAULT_Q",
    "SOLVER_NAMES",
    "solver_names",
    "NaiveSettings",
    "KinematicSettings",
    "OracleSettings",
    "CertaintyEquivalentSettings",
    "SequentialSettings",
    "OptimizedSettings",
]

#: The NLP solvers registered in :mod:`auvdock.controllers.solvers` (``SOLVERS``, which checks
#: that it registers these), named here so that reading a mission needs no CasADi.
SOLVER_NAMES = ("ipopt", "sqp", "rti")


def solver_names() -> tuple[str, ...]:
    """``auto`` and every registered solver."""
    return ("auto", *SOLVER_NAMES)


#: Diagonal stage and terminal weights of the 12-state error (paper; docs/parameter-sources.md section 4).
DEFAULT_Q = [1.0, 1.0, 1.0, 100.0, 100.0, 100.0, 1.0, 1.0, 1.0, 100.0, 100.0, 100.0]


class WeightsSpec(Strict):
    """MPC weights of cost (10): stage Q and terminal P on the 12-state error, R on input rate.

    ``R`` is on normalised thrust ``u_i / u_max,i`` (dimensionless); one number applies to
    every thruster, a list gives one per thruster (its length must be the vehicle's number
    of thrusters, checked when the mission is read).
    """

    Q: Vec12NonNeg = Field(default=list(DEFAULT_Q), description="12 diagonal stage weights")
    R: list[NonNegFloat] = Field(
        default=[10.0],
        description="input-rate weight per thruster on normalised thrust (one value: every thruster)",
    )
    P: Vec12NonNeg = Field(default=list(DEFAULT_Q), description="12 diagonal terminal weights")

    @field_validator("R", mode="before")
    @classmethod
    def _r(cls, v: Any) -> Any:
        if isinstance(v, int | float) and not isinstance(v, bool):
            return [v]
        return v

    def R_for(self, n_thrusters: int) -> list[float]:
        """R as ``n_thrusters`` values (ValueError if a list of another length was given)."""
        if len(self.R) == 1:
            return self.R * n_thrusters
        if len(self.R) != n_thrusters:
            raise ValueError(f"must have {n_thrusters} values (one per thruster) or one, got {len(self.R)}")
        return list(self.R)


class BoundsSpec(Strict):
    """State bounds of the MPC (docs/parameter-sources.md section 4)."""

    relative_velocity_max_m_s: Vec3Pos = Field(
        default=[2.5, 2.5, 2.5], description="|u_r|, |v_r|, |w_r|, m/s"
    )
    angular_rate_max_rad_s: Vec3Pos = Field(default=[0.25, 0.25, 0.25], description="|p|, |q|, |r|, rad/s")


class SolverSpec(Strict):
    """Numerical solver of the MPC problem (:mod:`auvdock.controllers.solvers`)."""

    name: str = Field(
        default="auto",
        description=(
            "sqp (sqpmethod + qrqp, iterated to convergence), rti (real-time iteration: one "
            "Gauss-Newton QP step per control step), ipopt (interior point) or auto (the "
            "controller's own choice; auvdock.controllers.solvers)"
        ),
    )
    qp: Literal["hpipm", "hpipm_casadi", "qrqp"] = Field(
        default="hpipm",
        description=(
            "QP solver of sqp and rti: hpipm (interior point by Riccati recursion on the stage-wise "
            "problem; rti's step compiled whole, QP data and HPIPM in one call), hpipm_casadi (HPIPM "
            "through CasADi's plugin: the reference, the same bits) or qrqp (CasADi's active-set method "
            "on the sparse QP)"
        ),
    )
    max_iter: Annotated[int, Field(ge=1, le=10_000)] = Field(
        default=100, description="iteration limit per solve"
    )
    tol: PosFloat = Field(default=1e-6, description="convergence tolerance")
    fallback_steps: Annotated[int, Field(ge=0, le=20)] = Field(
        default=2,
        description="after failed solves: the last good plan's input for that instant for at most this "
        "many steps in a row, then zero thrust (neutral) until a solve succeeds",
    )

    @field_validator("name")
    @classmethod
    def _known(cls, v: str) -> str:
        if v not in solver_names():
            raise ValueError(f"unknown solver {v!r} (known: {', '.join(solver_names())})")
        return v


class EntrySpec(Strict):
    """A controller's ``entry`` section: the dock's entry corridor in the MPC's cost."""

    enabled: bool | None = Field(
        default=None,
        description="hold the plan in the dock's entry corridor (soft constraints); default: on for the "
        "robust variant in a mission that docks on contact (docking.criterion: capture), off for the paper's",
    )
    contact_speed_m_s: PosFloat = Field(
        default=0.10, description="closing speed allowed when the nose reaches the cradle's entrance, m/s"
    )
    deceleration_1_s: PosFloat = Field(
        default=0.5, description="closing speed allowed per metre ahead of the cradle's entrance, (m/s)/m"
    )
    heading_margin_deg: PosFloat = Field(
        default=5.0, description="heading error allowed at the cradle's entrance, deg"
    )
    heading_slope_deg_m: NonNegFloat = Field(
        default=60.0, description="heading error allowed per metre ahead of the cradle's entrance, deg/m"
    )
    lateral_weight: NonNegFloat = Field(
        default=500.0, description="penalty on leaving the cone, per m^2 (the position weight Q is 1 per m^2)"
    )
    speed_weight: NonNegFloat = Field(default=200.0, description="penalty on closing too fast, per (m/s)^2")
    heading_weight: NonNegFloat = Field(default=200.0, description="penalty on the heading bound, per rad^2")


class CoarseSpec(Strict):
    """A controller's ``coarse`` section: the horizon's coarse tail, a non-uniform time grid (fine steps
    first, coarse later) that sees seconds ahead in few stages (the QP's cost follows the stages, the
    prediction's the time spanned: docs/controllers.md, "A horizon of seconds")."""

    steps: Annotated[int, Field(ge=0, le=200)] = Field(
        default=0,
        description="steps of dt_s each after the horizon's horizon_steps steps of the control period "
        "(0: a uniform grid, the paper's)",
    )
    dt_s: PosFloat = Field(
        default=0.25,
        description="each coarse step, s: a whole multiple of the control period (integrated in steps "
        "of it, so that the prediction is as accurate as the fine part's)",
    )


class MPCSettings(Strict):
    """What every docking MPC has: horizon, period, weights, bounds and solver."""

    type: str = Field(description="controller type (auvdock.controllers.registry)")
    variant: Literal["robust", "paper"] = Field(
        default="robust",
        description="robust: offset-free tracking (a lumped disturbance and a velocity offset "
        "estimated from the prediction error and predicted over the horizon) and, for Sequential "
        "FSE-MPC, an MPC that knows the perception input; paper: the paper's formulation exactly",
    )
    disturbance_time_constant_s: PosFloat = Field(
        default=1.0, description="robust: time constant of the lumped-disturbance estimate, s"
    )
    horizon_steps: Annotated[int, Field(ge=1, le=200)] = Field(
        default=10, description="N, steps of dt_s (then coarse.steps more of coarse.dt_s)"
    )
    dt_s: PosFloat = Field(default=0.05, description="control period and MPC step, s")
    coarse: CoarseSpec = Field(default_factory=CoarseSpec)
    weights: WeightsSpec = Field(default_factory=WeightsSpec)
    bounds: BoundsSpec = Field(default_factory=BoundsSpec)
    solver: SolverSpec = Field(default_factory=SolverSpec)
    entry: EntrySpec = Field(default_factory=EntrySpec)

    @model_validator(mode="after")
    def _coarse_multiple(self) -> MPCSettings:
        if self.coarse.steps > 0:
            ratio = self.coarse.dt_s / self.dt_s
            if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
                raise ValueError(
                    f"coarse.dt_s: {self.coarse.dt_s:g} s is not a whole multiple of dt_s ({self.dt_s:g} s)"
                )
        return self

    def horizon_text(self) -> str:
        """The horizon in words: ``N = 10, dt = 0.05 s`` or, with a coarse tail,
        ``N = 10 x 0.05 s + 12 x 0.25 s (3.5 s)``."""
        if self.coarse.steps == 0:
            return f"N = {self.horizon_steps}, dt = {self.dt_s:g} s"
        total = sum(self.stage_lengths_s())
        return (
            f"N = {self.horizon_steps} x {self.dt_s:g} s + {self.coarse.steps} x {self.coarse.dt_s:g} s "
            f"({total:.3g} s)"
        )

    def stage_lengths_s(self) -> list[float]:
        """Each step of the prediction's time grid, s: ``horizon_steps`` of ``dt_s``, then ``coarse.steps``
        of ``coarse.dt_s``."""
        return [self.dt_s] * self.horizon_steps + [self.coarse.dt_s] * self.coarse.steps

    def entry_enabled(self, docks_on_contact: bool) -> bool:
        """Whether the MPC's cost holds the dock's entry corridor (``entry.enabled``; by default the
        robust variant's in a mission that docks on contact, never the paper's formulation)."""
        if self.entry.enabled is not None:
            return bool(self.entry.enabled)
        return docks_on_contact and self.variant == "robust"


# --- each controller type's settings (registered in auvdock.controllers.registry) ---


class NaiveSettings(MPCSettings):
    """Naive MPC: predicts with eqs. (1)-(2) and no current."""

    type: Literal["naive"] = "naive"


class KinematicSettings(MPCSettings):
    """Kinematic MPC: the true current in the kinematics only (eq. 6); reads the true flow."""

    type: Literal["kinematic"] = "kinematic"


class OracleSettings(MPCSettings):
    """Oracle MPC: the full model with the true current (Assumption 3); reads the true flow."""

    type: Literal["oracle"] = "oracle"


class CertaintyEquivalentSettings(MPCSettings):
    """Certainty-equivalent MPC: the FSE controllers' flow filter and MPC, no exploration."""

    type: Literal["ce"] = "ce"


class SequentialSettings(MPCSettings):
    """Sequential FSE-MPC: the perception law (9), then the MPC with the estimated flow."""

    type: Literal["sequential"] = "sequential"
    perception_wrench_max: Vec6Pos = Field(
        default=[0.1, 0.1, 0.1, 0.1, 0.1, 0.1],
        description="bound of the active-perception wrench (N, N m), 6 values",
    )
    perception_solver: Literal["corners", "sqp", "ipopt"] = Field(
        default="corners",
        description=(
            "how law (9) is solved: corners (best of the 64 corners of the wrench box, one "
            "compiled call), sqp or ipopt (local optimum from a fixed start)"
        ),
    )


class OptimizedSettings(MPCSettings):
    """Optimized FSE-MPC: cost (10) minus alpha times the information metric F."""

    type: Literal["optimized"] = "optimized"
    alpha: Annotated[float, Field(ge=0)] = Field(
        default=1e-3, description="weight on the information metric F (see auvdock.controllers.fse)"
    )
