"""Signal quality of a head's quadrature signals: the Heydemann ellipse fit.

An arctangent interpolator fed the signals of a head (seed 001 sec. 5.2 watches
them as a Lissajous figure) sees, instead of a circle, the ellipse of the
Heydemann model::

    I = offset_cos + A cos(phi)
    Q = offset_sin + A * ratio * sin(phi + phase)

with phi the true signal phase [rad]. Fitting that ellipse to sampled (I, Q) gives
the offsets [V], the amplitude ratio, the phase error [rad] and the amplitude A [V];
from them follow the interpolation error the faults cause (the phase error of
``atan2(Q, I)``, divided by the periods per revolution for arcsec) and the
corrected phase. The same conventions are used by :mod:`enctools.truth`
(:class:`~enctools.truth.SignalFaults`, offsets relative to A).

The fit: an algebraic conic fit (closed form, exact for noise-free data) refined by
a geometric least-squares fit of the five parameters on the Sampson distance, whose
Jacobian gives the standard uncertainties. A partial arc of the ellipse still
determines it, less well: the uncertainties grow and say so; below ``min_arc`` the
fit is refused with a :class:`~enctools.errors.DataError` rather than returned wrong.

Four-phase heads (0/90/180/270 deg signals) are reduced to (I, Q) by
:func:`from_four_phase`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from enctools.errors import DataError
from enctools.units import ARCSEC, DEG, TWO_PI

#: names of the five parameters, in the order of :attr:`EllipseFit.params`
PARAMS = ("offset_cos", "offset_sin", "amplitude", "ratio", "phase")


@dataclass(frozen=True)
class EllipseFit:
    """Heydemann parameters of a Lissajous ellipse, with standard uncertainties.

    ``offset_cos``, ``offset_sin``, ``amplitude`` in the signals' unit [V];
    ``ratio`` (Q amplitude / I amplitude) dimensionless; ``phase`` [rad] (Q leads
    sin(phi) by it). ``u`` holds the standard uncertainty of each, keyed by name;
    ``cov`` the 5 x 5 covariance in :data:`PARAMS` order. ``noise`` is the rms
    distance of the samples from the ellipse [V]; ``arc`` the part of the ellipse
    the samples cover [rad] (2 pi for a full turn).
    """

    offset_cos: float
    offset_sin: float
    amplitude: float
    ratio: float
    phase: float
    u: dict[str, float]
    cov: np.ndarray
    noise: float
    arc: float
    samples: int
    warnings: list[str] = field(default_factory=list)

    @property
    def params(self) -> np.ndarray:
        """The five parameters in :data:`PARAMS` order: offsets and amplitude [V], ratio [1],
        phase [rad]."""
        return np.array([self.offset_cos, self.offset_sin, self.amplitude, self.ratio,
                         self.phase])

    def relative_faults(self) -> dict[str, float]:
        """Offsets relative to the amplitude, ratio and phase [rad]: the
        :class:`enctools.truth.SignalFaults` convention."""
        return {"offset_cos": self.offset_cos / self.amplitude,
                "offset_sin": self.offset_sin / self.amplitude,
                "ratio": self.ratio, "phase": self.phase}

    def to_dict(self) -> dict[str, object]:
        """JSON-able summary (offsets in V and relative, phase in rad and deg)."""
        rel = self.relative_faults()
        return {"offset_cos_v": self.offset_cos, "offset_sin_v": self.offset_sin,
                "amplitude_v": self.amplitude, "ratio": self.ratio, "phase_rad": self.phase,
                "phase_deg": self.phase / DEG,
                "offset_cos": rel["offset_cos"], "offset_sin": rel["offset_sin"],
                "u": dict(self.u), "noise_v": self.noise, "arc_deg": self.arc / DEG,
                "samples": self.samples, "warnings": list(self.warnings)}


def from_four_phase(s0: np.ndarray, s90: np.ndarray, s180: np.ndarray,
                    s270: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(I, Q) [V] of a four-phase head: I = s0 - s180, Q = s90 - s270.

    The differences cancel the common offset of each pair; what is left of the
    offsets is their mismatch, which the ellipse fit then measures.
    """
    return (np.asarray(s0, float) - np.asarray(s180, float),
            np.asarray(s90, float) - np.asarray(s270, float))


def _conic(i: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Algebraic conic a I^2 + b IQ + c Q^2 + d I + e Q + f = 0 through the points.

    Normalised coordinates keep the design matrix well conditioned; the smallest
    right singular vector is the conic (exact when the points lie on one).
    """
    ci, cq = float(np.mean(i)), float(np.mean(q))
    s = float(np.sqrt(np.mean((i - ci) ** 2 + (q - cq) ** 2))) or 1.0
    x, y = (i - ci) / s, (q - cq) / s
    design = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    _, _, vt = np.linalg.svd(design, full_matrices=False)
    a, b, c, d, e, f = vt[-1]
    # back to (I, Q): substitute x = (I - ci)/s, y = (Q - cq)/s
    a2, b2, c2 = a / s**2, b / s**2, c / s**2
    d2 = d / s - 2 * a2 * ci - b2 * cq
    e2 = e / s - 2 * c2 * cq - b2 * ci
    f2 = (a2 * ci**2 + b2 * ci * cq + c2 * cq**2 - d / s * ci - e / s * cq + f)
    return np.array([a2, b2, c2, d2, e2, f2])


def _from_conic(k: np.ndarray) -> np.ndarray:
    """Heydemann parameters (offset_cos, offset_sin, amplitude, ratio, phase) of a conic.

    With x = I - offset_cos, y = Q - offset_sin the model's ellipse is
    x^2/A^2 + y^2/(A r)^2 - 2 x y sin(d)/(A^2 r) = cos(d)^2.
    """
    a, b, c, d, e, f = k
    det = 4 * a * c - b * b
    if not det > 1e-12 * (abs(a) + abs(c)) ** 2:
        msg = "the signals do not lie on an ellipse (Lissajous figure is not closed-convex)"
        raise DataError(msg)
    x0 = (b * e - 2 * c * d) / det
    y0 = (b * d - 2 * a * e) / det
    f0 = f + (d * x0 + e * y0) / 2.0
    if a < 0:
        a, b, c, f0 = -a, -b, -c, -f0
    if not f0 < 0:
        msg = "the signals do not lie on a real ellipse (degenerate conic)"
        raise DataError(msg)
    ratio = np.sqrt(a / c)
    sin_d = -b / (2.0 * np.sqrt(a * c))
    sin_d = float(np.clip(sin_d, -1.0, 1.0))
    cos2 = 1.0 - sin_d * sin_d
    amplitude = np.sqrt(-f0 / (a * cos2))
    return np.array([x0, y0, amplitude, ratio, np.arcsin(sin_d)])


def _sampson(p: np.ndarray, i: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Sampson distance [V] of the points from the ellipse of parameters p."""
    oc, os_, amp, ratio, phase = p
    u = (i - oc) / amp
    w = (q - os_) / (amp * ratio)
    s = np.sin(phase)
    f = u * u + w * w - 2.0 * u * w * s - np.cos(phase) ** 2
    gi = (2.0 * u - 2.0 * w * s) / amp
    gq = (2.0 * w - 2.0 * u * s) / (amp * ratio)
    return f / np.sqrt(gi * gi + gq * gq)


def corrected_phase(i: np.ndarray, q: np.ndarray, oc: float, os_: float, amplitude: float,
                    ratio: float, phase: float) -> np.ndarray:
    """Signal phase phi [rad, -pi..pi] with the Heydemann faults removed.

    cos(phi) = (I - oc)/A, sin(phi) = ((Q - os)/(A r) - cos(phi) sin(d)) / cos(d).
    """
    u = (np.asarray(i, float) - oc) / amplitude
    w = (np.asarray(q, float) - os_) / (amplitude * ratio)
    return np.arctan2((w - u * np.sin(phase)) / np.cos(phase), u)


def _circle_centre(i: np.ndarray, q: np.ndarray) -> tuple[float, float]:
    """Centre of the least-squares circle through the points (Kasa fit) [V]."""
    ci, cq = float(np.mean(i)), float(np.mean(q))
    x, y = i - ci, q - cq
    design = np.column_stack([x, y, np.ones_like(x)])
    sol, *_ = np.linalg.lstsq(design, x * x + y * y, rcond=None)
    return ci + sol[0] / 2.0, cq + sol[1] / 2.0


def circle_arc(i: np.ndarray, q: np.ndarray) -> float:
    """Part of the Lissajous figure [rad] the points (I, Q) [V] cover, seen from the centre
    of the circle through them: no ellipse fit needed, which a short noisy arc can send off."""
    ci, cq = _circle_centre(i, q)
    return arc_covered(np.arctan2(q - cq, i - ci))


def arc_covered(phi: np.ndarray) -> float:
    """Part of the circle [rad] covered by phases phi: 2 pi minus the largest gap."""
    p = np.sort(np.mod(np.asarray(phi, float), TWO_PI))
    if p.size < 2:
        return 0.0
    gaps = np.diff(np.append(p, p[0] + TWO_PI))
    return float(TWO_PI - gaps.max())


def fit_ellipse(i: np.ndarray, q: np.ndarray, min_arc: float = 90 * DEG,
                max_u_ratio: float = 0.02) -> EllipseFit:
    """Fit the Heydemann ellipse to quadrature signals I, Q [V].

    Parameters
    ----------
    i, q : arrays [V]
        Simultaneous samples of the cos (I) and sin (Q) signals.
    min_arc : float [rad]
        Refuse (DataError) when the samples cover less of the ellipse than this.
    max_u_ratio : float
        Refuse when the standard uncertainty of the amplitude ratio exceeds this:
        the arc is too short for the noise, the fit is undetermined.

    Returns
    -------
    EllipseFit with the five parameters, their uncertainties (from the Jacobian of
    the Sampson distances, scaled by the residual rms), the residual noise [V] and
    the arc covered [rad]; ``warnings`` name a partial arc.
    """
    i, q = finite_signals(i, q)
    # the fit is done on signals scaled to about 1: volts of 1e300 or 1e-300 would
    # overflow or underflow in the squares of the conic and the Sampson distance
    scale = float(max(np.max(np.abs(i)), np.max(np.abs(q))))
    if not (scale > 0 and np.isfinite(scale)):
        scale = 1.0
    p0, arc = _first_guess(i / scale, q / scale, min_arc)
    p, cov, noise = _refine(p0, i / scale, q / scale)
    to_volts = np.array([scale, scale, scale, 1.0, 1.0])
    p, cov, noise = p * to_volts, cov * np.outer(to_volts, to_volts), noise * scale
    u = {name: float(np.sqrt(max(cov[k, k], 0.0))) for k, name in enumerate(PARAMS)}
    if not (0.5 < p[3] < 2.0 and abs(p[4]) < 45 * DEG):
        msg = (f"ellipse fit implausible for a head (ratio {p[3]:.3g}, phase error "
               f"{p[4] / DEG:.1f} deg over an arc of {arc / DEG:.0f} deg): the arc is too "
               f"short or the signals are not a quadrature pair")
        raise DataError(msg)
    if u["ratio"] > max_u_ratio:
        msg = (f"ellipse fit undetermined: u(ratio) = {u['ratio']:.3g} over an arc of "
               f"{arc / DEG:.0f} deg with noise {noise:.3g} V; record a longer arc")
        raise DataError(msg)
    warnings = []
    if arc < 270 * DEG:
        warnings.append(f"partial arc: the signals cover {arc / DEG:.0f} deg of the "
                        f"Lissajous ellipse; uncertainties are larger than over a full period")
    return EllipseFit(float(p[0]), float(p[1]), float(p[2]), float(p[3]), float(p[4]),
                      u, cov, noise, arc, int(i.size), warnings)


#: the largest |sample| [V] of a quadrature signal taken in; beyond, its square and the
#: covariance of the fit [V^2] would leave the range of a float
MAX_SIGNAL_V = 1e12


def finite_signals(i: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples [V] where both I and Q are finite; DataError for fewer than 8."""
    i = np.asarray(i, dtype=np.float64).ravel()
    q = np.asarray(q, dtype=np.float64).ravel()
    if i.shape != q.shape:
        msg = f"I and Q differ in length ({i.size} and {q.size} samples)"
        raise DataError(msg)
    good = np.isfinite(i) & np.isfinite(q)
    i, q = i[good], q[good]
    big = float(max(np.max(np.abs(i), initial=0.0), np.max(np.abs(q), initial=0.0)))
    if big > MAX_SIGNAL_V:
        msg = (f"a signal sample of {big:.3g} V: beyond {MAX_SIGNAL_V:.0e} V it is no "
               f"voltage an encoder gives (are the signal columns in volts?)")
        raise DataError(msg)
    if i.size < 8:
        msg = f"{i.size} finite signal samples: the ellipse fit needs at least 8"
        raise DataError(msg)
    return i, q


def _first_guess(i: np.ndarray, q: np.ndarray, min_arc: float) -> tuple[np.ndarray, float]:
    """The conic fit's parameters and the arc [rad] the samples cover; DataError under ``min_arc``.

    The arc seen from the centre of a circle through the points does not depend on
    the ellipse fit, which a short noisy arc can send far off.
    """
    arc = circle_arc(i, q)
    if arc >= min_arc:
        p0 = _from_conic(_conic(i, q))
        arc = min(arc, arc_covered(corrected_phase(i, q, *p0)))
    if not arc >= min_arc:  # NaN too: no arc at all
        arc = arc if np.isfinite(arc) else 0.0
        msg = (f"the signals cover {arc / DEG:.0f} deg of the Lissajous ellipse (< "
               f"{min_arc / DEG:.0f} deg): offsets and ratio are undetermined; "
               f"record over a longer arc of the signal period, better one or more periods")
        raise DataError(msg)
    return p0, arc


def _refine(p0: np.ndarray, i: np.ndarray, q: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, float]:
    """Geometric fit on the Sampson distance from ``p0``: parameters, covariance, noise [V].

    The covariance is that of the Jacobian scaled by the residual rms (the noise).
    """
    from scipy.optimize import least_squares  # 0.28 s to import: not for every importer

    scale = max(abs(p0[2]), 1e-300)
    x_scale = np.array([scale, scale, scale, 1.0, 1.0])
    res = least_squares(_sampson, p0, args=(i, q), method="lm", x_scale=x_scale,
                        xtol=1e-15, ftol=1e-15, gtol=1e-15)
    p = res.x if res.success and np.all(np.isfinite(res.x)) else p0
    if p[2] < 0:  # (A, phi) and (-A, phi + pi) are the same ellipse
        p[2] = -p[2]
    r = _sampson(p, i, q)
    dof = max(i.size - 5, 1)
    noise = float(np.sqrt(np.sum(r * r) / dof))
    jac = res.jac
    try:
        cov = np.linalg.pinv(jac.T @ jac) * noise**2
    except np.linalg.LinAlgError:
        cov = np.full((5, 5), np.inf)
    return p, cov, noise


def phase_error(fit: EllipseFit, phi: np.ndarray) -> np.ndarray:
    """Phase error [rad] of atan2(Q, I) for signals with the fitted faults, at true phase phi."""
    phi = np.asarray(phi, dtype=np.float64)
    i = fit.offset_cos + fit.amplitude * np.cos(phi)
    q = fit.offset_sin + fit.amplitude * fit.ratio * np.sin(phi + fit.phase)
    return np.angle(np.exp(1j * (np.arctan2(q, i) - phi)))


def interpolation_error(fit: EllipseFit, phi: np.ndarray, periods_per_rev: int) -> np.ndarray:
    """Interpolation error [arcsec] the fitted faults cause, at signal phase phi [rad]."""
    return phase_error(fit, phi) / periods_per_rev / ARCSEC


def interpolation_error_u(fit: EllipseFit, phi: np.ndarray, periods_per_rev: int) -> np.ndarray:
    """Standard uncertainty [arcsec] of :func:`interpolation_error`, propagated from
    the fit's covariance (numerical Jacobian)."""
    phi = np.asarray(phi, dtype=np.float64)
    base = fit.params
    rows = []
    for k in range(5):
        h = 1e-6 * max(abs(base[k]), fit.amplitude if k < 3 else 1.0)
        plus, minus = base.copy(), base.copy()
        plus[k] += h
        minus[k] -= h
        fp = _with(fit, plus)
        fm = _with(fit, minus)
        rows.append((interpolation_error(fp, phi, periods_per_rev)
                     - interpolation_error(fm, phi, periods_per_rev)) / (2 * h))
    jac = np.array(rows)  # 5 x n
    var = np.einsum("in,ij,jn->n", jac, fit.cov, jac)
    return np.sqrt(np.maximum(var, 0.0))


def _with(fit: EllipseFit, p: np.ndarray) -> EllipseFit:
    oc, os_, amplitude, ratio, phase = (float(x) for x in p)
    return EllipseFit(oc, os_, amplitude, ratio, phase, u=fit.u, cov=fit.cov, noise=fit.noise,
                      arc=fit.arc, samples=fit.samples)


def radius_variation(i: np.ndarray, q: np.ndarray) -> dict[str, float]:
    """Lissajous radius hypot(I, Q) about the origin, as an oscilloscope shows it [V].

    Returns min, max, mean radius and the relative variation (max - min) / mean;
    an ideal head draws a circle (variation 0 apart from noise).
    """
    r = np.hypot(np.asarray(i, float), np.asarray(q, float))
    r = r[np.isfinite(r)]
    if r.size == 0:
        msg = "no finite signal samples"
        raise DataError(msg)
    mean = float(r.mean())
    return {"min_v": float(r.min()), "max_v": float(r.max()), "mean_v": mean,
            "variation": float((r.max() - r.min()) / mean) if mean > 0 else float("inf")}


def read_phase_error(fit: EllipseFit, phi_read: np.ndarray, iterations: int = 40) -> np.ndarray:
    """Phase error [rad] as a function of the phase the interpolator *reads* [rad].

    The read phase is phi + e(phi); this inverts it by a fixed-point iteration (a
    contraction: |e'| is about the size of the faults), so the error can be looked
    up by the reading, as a correction table indexed by counts does.
    """
    phi_read = np.asarray(phi_read, dtype=np.float64)
    phi = phi_read.copy()
    for _ in range(iterations):
        phi = phi_read - phase_error(fit, phi)
    return phase_error(fit, phi)
