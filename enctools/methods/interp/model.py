"""The harmonic model of an interpolation error within one signal period (seed 000 sec. 4).

The error is a sum of harmonics of the signal phase phi [rad]::

    e(phi) = sum_n [a_n cos(n phi) + b_n sin(n phi)]       [arcsec]

with n in cycles per signal period. This module holds the design columns
cos(n phi), sin(n phi), the least-squares solution of the normal equations they
give, the curve with its standard uncertainty (:class:`PeriodHarmonics`), and
where another period's harmonics land among the device's (:func:`landing_harmonics`).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from enctools.units import TWO_PI


@dataclass(frozen=True)
class PeriodHarmonics:
    """A periodic error as harmonics of a signal period.

    ``orders`` (int, cycles per period), ``coef`` complex c_n = a_n - i b_n [arcsec]
    so that the error is sum Re(c_n exp(i n phi)); ``cov`` the covariance of the
    real pairs (a_1, b_1, a_2, b_2, ...) [arcsec^2].
    """

    orders: np.ndarray
    coef: np.ndarray
    cov: np.ndarray

    @classmethod
    def from_pairs(cls, orders: np.ndarray, pairs: np.ndarray,
                   cov: np.ndarray) -> PeriodHarmonics:
        """Harmonics from the fitted pairs (a_1, b_1, a_2, b_2, ...) [arcsec]."""
        return cls(orders, pairs[0::2] - 1j * pairs[1::2], cov)

    def __call__(self, phase: np.ndarray) -> np.ndarray:
        """The error [arcsec] at signal phase ``phase`` [rad]."""
        phase = np.asarray(phase, dtype=np.float64)
        out = np.zeros_like(phase)
        for n, c in zip(self.orders, self.coef, strict=True):
            out += c.real * np.cos(n * phase) - c.imag * np.sin(n * phase)
        return out

    def basis(self, phase: np.ndarray) -> np.ndarray:
        """Design columns cos(n phi), sin(n phi) for every order (rows: samples)."""
        phase = np.asarray(phase, dtype=np.float64)
        cols = []
        for n in self.orders:
            cols += [np.cos(n * phase), np.sin(n * phase)]
        return np.column_stack(cols) if cols else np.zeros((phase.size, 0))

    def uncertainty(self, phase: np.ndarray) -> np.ndarray:
        """Standard uncertainty [arcsec] of the error at ``phase`` [rad]."""
        g = self.basis(phase)
        return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", g, self.cov, g), 0.0))

    @property
    def amplitude(self) -> np.ndarray:
        """|c_n| [arcsec]."""
        return np.abs(self.coef)

    @property
    def phase(self) -> np.ndarray:
        """p_n of |c_n| cos(n phi + p_n) [rad]."""
        return np.angle(self.coef)

    @property
    def amplitude_u(self) -> np.ndarray:
        """Standard uncertainty of |c_n| [arcsec] (linearised)."""
        out = np.empty(self.orders.size)
        for k, c in enumerate(self.coef):
            a, b = c.real, -c.imag
            block = self.cov[2 * k:2 * k + 2, 2 * k:2 * k + 2]
            r = abs(c)
            if r > 0:
                g = np.array([a, b]) / r
                out[k] = np.sqrt(max(g @ block @ g, 0.0))
            else:
                out[k] = np.sqrt(max(np.trace(block) / 2, 0.0))
        return out

    def select(self, keep: Sequence[int]) -> PeriodHarmonics:
        """Only the orders in ``keep`` (those that were fitted)."""
        idx = [k for k, n in enumerate(self.orders) if int(n) in {int(x) for x in keep}]
        cov_idx = np.array([[2 * k, 2 * k + 1] for k in idx], dtype=int).ravel()
        return PeriodHarmonics(self.orders[idx], self.coef[idx],
                               self.cov[np.ix_(cov_idx, cov_idx)])


def harmonic_rows(phase: np.ndarray | None, orders: np.ndarray, out: np.ndarray,
                  step: np.ndarray | None = None, steps: int = 0) -> None:
    """cos(n phase), sin(n phase) for each order n into rows 2k, 2k + 1 of ``out``.

    ``phase`` [rad]. With ``step`` [count] (phase = 2 pi step / steps, from the
    counts; ``phase`` may then be None) they are looked up in a table of the
    ``steps`` phases; otherwise consecutive orders by complex products from
    exp(i phase) (one cos/sin pair).
    """
    if step is not None:
        table = phase_table(steps, tuple(np.asarray(orders).tolist()))
        for row, out_row in zip(table, out, strict=False):
            # mode "clip": written straight into ``out`` (the default checks in a buffer);
            # a step is within 0 .. steps - 1
            np.take(row, step, out=out_row, mode="clip")
        return
    assert phase is not None, "a phase or its step"
    e1 = np.exp(1j * phase)
    e = np.ones_like(e1)
    n = 0
    for k, order in enumerate(orders):
        e = e * (e1 if order == n + 1 else np.exp(1j * (order - n) * phase))
        n = int(order)
        out[2 * k], out[2 * k + 1] = e.real, e.imag


@functools.lru_cache(maxsize=8)
def phase_table(steps: int, orders: tuple[int, ...]) -> np.ndarray:
    """Rows cos(n phi), sin(n phi) for each order n at phi = 2 pi j / steps [rad], j < steps."""
    phi = np.arange(steps) * (TWO_PI / steps)
    out = np.empty((2 * len(orders), steps))
    for k, n in enumerate(orders):
        out[2 * k], out[2 * k + 1] = np.cos(n * phi), np.sin(n * phi)
    out.flags.writeable = False
    return out


def lookup_gram(steps: int, orders: np.ndarray, per_step: np.ndarray) -> np.ndarray:
    """X^T X of the columns :func:`harmonic_rows` looks up, from the samples per step.

    ``per_step`` [1]: how many samples were at each step 0 .. ``steps`` - 1 of the
    period; X^T X = sum over the steps of their count times the outer product of the
    table's column (rows 2k, 2k + 1: cos, sin of order k).
    """
    table = phase_table(steps, tuple(np.asarray(orders).tolist()))
    return (table * per_step) @ table.T


def scaled_normal_matrix(xtx: np.ndarray, raw_ss: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """X^T X with every column scaled by its norm before projection, and those norms.

    ``raw_ss``: the sums of squares of the columns before the trends were projected
    out; scaled by them, a harmonic the trends absorb shows as a small eigenvalue.
    """
    norms = np.sqrt(raw_ss)
    norms[norms == 0] = 1.0
    a = xtx / np.outer(norms, norms)
    return (a + a.T) / 2, norms


def condition_number(a: np.ndarray) -> float:
    """sqrt of the ratio of the extreme eigenvalues of the scaled normal matrix ``a``."""
    w = np.linalg.eigvalsh(a)
    return float(np.sqrt(w[-1] / w[0])) if w[0] > 0 else np.inf


def solve_scaled(a: np.ndarray, norms: np.ndarray, xty: np.ndarray, yty: float,
                 dof: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares coefficients [arcsec], their covariance [arcsec^2] and s^2 [arcsec^2].

    ``a``, ``norms`` from :func:`scaled_normal_matrix`; ``xty``, ``yty`` the other
    normal-equation sums; ``dof`` the degrees of freedom of the residual.
    """
    a_inv = np.linalg.inv(a)
    coef = (a_inv @ (xty / norms)) / norms
    rss = max(yty - float(coef @ xty), 0.0)
    s2 = rss / dof
    cov = a_inv * s2 / np.outer(norms, norms)
    return coef, cov, s2


def period_ratio(device_periods_per_rev: int, reference_periods_per_rev: int) -> float:
    """Device signal period / reference signal period (reference cycles per device period)."""
    return reference_periods_per_rev / device_periods_per_rev


def landing_harmonics(ratio: float, keep: Sequence[int], reference_orders: Sequence[int] = (1, 2),
                      tolerance: float = 0.5) -> list[tuple[int, float, int]]:
    """Reference harmonics j that land within ``tolerance`` of a kept device harmonic.

    The reference's j-th harmonic of its own period is at j * ratio harmonics of the
    device period; when that is near a kept order k, keeping k keeps the reference's
    error too. Returns (j, j * ratio, k) triples.
    """
    out = []
    for j in reference_orders:
        at = j * ratio
        for k in keep:
            if abs(at - k) < tolerance:
                out.append((int(j), float(at), int(k)))
    return out
