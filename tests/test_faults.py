"""Fault injection: signals in the middle of a sweep, kill -9 during writes, a full disk,
a read-only output directory, two runs into one directory.  Nothing finished is lost,
every file is absent or complete, every fault ends in one line."""
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import paper_tables

SWEEP = paper_tables() + """
[study]
methods = ["montecarlo"]
quantities = ["moments"]
[montecarlo]
n_paths = 512
t_sample = {t_sample}
threads = 1
seed = 3
[sweep]
r = [{r}]
"""


def scene(tmp_path, t_sample=3000.0, r=(0.5, 0.6, 0.7, 0.8, 0.9, 0.95), name="sweep.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(SWEEP.format(t_sample=t_sample,
                                              r=", ".join(str(v) for v in r))))
    return p


def start(args, **kw):
    return subprocess.Popen([sys.executable, "-m", "fpk_vibro", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def wait_for(cond, timeout=120.0):
    t0 = time.time()
    while not cond():
        if time.time() - t0 > timeout:
            raise AssertionError("timed out")
        time.sleep(0.05)


def children(pid):
    out = set()
    for task in Path(f"/proc/{pid}/task").iterdir():
        out.update(int(c) for c in (task / "children").read_text().split())
    return out


def alive(pid):
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)],
                         ids=["SIGINT", "SIGTERM"])
def test_signal_in_a_process_sweep_loses_nothing_and_resume_completes(tmp_path, sig, code):
    path, out = scene(tmp_path), tmp_path / "out"
    proc = start(["run", str(path), "--out", str(out), "--workers", "2"])
    wait_for(lambda: list((out / "points").glob("p*.json")))
    workers = children(proc.pid)
    assert workers
    t0 = time.time()
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=30)
    stopped = time.time() - t0
    assert proc.returncode == code, err
    assert "partial" in err and "--resume" in err and "Traceback" not in err
    doc = json.loads((out / "results.json").read_text())
    assert doc["status"] == "interrupted" and doc["signal"] == signal.Signals(sig).name
    status = [p["status"] for p in doc["points"]]
    assert len(status) == 6 and "interrupted" in status
    on_disk = {json.loads(f.read_text())["index"] for f in (out / "points").glob("p*.json")}
    # finished points, and those the signal stopped with what they had (issue 30)
    assert on_disk == {p["index"] for p in doc["points"] if p.get("methods")}
    assert all(p["methods"]["montecarlo"]["moments"]["E_H"] > 0
               for p in doc["points"] if p.get("methods"))
    assert not [w for w in workers if alive(w)]
    assert stopped < 10.0
    r = start(["run", str(path), "--out", str(out), "--workers", "2", "--resume", "--quiet"])
    _, err = r.communicate(timeout=300)
    assert r.returncode == 0, err
    doc2 = json.loads((out / "results.json").read_text())
    assert doc2["status"] == "complete" and all(p["status"] == "done" for p in doc2["points"])
    for p in doc["points"]:            # finished points were kept, not recomputed
        if p["status"] == "done":
            assert doc2["points"][p["index"]] == p


def start_on_a_terminal(args):
    """``fpk-vibro args`` with stderr on a pseudo-terminal (120 columns), so that it
    shows its progress line there as to a user; returns (process, the text written
    to the terminal so far (a list, read by a thread), the thread, the terminal)."""
    import fcntl
    import pty
    import struct
    import termios
    import threading
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "fpk_vibro", *args], stdout=subprocess.PIPE,
                            stderr=slave, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    os.close(slave)
    text: list[str] = []

    def drain():                       # the terminal's buffer must never fill
        while True:
            try:
                data = os.read(master, 4096)
            except OSError:            # EIO: the process closed the terminal
                return
            if not data:
                return
            text.append(data.decode("utf-8", "replace"))
    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    return proc, text, reader, master


def test_signal_on_a_single_monte_carlo_point_keeps_the_partial_result(tmp_path):
    path, out = scene(tmp_path, t_sample=1e5, r=(0.9,)), tmp_path / "out"
    proc, text, reader, master = start_on_a_terminal(["run", str(path), "--out", str(out)])
    try:
        # the sign: the progress line says "sampling" once the first chunk of samples
        # is in (the signal handler is installed before any work; compiling on a cold
        # cache and the burn-in come before it, however long they take)
        wait_for(lambda: proc.poll() is not None or "sampling" in "".join(text), 600.0)
        assert proc.poll() is None, "".join(text)
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=30)
        reader.join(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(master)
    err = "".join(text)
    assert proc.returncode == 130, err
    assert "partial" in err and "--resume" in err and "Traceback" not in err, err
    doc = json.loads((out / "results.json").read_text())
    point = doc["points"][0]
    assert point["status"] == "interrupted"
    mc = point["methods"]["montecarlo"]
    assert mc["partial"] is True and mc["moments"]["E_H"] > 0


WRITER = """
import sys, numpy as np
from pathlib import Path
from fpk_vibro.io import atomic_json, atomic_savez
from fpk_vibro import VibroImpactSystem, fem
from fpk_vibro.app import plotting
out = Path(sys.argv[1])
sol = fem.stationary(VibroImpactSystem.paper(r=0.9), nx=8, ny=16)
big = np.random.default_rng(0).random(400_000)
print("ready", flush=True)
i = 0
while True:
    i += 1
    atomic_json(out / "doc.json", {"i": i, "data": list(range(20000))})
    atomic_savez(out / "arrays.npz", {"a": big * i})
    plotting.plot_energy_pdfs([("fem", sol)], out / "fig.png", title=str(i))
    sol.save_vtu(out / "field.vtu")
    sol.save_vtu(out / "field.xdmf")
"""


def complete(out):
    if (out / "doc.json").exists():
        assert len(json.loads((out / "doc.json").read_text())["data"]) == 20000
    if (out / "arrays.npz").exists():
        with np.load(out / "arrays.npz") as d:
            assert d["a"].size == 400_000
    if (out / "fig.png").exists():
        data = (out / "fig.png").read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[-8:-4] == b"IEND"
    if (out / "field.vtu").exists():
        import meshio
        assert meshio.read(out / "field.vtu").point_data["p"].size > 0
    if (out / "field.xdmf").exists():
        import meshio
        assert meshio.read(out / "field.xdmf").point_data["p"].size > 0


def test_kill_9_during_writes_leaves_every_file_absent_or_complete(tmp_path):
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    rng = np.random.default_rng(1)
    for k in range(10):
        out = tmp_path / f"w{k}"
        out.mkdir()
        proc = subprocess.Popen([sys.executable, str(script), str(out)], stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True)
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(float(rng.uniform(0.05, 1.5)))
        proc.kill()
        proc.wait()
        complete(out)
        for f in out.iterdir():          # the user's umask, not 0600
            if not f.name.startswith("."):
                assert f.stat().st_mode & 0o777 == 0o666 & ~_umask(), f


def _umask():
    m = os.umask(0)
    os.umask(m)
    return m


@pytest.fixture
def tiny_fs(tmp_path):
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here (test_full_disk_injected covers it)")
    yield mnt
    subprocess.run(["umount", str(mnt)], capture_output=True)


AVG = paper_tables(D2=None) + """
[study]
methods = ["averaging"]
quantities = ["energy", "x", "y", "joint", "moments"]
[output]
formats = ["json", "npz", "png"]
"""


def test_a_full_disk_ends_in_one_line_and_leaves_complete_files(tmp_path, tiny_fs):
    path = tmp_path / "s.toml"
    path.write_text(AVG)
    r = subprocess.run([sys.executable, "-m", "fpk_vibro", "run", str(path), "--out",
                        str(tiny_fs / "o"), "--quiet"], capture_output=True, text=True)
    assert r.returncode in (1, 2), r.stderr
    assert "Traceback" not in r.stderr and "No space left" in r.stderr
    for f in (tiny_fs / "o").rglob("*.json"):
        json.loads(f.read_text())


def test_full_disk_injected(tmp_path, monkeypatch, capsys):
    import errno
    from fpk_vibro import io
    from fpk_vibro.app import cli

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    path = tmp_path / "s.toml"
    path.write_text(AVG)
    monkeypatch.setattr(io.os, "fsync", full)
    assert cli.main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]) in (1, 2)
    err = capsys.readouterr().err
    assert "No space left" in err and err.count("\n") <= 2
    assert not [f for f in (tmp_path / "o").rglob("*") if f.is_file()
                and not f.name.startswith(".")]


def test_read_only_output_directory(tmp_path):
    mnt = tmp_path / "ro"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(mnt)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a read-only tmpfs here")
    try:
        path = tmp_path / "s.toml"
        path.write_text(AVG)
        r = subprocess.run([sys.executable, "-m", "fpk_vibro", "run", str(path), "--out",
                            str(mnt / "o")], capture_output=True, text=True)
        assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
        assert "--out" in r.stderr and "Read-only" in r.stderr
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)


def test_two_runs_into_one_directory_never_mix(tmp_path):
    # long enough (~3 s a point) that the second command starts while the first runs
    first = scene(tmp_path, t_sample=12000.0, r=(0.5, 0.6, 0.7), name="a.toml")
    second = scene(tmp_path, t_sample=100.0, r=(0.9,), name="b.toml")
    out = tmp_path / "out"
    a = start(["run", str(first), "--out", str(out), "--workers", "1", "--quiet"])
    wait_for(lambda: (out / ".fpk-vibro.lock").exists())
    b = subprocess.run([sys.executable, "-m", "fpk_vibro", "run", str(second), "--out",
                        str(out)], capture_output=True, text=True)
    assert b.returncode == 2 and b.stderr.count("\n") == 1 and "in use" in b.stderr
    _, err = a.communicate(timeout=300)
    assert a.returncode == 0, err
    doc = json.loads((out / "results.json").read_text())
    assert doc["name"] == "a" and [p["parameters"]["r"] for p in doc["points"]] == [0.5, 0.6, 0.7]
    assert not (out / ".fpk-vibro.lock").exists()


def test_study_name_cannot_leave_the_results_area(tmp_path):
    from fpk_vibro.app.scenes import parse_scene
    data = {"system": dict(a=1, b=0.2, c=0.025, D1=0.01), "barriers": dict(delta=0.6),
            "study": dict(methods=["averaging"], name="../../x")}
    assert parse_scene(data).output_dir == Path("results") / "x"
    data["study"]["name"] = "/etc/passwd"
    assert parse_scene(data).output_dir == Path("results") / "etc_passwd"


def test_output_directory_that_is_a_file(tmp_path, capsys):
    from fpk_vibro.app import cli
    path = tmp_path / "s.toml"
    path.write_text(AVG)
    (tmp_path / "afile").write_text("x")
    assert cli.main(["run", str(path), "--out", str(tmp_path / "afile")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a directory" in err


def test_results_json_is_strict_and_readable_by_colleagues(tmp_path):
    from fpk_vibro.app import cli
    text = AVG.replace('methods = ["averaging"]', 'methods = ["averaging"]\ntimes = [0.0, 1.0]')
    text += "\n[initial]\nmean = [0.0, 1.0]\nstd = [0.05, 0.05]\n"
    path = tmp_path / "s.toml"
    path.write_text(text)
    assert cli.main(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    raw = (tmp_path / "o" / "results.json").read_text()
    json.loads(raw, parse_constant=lambda c: pytest.fail(f"non-strict JSON constant {c}"))
    for f in (tmp_path / "o").rglob("*"):
        if f.is_file():
            assert f.stat().st_mode & 0o044 == 0o044 & ~_umask(), f


def test_a_task_of_a_stopped_run_writes_nothing(tmp_path):
    """A Dask task cannot be killed: when it ends after its run stopped, it must not
    write into the directory (another run may own it by then)."""
    from fpk_vibro.app.outdir import OutputDir
    from fpk_vibro.app.runner import _point_job
    from fpk_vibro.app.scenes import load_scene
    path = tmp_path / "s.toml"
    path.write_text(AVG)
    sc = load_scene(path)
    params, system = sc.points()[0]
    out = tmp_path / "o"
    with OutputDir(out) as lock:
        rec = _point_job((sc, 0, params, system, out, False, "stale-token"))
        assert rec["status"] == "failed" and "stopped" in rec["error"]
        assert not [f for f in out.rglob("*") if f.is_file() and f.name != ".fpk-vibro.lock"]
        rec = _point_job((sc, 0, params, system, out, False, lock.token))
        assert rec["status"] == "done" and (out / "points" / "p0.json").exists()
