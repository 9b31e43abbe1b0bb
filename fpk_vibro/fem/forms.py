"""Weak forms of the FPK generator, written as the mathematics reads.

The FPK (docs/theory.md, §FPK on the strip) is ∂p/∂t = −∇·J with

    J = ( y p,  −(c y + a x + b x³) p − D(x) ∂p/∂y ),   D(x) = D1 + D2 x²,

and, after integration by parts against a test function q,

    ∫ ∂p/∂t q = ∫ J·∇q − B₊(p, q) − B₋(p, q).

Each interior term of ∫ J·∇q is one form below (``u`` = p the trial function,
``v`` = q the test function; skfem puts the test index on the rows).  Only the
terms active for a system are assembled.  The impact terms B± are in
:mod:`fpk_vibro.fem.impact`.

The second group are the 1-D factors of the same terms on a tensor-product mesh:
every term is (function of x) × (function of y), so its matrix is the Kronecker
product of two 1-D matrices (docs/theory.md, §Assembly and solve).
"""
from __future__ import annotations

from skfem import BilinearForm, LinearForm

__all__ = ["transport_x", "restoring", "damping", "diffusion_external",
           "diffusion_parametric", "mass", "unit",
           "weighted_mass_1d", "convection_1d", "stiffness_1d"]


# --- 2-D forms: the terms of ∫ J·∇q ---------------------------------------------
@BilinearForm
def transport_x(u, v, w):
    """∫ y p ∂q/∂x  (x-component of J: dx = y dt)."""
    y = w.x[1]
    return y * u * v.grad[0]


@BilinearForm
def restoring(u, v, w):
    """−∫ (a x + b x³) p ∂q/∂y."""
    x = w.x[0]
    return -(w.a * x + w.b * x ** 3) * u * v.grad[1]


@BilinearForm
def damping(u, v, w):
    """−∫ c y p ∂q/∂y."""
    y = w.x[1]
    return -w.c * y * u * v.grad[1]


@BilinearForm
def diffusion_external(u, v, w):
    """−∫ D1 ∂p/∂y ∂q/∂y."""
    return -w.D1 * u.grad[1] * v.grad[1]


@BilinearForm
def diffusion_parametric(u, v, w):
    """−∫ D2 x² ∂p/∂y ∂q/∂y."""
    x = w.x[0]
    return -w.D2 * x ** 2 * u.grad[1] * v.grad[1]


@BilinearForm
def mass(u, v, w):
    """∫ p q (the mass matrix M of M dp/dt = L p)."""
    return u * v


@LinearForm
def unit(v, w):
    """∫ q: the row that imposes ∫ p = 1."""
    return v


# --- 1-D factors for Kronecker assembly ------------------------------------------
def _poly(coef, s):
    """f(s) = Σ_k coef[k] s^k (every 1-D weight here is a polynomial)."""
    out = 0.0 * s
    for k, ck in enumerate(coef):
        if ck != 0:
            out = out + ck * s ** k
    return out


@BilinearForm
def weighted_mass_1d(u, v, w):
    """∫ f(s) u v ds, f the polynomial with coefficients ``w.coef``."""
    return _poly(w.coef, w.x[0]) * u * v


@BilinearForm
def convection_1d(u, v, w):
    """∫ f(s) u v' ds (the derivative on the test function, as in J·∇q)."""
    return _poly(w.coef, w.x[0]) * u * v.grad[0]


@BilinearForm
def stiffness_1d(u, v, w):
    """∫ u' v' ds."""
    return u.grad[0] * v.grad[0]
