"""Faults during the error estimates (issue 30): a signal in Monte Carlo's second run
(the time-step bias run at 2 dt) keeps every answer finished so far, in process, with
worker processes and on Dask, and the messages count what was kept; a damaged point
record is computed again by ``--resume``, never adopted.  Real processes and
signals; every wait is for a sign (the bias run's progress line) and bounded."""
import json
import os
import re
import signal
import subprocess
import textwrap

import pytest

from conftest import paper_tables
from test_faults import alive, children, start_on_a_terminal, wait_for

#: The issue's sweep (n_paths = 20000; t_sample 2500 rather than 300 s, so that the bias
#: run lasts a few seconds and the signal, sent once its progress line is seen, lands
#: in it).
SWEEP = paper_tables() + """
[study]
methods = ["montecarlo"]
quantities = ["moments"]
[montecarlo]
n_paths = 20000
t_sample = 2500.0
threads = 1
seed = 3
[sweep]
r = [0.5, 0.7, 0.9]
[output]
formats = ["json"]
"""

#: A Monte Carlo transient at two times whose second run lasts a few seconds.
TRANSIENT = paper_tables() + """
[study]
methods = ["montecarlo"]
quantities = ["moments"]
times = [250.0, 500.0]
[initial]
mean = [0.0, 1.0]
std = [0.0, 0.05]
[montecarlo]
n_paths = 100000
threads = 1
seed = 1
[output]
formats = ["json"]
"""

#: The sign: the progress line of Monte Carlo's second run (a bar in this process,
#: sampling; a plain line from a worker).  Every stage shows its progress as it starts
#: (FPK_VIBRO_PROGRESS_DELAY = 0, below): with the default two seconds a worker's line
#: was missed under load when the bias run took less.  A transient's second run has
#: no burn-in: its bar is the sign.
SIGN = re.compile(r"bias run at 2 dt( \.\.\.|:[^\r\x1b]*sampling)")
TRANSIENT_SIGN = re.compile("bias run at 2 dt")


@pytest.fixture(autouse=True)
def progress_at_once(monkeypatch):
    """Progress shown as each stage starts, in the run and in the Dask worker alike
    (their environment is this one)."""
    monkeypatch.setenv("FPK_VIBRO_PROGRESS_DELAY", "0")


def _signal_at_the_sign(args, sig, sign_in=None, sign=SIGN):
    """``fpk-vibro args`` with stderr on a terminal; ``sig`` sent to the run once
    ``sign`` is on that terminal (or in the file ``sign_in``).  Returns (exit
    status, the terminal's text, every worker process seen)."""
    proc, text, reader, master = start_on_a_terminal(args)
    seen = set()
    try:
        def signed():
            seen.update(children(proc.pid))
            where = "".join(text) if sign_in is None else (
                sign_in.read_text() if sign_in.exists() else "")
            return proc.poll() is not None or sign.search(where)
        wait_for(signed, 300.0)
        assert proc.poll() is None, "".join(text)[-1500:]
        proc.send_signal(sig)
        proc.communicate(timeout=60)
        reader.join(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(master)
    return proc.returncode, "".join(text), seen


def _kept(out):
    """results.json's points with their answers, checked against points/."""
    doc = json.loads((out / "results.json").read_text())
    assert doc["status"] == "interrupted"
    kept = [p for p in doc["points"] if p.get("methods")]
    on_disk = {json.loads(f.read_text())["index"]: json.loads(f.read_text())
               for f in (out / "points").glob("p*.json")}
    assert on_disk == {p["index"]: p for p in kept}
    return doc, kept


def _stopped_in_the_estimate(kept):
    """The points a signal stopped in their estimate: every answer, no estimate."""
    stopped = [p for p in kept
               if p["methods"]["montecarlo"].get("error_estimate") == {
                   "not_computed": "interrupted"}]
    for p in stopped:
        mc = p["methods"]["montecarlo"]
        assert p["status"] == "interrupted" and not mc.get("partial")
        assert mc["moments"]["E_H"] > 0 and mc["moments_se"]["E_H"] > 0
    return stopped


@pytest.mark.parametrize("workers, sig, code", [
    (1, signal.SIGINT, 130), (2, signal.SIGINT, 130), (2, signal.SIGTERM, 143)],
    ids=["workers-1-SIGINT", "workers-2-SIGINT", "workers-2-SIGTERM"])
def test_a_signal_in_the_bias_run_keeps_the_answers(tmp_path, workers, sig, code):
    """Ctrl-C or kill -TERM of the run once a point's second run has started: that
    point is written with its answer, its estimate 'not_computed: interrupted'; a
    point not started is not computed; no worker is left."""
    path, out = tmp_path / "s.toml", tmp_path / "out"
    path.write_text(textwrap.dedent(SWEEP))
    rc, err, seen = _signal_at_the_sign(
        ["run", str(path), "--out", str(out), "--workers", str(workers)], sig)
    assert rc == code, err[-1500:]
    assert "Traceback" not in err, err[-1500:]
    doc, kept = _kept(out)
    assert _stopped_in_the_estimate(kept), doc["points"]
    assert [p for p in doc["points"] if not p.get("methods")], doc["points"]  # not started
    assert not [w for w in seen if alive(w)]
    assert f"{len(kept)} of 3 point(s) kept" in err, err[-1500:]


@pytest.fixture
def dask_cluster(tmp_path):
    """A Dask scheduler and one single-threaded worker, separate processes (as in
    tests/test_execution_faults.py); yields (address, the worker's log)."""
    pytest.importorskip("distributed")
    logs = {n: tmp_path / f"{n}.log" for n in ("s", "w")}
    sfile = tmp_path / "scheduler.json"
    procs = []

    def dask(*args, log):
        procs.append(subprocess.Popen(["dask", *args], cwd=tmp_path, stdout=open(log, "w"),
                                      stderr=subprocess.STDOUT))
        return procs[-1]
    try:
        sched = dask("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(sfile), log=logs["s"])
        wait_for(lambda: "Scheduler at:" in logs["s"].read_text() or sched.poll() is not None,
                 timeout=60)
        address = json.loads(sfile.read_text())["address"]
        worker = dask("worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                      log=logs["w"])
        wait_for(lambda: "Registered to:" in logs["w"].read_text() or worker.poll() is not None,
                 timeout=60)
        assert sched.poll() is None and worker.poll() is None
        yield address, logs["w"]
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


def test_a_signal_in_the_bias_run_on_dask_keeps_the_answer(tmp_path, dask_cluster):
    """The same on Dask: the task in its second run is stopped and writes its point
    before the run ends (a Dask task cannot be killed: it is interrupted)."""
    address, worker_log = dask_cluster
    path, out = tmp_path / "s.toml", tmp_path / "out"
    path.write_text(textwrap.dedent(SWEEP))
    rc, err, _ = _signal_at_the_sign(
        ["run", str(path), "--out", str(out), "--scheduler", address], signal.SIGINT,
        sign_in=worker_log)
    assert rc == 130, err[-1500:]
    assert "Traceback" not in err, err[-1500:]
    doc, kept = _kept(out)
    assert _stopped_in_the_estimate(kept), doc["points"]
    assert "Traceback" not in worker_log.read_text()


def test_the_messages_after_a_signal_in_a_transients_bias_run_count_what_was_kept(tmp_path):
    """Ctrl-C in a Monte Carlo transient's second run: both times are kept, and the
    two messages say so (not 'returning 0 of 2 times', not '0 of 1 point(s)')."""
    path, out = tmp_path / "t.toml", tmp_path / "out"
    path.write_text(textwrap.dedent(TRANSIENT))
    rc, err, _ = _signal_at_the_sign(["run", str(path), "--out", str(out)], signal.SIGINT,
                                     sign=TRANSIENT_SIGN)
    assert rc == 130, err[-1500:]
    assert "Traceback" not in err and "returning 0 of" not in err, err[-1500:]
    assert "all 2 times" in err, err[-1500:]
    assert "1 of 1 point(s) kept" in err and "0 finished" in err, err[-1500:]
    point = json.loads((out / "results.json").read_text())["points"][0]
    assert point["status"] == "interrupted"
    at = point["methods"]["montecarlo"]["at"]
    assert len(at) == 2
    assert all(a["error_estimate"] == {"not_computed": "interrupted"} for a in at)


AVG = paper_tables(D2=None) + """
[study]
methods = ["averaging"]
quantities = ["energy", "moments"]
[output]
formats = ["json", "npz", "png"]
[sweep]
r = [0.5, 0.7]
"""


@pytest.mark.parametrize("damage", ["no methods", "no method entry", "moments edited"])
def test_resume_recomputes_a_damaged_point_record(tmp_path, damage):
    """A point record whose content was changed after it was written (here: status
    "done" without "methods" or with none of its methods, an edited moment) is
    computed again, and the one resume line says why; the run ends cleanly."""
    import contextlib
    import io

    from fpk_vibro.app import cli

    path, out = tmp_path / "s.toml", tmp_path / "out"
    path.write_text(textwrap.dedent(AVG))

    def run(*args):
        o, e = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
            code = cli.main(["run", str(path), "--out", str(out), *args])
        return code, o.getvalue(), e.getvalue()
    assert run("--quiet")[0] == 0
    first = json.loads((out / "results.json").read_text())["points"]
    rec_path = out / "points" / "p1.json"
    rec = json.loads(rec_path.read_text())
    if damage == "no methods":
        del rec["methods"]
    elif damage == "no method entry":
        rec["methods"] = {}
    else:
        rec["methods"]["averaging"]["moments"]["E_H"] *= 2.0
    rec_path.write_text(json.dumps(rec))
    code, stdout, err = run("--resume")
    assert code == 0, err[-1500:]
    line = [s.strip() for s in stdout.splitlines() if "resuming:" in s]
    assert line == ["resuming: 1 of 2 point(s) reused, 1 recomputed "
                    "(1 record changed after it was written)"], stdout
    doc = json.loads((out / "results.json").read_text())
    assert doc["status"] == "complete" and doc["points"][0] == first[0]
    again = doc["points"][1]
    assert again["status"] == "done"
    assert again["methods"]["averaging"]["moments"] == first[1]["methods"]["averaging"]["moments"]
    assert json.loads(rec_path.read_text()) == again
