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
from dataclasses import dataclass, field

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

    def add(self, x_rows: np.ndarray, y: np.ndarray, x: np.ndarray, keys: np.ndarray | None,
            scale: float, centre: np.ndarray | None = None,
            labels: np.ndarray | None = None, grouping: Grouping | None = None) -> None:
        """Add m samples: the columns X transposed, ``x_rows`` (p, m) or (p + 1, m) with a
        free last row (then used for y, saving a copy; ``y`` may be that row); data
        ``y`` (m); trend abscissa ``x`` (m); group ``keys`` (m); ``labels`` (m)
        integers in [0, n_labels) counted per group, or None.

        The trend coordinate is z = (x - centre) / scale, ``centre`` per sample, or
        (None) the first x of the sample's group. ``grouping``: :func:`group_batch` of
        these keys, x, scale and centre, when several fits share them (the heads of a
        run against one reference); computed here when None.
        """
        m = y.size
        if m == 0:
            return
        if grouping is None:
            assert keys is not None, "keys or their grouping"
            grouping = group_batch(keys, x, self.d1 - 1, scale, centre)
        g = grouping
        uk, lo, hi = g.keys, g.lo.copy(), g.hi.copy()
        y0, x0 = y[g.first].astype(np.float64), x[g.first].astype(np.float64)
        mom = np.zeros((uk.size, self._width))
        # groups still open from earlier batches keep their anchors and moments
        where = np.searchsorted(uk, self._keys)             # uk is sorted
        old = np.flatnonzero(uk[np.minimum(where, uk.size - 1)] == self._keys)
        where = where[old]
        y0[where], x0[where] = self._y0[old], self._x0[old]
        lo[where] = np.minimum(lo[where], self._lo[old])
        hi[where] = np.maximum(hi[where], self._hi[old])
        mom[where] = self._mom[old]
        tz, gram = g.tz, g.gram
        if g.z is None:  # centred on each group's first x: this fit's anchors
            z = (x - x0[g.inv]) / scale
            if g.order is not None:
                z = z[g.order]
            tz, gram = _trend_rows(z, self.d1), _gram(_trend_rows(z, self.d1), g)
        # the rows X and y less its group's first value (a constant of the trend, kept
        # out of the sums of squares so that they do not cancel), as one array
        xy = x_rows if x_rows.shape[0] == self.p + 1 else np.empty((self.p + 1, m))
        if xy is not x_rows:
            xy[:self.p] = x_rows
        np.subtract(y, y0[g.inv] if g.order is not None or not g.sorted
                    else np.repeat(y0, g.counts), out=xy[self.p])
        if g.order is not None:  # a sweep's runs interleaved: sorted by group once
            xy = xy[:, g.order]
            labels = None if labels is None else labels[g.order]
        mom += self._moments(xy, tz, gram, labels, g)
        cross = xy @ xy.T                                  # X^T X, X^T y, y^T y at once
        p = self.p
        self.xtx += cross[:p, :p]
        self.raw_ss += np.diagonal(cross)[:p]
        self.xty += cross[:p, p]
        self.yty += float(cross[p, p])
        self.n += m
        self._hold(old, uk, mom, y0, x0, lo, hi, g.last)

    def _moments(self, xy: np.ndarray, tz: list[np.ndarray], gram: np.ndarray,
                 labels: np.ndarray | None, g: Grouping) -> np.ndarray:
        """The sums T^T T, T^T X, T^T y and the label counts of each group: (groups, width).

        ``add.reduceat`` over the samples (columns) of each group: the rows of X and y
        together, summed without a copy for the constant polynomial (t_0 = 1, whose
        own sums are the counts, in ``gram`` with the t_i t_j of the grouping).
        """
        d1, p, n_groups = self.d1, self.p, g.keys.size
        mom = np.zeros((n_groups, self._width))
        mom[:, :d1 * d1] = gram.reshape(n_groups, d1 * d1)
        tx, ty = d1 * d1, d1 * (d1 + p)      # where T^T X and T^T y start in a row
        for i in range(d1):
            s = np.add.reduceat(xy if i == 0 else xy * tz[i - 1], g.starts, axis=1).T
            mom[:, tx + i * p:tx + (i + 1) * p] = s[:, :p]
            mom[:, ty + i] = s[:, p]
        if self.n_labels and labels is not None:
            if g.labelled is None or g.labelled[0] != self.n_labels:  # once per batch
                g.labelled = (self.n_labels, g.inv_sorted * self.n_labels)
            counted = np.bincount(g.labelled[1] + labels, minlength=n_groups * self.n_labels)
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


@dataclass
class Grouping:
    """The groups of one batch and the trend sums that depend on them alone, shared by
    every fit over the same keys and abscissae (the heads of a run, one reference).

    ``keys`` the distinct keys (sorted), ``last`` the batch's last key, ``first`` the
    first sample of each, ``counts`` their samples, ``inv`` the group of each sample,
    ``lo``/``hi`` the least/greatest x; ``sorted``: keys met in order (windows); else
    ``order`` sorts the samples by group. ``starts``: where each group begins in that
    order; ``inv_sorted``: the group of each sample in it. ``z``, ``tz`` (t_1 ..
    t_degree) and ``gram`` (groups, d, d: the sums of t_i t_j, t_0 = 1) in that order,
    when the centre is given (else None: each fit centres on its groups' first x).
    """

    keys: np.ndarray
    last: np.integer
    first: np.ndarray
    counts: np.ndarray
    inv: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    sorted: bool
    order: np.ndarray | None
    starts: np.ndarray
    inv_sorted: np.ndarray
    z: np.ndarray | None = None
    tz: list[np.ndarray] = field(default_factory=list)
    gram: np.ndarray = field(default_factory=lambda: np.zeros(0))
    labelled: tuple[int, np.ndarray] | None = None  # (n_labels, inv_sorted * n_labels)


def group_batch(keys: np.ndarray, x: np.ndarray, degree: int, scale: float,
                centre: np.ndarray | None = None) -> Grouping:
    """The :class:`Grouping` of a batch: its groups by ``keys``, and with ``centre`` the
    trend coordinate z = (x - centre) / scale [1] and its sums per group."""
    if bool(np.all(keys[1:] >= keys[:-1])):  # groups met in order (windows): no sort
        first = np.flatnonzero(keys[1:] != keys[:-1]) + 1
        first = np.concatenate([[0], first])
        counts = np.diff(np.append(first, keys.size))
        inv = np.repeat(np.arange(first.size), counts)
        g = Grouping(keys[first], keys[-1], first, counts, inv,
                     np.minimum.reduceat(x, first).astype(np.float64),
                     np.maximum.reduceat(x, first).astype(np.float64),
                     True, None, first, inv)
    else:
        uk, first, inv = np.unique(keys, return_index=True, return_inverse=True)
        lo = np.full(uk.size, np.inf)
        hi = np.full(uk.size, -np.inf)
        np.minimum.at(lo, inv, x)
        np.maximum.at(hi, inv, x)
        counts = np.bincount(inv, minlength=uk.size)
        sort = bool(np.all(inv[1:] >= inv[:-1]))
        order = None if sort else np.argsort(inv, kind="stable")
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        g = Grouping(uk, keys[-1], first, counts, inv, lo, hi, False, order, starts,
                     inv if order is None else inv[order])
    if centre is not None:
        z = (x - centre) / scale
        g.z = z if g.order is None else z[g.order]
        g.tz = _trend_rows(g.z, degree + 1)
        g.gram = _gram(g.tz, g)
    return g


def _trend_rows(z: np.ndarray, d1: int) -> list[np.ndarray]:
    """t_1 .. t_{d1-1}: the Legendre polynomials of z after t_0 = 1."""
    return list(np.polynomial.legendre.legvander(z, d1 - 1).T[1:]) if d1 > 2 else [z][:d1 - 1]


def _gram(tz: list[np.ndarray], g: Grouping) -> np.ndarray:
    """The sums of t_i t_j of each group (groups, d, d), t_0 = 1 (whose sums are counts)."""
    d1 = len(tz) + 1
    gram = np.zeros((g.keys.size, d1, d1))
    gram[:, 0, 0] = g.counts
    for i in range(1, d1):
        gram[:, 0, i] = gram[:, i, 0] = np.add.reduceat(tz[i - 1], g.starts)
        for j in range(i, d1):
            gram[:, i, j] = gram[:, j, i] = np.add.reduceat(tz[i - 1] * tz[j - 1], g.starts)
    return gram
