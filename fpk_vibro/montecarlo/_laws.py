"""A wall's restitution in compiled code: one encoding, one scalar function.

The kernels (CPU threads and the GPU) see a wall's law r(u) as plain numbers:

- ``kind``: :data:`CONSTANT` (r = ``par[0]``; also a law constant in u, so that a
  constant given as a law runs the very same arithmetic as the number), :data:`TANH`
  (r = par[0] − par[1] tanh(u/par[2])) or :data:`TABLE` (piecewise linear through
  ``tab_u``, ``tab_r``, constant beyond the ends);
- ``par``: float64[3];
- ``tab_u``, ``tab_r``: float64 arrays (length 1, unused, for the other kinds).

:func:`encode` makes these from a :class:`~fpk_vibro.wall.Wall` (or None: no wall);
:func:`restitution` is the scalar r(u), written once as a plain function so that both
targets compile it (``njit`` here, ``cuda.jit(device=True)`` on a GPU).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["CONSTANT", "TANH", "TABLE", "encode", "restitution", "restitution_py", "pack",
           "restitution_side", "restitution_side_py", "PACK_HEAD"]

CONSTANT, TANH, TABLE = 0, 1, 2


def encode(wall, u_max: float = 1e3) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """(kind, par, tab_u, tab_r) of ``wall`` (None: an elastic placeholder); a
    Python callable is tabulated up to ``u_max`` (the largest plausible impact
    speed; :meth:`fpk_vibro.restitution.Restitution.kernel_table`)."""
    one = np.zeros(1)
    if wall is None:
        return CONSTANT, np.array([1.0, 0.0, 1.0]), one, one
    law = wall.law
    if law is None or law.constant is not None:
        r = float(wall.r) if law is None else float(law.constant)
        return CONSTANT, np.array([r, 0.0, 1.0]), one, one
    if law.kind == "tanh":
        return TANH, np.array([law.r0, law.r1, law.u0]), one, one
    u, r = law.kernel_table(u_max)
    return TABLE, np.zeros(3), np.ascontiguousarray(u, float), np.ascontiguousarray(r, float)


def restitution_py(u, kind, par, tab_u, tab_r):
    """r(u) for the encoded law (plain Python: compiled by :func:`restitution`)."""
    if kind == CONSTANT:
        return par[0]
    if kind == TANH:
        return par[0] - par[1] * math.tanh(u / par[2])
    n = tab_u.shape[0]
    if u <= tab_u[0]:
        return tab_r[0]
    if u >= tab_u[n - 1]:
        return tab_r[n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:                      # bisection: tables are short or uniform
        mid = (lo + hi) // 2
        if tab_u[mid] <= u:
            lo = mid
        else:
            hi = mid
    w = (u - tab_u[lo]) / (tab_u[hi] - tab_u[lo])
    return tab_r[lo] + w * (tab_r[hi] - tab_r[lo])


def _compile():
    from numba import njit
    return njit(cache=True, inline="always")(restitution_py)


restitution = _compile()


#: Length of one wall's header in a packed buffer (:func:`pack`).
PACK_HEAD = 6


def pack(left, right, u_max: float = 1e3) -> np.ndarray:
    """Both walls' laws in one float64 buffer, for kernels that pass it per impact
    (one array instead of eight: numba counts references per array argument).

    Per side s (0 left, 1 right) at ``PACK_HEAD * s``: kind, par[0..2], the table's
    length n and its offset o (tab_u at o..o+n, tab_r at o+n..o+2n).  Read by
    :func:`restitution_side`."""
    head, tabs = [], []
    off = 2 * PACK_HEAD
    for wall in (left, right):
        kind, par, tu, tr = encode(wall, u_max)
        n = tu.size if kind == TABLE else 0
        head += [float(kind), float(par[0]), float(par[1]), float(par[2]), float(n),
                 float(off)]
        if n:
            tabs += [tu, tr]
            off += 2 * n
    return np.ascontiguousarray(np.concatenate([np.array(head)] + tabs), dtype=float)


def restitution_side_py(u, buf, side):
    """r(u) of wall ``side`` in a :func:`pack` buffer: the arithmetic of
    :func:`restitution_py`, bit for bit."""
    b = PACK_HEAD * side
    kind = buf[b]
    if kind == CONSTANT:
        return buf[b + 1]
    if kind == TANH:
        return buf[b + 1] - buf[b + 2] * math.tanh(u / buf[b + 3])
    n = int(buf[b + 4])
    o = int(buf[b + 5])
    if u <= buf[o]:
        return buf[o + n]
    if u >= buf[o + n - 1]:
        return buf[o + 2 * n - 1]
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if buf[o + mid] <= u:
            lo = mid
        else:
            hi = mid
    w = (u - buf[o + lo]) / (buf[o + hi] - buf[o + lo])
    return buf[o + n + lo] + w * (buf[o + n + hi] - buf[o + n + lo])


def _compile_side():
    from numba import njit
    return njit(cache=True, inline="always")(restitution_side_py)


restitution_side = _compile_side()
