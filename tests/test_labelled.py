"""Labelled data: every kind of solution round-trips through netCDF as an xarray
Dataset, and a run's results reopen as one Dataset holding every point, method and
transient time."""
import json

import numpy as np
import pytest

xr = pytest.importorskip("xarray")
pytest.importorskip("h5netcdf")

from fpk_vibro import VibroImpactSystem, Wall, averaging, exact, fem, montecarlo  # noqa: E402
from fpk_vibro.app import cli  # noqa: E402
from fpk_vibro.labelled import moments_frame, run_dataset  # noqa: E402
from conftest import paper_tables

S = VibroImpactSystem.paper(r=0.92)
INIT = {"mean": (0.1, 0.3), "std": (0.1, 0.2)}
KINDS = {
    "averaging": lambda: averaging.stationary(S),
    "fem": lambda: fem.stationary(S, nx=24),
    "montecarlo": lambda: montecarlo.stationary(S, seed=1, n_paths=256, t_sample=40.0,
                                                progress=False),
    "exact": lambda: exact.gibbs(VibroImpactSystem(a=1, b=0.2, c=0.025, D1=0.01,
                                                   left=Wall(-0.4), right=Wall(0.8))),
    "averaging_transient": lambda: averaging.transient(S, initial=INIT, times=[1.0])[0],
    "fem_transient": lambda: fem.transient(S, initial=INIT, times=[1.0], nx=12)[0],
    "montecarlo_transient": lambda: montecarlo.transient(S, initial=INIT, times=[1.0],
                                                         n_paths=256, seed=1, progress=False)[0],
}


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_solution_round_trips_through_netcdf(kind, tmp_path):
    sol = KINDS[kind]()
    ds = sol.to_xarray()
    path = tmp_path / "s.nc"
    ds.to_netcdf(path, engine="h5netcdf")
    with xr.open_dataset(path, engine="h5netcdf") as back:
        xr.testing.assert_identical(ds, back.load())
    assert VibroImpactSystem.from_dict(json.loads(ds.attrs["system"])) == sol.system
    assert ds["E_H"].item() == sol.moments()["E_H"]
    x = ds["x"].values
    assert np.array_equal(ds["pdf_x"].values, sol.pdf_x(x))
    assert ds.attrs["fpk_vibro_version"]


SCENE = paper_tables() + """
[study]
methods = ["averaging", "montecarlo"]
quantities = ["energy", "x", "moments"]
{extra}
[montecarlo]
seed = 1
n_paths = 256
{mc}
[output]
formats = ["json", "npz", "nc"]
"""


def test_swept_run_is_one_dataset(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE.format(extra="[sweep]\nr = [0.9, 0.95, 1.0]", mc="t_sample = 40.0"))
    assert cli.main(["run", str(scene), "--out", str(tmp_path / "o"), "--quiet",
                     "--workers", "1"]) == 0
    with xr.open_dataset(tmp_path / "o" / "results.nc", engine="h5netcdf") as ds:
        ds.load()
    assert ds.sizes["point"] == 3 and list(ds["method"].values) == ["averaging", "montecarlo"]
    assert list(ds["param_r"].values) == [0.9, 0.95, 1.0]
    assert np.all(np.isfinite(ds["E_H"].values))
    assert np.isnan(ds["E_H_se"].sel({"method": "averaging"})).all()
    assert np.all(ds["E_H_se"].sel({"method": "montecarlo"}) > 0)
    assert ds["pdf_energy"].shape[:2] == (3, 2) and "energy_grid" in ds
    df = moments_frame(tmp_path / "o")
    assert len(df) == 6 and {"E_H", "E_H_se", "param_r", "method"} <= set(df.columns)


def test_transient_run_holds_every_time(tmp_path):
    scene = tmp_path / "t.toml"
    scene.write_text(SCENE.format(extra="times = [0.5, 1.0, 2.0]\n[initial]\nmean = [0.1, 0.3]\n"
                                        "std = [0.1, 0.2]", mc="")
                     .replace('formats = ["json", "npz", "nc"]', 'formats = ["json", "npz", "nc", "png"]'))
    assert cli.main(["run", str(scene), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    ds = run_dataset(tmp_path / "o")
    assert list(ds["time"].values) == [0.5, 1.0, 2.0]
    assert ds["E_H"].dims == ("point", "method", "time")
    assert np.all(np.isfinite(ds["E_H"].values))
    assert ds["pdf_energy"].dims == ("point", "method", "time", "energy_index")
    assert np.all(np.isfinite(ds["pdf_energy"].values))          # every time, both methods
    figs = list((tmp_path / "o").glob("p0_t*_energy.png"))
    assert len(figs) == 3


def test_nc_without_xarray_is_one_line(monkeypatch, tmp_path):
    import builtins
    real = builtins.__import__

    def no_xarray(name, *a, **k):
        if name in ("xarray", "h5netcdf"):
            raise ImportError(name)
        return real(name, *a, **k)
    monkeypatch.setattr(builtins, "__import__", no_xarray)
    from fpk_vibro.app.scenes import SceneError, parse_scene
    import tomllib
    with pytest.raises(SceneError, match="fpk_vibro\\[data\\]"):
        parse_scene(tomllib.loads(SCENE.format(extra="", mc="")))
