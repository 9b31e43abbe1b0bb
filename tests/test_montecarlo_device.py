"""The ``device`` option of the Monte Carlo engine (issue 33): declared once, refused in
one line without a GPU, "auto" falling back to the CPU, and a run on numba's CUDA
simulator giving the same Solution type as the CPU (in a subprocess: the simulator
must be switched on before numba.cuda is first imported)."""
from __future__ import annotations

import glob
import json
import os
import subprocess
import sys

import pytest

from fpk_vibro import VibroImpactSystem
from fpk_vibro import montecarlo as mc
from fpk_vibro._checks import InputError
from fpk_vibro.montecarlo import Options
from fpk_vibro.montecarlo._device import available

#: A real NVIDIA device here (the session may run numba's simulator otherwise:
#: conftest.py), where "cuda" is not refused.
REAL_GPU = bool(glob.glob("/dev/nvidia[0-9]*")) and available()[0]
no_gpu = pytest.mark.skipif(REAL_GPU, reason="a CUDA device is usable here")


@pytest.fixture(autouse=True)
def _no_simulator_as_a_device(monkeypatch):
    """Without a real device the simulator does not count as one (as outside tests)."""
    if not REAL_GPU:
        from fpk_vibro.montecarlo import _device
        monkeypatch.setattr(_device, "available",
                            lambda: (False, "no CUDA GPU or driver was found"))


def test_device_is_declared_once_for_every_mode():
    opt = Options.__dataclass_fields__["device"].metadata["option"]
    assert opt.default == "cpu" and opt.choices == ("cpu", "cuda", "auto")
    assert set(opt.modes) == {"stationary", "transient", "first_passage", "periodic"}


def test_scene_key_exists():
    from fpk_vibro.app import scene_keys
    opt = scene_keys.table_keys("montecarlo")["device"]
    assert opt.choices == ("cpu", "cuda", "auto")


@no_gpu
@pytest.mark.parametrize("call", ["stationary", "transient", "first_passage"])
def test_cuda_without_gpu_is_refused_in_one_line(call):
    s = VibroImpactSystem.paper()
    kw = {"stationary": dict(t_sample=10.0),
          "transient": dict(initial={"mean": (0.0, 0.0), "std": (0.1, 0.1)}, times=[1.0]),
          "first_passage": dict(energy=0.3)}[call]
    with pytest.raises(InputError) as e:
        getattr(mc, call)(s, n_paths=64, n_batches=8, seed=1, progress=False,
                          device="cuda", **kw) if call != "first_passage" else \
            mc.first_passage(s, n_paths=64, seed=1, progress=False, device="cuda", **kw)
    msg = str(e.value)
    assert "\n" not in msg and "cuda" in msg and 'device = "cpu"' in msg


def test_unknown_device_is_refused():
    with pytest.raises(InputError, match="device"):
        mc.stationary(VibroImpactSystem.paper(), t_sample=10.0, device="gpu", progress=False)


@no_gpu
def test_auto_falls_back_to_the_cpu():
    s = VibroImpactSystem.paper()
    kw = dict(n_paths=64, n_batches=8, t_sample=20.0, seed=1, progress=False)
    a = mc.stationary(s, device="auto", **kw)
    c = mc.stationary(s, device="cpu", **kw)
    assert a.info["device"] == "cpu"
    assert a.moments() == c.moments()           # the very same run


SIM_RUN = r"""
import faulthandler, json, warnings
faulthandler.dump_traceback_later(240, exit=True)   # a hang shows where, in the test's output
warnings.simplefilter("ignore")
from fpk_vibro import VibroImpactSystem, montecarlo as mc
s = VibroImpactSystem.paper()
sol = mc.stationary(s, n_paths=64, n_batches=8, t_burn=30.0, t_sample=40.0, seed=2,
                    progress=False, device="cuda")
print(json.dumps({"type": type(sol).__name__, "device": sol.info["device"],
                  "EH": sol.moments()["E_H"], "se": sol.moments_se()["E_H"]}))
"""


def test_stationary_on_the_cuda_simulator_agrees_with_fe():
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    out = subprocess.run([sys.executable, "-c", SIM_RUN], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-4000:]
    r = json.loads(out.stdout.strip().splitlines()[-1])
    assert r["type"] == "MonteCarloSolution" and "simulator" in r["device"]
    assert abs(r["EH"] - 0.214725) <= 3 * r["se"] + 0.002 * 0.214725, r
