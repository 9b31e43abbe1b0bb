"""Every ``fpk-vibro bench`` command runs: each registered benchmark in its quick mode
(a few seconds) exits 0 and prints its table, and the benchmarks' old module paths
still work, with a DeprecationWarning, for one release (issue 31)."""
import importlib
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from fpk_vibro._moved import MOVED
from fpk_vibro.benchmarks import BENCHMARKS

ROOT = Path(__file__).resolve().parent.parent

#: A column of each benchmark's table (its header line holds it).
COLUMN = {"averaging": "median ms", "montecarlo": "kernel/floor", "fem": "L1 est",
          "fem-scale": "L1 err", "fem-transient": "max rel. error", "fem-doublewell": "median s",
          "fem-first-passage": "converged", "fem-scenes": "flagged",
          "fem-restitution": "table law s", "fem-periodic": "est lag", "fem-coloured": "iters",
          "fem-spectrum": "est rel"}



def _bench(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fpk_vibro", "bench", *args],
                          capture_output=True, text=True, timeout=300, cwd=ROOT)


def test_every_benchmark_has_a_smoke_test():
    assert set(COLUMN) == set(BENCHMARKS)


@pytest.mark.parametrize("name", list(BENCHMARKS))
def test_quick_mode_prints_its_table(name):
    r = _bench(name, "--quick")
    assert r.returncode == 0, r.stderr[-2000:]
    lines = r.stdout.splitlines()
    head = next((i for i, line in enumerate(lines) if COLUMN[name] in line), None)
    assert head is not None, r.stdout
    # a row of figures under the header (a separator line may come between)
    rows = [line for line in lines[head + 1:] if any(c.isdigit() for c in line)]
    assert rows, r.stdout


def test_methods_name_registered_benchmarks():
    import fpk_vibro
    named = {m.benchmark for m in fpk_vibro.methods().values() if m.benchmark}
    assert named and named <= set(BENCHMARKS)


def test_bench_lists_every_benchmark():
    r = _bench("--help")
    assert r.returncode == 0
    for name, b in BENCHMARKS.items():
        assert f"{name} " in r.stdout and b.summary in r.stdout


def test_unknown_benchmark_is_one_line():
    r = _bench("nothing")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "nothing" in r.stderr


def test_the_deprecated_paths_are_the_moved_ones():
    """A file at each old path, its docstring saying where it went; no other file
    begins so."""
    shims = {".".join(p.relative_to(ROOT).with_suffix("").parts): p
             for p in (ROOT / "fpk_vibro").rglob("*.py")
             if p.read_text(encoding="utf-8").startswith('"""Deprecated path:')}
    assert set(shims) == set(MOVED)
    for old, path in shims.items():
        assert path.read_text(encoding="utf-8").startswith(
            f'"""Deprecated path: {old} moved to {MOVED[old]} (kept for one release)."""')


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_module_path_warns_and_is_the_new_module(old):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=f"{old} moved to {MOVED[old]}") as seen:
        __import__(old)                  # an import statement's own call
    assert sys.modules[old] is importlib.import_module(MOVED[old])
    assert seen[0].filename == __file__          # the warning names the importing line


def test_old_benchmark_command_runs_with_a_warning():
    r = subprocess.run([sys.executable, "-m", "fpk_vibro.fem.benchmark_scenes", "--quick"],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "flagged" in r.stdout
    assert "DeprecationWarning: fpk_vibro.fem.benchmark_scenes moved to " \
           "fpk_vibro.benchmarks.fem_scenes" in r.stderr


def test_the_averaging_benchmarks_old_package_path():
    """``fpk_vibro.benchmarks`` was the averaging benchmark's module: its ``main`` and
    ``python -m fpk_vibro.benchmarks`` still run it, with a DeprecationWarning."""
    import fpk_vibro.benchmarks as package
    from fpk_vibro.benchmarks import averaging
    with pytest.warns(DeprecationWarning, match="fpk-vibro bench averaging"):
        assert package.main is averaging.main
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert package.load("averaging") is averaging.main
    r = subprocess.run([sys.executable, "-m", "fpk_vibro.benchmarks", "--quick"],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0 and "median ms" in r.stdout
    assert "DeprecationWarning" in r.stderr and "fpk-vibro bench averaging" in r.stderr
