"""
Stronger external noise (the paper's Fig. 8)
============================================

E[H] against the external noise intensity D1 at r = 0.92: averaging and finite
elements.  Averaging's excess grows with the noise — more impacts per unit time, and
its small-loss-per-period assumption holds less well.
"""
import matplotlib.pyplot as plt
import numpy as np

from fpk_vibro import VibroImpactSystem, averaging, fem

D1s = np.array([0.01, 0.02, 0.03])
E_avg, E_fem = [], []
for D1 in D1s:
    system = VibroImpactSystem.paper(r=0.92, D1=float(D1))
    E_avg.append(averaging.stationary(system).moments()["E_H"])
    E_fem.append(fem.stationary(system, degree=2, nx=24).moments()["E_H"])
fig, ax = plt.subplots(figsize=(6.0, 4.0))
ax.plot(D1s, E_avg, "-", label="stochastic averaging")
ax.plot(D1s, E_fem, "o", mfc="none", label="finite elements")
ax.set(xlabel="external noise intensity D1 (m²/s³)", ylabel="E[H] (J/kg)")
ax.legend()

# %%
# The number
# ----------
# Averaging's excess over FE grows from **3.1 %** at D1 = 0.01 to **5.2 %** at 0.03.
excess = np.array(E_avg) / np.array(E_fem) - 1
print("averaging / FE − 1:", np.round(excess, 4))
