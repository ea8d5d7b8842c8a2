"""Least squares with a polynomial trend per group, streamed in constant memory.

A model ``y = T_g beta_g + X c``: columns X shared by all samples (e.g. the
harmonics of an interpolation error), and per group g (a run of a sweep, a window of
a continuous run) a nuisance trend T_g, Legendre polynomials of a coordinate. The
trends are projected out group by group (Frisch-Waugh), so only the moments of the
open groups and the normal equations of X are held, whatever the input's length.
Several such problems over the same samples and groups (the heads of a run against one
reference) are fed as one (:class:`StackedTrendLSQ`): each batch's grouping, every
group's trend basis and the bookkeeping of the open groups are done once for all.
Used by :mod:`enctools.methods.interp.fit` (seed 000 eqs. (19), (20)).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np

#: ``on_close(counts, seen, lo, hi)``: of each group that closes, its samples, the bitmask
#: of the labels its samples carried (bits OR-ed), its least and greatest abscissa
OnClose = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], None]


class FusedRows(ABC):
    """One member's batch summed in one pass over its samples (a compiled kernel) rather
    than from its rows X and y: only for groups met in order (a grouping without
    ``order``)."""

    @abstractmethod
    def first_y(self, first: np.ndarray) -> np.ndarray:
        """y at the samples ``first`` (the first of each group)."""

    @abstractmethod
    def sums(self, g: Grouping, tz: list[np.ndarray], y0: np.ndarray, txy: np.ndarray,
             seen: np.ndarray, member: TrendProjectedLSQ) -> None:
        """Of y less its group's ``y0``: the sums T^T [X y] per group into ``txy``
        (d, p + 1, groups), the label bits OR-ed into ``seen`` (groups), and X^T X,
        X^T y, y^T y and the count into ``member`` (:func:`add_cross`)."""


#: one member's batch: its columns X transposed with y as the last row (p + 1, m; y is
#: changed in place), its label bits (m) or None, and X^T X when known (else None); or
#: its sums made in one pass (:class:`FusedRows`)
MemberRows = tuple[np.ndarray, np.ndarray | None, np.ndarray | None] | FusedRows


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
    ``on_close`` (:data:`OnClose`) receives, for the groups that close, their sample
    counts, the bits OR-ed of the ``labels`` given to :meth:`add` (e.g. 1 << the
    quarter of the signal period a sample's phase lies in), and the least/greatest ``x``.
    """

    def __init__(self, n_cols: int, degree: int, consecutive: bool,
                 on_close: OnClose | None = None) -> None:
        self.p = n_cols
        self.d1 = degree + 1
        self.consecutive = consecutive
        self.on_close = on_close
        self.xtx = np.zeros((n_cols, n_cols))
        self.xty = np.zeros(n_cols)
        self.yty = 0.0
        self.raw_ss = np.zeros(n_cols)    # sums of squares of the columns before projection
        self.n = 0
        self.n_trend = 0
        self.groups = 0
        self._open = OpenGroups.empty(1, n_cols + 1, self.d1)
        self._scratch = np.zeros(0)
        self._buffers = [np.zeros(0), np.zeros(0)]   # group_buffer's

    def add(self, x_rows: np.ndarray, y: np.ndarray, x: np.ndarray, keys: np.ndarray | None,
            scale: float, centre: np.ndarray | None = None,
            labels: np.ndarray | None = None, grouping: Grouping | None = None,
            xtx: np.ndarray | None = None) -> None:
        """Add m samples: the columns X transposed, ``x_rows`` (p, m) or (p + 1, m) with a
        free last row (then used for y, saving a copy; ``y`` may be that row); data
        ``y`` (m); trend abscissa ``x`` (m); group ``keys`` (m); ``labels`` (m) uint8
        bits of labels (up to 8) that each group's samples OR, or None.

        The trend coordinate is z = (x - centre) / scale, ``centre`` per sample, or
        (None) the first x of the sample's group. ``grouping``: :func:`group_batch` of
        these keys, x, scale and centre, when several fits share them (the heads of a
        run against one reference); computed here when None. ``xtx``: X^T X of these
        samples (p, p) when the caller has it for less than a product over the samples
        (columns looked up in a table: from a histogram of the look-ups), or zeros when
        it adds it later (:meth:`add_gram`); None: here.
        """
        m = y.size
        if m == 0:
            return
        if grouping is None:
            assert keys is not None, "keys or their grouping"
            grouping = group_batch(keys, x, self.d1 - 1, scale, centre)
        xy = x_rows if x_rows.shape[0] == self.p + 1 else np.empty((self.p + 1, m))
        if xy is not x_rows:
            xy[:self.p] = x_rows
        if not np.may_share_memory(y, xy[self.p]):
            xy[self.p] = y
        self._open = add_batch([self], self._open, x, scale, grouping, [(xy, labels, xtx)])

    def add_fused(self, x: np.ndarray, scale: float, grouping: Grouping,
                  rows: FusedRows) -> None:
        """Add a batch summed in one pass (``rows``); ``x``, ``scale`` and ``grouping`` as
        :meth:`add` (the grouping required, its groups in order)."""
        if x.size:
            self._open = add_batch([self], self._open, x, scale, grouping, [rows])

    def add_gram(self, xtx: np.ndarray) -> None:
        """Add X^T X (p, p) of samples added with X^T X given as zeros (the caller sums it
        its own way, e.g. from a histogram of looked-up columns over every batch)."""
        self.xtx += xtx
        self.raw_ss += np.diagonal(xtx)

    def close_all(self) -> None:
        """Close every open group (at the end of the input)."""
        close_groups([self], self._open)
        self._open = OpenGroups.empty(1, self.p + 1, self.d1)

    def group_buffer(self, held: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        """A buffer of ``shape`` for a batch's sums per group (:func:`add_batch`): one of
        two kept from batch to batch, the one that does not hold the groups left open
        (``held``, a view of the other), which these sums add to."""
        size = int(np.prod(shape))
        pair = self._buffers
        i = 1 if np.may_share_memory(pair[0], held) else 0
        if pair[i].size < size:
            pair[i] = np.empty(size)
        return pair[i][:size].reshape(shape)

    def scratch(self, shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Two buffers of ``shape`` for the products of :func:`close_groups`, kept from one
        batch to the next (a fresh buffer of a batch's size costs more than its products
        to the memory's first touch); grown when too small."""
        size = int(np.prod(shape))
        if self._scratch.size < 2 * size:
            self._scratch = np.empty(2 * size)
        return (self._scratch[:size].reshape(shape), self._scratch[size:2 * size].reshape(shape))


class StackedTrendLSQ:
    """Several :class:`TrendProjectedLSQ` (``members``, alike in columns, degree and
    groups) fed as one: the same samples, abscissae and groups, each its own X and y.

    Each member keeps its sums; the open groups of all are held here, and the work of a
    batch that depends on the groups alone (grouping, anchors, trend basis, which groups
    close) is done once. :meth:`release` hands every member its own open groups, after
    which each is fed alone (when a batch leaves the members different samples).
    """

    def __init__(self, members: list[TrendProjectedLSQ]) -> None:
        first = members[0]
        if any((m.p, m.d1, m.consecutive) != (first.p, first.d1, first.consecutive)
               for m in members):
            msg = "stacked least squares need members alike in columns, degree and groups"
            raise ValueError(msg)
        self.members = members
        self._open = OpenGroups.empty(len(members), first.p + 1, first.d1)

    def add(self, x: np.ndarray, scale: float, grouping: Grouping,
            rows: Iterable[MemberRows]) -> None:
        """Add m samples: ``x``, ``scale`` and ``grouping`` as :meth:`TrendProjectedLSQ.add`
        (the grouping is required); ``rows`` each member's in turn (:data:`MemberRows`),
        which may be made as they are asked for in one buffer (each is used before the next
        is asked for)."""
        if x.size == 0:
            return
        self._open = add_batch(self.members, self._open, x, scale, grouping, rows)

    def release(self) -> None:
        """Give every member its own open groups; the stack holds none after."""
        for q, member in enumerate(self.members):
            member._open = self._open.member(q).copy()  # not views of the stack's buffers
        self._open = OpenGroups.empty(len(self.members), self.members[0].p + 1,
                                      self.members[0].d1)

    def close_all(self) -> None:
        """Close every open group (at the end of the input)."""
        close_groups(self.members, self._open)
        self._open = OpenGroups.empty(len(self.members), self.members[0].p + 1,
                                      self.members[0].d1)


@dataclass
class OpenGroups:
    """The groups still open, with the last axis over the groups: ``keys``, the trend's
    anchor ``x0``, least/greatest abscissa ``lo``/``hi`` (groups); per member the first
    value of y ``y0`` and the label bits ``seen`` (members, groups); the sums T^T T
    ``gram`` (d, d, groups) and T^T [X y] ``txy`` (d, members, p + 1, groups)."""

    keys: np.ndarray
    x0: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    y0: np.ndarray
    seen: np.ndarray
    gram: np.ndarray
    txy: np.ndarray

    @classmethod
    def empty(cls, members: int, p1: int, d1: int) -> OpenGroups:
        """No group open: ``members`` problems of ``p1`` rows (X and y), trends of d1 terms."""
        z = np.zeros(0)
        return cls(np.zeros(0, np.int64), z, z, z, np.zeros((members, 0)),
                   np.zeros((members, 0), np.uint8), np.zeros((d1, d1, 0)),
                   np.zeros((d1, members, p1, 0)))

    def select(self, which: np.ndarray | slice) -> OpenGroups:
        """The groups ``which`` (indices, a mask or a slice over the groups: then views)."""
        return OpenGroups(self.keys[which], self.x0[which], self.lo[which], self.hi[which],
                          self.y0[:, which], self.seen[:, which], self.gram[..., which],
                          self.txy[..., which])

    def copy(self) -> OpenGroups:
        """The same groups in arrays of their own."""
        return OpenGroups(*(np.array(a) for a in (self.keys, self.x0, self.lo, self.hi,
                                                  self.y0, self.seen, self.gram, self.txy)))

    def member(self, q: int) -> OpenGroups:
        """Member ``q``'s open groups alone (one member)."""
        return OpenGroups(self.keys, self.x0, self.lo, self.hi, self.y0[q:q + 1],
                          self.seen[q:q + 1], self.gram, self.txy[:, q:q + 1])

    @staticmethod
    def join(a: OpenGroups, b: OpenGroups) -> OpenGroups:
        """The groups of ``a`` then those of ``b``."""
        return OpenGroups(*(np.concatenate([u, v], axis=-1) for u, v in (
            (a.keys, b.keys), (a.x0, b.x0), (a.lo, b.lo), (a.hi, b.hi), (a.y0, b.y0),
            (a.seen, b.seen), (a.gram, b.gram), (a.txy, b.txy))))


def add_batch(members: list[TrendProjectedLSQ], state: OpenGroups, x: np.ndarray,
              scale: float, g: Grouping, rows: Iterable[MemberRows]) -> OpenGroups:
    """One batch of every member (``rows``, in the members' order: :data:`MemberRows`)
    into their sums; the groups left open.

    Groups met before (in ``state``) keep their anchors and add their moments; y less
    its group's first value (a constant of the trend, kept out of the sums of squares
    so that they do not cancel) is summed with X. Each member's rows are summed as they
    come (while in the cache); what depends on the groups alone is done once.
    """
    n_members, p, d1, k = len(members), members[0].p, members[0].d1, g.keys.size
    x0, lo, hi = x[g.first].astype(np.float64), g.lo.copy(), g.hi.copy()
    where = np.searchsorted(g.keys, state.keys)          # g.keys is sorted
    old = np.flatnonzero(g.keys[np.minimum(where, k - 1)] == state.keys)
    where = where[old]
    x0[where] = state.x0[old]
    lo[where] = np.minimum(lo[where], state.lo[old])
    hi[where] = np.maximum(hi[where], state.hi[old])
    tz, gram = g.tz, g.gram
    if g.z is None:  # centred on each group's first x: these anchors
        z = (x - x0[g.inv]) / scale
        tz = _trend_rows(z if g.order is None else z[g.order], d1)
        gram = _gram(tz, g)
    # each member's T^T [X y] contiguous (a kernel writes it in place): stored by member
    txy = members[0].group_buffer(state.txy, (n_members, d1, p + 1, k)).transpose(1, 0, 2, 3)
    new = OpenGroups(g.keys, x0, lo, hi, np.empty((n_members, k)),
                     np.zeros((n_members, k), np.uint8), gram.copy(), txy)
    count = 0
    for q, item in enumerate(rows):
        y0 = new.y0[q]
        y0[:] = item.first_y(g.first) if isinstance(item, FusedRows) else item[0][p, g.first]
        y0[where] = state.y0[q, old]
        _member_sums(members[q], item, g, tz, y0, new.txy[:, q], new.seen[q])
        count += 1
    assert count == n_members, "rows for every member"
    new.gram[..., where] += state.gram[..., old]
    new.txy[..., where] += state.txy[..., old]
    new.seen[:, where] |= state.seen[:, old]
    keep = np.ones(state.keys.size, dtype=bool)
    keep[old] = False
    if members[0].consecutive and g.sorted:
        # windows met in order: the batch's last stays open, every other closes (views)
        closing = new.select(slice(0, k - 1))
        if keep.any():
            closing = OpenGroups.join(state.select(keep), closing)
        close_groups(members, closing)
        return new.select(slice(k - 1, k))
    both = OpenGroups.join(state.select(keep), new)
    if not members[0].consecutive:
        return both
    last = both.keys == g.last
    close_groups(members, both.select(~last))
    return both.select(last)


def _member_sums(member: TrendProjectedLSQ, item: MemberRows, g: Grouping,
                 tz: list[np.ndarray], y0: np.ndarray, txy: np.ndarray,
                 seen: np.ndarray) -> None:
    """One member's batch ``item`` into ``txy`` (d, p + 1, groups), ``seen`` (groups) and
    its sums, y less its group's ``y0``."""
    if isinstance(item, FusedRows):
        assert g.order is None, "fused sums: groups in order"
        item.sums(g, tz, y0, txy, seen, member)
        return
    xy, labels, xtx = item
    p = member.p
    np.subtract(xy[p], y0[g.inv] if g.order is not None or not g.sorted
                else np.repeat(y0, g.counts), out=xy[p])
    if g.order is not None:  # a sweep's runs interleaved: sorted by group once
        xy = xy[:, g.order]
        labels = None if labels is None else labels[g.order]
    _moments(xy, tz, g, txy)
    if labels is not None:
        np.bitwise_or.reduceat(labels, g.starts, out=seen)
    _cross(member, xy, xtx)


def _cross(member: TrendProjectedLSQ, xy: np.ndarray, xtx: np.ndarray | None) -> None:
    """Add X^T X (``xtx`` when given), X^T y, y^T y of one member's batch ``xy`` (p + 1, m)."""
    p = member.p
    if xtx is None:
        cross = xy @ xy.T                              # X^T X, X^T y, y^T y at once
        xtx, xty, yty = cross[:p, :p], cross[:p, p], cross[p, p]
    else:
        xty = xy @ xy[p]                               # X^T y and y^T y: one pass
        xty, yty = xty[:p], xty[p]
    add_cross(member, xtx, xty, float(yty), xy.shape[1])


def add_cross(member: TrendProjectedLSQ, xtx: np.ndarray, xty: np.ndarray, yty: float,
              m: int) -> None:
    """Add X^T X (p, p), X^T y (p), y^T y and the count ``m`` of a batch to ``member``."""
    member.xtx += xtx
    member.raw_ss += np.diagonal(xtx)
    member.xty += xty
    member.yty += yty
    member.n += m


def _moments(xy: np.ndarray, tz: list[np.ndarray], g: Grouping, out: np.ndarray) -> None:
    """The sums T^T [X y] of each group into ``out`` (d, p + 1, groups).

    ``add.reduceat`` over the samples (the last axis) of each group: the rows of X and y
    together, summed without a copy for the constant polynomial (t_0 = 1), the others
    from one product into the grouping's buffer (one for every fit sharing it).
    """
    np.add.reduceat(xy, g.starts, axis=1, out=out[0])
    if tz:
        scratch = g.scratch_for(xy.shape)
        for i, t in enumerate(tz, start=1):
            np.multiply(xy, t, out=scratch)
            np.add.reduceat(scratch, g.starts, axis=1, out=out[i])


def close_groups(members: list[TrendProjectedLSQ], state: OpenGroups) -> None:
    """Fold the groups of ``state`` into every member's sums, and tell its ``on_close``."""
    k = state.keys.size
    if k == 0:
        return
    d1, p = members[0].d1, members[0].p
    basis, ok = _inverse_root(state.gram)              # (T^T T)^+ = basis basis^T
    # [X y] projected on each basis vector j of each group, for each member: the Gram
    # matrix of those is what the trends take from X^T X, X^T y and y^T y
    taken = np.zeros((len(members), p + 1, p + 1))
    proj, term = members[0].scratch(state.txy.shape[1:])
    for j in range(d1):        # the closed-form basis (d <= 2) is upper triangular
        np.multiply(state.txy[0], basis[0, j], out=proj)
        for i in range(1, j + 1 if d1 <= 2 else d1):
            proj += np.multiply(state.txy[i], basis[i, j], out=term)
        taken += proj @ proj.transpose(0, 2, 1)
    n_ok = int(np.count_nonzero(ok))
    counts = state.gram[0, 0]
    for q, member in enumerate(members):
        member.xtx -= taken[q, :p, :p]
        member.xty -= taken[q, :p, p]
        member.yty -= float(taken[q, p, p])
        member.n_trend += n_ok
        member.groups += k
        if member.on_close is not None:
            member.on_close(counts, state.seen[q], state.lo, state.hi)


def _inverse_root(gram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """B with B B^T the pseudo-inverse of each Gram matrix (d, d, k), and which columns
    count (d, k): B as (d, d, k), the groups on the last axis.

    A group with fewer distinct abscissae than the degree + 1 is fitted exactly by its
    trend: directions with an eigenvalue below 1e-10 of the largest add nothing. For
    d <= 2 (a trend of degree 0 or 1, the usual) the basis is written in closed form,
    centred: 1/sqrt(n) and (z - mean z)/sqrt(S_zz), with S_zz = sum (z - mean z)^2.
    """
    d, _, k = gram.shape
    if d > 2:
        w, v = np.linalg.eigh(gram.transpose(2, 0, 1))
        ok = w > np.maximum(w[:, -1:], 0.0) * 1e-10
        s = np.where(ok, 1.0 / np.sqrt(np.where(ok, w, 1.0)), 0.0)
        return (v * s[:, None, :]).transpose(1, 2, 0), ok.T
    n = gram[0, 0]
    basis = np.zeros((d, d, k))
    ok = np.zeros((d, k), dtype=bool)
    ok[0] = n > 0
    basis[0, 0] = np.where(ok[0], 1.0 / np.sqrt(np.where(ok[0], n, 1.0)), 0.0)
    if d == 2:
        mean = gram[0, 1] / np.where(ok[0], n, 1.0)
        szz = gram[1, 1] - mean * gram[0, 1]
        # the smaller eigenvalue is det / larger >= det / trace; det = n S_zz
        trace = n + gram[1, 1]
        ok[1] = n * szz > 1e-10 * trace * trace
        root = np.where(ok[1], 1.0 / np.sqrt(np.where(ok[1], szz, 1.0)), 0.0)
        basis[1, 1] = root
        basis[0, 1] = -mean * root
    return basis, ok


@dataclass
class Grouping:
    """The groups of one batch and the trend sums that depend on them alone, shared by
    every fit over the same keys and abscissae (the heads of a run, one reference).

    ``keys`` the distinct keys (sorted), ``last`` the batch's last key, ``first`` the
    first sample of each, ``counts`` their samples, ``inv`` the group of each sample,
    ``lo``/``hi`` the least/greatest x; ``sorted``: keys met in order (windows); else
    ``order`` sorts the samples by group. ``starts``: where each group begins in that
    order. ``z``, ``tz`` (t_1 .. t_degree) and ``gram`` (d, d, groups: the sums of
    t_i t_j, t_0 = 1) in that order, when the centre is given (else None: each fit
    centres on its groups' first x); ``scratch``: a buffer for products over the batch
    (:meth:`scratch_for`).
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
    z: np.ndarray | None = None
    tz: list[np.ndarray] = field(default_factory=list)
    gram: np.ndarray = field(default_factory=lambda: np.zeros(0))
    scratch: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def scratch_for(self, shape: tuple[int, int]) -> np.ndarray:
        """A buffer of ``shape`` for products over the batch, one for every fit sharing
        the grouping (fewer allocations of a batch's size); grown when too small."""
        size = shape[0] * shape[1]
        if self.scratch.size < size:
            self.scratch = np.empty(size)
        return self.scratch[:size].reshape(shape)


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
                     True, None, first)
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
        g = Grouping(uk, keys[-1], first, counts, inv, lo, hi, False, order, starts)
    if centre is not None:
        z = np.subtract(x, centre)            # (x - centre) / scale, in place
        z /= scale
        g.z = z if g.order is None else z[g.order]
        g.tz = _trend_rows(g.z, degree + 1)
        g.gram = _gram(g.tz, g)
    return g


def _trend_rows(z: np.ndarray, d1: int) -> list[np.ndarray]:
    """t_1 .. t_{d1-1}: the Legendre polynomials of z after t_0 = 1."""
    return list(np.polynomial.legendre.legvander(z, d1 - 1).T[1:]) if d1 > 2 else [z][:d1 - 1]


def _gram(tz: list[np.ndarray], g: Grouping) -> np.ndarray:
    """The sums of t_i t_j of each group (d, d, groups), t_0 = 1 (whose sums are counts)."""
    d1 = len(tz) + 1
    gram = np.zeros((d1, d1, g.keys.size))
    gram[0, 0] = g.counts
    for i in range(1, d1):
        gram[0, i] = gram[i, 0] = np.add.reduceat(tz[i - 1], g.starts)
        for j in range(i, d1):
            gram[i, j] = gram[j, i] = np.add.reduceat(tz[i - 1] * tz[j - 1], g.starts)
    return gram
