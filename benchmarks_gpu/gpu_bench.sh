#!/bin/bash
# Issue 33 device check: the CUDA tests on real hardware, then the benchmark.
export PYTHONUNBUFFERED=1
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target /tmp/site benchmarks_gpu/whl/*.whl || exit 1
export PYTHONPATH=/tmp/site:$PWD
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
python3 -c "import numpy, numba, importlib.metadata as m; print('numpy', numpy.__version__, 'numba', numba.__version__, 'numba-cuda', m.version('numba-cuda'))"
T=tests/test_montecarlo_cuda.py
[ -f tests/test_montecarlo_device.py ] && T="$T tests/test_montecarlo_device.py"
timeout ${TEST_TIMEOUT:-120} python3 -m pytest -q -p no:cacheprovider -o addopts="" $T $TEST_ARGS -W ignore::RuntimeWarning 2>&1 | tail -15 | tee $OUT/tests.log
timeout ${BENCH_TIMEOUT:-280} python3 -m fpk_vibro.benchmarks.montecarlo_cuda $BENCH_ARGS 2>&1 | tee $OUT/bench.log
