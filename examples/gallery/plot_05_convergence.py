"""
Convergence of finite elements against the exact density
========================================================

With elastic walls (r = 1) and no parametric noise (D2 = 0) the stationary
density is known exactly: the Gibbs density p ∝ exp(−(c/D1) H) on the strip
(:func:`fpk_vibro.exact.gibbs`).  This measures the L1 error of Q1 and Q2 finite
elements against it as the mesh is refined.
"""
import time

import matplotlib.pyplot as plt
import numpy as np

from fpk_vibro import VibroImpactSystem, exact, fem

system = VibroImpactSystem.paper(r=1.0, D2=0.0)
truth = exact.gibbs(system)

# %%
# A quadrature grid for the L1 error
# ----------------------------------
# Gauss–Legendre points over the FE domain :math:`|x| < \Delta`,
# :math:`|y| < y_{max}`.

lo, hi = system.x_bounds
y_max = fem.default_y_max(system)
t, w = np.polynomial.legendre.leggauss(200)
xq, wx = 0.5 * (hi - lo) * t + 0.5 * (hi + lo), 0.5 * (hi - lo) * w
yq, wy = y_max * t, y_max * w
X, Y = np.meshgrid(xq, yq, indexing="ij")
weights = np.outer(wx, wy)
p_exact = truth.pdf_joint(X, Y)


def l1_error(sol):
    return float(np.sum(weights * np.abs(sol.pdf_joint(X, Y) - p_exact)))


# %%
# Refine the mesh
# ---------------

errors = {}
for degree, sizes in ((1, (8, 16, 32, 64)), (2, (4, 8, 16, 32))):
    errors[degree] = []
    for nx in sizes:
        start = time.perf_counter()
        sol = fem.stationary(system, degree=degree, nx=nx)
        seconds = time.perf_counter() - start
        errors[degree].append((nx, l1_error(sol)))
        print(f"Q{degree} nx = {nx:3d}: L1 error {errors[degree][-1][1]:.2e} "
              f"({sol.dofs.size} DOFs, "
              f"{seconds:.2f} s)")

fig, ax = plt.subplots(figsize=(6.4, 4.0))
for degree, rows in errors.items():
    nx, err = np.array(rows).T
    ax.loglog(nx, err, "o-", label=f"Q{degree}")
nx = np.array([8.0, 64.0])
ax.loglog(nx, 0.5 * nx ** -2.0, "k:", label="order 2")
ax.set_xticks([4, 8, 16, 32, 64], labels=["4", "8", "16", "32", "64"])
ax.minorticks_off()
ax.set(xlabel="cells across x, nx", ylabel="L1 error of p(x, y)")
ax.legend()

# %%
# The number
# ----------
# The observed order of Q1 between nx = 16 and 64 (about **2**), and the Q2
# error at nx = 32: about **1.5e-5**.

(n1, e1), (n2, e2) = errors[1][1], errors[1][3]
q1_order = float(np.log(e1 / e2) / np.log(n2 / n1))
q2_error = errors[2][-1][1]
print(f"Q1 order {q1_order:.2f}; Q2 L1 error at nx = 32: {q2_error:.2e}")

plt.show()
