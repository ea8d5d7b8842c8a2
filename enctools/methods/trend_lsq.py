"""Least squares with a polynomial trend per group, streamed in constant memory.

A model ``y = T_g beta_g + X c``: columns X shared by all samples (e.g. the
harmonics of an interpolation error), and per group g (a run of a sweep, a window of
a continuous run) a nuisance trend T_g, Legendre polynomials of a coordinate. The
trends are projected out group by group (Frisch-Waugh), so only the moments of the
open groups and the normal equations of X are held, whatever the input's length.
Used by :mod:`enctools.methods.interp.fit` (seed 000 eqs. (19), (20)).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


class TrendProjectedLSQ:
    """Least squares y = T_g beta_g + X c with a polynomial trend per group, in constant memory.

    Each group g (a run of a sweep, a window of a continuous run) has its own trend
    T_g: Legendre polynomials 0..degree of a coordinate z (the angle scaled to
    about [-1, 1]). The shared columns X (the harmonics) are fitted jointly with
    every trend by projecting the trends out (Frisch-Waugh): with Q_g an orthonormal
    basis of T_g, the normal equations of c are

        sum_g [(I - Q Q^T) X]^T [(I - Q Q^T) X] c = sum_g [(I - Q Q^T) X]^T y,

    and ``(I - QQ^T)`` applied to a group is X^T X - (T^T X)^T (T^T T)^+ (T^T X):
    only the moments T^T T, T^T X, T^T y of a group are kept until it closes,
    then folded into X^T X, X^T y, y^T y of the harmonic columns alone. The result
    is the joint least-squares fit with per-group trends, to rounding.

    ``consecutive``: groups are windows met in order; a group closes as soon as a
    batch ends past it (memory does not grow with the length of the input).
    Otherwise (a sweep's runs, few) every group stays open until :meth:`close_all`.
    ``on_close(counts, lo, hi)`` receives, for the groups that close, their counts
    (groups, 1 + n_labels): the samples, then the samples of each label given to
    :meth:`add` (e.g. the quarter of the signal period a sample's phase lies in), and
    the least/greatest ``x``.
    """

    def __init__(self, n_cols: int, degree: int, consecutive: bool,
                 on_close: Callable[[np.ndarray, np.ndarray, np.ndarray], None] | None = None,
                 n_labels: int = 0) -> None:
        self.p = n_cols
        self.d1 = degree + 1
        self.consecutive = consecutive
        self.on_close = on_close
        self.n_labels = n_labels
        self.xtx = np.zeros((n_cols, n_cols))
        self.xty = np.zeros(n_cols)
        self.yty = 0.0
        self.raw_ss = np.zeros(n_cols)    # sums of squares of the columns before projection
        self.n = 0
        self.n_trend = 0
        self.groups = 0
        d1 = self.d1
        self._width = d1 * d1 + d1 * n_cols + d1 + n_labels
        self._keys = np.zeros(0, dtype=np.int64)
        self._mom = np.zeros((0, self._width))
        self._y0 = np.zeros(0)
        self._x0 = np.zeros(0)
        self._lo = np.zeros(0)
        self._hi = np.zeros(0)

    def add(self, x_rows: np.ndarray, y: np.ndarray, x: np.ndarray, keys: np.ndarray,
            scale: float, centre: np.ndarray | None = None,
            labels: np.ndarray | None = None) -> None:
        """Add m samples: the columns X transposed, ``x_rows`` (p, m); data ``y`` (m);
        trend abscissa ``x`` (m); group ``keys`` (m); ``labels`` (m) integers in
        [0, n_labels) counted per group, or None.

        The trend coordinate is z = (x - centre) / scale, ``centre`` per sample, or
        (None) the first x of the sample's group.
        """
        m = y.size
        if m == 0:
            return
        uk, first, inv, lo, hi = _groups(keys, x)
        y0, x0 = y[first].astype(np.float64), x[first].astype(np.float64)
        mom = np.zeros((uk.size, self._width))
        # groups still open from earlier batches keep their anchors and moments
        where = np.searchsorted(uk, self._keys)             # uk is sorted
        old = np.flatnonzero(uk[np.minimum(where, uk.size - 1)] == self._keys)
        where = where[old]
        y0[where], x0[where] = self._y0[old], self._x0[old]
        lo[where] = np.minimum(lo[where], self._lo[old])
        hi[where] = np.maximum(hi[where], self._hi[old])
        mom[where] = self._mom[old]
        # y less its group's first value: a constant of the trend, kept out of the
        # sums of squares so that they do not cancel
        yc = y - y0[inv]
        z = (x - (x0[inv] if centre is None else centre)) / scale
        xt = np.ascontiguousarray(x_rows, dtype=np.float64)               # (p, m)
        mom += self._moments(z, xt, yc, labels, inv, uk.size)
        g = xt @ xt.T
        self.xtx += g
        self.raw_ss += np.diagonal(g)
        self.xty += xt @ yc
        self.yty += float(yc @ yc)
        self.n += m
        self._hold(old, uk, mom, y0, x0, lo, hi, keys[-1])

    def _moments(self, z: np.ndarray, xt: np.ndarray, yc: np.ndarray, labels: np.ndarray | None,
                 inv: np.ndarray, n_groups: int) -> np.ndarray:
        """The sums T^T T, T^T X, T^T y and the label counts of each group: (groups, width).

        ``add.reduceat`` over the samples (columns) of each group, row by row: X is
        summed without a copy for the constant polynomial (t_0 = 1, whose own sums are
        the counts), and only the distinct products t_i t_j are formed.
        """
        d1, p, m = self.d1, self.p, z.size
        if not bool(np.all(inv[1:] >= inv[:-1])):  # a sweep's runs interleaved: sort once
            order = np.argsort(inv, kind="stable")
            inv, z, xt, yc = inv[order], z[order], xt[:, order], yc[order]
            labels = None if labels is None else labels[order]
        starts = np.searchsorted(inv, np.arange(n_groups))
        # t_1 .. t_degree (t_0 = 1)
        tz = list(np.polynomial.legendre.legvander(z, d1 - 1).T[1:]) if d1 > 2 else [z][:d1 - 1]

        def sums(row: np.ndarray) -> np.ndarray:
            return np.add.reduceat(row, starts, axis=-1)

        mom = np.zeros((n_groups, self._width))
        gram = mom[:, :d1 * d1].reshape(n_groups, d1, d1)
        gram[:, 0, 0] = np.diff(np.append(starts, m))
        for i in range(1, d1):
            gram[:, 0, i] = gram[:, i, 0] = sums(tz[i - 1])
            for j in range(i, d1):
                gram[:, i, j] = gram[:, j, i] = sums(tz[i - 1] * tz[j - 1])
        tx, ty = d1 * d1, d1 * (d1 + p)      # where T^T X and T^T y start in a row
        mom[:, tx:tx + p] = sums(xt).T
        mom[:, ty] = sums(yc)
        for i in range(1, d1):
            mom[:, tx + i * p:tx + (i + 1) * p] = sums(xt * tz[i - 1]).T
            mom[:, ty + i] = sums(yc * tz[i - 1])
        if self.n_labels and labels is not None:
            counted = np.bincount(inv * self.n_labels + labels, minlength=n_groups * self.n_labels)
            mom[:, ty + d1:] = counted.reshape(n_groups, self.n_labels)
        return mom

    def _hold(self, old: np.ndarray, uk: np.ndarray, mom: np.ndarray, y0: np.ndarray,
              x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, last_key: np.integer) -> None:
        """Keep the batch's groups open with those not met (``old``: open groups met again).

        ``consecutive``: every group but the one of ``last_key`` closes now.
        """
        keep_old = np.ones(self._keys.size, dtype=bool)
        keep_old[old] = False
        keys_all = np.concatenate([self._keys[keep_old], uk])
        parts = [(self._mom[keep_old], mom), (self._y0[keep_old], y0), (self._x0[keep_old], x0),
                 (self._lo[keep_old], lo), (self._hi[keep_old], hi)]
        mom_all, y0_all, x0_all, lo_all, hi_all = (np.concatenate(p) for p in parts)
        if self.consecutive:
            last = keys_all == last_key
            self._close(mom_all[~last], lo_all[~last], hi_all[~last])
            keys_all, mom_all, y0_all, x0_all, lo_all, hi_all = (
                a[last] for a in (keys_all, mom_all, y0_all, x0_all, lo_all, hi_all))
        self._keys, self._mom, self._y0, self._x0 = keys_all, mom_all, y0_all, x0_all
        self._lo, self._hi = lo_all, hi_all

    def close_all(self) -> None:
        """Close every open group (at the end of the input)."""
        self._close(self._mom, self._lo, self._hi)
        self._keys = np.zeros(0, dtype=np.int64)
        self._mom = np.zeros((0, self._width))
        self._y0 = self._x0 = self._lo = self._hi = np.zeros(0)

    def _close(self, mom: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
        k = mom.shape[0]
        if k == 0:
            return
        d1, p = self.d1, self.p
        gram = mom[:, :d1 * d1].reshape(k, d1, d1)
        tx = mom[:, d1 * d1:d1 * d1 + d1 * p].reshape(k, d1, p)
        ty = mom[:, d1 * d1 + d1 * p:d1 * d1 + d1 * p + d1]
        basis, ok = _inverse_root(gram)                    # (T^T T)^+ = basis basis^T
        # per basis vector j: a_j = tx projected on it (k, p), b_j likewise; their
        # products summed over the groups are one matrix product each
        for j in range(d1):
            a = sum(basis[:, i, j, None] * tx[:, i] for i in range(j + 1 if d1 <= 2 else d1))
            b = sum(basis[:, i, j] * ty[:, i] for i in range(j + 1 if d1 <= 2 else d1))
            self.xtx -= a.T @ a
            self.xty -= a.T @ b
            self.yty -= float(b @ b)
        self.n_trend += int(ok.sum())
        self.groups += k
        if self.on_close is not None:
            counts = np.column_stack([gram[:, 0, 0], mom[:, self._width - self.n_labels:]])
            self.on_close(counts, lo, hi)


def _inverse_root(gram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """B with B B^T the pseudo-inverse of each Gram matrix (k, d, d), and which columns count.

    A group with fewer distinct abscissae than the degree + 1 is fitted exactly by its
    trend: directions with an eigenvalue below 1e-10 of the largest add nothing. For
    d <= 2 (a trend of degree 0 or 1, the usual) the basis is written in closed form,
    centred: 1/sqrt(n) and (z - mean z)/sqrt(S_zz), with S_zz = sum (z - mean z)^2.
    """
    k, d, _ = gram.shape
    if d > 2:
        w, v = np.linalg.eigh(gram)
        ok = w > np.maximum(w[:, -1:], 0.0) * 1e-10
        s = np.where(ok, 1.0 / np.sqrt(np.where(ok, w, 1.0)), 0.0)
        return v * s[:, None, :], ok
    n = gram[:, 0, 0]
    basis = np.zeros((k, d, d))
    ok = np.zeros((k, d), dtype=bool)
    ok[:, 0] = n > 0
    basis[:, 0, 0] = np.where(ok[:, 0], 1.0 / np.sqrt(np.where(ok[:, 0], n, 1.0)), 0.0)
    if d == 2:
        mean = gram[:, 0, 1] / np.where(ok[:, 0], n, 1.0)
        szz = gram[:, 1, 1] - mean * gram[:, 0, 1]
        # the smaller eigenvalue is det / larger >= det / trace; det = n S_zz
        trace = n + gram[:, 1, 1]
        ok[:, 1] = n * szz > 1e-10 * trace * trace
        root = np.where(ok[:, 1], 1.0 / np.sqrt(np.where(ok[:, 1], szz, 1.0)), 0.0)
        basis[:, 1, 1] = root
        basis[:, 0, 1] = -mean * root
    return basis, ok


def _groups(keys: np.ndarray, x: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The groups of a batch: keys, first sample, group of each sample, least and greatest x."""
    if bool(np.all(keys[1:] >= keys[:-1])):  # groups met in order (windows): no sort
        first = np.flatnonzero(keys[1:] != keys[:-1]) + 1
        first = np.concatenate([[0], first])
        uk = keys[first]
        inv = np.repeat(np.arange(uk.size), np.diff(np.append(first, keys.size)))
        lo = np.minimum.reduceat(x, first).astype(np.float64)
        hi = np.maximum.reduceat(x, first).astype(np.float64)
    else:
        uk, first, inv = np.unique(keys, return_index=True, return_inverse=True)
        lo = np.full(uk.size, np.inf)
        hi = np.full(uk.size, -np.inf)
        np.minimum.at(lo, inv, x)
        np.maximum.at(hi, inv, x)
    return uk, first, inv, lo, hi
