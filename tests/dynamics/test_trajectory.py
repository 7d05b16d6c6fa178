"""The trajectory file: self-describing NetCDF, written atomically."""

import cf_units
import numpy as np
import pytest
import xarray as xr

from postcapture.dynamics.simulate import simulate
from postcapture.core.errors import OutputPathError
from postcapture.io import write_atomic
from postcapture.io.netcdf import labelled


@pytest.fixture(scope="module")
def short_run(envisat):
    return simulate(envisat, duration=1.0)


def test_netcdf_round_trip_with_units(short_run, tmp_path):
    path = short_run.to_netcdf(tmp_path / "run.nc")
    with xr.open_dataset(path) as raw:
        ds = labelled(raw)  # the file's labels are character coordinates (CF): back on their dimensions
        assert ds["q_BN"].attrs["units"] == "1"
        assert ds["accel_B"].attrs["units"] == "m/s^2"
        assert ds["time"].attrs["units"] == "s"
        assert list(ds["quaternion"].values) == ["w", "x", "y", "z"]
        np.testing.assert_array_equal(ds["q_BN"].values, short_run["q_BN"])
        assert ds.attrs["scenario"] == "envisat"
        assert ds["q_BN"].dims == ("quaternion", "time")  # time is the last axis


def test_failed_write_leaves_the_old_file_intact(tmp_path):
    target = tmp_path / "keep.nc"
    target.write_text("previous results")

    def broken_writer(tmp):
        with open(tmp, "w") as fh:
            fh.write("half")
        raise RuntimeError("disk full")

    with pytest.raises(OutputPathError, match="keep.nc: write failed: disk full"):  # a library's failure
        write_atomic(target, broken_writer)
    assert target.read_text() == "previous results"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.nc"]


def test_quaternion_unit_and_positive_scalar(short_run):
    q = short_run["q_BN"]
    np.testing.assert_allclose(np.linalg.norm(q, axis=0), 1.0, atol=1e-14)
    assert np.all(q[0] >= 0)


@pytest.fixture(scope="module")
def forced_file(envisat, tmp_path_factory):
    """50 s of the embedded manoeuvre: the thrust (from 40 s) and the torques (from 20 s) are on."""
    traj = simulate(envisat, duration=50.0)
    return traj, traj.to_netcdf(tmp_path_factory.mktemp("nc") / "forced.nc")


def test_every_unit_is_cf_valid(forced_file):
    _, path = forced_file
    with xr.open_dataset(path) as ds:
        units = {name: var.attrs["units"] for name, var in ds.variables.items() if "units" in var.attrs}
        assert len(units) > 30
        for name, unit in units.items():
            cf_units.Unit(unit)  # raises ValueError on anything UDUNITS cannot parse
        assert cf_units.Unit(ds["state_joint_rate"].attrs["units"]).convert(1.0, "degree/s") == pytest.approx(
            180 / np.pi)
        assert not any(name.startswith("u") and name[1:].isdigit() for name in ds.variables)


def test_inputs_are_named_channels_with_the_scenario_values(forced_file):
    """The scenario file puts 100 N on force_x from 40 s, -40 N m on torque_z and -8 N m on torque_y from 20 s,
    sines and a chirp on arm joints 2, 4, 6 from 10 s, and nothing elsewhere (rise time 0.2 s)."""
    _, path = forced_file
    with xr.open_dataset(path) as ds:
        t = ds["time"].values
        names = ["force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z"] + [
            f"joint_{k}_torque" for k in range(1, 8)]
        for name in names:
            assert ds[name].dims == ("time",)
            assert ds[name].attrs["units"] == ("N" if name.startswith("force") else "N m")
        thrust = t >= 40.5
        np.testing.assert_allclose(ds["force_x"].values[thrust], 100.0)
        np.testing.assert_allclose(ds["force_x"].values[t < 40.0], 0.0)
        np.testing.assert_allclose(ds["torque_z"].values[t >= 20.5], -40.0)
        np.testing.assert_allclose(ds["torque_y"].values[t >= 20.5], -8.0)
        for quiet in ("force_y", "force_z", "torque_x", "joint_1_torque", "joint_3_torque", "joint_5_torque",
                      "joint_7_torque"):
            np.testing.assert_array_equal(ds[quiet].values, 0.0)
        for driven in ("joint_2_torque", "joint_4_torque", "joint_6_torque"):
            assert np.abs(ds[driven].values[t > 11.0]).max() > 1.0
            np.testing.assert_array_equal(ds[driven].values[t < 10.0], 0.0)


def test_state_vector_is_split_into_named_variables(forced_file):
    """The named state variables agree with the outputs computed from it (attitude, rate, arm angles)."""
    traj, path = forced_file
    with xr.open_dataset(path) as raw:
        ds = labelled(raw)
        xyzw = ds["state_chaser_quaternion"].values
        q_wxyz = np.vstack([xyzw[3], xyzw[:3]])
        q_wxyz *= np.where(q_wxyz[0] < 0, -1.0, 1.0)
        np.testing.assert_allclose(q_wxyz, ds["q_BN"].values, atol=1e-15)
        np.testing.assert_allclose(ds["state_chaser_position"].values, ds["r_BN_N"].values, atol=1e-15)
        np.testing.assert_allclose(ds["state_chaser_angular_velocity"].values, ds["omega_BN_B"].values, atol=1e-15)
        joints = list(ds["joint"].values)
        arm = [joints.index(f"arm_{k}") for k in range(1, 8)]
        np.testing.assert_allclose(ds["state_joint_angle"].values[arm], ds["arm_q"].values, atol=1e-15)
        np.testing.assert_allclose(ds["state_joint_acceleration"].values[arm], ds["arm_ddq"].values, atol=1e-15)
        assert len(joints) == traj.v.shape[0] - 6
        assert "q" not in ds and "v" not in ds


def test_short_repr(short_run):
    text = repr(short_run)
    assert text.startswith("Trajectory(scenario 'envisat', flexible model, 11 samples over 1 s, 25 DoF")
    assert len(text) < 200
