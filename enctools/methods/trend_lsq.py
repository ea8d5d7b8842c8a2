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
    ``on_close(extra, lo, hi)`` receives, for the groups that close, the sums of the
    ``extra`` columns given to :meth:`add` and the least/greatest ``x``.
    """

    def __init__(self, n_cols: int, degree: int, consecutive: bool,
                 on_close: Callable[[np.ndarray, np.ndarray, np.ndarray], None] | None = None,
                 n_extra: int = 0) -> None:
        self.p = n_cols
        self.d1 = degree + 1
        self.consecutive = consecutive
        self.on_close = on_close
        self.n_extra = n_extra
        self.xtx = np.zeros((n_cols, n_cols))
        self.xty = np.zeros(n_cols)
        self.yty = 0.0
        self.raw_ss = np.zeros(n_cols)    # sums of squares of the columns before projection
        self.n = 0
        self.n_trend = 0
        self.groups = 0
        d1 = self.d1
        self._width = d1 * d1 + d1 * n_cols + d1 + n_extra
        self._keys = np.zeros(0, dtype=np.int64)
        self._mom = np.zeros((0, self._width))
        self._y0 = np.zeros(0)
        self._x0 = np.zeros(0)
        self._lo = np.zeros(0)
        self._hi = np.zeros(0)

    def add(self, x_rows: np.ndarray, y: np.ndarray, x: np.ndarray, keys: np.ndarray,
            scale: float, centre: np.ndarray | None = None,
            extra: np.ndarray | None = None) -> None:
        """Add m samples: the columns X transposed, ``x_rows`` (p, m); data ``y`` (m);
        trend abscissa ``x`` (m); group ``keys`` (m); ``extra`` (n_extra, m) or None.

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
        old = np.flatnonzero(np.isin(self._keys, uk))
        where = np.searchsorted(uk, self._keys[old])
        y0[where], x0[where] = self._y0[old], self._x0[old]
        lo[where] = np.minimum(lo[where], self._lo[old])
        hi[where] = np.maximum(hi[where], self._hi[old])
        mom[where] = self._mom[old]
        # y less its group's first value: a constant of the trend, kept out of the
        # sums of squares so that they do not cancel
        yc = y - y0[inv]
        z = (x - (x0[inv] if centre is None else centre)) / scale
        xt = np.ascontiguousarray(x_rows)                                  # (p, m)
        mom += _group_sums(self._moment_rows(z, xt, yc, extra), inv, uk.size)
        self.xtx += xt @ xt.T
        self.xty += xt @ yc
        self.yty += float(yc @ yc)
        self.raw_ss += np.einsum("ij,ij->i", xt, xt)
        self.n += m
        self._hold(old, uk, mom, y0, x0, lo, hi, keys[-1])

    def _moment_rows(self, z: np.ndarray, xt: np.ndarray, yc: np.ndarray,
                     extra: np.ndarray | None) -> np.ndarray:
        """Per sample (columns) the products T T, T X, T y and the extra rows: (width, m)."""
        # one row per moment, one column per sample: reduceat along contiguous rows
        t = np.polynomial.legendre.legvander(z, self.d1 - 1).T.copy()     # (d1, m)
        d1, p, m = self.d1, self.p, z.size
        rows = np.empty((self._width, m))
        np.multiply(t[:, None, :], t[None, :, :], out=rows[:d1 * d1].reshape(d1, d1, m))
        np.multiply(t[:, None, :], xt[None, :, :],
                    out=rows[d1 * d1:d1 * (d1 + p)].reshape(d1, p, m))
        np.multiply(t, yc, out=rows[d1 * (d1 + p):d1 * (d1 + p + 1)])
        if extra is not None:
            rows[d1 * (d1 + p + 1):] = extra
        return rows

    def _hold(self, old: np.ndarray, uk: np.ndarray, mom: np.ndarray, y0: np.ndarray,
              x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, last_key: np.integer) -> None:
        """Keep the batch's groups open with those not met (``old``: open groups met again).

        ``consecutive``: every group but the one of ``last_key`` closes now.
        """
        keep_old = np.setdiff1d(np.arange(self._keys.size), old)
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
        w, v = np.linalg.eigh(gram)
        # the rank of each trend: a group with fewer distinct abscissae than the
        # degree + 1 is fitted exactly by its trend and adds nothing
        ok = w > np.maximum(w[:, -1:], 0.0) * 1e-10
        s = np.where(ok, 1.0 / np.sqrt(np.where(ok, w, 1.0)), 0.0)
        basis = v * s[:, None, :]                          # (T^T T)^+ = basis basis^T
        a = np.einsum("kij,kip->kjp", basis, tx)
        b = np.einsum("kij,ki->kj", basis, ty)
        self.xtx -= np.einsum("kjp,kjq->pq", a, a)
        self.xty -= np.einsum("kjp,kj->p", a, b)
        self.yty -= float(np.sum(b * b))
        self.n_trend += int(ok.sum())
        self.groups += k
        if self.on_close is not None:
            self.on_close(mom[:, self._width - self.n_extra:], lo, hi)


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


def _group_sums(rows: np.ndarray, inv: np.ndarray, n_groups: int) -> np.ndarray:
    """Sums of ``rows`` (width, m) over the samples of each group ``inv``: (n_groups, width)."""
    if np.all(inv[1:] >= inv[:-1]):    # groups met in order (windows): no sort
        starts = np.searchsorted(inv, np.arange(n_groups))
    else:
        order = np.argsort(inv, kind="stable")
        starts = np.searchsorted(inv[order], np.arange(n_groups))
        rows = rows[:, order]
    return np.add.reduceat(rows, starts, axis=1).T
