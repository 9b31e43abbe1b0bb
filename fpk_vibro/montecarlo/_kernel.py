"""Compiled (numba) kernels of the Monte Carlo engine.

Random numbers (:mod:`._rng`): one xoshiro256+ stream per block of paths
(seeded from ``numpy.random.SeedSequence.spawn``), standard normals by the
ziggurat method.  A block is simulated by one thread, in a fixed order, by
the same compiled code whatever the number of threads, so the results do not
depend on it.  The blocks are shared out to a thread pool
(:func:`._threads.run_blocks`; :func:`_run_block` is compiled ``nogil``).

The step (BAOAB splitting, see :mod:`fpk_vibro.montecarlo` for the argument)::

    B  y += (h/2) F(x)              F(x) = −(a x + b x³)
    A  x += (h/2) y                 free flight, impacts at x_L, x_R located exactly
    O  y ← e^{−c h} y + sqrt(D(x)(1 − e^{−2ch})/c) ξ     exact OU at fixed x
    A  x += (h/2) y                 (as above; :mod:`._flight`)
    B  y += (h/2) F(x)

Between steps the kernel holds v = y − (h/2) F(x) instead of y, so that the
closing B of one step and the opening B of the next are a single kick
v + h F(x) (one force evaluation per step); y is restored for sampling and on
return.  Per step, a chunk of paths draws its normals, then one branch-free
loop (:func:`_smooth_sweep`, which LLVM compiles to AVX2/SSE code) advances
every path as if no wall were hit and flags the paths whose flights left the
strip; only those (~2 % of path-steps in the paper's case) are redone by the
scalar step with exact impact handling (:func:`_step_walls`).

With coloured external noise ζ (an Ornstein–Uhlenbeck force, :mod:`fpk_vibro.noise`)
the kicks add κ ζ (B: y += (h/2)(F(x) + κ ζ), κ = 1 − (h/τ)²/24 + …,
:func:`._params.kick_gain`), O carries the parametric noise alone, and in O's slot
ζ advances exactly, ζ ← e^{−h/τ} ζ + sqrt((D1/τ)(1 − e^{−2h/τ})) ξ' (one more normal
per step): the opening kick and first flight see ζ_k, the second flight and closing
kick ζ_{k+1} (:mod:`._block`; the stored v is y − (h/2)(F(x) + κ ζ)).

``p`` and ``ip`` are the step's records :class:`._params.StepParams` (floats) and
:class:`._params.StepFlags` (integers), read by field name.  A side without a wall
has ``p.lo`` = −inf (``p.hi`` = +inf), so no flight crosses it: the kernel needs no
case for which walls exist (``ip.mode`` only records it).
"""
from __future__ import annotations

import numpy as np

from ._flight import (LEFT, NW, NX, RIGHT, W_N, W_Q, W_U, X_E, X_G0, X_GL, X_GM,  # noqa: F401
                      X_GR, X_M, X_TL, X_TR, _flight)
from ._rng import _floor_block
from ._threads import run_blocks

# the step's records (:mod:`._params`; their field positions and MODE_* stay
# importable from here), the sampling (:mod:`._sampling`), the step and the sweep
# (:mod:`._sweep`) and a block's run (:mod:`._block`)
from ._params import (I_D2, I_MAXK, I_MODE, MODE_BOTH, MODE_LEFT, MODE_NONE,  # noqa: F401
                      MODE_RIGHT, NI, NP, P_A, P_B, P_D1S2, P_D2S2, P_EC, P_FHI, P_FLO, P_GD,
                      P_H0, P_HH, P_HI, P_HIW, P_JX0, P_JXIW, P_JY0, P_JYIW, P_LO, P_R, P_RL,
                      P_SD0, P_UWL, P_UWR, P_X0, P_XIW, P_Y0, P_YIW)
from ._sampling import (M_H, M_N, M_OVH, M_OVJ, M_OVX, M_OVY, M_PIMP, M_X, M_X2,  # noqa: F401
                        M_X4, M_Y2, M_Y4, M_Z2, M_ZY, NM, _hist_index, _sample, snapshot)
from ._sweep import (CHUNK, _fma, _smooth_sweep, _step, _step_core, _step_full,  # noqa: F401
                     _step_walls)
from ._block import _run_block


def advance(xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
            mom, imp, xext, hH, hx, hy, hj, threads=None, walls=None, speeds=None,
            law=None, extra=None, last=None, energies=None, gaps=None, t0=0.0,
            periodic=None, zeta=None):
    """Advance every path by ``n_steps`` steps (in place), sampling if asked.

    Blocks run on ``threads`` workers (:func:`run_blocks`).  Within a block,
    paths are advanced CHUNK at a time by a vectorised sweep (:func:`_run_block`);
    the random numbers of a block are drawn in the order chunk, step, path from
    the block's own stream.

    Parameters
    ----------
    xs, ys : float64[n_paths]
        States, updated in place.
    rng : uint64[n_blocks, 4]
        One xoshiro256+ state per block, updated in place.
    starts : int64[n_blocks + 1]
        Block b holds paths ``starts[b]:starts[b+1]``.
    n_steps, step0, sample_every : int
        A sample is taken after step k (0-based within this call) when
        ``(step0 + k + 1) % sample_every == 0``; ``sample_every = 0`` disables it.
    p, ip : StepParams, StepFlags
        The step's records (module docstring).
    mom : float64[n_blocks, NM]
        Per-block sums of the sampled moments (``M_*`` columns).
    imp : float64[n_blocks, 2]
        Per-block impact count (both walls) and path-steps advanced.
    xext : float64[n_blocks, 2]
        Per-block min and max of x over the samples taken.
    hH, hx, hy, hj : float64 arrays
        Per-block histogram counts; a zero-length bin axis means "not requested".
    threads : int, optional
        Worker threads (default :func:`numba.get_num_threads`, i.e. all cores
        unless changed); the result does not depend on it.
    walls : float64[n_blocks, 2, NW], optional
        Per-block wall statistics, added to: ``walls[b, side, W_N]`` impacts,
        ``W_U`` Σ u, ``W_Q`` Σ u² (u the speed before impact; side 0 left, 1
        right).  Default: not kept.
    speeds : float64[n_blocks, 2, m], optional
        Per-block impact-speed histograms, added to (:mod:`._flight`; bin widths
        1/``p.u_iw_left``, 1/``p.u_iw_right``, column m − 1 the speeds beyond).  Default
        (or m = 0): not kept.
    law : float64 array, optional
        The walls' restitution packed (:func:`._params.wall_laws`); default the
        constants ``p.r_left``, ``p.r_right``.
    extra : float64[n_blocks, 2, NX], optional
        Per-block further wall statistics, added to (:mod:`._flight`: the energy the
        impacts remove, the largest impact speed in ``[b, 0, X_M]``, the gaps
        between impacts).
        Default: not kept.
    last : float64[n_paths, 2], optional
        Each path's last impact (time relative to now, −inf: none; wall 0 left, 1
        right), updated; then the gaps between impacts are counted in ``extra``
        (:mod:`._flight`).  Default: not tracked.
    energies : float64[n_blocks, 2, m], optional
        Per-block histograms of the energy each impact removes (bin widths
        1/``p.e_iw_left``, 1/``p.e_iw_right``).  Default: not kept.
    gaps : float64[n_blocks, 1, m], optional
        Per-block histogram of the gaps between successive impacts of a path (bin
        width 1/``p.g_iw``).  Default: not kept.
    t0 : float, optional
        The time of the states on entry: with forcing (``ip.forced``) the kick at
        t_k = t0 + k h adds h F cos(Ω t_k + φ0) (the merged closing and opening
        kicks, both at t_k; ``p.f_amp``, ``p.f_omega``, ``p.f_phase``).
    periodic : tuple, optional
        (M, slot_of, step_slot, s_avg, mh, xeh, pimp): phase-resolved sampling over a
        period of M steps (:mod:`._periodic`).  ``step0`` is then the grid index of
        the entry state (mod M) and ``sample_every`` is ignored.  After a step from
        grid point g to g + 1 (mod M): its impacts go to ``pimp[step_slot[g]·B + b]``
        (columns 0–3 count, Σu, Σu², Σe per side, column 4 of side 0 the path-steps);
        the new state is sampled into row ``slot_of[g + 1]·B + b`` of ``mom``,
        ``xext`` and the histograms (B blocks; −1: not sampled), and where
        (g + 1) % s_avg = 0 into their last B rows (the period average) and, moments
        only, into ``mh[((g + 1) // s_avg)·B + b]`` (``xeh`` its x range).
    zeta : float64[n_paths], optional
        With coloured external noise (``ip.coloured``): each path's force ζ, updated in
        place (the kicks add it; it advances exactly over each step,
        :mod:`._block`); the samples add Σζ² and Σζy to ``mom``.  Default: white noise.
    """
    nb = rng.shape[0]
    if walls is None:
        walls = np.zeros((nb, 2, NW))
    if speeds is None:
        speeds = np.zeros((nb, 2, 0))
    if law is None:
        law = np.array([0.0, p.r_left, 0.0, 1.0, 0.0, 12.0,
                        0.0, p.r_right, 0.0, 1.0, 0.0, 12.0])
    if extra is None:
        extra = np.zeros((nb, 2, NX))
    asked = None
    if last is not None or (energies is not None and energies.shape[2] > 0) or \
            (gaps is not None and gaps.shape[2] > 0):
        asked = (np.zeros((0, 2)) if last is None else last,
                 np.zeros((nb, 2, 0)) if energies is None else energies,
                 np.zeros((nb, 1, 0)) if gaps is None else gaps)
    if ip.forced:
        gtab = p.f_amp * np.cos(p.f_omega * (t0 + 2.0 * p.hh * np.arange(n_steps + 1))
                                + p.f_phase)
    else:
        gtab = np.zeros(0)
    per = None
    if periodic is not None:
        per = tuple(periodic) + (np.zeros((1, 0)), np.zeros((1, 0, 0)))
        sample_every = 0
    if (zeta is not None) != bool(ip.coloured):
        raise ValueError("advance: zeta (the paths' ζ) is given exactly for a coloured "
                         "system (ip.coloured)")
    zeta = np.zeros(0) if zeta is None else zeta
    run_blocks(_run_block, nb, (xs, ys, rng, starts, n_steps, step0, sample_every, p, ip,
                                mom, imp, xext, hH, hx, hy, hj, walls, speeds, law, extra,
                                asked, gtab, per, zeta), threads)


def normals_floor(rng, per_block, threads=None):
    """Draw ``per_block`` normals from each block's stream (the RNG's own rate).

    The same generator, the same blocking and the same thread-pool dispatch as
    :func:`advance`; returns the per-block sums (so nothing is optimised away).
    """
    return np.array(run_blocks(_floor_block, rng.shape[0], (rng, per_block), threads))
