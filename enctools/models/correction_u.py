"""The uncertainty of a correction model at any angle, not only at the points it was fitted to.

A model fitted to m calibration points is written to a table and applied at every angle.
Its error there has three parts, combined as independent standard uncertainties (GUM
5.1.2, sensitivities 1) into u_c and U = k u_c with k = 2:

- ``held_out``: the model's error between the points, measured by leaving each point out
  (the RMS of the leave-one-out residuals y_i - f_(-i)(x_i) [arcsec]). It contains the
  points' own noise as well, so it errs on the large side.
- ``band``: what m points cannot resolve. Harmonics of order >= m/2 alias onto lower
  orders at the points and are invisible between them (Nyquist). The data bound them from
  the top octave they do resolve: the RMS of the points' harmonics of order
  ceil(m/4)..ceil(m/2)-1 [arcsec] stands for the unresolved tail. A bound when the
  amplitudes fall at least as 1/n (power per order as n^-2: each octave holds at most half
  the energy of the one below, so all octaves above m/2 together hold at most that of
  m/4..m/2; a graduation's fall as n^-1 to n^-2). An assumption, named where printed.
- ``quantisation``: a table stores each value to an LSB of q [arcsec]: rounding leaves a
  rectangular error of half-width q/2, u = q / sqrt(12) (GUM 4.3.7). Only where the table
  written is known (a ``rom`` among a report's inputs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from enctools.units import DEG

#: the coverage factor of U (a normal combination of three terms; GUM 6.2.1)
K_CORRECTION = 2.0
#: fewer points than this resolve no top octave to bound the tail with
MIN_POINTS = 8
#: the most points whose top octave is fitted (a least squares of m x m): a denser table's
#: is that of an even subset of this many (its orders OCTAVE_POINTS/4 and up, which
#: bound the higher ones the same way), never an m x m/2 matrix
OCTAVE_POINTS = 1024


@dataclass(frozen=True)
class CorrectionU:
    """The standard uncertainties [arcsec] of a correction model at any angle.

    held_out, band : the model's (see the module); quantisation : the table's (None: no
    table known); points : m, the points the model was fitted to; band_from : the lowest
    harmonic order the band term is taken from (m/4) and ``unresolved``: the order m/2
    from which none is resolved.
    """

    held_out: float
    band: float
    points: int
    band_from: int
    unresolved: int
    quantisation: float | None = None
    k: float = K_CORRECTION

    @property
    def u_c(self) -> float:
        """Combined standard uncertainty [arcsec]."""
        q = 0.0 if self.quantisation is None else self.quantisation
        return math.sqrt(self.held_out ** 2 + self.band ** 2 + q ** 2)

    @property
    def U(self) -> float:
        """Expanded uncertainty U = k u_c [arcsec]."""
        return self.k * self.u_c

    def with_lsb(self, lsb_arcsec: float) -> CorrectionU:
        """The same with a table of LSB ``lsb_arcsec`` [arcsec]: half an LSB, rectangular."""
        return CorrectionU(self.held_out, self.band, self.points, self.band_from,
                           self.unresolved, lsb_arcsec / math.sqrt(12.0), self.k)

    def to_meta(self) -> dict[str, Any]:
        """The model stream's ``residuals.correction_u`` (the model's two terms)."""
        return {"held_out_arcsec": self.held_out, "band_arcsec": self.band,
                "points": self.points, "band_from_order": self.band_from,
                "unresolved_from_order": self.unresolved, "k": self.k}

    @classmethod
    def from_meta(cls, meta: Any) -> CorrectionU | None:
        """From :meth:`to_meta` (None: absent or malformed, an older model)."""
        try:
            out = cls(float(meta["held_out_arcsec"]), float(meta["band_arcsec"]),
                      int(meta["points"]), int(meta["band_from_order"]),
                      int(meta["unresolved_from_order"]), None, float(meta["k"]))
        except (TypeError, KeyError, ValueError):
            return None
        finite = all(math.isfinite(v) and v >= 0 for v in (out.held_out, out.band, out.k))
        return out if finite else None

    def terms(self) -> list[tuple[str, float | None]]:
        """Each term's name (what it spans) and its standard uncertainty [arcsec]."""
        m, lo, hi = self.points, self.band_from, self.unresolved
        return [(f"model between the points: leave-one-out RMS of {m} points", self.held_out),
                (f"band limit: orders >= {hi} unresolved at {m} points, bounded by the RMS "
                 f"of orders {lo}..{hi - 1} (amplitudes assumed to fall at least as 1/n)",
                 self.band),
                ("quantisation of the table written: half an LSB, rectangular",
                 self.quantisation)]


def top_octave_rms(angle_deg: np.ndarray, error_arcsec: np.ndarray) -> tuple[float, int, int]:
    """The RMS [arcsec] of the points' harmonics of order ceil(m/4)..ceil(m/2)-1 (least
    squares over all orders 0..ceil(m/2)-1), that first order and ceil(m/2); of more than
    :data:`OCTAVE_POINTS` points, those of an even subset of that many (by angle)."""
    x = np.asarray(angle_deg, np.float64) * DEG
    y = np.asarray(error_arcsec, np.float64)
    if x.size > OCTAVE_POINTS:
        order = np.argsort(x, kind="stable")
        pick = order[np.linspace(0, x.size - 1, OCTAVE_POINTS).round().astype(np.int64)]
        x, y = x[pick], y[pick]
    m = x.size
    top = math.ceil(m / 2)
    low = math.ceil(m / 4)
    n = np.arange(1, top)
    a = np.hstack([np.ones((m, 1)), np.cos(np.outer(x, n)), np.sin(np.outer(x, n))])
    coef = np.linalg.lstsq(a, y, rcond=None)[0]
    c, s = coef[1:top], coef[top:]
    keep = n >= low
    power = float(np.sum(c[keep] ** 2 + s[keep] ** 2)) / 2.0
    return math.sqrt(power), low, top


def correction_u(angle_deg: np.ndarray, error_arcsec: np.ndarray,
                 loo_arcsec: np.ndarray) -> CorrectionU | None:
    """The model's terms from its points (positions [deg], deviations [arcsec]) and its
    leave-one-out residuals [arcsec]; None with fewer than :data:`MIN_POINTS` points or a
    residual that is not finite."""
    loo = np.asarray(loo_arcsec, np.float64)
    if loo.size < MIN_POINTS or not np.all(np.isfinite(loo)):
        return None
    band, low, top = top_octave_rms(angle_deg, error_arcsec)
    held = float(np.sqrt(np.mean(loo * loo)))
    return CorrectionU(held, band, int(loo.size), low, top)
