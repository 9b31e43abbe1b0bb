"""Atomic file writes: a temporary file in the same directory, flushed, synced, renamed.

An interrupted or killed run never leaves a half-written file behind: a reader
sees the old file, or none, or the complete new one.  Files get the user's
umask (0644 under umask 022), like any file the user writes.  JSON is strict
(non-finite numbers are written as ``null``).
"""
from __future__ import annotations

import errno
import json
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any, BinaryIO, Callable

import numpy as np

__all__ = ["atomic_write", "atomic_write_text", "atomic_savez", "atomic_json",
           "atomic_files", "strict", "file_mode"]


def file_mode() -> int:
    """0666 less the process umask (read without changing it where Linux allows)."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return 0o666 & ~int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


def _sync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _named(exc: OSError, path: Path) -> OSError:
    """``exc`` naming ``path``, the file the caller asked for, where it named none or
    a temporary file of ``path`` (``.NAME.*.tmp``); any other file it names stays."""
    name = exc.filename
    if isinstance(name, (str, os.PathLike)) and not Path(name).name.startswith(
            f".{path.name}.") and not Path(name).parent.name.startswith(f".{path.name}."):
        return exc
    code = exc.errno
    if code is None and "No space left on device" in str(exc):   # h5py's wording
        code = errno.ENOSPC
    reason = exc.strerror or (os.strerror(code) if code else str(exc))
    return OSError(code, reason, str(path))


def atomic_write(path: str | os.PathLike, write: Callable[[BinaryIO], None]) -> Path:
    """Call ``write(fh)`` on a temporary file beside ``path`` and rename it to ``path``.

    An :class:`OSError` (a full disk, say) names ``path``, never the temporary file.
    """
    path = Path(path)
    tmp = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    except BaseException as exc:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise _named(exc, path) from None
        raise
    _sync_dir(path.parent)
    return path


def atomic_files(path: str | os.PathLike, write: Callable[[Path], None]) -> Path:
    """``write(p)`` writes ``p`` (and any files beside it, e.g. an XDMF's .h5) in a
    temporary directory beside ``path``; each is then renamed into place, ``path``
    last, so that a reader never sees ``path`` without its companions."""
    path = Path(path)
    tmpdir = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmpdir = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"))
        write(tmpdir / path.name)
        produced = sorted(tmpdir.iterdir(), key=lambda p: p.name == path.name)
        for p in produced:
            with open(p, "rb+") as fh:
                os.fsync(fh.fileno())
            os.chmod(p, file_mode())
            os.replace(p, path.parent / p.name)
    except OSError as exc:
        raise _named(exc, path) from None
    finally:
        if tmpdir is not None:
            shutil.rmtree(tmpdir, ignore_errors=True)
    _sync_dir(path.parent)
    return path


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    return atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))


def atomic_savez(path: str | os.PathLike, arrays: dict[str, np.ndarray]) -> Path:
    return atomic_write(path, lambda fh: np.savez(fh, **arrays))


def strict(obj: Any) -> Any:
    """``obj`` with NumPy scalars as Python numbers and non-finite floats as None."""
    if isinstance(obj, dict):
        return {str(k): strict(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return strict(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, (str, type(None))):
        return obj
    return str(obj)


def atomic_json(path: str | os.PathLike, obj: Any) -> Path:
    """Write ``obj`` as strict JSON (RFC 8259: no NaN or Infinity), atomically."""
    return atomic_write_text(path, json.dumps(strict(obj), indent=1, allow_nan=False))
