"""The trajectory file: self-describing NetCDF, written atomically."""

import numpy as np
import pytest
import xarray as xr

from postcapture.dynamics.simulate import simulate
from postcapture.core.errors import OutputPathError
from postcapture.io import write_atomic


@pytest.fixture(scope="module")
def short_run(envisat):
    return simulate(envisat, duration=1.0)


def test_netcdf_round_trip_with_units(short_run, tmp_path):
    path = short_run.to_netcdf(tmp_path / "run.nc")
    with xr.open_dataset(path) as ds:
        assert ds["q_BN"].attrs["units"] == "1"
        assert ds["accel_B"].attrs["units"] == "m/s^2"
        assert ds["time"].attrs["units"] == "s"
        assert list(ds["q_BN_component"].values) == ["w", "x", "y", "z"]
        np.testing.assert_array_equal(ds["q_BN"].values, short_run["q_BN"])
        assert ds.attrs["scenario"] == "envisat"
        assert ds["q_BN"].dims == ("q_BN_component", "time")  # time is the last axis


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
