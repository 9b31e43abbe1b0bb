"""The solution file: what a file of each kind must hold, and the checks of ``load``.

A file is a NumPy ``.npz`` archive (see :mod:`fpk_vibro.solution`).  Before anything
is built, :func:`read` checks it: a zip of ``.npy`` members (never unpickled; each
header checked against the bytes present), the format and version, the JSON of
``system`` (a valid :class:`~fpk_vibro.VibroImpactSystem`) and ``meta`` (against
the class's ``_meta_schema`` of :class:`Rule`; a stored estimate against
:data:`ESTIMATE_RULE`), and every array against the class's
``_array_schema`` of :class:`Stored` (names, dtypes, shapes, finite values, signs).
Problems are raised as :class:`Corrupt` (the message without the file name).
"""
from __future__ import annotations

import dataclasses
import importlib
import io
import json
import math
import os
import re
import stat
import zipfile
import zlib
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np

from ._checks import interval, show
from .keys import ESTIMATE_KEYS
from .model import VibroImpactSystem

__all__ = ["Rule", "Stored", "Corrupt", "read", "open_archive", "FORMAT_NAME", "FORMAT_VERSION",
           "KIND_MODULES", "RESERVED", "ESTIMATE", "ESTIMATE_RULE"]

FORMAT_NAME = "fpk_vibro.solution"
FORMAT_VERSION = 1

#: Where the class of each stored ``kind`` lives (imported on demand by ``load``).
KIND_MODULES = {"averaging": "fpk_vibro.averaging", "averaging_grid": "fpk_vibro.averaging",
                "exact": "fpk_vibro.exact", "fem": "fpk_vibro.fem", "fem_coloured": "fpk_vibro.fem.coloured",
                "montecarlo": "fpk_vibro.montecarlo"}
#: Members every file holds besides the class's arrays ("package": the writer's version).
RESERVED = ("format", "version", "kind", "system", "meta", "package")
#: The ``meta`` key of the error estimate made before saving (every kind:
#: ``Solution.save`` writes it, ``Solution.load`` gives it back as made).
ESTIMATE = "estimate"


class Corrupt(Exception):
    """A problem with a solution file (message without the file name)."""


@dataclasses.dataclass(frozen=True)
class Rule:
    """What one ``meta`` value must be.

    Attributes
    ----------
    allowed : str
        The rule in words, for the message (``"an integer >= 1"``).
    ok : callable
        ``ok(value) -> bool``.
    required : bool
        False: the key may be absent.
    """

    allowed: str
    ok: Callable[[Any], bool]
    required: bool = True
    FLAG: ClassVar["Rule"]
    TEXT: ClassVar["Rule"]
    ANY: ClassVar["Rule"]
    SCALAR: ClassVar["Rule"]

    # -- the vocabulary ------------------------------------------------------------
    @staticmethod
    def number(lo: float = -math.inf, *, lo_open: bool = False, hi: float = math.inf,
               nan: bool = False, none: bool = False) -> "Rule":
        """A finite int or float in [lo, hi] (or (lo, hi]); optionally NaN or None."""
        def ok(v):
            if v is None or isinstance(v, bool) or not isinstance(v, (int, float)):
                return none and v is None
            if isinstance(v, float) and math.isnan(v):
                return nan
            if isinstance(v, int) and abs(v) > 2 ** 1023:      # no float holds it
                return False
            return math.isfinite(v) and (v > lo if lo_open else v >= lo) and v <= hi
        words = interval(lo, hi, lo_open, False) + (", or NaN" if nan else "") \
            + (", or null" if none else "")
        return Rule(words, ok)

    @staticmethod
    def integer(lo: int, hi: int | None = None) -> "Rule":
        """An int (not a bool) in [lo, hi]."""
        return Rule(f"an integer in [{lo}, {hi}]" if hi is not None else f"an integer >= {lo}",
                    lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= lo
                    and (hi is None or v <= hi))

    @staticmethod
    def choice(*values: Any) -> "Rule":
        """One of ``values`` (same type and value)."""
        return Rule(f"one of {list(values)}",
                    lambda v: any(type(v) is type(c) and v == c for c in values))

    @staticmethod
    def listing(item: "Rule", size: int | None = None) -> "Rule":
        """A list of ``size`` (any if None) values each obeying ``item``."""
        n = "" if size is None else f" of {size}"
        return Rule(f"a list{n} whose items are each {item.allowed}",
                    lambda v: isinstance(v, list) and (size is None or len(v) == size)
                    and all(item.ok(x) for x in v))

    @staticmethod
    def mapping(item: "Rule", needs: tuple = (), keys: tuple | None = None) -> "Rule":
        """An object with the keys ``needs`` (and only ``keys``, if given) and ``item`` values."""
        words = "an object" + (f" with keys {list(needs)}" if needs else "") \
            + (f" (of {list(keys)})" if keys else "") + f" whose values are each {item.allowed}"
        return Rule(words, lambda v: isinstance(v, dict) and set(needs) <= set(v)
                    and (keys is None or set(v) <= set(keys)) and all(item.ok(x) for x in v.values()))

    @staticmethod
    def of(option: Any) -> "Rule":
        """The range of a declared :class:`~fpk_vibro.options.Option` (e.g. a solver's
        ``n_panel``), so a file holds no setting the solver itself would refuse."""
        def ok(v):
            try:
                option.validate("value", v, None)
            except ValueError:
                return False
            return v is not None
        words = option.describe()
        return Rule(("an " if words.startswith(("integer", "even")) else
                     "a " if words.startswith("finite") else "") + words, ok)

    def optional(self) -> "Rule":
        """The same rule for a key that may be absent."""
        return dataclasses.replace(self, required=False)


Rule.FLAG = Rule("true or false", lambda v: isinstance(v, bool))
Rule.TEXT = Rule("a string", lambda v: isinstance(v, str))
Rule.ANY = Rule("any JSON value", lambda v: True)
Rule.SCALAR = Rule("a number, string, boolean or null",
                   lambda v: v is None or isinstance(v, (bool, int, float, str)))


def _estimated(v: Any) -> bool:
    """An ``error_estimate()`` dict: its figures (:data:`~fpk_vibro.keys.ESTIMATE_KEYS`)
    numbers ≥ 0, inf or NaN; the rest numbers, strings, flags, null or objects of numbers."""
    def num(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool)

    def ok(k, x):
        if k in ESTIMATE_KEYS:
            return num(x) and (x >= 0 or math.isnan(x))
        return x is None or isinstance(x, (bool, int, float, str)) or (
            isinstance(x, dict) and all(map(num, x.values())))
    return isinstance(v, dict) and all(ok(k, x) for k, x in v.items())


#: What a stored :data:`ESTIMATE` must be.
ESTIMATE_RULE = Rule("an object of the estimate's figures (numbers >= 0, inf or NaN) and "
                     "notes (numbers, strings, flags, null or objects of numbers)", _estimated,
                     required=False)


@dataclasses.dataclass(frozen=True)
class Stored:
    """How one stored array must look.

    Attributes
    ----------
    shape : tuple
        One entry per axis: an int, or a size name (``"n"``, ``"n-1"``, ``"n+1"``)
        shared between the arrays of one file (bound by its first use, in schema order).
    dtype : {"float", "int"}
        float64 or int64.
    min_size : int
        Fewest elements.
    nonneg : bool
        Values ≥ 0 (to round-off: ≥ -1e-9 max |value|).
    nan_ok : bool
        NaN allowed (e.g. a standard error from one batch); ±inf never is.
    increasing : bool
        Strictly increasing (bin edges, grid nodes).
    below : str or None
        int arrays: every value an index in [0, size ``below``).
    """

    shape: tuple
    dtype: str = "float"
    min_size: int = 0
    nonneg: bool = False
    nan_ok: bool = False
    increasing: bool = False
    below: str | None = None


def read(zf: zipfile.ZipFile, registry: dict[str, type], expected: type
         ) -> tuple[type, VibroImpactSystem, dict[str, Any], dict[str, np.ndarray]]:
    """(class, system, meta, arrays) of the open archive ``zf``, every part checked.

    ``registry`` maps kinds to classes; the class must be ``expected`` or derive from it.
    """
    target, system, meta = _read_header(zf, registry)
    if not issubclass(target, expected):
        raise Corrupt(f"holds a {target.__name__}, not a {expected.__name__}")
    arrays = _read_arrays(zf, target._array_schema(meta))
    target._check_state(system, meta, arrays)
    return target, system, meta, arrays


def open_archive(path: str | os.PathLike) -> zipfile.ZipFile:
    """The zip archive at ``path``; Corrupt if there is none."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise Corrupt("no such file") from None
    except OSError as exc:
        raise Corrupt(f"cannot be read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(mode):
        raise Corrupt("is a directory, not an fpk_vibro solution file")
    if not stat.S_ISREG(mode):
        raise Corrupt("is not a regular file")
    try:
        return zipfile.ZipFile(path)
    except PermissionError as exc:
        raise Corrupt(f"cannot be read ({exc.strerror})") from None
    except (zipfile.BadZipFile, OSError, EOFError, ValueError, NotImplementedError):
        raise Corrupt("not an fpk_vibro solution file (not a zip archive)") from None


def _member(zf: zipfile.ZipFile, key: str) -> np.ndarray:
    """Array ``key`` of the archive, read as ``np.load`` does, after checking its header
    against the bytes present (no pickles, no allocation beyond what the file holds)."""
    what = f"{'member' if key in RESERVED else 'array'} {key!r}"
    try:
        raw = zf.read(key + ".npy")
        fh = io.BytesIO(raw)
        version = np.lib.format.read_magic(fh)
        if version not in ((1, 0), (2, 0)):
            raise Corrupt(f"{what} has .npy format version {version}, not 1.0 or 2.0")
        read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                else np.lib.format.read_array_header_2_0)
        shape, _, dtype = read(fh)
        if dtype.hasobject:
            raise Corrupt(f"{what} holds Python objects (pickled data, never loaded)")
        if fh.tell() + math.prod(shape) * dtype.itemsize != len(raw):
            raise Corrupt(f"{what} is truncated or padded ({len(raw) - fh.tell()} "
                           f"data bytes for shape {shape} of {dtype})")
        fh.seek(0)
        return np.lib.format.read_array(fh, allow_pickle=False)
    except Corrupt:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, KeyError,
            NotImplementedError, RuntimeError, OverflowError) as exc:
        why = " ".join(str(exc).split())[:120]
        raise Corrupt(f"{what} cannot be read ({type(exc).__name__}: {why})") from None


def _read_header(zf: zipfile.ZipFile, registry: dict[str, type]
                 ) -> tuple[type, VibroImpactSystem, dict]:
    """(class, system, meta) from the reserved members, each checked."""
    names = zf.namelist()
    if "format.npy" not in names:
        raise Corrupt("not an fpk_vibro solution file (no 'format' member)")
    text = {}
    for key in ("format", "version", "kind", "system", "meta"):
        if key + ".npy" not in names:
            raise Corrupt(f"member {key!r} is missing")
        a = _member(zf, key)
        want = "i" if key == "version" else "U"
        if a.ndim != 0 or a.dtype.kind != want:
            raise Corrupt(f"member {key!r} must be a single {'integer' if want == 'i' else 'string'}"
                           f"; got dtype {a.dtype}, shape {a.shape}")
        text[key] = int(a) if key == "version" else str(a)
    if text["format"] != FORMAT_NAME:
        raise Corrupt(f"not an fpk_vibro solution file (format {show(text['format'])})")
    version = text["version"]
    if version > FORMAT_VERSION:
        raise Corrupt(f"format version {version} is newer than this fpk_vibro reads "
                       f"({FORMAT_VERSION})")
    if version < 1:
        raise Corrupt(f"format version must be an integer in [1, {FORMAT_VERSION}]; got {version}")
    kind = text["kind"]
    if kind not in KIND_MODULES:
        raise Corrupt(f"unknown solution kind {show(kind)}; known: {sorted(KIND_MODULES)}")
    importlib.import_module(KIND_MODULES[kind])
    target = registry.get(kind)
    if target is None:      # a package bug, not a file problem
        raise RuntimeError(f"{KIND_MODULES[kind]} defines no Solution of kind {kind!r}")
    system = _system(_json(text["system"], "system"))
    meta = _json(text["meta"], "meta")
    for key, rule in target._meta_schema.items():
        if key not in meta:
            if rule.required:
                raise Corrupt(f"meta misses key {key!r} ({rule.allowed}), needed by kind {kind!r}")
        elif not rule.ok(meta[key]):
            raise Corrupt(f"meta[{key!r}] must be {rule.allowed}; got {show(meta[key])}")
    if ESTIMATE in meta and not ESTIMATE_RULE.ok(meta[ESTIMATE]):
        raise Corrupt(f"meta[{ESTIMATE!r}] must be {ESTIMATE_RULE.allowed}; got "
                      f"{show(meta[ESTIMATE])}")
    return target, system, meta


def _json(text: str, what: str) -> dict:
    """The JSON object in member ``what``."""
    try:
        value = json.loads(text)
    except (ValueError, RecursionError) as exc:
        why = exc.args[0] if isinstance(exc, json.JSONDecodeError) else type(exc).__name__
        raise Corrupt(f"member {what!r} is not valid JSON ({why})") from None
    if not isinstance(value, dict):
        raise Corrupt(f"member {what!r} must be a JSON object; got {show(value)}")
    return value


def _system(fields: dict) -> VibroImpactSystem:
    """The system described by ``fields`` (the dataclass validates the values)."""
    known = {f.name: f for f in dataclasses.fields(VibroImpactSystem)}
    unknown = sorted(set(fields) - set(known))
    if unknown:
        raise Corrupt(f"system has unknown field(s) {unknown}")
    missing = sorted(k for k, f in known.items() if k not in fields
                     and f.default is dataclasses.MISSING)
    if missing:
        raise Corrupt(f"system misses field(s) {missing}")
    try:
        return VibroImpactSystem.from_dict(fields)
    except (ValueError, TypeError) as exc:
        raise Corrupt(f"invalid system ({exc})") from None


def _read_arrays(zf: zipfile.ZipFile, schema: dict[str, Stored]) -> dict[str, np.ndarray]:
    """The arrays of ``schema`` from the archive, each checked; no others may be present."""
    present = []
    for member in zf.namelist():
        key = member[:-4] if member.endswith(".npy") else None
        if key is None or (key not in schema and key not in RESERVED):
            raise Corrupt(f"unexpected member {show(member)}"
                           + (f"; expected {sorted(schema)}" if schema else "; expected no arrays"))
        present.append(key)
    sizes: dict[str, int] = {}
    arrays = {}
    for key, spec in schema.items():
        if key not in present:
            raise Corrupt(f"array {key!r} is missing")
        arrays[key] = a = _member(zf, key)
        _check_array(key, a, spec, sizes)
    return arrays


def _dim(expr: int | str, sizes: dict[str, int], actual: int | None) -> int | str:
    """The size ``expr`` stands for (binding its name to ``actual`` if unbound)."""
    if isinstance(expr, int):
        return expr
    m = re.fullmatch(r"(\w+)([+-]\d+)?", expr)
    name, offset = m[1], int(m[2] or 0)
    if name not in sizes:
        if actual is None:
            return expr
        sizes[name] = actual - offset
    return sizes[name] + offset


def _check_array(key: str, a: np.ndarray, spec: Stored, sizes: dict[str, int]) -> None:
    """Raise Corrupt unless ``a`` obeys ``spec``; binds the size names it introduces."""
    want = np.dtype(np.float64 if spec.dtype == "float" else np.int64)
    if a.dtype.kind != want.kind or a.dtype.itemsize != want.itemsize:
        raise Corrupt(f"array {key!r} has dtype {a.dtype}, expected {want}")
    trial = dict(sizes)
    if a.ndim == len(spec.shape):
        expected = tuple(_dim(d, trial, n) for d, n in zip(spec.shape, a.shape))
    else:
        expected = tuple(_dim(d, trial, None) for d in spec.shape)
    if a.shape != expected:
        shown = "(" + ", ".join(map(str, expected)) + ("," if len(expected) == 1 else "") + ")"
        if a.ndim != len(expected):
            shown = f"{len(expected)} ax{'i' if len(expected) == 1 else 'e'}s {shown}"
        raise Corrupt(f"array {key!r} has shape {a.shape}, expected {shown}")
    sizes.update(trial)
    if a.size < spec.min_size:
        raise Corrupt(f"array {key!r} has {a.size} value(s), expected at least {spec.min_size}")
    if spec.dtype == "int":
        if spec.below is not None and a.size and (a.min() < 0 or a.max() >= sizes[spec.below]):
            raise Corrupt(f"array {key!r} holds indices outside [0, {sizes[spec.below]})")
        return
    bad = ~np.isfinite(a) & ~(np.isnan(a) if spec.nan_ok else False)
    if bad.any():
        raise Corrupt(f"array {key!r} holds {int(bad.sum())} non-finite value(s) "
                       f"({a.flat[np.flatnonzero(bad)[0]]} at flat index {np.flatnonzero(bad)[0]})")
    if spec.nonneg and a.size:
        lowest, scale = np.nanmin(a, initial=0.0), np.nanmax(np.abs(a), initial=0.0)
        if lowest < -1e-9 * scale:
            raise Corrupt(f"array {key!r} holds negative values (min {lowest:.6g}); "
                           f"it cannot be negative")
    if spec.increasing and a.size > 1 and not np.all(np.diff(a) > 0):
        raise Corrupt(f"array {key!r} is not strictly increasing")
