"""The positive tensor-grid generator of the stationary FPK (:func:`positive_generator`).

The construction, part A of :mod:`fpk_vibro.fem.positivity`:

A. The positive tensor-grid generator (:func:`positive_generator`)
------------------------------------------------------------------
On the grid x_i × y_k of the structured Q1 mesh, with the dual (median) cells
of area m_i^x m_k^y (= ∫ of the Q1 hat functions) and nodal values p_ik, the
flux J (docs/theory.md, §FPK on the strip) is split into three parts, each written
as *mass moving from a node to a neighbour at a non-negative rate times p at the
source* (a generator block):

- x-transport y p: through the x-faces of the dual cells, rate |y_k| m_k^y g^x_ik
  from the upwind node (direction sign y_k);
- Hamiltonian y-drift −G(x) p, G = a x + b x³ (constant along an x-column): rate
  |G(x_i)| m_i^x g^y_ik from the upwind node;
- dissipative y part −c y p − D(x) ∂p/∂y: Scharfetter–Gummel fluxes
  (D/h) m_i^x [B(−P) p_lo − B(P) p_hi], P = −c y_face h / D, B(z) = z/(eᶻ−1) > 0
  (exact for the 1-D Ornstein–Uhlenbeck balance at any cell Péclet number);
- walls (B± of docs/theory.md, §Impact coupling): outflow |y_k| m_k^y p at the wall
  node, re-injected over the image −r·[dual cell of k] (a law: −φ(dual cell), φ(u) =
  u r(u)) and shared by overlap (:func:`wall_injection`); r = 0 puts it at y = 0.  Mass
  conservative for every r and law.

With g ≡ 1 this is first order ("first-order").  Separating the Hamiltonian
drift from the dissipative part matters: putting all of −(c y + G) into the SG
flux (the first prototype) makes SG act as upwinding with numerical diffusion
|G| h_y/2 ≫ D1, and the error was then mostly in y — exact case E[H] 0.446 at
nx = 512, ny = 64 versus 0.446 at nx = 64, ny = 128 (x-refinement useless).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..restitution import Restitution  # noqa: F401  (annotations)

__all__ = ["bernoulli", "dual_weights", "wall_injection", "positive_generator"]


def bernoulli(z: np.ndarray) -> np.ndarray:
    """B(z) = z / (eᶻ − 1) (B(0) = 1), the Scharfetter–Gummel weight; B(z) > 0."""
    z = np.asarray(z, dtype=float)
    out = np.empty_like(z)
    small = np.abs(z) < 1e-5
    zs = z[small]
    out[small] = 1.0 - 0.5 * zs + zs * zs / 12.0
    zz = z[~small]
    out[~small] = zz / np.expm1(zz)
    return out


def dual_weights(nodes: np.ndarray) -> np.ndarray:
    """Lengths of the dual (median) cells of 1-D ``nodes`` = ∫ of the P1 hat functions."""
    h = np.diff(np.asarray(nodes, dtype=float))
    m = np.zeros(h.size + 1)
    m[:-1] += 0.5 * h
    m[1:] += 0.5 * h
    return m


def wall_injection(ynodes: np.ndarray, r: "float | Restitution", side: int
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Conservative re-injection of the wall outflow (B±; docs/theory.md, §Impact coupling),
    lumped.

    The outflow node k (``side · y_k > 0``) owns the dual cell [lo_k, hi_k]; its
    outflow re-enters over the image −r·[lo_k, hi_k] (width r·(hi_k − lo_k): the
    1/r² jump of the impact condition in integrated form), shared among the dual cells j in
    proportion to the overlap.  A law r(u) (``r`` a :class:`~fpk_vibro.Restitution`):
    the image −φ([lo_k, hi_k]), φ(u) = u r(u) increasing.  For r = 0 (or a degenerate image) all of it goes
    to the node whose dual cell contains y = 0.

    Returns
    -------
    src, dst, w : ndarray
        Fraction ``w ≥ 0`` of node ``src``'s outflow re-injected at node ``dst``;
        Σ over a given src of w is 1 (to round-off) — conservation.
    """
    yn = np.asarray(ynodes, dtype=float)
    ny = yn.size
    yf = 0.5 * (yn[1:] + yn[:-1])
    lo = np.concatenate([[yn[0]], yf])
    hi = np.concatenate([yf, [yn[-1]]])
    out = np.nonzero(side * yn > 0)[0]
    if isinstance(r, (int, float)):
        a = np.minimum(-r * lo[out], -r * hi[out])
        b = np.maximum(-r * lo[out], -r * hi[out])
    else:       # a law: the image of [lo, hi] under v ↦ −sign(v) φ(|v|), φ increasing
        ends = -side * r.rebound(np.maximum(side * np.stack([lo[out], hi[out]]), 0.0))
        a, b = ends.min(axis=0), ends.max(axis=0)
    j0 = np.clip(np.searchsorted(hi, a, side="right"), 0, ny - 1)
    j1 = np.clip(np.searchsorted(lo, b, side="left") - 1, j0, ny - 1)
    cnt = j1 - j0 + 1
    src = np.repeat(out, cnt)
    start = np.cumsum(cnt) - cnt
    dst = np.repeat(j0, cnt) + (np.arange(cnt.sum()) - np.repeat(start, cnt))
    ar, br = np.repeat(a, cnt), np.repeat(b, cnt)
    width = br - ar
    degenerate = width <= 1e-14 * (yn[-1] - yn[0])
    w = np.clip(np.minimum(hi[dst], br) - np.maximum(lo[dst], ar), 0.0, None)
    w = np.where(degenerate, 0.0, w / np.where(degenerate, 1.0, width))
    if degenerate.any():
        jc = np.clip(np.searchsorted(hi, ar, side="left"), 0, ny - 1)
        w = np.where(degenerate & (dst == jc), 1.0, w)
    w = w / np.bincount(src, w, ny)[src]
    keep = w > 0
    return src[keep], dst[keep], w[keep]


def positive_generator(system, xnodes: np.ndarray, ynodes: np.ndarray, walls,
                       gx: np.ndarray | None = None, gy: np.ndarray | None = None
                       ) -> tuple[sp.csr_matrix, np.ndarray]:
    """The generator of module docstring part A on the grid ``xnodes × ynodes``.

    Parameters
    ----------
    system : VibroImpactSystem
    xnodes, ynodes : ndarray
        Increasing nodes; DOF (i, k) ↦ i·ny + k (the Q1 Kronecker order of
        :func:`fpk_vibro.fem.generator.assemble_tensor`).
    walls : sequence of 2 :class:`~fpk_vibro.fem.mesh.StripEnd`
        Left and right wall (x = xnodes[0], xnodes[-1]).
    gx, gy : ndarray (nx, ny), optional
        Non-negative flux factors of the x-transport and of the Hamiltonian
        y-drift (the limiter, part B); default 1 (first-order upwind).

    Returns
    -------
    A : csr_matrix
        ``unit ⊙ dp/dt = A p``: off-diagonals ≥ 0, column sums 0 — a generator.
    unit : ndarray
        Dual-cell areas (= ∫ φ of the Q1 hat functions): mass is ``unit @ p``.
    """
    s = system
    xn, yn = np.asarray(xnodes, float), np.asarray(ynodes, float)
    nx, ny = xn.size, yn.size
    mx, my = dual_weights(xn), dual_weights(yn)
    idx = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, vals = [], [], []

    def flux(src, dst, rate):
        """Mass moves src → dst at rate·p_src (rate ≥ 0): a generator block."""
        rate = np.broadcast_to(np.asarray(rate, dtype=float), src.shape).ravel()
        src, dst = src.ravel(), dst.ravel()
        rows.extend([src, dst])
        cols.extend([src, src])
        vals.extend([-rate, rate])

    gx = np.ones((nx, ny)) if gx is None else gx
    gy = np.ones((nx, ny)) if gy is None else gy
    # x-transport y p: flux through the x-faces of the dual cells, upwind node
    q = np.abs(yn) * my
    pos, neg = yn > 0, yn < 0
    flux(idx[:-1, pos], idx[1:, pos], (q * gx)[:-1, pos])
    flux(idx[1:, neg], idx[:-1, neg], (q * gx)[1:, neg])
    # Hamiltonian y-drift −G(x) p (constant along each column): upwind node
    G = s.a * xn + s.b * xn ** 3
    qy = np.abs(G) * mx
    up, dn = G < 0, G > 0
    flux(idx[up, :-1], idx[up, 1:], (qy[:, None] * gy)[up, :-1])
    flux(idx[dn, 1:], idx[dn, :-1], (qy[:, None] * gy)[dn, 1:])
    # dissipative y part −c y p − D(x) p_y: Scharfetter–Gummel
    D = s.noise_intensity(xn)
    hy = np.diff(yn)
    v = -s.c * 0.5 * (yn[1:] + yn[:-1])                       # (ny−1,)
    Dc = D[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        P = v[None, :] * hy[None, :] / Dc
        w_up = np.where(Dc > 0, Dc / hy * bernoulli(-P), np.maximum(v, 0.0)[None, :])
        w_dn = np.where(Dc > 0, Dc / hy * bernoulli(P), np.maximum(-v, 0.0)[None, :])
    flux(idx[:, :-1], idx[:, 1:], mx[:, None] * w_up)
    flux(idx[:, 1:], idx[:, :-1], mx[:, None] * w_dn)
    # walls: lumped outflow |y_k| my_k p, re-injected over −r·(dual cell k)
    for wall, i in zip(walls, (0, nx - 1)):
        src, dst, w = wall_injection(yn, wall.r, wall.side)
        flux(idx[i, src], idx[i, dst], q[src] * w)
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(nx * ny, nx * ny))
    return A, np.kron(mx, my)
