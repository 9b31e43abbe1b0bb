"""Solution files: corrupted or foreign files end in one ValueError line naming the file,
before anything is built; good files of every kind load in a fresh interpreter, where
only ``from fpk_vibro import Solution`` was imported, to the same moments bit for bit."""
import io
import json
import os
import subprocess
import sys
import textwrap
import zipfile

import numpy as np
import pytest

from fpk_vibro import Solution, VibroImpactSystem, averaging, exact, fem, montecarlo
from fpk_vibro.solution import KIND_MODULES

PAPER = VibroImpactSystem.paper(r=0.92)
INIT = {"mean": (0.0, 1.0), "std": (0.05, 0.05)}


def _build():
    """One small solution of every kind (about a second in all)."""
    return {
        "averaging": averaging.stationary(PAPER),
        "fem": fem.stationary(PAPER, nx=8, ny=16),
        "montecarlo": montecarlo.stationary(PAPER, seed=1, n_paths=256, t_sample=50),
        "averaging_grid": averaging.transient(PAPER, times=[1.0], initial=INIT)[0],
        "exact": exact.gibbs(VibroImpactSystem.paper(r=1.0, D2=0.0)),
    }


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    """kind -> path of a good file of that kind."""
    d = tmp_path_factory.mktemp("good")
    return {k: s.save(d / f"{k}.npz") for k, s in _build().items()}


# -- building bad files ----------------------------------------------------------------
def members(path):
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def savez(dst, arrays):
    np.savez(dst, **arrays)
    return dst


def edit(change):
    """A case: the good file of a kind with its members changed by ``change(m)``."""
    def make(src, dst):
        m = members(src)
        change(m)
        return savez(dst, m)
    return make


def edit_json(member, change):
    """A case: member ``member`` (JSON) of the good file changed by ``change(obj)``."""
    def change_member(m):
        obj = json.loads(str(m[member]))
        change(obj)                       # in place
        m[member] = np.array(json.dumps(obj))
    return edit(change_member)


def raw(data):
    def make(src, dst):
        dst.write_bytes(data)
        return dst
    return make


def truncated(frac):
    def make(src, dst):
        b = src.read_bytes()
        dst.write_bytes(b[:int(len(b) * frac)] if frac < 1 else b[:-1])
        return dst
    return make


def zip_of(entries):
    """A case: a zip with ``entries`` (name -> bytes) added to the good file's members."""
    def make(src, dst):
        with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
            for info in zin.infolist():
                if info.filename not in entries:
                    zout.writestr(info.filename, zin.read(info))
            for name, data in entries.items():
                zout.writestr(name, data)
        return dst
    return make


def npy_header(shape, descr="<f8"):
    fh = io.BytesIO()
    np.lib.format.write_array_header_1_0(fh, {"descr": descr, "fortran_order": False,
                                              "shape": shape})
    return fh.getvalue()


def npy_bytes(array):
    fh = io.BytesIO()
    np.save(fh, array)
    return fh.getvalue()


def flip_data_byte(member):
    """A case: the last data byte of ``member`` flipped in place (zip CRC no longer matches)."""
    def make(src, dst):
        b = bytearray(src.read_bytes())
        with zipfile.ZipFile(src) as z:
            info = z.getinfo(member + ".npy")
        off = info.header_offset
        n, e = int.from_bytes(b[off + 26:off + 28], "little"), int.from_bytes(b[off + 28:off + 30], "little")
        b[off + 30 + n + e + info.compress_size - 1] ^= 0xFF
        dst.write_bytes(bytes(b))
        return dst
    return make


def directory(src, dst):
    dst.mkdir()
    return dst


def missing(src, dst):
    return dst


def fifo(src, dst):
    os.mkfifo(dst)
    return dst


def compressed_junk(src, dst):
    """A deflated zip member whose .npy header claims 10¹² values."""
    with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as z:
        for k, a in members(src).items():
            if k != "dofs":
                z.writestr(k + ".npy", npy_bytes(a))
        z.writestr("dofs.npy", npy_header((10 ** 12,)) + bytes(64))
    return dst


def _set(key, value):
    return lambda m: m.__setitem__(key, value)


def _drop(key):
    return lambda m: m.pop(key)


def _poke(key, index, value):
    def change(m):
        a = m[key].copy()
        a.flat[index] = value
        m[key] = a
    return change


# -- the cases ---------------------------------------------------------------------------
ANY_KIND = {   # name -> (make, part of the expected message); made from the FE file
    "empty": (raw(b""), "not a zip archive"),
    "random_bytes": (raw(np.random.default_rng(0).bytes(4000)), "not a zip archive"),
    "text": (raw(b"E_H = 0.2\nE_x2 = 0.1\n"), "not a zip archive"),
    "json": (raw(b'{"format": "fpk_vibro.solution"}'), "not a zip archive"),
    "npy_not_npz": (raw(npy_bytes(np.arange(5.0))), "not a zip archive"),
    "pickle": (raw(b"\x80\x04\x95\x05\x00\x00\x00\x00\x00\x00\x00K\x01."), "not a zip archive"),
    "zip_without_members": (lambda s, d: _plain_zip(d, {"readme.txt": b"hello"}), "no 'format'"),
    "empty_zip": (lambda s, d: _plain_zip(d, {}), "no 'format'"),
    "npz_foreign": (lambda s, d: savez(d, {"a": np.arange(3)}), "no 'format'"),
    "npz_object_array": (edit(_set("dofs", np.array([{"evil": 1}], dtype=object))), "pickled"),
    "meta_object_array": (zip_of({"meta.npy": npy_bytes(np.array([{"a": 1}], dtype=object))}),
                          "member 'meta' holds Python objects"),
    "format_wrong": (edit(_set("format", np.array("other.format"))), "not an fpk_vibro"),
    "format_bytes": (edit(_set("format", np.array(b"fpk_vibro.solution"))), "'format' must be"),
    "version_newer": (edit(_set("version", np.array(2))), "newer"),
    "version_zero": (edit(_set("version", np.array(0))), "format version"),
    "version_text": (edit(_set("version", np.array("1"))), "'version' must be"),
    "version_float": (edit(_set("version", np.array(1.0))), "'version' must be"),
    "version_missing": (edit(_drop("version")), "'version' is missing"),
    "kind_unknown": (edit(_set("kind", np.array("spectral"))), "unknown solution kind"),
    "kind_1d": (edit(_set("kind", np.array(["fem"]))), "'kind' must be"),
    "meta_not_json": (edit(_set("meta", np.array("{degree: 1"))), "not valid JSON"),
    "meta_list": (edit(_set("meta", np.array("[1, 2]"))), "JSON object"),
    "meta_deep": (edit(_set("meta", np.array("[" * 100000 + "]" * 100000))), "not valid JSON"),
    "meta_empty": (edit(_set("meta", np.array(""))), "not valid JSON"),
    "system_r2": (edit_json("system", lambda s: s.update(r=2.0)), "r must be"),
    "system_D1_negative": (edit_json("system", lambda s: s.update(D1=-1.0)), "D1 must be"),
    "system_text_field": (edit_json("system", lambda s: s.update(a="one")), "a must be"),
    "system_unknown_field": (edit_json("system", lambda s: s.update(mass=1.0)), "unknown field"),
    "system_missing_field": (edit_json("system", lambda s: s.pop("c")), "misses field"),
    "system_list": (edit(_set("system", np.array("[1.0, 0.2]"))), "JSON object"),
    "system_barrier_none_soft": (edit_json("system", lambda s: s.update(barriers="none", b=-1.0)),
                                 "invalid system"),
    "extra_member_text": (zip_of({"notes.txt": b"hello"}), "unexpected member"),
    "extra_array": (edit(_set("extra", np.zeros(3))), "unexpected member"),
    "crc_tampered": (flip_data_byte("dofs"), "cannot be read"),
    "header_claims_more": (zip_of({"dofs.npy": npy_header((10 ** 12,)) + bytes(64)}),
                           "truncated or padded"),
    "header_claims_less": (zip_of({"dofs.npy": npy_header((2,)) + bytes(64)}),
                           "truncated or padded"),
    "header_garbage": (zip_of({"dofs.npy": b"\x93NUMPY\x01\x00\x10\x00{'descr': <<<}   \n"}),
                       "cannot be read"),
    "not_npy_member": (zip_of({"dofs.npy": b"just text"}), "cannot be read"),
    "compressed_bomb_header": (compressed_junk, "truncated or padded"),
    "directory": (directory, "is a directory"),
    "missing_path": (missing, "no such file"),
    "fifo": (fifo, "not a regular file"),
    "fem_degree_5": (edit_json("meta", lambda m: m.update(degree=5)), "meta['degree']"),
    "fem_cell_hex": (edit_json("meta", lambda m: m.update(cell="hex")), "meta['cell']"),
    "fem_tensor_text": (edit_json("meta", lambda m: m.update(tensor="yes")), "meta['tensor']"),
    "fem_mass_zero": (edit_json("meta", lambda m: m.update(mass=0.0)), "meta['mass']"),
    "fem_info_nested": (edit_json("meta", lambda m: m.update(info={"a": [1]})), "meta['info']"),
    "fem_tri_cells_quad": (edit_json("meta", lambda m: m.update(cell="tri")), "'mesh_t' has shape"),
    "fem_degree_2_dofs": (edit_json("meta", lambda m: m.update(degree=2)), "for degree 2"),
    "fem_no_tensor_nodes": (edit(lambda m: (m.pop("xnodes"), m.pop("ynodes"))), "'xnodes' is missing"),
    "fem_index_out_of_range": (edit(_poke("mesh_t", 5, 10 ** 6)), "indices outside"),
    "fem_index_negative": (edit(_poke("mesh_t", 0, -1)), "indices outside"),
    "fem_cells_float": (edit(lambda m: m.update(mesh_t=m["mesh_t"].astype(float))), "dtype float64"),
    "fem_dofs_float32": (edit(lambda m: m.update(dofs=m["dofs"].astype(np.float32))), "dtype float32"),
    "fem_dofs_short": (edit(lambda m: m.update(dofs=m["dofs"][:3])), "'dofs' has shape (3,)"),
    "fem_dofs_2d": (edit(lambda m: m.update(dofs=m["dofs"][None, :])), "expected 1 axis"),
    "fem_points_3d": (edit(lambda m: m.update(mesh_p=np.vstack([m["mesh_p"], m["mesh_p"][:1]]))),
                      "'mesh_p' has shape (3,"),
    "fem_nodes_unsorted": (edit(lambda m: m.update(xnodes=m["xnodes"][::-1].copy())),
                           "not strictly increasing"),
    "fem_nodes_not_spanning": (edit(lambda m: m.update(ynodes=m["ynodes"][:-1].copy())),
                               "do not span"),
    "fem_points_inf": (edit(_poke("mesh_p", 3, np.inf)), "non-finite"),
    "fem_dofs_nan": (edit(_poke("dofs", 7, np.nan)), "non-finite"),
    "fem_as_montecarlo": (edit(_set("kind", np.array("montecarlo"))), "meta misses key"),
    "fem_as_exact": (edit(_set("kind", np.array("exact"))), "unexpected member"),
}

# kind -> name -> (make, part of the message): the same faults for each kind's own layout
PER_KIND = {
    "averaging": {
        "meta_missing_Z": (edit_json("meta", lambda m: m.pop("Z")), "meta misses key 'Z'"),
        "meta_Z_negative": (edit_json("meta", lambda m: m.update(Z=-1.0)), "meta['Z']"),
        "meta_Z_nan": (edit_json("meta", lambda m: m.update(Z=float("nan"))), "meta['Z']"),
        "meta_n_panel_text": (edit_json("meta", lambda m: m.update(n_panel="24")), "meta['n_panel']"),
        "meta_n_panel_bool": (edit_json("meta", lambda m: m.update(n_panel=True)), "meta['n_panel']"),
        "meta_n_theta_huge": (edit_json("meta", lambda m: m.update(n_theta=10 ** 9)),
                              "meta['n_theta'] must be an integer in [4, 2000]"),
        "meta_Z_huge_int": (edit_json("meta", lambda m: m.update(Z=10 ** 400)), "meta['Z']"),
        "meta_n_panel_other": (edit_json("meta", lambda m: m.update(n_panel=20)), "'low_coef' has shape"),
        "meta_moments_list": (edit_json("meta", lambda m: m.update(moments=[1, 2])), "meta['moments']"),
        "meta_moments_inf": (edit_json("meta", lambda m: m["moments"].update(E_H=float("inf"))),
                             "meta['moments']"),
        "meta_no_P_impact": (edit_json("meta", lambda m: m["moments"].pop("P_impact")), "P_impact"),
        "array_missing": (edit(_drop("high_coef")), "'high_coef' is missing"),
        "array_shape": (edit(lambda m: m.update(low_phi0=m["low_phi0"][:-1].copy())), "'low_phi0' has shape"),
        "array_nan": (edit(_poke("high_coef", 4, np.nan)), "non-finite"),
        "array_inf": (edit(_poke("low_phi0", 0, -np.inf)), "non-finite"),
        "edges_unsorted": (edit(lambda m: m.update(high_edges=m["high_edges"][::-1].copy())),
                           "not strictly increasing"),
        "array_int": (edit(lambda m: m.update(low_edges=np.arange(m["low_edges"].size))), "dtype int64"),
    },
    "fem": {
        "meta_missing_degree": (edit_json("meta", lambda m: m.pop("degree")), "meta misses key 'degree'"),
        "meta_residual_negative": (edit_json("meta", lambda m: m.update(residual=-1.0)), "meta['residual']"),
        "array_missing": (edit(_drop("dofs")), "'dofs' is missing"),
        "array_shape": (edit(lambda m: m.update(mesh_t=m["mesh_t"][:3].copy())), "'mesh_t' has shape"),
        "array_nan": (edit(_poke("dofs", 0, np.nan)), "non-finite"),
        "array_inf": (edit(_poke("ynodes", 0, -np.inf)), "non-finite"),
    },
    "montecarlo": {
        "meta_missing_dt": (edit_json("meta", lambda m: m.pop("dt")), "meta misses key 'dt'"),
        "meta_dt_zero": (edit_json("meta", lambda m: m.update(dt=0.0)), "meta['dt']"),
        "meta_quantities_unknown": (edit_json("meta", lambda m: m.update(quantities=["x", "z"])),
                                    "meta['quantities']"),
        "meta_quantities_text": (edit_json("meta", lambda m: m.update(quantities="x")),
                                 "meta['quantities']"),
        "meta_quantities_fewer": (edit_json("meta", lambda m: m.update(quantities=["x"])),
                                  "unexpected member"),
        "meta_x_seen_short": (edit_json("meta", lambda m: m.update(x_seen=[0.1])), "meta['x_seen']"),
        "meta_overflow_big": (edit_json("meta", lambda m: m["overflow"].update(x=2.0)), "meta['overflow']"),
        "meta_partial_int": (edit_json("meta", lambda m: m.update(partial=0)), "meta['partial']"),
        "meta_mode_other": (edit_json("meta", lambda m: m.update(mode="left")), "meta['mode']"),
        "array_missing": (edit(_drop("density_joint")), "'density_joint' is missing"),
        "array_shape": (edit(lambda m: m.update(density_x=m["density_x"][:-1].copy())), "'density_x' has shape"),
        "joint_transposed": (edit(lambda m: m.update(density_joint=np.zeros((50, 49)))), "'density_joint' has shape"),
        "moments_short": (edit(lambda m: m.update(moments=m["moments"][:5].copy())), "'moments' has shape"),
        "array_nan": (edit(_poke("density_y", 3, np.nan)), "non-finite"),
        "array_inf": (edit(_poke("se_energy", 3, np.inf)), "non-finite"),
        "moments_nan": (edit(_poke("moments", 0, np.nan)), "non-finite"),
        "density_negative": (edit(_poke("density_x", 10, -0.5)), "negative"),
        "se_negative": (edit(_poke("se_joint", 10, -0.5)), "negative"),
        "edges_unsorted": (edit(_poke("edges_H", 5, 1e9)), "not strictly increasing"),
        "edges_too_few": (edit(lambda m: m.update(edges_y=m["edges_y"][:1].copy(),
                                                  density_y=np.zeros(0), se_y=np.zeros(0))),
                          "at least 2"),
    },
    "averaging_grid": {
        "meta_missing_time": (edit_json("meta", lambda m: m.pop("time")), "meta misses key 'time'"),
        "meta_time_negative": (edit_json("meta", lambda m: m.update(time=-1.0)), "meta['time']"),
        "meta_time_text": (edit_json("meta", lambda m: m.update(time="1")), "meta['time']"),
        "array_missing": (edit(_drop("faces")), "'faces' is missing"),
        "array_shape": (edit(lambda m: m.update(density=m["density"][:-2].copy())), "'density' has shape"),
        "array_nan": (edit(_poke("density", 3, np.nan)), "non-finite"),
        "array_inf": (edit(_poke("faces", 3, np.inf)), "non-finite"),
        "density_negative": (edit(_poke("density", 3, -1.0)), "negative"),
        "faces_unsorted": (edit(_poke("faces", 3, 0.0)), "not strictly increasing"),
    },
    "exact": {
        "not_gibbs_r": (edit_json("system", lambda s: s.update(
            r=0.5, left={**s["left"], "r": 0.5}, right={**s["right"], "r": 0.5})),
            "Gibbs density needs"),
        "walls_disagree": (edit_json("system", lambda s: s.update(r=0.5)), "not both"),
        "not_gibbs_D2": (edit_json("system", lambda s: s.update(D2=0.01)), "Gibbs density needs"),
        "meta_list": (edit(_set("meta", np.array("[]"))), "JSON object"),
        "extra_array": (edit(_set("dofs", np.zeros(3))), "expected no arrays"),
    },
}
for _kind in PER_KIND:
    PER_KIND[_kind].update({
        "truncated_1": (truncated(0.0001), "not a zip archive"),
        "truncated_half": (truncated(0.5), "not a zip archive"),
        "truncated_most": (truncated(0.97), "not a zip archive"),
        "truncated_last_byte": (truncated(1.0), "not a zip archive"),
        "kind_swapped": (edit(_set("kind", np.array("fem" if _kind != "fem" else "averaging"))),
                         "meta misses key"),
        "system_r2": (edit_json("system", lambda s: s.update(r=2.0)), "r must be"),
        "system_D1_negative": (edit_json("system", lambda s: s.update(D1=-1.0)), "D1 must be"),
        "version_newer": (edit(_set("version", np.array(7))), "newer"),
    })

CASES = [pytest.param("fem", make, part, id=f"any-{name}") for name, (make, part) in ANY_KIND.items()]
CASES += [pytest.param(kind, make, part, id=f"{kind}-{name}")
          for kind, cases in PER_KIND.items() for name, (make, part) in cases.items()]


def _plain_zip(dst, entries):
    with zipfile.ZipFile(dst, "w") as z:
        for name, data in entries.items():
            z.writestr(name, data)
    return dst


def test_at_least_30_cases():
    assert len(CASES) >= 30


@pytest.mark.parametrize("kind, make, part", CASES)
def test_bad_file_is_one_value_error(good, tmp_path, kind, make, part):
    if make is fifo and not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    path = make(good[kind], tmp_path / "bad file.npz")
    with pytest.raises(ValueError) as info:
        Solution.load(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: ") and "bad file.npz" in msg
    assert "\n" not in msg and len(msg) < 400, msg
    assert part in msg, msg
    assert info.value.__cause__ is None and info.value.__suppress_context__


def test_subclass_load_names_the_other_class(good):
    with pytest.raises(ValueError, match=r"fem\.npz: holds a FEMSolution, not a GibbsSolution"):
        exact.GibbsSolution.load(good["fem"])


def test_path_of_wrong_type():
    with pytest.raises(ValueError, match="Solution.load: path must be a file path"):
        Solution.load(3)


def test_unprintable_file_name_stays_one_line(tmp_path):
    path = tmp_path / "two\nlines.npz"
    path.write_bytes(b"junk")
    with pytest.raises(ValueError) as info:
        Solution.load(path)
    assert "\n" not in str(info.value) and "two\\nlines.npz" in str(info.value)


def test_every_kind_declared():
    """The lazy map names exactly the kinds the subclasses register."""
    for module in set(KIND_MODULES.values()):
        __import__(module)
    assert set(Solution._registry) == set(KIND_MODULES)


def test_compressed_and_round_trips_still_load(good, tmp_path):
    """A good file zipped with deflate (np.savez_compressed) is no corruption."""
    m = members(good["montecarlo"])
    np.savez_compressed(tmp_path / "c.npz", **m)
    back = Solution.load(tmp_path / "c.npz")
    assert back.moments() == Solution.load(good["montecarlo"]).moments()


@pytest.mark.parametrize("kw", [dict(degree=2), dict(degree=2, element="tri"), dict(element="tri"),
                                dict(mesh="meshes/paper_d0.6_tri_32x96.msh")])
def test_fem_layouts_round_trip(tmp_path, kw):
    """The DOF count check agrees with skfem for Q2, P2, P1 and unstructured meshes."""
    from pathlib import Path
    if "mesh" in kw:
        kw = dict(mesh=str(Path(__file__).parent.parent / kw["mesh"]))
    else:
        kw = dict(nx=6, ny=12, **kw)
    sol = fem.stationary(PAPER, **kw)
    back = Solution.load(sol.save(tmp_path / "f.npz"))
    assert np.array_equal(back.dofs, sol.dofs) and back.basis.N == sol.dofs.size
    x = np.linspace(-0.6, 0.6, 5)
    assert np.array_equal(back.pdf_joint(x, x), sol.pdf_joint(x, x))


def test_montecarlo_variants_round_trip(tmp_path):
    """Transient snapshots and a subset of histograms have their own layouts."""
    run = montecarlo.transient(PAPER, initial=INIT, times=[0.5], n_paths=256, seed=2,
                               quantities=("x", "joint"))
    back = Solution.load(run[0].save(tmp_path / "t.npz"))
    assert back.time == 0.5 and back.quantities == ("x", "joint")
    assert back.moments() == run[0].moments() and back.moments_se() == run[0].moments_se()


FRESH = textwrap.dedent("""
    import json, sys
    from fpk_vibro import Solution
    assert not any(m in sys.modules for m in ("fpk_vibro.fem", "fpk_vibro.averaging",
                                              "fpk_vibro.montecarlo", "fpk_vibro.exact"))
    out = {}
    for kind, path in json.loads(sys.argv[1]).items():
        s = Solution.load(path)
        out[kind] = [type(s).__name__, s.moments()]
    print(json.dumps(out))
""")


def test_load_in_fresh_interpreter(tmp_path):
    sols = _build()
    paths = {k: str(s.save(tmp_path / f"{k}.npz")) for k, s in sols.items()}
    res = subprocess.run([sys.executable, "-c", FRESH, json.dumps(paths)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    got = json.loads(res.stdout)
    for kind, s in sols.items():
        name, moments = got[kind]
        assert name == type(s).__name__
        assert moments == s.moments(), kind      # JSON floats round-trip exactly


def test_a_saved_file_records_the_package_version(tmp_path):
    import fpk_vibro
    from fpk_vibro import VibroImpactSystem, averaging
    path = averaging.stationary(VibroImpactSystem.paper(r=0.92)).save(tmp_path / "a.npz")
    with np.load(path) as d:
        assert str(d["package"]) == fpk_vibro.__version__
