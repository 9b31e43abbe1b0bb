import subprocess
import sys

import numpy as np
import pytest

from fpk_vibro import Solution
from fpk_vibro.app import cli
from conftest import paper_tables


def test_paper_job_writes_figure_and_solutions(tmp_path, capsys):
    assert cli.main(["paper", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "r=0.98" in out and "r=0.92" in out and "E_H=" in out
    png = tmp_path / "fig3_pdf_energy.png"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    sol = Solution.load(tmp_path / "averaging_r0.92.npz")
    assert abs(sol.moments()["E_H"] - float(out.split("r=0.92")[1].split("E_H=")[1].split()[0])) < 1e-5


def test_module_entry_point_reports_bad_input(tmp_path):
    r = subprocess.run([sys.executable, "-m", "fpk_vibro", "bench", "averaging", "--repeat", "0"],
                       capture_output=True, text=True)
    assert r.returncode != 0 and "--repeat" in r.stderr


def test_check_error_on_a_bad_scene_is_one_line_ending_in_a_newline(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text(paper_tables(r=2.0) + '\n[study]\nmethods = ["averaging"]\n')
    r = subprocess.run([sys.executable, "-m", "fpk_vibro", "check", str(scene)],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "barriers.r" in r.stderr
    assert r.stderr.endswith("\n") and r.stderr.count("\n") == 1, repr(r.stderr)


@pytest.mark.parametrize("raised,status,word", [
    (ValueError("a rule\nover two lines"), 2, "a rule over two lines"),
    (OSError("a device\nsays so"), 2, "a device says so"),
    (FileNotFoundError(2, "No such file\nor directory", "x.toml"), 2, "'x.toml': No such"),
    (KeyboardInterrupt(), 130, "interrupted"),
])
def test_every_error_of_the_command_is_one_line_ending_in_a_newline(monkeypatch, capsys,
                                                                       raised, status, word):
    """Each way ``main`` reports a failure: one line on stderr, ending in a newline
    (an OSError's text over two lines was printed as two)."""
    def fail(args):
        raise raised
    monkeypatch.setattr(cli, "cmd_keys", fail)
    assert cli.main(["keys"]) == status
    err = capsys.readouterr().err
    assert err.endswith("\n") and err.count("\n") == 1 and word in err, repr(err)


def test_an_argument_error_is_one_line_ending_in_a_newline(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["run", "scene.toml", "--workers", "0"])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.endswith("\n") and err.count("\n") == 1, repr(err)


def test_an_interrupted_run_says_so_in_one_line(monkeypatch, tmp_path, capsys):
    from fpk_vibro.app import runner
    scene = tmp_path / "s.toml"
    scene.write_text(paper_tables() + '\n[study]\nmethods = ["averaging"]\n')

    def interrupted(scene, **kw):
        return {"status": "interrupted", "signal": "SIGTERM",
                "points": [{"parameters": {}, "status": "done", "methods": {}}]}
    monkeypatch.setattr(runner, "run_scene", interrupted)
    assert cli.main(["run", str(scene), "--quiet", "--out", str(tmp_path / "o")]) == 143
    err = capsys.readouterr().err
    assert err.endswith("\n") and err.count("\n") == 1 and "--resume" in err, repr(err)
