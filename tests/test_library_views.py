"""The notebook view of a run (issue 37 item 9): Run.to_xarray / to_dataframe with one unit per
variable and every name described, netCDF files, and auvdock.load_run."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import matplotlib
import numpy as np
import pytest
import xarray as xr

import auvdock
from auvdock.results import run as run_module
from auvdock.results.run import INNOVATION_COMPONENTS, Run, series_info

matplotlib.use("Agg")

#: Every variable of the xarray view of an FSE run (default estimation) and its units (None: none).
FSE_UNITS = {
    "position": "m",
    "attitude": "rad",
    "velocity": "m/s",
    "angular_rate": "rad/s",
    "thrust_N": "N",
    "force": "N",
    "moment": "N m",
    "flow_ned_m_s": "m/s",
    "dock_position_m": "m",
    "dock_velocity_m_s": "m/s",
    "distance_m": "m",
    "solve_time_s": "s",
    "solver_status": None,
    "flow_estimate_m_s": "m/s",
    "flow_covariance": "m^2/s^2",
    "flow_body_true_m_s": "m/s",
    "flow_estimate_ned_m_s": "m/s",
    "information": "s^2/m^2",
    "perception_force": "N",
    "perception_moment": "N m",
    "innovation_accel": "m/s^2",
    "innovation_depth_rate": "m/s",
}


@pytest.fixture(scope="module")
def fse_run() -> Run:
    """A short run of the Sequential FSE-MPC (0.5 s: 10 control steps and the final row)."""
    return auvdock.simulate("gyre", "sequential", docking__timeout_s=0.5)


def test_every_variable_has_one_unit(fse_run: Run) -> None:
    ds = fse_run.to_xarray()
    assert {name: ds[name].attrs.get("units") for name in ds.data_vars} == FSE_UNITS
    assert "state" not in ds and "wrench" not in ds and "innovation" not in ds  # no stacked mixed units
    # the split variables hold the stored components, in order
    r = fse_run
    np.testing.assert_array_equal(ds["position"].values, r.state[:, 0:3])
    np.testing.assert_array_equal(ds["attitude"].sel(euler="yaw").values, r.state[:, 5])
    np.testing.assert_array_equal(ds["velocity"].values, r.state[:, 6:9])
    np.testing.assert_array_equal(ds["angular_rate"].sel(body_rate="r").values, r.state[:, 11])
    np.testing.assert_array_equal(ds["force"].values, r.wrench[:, 0:3])
    np.testing.assert_array_equal(ds["moment"].sel(moment_component="N").values, r.wrench[:, 5])
    np.testing.assert_array_equal(ds["perception_moment"].values, r.extras["perception_wrench"][:, 3:6])
    assert ds["position"].dims == ("time_s", "ned") and list(ds["ned"].values) == ["north", "east", "down"]
    assert ds["attitude"].dims == ("time_s", "euler") and list(ds["euler"].values) == ["roll", "pitch", "yaw"]
    assert ds["velocity"].dims == ("time_s", "body") and list(ds["body"].values) == ["u", "v", "w"]
    assert list(ds["body_rate"].values) == ["p", "q", "r"]
    assert list(ds["force_component"].values) == ["X", "Y", "Z"]
    assert list(ds["moment_component"].values) == ["K", "M", "N"]
    # the frames, in the descriptions
    assert "North-East-Down frame {n}" in ds["position"].attrs["description"]
    assert "over ground" in ds["velocity"].attrs["description"]
    assert "body frame {b}" in ds["velocity"].attrs["description"]
    assert ds["velocity"].attrs["frame"] == "body {b}" and ds["position"].attrs["frame"] == "NED {n}"
    assert ds["force"].attrs["frame"] == "body {b}" and "body axes" in ds["moment"].attrs["description"]


def test_plot_labels_show_the_unit(fse_run: Run) -> None:
    import matplotlib.pyplot as plt

    ds = fse_run.to_xarray()
    labels = {}
    for name, sel in [
        ("position", {"ned": "down"}),
        ("moment", {"moment_component": "N"}),
        ("information", {}),
    ]:
        fig = plt.figure()
        ds[name].sel(**sel).plot()
        labels[name] = fig.axes[0].get_ylabel()
        plt.close(fig)
    assert labels == {
        "position": "position [m]",
        "moment": "moment [N m]",
        "information": "flow information F [s^2/m^2]",
    }


def test_innovation_is_named_and_described(fse_run: Run) -> None:
    ds = fse_run.to_xarray()
    accel, depth = ds["innovation_accel"], ds["innovation_depth_rate"]
    assert accel.dims == ("time_s", "body") and list(accel["body"].values) == ["u", "v", "w"]
    assert depth.dims == ("time_s",)
    assert accel.attrs["units"] == "m/s^2" and depth.attrs["units"] == "m/s"
    assert "accelerometer" in accel.attrs["description"] and "depth-rate" in depth.attrs["description"]
    np.testing.assert_array_equal(accel.values, fse_run.extras["innovation"][:, 0:3])
    np.testing.assert_array_equal(depth.values, fse_run.extras["innovation"][:, 3])
    # the stored series (and the DataFrame's columns) name the same rows
    info = series_info("innovation", (4,))
    assert info["axes"] == [("innovation_row", INNOVATION_COMPONENTS)]
    assert INNOVATION_COMPONENTS == ("accel_u", "accel_v", "accel_w", "depth_rate")
    assert info["units"] == ("m/s^2", "m/s^2", "m/s^2", "m/s")
    df = fse_run.to_dataframe()
    assert (
        df.attrs["units"]["innovation.accel_v"] == "m/s^2"
        and df.attrs["units"]["innovation.depth_rate"] == "m/s"
    )


def test_recorded_innovation_is_the_accelerometer_and_depth_rate_one(fse_run: Run) -> None:
    # the default (robust) filter also reads the pose's motion after them; its 3-row innovation (NED,
    # with a 0 in the depth-rate row) used to overwrite the recorded one
    depth_rate = fse_run.extras["innovation"][1:-1, 3]
    assert np.all(np.isfinite(depth_rate)) and np.count_nonzero(depth_rate) == depth_rate.size


def test_information_unit_and_description(fse_run: Run) -> None:
    a = fse_run.to_xarray()["information"]
    assert a.attrs["units"] == "s^2/m^2" == run_module.INFORMATION_UNITS
    assert a.attrs["long_name"] == "flow information F"
    text = a.attrs["description"]
    assert text.startswith("F = lambda_min(G)") and "gramian" in text and "1/sqrt(F)" in text
    assert a.values[0] == 1.0  # G_0 = I


def test_every_variable_and_coordinate_is_described(fse_run: Run) -> None:
    ds = fse_run.to_xarray()
    for name in [*ds.data_vars, *ds.coords]:
        attrs = ds[name].attrs
        assert attrs.get("long_name") and attrs.get("description"), name
        assert "," not in attrs.get("units", ""), name  # one unit, never a list
    assert ds["time_s"].attrs["units"] == "s"
    assert ds["solver_status"].attrs["flag_meanings"].split()[:2] == ["ok", "not_converged"]
    assert "units" not in ds["solver_status"].attrs  # a code, no unit


def _catalogued_run(base: Run) -> Run:
    """``base`` with every catalogued extra series (zeros) of its catalogued shape."""
    n = base.n_steps
    extras = {}
    for name, known in run_module._KNOWN.items():
        if name in Run.__dataclass_fields__ or name in base.extras:
            continue
        extras[name] = np.zeros((n, *(len(labels) for _, labels in known.axes)))
    return dataclasses.replace(base, extras={**base.extras, **extras})


def test_every_catalogued_series_has_one_unit_and_a_description(fse_run: Run, tmp_path: Path) -> None:
    ds = _catalogued_run(fse_run).to_xarray()
    for name in [*ds.data_vars, *ds.coords]:
        attrs = ds[name].attrs
        assert attrs.get("long_name") and attrs.get("description"), name
        assert "," not in attrs.get("units", "") and "_dim" not in name, name
    units = {name: ds[name].attrs.get("units") for name in ds.data_vars}
    assert units["dock_pose_position"] == "m" and units["dock_pose_attitude"] == "rad"
    assert units["dock_twist_velocity"] == "m/s" and units["dock_twist_angular_rate"] == "rad/s"
    assert units["estimated_position_std"] == "m" and units["estimated_angular_rate"] == "rad/s"
    assert units["channels_us"] == "us" and units["water_acceleration_ned_m_s2"] == "m/s^2"
    assert ds["dock_forecast_m"].dims == ("time_s", "forecast_horizon_s", "ned")
    assert list(ds["forecast_horizon_s"].values) == [0.5, 1.0, 2.0, 3.0]
    assert ds["forecast_horizon_s"].attrs["units"] == "s"
    assert ds["guidance_phase"].attrs["flag_meanings"].split()[0] == "approach"
    assert ds["camera_state"].attrs["flag_meanings"] == "searching tracking holding lost"
    path = tmp_path / "all.nc"
    ds.to_netcdf(path, engine="h5netcdf")
    with xr.open_dataset(path, engine="h5netcdf") as back:
        xr.testing.assert_identical(back.load(), ds)


def test_catalogue_agrees_with_the_recording_code() -> None:
    from auvdock.config.guidance import GUIDANCE_PHASES
    from auvdock.controllers.fse import FSEMPC
    from auvdock.estimation.stage import ESTIMATION_SERIES, FORECAST_HORIZONS_S, FORECAST_SERIES, WAVE_SERIES
    from auvdock.fly.camera import CAMERA_SERIES, CAMERA_STATES
    from auvdock.fly.camera_sensor import CAMERA_SENSOR_SERIES
    from auvdock.fly.dock_telemetry import DOCK_TELEMETRY_SERIES
    from auvdock.fly.plant import TELEMETRY_COLUMNS
    from auvdock.loop.guidance import GUIDANCE_SERIES
    from auvdock.loop.simulated_plant import SEA_COLUMNS
    from auvdock.standins.truth_record import CONTACT_STATUSES
    from auvdock.vehicle.ardusub import CHANNELS

    assert run_module.FORECAST_HORIZONS_S is FORECAST_HORIZONS_S  # one definition, imported
    assert run_module.GUIDANCE_PHASES is GUIDANCE_PHASES and run_module._CAMERA_STATES == CAMERA_STATES
    assert run_module._CONTACT_STATUSES == CONTACT_STATUSES
    assert run_module._KNOWN["channels_us"].axes[0][1] == CHANNELS
    for table in (FSEMPC.extra_series, ESTIMATION_SERIES, FORECAST_SERIES, WAVE_SERIES, GUIDANCE_SERIES):
        for name, shape in table.items():
            assert run_module._is_known(name, shape), name
    for table in (CAMERA_SERIES, CAMERA_SENSOR_SERIES, DOCK_TELEMETRY_SERIES, TELEMETRY_COLUMNS, SEA_COLUMNS):
        for name, shape in table.items():
            assert run_module._is_known(name, shape), name
    # a series with components of several units is split into variables that cover its rows once
    for name, known in run_module._KNOWN.items():
        if isinstance(known.units, tuple) and len(set(known.units)) > 1:
            parts = run_module._SPLIT[name]
            rows = [i for p in parts for i in range(*p.rows.indices(len(known.units)))]
            assert rows == list(range(len(known.units))), name
            assert [p.units for p in parts for _ in range(p.rows.stop - p.rows.start)] == list(known.units), (
                name
            )


def test_netcdf_round_trip(fse_run: Run, tmp_path: Path) -> None:
    odd = dataclasses.replace(
        fse_run,
        attrs={
            **fse_run.attrs,
            "flag": True,
            "numpy_flag": np.bool_(False),
            "note": None,
            "names": ["a", "b"],
            "gains": [1.0, 2.5],
            "mapping": {"k": 1},
            "count": np.int64(3),
        },
    )
    ds = odd.to_xarray()
    assert ds.attrs["flag"] == 1 and ds.attrs["numpy_flag"] == 0 and ds.attrs["note"] == ""
    assert json.loads(ds.attrs["names"]) == ["a", "b"] and json.loads(ds.attrs["mapping"]) == {"k": 1}
    assert ds.attrs["docked"] == 0 and ds.attrs["complete"] == 1 and type(ds.attrs["count"]) is int
    path = tmp_path / "run.nc"
    ds.to_netcdf(path, engine="h5netcdf")
    with xr.open_dataset(path, engine="h5netcdf") as back:
        back = back.load()
    xr.testing.assert_identical(back, ds)
    np.testing.assert_array_equal(back["position"].sel(ned="down").values, fse_run.state[:, 2])
    assert back["moment"].attrs["units"] == "N m" and back.attrs["mission_name"] == "gyre"
    assert list(back.attrs["gains"]) == [1.0, 2.5] and math.isnan(back.attrs["time_to_dock_s"])


def test_dataframe_units(fse_run: Run, tmp_path: Path) -> None:
    df = fse_run.to_dataframe()
    assert df.attrs["units"]["state.z"] == "m" and df.attrs["units"]["information"] == "s^2/m^2"
    assert df.attrs["units"]["status"] == "" and "gramian" in df.attrs["descriptions"]["information"]
    named = fse_run.to_dataframe(units_in_names=True)
    cols = list(named.columns)
    assert cols[:4] == ["state.x [m]", "state.y [m]", "state.z [m]", "state.phi [rad]"]
    assert "wrench.K [N m]" in cols and "information [s^2/m^2]" in cols and "solver_status" in cols
    assert cols[-1] == "status" and named.attrs["units"]["wrench.K [N m]"] == "N m"
    np.testing.assert_array_equal(named["state.z [m]"].to_numpy(), df["state.z"].to_numpy())
    path = tmp_path / "run.csv"
    named.to_csv(path)
    assert path.read_text().splitlines()[0].startswith("time_s,state.x [m],state.y [m],")


def test_load_run_reads_a_saved_run(fse_run: Run, tmp_path: Path) -> None:
    assert "load_run" in auvdock.__all__ and "RunFileError" in auvdock.__all__
    path = fse_run.save(tmp_path / "gyre.h5")
    back = auvdock.load_run(path)
    assert isinstance(back, Run) and back.equals(fse_run)
    assert back.outcome.keys() == fse_run.outcome.keys()
    assert all(run_module._same(back.outcome[k], fse_run.outcome[k]) for k in fse_run.outcome)
    assert back.source == f"{path}:/"
    fse_run.save(tmp_path / "many.h5", "/runs/gyre/sequential")
    assert auvdock.load_run(str(tmp_path / "many.h5"), group="/runs/gyre/sequential").equals(fse_run)


def test_load_run_errors(tmp_path: Path) -> None:
    missing = tmp_path / "nope.h5"
    with pytest.raises(auvdock.RunFileError) as ei:
        auvdock.load_run(missing)
    assert str(ei.value) == f"{missing}: no such results file"
    assert ei.value.path == str(missing)
    text = tmp_path / "notes.txt"
    text.write_text("not a run\n")
    with pytest.raises(auvdock.RunFileError) as ei:
        auvdock.load_run(text)
    assert str(ei.value) == f"{text}: not an auvdock results file (not an HDF5 file)"
