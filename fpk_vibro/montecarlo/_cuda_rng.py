"""The GPU's random source: xoroshiro128+ per thread, Box–Muller normals.

The generator is numba's own (``numba.cuda.random``'s xoroshiro128+ arithmetic), with
the state in two registers (:func:`build`'s ``next``) rather than read and written in
global memory at every draw, and each pair of uniforms giving two Box–Muller normals
(one log, one sqrt and one sincospi for two normals on a GPU).  Streams:

- :func:`seed_states`: numba's seeding (``init_xoroshiro128p_states_cpu``: thread i
  starts 2⁶⁴·(start + i) outputs into the sequence of one seed; no overlap, but a
  serial jump per thread on the host).
- ``seed`` (:func:`seed_py`): the state of stream i of a seed from splitmix64 (the
  seeding the generator's authors recommend), computed where it is used, so a GPU
  thread seeds its path itself and a path's numbers do not depend on which thread
  runs it.

The functions are plain Python compiled for a target by :func:`build` (``njit`` for
the CPU copy the tests compare with).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["build", "seed_states", "seed_of", "seed_py", "CPU"]

_U55 = np.uint64(55)
_U9 = np.uint64(9)
_U14 = np.uint64(14)
_U36 = np.uint64(36)
_U28 = np.uint64(28)
_U11 = np.uint64(11)
_U30 = np.uint64(30)
_U27 = np.uint64(27)
_U31 = np.uint64(31)
_GOLD = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_TWO_M53 = 2.0 ** -53
_TWO_PI = 2.0 * math.pi


def seed_of(ss: np.random.SeedSequence) -> int:
    """A 64-bit seed for numba's generator from a SeedSequence."""
    return int(ss.generate_state(1, np.uint64)[0])


def seed_states(n: int, seed: int, start: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(s0, s1) uint64[n]: the states of threads start..start+n−1 of ``seed``
    (numba.cuda.random's seeding: a 2⁶⁴ jump per thread)."""
    import warnings
    from ._device import cuda
    cuda()                                  # numba.cuda with its numpy shim
    from numba.cuda.random import init_xoroshiro128p_states_cpu, xoroshiro128p_dtype
    st = np.empty(n, dtype=xoroshiro128p_dtype)
    with warnings.catch_warnings(), np.errstate(over="ignore"):
        warnings.simplefilter("ignore")     # the simulator's object-mode fallback says so
        init_xoroshiro128p_states_cpu(st, np.uint64(seed), np.uint64(start))
    return np.ascontiguousarray(st["s0"]), np.ascontiguousarray(st["s1"])


def next_py(s0, s1):
    """xoroshiro128+: (output, s0, s1)."""
    res = s0 + s1
    s1 ^= s0
    s0 = ((s0 << _U55) | (s0 >> _U9)) ^ s1 ^ (s1 << _U14)
    s1 = (s1 << _U36) | (s1 >> _U28)
    return res, s0, s1


def _mix_py(z):
    """splitmix64's output function (a bijection of the 64-bit integers)."""
    z = (z ^ (z >> _U30)) * _MIX1
    z = (z ^ (z >> _U27)) * _MIX2
    return z ^ (z >> _U31)


def seed_py(seed, i):
    """(s0, s1) of stream i: outputs 2i + 1 and 2i + 2 of splitmix64 from ``seed``
    (distinct inputs of a bijection: distinct states for distinct i)."""
    z = np.uint64(seed) + np.uint64(2) * np.uint64(i) * _GOLD
    return _mix_py(z + _GOLD), _mix_py(z + _GOLD + _GOLD)


def _sincos2pi_py(u):
    a = _TWO_PI * u
    return math.sin(a), math.cos(a)


def build(jit, sincospi=None):
    """``next``, ``uniform`` (in (0, 1]), ``normal2`` (two N(0, 1) by Box–Muller)
    and ``seed`` compiled by ``jit``.  ``sincospi(v)`` → (sin πv, cos πv) of the
    target (libdevice's on a GPU); None: math.sin and math.cos of 2πu."""
    nxt = jit(next_py)
    mix = jit(_mix_py)

    def seed(sd, i):
        z = np.uint64(sd) + np.uint64(2) * np.uint64(i) * _GOLD
        return mix(z + _GOLD), mix(z + _GOLD + _GOLD)

    seed = jit(seed)
    if sincospi is None:
        sc = jit(_sincos2pi_py)
    else:
        def sc(u):
            return sincospi(2.0 * u)
        sc = jit(sc)

    def uniform(s0, s1):
        r, s0, s1 = nxt(s0, s1)
        return (np.float64(r >> _U11) + 1.0) * _TWO_M53, s0, s1

    uniform = jit(uniform)

    def normal2(s0, s1):
        u1, s0, s1 = uniform(s0, s1)
        u2, s0, s1 = uniform(s0, s1)
        rad = math.sqrt(-2.0 * math.log(u1))
        sn, cs = sc(u2)
        return rad * cs, rad * sn, s0, s1

    normal2 = jit(normal2)

    class NS:
        pass

    ns = NS()
    ns.next, ns.uniform, ns.normal2, ns.seed = nxt, uniform, normal2, seed
    return ns


def _cpu():
    from numba import njit
    return build(njit(inline="always"))


#: The CPU compilation (the tests draw the GPU's normals with it).
CPU = _cpu()
