"""A deviations stream read a block of rows at a time: what the report needs of a long curve.

A stream of at most :data:`HOLD_ROWS` rows is held whole and reported as it always was
(:mod:`enctools.report.sections`). A longer one is never held: :func:`gather` reads its
batches and each block of rows adds, for every curve, to

- its figures: n, mean, smallest and largest value, the Bessel s of seed 001 eq. (8)
  (sums of squared deviations merged block by block: Chan, Golub and LeVeque, "Updating
  formulae and a pairwise algorithm for computing sample variances", 1979) and the rms;
- its harmonics n = 0..nmax: on a uniform grid over one period (in angle order), the
  sums c_n = sum_j y_j exp(-i n theta_j), the FFT's coefficients to rounding; on any
  other grid, the mean of each of :data:`ARCS` equal arcs, fitted as
  :func:`~enctools.report.figures.harmonics` fits any positions (a mean over an arc
  attenuates order n by sinc(n pi / ARCS): 0.1 % at n = 100);
- the plot's envelope: in each of :data:`COLUMNS` equal columns of the period, its
  smallest and largest value (where they are) and the largest u;
- the grid point nearest every :data:`MARK_DEG` of angle, which the results list.

Its memory does not grow with the rows: a block, and per curve some 10,000 numbers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.schemas import field_meta
from enctools.data.statistics import Figures
from enctools.errors import DataError
from enctools.report.figures import K_COVERAGE, Harmonics, harmonics
from enctools.units import DEG, TWO_PI

#: rows of a deviations stream held whole (and reported exactly as before) [rows]
HOLD_ROWS = 1 << 16
#: pixel columns a plotted series is binned to (wider than a plot: 792 px at 110 dpi)
COLUMNS = 1024
#: equal arcs a long curve off a uniform grid is averaged over for its harmonics
ARCS = 4096
#: the results list a long curve at the grid point nearest every MARK_DEG [deg]
MARK_DEG = 10.0
#: rows of a sub-block of the harmonic sums and the marks (their matrices stay small)
SUB_ROWS = 8192
#: a grid is uniform when every angle is within this fraction of a step of its place
UNIFORM_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Digest:
    """What a long curve keeps beside its envelope: the grid point nearest each mark
    (``angle`` [rad], ``values`` and ``u`` in the curve's unit) and, for a radial x curve
    with its y, the polar trace r = x cos(theta) + y sin(theta) binned as the envelope
    (angle [rad], r [nm])."""

    angle: np.ndarray
    values: np.ndarray
    u: np.ndarray | None = None
    polar: tuple[np.ndarray, np.ndarray] | None = None

    def scaled(self, k: float) -> Digest:
        """The digest with its values and u times ``k`` (another unit)."""
        return replace(self, values=self.values * k, u=None if self.u is None else self.u * k)

    def with_u(self, new_u: Callable[[np.ndarray], np.ndarray]) -> Digest:
        """The digest with its u as ``new_u`` makes it (a budget's u added)."""
        return self if self.u is None else replace(self, u=new_u(self.u))


@dataclass
class Long:
    """A long curve reduced: ``figures``, ``harmonics``, the envelope ``angle`` [rad],
    ``values`` and ``u`` (each column's largest) and its :class:`Digest`."""

    figures: Figures
    harmonics: Harmonics | None
    angle: np.ndarray
    values: np.ndarray
    u: np.ndarray | None
    digest: Digest
    #: rms of u over every row (a budget's Type A u), in the curve's unit
    u_rms: float | None = None


def _segments(col: np.ndarray, y: np.ndarray, x: np.ndarray, smallest: bool
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per column present in ``col`` (non-decreasing): the column, its extreme ``y`` and
    the ``x`` of its first occurrence."""
    starts = np.flatnonzero(np.r_[True, col[1:] != col[:-1]])
    reduce = np.fmin if smallest else np.fmax
    ext = reduce.reduceat(y, starts)
    seg = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, col.size]))
    hit = np.flatnonzero(y == ext[seg])
    first = hit[np.unique(seg[hit], return_index=True)[1]]
    keep = np.isin(np.arange(starts.size), seg[first])
    return col[starts][keep], ext[keep], x[first]


class Envelope:
    """Each column's smallest and largest value, where they are, and its largest u."""

    def __init__(self) -> None:
        self.lo = np.full(COLUMNS, np.inf)
        self.hi = np.full(COLUMNS, -np.inf)
        self.lo_x = np.zeros(COLUMNS)
        self.hi_x = np.zeros(COLUMNS)
        self.u = np.full(COLUMNS, -np.inf)

    def add(self, col: np.ndarray, x: np.ndarray, y: np.ndarray, u: np.ndarray | None) -> None:
        """A block: ``col`` non-decreasing, ``x`` [rad], ``y`` and ``u`` in their unit."""
        for smallest, best, where in ((True, self.lo, self.lo_x), (False, self.hi, self.hi_x)):
            c, ext, at = _segments(col, y, x, smallest)
            better = ext < best[c] if smallest else ext > best[c]
            best[c[better]], where[c[better]] = ext[better], at[better]
        if u is not None:
            np.maximum.at(self.u, col, u)

    def points(self, with_u: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The envelope as points in angle order: each column's smallest and largest."""
        has = np.flatnonzero(np.isfinite(self.lo))
        x = np.stack([self.lo_x[has], self.hi_x[has]], axis=1)
        y = np.stack([self.lo[has], self.hi[has]], axis=1)
        swap = x[:, 1] < x[:, 0]
        x[swap], y[swap] = x[swap][:, ::-1], y[swap][:, ::-1]
        one = x[:, 0] == x[:, 1]                 # the same point: drawn once
        keep = np.ones(x.shape, bool)
        keep[one, 1] = False
        u = np.repeat(self.u[has], 2).reshape(-1, 2)[keep] if with_u else None
        return x[keep], y[keep], u


@dataclass
class _Curve:
    """The sums of one curve over the blocks read so far."""

    name: str
    u_name: str | None
    n: int = 0
    mean: float = 0.0
    m2: float = 0.0
    sumsq: float = 0.0
    u_sq: float = 0.0
    lo: float = np.inf
    hi: float = -np.inf
    bad: int = 0
    dft: np.ndarray = field(default_factory=lambda: np.zeros(0, complex))
    arc_sum: np.ndarray = field(default_factory=lambda: np.zeros(ARCS))
    arc_n: np.ndarray = field(default_factory=lambda: np.zeros(ARCS))
    envelope: Envelope = field(default_factory=Envelope)
    mark_value: np.ndarray = field(default_factory=lambda: np.zeros(0))
    mark_u: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def add_figures(self, y: np.ndarray) -> None:
        """Chan et al.'s update of n, mean and the sum of squared deviations."""
        ok = np.isfinite(y)
        self.bad += int(y.size - np.count_nonzero(ok))
        y = y[ok] if self.bad else y
        if not y.size:
            return
        nb, mb = y.size, float(y.mean())
        m2b = float(np.sum((y - mb) ** 2))
        total = self.n + nb
        delta = mb - self.mean
        self.mean += delta * nb / total
        self.m2 += m2b + delta * delta * self.n * nb / total
        self.n = total
        self.sumsq += float(np.dot(y, y))
        self.lo, self.hi = min(self.lo, float(y.min())), max(self.hi, float(y.max()))

    def figures(self, source: str, rows: int) -> Figures:
        if self.bad or not self.n:
            msg = f"{source}: column {self.name!r}: {self.bad} of {rows} values are NaN or infinite"
            raise DataError(msg if self.n else f"{source}: column {self.name!r}: no values")
        std = float(np.sqrt(self.m2 / (self.n - 1))) if self.n > 1 else float("nan")
        return Figures(self.n, self.mean, self.lo, self.hi, self.hi - self.lo,
                       (self.hi - self.lo) / 2.0, std, float(np.sqrt(self.sumsq / self.n)))


def stated_k(schema: pa.Schema, u_column: str) -> float:
    """The coverage factor an uncertainty column states (field metadata ``k``, checked
    against its range when the stream was read), else 2."""
    k = field_meta(schema.field(u_column)).get("k")
    return K_COVERAGE if k is None else float(k)


def period_domain(meta: dict[str, Any], schema: pa.Schema) -> bool:
    """True when theta is the phase within a signal period (interpolation errors)."""
    domain = str(meta.get("domain", ""))
    return domain == "period" or domain.startswith("signal period") or any(
        "period_arcsec" in field_meta(f) for f in schema
        if field_meta(f).get("role") == "deviation")


def budget(s: Any, call: Callable[[], None], longs: dict[str, Long]) -> None:
    """Run ``call``, a budget of :mod:`enctools.report.budget` on the section ``s``, its
    long curves (``longs``, by name) standing in as two values of u whose mean square is
    the curve's, 0 and sqrt(2) u_rms, and their smallest and largest value: what the
    budget adds to u in quadrature is then the first's new u, added so to the envelope's
    and the marks' u, with the budget's k."""
    real = s.curves
    stand = [replace(c, u=np.array([0.0, np.sqrt(2.0) * longs[c.name].u_rms]),
                     values=np.array([c.figures.minimum, c.figures.maximum]))
             if c.name in longs and longs[c.name].u_rms is not None else c for c in real]
    s.curves = stand
    try:
        call()
    finally:
        s.curves = real
    for c, st in zip(real, stand, strict=True):
        if st is not c and st.u is None:        # its U refused (report.budget.refuse)
            c.u, c.digest = None, replace(c.digest, u=None)
        elif st is not c and (st.u[0] > 0.0 or st.k != c.k):
            added = float(st.u[0]) ** 2
            c.u = np.sqrt(np.square(c.u) + added)
            c.digest = c.digest.with_u(lambda u, b2=added: np.sqrt(np.square(u) + b2))
            c.k = st.k


class Gatherer:
    """The sums of every curve of a long deviations stream, added a block at a time.

    ``curves``: (column, its uncertainty column or None) in the stream's units;
    ``nmax``: the highest harmonic order; ``rows``: the rows the file claims (None: a
    pipe's, known at its end); ``polar``: the radial x and y columns whose polar trace
    is binned (None: none)."""

    def __init__(self, curves: list[tuple[str, str | None]], nmax: int, rows: int | None,
                 polar: tuple[str, str] | None = None) -> None:
        self.marks = np.arange(0.0, 360.0, MARK_DEG)
        self.curves = [_Curve(name, u, dft=np.zeros(nmax + 1, complex),
                              mark_value=np.zeros(self.marks.size),
                              mark_u=np.zeros(self.marks.size)) for name, u in curves]
        self.nmax, self.rows, self.polar_of = nmax, 0, polar
        self.polar = Envelope() if polar else None
        self.x0: float | None = None
        self.step = TWO_PI / rows if rows else None   # rad
        self.ordered, self.last = True, -np.inf
        self.spans: list[tuple[int, int, float, float]] = []  # rows, deviation from the grid
        self.mark_gap = np.full(self.marks.size, np.inf)
        self.mark_angle = np.zeros(self.marks.size)
        self._powers: np.ndarray | None = None   # exp(-i n j step), j < SUB_ROWS

    def add(self, theta: np.ndarray, cols: dict[str, np.ndarray]) -> None:
        """A block: ``theta`` [rad] and each column by name, in the curve's unit."""
        self._grid(theta)
        phase = np.mod(theta, TWO_PI)
        col = np.minimum((phase * (COLUMNS / TWO_PI)).astype(np.int64), COLUMNS - 1)
        arc = np.minimum((phase * (ARCS / TWO_PI)).astype(np.int64), ARCS - 1)
        order = None if np.all(col[1:] >= col[:-1]) else np.argsort(col, kind="stable")

        def envelope(env: Envelope, y: np.ndarray, u: np.ndarray | None) -> None:
            if order is None:
                env.add(col, theta, y, u)
            else:
                env.add(col[order], theta[order], y[order], None if u is None else u[order])

        for c in self.curves:
            y, u = cols[c.name], cols.get(c.u_name or "")
            c.add_figures(y)
            c.arc_sum += np.bincount(arc, weights=y, minlength=ARCS)
            c.arc_n += np.bincount(arc, minlength=ARCS)
            if u is not None:
                c.u_sq += float(np.dot(u, u))
            envelope(c.envelope, y, u)
        if self.polar is not None and self.polar_of is not None:
            x_name, y_name = self.polar_of
            envelope(self.polar, cols[x_name] * np.cos(theta) + cols[y_name] * np.sin(theta),
                     None)
        for start in range(0, theta.size, SUB_ROWS):
            part = slice(start, start + SUB_ROWS)
            self._sub(self.rows + start, theta[part], {k: v[part] for k, v in cols.items()})
        self.rows += theta.size

    def _grid(self, theta: np.ndarray) -> None:
        """Whether the angles so far are in order and where they stand off a uniform grid."""
        if self.x0 is None:
            self.x0 = float(theta[0])
        if self.step is None and self.rows + theta.size > 1:
            self.step = (float(theta[-1]) - self.x0) / (self.rows + theta.size - 1)
        self.ordered = self.ordered and bool(theta[0] > self.last) and bool(
            np.all(np.diff(theta) > 0))
        self.last = float(theta[-1])
        j = self.rows + np.arange(theta.size)
        off = theta - self.x0 - j * (self.step or 0.0)
        self.spans.append((self.rows, self.rows + theta.size - 1, float(off.min()),
                           float(off.max())))

    def _sub(self, first: int, theta: np.ndarray, cols: dict[str, np.ndarray]) -> None:
        """The harmonic sums and the nearest grid points of a few thousand rows, the
        first of them row ``first`` of the stream."""
        if self.curves:
            self._harmonic_sums(first, theta.size, cols)
        angle = np.mod(theta / DEG, 360.0)
        pick = np.arange(theta.size)
        if np.all(np.diff(angle) > 0):   # in order: each mark's neighbours, and the ends
            at = np.searchsorted(angle, self.marks)
            pick = np.unique(np.clip(np.r_[at - 1, at, 0, theta.size - 1], 0, theta.size - 1))
        gap = np.abs(((angle[pick][None, :] - self.marks[:, None]) + 180.0) % 360.0 - 180.0)
        near = np.argmin(gap, axis=1)
        better = gap[np.arange(near.size), near] < self.mark_gap
        self.mark_gap[better] = gap[np.flatnonzero(better), near[better]]
        at = pick[near[better]]
        self.mark_angle[better] = theta[at]
        for c in self.curves:
            c.mark_value[better] = cols[c.name][at]
            if c.u_name is not None:
                c.mark_u[better] = cols[c.u_name][at]

    def _harmonic_sums(self, first: int, size: int, cols: dict[str, np.ndarray]) -> None:
        """c_n += sum_j y_j exp(-i n theta_j) over rows ``first`` .. ``first + size - 1``,
        at the places of the uniform grid theta_j = theta_0 + j step (as the FFT takes
        them; they are used only if the angles are that grid)."""
        n = np.arange(self.nmax + 1)
        if self._powers is None and self.step is not None:
            self._powers = np.exp(-1j * np.outer(np.arange(SUB_ROWS), n) * self.step)
        # no step yet: the stream's first row alone, at j = 0
        powers = self._powers if self._powers is not None else np.ones((size, n.size))
        turn = np.exp(-1j * n * ((self.x0 or 0.0) + first * (self.step or 0.0)))
        sums = np.stack([cols[c.name] for c in self.curves]) @ powers[:size]
        for c, s in zip(self.curves, sums, strict=True):
            c.dft += s * turn

    def uniform(self) -> bool:
        """True when the angles read are a uniform grid over one period, in order (each
        within :data:`UNIFORM_TOLERANCE` of a step of its place)."""
        n = self.rows
        if n < 4 or not self.ordered or self.step is None:
            return False
        step = TWO_PI / n
        drift = step - self.step
        worst = max(max(abs(lo - max(a * drift, b * drift)), abs(hi - min(a * drift, b * drift)))
                    for a, b, lo, hi in self.spans)
        return worst <= UNIFORM_TOLERANCE * step

    def _harmonics(self, c: _Curve) -> Harmonics | None:
        nmax = min((self.rows - 1) // 2, self.nmax)
        if self.uniform() and nmax >= 1:
            coef = c.dft[:nmax + 1] * (2.0 / self.rows)
            coef[0] /= 2.0
            a, b = coef.real, -coef.imag
            return Harmonics(np.arange(nmax + 1), np.hypot(a, b), np.arctan2(-b, a),
                             positions=self.rows)
        has = c.arc_n > 0
        centres = (np.arange(ARCS) + 0.5) * (TWO_PI / ARCS)
        try:
            return harmonics(centres[has], c.arc_sum[has] / c.arc_n[has], self.nmax)
        except DataError:
            return None

    def results(self, source: str) -> dict[str, Long]:
        """Each curve reduced (DataError naming the column when a value is NaN)."""
        out = {}
        polar = None if self.polar is None else self.polar.points(False)[:2]
        for c in self.curves:
            angle, values, u = c.envelope.points(c.u_name is not None)
            digest = Digest(self.mark_angle.copy(), c.mark_value,
                            None if c.u_name is None else c.mark_u,
                            polar if self.polar_of and c.name == self.polar_of[0] else None)
            out[c.name] = Long(c.figures(source, self.rows), self._harmonics(c), angle, values,
                               u, digest, None if c.u_name is None
                               else float(np.sqrt(c.u_sq / max(self.rows, 1))))
        return out


def radial_pair(names: list[str]) -> tuple[str, str] | None:
    """The radial curves the polar plot combines: the first whose name ends in x and the
    first in y (case aside), as :func:`enctools.report.plots.radial_polar_plot` picks."""
    byname = {n.lower(): n for n in names}
    xs = [n for low, n in byname.items() if low.endswith("x")]
    ys = [n for low, n in byname.items() if low.endswith("y")]
    return (xs[0], ys[0]) if xs and ys else None


def address_angle(entries: Any, source: str
                  ) -> Callable[[pa.RecordBatch | pa.Table], np.ndarray]:
    """A correction table's block of rows to angles [rad]: its addresses over its size,
    ``entries`` (metadata ``rom.entries``, enc-streams(5)); DataError when the size is not
    a whole number > 0, or, for a table read in blocks, not stated."""
    if entries is not None and not (isinstance(entries, int) and not isinstance(entries, bool)
                                    and entries > 0):
        msg = f"{source}: rom.entries must be a whole number of addresses > 0, not {entries!r}"
        raise DataError(msg)

    def angle(b: pa.RecordBatch | pa.Table) -> np.ndarray:
        if entries is None:
            msg = (f"{source}: a correction table of over {HOLD_ROWS} addresses must state "
                   "its size (rom.entries)")
            raise DataError(msg)
        address = b.column("address").to_numpy(zero_copy_only=False).astype(np.float64)
        return address * (TWO_PI / entries)

    return angle


def gather(stream: Any, curves: list[tuple[str, str, str | None]], nmax: int,
           polar: tuple[str, str] | None,
           angle: Callable[[pa.RecordBatch], np.ndarray] | None = None) -> pa.Table | Gatherer:
    """A deviations stream of at most :data:`HOLD_ROWS` rows as one table; a longer one
    summed by a :class:`Gatherer`, block by block. ``curves``: (column, unit, uncertainty
    column or None); ``angle``: a block's angles [rad] (default its theta column, read
    in rad; a correction table's: its addresses over the table's size)."""
    from enctools.data.columns import column

    if angle is None:
        def angle(b: pa.RecordBatch) -> np.ndarray:
            return column(b, "theta", "rad", stream.source)

    held: list[pa.RecordBatch] = []
    rows = 0
    batches = stream.batches()
    for b in batches:
        held.append(b)
        rows += b.num_rows
        if rows > HOLD_ROWS:
            break
    else:
        return pa.Table.from_batches(held, schema=stream.schema)
    g = Gatherer([(name, u) for name, _, u in curves], nmax, stream.claimed_rows, polar)
    units = {name: unit for name, unit, _ in curves} | {
        u: unit for _, unit, u in curves if u is not None}

    def add(b: pa.RecordBatch) -> None:
        if b.num_rows:
            g.add(angle(b),
                  {name: column(b, name, unit, stream.source) for name, unit in units.items()})

    while held:
        add(held.pop(0))
    for b in batches:
        add(b)
    return g
