"""Figures: nothing switches the matplotlib backend; public functions draw into an
``ax`` and return it; scene figures have the log and difference panels."""
import subprocess
import sys

import numpy as np

from fpk_vibro import VibroImpactSystem, averaging, fem, plotting


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
