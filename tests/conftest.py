from __future__ import annotations

import numpy as np
import pytest

from fpk_vibro import VibroImpactSystem


@pytest.fixture
def paper92():
    return VibroImpactSystem.paper(r=0.92)


def paper_tables(D2: float | None = 0.01, r: float = 0.92) -> str:
    """The paper's system as a scene's [system] and [barriers] tables (D2 None: not
    written, the model's default), for the scenes the tests write."""
    d2 = "" if D2 is None else f"D2 = {D2!r}\n"
    return ("[system]\na = 1.0\nb = 0.2\nc = 0.025\nD1 = 0.01\n" + d2 +
            f"\n[barriers]\ndelta = 0.6\nr = {r!r}\n")


def gibbs_cases():
    """Systems where r = 1 (or no barrier) and D2 = 0: exact Gibbs density."""
    return {
        "paper": VibroImpactSystem.paper(r=1.0, D2=0.0),
        "softening": VibroImpactSystem.paper(r=1.0, D2=0.0, b=-0.5, D1=0.05),
        "unilateral": VibroImpactSystem.paper(r=1.0, D2=0.0, barriers="right"),
        "no_barrier": VibroImpactSystem(a=1.0, b=0.2, c=0.05, D1=0.02, barriers="none"),
        "quartic": VibroImpactSystem(a=0.0, b=1.0, c=0.05, D1=0.02, delta=0.5),
        "wide": VibroImpactSystem.paper(r=1.0, D2=0.0, delta=3.0),
    }


def averaging_cases():
    """Systems covering every branch of the averaged solution."""
    return {
        "paper_0.92": VibroImpactSystem.paper(r=0.92),
        "paper_0.98": VibroImpactSystem.paper(r=0.98),
        "r0.3_c0.1": VibroImpactSystem.paper(r=0.3, c=0.1),
        "r0": VibroImpactSystem.paper(r=0.0, D1=0.002),
        "unilateral": VibroImpactSystem.paper(r=0.5, barriers="right"),
        "no_barrier_D2": VibroImpactSystem.paper(barriers="none"),
        "softening_above_max": VibroImpactSystem.paper(r=0.5, b=-0.5, D1=0.2),
        "no_damping": VibroImpactSystem.paper(r=0.5, c=0.0),
        "quartic": VibroImpactSystem(a=0.0, b=1.0, c=0.05, D1=0.02, D2=0.01, delta=0.5, r=0.9),
    }


def quad_total(f, lo, hi, breaks=()):
    """∫ f over [lo, hi] with adaptive quadrature split at the given points."""
    from scipy.integrate import quad
    pts = [lo] + sorted(b for b in breaks if lo < b < hi) + [hi]
    return sum(quad(lambda t: float(f(np.array(t))), u, v, epsabs=1e-14, epsrel=1e-12,
                    limit=400)[0] for u, v in zip(pts[:-1], pts[1:]))


def gauss_total(f, breaks, n=400):
    """∫ f over consecutive intervals of ``breaks`` with n-point Gauss–Legendre each (vectorised)."""
    t, w = np.polynomial.legendre.leggauss(n)
    b = np.asarray(sorted(breaks), dtype=float)
    mid, half = 0.5 * (b[1:] + b[:-1]), 0.5 * (b[1:] - b[:-1])
    x = (mid[:, None] + half[:, None] * t).ravel()
    return float(np.sum((half[:, None] * w).ravel() * f(x)))
