"""Scene runs: only what the scene asks is computed; results written atomically."""
import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from fpk_vibro.app.runner import run_scene
from fpk_vibro.app.scenes import load_scene
from conftest import paper_tables

AVG_ONLY = paper_tables(D2=0.0) + """
[study]
methods = ["averaging"]
quantities = ["energy"]
"""


def write(tmp_path, text, name="scene.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text))
    return p


def test_averaging_energy_scene_runs_no_fem_or_monte_carlo(tmp_path):
    """Timing-independent instrumentation: which modules the run imported."""
    scene = write(tmp_path, AVG_ONLY)
    code = textwrap.dedent(f"""
        import sys
        from fpk_vibro.app import cli
        assert cli.main(["run", {str(scene)!r}, "--out", {str(tmp_path / 'out')!r}, "--quiet"]) == 0
        print(sorted(m for m in sys.modules if m.startswith(("fpk_vibro.fem", "fpk_vibro.montecarlo",
                                                              "skfem", "numba", "pyamg"))))
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip() == "[]"
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    point = doc["points"][0]
    assert list(point["methods"]) == ["averaging"]
    assert "parametric_noise" not in point["effects"]
    assert {"impact_right", "impact_left"} <= set(point["effects"])
    assert (tmp_path / "out" / "p0_energy.png").exists()
    assert not (tmp_path / "out" / "p0_x.png").exists()     # not asked for
    assert not list((tmp_path / "out").glob("*joint*"))


def test_effects_without_barrier_and_with_parametric_noise(tmp_path):
    text = AVG_ONLY.replace("D2 = 0.0", "D2 = 0.01").replace("delta = 0.6\nr = 0.92", 'sides = "none"')
    doc = run_scene(load_scene(write(tmp_path, text)), out=tmp_path / "o", log=lambda s: None)
    eff = doc["points"][0]["effects"]
    assert "parametric_noise" in eff and not any(e.startswith("impact") for e in eff)


def test_moments_and_densities_saved(tmp_path):
    text = AVG_ONLY.replace('quantities = ["energy"]', 'quantities = ["energy", "x", "moments"]').replace(
        "r = 0.92", "r = 1.0").replace('methods = ["averaging"]', 'methods = ["averaging", "exact"]')
    doc = run_scene(load_scene(write(tmp_path, text)), out=tmp_path / "o", log=lambda s: None)
    m = doc["points"][0]["methods"]
    assert m["averaging"]["moments"]["E_H"] == pytest.approx(m["exact"]["moments"]["E_H"], rel=1e-10)
    with np.load(tmp_path / "o" / "densities.npz") as d:
        assert np.allclose(d["p0.averaging.x.pdf"], d["p0.exact.x.pdf"], rtol=1e-9)
        assert d["p0.averaging.energy.grid"].size == d["p0.averaging.energy.pdf"].size


def test_a_point_where_averaging_does_not_apply_is_refused_before_any_work(tmp_path):
    """Linear oscillator without barrier: D2 = 0.2 gives a power-law tail."""
    from fpk_vibro.app.scenes import SceneError
    text = AVG_ONLY.replace("b = 0.2", "b = 0.0").replace("delta = 0.6\nr = 0.92", 'sides = "none"')
    text += "\n[sweep]\nD2 = [0.0, 0.2]\n"
    with pytest.raises(SceneError, match=r"study.methods: averaging: .*does not converge.*D2 = 0.2"):
        run_scene(load_scene(write(tmp_path, text)), out=tmp_path / "o", workers=2,
                  log=lambda s: None)
    assert not (tmp_path / "o").exists()


def test_sweep_in_parallel_and_a_failed_point_is_reported(tmp_path, monkeypatch):
    """A point that fails during its run is reported; the others are kept."""
    from fpk_vibro.app import runner
    solve = runner._solve

    def failing(method, system, scene, progress=False):
        if system.r == 0.5:
            raise RuntimeError("the solver broke")
        return solve(method, system, scene, progress)

    monkeypatch.setattr(runner, "_solve", failing)
    text = AVG_ONLY + "\n[sweep]\nr = [0.92, 0.5]\n"
    doc = run_scene(load_scene(write(tmp_path, text)), out=tmp_path / "o", workers=1,
                    log=lambda s: None)
    ok, bad = doc["points"]
    assert "methods" in ok and "error" in bad and "the solver broke" in bad["error"]
    assert bad["parameters"] == {"r": 0.5}
    assert (tmp_path / "o" / "points" / "p0.json").exists()
    assert not list((tmp_path / "o").rglob("*.tmp"))


def test_sweep_in_worker_processes(tmp_path):
    text = AVG_ONLY + "\n[sweep]\nr = [0.92, 0.5]\n"
    doc = run_scene(load_scene(write(tmp_path, text)), out=tmp_path / "o", workers=2,
                    log=lambda s: None)
    E = [p["methods"]["averaging"]["moments"]["E_H"] for p in doc["points"]]
    assert [p["parameters"]["r"] for p in doc["points"]] == [0.92, 0.5] and E[1] < E[0]


def test_cli_check_and_show(tmp_path, capsys):
    from fpk_vibro.app import cli
    scene = write(tmp_path, AVG_ONLY)
    assert cli.main(["check", str(scene)]) == 0
    assert "valid" in capsys.readouterr().out
    assert cli.main(["run", str(scene), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    assert cli.main(["show", str(tmp_path / "o")]) == 0
    assert "averaging" in capsys.readouterr().out


def test_cli_bad_scene_is_one_line_without_traceback(tmp_path):
    scene = write(tmp_path, AVG_ONLY.replace("r = 0.92", "r = 2"))
    r = subprocess.run([sys.executable, "-m", "fpk_vibro", "run", str(scene)], capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "barriers.r" in r.stderr and "Traceback" not in r.stderr
    assert not (tmp_path / "results").exists()


def test_sweep_on_a_dask_cluster(tmp_path):
    distributed = pytest.importorskip("distributed")
    text = AVG_ONLY + "\n[sweep]\nr = [0.5, 0.92, 1.0]\n"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        doc = run_scene(load_scene(write(tmp_path, text)), out=tmp_path / "o",
                        scheduler=cluster.scheduler_address, log=lambda s: None)
    E = [p["methods"]["averaging"]["moments"] for p in doc["points"]]
    assert [p["parameters"]["r"] for p in doc["points"]] == [0.5, 0.92, 1.0]
    assert E[0]["E_H"] < E[1]["E_H"] < E[2]["E_H"]


def test_positive_fem_transient_scene(tmp_path):
    """fem.positivity reaches the FE transient (it used to be dropped there)."""
    from fpk_vibro.app.runner import _solve
    from fpk_vibro.app.scenes import parse_scene

    scene = parse_scene({
        "system": dict(a=1.0, b=0.2, c=0.025, D1=0.01, D2=0.01),
        "barriers": dict(delta=0.6, r=0.92),
        "study": dict(methods=["fem"], quantities=["moments"], times=[1.0, 2.0]),
        "initial": dict(mean=[0.0, 1.0], std=[0.0, 0.05]),
        "fem": dict(nx=16, positivity=True, dt=0.05)})
    sols = _solve("fem", scene.system, scene)
    assert [s.time for s in sols] == [1.0, 2.0]
    for s in sols:
        assert s.info["positivity"] is True and s.info["scheme"] == "theta"
        assert s.min_density >= -1e-14 * s.dofs.max() and abs(s.mass - 1) < 1e-12


def test_quiet_still_reports_a_failed_point(tmp_path, monkeypatch, capsys):
    from fpk_vibro.app import cli, runner
    solve = runner._solve

    def failing(method, system, scene, progress=False):
        if system.r == 0.5:
            raise RuntimeError("the solver broke")
        return solve(method, system, scene, progress)

    monkeypatch.setattr(runner, "_solve", failing)
    scene = write(tmp_path, AVG_ONLY + "\n[sweep]\nr = [0.92, 0.5]\n")
    assert cli.main(["run", str(scene), "--out", str(tmp_path / "o"), "--quiet",
                     "--workers", "1"]) == 1
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "r=0.5" in err and "the solver broke" in err


def test_scheduler_without_dask_is_one_line(tmp_path, monkeypatch, capsys):
    from fpk_vibro.app import cli
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    scene = write(tmp_path, AVG_ONLY)
    assert cli.main(["run", str(scene), "--out", str(tmp_path / "o"),
                     "--scheduler", "tcp://127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--scheduler" in err and "distributed" in err
    assert not (tmp_path / "o").exists()
