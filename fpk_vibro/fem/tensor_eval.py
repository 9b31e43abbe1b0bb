"""p_h on the structured tensor mesh: point values, element quadrature and the level
split, without skfem's 2-D basis or its inverse map.

On the default mesh (the rectilinear grid ``xs × ys`` of quadrilaterals,
:func:`fpk_vibro.fem.mesh.structured_mesh`) the density is

    p_h(x, y) = Σ_ab P[a, b] ψ_a(x) χ_b(y)

with ψ, χ the 1-D Lagrange bases of the degree on the x- and y-nodes.  So

- a point is located by ``np.searchsorted`` in ``xs`` and ``ys`` (O(log n), no
  inverse bilinear map: on a rectangle the reference coordinates are affine in x
  and in y), and p_h there is the contraction of the 1-D basis values with the
  cell's block of P;
- the element quadrature (even moments of p_h and of p₊ = max(p_h, 0), negative
  mass, mass per cell) uses the tensor Gauss rule of order 2k + 3 that skfem's
  2-D basis uses, evaluated as two 1-D contractions per block of x-cells;
- P(H > level) repeats :func:`fpk_vibro.fem.integrals.split` and
  :func:`~fpk_vibro.fem.integrals.cut_integrals` on rectangles: the level set
  meets a horizontal edge y = y_j where G(x) = level − y_j²/2, one quartic per
  y-node (not per cell).

Every loop runs over blocks of cells of bounded size, never over single cells.
The numbers agree with the general skfem path to round-off (tests/test_fem_tensor_eval.py);
memory is O(DOFs) plus a block.  Measured at 10⁶ and 4·10⁶ DOFs:
docs/measurements.md, §Scale.
"""
from __future__ import annotations

import numpy as np

from .integrals import CUT_NY, cut_nodes, cut_pieces, potential_range, real_roots

__all__ = ["TensorField"]

#: cells (quadrature) or points (evaluation) per block: bounds the temporaries
BLOCK = 250_000


def _locate(nodes: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cell index, reference coordinate in [0, 1]) of each v in [nodes[0], nodes[-1]]."""
    c = np.clip(np.searchsorted(nodes, v, side="right") - 1, 0, nodes.size - 2)
    return c, (v - nodes[c]) / (nodes[c + 1] - nodes[c])


class TensorField:
    """p_h = Σ P[a, b] ψ_a(x) χ_b(y) on the grid ``xs × ys`` (module docstring).

    Parameters
    ----------
    xbasis, ybasis : skfem.CellBasis
        The 1-D bases on the x- and y-nodes
        (:func:`~fpk_vibro.fem.generator.assemble_tensor_bases`).
    P : ndarray, shape (xbasis.N, ybasis.N)
        The DOF values in the 1-D bases' numbering.
    """

    def __init__(self, xbasis, ybasis, P: np.ndarray):
        self.xb, self.yb, self.P = xbasis, ybasis, P
        self.xs = np.asarray(xbasis.mesh.p[0], float)
        self.ys = np.asarray(ybasis.mesh.p[0], float)
        if np.any(np.diff(self.xs) <= 0) or np.any(np.diff(self.ys) <= 0):
            raise ValueError("TensorField: the 1-D nodes must be increasing")
        # MeshLine numbers cell c from node c to node c + 1: the reference map is affine
        for b, nodes in ((xbasis, self.xs), (ybasis, self.ys)):
            t = b.mesh.t
            if not (np.array_equal(t[0], np.arange(nodes.size - 1))
                    and np.array_equal(t[1], np.arange(1, nodes.size))):
                raise ValueError("TensorField: 1-D cells not numbered left to right")
        self.dx = xbasis.element_dofs          # (local, cells)
        self.dy = ybasis.element_dofs

    # -- 1-D pieces -------------------------------------------------------------
    @staticmethod
    def _values(basis, t: np.ndarray) -> np.ndarray:
        """Local basis values at reference coordinates t: shape t.shape + (local,)."""
        flat = np.asarray(t, float).reshape(1, -1)
        return np.stack([np.asarray(basis.elem.lbasis(flat, a)[0]).reshape(np.shape(t))
                         for a in range(basis.Nbfun)], axis=-1)

    def _rule(self, basis, nodes):
        """(reference values (q, local), points (q, cells), weights (q, cells)) of
        the basis's own Gauss rule on every 1-D cell."""
        t, w = np.asarray(basis.X)[0], np.asarray(basis.W)
        h = np.diff(nodes)
        return (self._values(basis, t), nodes[:-1][None, :] + t[:, None] * h[None, :],
                w[:, None] * h[None, :])

    # -- evaluation -----------------------------------------------------------------
    def in_cells(self, i: np.ndarray, j: np.ndarray, x: np.ndarray, y: np.ndarray
                 ) -> np.ndarray:
        """p_h at points x[n, ...], y[n, ...] of cell (i[n], j[n]) (any points; the
        cell's polynomial is used)."""
        tx = (x - self.xs[i].reshape(i.shape + (1,) * (x.ndim - 1))) / \
            np.diff(self.xs)[i].reshape(i.shape + (1,) * (x.ndim - 1))
        ty = (y - self.ys[j].reshape(j.shape + (1,) * (y.ndim - 1))) / \
            np.diff(self.ys)[j].reshape(j.shape + (1,) * (y.ndim - 1))
        vx, vy = self._values(self.xb, tx), self._values(self.yb, ty)
        out = np.zeros(np.shape(x))
        shape = (-1,) + (1,) * (x.ndim - 1)
        for a in range(vx.shape[-1]):
            ia = self.dx[a, i].reshape(shape)
            for b in range(vy.shape[-1]):
                out += vx[..., a] * vy[..., b] * self.P[ia, self.dy[b, j].reshape(shape)]
        return out

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """p_h at points of the strip (1-D arrays; the caller drops outside points)."""
        out = np.empty(x.size)
        for k in range(0, x.size, BLOCK):
            i, _ = _locate(self.xs, x[k:k + BLOCK])
            j, _ = _locate(self.ys, y[k:k + BLOCK])
            out[k:k + BLOCK] = self.in_cells(i, j, x[k:k + BLOCK], y[k:k + BLOCK])
        return out

    @staticmethod
    def line(basis, nodes: np.ndarray, v: np.ndarray, coef: np.ndarray) -> np.ndarray:
        """Σ_a coef[a] φ_a(v) for the 1-D basis on ``nodes`` (v inside)."""
        c, t = _locate(nodes, v)
        vals = TensorField._values(basis, t)
        return np.einsum("na,na->n", vals, coef[basis.element_dofs[:, c].T])

    # -- element quadrature ----------------------------------------------------------
    def quadrature(self) -> dict:
        """The dict of :func:`fpk_vibro.fem.integrals.element_quadrature`, by the
        same Gauss rule; ``element_mass`` has shape (2, x-cells, y-cells)."""
        Bx, X, Wx = self._rule(self.xb, self.xs)
        By, Y, Wy = self._rule(self.yb, self.ys)
        ncx, ncy = X.shape[1], Y.shape[1]
        Xp = {2: X ** 2, 4: X ** 4}
        Yp = {2: Y ** 2, 4: Y ** 4}
        mass = np.zeros((2, ncx, ncy))
        acc = {s: {k: 0.0 for k in ("E_x2", "E_x4", "E_y2", "E_y4")} for s in ("p", "n")}
        step = max(1, BLOCK // max(ncy, 1))
        for i0 in range(0, ncx, step):
            sl = slice(i0, min(i0 + step, ncx))
            # x first: A[q, i, :] = Σ_a Bx[q, a] P[dx[a, i], :]
            A = np.einsum("qa,ain->qin", Bx, self.P[self.dx[:, sl]])
            # then y: V[q, i, r, j] = Σ_b By[r, b] A[q, i, dy[b, j]]
            V = np.einsum("rb,qibj->qirj", By, A[:, :, self.dy])
            W = Wx[:, sl][:, :, None, None] * Wy[None, None, :, :]
            wp = np.maximum(V, 0.0) * W
            wn = np.minimum(V, 0.0) * W
            for s, w in (("p", wp), ("n", wn)):
                acc[s]["E_x2"] += float(np.einsum("qirj,qi->", w, Xp[2][:, sl]))
                acc[s]["E_x4"] += float(np.einsum("qirj,qi->", w, Xp[4][:, sl]))
                acc[s]["E_y2"] += float(np.einsum("qirj,rj->", w, Yp[2]))
                acc[s]["E_y4"] += float(np.einsum("qirj,rj->", w, Yp[4]))
            mass[1, sl] = wp.sum(axis=(0, 2))
            mass[0, sl] = mass[1, sl] + wn.sum(axis=(0, 2))
        mp = float(mass[1].sum())
        mn = float(mass[0].sum()) - mp
        keys = ("E_x2", "E_x4", "E_y2", "E_y4")
        return {"positive": {k: acc["p"][k] / mp for k in keys},
                "signed": {k: (acc["p"][k] + acc["n"][k]) / (mp + mn) for k in keys},
                "negative_mass": abs(mn) / (mp + mn),
                "element_mass": mass}

    # -- P(H > level) --------------------------------------------------------------------
    def split(self, system, level: float, element_mass: np.ndarray) -> np.ndarray:
        """[[above, below] of p_h, [above, below] of p₊] (:func:`fpk_vibro.fem.integrals.split`
        on rectangles); ``element_mass`` from :meth:`quadrature`."""
        xlo, xhi, ylo, yhi = self.xs[:-1], self.xs[1:], self.ys[:-1], self.ys[1:]
        Gmin, Gmax = potential_range(system, xlo, xhi)
        y2min = 0.5 * np.where((ylo <= 0) & (yhi >= 0), 0.0, np.minimum(ylo ** 2, yhi ** 2))
        y2max = 0.5 * np.maximum(ylo ** 2, yhi ** 2)
        above = Gmin[:, None] + y2min[None, :] >= level
        below = Gmax[:, None] + y2max[None, :] <= level
        whole = np.stack([element_mass[:, above].sum(axis=1),
                          element_mass[:, below].sum(axis=1)], axis=1)
        ci, cj = np.nonzero(~above & ~below)
        return whole + self.cut(system, ci, cj, level)

    def cut(self, system, ci: np.ndarray, cj: np.ndarray, level: float,
            chunk: int = 2_000) -> np.ndarray:
        """:func:`fpk_vibro.fem.integrals.cut_integrals` over the rectangles (ci, cj)."""
        total = np.zeros((2, 2))
        if ci.size == 0:
            return total
        s = system
        # the level set meets y = y_j where b/4 x⁴ + a/2 x² + y_j²/2 − level = 0
        yn = self.ys
        if s.b != 0:
            coef = np.stack([np.full_like(yn, 0.25 * s.b), np.zeros_like(yn),
                             np.full_like(yn, 0.5 * s.a), np.zeros_like(yn),
                             0.5 * yn * yn - level], axis=1)
        elif s.a != 0:
            coef = np.stack([np.full_like(yn, 0.5 * s.a), np.zeros_like(yn),
                             0.5 * yn * yn - level], axis=1)
        else:
            coef = np.tile([1.0, 0.0, 1.0], (yn.size, 1))
        yroots = real_roots(coef)                           # (ny + 1, d)
        x0, x1 = self.xs[ci], self.xs[ci + 1]
        piece, xa, xb = cut_pieces(s, level, np.concatenate(
            [x0[:, None], x1[:, None], yroots[cj], yroots[cj + 1]], axis=1), x0, x1)
        u, wu = np.polynomial.legendre.leggauss(CUT_NY)
        for k in range(0, piece.size, chunk):
            c = piece[k:k + chunk]
            xq, wx = cut_nodes(xa[k:k + chunk], xb[k:k + chunk])             # (n, NX)
            ylo, yhi = self.ys[cj[c]][:, None], self.ys[cj[c] + 1][:, None]
            Y = np.sqrt(np.maximum(2.0 * (level - s.potential(xq)), 0.0))
            lo = np.stack([np.broadcast_to(ylo, Y.shape), np.maximum(ylo, Y),
                           np.maximum(ylo, -Y)])                     # above, above, below
            hi = np.stack([np.minimum(yhi, -Y), np.broadcast_to(yhi, Y.shape),
                           np.minimum(yhi, Y)])
            lo = np.minimum(lo, yhi)
            L = np.maximum(hi - lo, 0.0)
            yq = lo[..., None] + 0.5 * L[..., None] * (1.0 + u)       # (3, n, NX, NY)
            w = 0.5 * L[..., None] * wu * wx[None, :, :, None]
            xs = np.broadcast_to(xq[None, :, :, None], yq.shape)
            p = self.in_cells(ci[c], cj[c], xs.transpose(1, 0, 2, 3).reshape(c.size, -1),
                              yq.transpose(1, 0, 2, 3).reshape(c.size, -1))
            w = w.transpose(1, 0, 2, 3).reshape(c.size, 3, -1)
            for row, f in enumerate((p, np.maximum(p, 0.0))):
                fw = f.reshape(c.size, 3, -1) * w
                total[row] += [fw[:, :2].sum(), fw[:, 2].sum()]
        return total
