"""Faults of the execution of a sweep: worker processes that die or outlive the run,
more workers than points, signals while workers start; Dask schedulers that are
unreachable, silent, not Dask, or lost mid-sweep, and Dask workers in another
working directory.  Real processes and signals; every wait is for a sign (a line,
a file, a process state) and bounded; every fault ends in one line and loses
nothing finished."""
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from test_faults import alive, children, scene, start, wait_for

CLK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().split(")")[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / CLK


def holds_lock(pid, out):
    """True if process ``pid`` has the output directory's lock file open."""
    lock = str(out / ".fpk-vibro.lock")
    try:
        fds = list(Path(f"/proc/{pid}/fd").iterdir())
    except OSError:
        return False
    for fd in fds:
        try:
            if os.readlink(fd).startswith(lock):
                return True
        except OSError:
            pass
    return False


def marked(mark):
    """Pids of the live processes whose environment carries ``FPK_TEST_MARK=mark``:
    a run started by the test and every process it started, orphans included."""
    tag, out = f"FPK_TEST_MARK={mark}".encode(), []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if tag in (d / "environ").read_bytes().split(b"\0") and alive(int(d.name)):
                    out.append(int(d.name))
            except OSError:
                pass
    return out


def run(args, mark, **kw):
    return start(args, env={**os.environ, "FPK_TEST_MARK": mark}, **kw)


def end(pids):
    """Kill what a test started (by pid) if it is still there."""
    for pid in pids:
        if alive(pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass


def point_files(out):
    return sorted((out / "points").glob("p*.json"))


def test_a_killed_worker_fails_its_point_and_the_others_go_on(tmp_path):
    """kill -9 of a worker (what the OOM killer does): its point fails with the
    reason, the others finish, --resume computes the failed one."""
    path, out = scene(tmp_path, t_sample=40000.0, r=(0.5, 0.7, 0.9)), tmp_path / "out"
    proc = run(["run", str(path), "--out", str(out), "--workers", "2"], "killed-worker")
    seen = set()
    try:
        def computing():
            seen.update(children(proc.pid))
            return [w for w in children(proc.pid) if cpu_seconds(w) > 0.5]
        wait_for(lambda: computing() or proc.poll() is not None, timeout=60)
        victim = computing()[0]
        os.kill(victim, signal.SIGKILL)
        _, err = proc.communicate(timeout=90)
    finally:
        end([proc.pid, *seen, *marked("killed-worker")])
    assert proc.returncode == 1, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert "FAILED" in err and "worker process died" in err and "SIGKILL" in err
    doc = json.loads((out / "results.json").read_text())
    assert doc["status"] == "complete"
    failed = [p for p in doc["points"] if p["status"] == "failed"]
    assert len(failed) == 1 and "SIGKILL" in failed[0]["error"]
    assert sum(p["status"] == "done" for p in doc["points"]) == 2
    assert not (out / "points" / f"p{failed[0]['index']}.json").exists()   # resume redoes it
    r = start(["run", str(path), "--out", str(out), "--workers", "2", "--resume", "--quiet"])
    _, err = r.communicate(timeout=120)
    assert r.returncode == 0, err
    doc2 = json.loads((out / "results.json").read_text())
    assert all(p["status"] == "done" for p in doc2["points"])
    for p in doc["points"]:
        if p["status"] == "done":
            assert doc2["points"][p["index"]] == p


@pytest.mark.parametrize("how", ["ctrl-c while starting", "ctrl-c while computing",
                                 "SIGTERM while starting"])
def test_never_more_workers_than_points_and_a_signal_ends_them_all(tmp_path, how):
    """--workers 32 on a 2-point sweep: 2 worker processes.  Ctrl-C at the terminal
    (SIGINT to the whole process group) or SIGTERM to the run ends every one of
    them, with one line and no traceback."""
    path, out = scene(tmp_path, t_sample=200000.0, r=(0.5, 0.9)), tmp_path / "out"
    mark = "signal-" + how.replace(" ", "-")
    proc = run(["run", str(path), "--out", str(out), "--workers", "32"], mark,
               start_new_session=True)            # its own process group, as in a terminal
    seen, most = set(), [0]
    try:
        def sign():
            kids = children(proc.pid)
            seen.update(kids)
            most[0] = max(most[0], len(kids))
            if "starting" in how:
                return kids
            return [w for w in kids if cpu_seconds(w) > 0.5]
        wait_for(lambda: sign() or proc.poll() is not None, timeout=60)
        if how.startswith("ctrl-c"):
            os.killpg(proc.pid, signal.SIGINT)
        else:
            proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
        left = marked(mark)               # orphans too: nothing the run started is left
    finally:
        end([proc.pid, *seen, *marked(mark)])
    assert most[0] <= 2, f"{most[0]} worker processes for 2 points"
    assert proc.returncode in (130, 143), err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert not left and not [w for w in seen if alive(w)]
    doc = json.loads((out / "results.json").read_text())
    assert doc["status"] == "interrupted"


def test_workers_hold_no_lock_and_die_with_the_run(tmp_path):
    """kill -9 of the run: its workers die too, and the directory is free at once."""
    path, out = scene(tmp_path, t_sample=400000.0, r=(0.5, 0.9)), tmp_path / "out"
    proc = run(["run", str(path), "--out", str(out), "--workers", "2"], "kill-9-run")
    seen = set()
    try:
        def both():
            kids = children(proc.pid)
            seen.update(kids)
            return len(kids) == 2 and all(cpu_seconds(w) > 0.3 for w in kids)
        wait_for(lambda: both() or proc.poll() is not None, timeout=60)
        assert proc.poll() is None
        assert holds_lock(proc.pid, out)
        assert not [w for w in seen if holds_lock(w, out)], "a worker holds the lock"
        proc.kill()
        proc.wait()
        wait_for(lambda: not marked("kill-9-run"), timeout=10)
        quick = scene(tmp_path, t_sample=100.0, r=(0.9,), name="quick.toml")
        r = subprocess.run([sys.executable, "-m", "fpk_vibro", "run", str(quick), "--out",
                            str(out), "--quiet"], capture_output=True, text=True, timeout=120)
    finally:
        end([proc.pid, *seen, *marked("kill-9-run")])
    assert r.returncode == 0 and "in use" not in r.stderr, r.stderr


def test_the_lock_is_not_inherited_by_a_fork(tmp_path):
    """Code that forks while a run holds its directory (a library user, a plugin)
    leaves the lock with the run: the child drops it."""
    from fpk_vibro.app.outdir import OutputDir
    out = tmp_path / "o"
    with OutputDir(out):
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:                      # the child: does it still hold the lock?
            os.close(r)
            held = holds_lock(os.getpid(), out)
            os.write(w, b"1" if held else b"0")
            os._exit(0)
        os.close(w)
        answer = os.read(r, 1)
        os.close(r)
        os.waitpid(pid, 0)
        assert answer == b"0"
        assert holds_lock(os.getpid(), out)


# ---------------------------------------------------------------------------- Dask

pytest.importorskip("distributed")

TIMEOUT_ENV = "DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT"


def dask_cli(*args, cwd, log):
    f = open(log, "w")
    return subprocess.Popen(["dask", *args], cwd=cwd, stdout=f, stderr=subprocess.STDOUT,
                            text=True)


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and a worker as separate processes, working in another directory."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    sfile = elsewhere / "scheduler.json"
    sched = dask_cli("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(sfile), cwd=elsewhere, log=tmp_path / "s.log")
    procs = [sched]
    try:
        wait_for(lambda: "Scheduler at:" in (tmp_path / "s.log").read_text()
                 or sched.poll() is not None, timeout=60)
        address = json.loads(sfile.read_text())["address"]
        worker = dask_cli("worker", address, "--nthreads", "1", "--no-nanny",
                          "--no-dashboard", cwd=elsewhere, log=tmp_path / "w.log")
        procs.append(worker)
        wait_for(lambda: "Registered to:" in (tmp_path / "w.log").read_text()
                 or worker.poll() is not None, timeout=60)
        assert sched.poll() is None and worker.poll() is None
        yield address, sched, elsewhere
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_dask_workers_elsewhere_and_a_relative_output_directory(tmp_path, cluster):
    """The default results/<name> (relative to the run's directory): every point done
    by workers whose working directory is another one."""
    address, _, elsewhere = cluster
    here = tmp_path / "here"
    here.mkdir()
    scene(here, t_sample=300.0, r=(0.5, 0.7, 0.9))
    r = start(["run", "sweep.toml", "--scheduler", address, "--quiet"], cwd=here)
    _, err = r.communicate(timeout=120)
    assert r.returncode == 0, err
    doc = json.loads((here / "results" / "sweep" / "results.json").read_text())
    assert doc["status"] == "complete"
    assert [p["status"] for p in doc["points"]] == ["done"] * 3
    assert not (elsewhere / "results").exists()


def test_a_lost_scheduler_keeps_what_finished_and_resume_completes(tmp_path, cluster):
    address, sched, _ = cluster
    (tmp_path / "s").mkdir()
    path = scene(tmp_path / "s", t_sample=30000.0, r=(0.5, 0.6, 0.7, 0.8))
    text = path.read_text() + '\n[output]\ndirectory = "out"\n'   # relative to the scene
    path.write_text(text)
    out = tmp_path / "s" / "out"
    proc = start(["run", str(path), "--scheduler", address])
    try:
        wait_for(lambda: point_files(out) or proc.poll() is not None, timeout=90)
        sched.kill()
        _, err = proc.communicate(timeout=60)
    finally:
        end([proc.pid])
    assert proc.returncode == 1, err
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert address in err and "lost" in err and "--resume" in err
    doc = json.loads((out / "results.json").read_text())
    status = [p["status"] for p in doc["points"]]
    assert "done" in status and "failed" in status and set(status) <= {"done", "failed"}
    on_disk = {json.loads(f.read_text())["index"] for f in point_files(out)}
    assert {p["index"] for p in doc["points"] if p["status"] == "done"} <= on_disk
    r = start(["run", str(path), "--resume", "--workers", "1", "--quiet"])
    _, err = r.communicate(timeout=120)
    assert r.returncode == 0, err
    doc2 = json.loads((out / "results.json").read_text())
    assert all(p["status"] == "done" for p in doc2["points"])
    for p in doc["points"]:
        if p["status"] == "done":
            assert doc2["points"][p["index"]] == p


class Server:
    """A TCP service on 127.0.0.1 that is not a Dask scheduler."""

    def __init__(self, behaviour):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.address = "tcp://127.0.0.1:%d" % self.sock.getsockname()[1]
        self.behaviour, self.conns = behaviour, []
        threading.Thread(target=self.serve, daemon=True).start()

    def serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            try:
                if self.behaviour == "garbage":
                    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
                elif self.behaviour == "http":      # answers once spoken to
                    conn.settimeout(60)
                    if conn.recv(65536):
                        conn.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n")
            except OSError:
                pass

    def close(self):
        self.sock.close()
        for c in self.conns:
            c.close()


def refused_address():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return f"tcp://127.0.0.1:{port}"


@pytest.mark.parametrize("kind, bound, words", [
    ("refused", 10.0, "refused"),
    ("silent", 30.0, "no Dask scheduler answered"),
    ("garbage", 10.0, "not a Dask scheduler"),
    ("http", 15.0, "no Dask scheduler answered"),
])
def test_a_scheduler_address_that_is_not_a_scheduler_is_one_line(tmp_path, kind, bound, words):
    """Refused, accepting but silent, answering garbage, or an HTTP-like service:
    one line naming the address and what happened, within 30 s, nothing removed."""
    server = None if kind == "refused" else Server(kind)
    address = refused_address() if server is None else server.address
    path, out = scene(tmp_path, t_sample=100.0, r=(0.5, 0.9)), tmp_path / "out"
    (out / "points").mkdir(parents=True)
    (out / "points" / "p0.json").write_text("{}")       # an earlier run's: kept
    env = {**os.environ, TIMEOUT_ENV: "3s"} if kind == "http" else None
    t0 = time.time()
    proc = start(["run", str(path), "--out", str(out), "--scheduler", address], env=env)
    try:
        _, err = proc.communicate(timeout=45)
    finally:
        end([proc.pid])
        if server is not None:
            server.close()
    took = time.time() - t0
    assert proc.returncode == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert address in err and words in err, err
    assert took < bound, took
    assert (out / "points" / "p0.json").exists()
