"""Monte Carlo sweeps: one YAML file expands into many closed-loop runs on the campaign engine.

A *sweep file* names a base mission and what to vary around it::

    name: current_speed
    base: ../diagonal.yaml              # base mission: relative to the sweep file, or a shipped name
    controllers: [naive, kinematic, oracle, sequential, optimized]
    seeds: 1                            # seeds per point: mission.seed = base seed + i
    grid:                               # full factorial over dotted mission fields
      flow.speed_m_s: [0.0, 0.5, 1.0, 1.5, 2.0, 2.5]
      flow.direction_deg: [0, 45, 90, 135, 180, 225, 270, 315]
    random:                             # n draws (seeded by sweep_seed), crossed with the grid
      n: 0
      fields:
        dock.heave.amplitude_m: {uniform: [0.0, 0.5]}      # [low, high]
        sensors.accel_std_m_s2: {normal: [0.0045, 0.001]}  # [mean, std]
        controller.horizon_steps: {choice: [8, 10, 12]}
    model_error:                        # the truth model only: vehicle parameters x random factors
      n: 0                              # draws per point (0: none)
      scale: {added_mass: 0.1, mass_kg: 0.05}   # relative std, or {uniform: [low, high]}
    timeout_s: 75                       # docking timeout of every run (default: the mission's)
    sweep_seed: 0
    reference:                          # optional: success rates to set beside the sweep's
      - {label: "paper tank trials", docked: 8, runs: 11}

=============  ================================================================
module         job
=============  ================================================================
``schema``     the sweep file's schema and field-path checks
``load``       :func:`load_sweep`: read, validate and expand a sweep file
``expand``     points, derived and coupled fields, model-error draws -> the
               campaign plan (:func:`expand_sweep`, :func:`sweep_plan`)
``run``        :func:`run_sweep` on the campaign engine, :func:`read_sweep`
=============  ================================================================

The runs execute on the one campaign engine (:mod:`auvdock.campaign`): local worker
processes, or a Dask cluster with ``scheduler=``; the same results layout, resume, retry
and Ctrl-C handling as ``auvdock compare``.  Statistics and figures:
:mod:`auvdock.sweep.stats`.

Points and runs
---------------
The *points* are the grid's full factorial (in file order, the last field fastest), each
crossed with the ``random.n`` draws (draw 0..n-1; without a grid the draws alone; with
neither, the base mission alone).  Every point runs every controller with ``seeds``
seeds and, when ``model_error.n > 0``, ``model_error.n`` truth models.  A run is
(point, controller, seed, model-error draw) with the stable id ``p0003-oracle-s1-m0``
(point 3, seed 1, draw 0; ``m0`` is the nominal model when ``model_error.n`` is 0).

Draws are reproducible and independent of one another: each random field draws its ``n``
values from its own generator seeded by ``(sweep_seed, crc32(field))``, so adding a field
leaves the others' draws unchanged; model-error factors of draw m at point p come from
``(sweep_seed, crc32(parameter), p, m)``, the same for every controller and seed (common
random numbers: controllers are compared on the same truth vehicles).

Derived and coupled fields
--------------------------
* ``flow.speed_m_s`` and ``flow.direction_deg`` (the mission's FlowSpec has only the
  vector ``flow.velocity_ned_m_s``) set a constant current of that speed (m/s, >= 0)
  flowing TOWARDS that direction, degrees clockwise from north (0 north, 90 east):
  ``velocity_ned_m_s = [speed cos(dir), speed sin(dir)]``.  If only one is varied, the
  other comes from the base mission's constant current (paper case 2 is 0.71 m/s towards
  45 deg); a base without a current has no direction, so give both.
* Varying ``flow.velocity_ned_m_s`` (or the derived fields) makes the flow an explicit
  ``type: constant`` (the base's ``case`` is dropped); varying ``flow.amplitude_m_s``,
  ``flow.period_h`` or ``flow.epsilon`` turns a double-gyre case into the explicit
  ``type: double_gyre`` with the case's values; varying ``flow.case`` drops a ``type``.
* ``dock.heave.frequency_hz`` and ``dock.heave.angular_frequency_rad_s`` are two forms of
  one value: varying one clears the other (HeaveSpec accepts both only when they agree).
* ``seed`` and ``controller.type`` are set by ``seeds`` and ``controllers`` and cannot be
  varied; list values are varied whole (``dock.position_ned_m: [[2, 3, 5], [3, 3, 5]]``).
  Controller settings are checked per controller type (:func:`auvdock.schema.strict.field_at`).

Model error
-----------
With ``model_error.n > 0`` each run's TRUTH mission gets ``vehicle.overrides`` = nominal
value x factor for every parameter in ``scale`` (one factor per parameter: a vector such as
``added_mass`` is scaled as a whole), while the controller and its estimator are built
from the NOMINAL mission (:func:`auvdock.campaign.worker.execute_run`)::

    simulate(truth, autopilot=build_autopilot(nominal, nominal.build_vehicle(), nominal.build_dock(), c))

A number in ``scale`` is a relative standard deviation: factor ``1 + s z`` with z standard
normal truncated at +-3 (s < 1/3 keeps factors positive); ``{uniform: [low, high]}`` draws
the factor itself (0 < low <= high).

Results file ``<out>/sweep.h5``
-------------------------------
The campaign layout (:mod:`auvdock.campaign.store`) with ``kind = "sweep"``: the run table
``/campaign_table`` has ``run_id``, ``point``, ``model_error_draw``, one column per varied
field (named by its dotted path; float, int, bool or str -- lists as JSON text), one
``model_error.<parameter>`` factor column per scaled parameter, then the outcome columns
(:data:`auvdock.campaign.OUTCOME_COLUMNS`: controller, seed, status, error, docked, time to
dock, closest approach, flow RMSE, wall and set-up time, worker, ...).  Root attributes
add ``sweep_name``, ``sweep_file``, ``sweep_yaml``, ``base_mission_yaml``, ``controllers``,
``varied``, ``grid_fields`` and ``model_error_columns``.  With ``trajectories=True`` every
run is also kept as a run group ``/runs/<run id>`` (the layout of ``auvdock sim``).
"""

from __future__ import annotations

from auvdock.sweep.expand import expand_sweep, label_columns, sweep_plan
from auvdock.sweep.load import load_sweep
from auvdock.sweep.run import RESULTS_NAME, read_sweep, run_sweep
from auvdock.sweep.schema import DERIVED_FIELDS, Sweep, SweepError

__all__ = [
    "DERIVED_FIELDS",
    "RESULTS_NAME",
    "SweepError",
    "Sweep",
    "load_sweep",
    "expand_sweep",
    "label_columns",
    "sweep_plan",
    "run_sweep",
    "read_sweep",
]
