"""Solution files against what a file may meet (issue 30): an error estimate, once made,
is part of the answer and survives a save and a load in a fresh interpreter (FE
stationary and transient, Monte Carlo stationary and transient: every key, floats
equal, since they are stored); a file whose wall no longer matches its mesh, a save onto
a directory and a missing pandas each end in one line naming what is wrong."""
import json
import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from fpk_vibro import Solution, VibroImpactSystem, fem, montecarlo

PAPER = VibroImpactSystem.paper(r=0.7)
PACKET = {"mean": (0.0, 0.5), "std": (0.15, 0.15)}

#: Loads each file in a fresh interpreter (only ``fpk_vibro.Solution`` imported) and
#: prints its ``error_estimate()`` as JSON (NaN and Infinity kept), or the one-line
#: error it raises.
FRESH = textwrap.dedent("""
    import json, sys
    from fpk_vibro import Solution
    out = []
    for path in sys.argv[1:]:
        try:
            out.append(Solution.load(path).error_estimate())
        except Exception as exc:
            out.append({"raised": type(exc).__name__, "message": str(exc)})
    print(json.dumps(out))
""")


def _fresh(*paths):
    """The estimate of each file as a fresh interpreter reads it."""
    res = subprocess.run([sys.executable, "-c", FRESH, *map(str, paths)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def _same(got, want, where=""):
    """Equal dicts: the same keys, strings equal, floats equal (NaN to NaN)."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and sorted(got) == sorted(want), (where, got, want)
        for k in want:
            _same(got[k], want[k], f"{where}[{k!r}]")
    elif isinstance(want, str):
        assert got == want, (where, got, want)
    else:
        assert isinstance(got, (int, float)), (where, got, want)
        assert (math.isnan(got) and math.isnan(want)) or float(got) == float(want), \
            (where, got, want)


def _one_line(exc):
    text = str(exc)
    assert "\n" not in text and len(text) < 400, text
    return text


# -- estimates --------------------------------------------------------------------------
def test_fe_stationary_estimate_and_correction_survive_a_file(tmp_path):
    """The rtol solve's corrected density (the non-negative correction moved 2e-6 of
    L1): its estimate, made before saving, is returned after loading with every key
    (``correction_L1``, ``levels``) and equal floats; the correction itself is kept
    (``info["correction"]``), so a density saved before its estimate was made still
    adds the correction's share when it is estimated after loading."""
    sol = fem.stationary(PAPER, rtol=1e-2)
    assert sol.info["correction"]["L1"] > 0          # the case of the issue: corrected
    est = sol.error_estimate()
    path = sol.save(tmp_path / "fe.npz")
    got, = _fresh(path)
    _same(got, est)
    back = Solution.load(path)
    _same(back.info["correction"], sol.info["correction"])
    assert back.info["error_estimate"] == sol.info["error_estimate"]
    # saved before its estimate: estimated after loading, with the correction's share
    early = fem.stationary(PAPER, degree=2, nx=16, ny=32)
    assert early.info["correction"]["L1"] > 0 and early._estimate is None
    late = Solution.load(early.save(tmp_path / "early.npz")).error_estimate()
    assert late["correction_L1"] == pytest.approx(
        early.info["correction"]["L1"] + early.info["correction"]["dips"], rel=1e-12)
    now = early.error_estimate()
    for k in ("L1", "E_H", "E_x2", "E_y2", "P_impact"):
        assert late[k] == pytest.approx(now[k], rel=1e-9), k


def test_fe_transient_member_keeps_its_estimate(tmp_path):
    """A member of ``fem.transient``'s list saved after the shared estimate was made
    returns it after loading (every key, equal floats); one saved before any estimate
    refuses in one line that says so."""
    sols = fem.transient(VibroImpactSystem.paper(), initial=PACKET, times=[0.25, 0.5],
                         nx=8, dt=0.05, progress=False)
    before = sols[0].save(tmp_path / "before.npz")
    ests = [s.error_estimate() for s in sols]
    paths = [s.save(tmp_path / f"t{i}.npz") for i, s in enumerate(sols)]
    got = _fresh(*paths, before)
    for g, e in zip(got, ests):
        _same(g, e)
    assert got[-1]["raised"] == "ValueError"
    assert "saved before" in _one_line(got[-1]["message"])


def test_montecarlo_estimates_survive_a_file(tmp_path, monkeypatch):
    """A transient member's estimate (with its time-step bias from the shared second
    run) is returned after loading, not 2 SE only; a stationary one is read back
    without running the second run again."""
    run = montecarlo.transient(PAPER, initial={"mean": (0.1, 0.2), "std": (0.1, 0.1)},
                               times=[0.5, 2.0], dt=0.05, n_paths=512, seed=3,
                               progress=False)
    est = run[-1].error_estimate()
    assert all(math.isfinite(v) for v in est["bias"].values())
    stat = montecarlo.stationary(PAPER, seed=1, n_paths=256, t_sample=50, progress=False)
    sest = stat.error_estimate()
    paths = [run[-1].save(tmp_path / "mt.npz"), stat.save(tmp_path / "ms.npz")]
    got = _fresh(*paths)
    _same(got[0], est)
    _same(got[1], sest)
    again = Solution.load(Solution.load(paths[0]).save(tmp_path / "again.npz"))
    _same(again.error_estimate(), est)                  # kept through a second save

    def no_second_run(*args, **kw):
        raise AssertionError("the second run was made again")
    monkeypatch.setattr(type(stat), "rerun", staticmethod(no_second_run))
    _same(Solution.load(paths[1]).error_estimate(), sest)


def test_a_tampered_estimate_is_refused(tmp_path):
    """The stored estimate is checked like the rest of the file."""
    sol = fem.stationary(PAPER, degree=2, nx=8, ny=16)
    sol.error_estimate()
    path = sol.save(tmp_path / "f.npz")
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    meta["estimate"]["E_H"] = [1, 2]
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "bad.npz", **arrays)
    with pytest.raises(ValueError, match="estimate") as exc:
        Solution.load(tmp_path / "bad.npz")
    _one_line(exc.value)


# -- old ones ----------------------------------------------------------------------------
def test_save_onto_a_directory_is_one_line(tmp_path):
    sol = fem.stationary(PAPER, nx=8, ny=16)
    (tmp_path / "d.npz").mkdir()
    for given in (tmp_path / "d.npz", tmp_path / "d"):      # (".npz" appended)
        with pytest.raises(ValueError, match="directory") as exc:
            sol.save(given)
        assert str(tmp_path / "d.npz") in _one_line(exc.value)
        assert exc.value.name == "path"


def test_to_xarray_without_pandas_names_pandas():
    """xarray imports pandas: with pandas unimportable the message names pandas."""
    code = textwrap.dedent("""
        import sys
        sys.modules["pandas"] = None             # unimportable
        from fpk_vibro import VibroImpactSystem, exact
        sol = exact.gibbs(VibroImpactSystem.paper(r=1.0, D2=0.0))
        try:
            sol.to_xarray()
        except ImportError as exc:
            print(str(exc))
        else:
            print("no error")
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr
    message = res.stdout.strip()
    assert "needs pandas" in _one_line(message), message
    assert "fpk_vibro[data]" in message


def _tampered(path, dst, *, system=None, shift=None):
    """A copy of the FE file ``path`` with another stored system, or the mesh's x
    coordinates (vertices and tensor nodes) scaled by ``shift``."""
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    if system is not None:
        arrays["system"] = np.array(system.to_json())
    if shift is not None:
        p = arrays["mesh_p"].copy()
        p[0] *= shift
        arrays["mesh_p"] = p
        arrays["xnodes"] = arrays["xnodes"] * shift
    np.savez(dst, **arrays)
    return dst


@pytest.mark.parametrize("how", ["system", "mesh"])
def test_a_wall_off_its_mesh_is_refused(tmp_path, how):
    """The stored system's walls must be the mesh's x-extremes (as a solve requires,
    fem.generator.mesh_domain): a file whose system (or mesh) was edited is refused in
    one line naming the wall; one-sided and asymmetric walls still load."""
    sol = fem.stationary(PAPER, nx=8, ny=16)
    path = sol.save(tmp_path / "f.npz")
    moved = VibroImpactSystem.paper(r=0.7, delta=0.5) if how == "system" else None
    bad = _tampered(path, tmp_path / "bad.npz", system=moved,
                    shift=0.9 if how == "mesh" else None)
    with pytest.raises(ValueError, match="wall") as exc:
        Solution.load(bad)
    assert str(bad) in _one_line(exc.value)
    for s in (VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, barriers="right",
                                delta=0.6, r=0.8),
              VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.01, left={"position": -0.4,
                                "r": 0.9}, right={"position": 0.7, "r": 0.6})):
        good = fem.stationary(s, nx=8, ny=16)
        back = Solution.load(good.save(tmp_path / "good.npz"))
        assert np.array_equal(back.dofs, good.dofs)
