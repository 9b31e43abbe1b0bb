"""Which earlier point records a run may keep, and the earlier outputs it clears.

Every point record (``points/p{i}.json``) carries a ``fingerprint``: ``"scene"``, a
digest of the scene (its parsed TOML and its name), and ``"point"``, a digest of the
point's own index, parameters, system and every method option as used (defaults
filled in, so ``--reduced`` and the full size differ).  A record as written also
carries ``"record"``, a digest of everything else in it (:func:`seal`).
``fpk-vibro run --resume`` keeps a record only when it is the file of its own index,
both digests match the run's, it finished (failed, interrupted and damaged points
are computed again), its content is as written (an edited or truncated record, one
without its answers, is computed again) and the files it lists (densities, figures,
VTU) are still there; :func:`select` says in one line how many it kept, how many
are computed again and why.

A run owns its directory's outputs: :func:`clear_outputs` removes what an earlier
run wrote there (``results.json``, ``densities.npz``, ``results.nc``, sweep figures,
point records, figures and fields, temporary files left by a killed writer) except
the points a resumed run keeps, so that old and new results never sit side by side.
Files the runner does not write are left alone.
"""
from __future__ import annotations

import errno
import hashlib
import json
import re
import shutil
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from ..io import strict

__all__ = ["fingerprint", "seal", "select", "clear_outputs", "clear_temporaries",
           "storage_fault", "STORAGE_ERRORS"]

#: errno values that mean the output's storage failed (not the point): the run stops.
STORAGE_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS})

#: The run's outputs in the directory (figures and fields carry the point's index).
_TOP = re.compile(r"(results\.json|densities\.npz|results\.nc|sweep_[A-Za-z0-9_]+\.png"
                  r"|p\d+_[A-Za-z0-9_.]+\.(png|vtu))")
_POINT = re.compile(r"p(\d+)\.(json|npz)")


def _digest(obj: Any) -> str:
    text = json.dumps(strict(obj), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:32]


def fingerprint(scene: Any, index: int, params: dict[str, float], system: Any
                ) -> dict[str, str]:
    """{"scene": digest of the scene, "point": digest of this point and its settings}."""
    from .plan import resolved_options
    point = {"index": index, "parameters": params, "system": system.to_dict(),
             "methods": {m: resolved_options(scene, m) for m in scene.methods},
             "quantities": list(scene.quantities), "formats": list(scene.formats),
             "times": scene.times, "initial": scene.initial,
             "first_passage": scene.first_passage}
    if scene.phases is not None:        # (absent otherwise: earlier runs stay resumable)
        point["phases"] = list(scene.phases)
    return {"scene": _digest({"name": scene.name, "source": scene.source}),
            "point": _digest(point)}


def _content(record: dict[str, Any]) -> str:
    """The digest of a point record without its own ``fingerprint["record"]``."""
    stamp = {k: v for k, v in record.get("fingerprint", {}).items() if k != "record"}
    return _digest({**record, "fingerprint": stamp})


def seal(record: dict[str, Any]) -> dict[str, Any]:
    """``record`` with ``fingerprint["record"]``, the digest of its content as written
    (strict JSON: the same digest after reading the file back), so that a record
    changed after it was written is not reused (:func:`select`)."""
    record["fingerprint"] = {**record.get("fingerprint", {}), "record": _content(record)}
    return record


def _sealed(record: dict[str, Any]) -> bool:
    stamp = record.get("fingerprint")
    try:
        return isinstance(stamp, dict) and stamp.get("record") == _content(record)
    except (TypeError, ValueError):     # not JSON that the runner writes
        return False


def storage_fault(exc: BaseException) -> bool:
    """True for an OSError that says the output's storage is full or unwritable."""
    return isinstance(exc, OSError) and exc.errno in STORAGE_ERRORS


def _listed_files(record: dict[str, Any]) -> list[str]:
    """The files (relative to the output directory) a point record lists."""
    files = [f for f in record.get("figures", []) if isinstance(f, str)]
    files += [record[k] for k in ("vtu", "densities") if isinstance(record.get(k), str)]
    return files


def _files_present(out_dir: Path, record: dict[str, Any]) -> bool:
    for name in _listed_files(record):
        path = out_dir / name
        if not path.is_file():
            return False
        if path.suffix == ".npz":
            try:
                with np.load(path) as data:
                    data.files  # noqa: B018  (a readable archive)
            except (OSError, ValueError):
                return False
    return True


def select(out_dir: Path, scene: Any, points: list) -> tuple[dict[int, dict[str, Any]], str]:
    """The records of ``out_dir/points`` that ``scene`` may keep, and the line that says
    how many it keeps and why the others are computed again.

    Raises :class:`~fpk_vibro._checks.InputError` (from
    :func:`fpk_vibro.app.outdir.finished_points`) if ``results.json`` is another scene's.
    """
    from .outdir import finished_points
    finished_points(out_dir, scene.source)       # refuses another scene's results.json
    found: dict[int, Any] = {}
    for f in sorted((out_dir / "points").glob("p*.json")):
        m = _POINT.fullmatch(f.name)
        if m is None:
            continue
        try:
            rec = json.loads(f.read_text(encoding="utf-8"))
        except (OSError, ValueError, UnicodeDecodeError):
            rec = None
        found[int(m.group(1))] = rec
    kept: dict[int, dict[str, Any]] = {}
    why: Counter[str] = Counter()
    for i, (params, system) in enumerate(points):
        rec = found.get(i, False)
        if rec is False:
            why["not computed before"] += 1
            continue
        if not isinstance(rec, dict) or rec.get("index") != i:
            why["record unreadable or of another index"] += 1
            continue
        stamp = rec.get("fingerprint")
        want = fingerprint(scene, i, params, system)
        if not isinstance(stamp, dict) or stamp.get("scene") != want["scene"]:
            why["of another scene"] += 1
        elif stamp.get("point") != want["point"]:
            why["other parameters or settings"] += 1
        elif rec.get("status") == "failed":
            why["failed before"] += 1
        elif rec.get("status") != "done":
            why["interrupted before"] += 1
        elif not _sealed(rec):
            why["record changed after it was written"] += 1
        elif not _files_present(out_dir, rec):
            why["densities or figures missing"] += 1
        else:
            kept[i] = rec
    n = len(points)
    line = f"  resuming: {len(kept)} of {n} point(s) reused, {n - len(kept)} recomputed"
    if why:
        line += " (" + ", ".join(f"{k} {w}" for w, k in why.most_common()) + ")"
    return kept, line


def _temporary(name: str, pattern: re.Pattern) -> bool:
    """``name`` is a temporary file of :mod:`fpk_vibro.io` for an output ``pattern``."""
    m = re.fullmatch(r"\.(.+)\.[^.]+\.tmp", name)
    return m is not None and pattern.fullmatch(m.group(1)) is not None


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            path.unlink()
        except FileNotFoundError:
            pass


def clear_temporaries(out_dir: Path) -> None:
    """Remove the temporary files a killed writer left in ``out_dir`` and its points."""
    for d, pattern in ((out_dir, _TOP), (out_dir / "points", _POINT)):
        if d.is_dir():
            for f in d.iterdir():
                if _temporary(f.name, pattern):
                    _remove(f)


def clear_outputs(out_dir: Path, keep: dict[int, dict[str, Any]]) -> None:
    """Remove an earlier run's outputs from ``out_dir``, except the points in ``keep``
    (their records and the files they list)."""
    kept = {f for rec in keep.values() for f in _listed_files(rec)}
    clear_temporaries(out_dir)
    for f in out_dir.iterdir() if out_dir.is_dir() else ():
        if _TOP.fullmatch(f.name) and f.name not in kept and f.is_file():
            _remove(f)
    points = out_dir / "points"
    for f in points.iterdir() if points.is_dir() else ():
        m = _POINT.fullmatch(f.name)
        if m and int(m.group(1)) not in keep and f"points/{f.name}" not in kept:
            _remove(f)
