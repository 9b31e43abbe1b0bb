"""Monte Carlo simulation of the vibro-impact SDE (docs/theory.md, §Monte Carlo).

Model (docs/theory.md, §Model; the paper's Eq. 1 in Itô form)::

    dx = y dt,   dy = −(c y + a x + b x³) dt + sqrt(2 D1 + 2 D2 x²) dW,
    y⁺ = −r_L(u) y⁻  at x = x_L,   y⁺ = −r_R(u) y⁻  at x = x_R,   u = |y⁻|,

on the strip x_L ≤ x ≤ x_R; either wall may be absent, and both may stand on one
side of the equilibrium (the symmetric shorthand: walls at ±Δ with one r).

Scheme
------
Each step of length h is the symmetric (Strang/BAOAB) splitting of the generator
into B (force kick, y += (h/2) F(x)), A (free flight x += (h/2) y) and O (the
Ornstein–Uhlenbeck part dy = −c y dt + sqrt(2 D(x)) dW at fixed x, solved
exactly: y ← e^{−ch} y + sqrt(D(x)(1 − e^{−2ch})/c) ξ)::

    B(h/2) A(h/2) O(h) A(h/2) B(h/2)

Every sub-flow is exact, so for smooth motion the scheme has weak order 2 (one
normal per step; the multiplicative noise only depends on x, which O does not
change, so no Itô correction arises).  The force is evaluated once per step
(the closing kick's force is reused for the next opening kick).

Impacts
-------
Only A moves x, and in A the motion is linear, so the crossing time of a wall
x_w is exact: s = (x_w − x)/y.  There the physical velocity is the stored one
corrected for the kick timing (the opening kick (h/2) F was applied in full before
the flight): y_imp = y + (s − h/2) F(x_w) in the first flight, y + s F(x_w) in
the second; y_imp → −r_w y_imp (the restitution of the wall hit), the rest of the
sub-step is flown with it, and the stored velocity is converted back so that the
closing kick ends the step right.
Without this correction the energy lost at impacts is O(h) wrong and E[H] drifts
by +0.4 % at dt = T0/120 on the paper's r = 0.92 case (+3.9 % at T0/30); with it
the measured drift is −0.27 % at T0/30, −0.07 ± 0.07 % at T0/60 and below the
0.05 % standard error at the default T0/120 (reference T0/240).
A flight may reach the other wall too (several impacts per step, in a loop).
A crossing the curved path would not make (y_imp pointing away: a graze) leaves
the path on the wall with zero velocity and counts no impact.  Paths never
leave the strip: after an impact the position is x_w ∓ r_w|y_imp|·(rest) and the
loop stops on the wall when it ends there.

Each impact is counted for its wall with its speed u = |y_imp|: per wall the
result gives the impact rate (impacts per unit time per path), the mean and
mean-square impact speed and the energy removed per unit time and per impact, the
sum of the actual losses ½ (1 − r_w(u)²) u² (a restitution law r(u) of the impact
speed, :mod:`fpk_vibro.restitution`, is applied at each located impact), each with
a standard error between batches
(:meth:`MonteCarloSolution.impacts`).  For r = 1 and D2 = 0 (Gibbs density
p ∝ exp(−c H/D1), velocity N(0, D1/c) independent of x) the rate at a wall is
the flux p_X(x_w) E[y⁺] = p_X(x_w) sqrt(D1/c)/sqrt(2π), the mean impact speed
sqrt(π D1/(2c)) and the mean square 2 D1/c; the tests check them.  Asked for
(``quantities`` including "impacts", never by default), every impact speed is also
counted in a histogram per wall, from 0 to sqrt(2 (H_max − G(x_w))):
:meth:`MonteCarloSolution.impact_speed_histogram` (edges, density, standard error
between batches) and :meth:`MonteCarloSolution.impact_speed_pdf`; in the case above
the density is Rayleigh, f(u) = (u/σ²) exp(−u²/(2σ²)), σ² = D1/c.

Chattering and inelastic collapse (r below ~0.163, or r = 0): within one
free-flight sub-step a path leaving a wall cannot return to it, so there are
at most two impacts per step on one wall; a sequence of impacts that would
accumulate in finite time (inelastic collapse) is resolved at the time-step
resolution: the path sits on the wall (x = x_w exactly) with a velocity of
order h·|F| + noise until force and noise carry it away — the physical
sticking / release motion at resolution h (where force pushes the path onto the
wall, e.g. a double well or a preloaded wall, it rests there).  r = 0 puts the
path at rest on the wall (y = 0).  In these regimes the impact *count*
(``impact_rate``, per wall in ``impacts()``) depends on h, as the true count is
infinite; densities and moments do not.  The number of impacts in one sub-step
(only large for r ≈ 1 and |y| h ≫ x_R − x_L) is bounded by ``max_impacts``; if
reached, the path stays on the wall it hit last with its reflected velocity.
The work per step is bounded, so a run never stalls.

Coloured noise
--------------
With ``external=OrnsteinUhlenbeck(tau=τ)`` (:mod:`fpk_vibro.noise`) the external
white noise is replaced by the force ζ, dζ = −ζ/τ dt + sqrt(2 D1)/τ dW1, a per-path
state like x and y, continuous at impacts.  The step is the same splitting::

    B(h/2) A(h/2) [O(h), Z(h)] A(h/2) B(h/2)

with the kicks B adding the force κ ζ (y += (h/2)(F(x) + κ ζ)), O carrying only the
parametric noise D2 x², and Z, in O's slot (they commute), the exact OU step
ζ ← e^{−h/τ} ζ + sqrt((D1/τ)(1 − e^{−2h/τ})) ξ' (one more normal per step; with D2 = 0
the only one).  The opening kick and the first flight see ζ_k, the second flight and
the closing kick ζ_{k+1}; at an impact the kick-timing correction uses the force
F(x_w) + κ ζ of its half step.  Each sub-flow is exact and the composition
symmetric: weak order 2.  κ = sqrt(tanh(u)/u), u = h/(2τ), is 1 − (h/τ)²/24 + O(h⁴)
(so the order stays 2) and makes the kicks' impulse have ζ's zero-frequency
intensity 2 D1 for every h/τ (:func:`._params.kick_gain`): with κ = 1 the bias is
about (h/τ)²/12 relative, so the step would have to resolve τ (1.3e-3 at h = τ/8,
+47 % at h = 2.5 τ); with κ it stays of the white scheme's size at any h/τ (linear
oscillator, exact discrete covariance: E[H] 3–5e-4 at h = 0.05 for τ from 0.5 to
0.002), so the default step is the white one (no τ scale).  Measured on the paper
system (r = 0.92, D2 = 0) at dt = 0.05, 0.025, 0.0125: E[H] within its 0.1 % SE of
the dt → 0 value for τ = 0.5, 0.05 and 0.02; at τ = 0.005 (h/τ = 10 at the default)
−0.1 ± 0.09 % (−0.7 % at dt = 0.1, h/τ = 20).  Paths start with ζ from its
stationary law N(0, D1/τ), independent of (x, y) (a transient's initial density
describes (x, y) only).  E[ζ²] and E[ζ y], the power ζ puts in, are sampled with
the moments: :meth:`MonteCarloSolution.coloured_moments` (E[ζ y] as κ E[ζ_k y_k],
the power of the force the kicks apply; its relative bias is O(h²) for every h/τ,
e.g. 1.9e-4 to 4.5e-4 at h = 0.05 on the linear oscillator).  As τ → 0 the
answer tends to the white-noise one of the same D1, at first order in τ where there
are walls (paper system: E[H] −3.54, −1.75, −0.76 % at τ = 0.1, 0.05, 0.025; an
impact reverses y but not ζ, so the correlation E[ζ y] built over the last τ is lost
at each impact), at τ² + c τ/2 without.  ``error_estimate()`` covers the coloured
answer as the white one: 2 SE plus the bias from a run at 2 dt with the same τ (the
bias is O(h²) at every h/τ), E[ζ y] among its figures; the paired bias run
(``error_estimate(paired=True)``) takes white noise only.

Sampling: stationary statistics are time-and-ensemble averages after a burn-in
of 6 relaxation times (6/c), one sample per path about every T0/4; transient
statistics are ensemble averages at the requested times.  Standard errors come
from the spread between independent batches of paths.

Compute only what is asked: no impact test without walls, no parametric term
when D2 = 0, only requested histograms are accumulated.

Asked for ("impact_energy", "inter_impact"), the energy each impact removes is
histogrammed per wall, and the time between successive impacts of a path (any wall;
each path's last impact is tracked from the burn-in on, so that every sampled impact
carries the complete gap before it: the gaps of the stationary impact process, with
no length bias and no censoring by the window), with its mean and per wall pair:
:meth:`MonteCarloSolution.inter_impact`; the identity mean = 1/(total impact rate)
holds within the standard errors (tested).

First passage
-------------
:func:`first_passage` leaves {H < H_c} (``energy``), {x_lo < x < x_hi}
(``displacement``: the crossing located exactly on the scheme's path, linear in
each half step) or the strip at the first impact faster than u_c
(``impact_speed``).  For the energy set it runs paths from a point, a Gaussian or
the stationary density (each conditioned on the safe set) with this same step
until H first reaches H_c, detecting crossings between step ends by a Brownian bridge of the
velocity against the band |y| < sqrt(2 (H_c − G(x))); it returns the mean time ±
its standard error, quantiles and the empirical reliability R(t) with a 95 %
band (:mod:`._first_passage` has the measured bias against dt and the handling
of paths censored at ``t_max``).

Parallelism and reproducibility: paths are split into ``n_batches`` blocks,
each with its own xoshiro256+ stream seeded by ``numpy.random.SeedSequence``;
the blocks are shared out to a thread pool (``threads``, default
``numba.get_num_threads()``: all cores) running one compiled ``nogil`` block
function, and a block's paths are advanced in a fixed order (chunks of 64 paths,
normals drawn step by step then path by path), so a seed gives
bit-identical results for any number of threads.  Standard errors come from the
spread between blocks (independent batches).

Speed (2-core AMD EPYC (Zen 3) VM shared with other jobs, numba 0.68,
measured 2026-11-22 at load average 0.4–1.3; single measurements vary by
±10 % or more, so the benchmark pairs them, see
:mod:`fpk_vibro.benchmarks.montecarlo`):

- benchmark (``fpk-vibro bench montecarlo``), one thread: kernel
  1.46–1.65·10⁸ path-steps/s with the default sampling (1.61–1.84·10⁸ without)
  against 2.9–3.3·10⁸ normals/s drawn alone by the same generator;
  kernel/floor 0.53–0.55 by wall time and 0.51–0.54 by the thread's CPU time
  (medians of 9 back-to-back pairs, over six runs).  Two threads: 1.73–2.04×
  one thread (median of pairs; it depends on the other jobs' load).
- first passage (benchmark part 4: paper r = 0.92, H_c = 0.498 from (0, 0), 16384
  paths to exit; measured 2026-11-22 at load average 0.5–1.0): 1.6–1.7·10⁸
  path-steps/s on one thread, 0.37–0.46 of the normals floor by wall time and
  0.37–0.40 by CPU time (the stationary kernel's 0.49–0.53 in the same runs); two
  threads 2.9–3.1·10⁸/s.  The extra cost is the monitor (H and the band |y| < Y(x),
  one vectorised square root per path-step) and the bridge draws (~8 %).
- cost per path-step relative to the normal alone (paired runs with parts
  switched off): the square root of the parametric noise ~9 %, sampling every
  T0/4 ~6 %, the impact paths ~3 %; the rest is the sweep's arithmetic and
  loads/stores.  Sampling every T0/4 is kept: every T0/2 raises the standard
  errors of the x and y histograms by ×1.4 (measured; T0/8 lowers them ×0.7).
- what helped (from the former 4-lane scalar kernel, 0.9·10⁸/s, ratio 0.28):
  the SIMD sweep; sampling a whole chunk per call (an inlined per-sample helper
  taking arrays cost ~30 ns of numba reference counting per sample); the
  kick-merged state (one force evaluation per step, ~7 %); bit masks instead of
  a NaN scan for the impact paths, and finishing the paths whose impact falls
  in the second flight from the stored midpoint (together ~8 %).  What did not:
  interleaving the normals with a 4-path scalar or SLP-vectorised step (1.5–2×
  slower: LLVM does not vectorise across the ziggurat's branch), chunks of
  128/256 paths, integer histogram counts, a float32 square root (numba does
  not vectorise it).
- paper r = 0.92 case to a relative SE of 0.1 % on E[H] in a fresh interpreter
  (2048 paths, ~4000–5000 time units): 5.0–7.5 s from import to result with a
  cold numba cache (5.5–8.3 s wall with interpreter start), 1.4–2.4 s warm.
"""
from ._engine import TransientRun, stationary, transient
from ._first_passage import first_passage
from ._periodic import periodic
from .crossings import CrossingRates, crossings
from .options import Options
from .solution import ALL_QUANTITIES, QUANTITIES, MonteCarloSolution
from .spectrum import spectrum

__all__ = ["Options", "stationary", "transient", "first_passage", "periodic",
           "spectrum", "crossings", "CrossingRates", "MonteCarloSolution",
           "TransientRun", "QUANTITIES", "ALL_QUANTITIES"]
