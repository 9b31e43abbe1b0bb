"""The output directory of a run: one run at a time, checked before any work.

A run holds an exclusive lock on ``DIR/.fpk-vibro.lock`` (``fcntl.flock``) from
its first write to its last: a second run into the same directory is refused
with one line, so two runs never mix their data.  The lock dies with its
process (also under ``kill -9``), so a stale lock file never blocks a later run.
Only the run holds it: the descriptor is close-on-exec (worker processes are
fresh interpreters, :mod:`fpk_vibro.app.pool`) and a process forked during the run
closes its copy at once (``os.register_at_fork``), since an ``flock`` lives as
long as any process has the open file, and an orphan would keep the directory
"in use" after the run died.
The directory must be a directory and writable; the check happens before any
point is computed.

:func:`finished_points` reads back what an earlier run of the same scene
finished (``points/p{i}.json``), for ``fpk-vibro run --resume``.
"""
from __future__ import annotations

import json
import os
import re
import weakref
from pathlib import Path
from typing import Any

from .._checks import InputError

__all__ = ["OutputDir", "safe_name", "finished_points", "point_records", "holds",
           "LOCK_NAME"]

LOCK_NAME = ".fpk-vibro.lock"


def safe_name(name: str) -> str:
    """``name`` as one path component: letters, digits, '.', '_', '-' (no leading dot)."""
    out = re.sub(r"[^A-Za-z0-9._-]+", "_", name).lstrip("._")
    return out[:100] or "scene"


_HELD: "weakref.WeakSet[OutputDir]" = weakref.WeakSet()


def _drop_in_child() -> None:
    """In a forked child: close the copies of every held lock (the parent keeps them)."""
    for held in list(_HELD):
        if held._fd is not None:
            try:
                os.close(held._fd)
            except OSError:
                pass
            held._fd = None
    _HELD.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_drop_in_child)


class OutputDir:
    """Context manager: the locked, writable output directory ``path``."""

    def __init__(self, path: str | os.PathLike, key: str = "--out") -> None:
        self.path, self.key = Path(path), key
        self._fd: int | None = None
        #: Names this run in the lock file: a task of a cancelled run (a Dask worker
        #: cannot be stopped mid-task) checks it before writing (:func:`holds`).
        self.token = os.urandom(8).hex()

    def __enter__(self) -> "OutputDir":
        import fcntl
        p = self.path
        if p.exists() and not p.is_dir():
            raise InputError(f"{self.key}: {str(p)!r} exists and is not a directory",
                             name=self.key)
        try:
            p.mkdir(parents=True, exist_ok=True)
            fd = os.open(p / LOCK_NAME, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise InputError(f"{self.key}: cannot write to {str(p)!r} "
                             f"({exc.strerror or exc})", name=self.key) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise InputError(f"{self.key}: {str(p)!r} is in use by another run; wait for it "
                             "or choose another output directory", name=self.key) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()} {self.token}\n".encode())
        self._fd = fd
        _HELD.add(self)
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._fd is not None:
            try:
                os.unlink(self.path / LOCK_NAME)
            except OSError:
                pass
            os.close(self._fd)          # releases the lock
            self._fd = None
            _HELD.discard(self)


def holds(path: Path, token: str) -> bool:
    """True while the run named ``token`` holds the lock of ``path``."""
    try:
        return (path / LOCK_NAME).read_text(encoding="ascii").split()[1:] == [token]
    except (OSError, ValueError, UnicodeDecodeError):
        return False


def point_records(path: Path) -> dict[int, dict[str, Any]]:
    """{index: record} of every readable ``points/p{i}.json`` in ``path`` whose
    ``index`` is the ``i`` of its file name (a record is trusted by its file)."""
    out = {}
    for f in sorted((path / "points").glob("p*.json")):
        try:
            rec = json.loads(f.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue                      # a damaged record is computed again
        if isinstance(rec, dict) and isinstance(rec.get("index"), int) \
                and f.name == f"p{rec['index']}.json":
            out[rec["index"]] = rec
    return out


def finished_points(path: Path, source: dict[str, Any]) -> dict[int, dict[str, Any]]:
    """{index: record} of the points an earlier run of the scene ``source`` finished
    in ``path`` (failed, interrupted and missing points are left out: they are
    computed again).  :func:`fpk_vibro.app.resume.select` adds the fingerprint checks.

    Raises :class:`InputError` if ``path`` holds the results of another scene.
    """
    results = path / "results.json"
    if results.exists():
        try:
            old = json.loads(results.read_text(encoding="utf-8"))
            same = old.get("scene") == json.loads(json.dumps(source))
        except (OSError, ValueError, AttributeError):
            same = False
        if not same:
            raise InputError(f"--resume: {str(results)!r} holds the results of another scene "
                             "(or is unreadable); choose another output directory",
                             name="--resume")
    return {i: r for i, r in point_records(path).items() if r.get("status") == "done"}
