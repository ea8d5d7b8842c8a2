"""The polygon step run's measurement model propagated through GTC (the GUM Tree Calculator).

The model of point j of one run against its datum, the run's first position (seed 001
sec. 5.3; :mod:`enctools.methods.budget`):

    D_j = x_j + (r_j - r_0) + (1/N) sum_k (Q_jk - Q_0k) - (delta_j - delta_0)
          - (a_j - a_0) kappa + z

x_j the measured deviation [arcsec] (the estimate), r_i the repeatability of position
i's mean of n readings (Type A: the run's pooled s / sqrt(n), one estimate of s for
every position, so the r_i are one GTC ensemble on its dof), Q_ik the quantisation of
head k's mean at position i (u_q, :func:`enctools.methods.budget.quantisation`),
delta_i the polygon's face angle at position i (its certificate's u, or the rig's
declaration when the faces are not corrected), kappa the autocollimator's scale error
and a_i - a_0 the autocollimator's indication at position i against the datum's
[arcsec], z the zero's drift since the datum where a closing reading at 360 deg bounds
it (:func:`enctools.methods.budget.closing_drift`, one input common to the points).
Every input is a GTC uncertain real labelled with its row's name, so GTC
carries what the points share: the datum's r_0, Q_0k and delta_0 and kappa enter every
point, and any two points correlate (r about 0.5 when the datum's terms are half of a
point's variance). From the same inputs: each point's u and nu_eff, the covariance
matrix, the U of the difference of two points (the datum's terms cancel), of p-p taken
as the difference of the two extreme points, and of the amplitude of each harmonic.

GTC: B. D. Hall, "The GUM Tree Calculator", Measurement Standards Laboratory of New
Zealand (https://gtc.readthedocs.io); Welch-Satterthwaite with an ensemble of inputs
sharing one estimate's dof: R. Willink, Metrologia 44 (2007) 340-349. Units: arcsec.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from enctools.data.uncertainty import UNITS, Declaration
from enctools.errors import DataError
from enctools.methods.budget import PolygonRun, coverage_factor, dithered_quantisation
from enctools.methods.polygon_terms import POLYGON_TERMS

#: the highest harmonic order whose amplitude's U is stated (below F/2: one sample a half
#: period is no amplitude)
MAX_ORDER = 12


@dataclass(frozen=True)
class Faces:
    """The polygon's face angles: ``u_arcsec`` the standard uncertainty of each face's
    angle, the face at the datum first [arcsec], on ``dof``
    degrees of freedom (``math.inf``: Type B taken as exact), ``kind`` "A" or "B", its
    ``source``, and ``corrected``: the certified errors were applied (else ``u`` is of the
    uncorrected faces' own errors)."""

    u_arcsec: np.ndarray
    dof: float = math.inf
    kind: str = "B"
    source: str = ""
    corrected: bool = True


@dataclass(frozen=True)
class Figure:
    """A derived figure's standard uncertainty [arcsec], nu_eff, k and U = k u."""

    u: float
    dof: float
    k: float

    @property
    def U(self) -> float:
        return self.k * self.u


@dataclass(frozen=True)
class PointsModel:
    """The model's results: per point ``u`` [arcsec], ``dof``, ``k`` (0 u at the datum),
    the covariance [arcsec^2] and correlation matrices, the difference of two points (the
    pair of the largest U), p-p as the difference of ``extremes`` = (index of the largest,
    of the smallest deviation), and the harmonics' amplitudes: ``orders``, ``amplitude``
    [arcsec] and their figures."""

    u: np.ndarray
    dof: np.ndarray
    k: np.ndarray
    cov: np.ndarray
    corr: np.ndarray
    difference: Figure
    pair: tuple[int, int]
    pp: Figure
    extremes: tuple[int, int]
    orders: np.ndarray
    amplitude: np.ndarray
    harmonics: tuple[Figure, ...]

    def r_range(self) -> tuple[float, float]:
        """The least and greatest correlation between two points other than the datum."""
        n = self.corr.shape[0]
        off = self.corr[1:, 1:][~np.eye(n - 1, dtype=bool)] if n > 2 else np.zeros(1)
        return float(off.min()), float(off.max())


def _figure(y: Any, coverage: float) -> Figure:
    u, nu = float(y.u), float(y.df)
    nu = math.inf if not math.isfinite(nu) or nu > 1e12 else nu
    return Figure(u, nu, coverage_factor(nu, coverage) if u > 0 else 0.0)


def inputs(run: PolygonRun, faces: Faces, kappa: Declaration | None, points: int
           ) -> tuple[list[Any], list[list[Any]], list[Any], Any]:
    """The GTC uncertain reals of the model's inputs, each labelled with its row's name:
    the repeatability of each point's mean (one ensemble on the run's dof), each head's
    quantisation there, each face's angle, the autocollimator's scale."""
    from GTC import multiple_ureal, ureal

    u_r = run.s_arcsec / math.sqrt(run.readings)
    rep = multiple_ureal([0.0] * points, [u_r] * points, run.dof,
                         [f"repeatability of the readings at position {i}"
                          for i in range(points)])
    q = run.lsb_arcsec
    u_q = dithered_quantisation(q, math.sqrt(max(run.head_s_arcsec ** 2 - q * q / 12.0, 0.0)))
    quant = [[ureal(0.0, u_q, label=f"quantisation of head {k + 1} at position {i}")
              for k in range(run.heads)] for i in range(points)]
    face_labels = [f"polygon face angle {f} from the datum's" for f in
                   range(faces.u_arcsec.size)]
    if math.isfinite(faces.dof):
        face = list(multiple_ureal([0.0] * faces.u_arcsec.size,
                                   [float(u) for u in faces.u_arcsec], faces.dof,
                                   face_labels))
    else:
        face = [ureal(0.0, float(u), label=lb) for u, lb in zip(faces.u_arcsec, face_labels,
                                                                 strict=True)]
    scale = None
    if kappa is not None:
        scale = ureal(0.0, kappa.standard, kappa.dof, label="autocollimator scale error")
    return list(rep), quant, face, scale


def declared_terms(terms: dict[str, Declaration], n: int) -> list[Any]:
    """What the rig's declared terms (:mod:`enctools.methods.polygon_terms`) add to each
    of ``n`` points [arcsec]: a pair's x_j - x_0 (an input a position), a point's x_j, a
    common one's x (0 at the datum), as GTC uncertain reals labelled with their row."""
    from GTC import ureal

    add: list[Any] = [0.0] * n
    for q, (name, kind) in POLYGON_TERMS.items():
        if q not in terms:
            continue
        d = terms[q]
        u, nu = d.standard * UNITS["angle"][d.unit], d.dof
        if kind == "common":
            x = ureal(0.0, u, nu, label=name)
            xs = [0.0] + [x] * (n - 1)
        else:
            xs = [ureal(0.0, u, nu, label=f"{name} ({j})") for j in range(n)]
            xs = [0.0] + [(x - xs[0]) if kind == "pair" else -x for x in xs[1:]]
        add = [a + x for a, x in zip(add, xs, strict=True)]
    return add


def deviations(x_arcsec: np.ndarray, ac_arcsec: np.ndarray, face_index: np.ndarray,
               run: PolygonRun, faces: Faces, kappa: Declaration | None,
               terms: dict[str, Declaration] | None = None) -> list[Any]:
    """The points D_j as GTC uncertain reals (the model above): ``x_arcsec`` the measured
    deviations, the datum first; ``ac_arcsec`` a_j - a_0 at each point [arcsec];
    ``face_index`` the face at each point counted from the datum's (0 at the datum; a
    closing point at 360 deg is face 0 again)."""
    n = x_arcsec.size
    f = np.asarray(face_index, np.int64)
    if not (ac_arcsec.size == n == f.size and n >= 2 and f[0] == 0
            and np.all((f >= 0) & (f < faces.u_arcsec.size))):
        msg = (f"the polygon model needs one autocollimator offset and face per point, "
               f"the datum's face 0 ({n} points, {ac_arcsec.size} offsets, {f.size} faces "
               f"of {faces.u_arcsec.size})")
        raise DataError(msg)
    rep, quant, face, scale = inputs(run, faces, kappa, n)
    extra = declared_terms(terms or {}, n)
    drift = None
    if run.closing_arcsec is not None:   # a common bound from the closing reading
        from GTC import ureal
        drift = ureal(0.0, abs(run.closing_arcsec) / math.sqrt(3.0),
                      label="drift over the run (closing reading)")
    out = []
    for j in range(n):
        d = float(x_arcsec[j]) + (rep[j] - rep[0]) - (face[f[j]] - face[0])
        if drift is not None and j > 0:
            d = d + drift
        d = d + extra[j]
        for k in range(run.heads):
            d = d + (quant[j][k] - quant[0][k]) / run.heads
        if scale is not None:
            d = d - float(ac_arcsec[j]) * scale
        out.append(d)
    return out


def harmonic_amplitudes(points: list[Any], orders: np.ndarray) -> list[Any]:
    """The amplitude [arcsec] of each order n of the points taken at n_p equal steps of a
    turn (the datum at 0): sqrt(a_n^2 + b_n^2), a_n = (2/n_p) sum_j D_j cos(2 pi n j/n_p),
    b_n likewise with sin. The datum's terms, common to every point, do not enter (the
    sums of cos and sin vanish). Linearised: an amplitude not well above its u is biased
    upwards and its U does not hold (Rice)."""
    n_p = len(points)
    out = []
    for n in orders:
        phase = 2.0 * math.pi * float(n) * np.arange(n_p) / n_p
        a = sum((2.0 / n_p * math.cos(p)) * d for p, d in zip(phase, points, strict=True))
        b = sum((2.0 / n_p * math.sin(p)) * d for p, d in zip(phase, points, strict=True))
        out.append((a * a + b * b) ** 0.5)
    return out


def propagate(x_arcsec: np.ndarray, ac_arcsec: np.ndarray, face_index: np.ndarray,
              run: PolygonRun, faces: Faces, kappa: Declaration | None,
              coverage: float = 0.95, terms: dict[str, Declaration] | None = None
              ) -> PointsModel:
    """The model propagated through GTC (:func:`deviations`): per point u and k, the
    covariance and correlation, the U of the difference of two points, of p-p and of
    the harmonics' amplitudes (of points at every face once, one turn at equal steps;
    none otherwise)."""
    from GTC import get_covariance

    f = np.asarray(face_index, np.int64)
    d = deviations(np.asarray(x_arcsec, float), np.asarray(ac_arcsec, float), f, run, faces,
                   kappa, terms)
    n = len(d)
    figures = [_figure(y, coverage) for y in d]
    cov = np.zeros((n, n))
    for i in range(1, n):
        for j in range(i, n):
            cov[i, j] = cov[j, i] = get_covariance(d[i], d[j])
    sd = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.where(np.outer(sd, sd) > 0, cov / np.outer(sd, sd), 0.0)
    np.fill_diagonal(corr, 1.0)
    var = np.diag(cov)[:, None] + np.diag(cov)[None, :] - 2.0 * cov
    pi, pj = (int(v) for v in np.unravel_index(int(np.argmax(var)), var.shape))
    hi, lo = int(np.argmax(x_arcsec)), int(np.argmin(x_arcsec))
    whole_turn = n == faces.u_arcsec.size and np.array_equal(f, np.arange(n))
    orders = np.arange(1, min(MAX_ORDER, (n - 1) // 2) + 1) if whole_turn else \
        np.arange(1, 1)
    amps = harmonic_amplitudes(d, orders)
    return PointsModel(np.array([f.u for f in figures]), np.array([f.dof for f in figures]),
                       np.array([f.k for f in figures]), cov, corr,
                       _figure(d[pi] - d[pj], coverage), (pi, pj),
                       _figure(d[hi] - d[lo], coverage), (hi, lo), orders,
                       np.array([float(a.x) for a in amps]),
                       tuple(_figure(a, coverage) for a in amps))
