import subprocess
import sys

import numpy as np

from fpk_vibro import Solution, cli


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
