"""Welch averages of sampled paths, streamed, per batch of paths (numpy/scipy FFTs).

A stream of samples q_k (interval Δ) arrives in chunks of ``half`` = N/2 samples per
path.  Each chunk closes one segment of N samples (the previous chunk and this one:
segments overlap by half), which is Hann-windowed and transformed (``scipy.fft.rfft``
along the rows, a batch at a time); |X|² and X are summed per batch.  The chunk alone
is also a half-length segment (its own Hann window): the estimate at N/2, whose
difference from the one at N measures the window's resolution bias.

With w the window and U = Σ w², the periodogram Δ |X(ω_j)|² / (2π U) estimates the
two-sided density per rad/s at ω_j = 2π j/(N Δ) (white noise of variance σ² gives
σ² Δ/2π, whose integral over |ω| < π/Δ is σ²).  The correlation R(kΔ) of the centred
stream is the inverse transform of the mean |X|² (the windowed circular
autocorrelation) over the window's own autocorrelation Σ_n w_n w_{n+k}, for
k ≤ N/2 (the wrap-around pairs lie N − k ≥ N/2 samples apart, where R has decayed
for the segments :mod:`.spectrum` chooses).

The stream's mean m is subtracted exactly at the end: the chunks arrive minus an
``offset`` (a first guess), and |X − δ W|² = |X|² − 2δ Re(W̄ X) + δ² |W|² with
δ = m − offset, W the window's transform, is a sum over segments of |X|², X and a
count (:meth:`Welch.power`).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import fft as sfft
from scipy.signal import correlate, get_window

__all__ = ["Welch"]

#: Samples transformed at once, at most (the memory of one FFT batch).
FFT_BATCH = 1 << 22


class Welch:
    """Per-batch Welch sums of a stream (module docstring).

    Parameters
    ----------
    nseg : int
        Segment length N (even).
    starts : int64[nb + 1]
        Batch b holds rows ``starts[b]:starts[b + 1]``.
    interval : float
        Δ, the sampling interval.
    offset : float
        Subtracted from the samples before the transforms (the stream's mean, or a
        guess of it).
    half : bool
        Also keep the half-length segments' sums.
    workers : int
        Threads of the transforms (``scipy.fft``; −1: all cores).
    """

    def __init__(self, nseg: int, starts: np.ndarray, interval: float, offset: float = 0.0,
                 half: bool = True, workers: int = -1) -> None:
        self.workers = int(workers)
        self.nseg, self.half_len = int(nseg), int(nseg) // 2
        self.starts = np.asarray(starts)
        self.interval = float(interval)
        self.offset = float(offset)
        nb = self.starts.size - 1
        self.w = get_window("hann", self.nseg)
        nf = self.nseg // 2 + 1
        self.P = np.zeros((nb, nf))
        self.X = np.zeros((nb, nf), dtype=complex)
        self.n = np.zeros(nb)
        self.keep_half = half
        if half:
            self.wh = get_window("hann", self.half_len)
            nh = self.half_len // 2 + 1
            self.Ph = np.zeros((nb, nh))
            self.Xh = np.zeros((nb, nh), dtype=complex)
            self.nh = np.zeros(nb)
        self.sum = np.zeros(nb)          # Σ (q − offset) and Σ (q − offset)² per batch
        self.sum2 = np.zeros(nb)
        self.count = np.zeros(nb)
        self.carry: np.ndarray | None = None

    def push(self, chunk: np.ndarray) -> None:
        """A chunk of ``half`` samples of every path (rows in batch order)."""
        q = np.asarray(chunk, dtype=float) - self.offset
        if q.shape[1] != self.half_len:
            raise ValueError(f"Welch.push: chunks of {self.half_len} samples; got "
                             f"{q.shape[1]}")
        for b in range(self.starts.size - 1):
            rows = q[self.starts[b]:self.starts[b + 1]]
            self.sum[b] += rows.sum()
            self.sum2[b] += np.square(rows).sum()
            self.count[b] += rows.size
            if self.keep_half:
                self._add(rows, self.wh, self.Ph, self.Xh, self.nh, b)
            if self.carry is not None:
                prev = self.carry[self.starts[b]:self.starts[b + 1]]
                self._add(np.concatenate([prev, rows], axis=1), self.w, self.P, self.X,
                          self.n, b)
        self.carry = q

    def _add(self, seg: np.ndarray, w: np.ndarray, P: np.ndarray, X: np.ndarray,
             n: np.ndarray, b: int) -> None:
        step = max(1, FFT_BATCH // max(seg.shape[1], 1))
        for r0 in range(0, seg.shape[0], step):
            F = sfft.rfft(seg[r0:r0 + step] * w, axis=1, workers=self.workers)
            P[b] += (F.real ** 2 + F.imag ** 2).sum(axis=0)
            X[b] += F.sum(axis=0)
        n[b] += seg.shape[0]

    # -- results --------------------------------------------------------------------
    @property
    def segments(self) -> float:
        return float(self.n.sum())

    def mean(self) -> float:
        """The stream's mean (all batches)."""
        return self.offset + float(self.sum.sum() / self.count.sum())

    def power(self, mean: float | None, which: str = "full") -> np.ndarray:
        """Σ over segments of |X|² per batch, of the stream minus ``mean`` (None: the
        offset itself is the mean)."""
        P, X, n, w = ((self.P, self.X, self.n, self.w) if which == "full" else
                      (self.Ph, self.Xh, self.nh, self.wh))
        if mean is None or mean == self.offset:
            return P.copy()
        d = mean - self.offset
        W = sfft.rfft(w)
        return P - 2.0 * d * (np.conj(W) * X).real + d * d * n[:, None] * np.abs(W) ** 2

    def density(self, P: np.ndarray, which: str = "full") -> tuple[np.ndarray, np.ndarray]:
        """(ω_j, per-batch two-sided densities S_b(ω_j)) from per-batch sums ``P``."""
        w, n = (self.w, self.n) if which == "full" else (self.wh, self.nh)
        N = w.size
        omega = 2.0 * math.pi * np.arange(N // 2 + 1) / (N * self.interval)
        S = P * self.interval / (2.0 * math.pi * np.sum(w * w)) / np.maximum(n, 1)[:, None]
        return omega, S

    def correlation(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lags kΔ for k ≤ N/2, per-batch R_b(kΔ)) from per-batch sums ``P`` (full)."""
        N = self.nseg
        K = N // 2
        c = sfft.irfft(P / np.maximum(self.n, 1)[:, None], n=N, axis=1)[:, :K + 1]
        wacf = correlate(self.w, self.w, mode="full", method="fft")[N - 1:N + K]
        return np.arange(K + 1) * self.interval, c / wacf

    def variance(self, mean: float) -> np.ndarray:
        """Per-batch sample variance about ``mean``."""
        d = mean - self.offset
        with np.errstate(invalid="ignore", divide="ignore"):
            return (self.sum2 - 2.0 * d * self.sum + d * d * self.count) / self.count
