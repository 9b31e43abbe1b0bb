"""Which device a Monte Carlo run uses: ``device = "cpu" | "cuda" | "auto"``.

``"cuda"`` needs the optional ``numba-cuda`` package (``pip install fpk-vibro[gpu]``)
and an NVIDIA GPU with its driver; without them it is refused in one line.  ``"auto"``
takes the GPU when one is usable, else the CPU threads.  numba's CUDA simulator
(``NUMBA_ENABLE_CUDASIM=1``) counts as a device: it runs the GPU kernels on the CPU in
Python, for tests.

numba-cuda 0.30.4 (and earlier) call ``np.row_stack`` at import, which numpy 2.5
removed: :func:`cuda` puts ``numpy.row_stack = numpy.vstack`` back (the same
function, deprecated since numpy 2.0) before importing it.  Supported: numba-cuda
≥ 0.20 with numba ≥ 0.60, numpy ≥ 1.24 (2.5 through that alias).

>>> resolve("cpu")
'cpu'
>>> resolve("gpu")
Traceback (most recent call last):
...
fpk_vibro._checks.InputError: montecarlo: device must be one of 'cpu', 'cuda', 'auto'; got 'gpu'
"""
from __future__ import annotations

import os
import sys
from typing import Any

from .. import _checks

__all__ = ["DEVICES", "resolve", "cuda", "available", "describe"]

DEVICES = ("cpu", "cuda", "auto")
#: numba-cuda versions measured to work (the benchmark prints the one in use).
SUPPORTED = "numba-cuda >= 0.20 (0.30.4 measured), numba >= 0.60, numpy >= 1.24"

#: The interpreter's thread switch interval (s) while numba's simulator is on: it runs
#: each CUDA thread as a Python thread while the launching thread polls them holding
#: the GIL, so every hand-off waits out the interval; at the default 5 ms a small
#: crossings run took 238 s, at 1 ms 42 s, at 0.1 ms 6.6–8.4 s (the same run).
SIMULATOR_SWITCH_INTERVAL = 1e-4

_why: str | None = None          # why no GPU is usable (cached after the first look)
_ok: bool | None = None


def cuda():
    """``numba.cuda``, imported with the numpy 2.5 shim (module docstring).

    Raises
    ------
    ImportError
        One line naming the missing package and how to install it.
    """
    import numpy as np
    if simulator():
        sys.setswitchinterval(min(sys.getswitchinterval(), SIMULATOR_SWITCH_INTERVAL))
    if not hasattr(np, "row_stack"):
        np.row_stack = np.vstack            # removed in numpy 2.5; numba-cuda 0.30 uses it
    try:
        from numba import cuda as nc
    except ImportError as exc:              # numba without its CUDA target
        raise ImportError("montecarlo: device = \"cuda\" needs numba-cuda (pip install "
                          f"'fpk-vibro[gpu]'; {SUPPORTED}): {exc}") from None
    return nc


def simulator() -> bool:
    """True when numba's CUDA simulator is asked for (``NUMBA_ENABLE_CUDASIM=1``)."""
    return os.environ.get("NUMBA_ENABLE_CUDASIM", "0") not in ("", "0")


def available() -> tuple[bool, str]:
    """(usable, why not): numba-cuda importable and a GPU (or the simulator) present."""
    global _why, _ok
    if _ok is None:
        try:
            nc = cuda()
            _ok = bool(nc.is_available())
            _why = "" if _ok else "no CUDA GPU or driver was found"
        except Exception as exc:            # noqa: BLE001 - any failure means no GPU
            _ok, _why = False, str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return _ok, _why or ""


def resolve(device: Any, where: str = "montecarlo") -> str:
    """"cpu" or "cuda" for the option ``device``; an InputError (one line) for
    anything else, and for "cuda" where no GPU is usable."""
    if device not in DEVICES:
        raise _checks.invalid(where, "device", "one of 'cpu', 'cuda', 'auto'", device)
    if device == "cpu":
        return "cpu"
    ok, why = available()
    if ok:
        return "cuda"
    if device == "auto":
        return "cpu"
    raise _checks.InputError(f"{where}: device = \"cuda\" but no CUDA device is usable "
                             f"({why}); use device = \"cpu\" (or \"auto\")",
                             where=where, name="device")


def describe() -> dict[str, str]:
    """GPU name, driver and numba-cuda versions (for benchmarks and results)."""
    out = {"numba_cuda": "not installed", "gpu": "none", "driver": "none"}
    try:
        from importlib.metadata import version
        out["numba_cuda"] = version("numba-cuda")
    except Exception:                       # noqa: BLE001
        pass
    ok, why = available()
    if not ok:
        out["gpu"] = f"none ({why})"
        return out
    nc = cuda()
    if simulator():
        out["gpu"] = "numba CUDA simulator"
        return out
    dev = nc.get_current_device()
    name = dev.name
    out["gpu"] = name.decode() if isinstance(name, bytes) else str(name)
    try:
        v = nc.cudadrv.driver.driver.get_version()
        out["driver"] = f"CUDA driver API {v[0]}.{v[1]}"
    except Exception:                       # noqa: BLE001
        pass
    return out
