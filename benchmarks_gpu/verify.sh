#!/bin/bash
# Issue 33, last device check: the wired public API (device="cuda") after the kernel
# rewrite for deterministic sums and the issue-32 quantities.
export PYTHONUNBUFFERED=1
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site benchmarks_gpu/whl/*.whl || exit 1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
timeout 100 python3 - <<'PY' 2>&1 | grep -v Warning | tee $OUT/verify.log
import time, warnings
warnings.simplefilter("ignore")
import numpy as np
from fpk_vibro import VibroImpactSystem, Restitution, montecarlo as mc
s = VibroImpactSystem.paper()
kw = dict(device="cuda", n_paths=2 ** 20, seed=1, progress=False,
          quantities=("energy", "x", "y", "inter_impact", "impact_energy"))
t = time.perf_counter(); a = mc.stationary(s, **kw); ta = time.perf_counter() - t
t = time.perf_counter(); b = mc.stationary(s, **kw); tb = time.perf_counter() - t
m, se = a.moments(), a.moments_se()
print("device", a.info.get("device"), "first", round(ta, 2), "s, again", round(tb, 2), "s")
print("E[H]", m["E_H"], "+-", se["E_H"], "FE 0.214725, SE off", (m["E_H"] - 0.214725) / se["E_H"])
print("same seed bit-identical:", a.moments() == b.moments(), a.impacts() == b.impacts())
rate = sum(v["rate"] for v in a.impacts().values())
print("mean gap", a.mean_inter_impact_time(), "1/rate", 1 / rate,
      "energy/impact", a.mean_impact_energy("right"))
law = Restitution.tanh(0.9, 0.2, 1.0)
p = s.replace(**{"left.r": law, "right.r": law})
c = mc.stationary(p, device="cuda", n_paths=2 ** 20, seed=2, progress=False)
print("peer law E[H]", c.moments()["E_H"], "+-", c.moments_se()["E_H"], "FE 0.1383094594")
f = VibroImpactSystem.paper(r=0.92)
t = time.perf_counter()
fp = mc.first_passage(f, energy=0.498, device="cuda", n_paths=2 ** 22, seed=3, progress=False)
print("FP mean", fp.mean, "+-", fp.mean_se, "FE 80.43;", round(time.perf_counter() - t, 2), "s",
      fp.info.get("path_steps"))
d = mc.first_passage(s, displacement=(-0.2, 0.4), start=(0.0, 0.0), device="cuda",
                     n_paths=2 ** 20, seed=4, progress=False)
print("displacement FP", d.mean, "+-", d.mean_se, "FE 6.763")
PY
timeout 40 python3 -m pytest -q -p no:cacheprovider -o addopts="" tests/test_montecarlo_cuda.py -k real -W ignore::RuntimeWarning 2>&1 | tail -3 | tee $OUT/tests.log
