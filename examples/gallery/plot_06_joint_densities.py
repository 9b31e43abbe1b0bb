"""
The joint density p(x, y) at r = 0.98 and 0.92 (the paper's Figs. 4 and 5)
==========================================================================

Finite elements (Q2) and stochastic averaging give the joint density of
displacement and velocity between walls at ±0.6.  With one colour scale from 0
(:func:`fpk_vibro.app.plotting.plot_joint`) the lower restitution visibly concentrates
the density at low energy; the difference maps show where averaging, which makes
p(x, y) a function of the energy alone, departs from FE: along the walls, where the
impacts take energy out.
"""
import matplotlib.pyplot as plt
import numpy as np

from fpk_vibro import VibroImpactSystem, averaging, fem
from fpk_vibro.app import plotting

x = np.linspace(-0.6, 0.6, 121)
y = np.linspace(-1.2, 1.2, 121)
peaks = {}
for r in (0.98, 0.92):
    system = VibroImpactSystem.paper(r=r)
    sols = {"averaging": averaging.stationary(system), "fem": fem.stationary(system, degree=2, nx=24)}
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    _, cs = plotting.plot_joint(sols, x, y, axes=axes[:2])
    fig.colorbar(cs, ax=axes[:2], label="p(x, y)")
    diff = sols["averaging"].pdf_joint(x[None, :], y[:, None]) - sols["fem"].pdf_joint(x[None, :], y[:, None])
    lim = np.abs(diff).max()
    im = axes[2].contourf(x, y, diff, levels=np.linspace(-lim, lim, 17), cmap="RdBu_r")
    fig.colorbar(im, ax=axes[2], label="averaging − FE")
    axes[2].set(xlabel="displacement x (m)", title=f"r = {r}")
    peaks[r] = float(sols["fem"].dofs.max())

# %%
# The number
# ----------
# The peak of p(x, y) rises from **0.634** at r = 0.98 to **0.709** at r = 0.92
# (FE Q2, nx = 24): more energy lost at the walls, more mass near the rest state.
peak_ratio = peaks[0.92] / peaks[0.98]
print(f"peak p(x, y): {peaks}; ratio {peak_ratio:.3f}")
