"""The default RBF network on a dense table, in memory and time in proportion to the points.

enc fit-rbf's network (:func:`enctools.models.rbf.choose_network`) has a fixed set of at
most :data:`~enctools.models.rbf.MAX_UNITS` units, so every figure of its least squares
comes from a small factor: the R of the QR decomposition of the columns ``[1, Phi, y]``
(an unpenalised bias, the units of seed 001 eq. 6, the deviations), (m + 2) x (m + 2)
words whatever the number of points N. That R is accumulated a block of
:data:`BLOCK` points at a time (the blocks' R stacked and factored again, as a tall
QR is done out of core), so the memory is a few blocks' worth and Python runs between
blocks (a signal ends the fit there); each block's QR is taken over the units whose output
reaches :data:`NEGLIGIBLE` at one of its points (R in row echelon form). From R:

- the centred design's SVD ``P Phi = U S V^T`` (P removes the mean): ``S`` and ``V``
  from the SVD of R's middle block, ``U^T y`` from its last column, to rounding as the
  SVD of the whole design gives them (the QR is backward stable);
- the weights and bias of any smoothing lambda, as :class:`~enctools.models.rbf._Ridge`;
- in a second pass over the blocks, each point's leave-one-out residual
  ``r_i / (1 - H_ii)`` for every smoothing at once, with
  ``H_ii = 1/N + sum_j p_ij^2 / (S_j^2 + lambda)`` and ``p_i = V^T (phi_i - mean)``:
  accurate to about 1e-10 of the deviations at the smallest smoothing tried (1e-12 of
  the largest squared singular value), and to rounding where H_ii is not near 1, as in a
  table of many more points than units;
- the blocked hold-out (:mod:`enctools.models.gain`): the R of each 15-deg block is kept,
  and the network without block k is the QR of the others' R (prefix and suffix
  products, two merges a block), no refit over the points.

The spread is chosen on an even subset of :data:`SEARCH_POINTS` points by the same
closed-form criterion (the smallest RMS leave-one-out residual over spreads x
smoothings); the smoothing is then chosen again over every point at that spread.
Tables of at most SEARCH_POINTS points are searched over all of them by
:func:`~enctools.models.rbf.choose_network` itself.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from enctools.errors import DataError
from enctools.models.gain import block_index
from enctools.models.rbf import (
    MAX_WEIGHT,
    SMOOTHING,
    SPREAD_FACTOR,
    Choice,
    RBFModel,
    search_grid,
    spread_chord,
)
from enctools.units import DEG

#: points of the subset the spread is searched on: above this the spread search costs
#: the same whatever the table's size (the default network has at most 256 units)
SEARCH_POINTS = 2048
#: points a block: the largest arrays are BLOCK x 258 words (4.2 MB)
BLOCK = 2048
#: a unit whose output (at most 1) is below this at every point of a block is left out
#: of that block's factor, its column there taken as 0: a change of each column 1e6 times
#: below the rounding of the QR itself (about 1e-14 of its norm); of a 15-deg block at
#: the spreads chosen on the bench's tables, about half the units
NEGLIGIBLE = 1e-20
#: the most points whose leave-one-out residuals of every smoothing the scoring pass
#: keeps (points x 25 words, 52 MB at most); above, the last pass computes the chosen
#: smoothing's again
KEEP_LOO_POINTS = 1 << 18
#: points of a run of the search's subset factored alone at narrow spreads (256 of
#: 2048 points sorted by angle: about 45 deg of the turn)
SEARCH_RUN = 256


class _Units:
    """The units of one spread at fixed centres [deg] (seed 001 eq. 6)."""

    def __init__(self, centres_deg: np.ndarray, spread_deg: float) -> None:
        self.centres, self.spread = centres_deg, float(spread_deg)
        self.cc, self.sc = np.cos(centres_deg * DEG), np.sin(centres_deg * DEG)
        self.k2 = 2.0 * SPREAD_FACTOR ** 2 / spread_chord(spread_deg) ** 2
        self.right = np.vstack([self.cc, self.sc, np.ones_like(self.cc)])

    def __call__(self, x_deg: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """R_i(x), shape (len(x), m): exp(-k d^2) with d^2 = 2 - 2 cos(x - c), as
        k (2 cos x cos c + 2 sin x sin c - 2): one product of (len(x) x 3) (3 x m), no
        len(x) x m trigonometric call."""
        xr = x_deg * DEG
        left = np.empty((xr.size, 3))
        left[:, 0], left[:, 1], left[:, 2] = np.cos(xr), np.sin(xr), -1.0
        left *= self.k2
        a = np.matmul(left, self.right, out=out)
        return np.exp(a, out=a)


def _r_factor(a: np.ndarray) -> np.ndarray:
    """The R of the QR decomposition of ``a`` (Householder, LAPACK dgeqrf)."""
    return np.asarray(np.linalg.qr(a, mode="r"))


def _r_of_columns(a: np.ndarray, cols: np.ndarray, width: int) -> np.ndarray:
    """The R of ``a``, the columns ``cols`` (ascending) of a matrix ``width`` wide whose
    other columns are 0, in those columns' places: R^T R is the matrix's Gram, and R is
    in row echelon form (each row starts past the one above; row 0 holds column 0)."""
    r = _r_factor(a)
    if cols.size == width:
        return r
    out = np.zeros((r.shape[0], width))
    out[:, cols] = r
    return out


@dataclass
class _Part:
    """What a set of points contributes: the R factor of its columns [1, Phi, y] (at most
    m + 2 rows, row echelon form), its count and sums."""

    r: np.ndarray | None
    n: int
    phi_sum: np.ndarray
    y_sum: float

    @classmethod
    def empty(cls, m: int) -> _Part:
        return cls(None, 0, np.zeros(m), 0.0)

    def add(self, units: _Units, x: np.ndarray, y: np.ndarray,
            phi: np.ndarray | None = None) -> np.ndarray:
        """Points [deg, arcsec] added (a block; their Phi if known): the QR of R stacked
        over their columns, a unit whose output is below :data:`NEGLIGIBLE` at every
        point of the block (and 0 in R) left out. Returns their Phi."""
        m = units.centres.size
        top = 0 if self.r is None else self.r.shape[0]
        a = np.empty((top + x.size, m + 2))
        if self.r is not None:
            a[:top] = self.r
        if phi is None:
            phi = units(x, out=a[top:, 1:m + 1])
        else:
            a[top:, 1:m + 1] = phi
            phi = a[top:, 1:m + 1]
        a[top:, 0], a[top:, m + 1] = 1.0, y
        used = np.ones(m + 2, dtype=bool)
        used[1:m + 1] = phi.max(axis=0, initial=0.0) >= NEGLIGIBLE
        if self.r is not None:
            used |= np.any(self.r, axis=0)
        cols = np.flatnonzero(used)
        if cols.size < m + 2:
            a = a[:, cols]
        self.phi_sum += phi.sum(axis=0)
        self.y_sum += float(y.sum())
        self.n += x.size
        self.r = _r_of_columns(a, cols, m + 2)
        return phi

    def join(self, other: _Part) -> _Part:
        """The part of both sets of points."""
        if self.r is None or other.r is None:
            r = other.r if self.r is None else self.r
        else:
            cols = np.flatnonzero(np.any(self.r, axis=0) | np.any(other.r, axis=0))
            r = _r_of_columns(np.vstack([self.r[:, cols], other.r[:, cols]]), cols,
                              self.r.shape[1])
        return _Part(r, self.n + other.n, self.phi_sum + other.phi_sum,
                     self.y_sum + other.y_sum)


class _Solution:
    """The ridge network of one spread from a :class:`_Part` (see :class:`rbf._Ridge`):
    ``min |y - b - Phi w|^2 + lambda |w|^2``, lambda = smoothing x S_0^2."""

    def __init__(self, part: _Part, m: int) -> None:
        n = part.n
        r = np.zeros((m + 2, m + 2))
        if part.r is not None:
            r[:part.r.shape[0]] = part.r
        u, s, vt = np.linalg.svd(r[1:m + 1, 1:m + 1])
        rank = int(np.sum(s > (s[0] if s.size else 0.0) * max(n, m) * np.finfo(float).eps))
        self.n, self.s, self.vt = n, s[:rank], vt[:rank]
        self.uy = u[:, :rank].T @ r[1:m + 1, m + 1]
        self.mu = part.phi_sum / max(n, 1)
        self.ybar = part.y_sum / max(n, 1)

    def lam(self, smoothing: np.ndarray | float) -> np.ndarray:
        return np.asarray(smoothing) * (float(self.s[0]) ** 2 if self.s.size else 0.0)

    def weights(self, smoothing: float) -> np.ndarray:
        """The output weights [arcsec] (as rbf._Ridge.weights)."""
        s2 = self.s * self.s
        g = s2 / (s2 + self.lam(smoothing)) if s2.size else s2
        positive = self.s > 0
        inverse = np.where(positive, g / np.where(positive, self.s, 1.0), 0.0)
        return np.asarray(self.vt.T @ (inverse * self.uy))

    def effective(self, smoothing: float) -> float:
        s2 = self.s * self.s
        return float(1.0 + (s2 / (s2 + self.lam(smoothing))).sum()) if s2.size else 1.0

    def model(self, units: _Units, smoothing: float) -> RBFModel:
        w = self.weights(smoothing)
        return RBFModel(units.centres.copy(), w, self.ybar - float(self.mu @ w), units.spread)

    def residuals(self, phi: np.ndarray, y: np.ndarray, smoothings: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Training residuals [arcsec] and 1 - H_ii of points (their Phi, y), one column
        a smoothing."""
        p = phi @ self.vt.T
        p -= self.mu @ self.vt.T
        inv = 1.0 / (np.square(self.s)[:, None] + self.lam(smoothings)[None, :])
        fit = p @ ((self.s * self.uy)[:, None] * inv)
        lev = np.square(p) @ inv
        return (y - self.ybar)[:, None] - fit, (1.0 - 1.0 / self.n) - lev


def _blocks(n: int, edges: np.ndarray | None = None) -> Iterator[tuple[int, int]]:
    """(start, stop) of runs of at most BLOCK points, cut at ``edges`` too."""
    cuts = np.unique(np.concatenate([[0, n], [] if edges is None else edges])).astype(int)
    for lo, hi in pairwise(cuts.tolist()):
        for start in range(lo, hi, BLOCK):
            yield start, min(start + BLOCK, hi)


@dataclass
class _Scores:
    """Per smoothing: sum of squared leave-one-out residuals, largest |training
    residual| [arcsec]; when kept (``loo`` not None), every point's leave-one-out
    residual [arcsec] (points x smoothings) and the sum of squared training residuals
    [arcsec^2]."""

    sumsq: np.ndarray
    worst: np.ndarray
    n: int = 0
    loo: np.ndarray | None = None
    sse: np.ndarray | None = None

    def rms(self) -> np.ndarray:
        return np.sqrt(self.sumsq / max(self.n, 1))


def _score(sol: _Solution, phi: np.ndarray, y: np.ndarray, scores: _Scores,
           rows: slice | None = None) -> None:
    res, one_minus_h = sol.residuals(phi, y, SMOOTHING)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        loo = res / one_minus_h
        scores.sumsq += np.square(loo).sum(axis=0)
        if scores.loo is not None and scores.sse is not None and rows is not None:
            scores.loo[rows] = loo
            scores.sse += np.square(res).sum(axis=0)
    scores.worst = np.maximum(scores.worst, np.abs(res).max(axis=0, initial=0.0))
    scores.n += y.size


def _best(sol: _Solution, scores: _Scores, goal: float | None,
          best: tuple[tuple[bool, float], float] | None = None
          ) -> tuple[tuple[tuple[bool, float], float] | None, float]:
    """The best smoothing by choose_network's rule: within the goal first, then the
    smaller RMS leave-one-out residual (1e-9 of it a tie); weights a stream holds."""
    rms_all, best_rms = scores.rms(), np.inf
    for smoothing, rms, worst in zip(SMOOTHING, rms_all, scores.worst, strict=True):
        if not np.max(np.abs(sol.weights(float(smoothing))), initial=0.0) <= MAX_WEIGHT:
            continue
        rms = float(rms)
        if not np.isfinite(rms):
            continue
        best_rms = min(best_rms, rms)
        key = (goal is not None and float(worst) > goal, rms)
        if best is None or key[0] < best[0][0] or (key[0] == best[0][0]
                                                   and rms < best[0][1] * (1 - 1e-9)):
            best = (key, float(smoothing))
    return best, best_rms


def _even_subset(x: np.ndarray, most: int) -> np.ndarray:
    """Indices of ``most`` points spread evenly over the turn (every N/most-th in angle)."""
    order = np.argsort(x, kind="stable")
    return order[(np.arange(most) * (x.size / most)).astype(np.int64)]


def _subset_part(units: _Units, x: np.ndarray, y: np.ndarray) -> tuple[_Part, np.ndarray]:
    """The part of points [deg, arcsec] sorted by angle, and their Phi. At a narrow
    spread each run of :data:`SEARCH_RUN` points uses few units (:data:`NEGLIGIBLE`):
    where the runs' R, each over the units it uses, stack to under half the points'
    rows, the part is the QR of that stack; else one QR of every point's columns."""
    m = units.centres.size
    phi = units(x)
    runs = [(i, min(i + SEARCH_RUN, x.size)) for i in range(0, x.size, SEARCH_RUN)]
    used = [np.flatnonzero(phi[a:b].max(axis=0) >= NEGLIGIBLE) for a, b in runs]
    if 2 * sum(min(b - a, u.size + 2) for (a, b), u in zip(runs, used, strict=True)) >= x.size:
        part = _Part.empty(m)
        return part, part.add(units, x, y, phi)
    rs = []
    for (a, b), u in zip(runs, used, strict=True):
        run = np.empty((b - a, u.size + 2))
        run[:, 0], run[:, 1:-1], run[:, -1] = 1.0, phi[a:b, u], y[a:b]
        rs.append(_r_of_columns(run, np.r_[0, u + 1, m + 1], m + 2))
    stack = np.vstack(rs)
    cols = np.flatnonzero(np.any(stack, axis=0))
    return _Part(_r_of_columns(stack[:, cols], cols, m + 2), x.size, phi.sum(axis=0),
                 float(y.sum())), phi


def _search_spread(x: np.ndarray, y: np.ndarray, centres: np.ndarray, spreads: list[float],
                   goal: float | None, progress: Callable[[int, int], object] | None) -> float:
    """The spread [deg] whose best smoothing predicts the subset best (leave-one-out)."""
    pick = _even_subset(x, SEARCH_POINTS)
    xs, ys = x[pick], y[pick]
    best: tuple[tuple[bool, float], float] | None = None
    chosen = spreads[0]
    for k, spread in enumerate(spreads):
        units = _Units(centres, spread)
        part, phi = _subset_part(units, xs, ys)
        sol = _Solution(part, centres.size)
        scores = _Scores(np.zeros(SMOOTHING.size), np.zeros(SMOOTHING.size))
        _score(sol, phi, ys, scores)
        before = best
        best, _ = _best(sol, scores, goal, best)
        if best is not before:
            chosen = spread
        if progress is not None:
            progress(k + 1, len(spreads) + 2)
    if best is None:
        msg = "no spread gives finite leave-one-out residuals"
        raise DataError(msg)
    return chosen


@dataclass
class DenseFit:
    """The network, how it was chosen, and each point's blocked hold-out residual
    [arcsec] (NaN where its block's refit was not possible)."""

    model: RBFModel
    choice: Choice
    blocked: np.ndarray


def choose_dense(angle_deg: np.ndarray, error_arcsec: np.ndarray,
                 spread_deg: float | None = None,
                 progress: Callable[[int, int], object] | None = None,
                 goal: float | None = None) -> DenseFit:
    """The default network of :func:`rbf.choose_network` on many points, by blocks.

    Parameters
    ----------
    angle_deg, error_arcsec : distinct positions [deg] and deviations [arcsec].
    spread_deg : a fixed spread [deg]; None searches :data:`rbf.SPREAD_STEPS` centre
        spacings on an even subset of :data:`SEARCH_POINTS` points.
    progress : ``progress(done, total)`` after each spread and each pass over the points.
    goal : a training goal [arcsec], as choose_network's (the spread's on the subset).

    Returns
    -------
    DenseFit: the network fitted to every point with the chosen spread and smoothing
    (the smoothing chosen over every point), its :class:`rbf.Choice` with each point's
    leave-one-out residual [arcsec] in the input order, and the blocked hold-out
    residuals [arcsec] (:mod:`enctools.models.gain`, 24 blocks of 15 deg).
    """
    x, y, centres, spreads = search_grid(angle_deg, error_arcsec, spread_deg)
    total = len(spreads) + 2 if spread_deg is None else 2
    spread = (spreads[0] if spread_deg is not None or x.size <= 1
              else _search_spread(x, y, centres, spreads, goal, progress))
    block = block_index(x)
    order = np.lexsort((x, block))
    xs, ys, bs = x[order], y[order], block[order]
    edges = np.flatnonzero(np.diff(bs)) + 1
    units = _Units(centres, spread)
    parts = _factor(units, xs, ys, bs, edges)
    prefix = _prefixes(parts, centres.size)
    sol, scores = _scored(units, prefix[-1], xs, ys, edges)
    if progress is not None:
        progress(total - 1, total)
    best, best_rms = _best(sol, scores, goal)
    if best is None:
        msg = "no spread gives finite leave-one-out residuals"
        raise DataError(msg)
    key, smoothing = best
    held = _held_out(parts, prefix, units, smoothing)
    loo, blocked, sse = _final(units, sol, held, smoothing, xs, ys, bs, edges, scores)
    if progress is not None:
        progress(total, total)
    back = np.empty_like(order)
    back[order] = np.arange(order.size)
    model = sol.model(units, smoothing)
    model.sse = sse
    choice = Choice(spread, smoothing, loo[back], sol.effective(smoothing),
                    len(spreads) * SMOOTHING.size, None if goal is None else not key[0],
                    best_rms, (spreads[0], spreads[-1]))
    return DenseFit(model, choice, blocked[back])


def _scored(units: _Units, whole: _Part, xs: np.ndarray, ys: np.ndarray,
            edges: np.ndarray) -> tuple[_Solution, _Scores]:
    """The network of every point and, from a pass over the blocks, the leave-one-out
    and training figures of every smoothing."""
    sol = _Solution(whole, units.centres.size)
    scores = _Scores(np.zeros(SMOOTHING.size), np.zeros(SMOOTHING.size))
    if xs.size <= KEEP_LOO_POINTS:
        scores.loo, scores.sse = np.empty((xs.size, SMOOTHING.size)), np.zeros(SMOOTHING.size)
    for start, stop in _blocks(xs.size, edges):
        _score(sol, units(xs[start:stop]), ys[start:stop], scores, slice(start, stop))
    return sol, scores


def _factor(units: _Units, xs: np.ndarray, ys: np.ndarray, bs: np.ndarray,
            edges: np.ndarray) -> dict[int, _Part]:
    """The :class:`_Part` of each 15-deg block of points sorted by block."""
    parts: dict[int, _Part] = {}
    for start, stop in _blocks(xs.size, edges):
        part = parts.setdefault(int(bs[start]), _Part.empty(units.centres.size))
        part.add(units, xs[start:stop], ys[start:stop])
    return parts


def _prefixes(parts: dict[int, _Part], m: int) -> list[_Part]:
    """The parts of the blocks before each block in key order (the first empty), and last
    the part of every point: one merge a block, the whole network's factor among them."""
    prefix = [_Part.empty(m)]
    for k in sorted(parts):
        prefix.append(prefix[-1].join(parts[k]))
    return prefix


def _held_out(parts: dict[int, _Part], prefix: list[_Part], units: _Units,
              smoothing: float) -> dict[int, RBFModel | None]:
    """For each block k, the network fitted with ``smoothing`` to every other block (None
    where that is not possible): the part of the others as the prefix before k and the
    suffix after it, two merges a block. Empties ``parts`` and ``prefix``."""
    m = units.centres.size
    keys = sorted(parts)
    prefix.pop()        # every block's
    suffix, out = _Part.empty(m), {}
    for k in reversed(keys):
        rest = prefix.pop().join(suffix)
        try:
            out[k] = _Solution(rest, m).model(units, smoothing) if rest.n >= 2 else None
        except (ValueError, np.linalg.LinAlgError, ArithmeticError):
            out[k] = None
        suffix = parts.pop(k).join(suffix)
    return out


def _final(units: _Units, sol: _Solution, held: dict[int, RBFModel | None],
           smoothing: float, xs: np.ndarray, ys: np.ndarray, bs: np.ndarray,
           edges: np.ndarray, scores: _Scores) -> tuple[np.ndarray, np.ndarray, float]:
    """Each point's leave-one-out residual with the chosen smoothing and its residual
    against the network fitted without its block [arcsec] (points sorted by block), and
    the sum of the squared training residuals [arcsec^2]: the first and the last from
    the scoring pass where it kept them."""
    blocked = np.full(xs.size, np.nan)
    lam, sse = np.array([smoothing]), 0.0
    if scores.loo is not None and scores.sse is not None:
        j = int(np.flatnonzero(smoothing == SMOOTHING)[0])
        loo, sse = scores.loo[:, j].copy(), float(scores.sse[j])
        scores.loo = None
    else:
        loo = np.empty(xs.size)
    for start, stop in _blocks(xs.size, edges):
        phi, y = units(xs[start:stop]), ys[start:stop]
        if scores.sse is None:
            res, one_minus_h = sol.residuals(phi, y, lam)
            with np.errstate(divide="ignore", invalid="ignore"):
                loo[start:stop] = res[:, 0] / one_minus_h[:, 0]
            sse += float(res[:, 0] @ res[:, 0])
        fitted = held[int(bs[start])]
        if fitted is not None:
            blocked[start:stop] = y - (fitted.bias + phi @ fitted.weights)
    return loo, blocked, sse
