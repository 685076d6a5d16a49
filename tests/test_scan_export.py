"""Scans under the schema's keys, their honest timings, D(f) plots and the exports to
xarray, netCDF and pandas (docs/schema.md)."""

import json
import sys
import time

import numpy as np
import pytest

from bbdyn.commands import cli
from bbdyn.scans.frequency import frequency_scan
from bbdyn.scans.runner import load_scan, run_scan

TINY = {"n": 4, "t": 1.0}
SLEEP_S = 0.4


def sleeper(value, seed_sequence):
    """A point that waits without working: wall time, almost no CPU time."""
    time.sleep(SLEEP_S)
    return {"x": value}


@pytest.fixture(scope="module")
def scan(tmp_path_factory):
    folder = tmp_path_factory.mktemp("scan") / "s"
    return frequency_scan([85.0, 85.2], out_dir=folder, seed=2, workers=1, progress=False,
                          model={"alpha": 0.7}, **TINY)  # fmt: skip


def test_scan_keys_are_the_schemas(scan):
    from bbdyn.schema import is_quantity

    assert {"D", "D_se", "E_se", "E_x_se", "collision_rate", "collision_rate_se"} <= set(
        scan.arrays
    )
    assert not [k for k in scan.arrays if k.endswith("_err")]
    assert all(is_quantity(k) for k in scan.arrays)


def test_a_point_reports_its_workers_cpu_time_not_its_wall_time(tmp_path):
    """A point that sleeps takes wall time but no CPU time: its ``cpu_s`` is the worker's
    process time (before, it was the wall time)."""
    res = run_scan([1.0, 2.0], sleeper, out_dir=tmp_path, seed=0, workers=1, progress=False)
    times = res.point_times()
    assert np.all(times["wall_s"] >= SLEEP_S)
    assert np.all(times["cpu_s"] < 0.25 * SLEEP_S)
    np.testing.assert_array_equal(res.point_cpu_s(), times["cpu_s"])


def test_scenes_count_the_points_cpu_time(scan):
    """S3-S5 state the scan's CPU time from the points' process time, not their wall time;
    a point that recorded no CPU time (an older scan) counts its wall time instead."""
    from bbdyn.params import Params
    from bbdyn.scenes.frequency_scene import FrequencyScanScene

    times = scan.point_times()
    scene = FrequencyScanScene.from_scan(scan, Params(f=85.0))
    assert scene.meta["scan_cpu_s"] == pytest.approx(times["cpu_s"].sum(), rel=1e-12)
    scan.meta["points"][0].pop("cpu_s")
    try:
        expected = times["wall_s"][0] + times["cpu_s"][1]
        assert scan.point_cpu_s().sum() == pytest.approx(expected, rel=1e-12)
    finally:
        scan.meta["points"][0]["cpu_s"] = times["cpu_s"][0]


def test_plot_draws_D_with_its_standard_errors(scan):
    ax = scan.plot()
    assert ax.get_ylabel() == "D (mm^2/s)" and ax.get_xlabel() == "f (Hz)"
    (bars,) = ax.containers
    np.testing.assert_array_equal(bars.lines[0].get_ydata(), scan["D"])
    segments = bars.lines[2][0].get_segments()
    half = np.array([(s[1][1] - s[0][1]) / 2 for s in segments])
    np.testing.assert_allclose(half, scan["D_se"], rtol=1e-12)


def test_netcdf_round_trip_gives_the_arrays(scan, tmp_path):
    xr = pytest.importorskip("xarray")
    path = scan.to_netcdf(tmp_path / "scan.nc")
    with xr.open_dataset(path) as ds:
        np.testing.assert_array_equal(ds["f"].values, scan.values)
        for key, values in scan.arrays.items():
            np.testing.assert_array_equal(ds[key].values, values, err_msg=key)
        times = scan.point_times()
        np.testing.assert_array_equal(ds["cpu_s"].values, times["cpu_s"])
        assert ds["D"].attrs["units"] == "mm^2/s" and ds["D_se"].attrs["units"] == "mm^2/s"
        assert ds["msd"].dims == ("f", "sample")
        assert json.loads(ds.attrs["params"])["alpha"] == 0.7
        assert json.loads(ds.attrs["compute"]) == scan.meta["compute"]
        assert ds.attrs["seed"] == 2 and ds.attrs["bbdyn_source"] == scan.meta["bbdyn_source"]


def test_dataframe_holds_the_scalars(scan):
    pytest.importorskip("pandas")
    frame = scan.to_dataframe()
    np.testing.assert_array_equal(frame.index.values, scan.values)
    np.testing.assert_array_equal(frame["D_se"].values, scan["D_se"])
    assert "msd" not in frame and frame.attrs["units"]["E"] == "kg mm^2/s^2"


@pytest.mark.parametrize("method, module", [("to_xarray", "xarray"), ("to_netcdf", "xarray"),
                                            ("to_dataframe", "pandas")])  # fmt: skip
def test_without_the_io_extra_the_error_names_it(scan, tmp_path, monkeypatch, method, module):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    args = (tmp_path / "x.nc",) if method == "to_netcdf" else ()
    with pytest.raises(ImportError, match=r"install the io extra: pip install 'bbdyn\[io\]'"):
        getattr(scan, method)(*args)
    assert not (tmp_path / "x.nc").exists()


def test_bbdyn_scan_writes_the_whole_scan_as_netcdf(tmp_path, capsys, monkeypatch):
    xr = pytest.importorskip("xarray")
    out = tmp_path / "s"
    argv = ["scan", "--f-start", "85", "--f-stop", "85.2", "--f-step", "0.2", "--n", "4",
            "--t", "1", "--workers", "1", "--out", str(out)]  # fmt: skip
    assert cli.main(argv) == 0
    assert f"netCDF: {out / 'scan.nc'}" in capsys.readouterr().out
    with xr.open_dataset(out / "scan.nc") as ds:
        xr.testing.assert_identical(ds.load(), load_scan(out).to_xarray())
    # without xarray the scan still finishes, with a note naming the extra
    monkeypatch.setitem(sys.modules, "xarray", None)
    (out / "scan.nc").unlink()
    assert cli.main([*argv, "--resume"]) == 0
    assert "pip install 'bbdyn[io]'" in capsys.readouterr().err
    assert not (out / "scan.nc").exists()
