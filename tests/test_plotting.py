"""Figures: nothing switches the matplotlib backend; public functions draw into an
``ax`` and return it; scene figures have the log and difference panels."""
import subprocess
import sys

import numpy as np

from fpk_vibro import VibroImpactSystem, averaging, fem
from fpk_vibro.app import plotting


def test_import_and_plot_leave_the_backend_alone():
    code = ("import matplotlib; matplotlib.use('svg'); "
            "from fpk_vibro import VibroImpactSystem, averaging, plotting; "
            "import numpy as np; s = VibroImpactSystem.paper(r=0.92); "
            "plotting.plot_density({'averaging': averaging.stationary(s)}, 'x', np.linspace(-0.6, 0.6, 50)); "
            "print(matplotlib.get_backend())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "svg"


def test_plot_density_draws_into_the_given_ax():
    from matplotlib.figure import Figure
    s = VibroImpactSystem.paper(r=0.92)
    sols = {"averaging": averaging.stationary(s), "fem": fem.stationary(s, nx=24)}
    fig = Figure()
    ax = fig.subplots()
    g = np.linspace(0.0, 1.0, 100)
    assert plotting.plot_density(sols, "energy", g, ax=ax, log=True) is ax
    assert ax.get_yscale() == "log"
    labels = [line.get_label() for line in ax.get_lines()]
    assert "stochastic averaging" in labels and "finite elements" in labels
    ax2 = plotting.plot_density(sols, "x", np.linspace(-0.6, 0.6, 50), difference_from="fem")
    assert "difference" in ax2.get_ylabel()
    axes, cs = plotting.plot_joint(sols, np.linspace(-0.6, 0.6, 30), np.linspace(-1, 1, 30))
    assert cs.levels[0] == 0.0 and len(axes) == 2


def test_two_parameter_sweep_is_faceted(tmp_path):
    from fpk_vibro.app import cli
    scene = tmp_path / "s.toml"
    scene.write_text("[system]\na = 1.0\nb = 0.2\nc = 0.025\nD1 = 0.01\n[barriers]\n"
                     "delta = 0.6\nr = 0.9\n[study]\nmethods = [\"averaging\"]\n"
                     "quantities = [\"energy\", \"moments\"]\n[sweep]\nr = [0.8, 0.9]\n"
                     "c = [0.025, 0.05, 0.1]\n")
    assert cli.main(["run", str(scene), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    assert (tmp_path / "o" / "sweep_moments.png").stat().st_size > 20_000


def test_plot_energy_pdfs_into_an_ax():
    from matplotlib.figure import Figure
    ax = Figure().subplots()
    sol = averaging.stationary(VibroImpactSystem.paper(r=0.92))
    assert plotting.plot_energy_pdfs([("stochastic averaging", sol)], ax=ax) is ax
    assert "J/kg" in ax.get_xlabel()
