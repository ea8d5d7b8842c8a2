"""Trigonometric (Fourier-series) least-squares error model on the circle.

The alternative to the RBF network of seed 001 sec. 4: the error [arcsec] at angle
x as ``a_0 + sum_{n=1..K} a_n cos(n x) + b_n sin(n x)``, fitted by linear least
squares to the calibration points. With N equally spaced points the terms above
N/2 alias onto lower ones and ``sin(N/2 x)`` vanishes at every point: such terms
are not determined by the data (``undetermined``). On uneven points the design
grows ill-conditioned well before N/2: orders past the condition limit
(:data:`COND_LIMIT`) are ``ill_conditioned``. Both kinds are left out of the fit
(their coefficients are exactly 0) and named. The default order
(:func:`choose_order`) is the one with the smallest leave-one-out residual, in
closed form from one QR.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from enctools.units import DEG, TWO_PI

#: points in a row of :meth:`FourierModel.on_grid` (one BLAS product a chunk of rows)
GRID_ROW = 4096
#: the largest condition number of the design a fit keeps (dimensionless): noise in the
#: points reaches the coefficients amplified by up to this
COND_LIMIT = 100.0
#: the highest order the default series tries (513 unknowns: one QR of N x 513)
DEFAULT_MAX_ORDER = 256
#: the largest condition number of the design whose harmonics are figures of the turn
#: (dimensionless; enc report): a model may predict between its points through a design of
#: :data:`COND_LIMIT`, but an amplitude stated for the whole turn must not move by more
#: than 10x what the points' scatter and the orders left out move them (N even positions
#: over the turn: sqrt(2); 24 positions over 120 deg reach 10 at n = 1)
RESOLVE_LIMIT = 10.0


@dataclass
class FourierModel:
    """Harmonics n = 0..K with cosine ``a`` and sine ``b`` coefficients [arcsec]."""

    n: np.ndarray
    a: np.ndarray
    b: np.ndarray
    undetermined: list[str] = field(default_factory=list)
    ill_conditioned: list[str] = field(default_factory=list)
    limit: int | None = None        # highest order the points condition (None: not checked)
    condition: float | None = None  # condition number of the fitted terms' design

    def __call__(self, angle_deg: np.ndarray | float, chunk: int = 1 << 21) -> np.ndarray:
        """The model's error [arcsec] at angles [deg]."""
        x = np.asarray(angle_deg, dtype=np.float64)
        flat = x.reshape(-1)
        out = np.empty(flat.shape, dtype=np.float64)
        c = self.a - 1j * self.b  # a cos + b sin = Re(c e^{i n x})
        for start in range(0, flat.size, chunk):
            z = np.exp(1j * flat[start:start + chunk] * DEG)
            # Horner in z over the integer orders 0..K (Re of a polynomial in z)
            coef = np.zeros(int(self.n.max()) + 1 if self.n.size else 1, dtype=np.complex128)
            np.add.at(coef, self.n.astype(int), c)
            acc = np.full(z.shape, coef[-1], dtype=np.complex128)
            for ck in coef[-2::-1]:
                acc *= z
                acc += ck
            out[start:start + chunk] = acc.real
        return out.reshape(x.shape)

    def on_grid(self, first_deg: float, step_deg: float) -> GridSeries:
        """The model [arcsec] at the uniform grid ``first_deg + k * step_deg``, k = start..stop-1.

        Returns ``values(start, stop)`` (a :class:`GridSeries`). A grid of L =
        :data:`GRID_ROW` points is a row; row j starts at angle x_j and point i of it
        lies at x_j + h_i, so ``cos n(x_j + h_i)`` and ``sin n(x_j + h_i)`` split into a
        (rows x 2K+2) matrix of the rows' phases times a (2K+2 x L) matrix of the
        coefficients turned by h_i: one BLAS product per chunk, 2 (K+1) multiply-adds a
        point instead of K complex Horner steps. Phases are reduced in turns, so large
        orders keep their accuracy.
        """
        return GridSeries(self, first_deg, step_deg)


#: points of a row that :meth:`GridSeries.near` takes from one cubic (divides GRID_ROW)
SEGMENT = 64
#: the unit roundoff of float64
_U = 2.0 ** -53


class GridSeries:
    """A Fourier series [arcsec] on the grid ``first_deg + k * step_deg``: ``values(start,
    stop)`` exactly as :meth:`FourierModel.on_grid` describes, or (:meth:`near`) from a
    cubic a :data:`SEGMENT` of points, within a bound stated with it."""

    def __init__(self, model: FourierModel, first_deg: float, step_deg: float) -> None:
        self.n = np.asarray(model.n, dtype=np.float64)
        self.first, self.step = first_deg, step_deg
        self.turn = self._turned(model, np.arange(GRID_ROW, dtype=np.float64))
        # Taylor's terms of each segment at its centre c, in t = i - c [point]: the k-th
        # derivative of a cos(n u) + b sin(n u) in t turns (a, b) by k quarter turns and
        # scales them by w^k, w = 2 pi n step [rad a point]
        centre = np.arange(0, GRID_ROW, SEGMENT) + (SEGMENT - 1) / 2.0
        t0 = self._turned(model, centre)
        k = t0.shape[0] // 2
        w = (TWO_PI * (step_deg / 360.0) * self.n)[:, None]
        a_c, b_c = t0[:k], t0[k:]
        terms = [t0, np.vstack([w * b_c, -w * a_c]),
                 np.vstack([-w ** 2 / 2 * a_c, -w ** 2 / 2 * b_c]),
                 np.vstack([-w ** 3 / 6 * b_c, w ** 3 / 6 * a_c])]
        # (2K+2, segments * 4): a row's phases times this are each segment's 4 terms
        self.taylor = np.stack(terms, axis=2).reshape(t0.shape[0], -1)
        t = np.arange(SEGMENT) - (SEGMENT - 1) / 2.0
        self.powers = np.vstack([np.ones(SEGMENT), t, t * t, t * t * t])  # (4, SEGMENT)
        r = np.hypot(model.a, model.b)
        # the cubic's remainder, w^4 r |t|^4 / 24 summed, and twice the rounding of either
        # evaluation (the phases' reduction, the products, the sums of 2K+2 terms) [arcsec]
        rest = float(np.sum(w[:, 0] ** 4 * r)) * (SEGMENT / 2.0) ** 4 / 24.0
        rounding = 4.0 * _U * float(np.sum(r * (40.0 * self.n + 4.0 * self.n.size + 40.0)))
        self.bound = rest + 2.0 * rounding

    def _turned(self, model: FourierModel, points: np.ndarray) -> np.ndarray:
        """The coefficients turned by h = points * step: (2K+2, len(points))."""
        h = points * (self.step / 360.0)
        nh = np.mod(np.multiply.outer(self.n, h), 1.0) * TWO_PI
        cos_nh, sin_nh = np.cos(nh), np.sin(nh)
        a, b = model.a[:, None], model.b[:, None]
        return np.vstack([a * cos_nh + b * sin_nh, b * cos_nh - a * sin_nh])

    def _phases(self, start: int, stop: int) -> np.ndarray:
        """The phases' cosines and sines of the rows from ``start``: (rows, 2K+2)."""
        rows = -(-(stop - start) // GRID_ROW)
        k = start + GRID_ROW * np.arange(rows, dtype=np.float64)
        x0 = (self.first + k * self.step) / 360.0
        phase = np.mod(np.multiply.outer(x0, self.n), 1.0) * TWO_PI  # (rows, K+1) [rad]
        return np.hstack([np.cos(phase), np.sin(phase)])

    def __call__(self, start: int, stop: int) -> np.ndarray:
        """The series [arcsec] at points start..stop-1."""
        out = self._phases(start, stop) @ self.turn
        return out.reshape(-1)[:stop - start]

    def near(self, start: int, stop: int) -> tuple[np.ndarray, float]:
        """The series [arcsec] at points start..stop-1 from a cubic a segment of
        :data:`SEGMENT` points (4 (2K+2) / SEGMENT multiply-adds a point for its terms,
        then 4 for the cubic: two BLAS products), and the bound [arcsec] of its distance
        from :meth:`__call__`'s values."""
        return (self.terms(start, stop) @ self.powers).reshape(-1)[:stop - start], self.bound

    def terms(self, start: int, stop: int) -> np.ndarray:
        """Each segment's cubic from point ``start`` on, (segments, 4) [arcsec]: its value at
        the segment's centre and the Taylor terms of degree 1, 2, 3 in t = i - c [point]
        (the rows of :attr:`powers`: 1, t, t^2, t^3 at the segment's points); whole rows
        of :data:`GRID_ROW` points, past ``stop`` if it ends within one."""
        return (self._phases(start, stop) @ self.taylor).reshape(-1, 4)


def design_matrix(x_rad: np.ndarray, harmonics: int) -> np.ndarray:
    """Columns 1, cos x, sin x, ..., cos Kx, sin Kx at angles ``x_rad`` [rad]."""
    x = np.asarray(x_rad, dtype=np.float64).reshape(-1, 1)
    n = np.arange(1, harmonics + 1).reshape(1, -1)
    cols = [np.ones((x.shape[0], 1))]
    for k in range(harmonics):
        cols += [np.cos(n[:, k:k + 1] * x), np.sin(n[:, k:k + 1] * x)]
    return np.hstack(cols)


@dataclass(frozen=True)
class Terms:
    """Which terms of a series of order K the points determine (column j of
    :func:`design_matrix`: 0 is a0, 2k-1 is a_k, 2k is b_k).

    kept : the columns fitted; undetermined : names of terms the points cannot tell
    from lower ones (aliases, ``sin(N/2 x)`` on N even points); ill_conditioned :
    names of the terms of the orders past the condition limit; limit : the highest
    order kept (the condition limit for these points); condition : the condition
    number of the kept columns (dimensionless).
    """

    kept: np.ndarray
    undetermined: list[str]
    ill_conditioned: list[str]
    limit: int
    condition: float


def term_names(harmonics: int) -> list[str]:
    """``a0, a1, b1, ..., aK, bK``: the columns of :func:`design_matrix`."""
    return ["a0"] + [f"{p}{k}" for k in range(1, harmonics + 1) for p in ("a", "b")]


def _orders(columns: np.ndarray) -> np.ndarray:
    return (np.asarray(columns) + 1) // 2


def determined_terms(x_rad: np.ndarray, harmonics: int, cond_limit: float = COND_LIMIT
                     ) -> tuple[Terms, np.ndarray, np.ndarray]:
    """The terms of orders 0..K that angles ``x_rad`` [rad] determine, and the QR of them.

    A term whose column has less than 1e-9 of its norm outside the span of the lower
    terms is undetermined (it aliases). Of the rest, orders are kept from 0 up while
    the kept columns' condition number stays within ``cond_limit`` (dimensionless,
    :data:`COND_LIMIT` by default); the orders above are ill-conditioned. Returns the
    :class:`Terms`, and Q (N x kept) and R of the kept columns in order.
    """
    a = design_matrix(x_rad, harmonics)
    r = np.asarray(np.linalg.qr(a, mode="r"))   # R alone: no N x (2K+1) Q
    terms = _terms(r, np.linalg.norm(a, axis=0), harmonics, cond_limit)
    qk, rk = np.linalg.qr(a[:, terms.kept])
    return terms, qk, rk


def _terms(r: np.ndarray, norms: np.ndarray, harmonics: int, cond_limit: float) -> Terms:
    """:func:`determined_terms`'s choice from the R of the design (any rows beyond
    min(N, 2K+1) zero) and its columns' norms."""
    diag = np.zeros(r.shape[1])
    diag[:min(r.shape)] = np.abs(np.diag(r))
    independent = np.flatnonzero(diag > 1e-9 * np.maximum(norms, 1e-300))
    names = term_names(harmonics)

    def cond(order: int) -> float:
        cols = independent[_orders(independent) <= order]
        sv = np.linalg.svd(r[:, cols], compute_uv=False)
        return float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else np.inf

    limit = harmonics
    if cond(limit) > cond_limit:   # cond grows with the order: bisect for the last one within
        lo, hi = 0, harmonics
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (mid, hi) if cond(mid) <= cond_limit else (lo, mid)
        limit = lo
    kept = independent[_orders(independent) <= limit]
    dependent = np.setdiff1d(np.arange(r.shape[1]), independent)
    ill = independent[_orders(independent) > limit]
    return Terms(kept, [names[j] for j in dependent], [names[j] for j in ill], limit,
                 cond(limit))


def fit_fourier(angle_deg: np.ndarray, error_arcsec: np.ndarray, harmonics: int,
                cond_limit: float = COND_LIMIT) -> FourierModel:
    """Least-squares Fourier series of orders 0..K through points [deg, arcsec], on the
    terms the points determine within ``cond_limit`` (:func:`determined_terms`); the
    others are exactly 0 and named in ``undetermined`` and ``ill_conditioned``."""
    model, _ = fit_with_loo(angle_deg, error_arcsec, harmonics, cond_limit)
    return model


def _model(harmonics: int, terms: Terms, coef: np.ndarray) -> FourierModel:
    sol = np.zeros(2 * harmonics + 1)
    sol[terms.kept] = coef
    n = np.arange(harmonics + 1)
    acoef = np.concatenate([[sol[0]], sol[1::2]])
    bcoef = np.concatenate([[0.0], sol[2::2]])
    return FourierModel(n, acoef, bcoef, terms.undetermined, terms.ill_conditioned,
                        terms.limit, terms.condition)


def fit_with_loo(angle_deg: np.ndarray, error_arcsec: np.ndarray, harmonics: int,
                 cond_limit: float = COND_LIMIT) -> tuple[FourierModel, np.ndarray]:
    """:func:`fit_fourier` and its leave-one-out residuals [arcsec], in closed form
    (``r_i / (1 - H_ii)``, the same terms fitted without point i); NaN where a point
    is interpolated (H_ii = 1: without it the terms are not determined)."""
    x = np.asarray(angle_deg, dtype=np.float64) * DEG
    y = np.asarray(error_arcsec, dtype=np.float64)
    terms, q, r = determined_terms(x, harmonics, cond_limit)
    qy = q.T @ y
    coef = np.linalg.solve(r, qy) if r.size else np.zeros(0)
    resid = y - q @ qy
    h = np.sum(q * q, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        loo = np.where(h < 1.0 - 1e-9, resid / (1.0 - h), np.nan)
    return _model(harmonics, terms, coef), loo


def blocked_residuals(angle_deg: np.ndarray, error_arcsec: np.ndarray, block: np.ndarray,
                      harmonics: int, cond_limit: float = COND_LIMIT) -> np.ndarray:
    """Each point's residual [arcsec] against :func:`fit_fourier` of order K fitted to
    the points of the other blocks (``block``: each point's block number); NaN where
    fewer than 2 points are left or that fit fails.

    One pass over the points: the R of each block's columns [design, deviations]; the
    others' R as a prefix and a suffix product (the QR of stacked R, (2K+2) words
    square); their fit by :func:`determined_terms`'s rule and the least squares of the
    kept terms from that R (a = QR, so a[:, kept] = Q R[:, kept]): to rounding the
    series a refit over the other points gives, no refit over them.
    """
    x = np.asarray(angle_deg, dtype=np.float64)
    y = np.asarray(error_arcsec, dtype=np.float64)
    a = np.hstack([design_matrix(x * DEG, harmonics), y[:, None]])
    keys = np.unique(block)
    held = [block == k for k in keys]
    rs = [np.asarray(np.linalg.qr(a[h], mode="r")) for h in held]
    prefix = [np.zeros((0, a.shape[1]))]
    for r in rs[:-1]:
        prefix.append(np.asarray(np.linalg.qr(np.vstack([prefix[-1], r]), mode="r")))
    out, suffix = np.full(y.shape, np.nan), np.zeros((0, a.shape[1]))
    for i in reversed(range(len(keys))):
        rest = np.vstack([prefix.pop(), suffix])
        rest = np.asarray(np.linalg.qr(rest, mode="r")) if rest.size else rest
        suffix = np.asarray(np.linalg.qr(np.vstack([rs[i], suffix]), mode="r"))
        if y.size - np.count_nonzero(held[i]) < 2:
            continue
        try:
            model = _fit_from_r(rest, harmonics, cond_limit)
        except (ValueError, np.linalg.LinAlgError, ArithmeticError):
            continue
        out[held[i]] = y[held[i]] - model(x[held[i]])
    return out


def _fit_from_r(rest: np.ndarray, harmonics: int, cond_limit: float) -> FourierModel:
    """:func:`fit_fourier` from the R of the points' columns [design, deviations]."""
    c = 2 * harmonics + 1
    r = np.zeros((c + 1, c + 1))
    r[:rest.shape[0]] = rest
    terms = _terms(r[:c, :c], np.linalg.norm(r[:, :c], axis=0), harmonics, cond_limit)
    k = terms.kept.size
    t = np.asarray(np.linalg.qr(r[:, np.r_[terms.kept, c]], mode="r"))
    coef = np.linalg.solve(t[:k, :k], t[:k, k]) if k else np.zeros(0)
    return _model(harmonics, terms, coef)


def arc_coverage_deg(angle_deg: np.ndarray) -> float:
    """The arc of the turn that positions [deg] cover [deg]: 360 less the largest gap
    between neighbours on the circle (0 for one position; positions modulo 360)."""
    x = np.unique(np.mod(np.asarray(angle_deg, dtype=np.float64).ravel(), 360.0))
    if x.size < 2:
        return 0.0
    gaps = np.diff(np.r_[x, x[0] + 360.0])
    return float(360.0 - gaps.max())


def design_condition(x_rad: np.ndarray, harmonics: int) -> float:
    """The condition number (dimensionless) of :func:`design_matrix` of orders 0..K at
    angles ``x_rad`` [rad]: how much the coefficients of a least-squares fit may
    magnify an error of the points (inf when the points do not determine them: fewer
    distinct angles than the 2K + 1 terms)."""
    a = design_matrix(x_rad, harmonics)
    if a.shape[0] < a.shape[1]:
        return float("inf")
    sv = np.linalg.svd(a, compute_uv=False)
    return float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf")


def choose_order(angle_deg: np.ndarray, error_arcsec: np.ndarray,
                 most: int = DEFAULT_MAX_ORDER) -> tuple[FourierModel, np.ndarray]:
    """The default series: the order with the smallest RMS leave-one-out residual.

    Orders 0..min(most, (m-1)/2) for m distinct positions (never more unknowns than
    points), within the condition limit (:func:`determined_terms`). One QR of the
    highest order serves every order: the columns are nested, so order k's hat
    matrix is the first columns of Q. Returns the model refitted at that order, its
    ``limit`` the highest order tried (the condition limit when it is lower than the
    ceiling), and its leave-one-out residuals [arcsec].
    """
    x = np.asarray(angle_deg, dtype=np.float64) * DEG
    y = np.asarray(error_arcsec, dtype=np.float64)
    top = max(0, min(int(most), (x.size - 1) // 2))
    terms, q, _ = determined_terms(x, top)
    qy = q.T @ y
    # order k's fit and leverage are the sums over Q's first columns: summed a column at
    # a time (a few N-vectors, not N x (2K+1) arrays of each)
    fitted, h = np.zeros(x.size), np.zeros(x.size)
    press = np.empty(q.shape[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        for j in range(q.shape[1]):
            fitted += q[:, j] * qy[j]
            h += q[:, j] * q[:, j]
            press[j] = np.sqrt(np.mean(((y - fitted) / (1.0 - h)) ** 2))
    orders = _orders(terms.kept)
    last = np.r_[orders[1:] != orders[:-1], True]   # the last column of each order
    candidates = np.flatnonzero(last & np.isfinite(press))
    best = candidates[np.argmin(press[candidates])] if candidates.size else 0
    order = int(orders[best])
    model, loo = fit_with_loo(angle_deg, y, order)
    model.limit = terms.limit
    return model, loo
