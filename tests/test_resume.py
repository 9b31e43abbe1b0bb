"""Resume and the ownership of an output directory (issue 22, sections 2 and 6).

A point record is kept by ``--resume`` only when it is the file of its own index and
carries the fingerprint of this scene and of this point's parameters and settings,
finished, with its files; a full disk ends in one line naming the file, results.json
keeps what finished, and a later ``--resume`` completes the run; a new run owns the
directory's outputs (no earlier run's densities, netCDF or figures stay beside it).
"""
import errno
import json
import os
import re
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from fpk_vibro.app import cli
from test_faults import SWEEP
from conftest import paper_tables

AVG = paper_tables(D2=None) + """
[study]
methods = ["averaging"]
quantities = ["energy", "x", "moments"]
[output]
formats = {formats}
[sweep]
r = [{r}]
"""

MC = SWEEP   # the Monte Carlo sweep of the signal tests



def write(tmp_path, text, name, **fmt):
    fmt = {k: (", ".join(str(x) for x in v) if k == "r" else v) for k, v in fmt.items()}
    p = tmp_path / name
    p.write_text(textwrap.dedent(text.format(**fmt)))
    return p


def avg(tmp_path, r=(0.5, 0.6, 0.7), formats='["json", "npz"]', name="avg.toml"):
    return write(tmp_path, AVG, name, r=r, formats=formats)


def run(*args):
    """``fpk-vibro run ...`` in this process: (exit status, stdout, stderr)."""
    import contextlib
    import io
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["run", *map(str, args)])
    return code, out.getvalue(), err.getvalue()


def start(args, **kw):
    return subprocess.Popen([sys.executable, "-m", "fpk_vibro", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def wait_for(cond, timeout=120.0):
    t0 = time.time()
    while not cond():
        if time.time() - t0 > timeout:
            raise AssertionError("timed out")
        time.sleep(0.05)


def results(out):
    return json.loads((out / "results.json").read_text())


def resume_line(stdout):
    lines = [s.strip() for s in stdout.splitlines() if "resuming:" in s]
    assert len(lines) == 1, stdout
    return lines[0]


# -- section 2: --resume keeps only this scene's own records ---------------------------

def test_resume_after_kill_9_does_not_adopt_another_scenes_points(tmp_path):
    """Scene A killed with kill -9 before results.json; scene B (same sweep values,
    other settings) resumed into the same directory computes every point itself."""
    a = write(tmp_path, MC, "a.toml", t_sample=12000.0, r=(0.5, 0.6, 0.7))
    b = write(tmp_path, MC, "b.toml", t_sample=100.0, r=(0.5, 0.6, 0.7))
    out = tmp_path / "out"
    proc = start(["run", str(a), "--out", str(out), "--workers", "1", "--quiet"])
    wait_for(lambda: (out / "points" / "p0.json").exists())
    proc.kill()
    proc.communicate(timeout=30)
    assert proc.returncode == -9 and not (out / "results.json").exists()
    r = start(["run", str(b), "--out", str(out), "--workers", "1", "--resume"])
    stdout, err = r.communicate(timeout=300)
    assert r.returncode == 0, err
    doc = results(out)
    assert doc["status"] == "complete" and doc["name"] == "b"
    assert [p["parameters"]["r"] for p in doc["points"]] == [0.5, 0.6, 0.7]
    for p in doc["points"]:
        assert p["methods"]["montecarlo"]["options"]["t_sample"] == 100.0, p["index"]
    assert "0 of 3 point(s) reused, 3 recomputed" in resume_line(stdout)
    assert "1 of another scene" in resume_line(stdout)


def test_resume_with_another_sweep_computes_its_own_points(tmp_path):
    """The issue's case: B's results.json listed A's r = 0.5, 0.6 as its own."""
    out = tmp_path / "o"
    assert run(avg(tmp_path, r=(0.5, 0.6)), "--out", out, "--quiet")[0] == 0
    (out / "results.json").unlink()              # as if A was killed before writing it
    code, stdout, _ = run(avg(tmp_path, r=(0.8, 0.9)), "--out", out, "--resume")
    assert code == 0
    assert [p["parameters"]["r"] for p in results(out)["points"]] == [0.8, 0.9]
    for p in results(out)["points"]:
        assert p["system"]["r"] == p["parameters"]["r"]
    assert resume_line(stdout).endswith("0 of 2 point(s) reused, 2 recomputed "
                                        "(2 of another scene)")


def test_resume_trusts_a_record_by_its_file_name(tmp_path):
    """An edited p1.json with "index": 0 does not replace point 0."""
    path, out = avg(tmp_path, r=(0.5, 0.6)), tmp_path / "o"
    assert run(path, "--out", out, "--quiet")[0] == 0
    first = results(out)["points"]
    rec = json.loads((out / "points" / "p1.json").read_text())
    rec["index"] = 0
    (out / "points" / "p1.json").write_text(json.dumps(rec))
    code, stdout, _ = run(path, "--out", out, "--resume")
    assert code == 0
    doc = results(out)
    assert [p["parameters"]["r"] for p in doc["points"]] == [0.5, 0.6]
    assert doc["points"][0] == first[0]
    assert doc["points"][1]["index"] == 1
    assert doc["points"][1]["methods"]["averaging"]["moments"] == \
        first[1]["methods"]["averaging"]["moments"]
    assert resume_line(stdout).endswith("1 of 2 point(s) reused, 1 recomputed "
                                        "(1 record unreadable or of another index)")


def test_resume_recomputes_other_settings_of_the_same_scene(tmp_path):
    """--reduced and the full size differ in their options: not reused for each other."""
    from fpk_vibro.app.runner import run_scene
    from fpk_vibro.app.scenes import load_scene
    path, out = write(tmp_path, MC, "mc.toml", t_sample=300.0, r=(0.5,)), tmp_path / "o"
    scene = load_scene(path)
    run_scene(scene.reduced(), out=out, log=lambda s: None)
    lines = []
    doc = run_scene(scene, out=out, resume=True, log=lines.append)
    assert doc["points"][0]["methods"]["montecarlo"]["options"]["t_sample"] == 300.0
    assert lines[0].strip() == ("resuming: 0 of 1 point(s) reused, 1 recomputed "
                                "(1 other parameters or settings)")


def test_resume_recomputes_a_point_whose_densities_file_is_missing(tmp_path):
    path, out = avg(tmp_path), tmp_path / "o"
    assert run(path, "--out", out, "--quiet")[0] == 0
    with np.load(out / "densities.npz") as d:
        before = {k: d[k] for k in d.files}
    (out / "points" / "p1.npz").unlink()
    code, stdout, _ = run(path, "--out", out, "--resume")
    assert code == 0
    with np.load(out / "densities.npz") as d:
        assert sorted(d.files) == sorted(before)
        assert any(k.startswith("p1.") for k in d.files)
        for k in d.files:
            assert np.array_equal(d[k], before[k]), k
    assert resume_line(stdout).endswith("2 of 3 point(s) reused, 1 recomputed "
                                        "(1 densities or figures missing)")


def test_resume_retries_failed_points(tmp_path, monkeypatch):
    from fpk_vibro.app import runner
    solve = runner._solve

    def failing(method, system, scene, progress=False):
        if system.r == 0.6:
            raise RuntimeError("the solver broke")
        return solve(method, system, scene, progress)

    path, out = avg(tmp_path), tmp_path / "o"
    monkeypatch.setattr(runner, "_solve", failing)
    assert run(path, "--out", out, "--quiet", "--workers", "1")[0] == 1
    assert [p["status"] for p in results(out)["points"]] == ["done", "failed", "done"]
    monkeypatch.setattr(runner, "_solve", solve)
    code, stdout, _ = run(path, "--out", out, "--resume", "--workers", "1")
    assert code == 0
    assert resume_line(stdout).endswith("2 of 3 point(s) reused, 1 recomputed "
                                        "(1 failed before)")
    doc = results(out)
    assert doc["status"] == "complete" and [p["status"] for p in doc["points"]] == ["done"] * 3


# -- section 6: a full disk, and a run owns its directory ------------------------------

def _named_file(err, out):
    """The file the one-line error names: in ``out`` or its points, not a temporary."""
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert "No space left on device" in err, err
    m = re.search(r"error: '([^']+)':", err)
    assert m, err
    named = Path(m.group(1))
    assert named.parent in (out, out / "points") and not named.name.startswith("."), err
    assert ".tmp" not in err, err
    return named


def _temporaries(out):
    return [f for f in out.rglob("*") if f.name.endswith(".tmp")]


def test_full_disk_names_the_file_keeps_what_finished_and_resume_completes(
        tmp_path, monkeypatch):
    """Injected in this process: writing points/p1.npz finds the disk full."""
    from fpk_vibro import io
    path, out = avg(tmp_path), tmp_path / "o"
    fsync = os.fsync

    def full(fd):
        if ".p1.npz." in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(errno.ENOSPC, "No space left on device")
        return fsync(fd)

    monkeypatch.setattr(io.os, "fsync", full)
    code, _, err = run(path, "--out", out, "--quiet", "--workers", "1")
    assert code == 2
    assert _named_file(err, out) == out / "points" / "p1.npz"
    assert "results.json lists the 1 finished point(s)" in err and "--resume" in err
    assert not _temporaries(out)
    doc = results(out)
    assert doc["status"] == "failed" and str(out / "points" / "p1.npz") in doc["error"]
    assert [p["status"] for p in doc["points"]] == ["done", "interrupted", "interrupted"]
    monkeypatch.setattr(io.os, "fsync", fsync)          # space freed
    code, stdout, err = run(path, "--out", out, "--resume", "--workers", "1")
    assert code == 0, err
    assert resume_line(stdout).endswith("1 of 3 point(s) reused, 2 recomputed "
                                        "(2 not computed before)")
    doc2 = results(out)
    assert doc2["status"] == "complete" and doc2["points"][0] == doc["points"][0]
    with np.load(out / "densities.npz") as d:
        assert {k.split(".")[0] for k in d.files} == {"p0", "p1", "p2"}


def test_full_disk_when_even_results_json_cannot_be_written(tmp_path, monkeypatch, capsys):
    from fpk_vibro import io
    path, out = avg(tmp_path), tmp_path / "o"
    fsync = os.fsync
    state = {"full": False}

    def full(fd):
        if ".p1.npz." in os.readlink(f"/proc/self/fd/{fd}"):
            state["full"] = True
        if state["full"]:
            raise OSError(errno.ENOSPC, "No space left on device")
        return fsync(fd)

    monkeypatch.setattr(io.os, "fsync", full)
    code, _, err = run(path, "--out", out, "--quiet", "--workers", "1")
    assert code == 2
    assert _named_file(err, out) == out / "points" / "p1.npz"
    assert "results.json could not be written" in err and "1 finished point(s)" in err
    assert not (out / "results.json").exists() and not _temporaries(out)
    monkeypatch.setattr(io.os, "fsync", fsync)
    code, stdout, _ = run(path, "--out", out, "--resume", "--workers", "1")
    assert code == 0 and "1 of 3 point(s) reused" in resume_line(stdout)


@pytest.fixture
def small_fs(tmp_path):
    """A tmpfs of a given size (kB), resizable: a real full disk (root only)."""
    mnt = tmp_path / "mnt"
    mnt.mkdir()

    def mount(kb, remount=False):
        opts = f"remount,size={kb}k" if remount else f"size={kb}k"
        return subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(mnt)],
                              capture_output=True).returncode == 0

    if not mount(64):
        pytest.skip("cannot mount a tmpfs here (the injected full-disk tests cover it)")
    try:
        yield mnt, mount
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)


def test_a_real_full_disk_during_a_sweep_and_resume_after_space_is_freed(tmp_path, small_fs):
    mnt, mount = small_fs
    path = avg(tmp_path, formats='["json", "npz", "png"]')
    ref = tmp_path / "ref"                # the size of one point's outputs
    assert run(avg(tmp_path, r=(0.5,), formats='["json", "npz", "png"]', name="one.toml"),
               "--out", ref, "--quiet")[0] == 0
    point = sum(f.stat().st_size for f in ref.rglob("p0*") if f.is_file())
    assert mount(int(1.3 * point / 1024) + 8, remount=True)
    out = mnt / "o"
    r = subprocess.run([sys.executable, "-m", "fpk_vibro", "run", str(path), "--out", str(out),
                        "--quiet", "--workers", "1"], capture_output=True, text=True)
    assert r.returncode == 2, r.stderr
    named = _named_file(r.stderr, out)
    assert "results.json lists the 1 finished point(s)" in r.stderr
    assert not _temporaries(out)
    doc = results(out)
    assert doc["status"] == "failed" and str(named) in doc["error"]
    assert [p["status"] for p in doc["points"]] == ["done", "interrupted", "interrupted"]
    assert mount(16384, remount=True)     # space freed
    r = subprocess.run([sys.executable, "-m", "fpk_vibro", "run", str(path), "--out", str(out),
                        "--resume", "--workers", "1"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert resume_line(r.stdout).endswith("1 of 3 point(s) reused, 2 recomputed "
                                          "(2 not computed before)")
    doc2 = results(out)
    assert doc2["status"] == "complete" and doc2["points"][0] == doc["points"][0]
    with np.load(out / "densities.npz") as d:
        assert {k.split(".")[0] for k in d.files} == {"p0", "p1", "p2"}
    assert sorted(f.name for f in out.glob("*.png")) == sorted(
        f for p in doc2["points"] for f in p["figures"]) + sorted(doc2["figures"])


def test_a_new_run_owns_the_directory(tmp_path):
    """No densities.npz, results.nc or figures of an earlier run beside the new results;
    files the runner does not write stay."""
    pytest.importorskip("xarray")
    out = tmp_path / "o"
    first = avg(tmp_path, formats='["json", "npz", "png", "nc"]', name="first.toml")
    assert run(first, "--out", out, "--quiet")[0] == 0
    assert (out / "results.nc").exists() and list(out.glob("sweep_*.png"))
    (out / "notes.txt").write_text("mine")
    second = avg(tmp_path, r=(0.9,), formats='["json"]', name="second.toml")
    assert run(second, "--out", out, "--quiet")[0] == 0
    assert sorted(f.name for f in out.iterdir()) == ["notes.txt", "points", "results.json"]
    assert sorted(f.name for f in (out / "points").iterdir()) == ["p0.json"]
    assert results(out)["name"] == "second"


def test_a_run_whose_points_all_fail_leaves_no_earlier_densities(tmp_path, monkeypatch):
    from fpk_vibro.app import runner
    out = tmp_path / "o"
    path = avg(tmp_path, formats='["json", "npz", "png"]')
    assert run(path, "--out", out, "--quiet")[0] == 0

    def broken(*a, **k):
        raise RuntimeError("the solver broke")

    monkeypatch.setattr(runner, "_solve", broken)
    assert run(path, "--out", out, "--quiet", "--workers", "1")[0] == 1
    assert [p["status"] for p in results(out)["points"]] == ["failed"] * 3
    assert not (out / "densities.npz").exists() and not list(out.glob("*.png"))


def test_temporary_files_of_a_killed_writer_are_removed_by_the_next_run(tmp_path):
    path, out = avg(tmp_path), tmp_path / "o"
    (out / "points").mkdir(parents=True)
    left = [out / ".densities.npz.k2j3h4.tmp", out / ".results.json.abc.tmp",
            out / "points" / ".p0.npz.q9w8.tmp", out / ".p1_energy.png.x7.tmp"]
    for f in left:
        f.write_bytes(b"half")
    (out / ".results.nc.zz.tmp").mkdir()
    (out / ".results.nc.zz.tmp" / "results.nc").write_bytes(b"half")
    (out / ".mine.tmp").write_text("not the runner's")
    assert run(path, "--out", out, "--quiet")[0] == 0
    assert [f.name for f in _temporaries(out)] == [".mine.tmp"]


# -- section 8: a message names the file asked for, never its temporary ------------------

def test_write_errors_name_the_file_not_its_temporary(tmp_path, monkeypatch):
    from fpk_vibro import io
    target = tmp_path / "densities.npz"

    def no_space(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(io.os, "fsync", no_space)          # a write: no file named
    with pytest.raises(OSError) as e:
        io.atomic_savez(target, {"a": np.zeros(3)})
    assert e.value.filename == str(target) and e.value.errno == errno.ENOSPC
    monkeypatch.undo()

    replace = os.replace

    def fails(src, dst):                                   # names the temporary file
        raise OSError(errno.EIO, "Input/output error", src, dst)

    monkeypatch.setattr(io.os, "replace", fails)
    with pytest.raises(OSError) as e:
        io.atomic_json(tmp_path / "results.json", {"a": 1})
    assert e.value.filename == str(tmp_path / "results.json")
    monkeypatch.setattr(io.os, "replace", replace)

    def writer(p):                                         # names tmpdir/results.nc
        raise OSError(errno.ENOSPC, "No space left on device", str(p))

    with pytest.raises(OSError) as e:
        io.atomic_files(tmp_path / "results.nc", writer)
    assert e.value.filename == str(tmp_path / "results.nc")
    assert "tmp" not in str(e.value).replace(str(tmp_path), "")
    assert not _temporaries(tmp_path)

    def other(p):                                          # another file stays named
        raise FileNotFoundError(errno.ENOENT, "No such file or directory", "/x/font.ttf")

    with pytest.raises(FileNotFoundError) as e:
        io.atomic_write(tmp_path / "fig.png", lambda fh: other(fh))
    assert e.value.filename == "/x/font.ttf"
