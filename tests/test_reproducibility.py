"""Monte Carlo reproducibility across processes: the same seed gives bit-identical
moments and histograms whatever the state of numba's compile cache (cold: compiled
in the process; warm: loaded from the cache) and the number of threads.

Each run is a fresh interpreter with its own ``NUMBA_CACHE_DIR``: a cold and a
warm process do not run the same machine code path to the kernels (a cold one
compiles every callee on its own first), which a test within one process cannot
see.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# prints {key: hex} for every moment, standard error and histogram array (bytes,
# with dtype and shape) of two stationary runs and a transient one
SCRIPT = r"""
import json, sys
import numpy as np
from fpk_vibro import VibroImpactSystem
from fpk_vibro import montecarlo as mc

threads = int(sys.argv[1])
system = VibroImpactSystem.paper(r=0.98)
out = {}

def record(tag, sol):
    for kind, d in (("moment", sol.moments()), ("se", sol.moments_se())):
        for k, v in d.items():
            out[f"{tag} {kind} {k}"] = float(v).hex()
    out[f"{tag} impact_rate"] = float(sol.impact_rate).hex()
    for q in sol.quantities:
        for i, a in enumerate(sol.histogram(q)):
            a = np.ascontiguousarray(a)
            out[f"{tag} histogram {q} [{i}]"] = f"{a.dtype.str}{a.shape}:{a.tobytes().hex()}"

record("stationary", mc.stationary(system, seed=1, n_paths=512, t_sample=150,
                                   threads=threads, progress=False))
# the other branches of the sweep: additive noise only (D2 = 0), one barrier
record("stationary D2=0 right", mc.stationary(
    VibroImpactSystem.paper(r=0.9, D2=0.0, barriers="right"), seed=3, n_paths=256,
    t_sample=100, threads=threads, progress=False))
run = mc.transient(system, initial={"mean": (0.0, 1.0), "std": (0.05, 0.05)},
                   times=(0.0, 10.0, 40.0), seed=2, n_paths=512, threads=threads,
                   progress=False)
for sol in run:
    record(f"transient t={sol.time:g}", sol)
print(json.dumps(out))
"""


def _run(cache_dir: Path, threads: int) -> dict[str, str]:
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = str(cache_dir)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    r = subprocess.run([sys.executable, "-c", SCRIPT, str(threads)], env=env, cwd=ROOT,
                       capture_output=True, text=True, timeout=300, check=False)
    assert r.returncode == 0, r.stderr[-3000:]
    return json.loads(r.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict[str, dict[str, str]]:
    cache = tmp_path_factory.mktemp("numba_cache")
    assert not any(cache.iterdir())
    out = {"cold, 1 thread": _run(cache, 1)}
    assert any(cache.rglob("*.nbc")), "the cold run wrote no numba cache"
    out["warm, 2 threads"] = _run(cache, 2)
    out["warm, 1 thread"] = _run(cache, 1)
    return out


def _assert_identical(a: dict[str, str], b: dict[str, str], what: str) -> None:
    assert a.keys() == b.keys()
    differ = [k for k in a if a[k] != b[k]]
    assert not differ, (f"{what}: {len(differ)} of {len(a)} results differ, e.g. "
                        + "; ".join(f"{k}: {a[k][:40]} vs {b[k][:40]}" for k in differ[:4]))


def test_cold_and_warm_cache_identical(runs):
    _assert_identical(runs["cold, 1 thread"], runs["warm, 1 thread"], "cold vs warm cache")


def test_thread_count_identical(runs):
    _assert_identical(runs["warm, 1 thread"], runs["warm, 2 threads"], "1 vs 2 threads")


def test_runs_cover_every_histogram(runs):
    keys = runs["cold, 1 thread"]
    for tag in ("stationary", "stationary D2=0 right", "transient t=0", "transient t=10",
                "transient t=40"):
        for q in ("energy", "x", "y", "joint"):
            assert f"{tag} histogram {q} [0]" in keys
        assert f"{tag} moment E_H" in keys
