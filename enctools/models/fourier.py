"""Trigonometric (Fourier-series) least-squares error model on the circle.

The alternative to the RBF network of seed 001 sec. 4: the error [arcsec] at angle
x as ``a_0 + sum_{n=1..K} a_n cos(n x) + b_n sin(n x)``, fitted by linear least
squares to the calibration points. With N equally spaced points the terms above
N/2 alias onto lower ones and ``sin(N/2 x)`` vanishes at every point: such terms
are not determined by the data. The fit then returns the minimum-norm solution
(those terms set to zero) and names them in ``undetermined``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from enctools.units import DEG, TWO_PI

#: points in a row of :meth:`FourierModel.on_grid` (one BLAS product a chunk of rows)
GRID_ROW = 4096


@dataclass
class FourierModel:
    """Harmonics n = 0..K with cosine ``a`` and sine ``b`` coefficients [arcsec]."""

    n: np.ndarray
    a: np.ndarray
    b: np.ndarray
    undetermined: list[str] = field(default_factory=list)

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

    def on_grid(self, first_deg: float, step_deg: float) -> Callable[[int, int], np.ndarray]:
        """The model [arcsec] at the uniform grid ``first_deg + k * step_deg``, k = start..stop-1.

        Returns ``values(start, stop)``. A grid of L = :data:`GRID_ROW` points is a
        row; row j starts at angle x_j and point i of it lies at x_j + h_i, so
        ``cos n(x_j + h_i)`` and ``sin n(x_j + h_i)`` split into a (rows x 2K+2)
        matrix of the rows' phases times a (2K+2 x L) matrix of the coefficients
        turned by h_i: one BLAS product per chunk, 2 (K+1) multiply-adds a point
        instead of K complex Horner steps. Phases are reduced in turns, so large
        orders keep their accuracy.
        """
        n = np.asarray(self.n, dtype=np.float64)
        h = np.arange(GRID_ROW, dtype=np.float64) * (step_deg / 360.0)
        nh = np.mod(np.multiply.outer(n, h), 1.0) * TWO_PI
        cos_nh, sin_nh = np.cos(nh), np.sin(nh)
        a, b = self.a[:, None], self.b[:, None]
        turn = np.vstack([a * cos_nh + b * sin_nh, b * cos_nh - a * sin_nh])  # (2K+2, L)

        def values(start: int, stop: int) -> np.ndarray:
            rows = -(-(stop - start) // GRID_ROW)
            k = start + GRID_ROW * np.arange(rows, dtype=np.float64)
            x0 = (first_deg + k * step_deg) / 360.0
            phase = np.mod(np.multiply.outer(x0, n), 1.0) * TWO_PI  # (rows, K+1) [rad]
            out = np.hstack([np.cos(phase), np.sin(phase)]) @ turn
            return out.reshape(-1)[:stop - start]

        return values


def design_matrix(x_rad: np.ndarray, harmonics: int) -> np.ndarray:
    """Columns 1, cos x, sin x, ..., cos Kx, sin Kx at angles ``x_rad`` [rad]."""
    x = np.asarray(x_rad, dtype=np.float64).reshape(-1, 1)
    n = np.arange(1, harmonics + 1).reshape(1, -1)
    cols = [np.ones((x.shape[0], 1))]
    for k in range(harmonics):
        cols += [np.cos(n[:, k:k + 1] * x), np.sin(n[:, k:k + 1] * x)]
    return np.hstack(cols)


def fit_fourier(angle_deg: np.ndarray, error_arcsec: np.ndarray, harmonics: int) -> FourierModel:
    """Least-squares Fourier series with harmonics 0..K through points [deg, arcsec]."""
    x = np.asarray(angle_deg, dtype=np.float64) * DEG
    y = np.asarray(error_arcsec, dtype=np.float64)
    a = design_matrix(x, harmonics)
    u, s, vt = np.linalg.svd(a, full_matrices=True)
    tol = s.max() * max(a.shape) * np.finfo(float).eps * 1e3
    rank = int(np.sum(s > tol))
    sol = vt[:rank].T @ ((u[:, :rank].T @ y) / s[:rank])
    # A coefficient is undetermined when a null-space direction loads on it.
    null = vt[rank:]
    names = ["a0"] + [f"{p}{k}" for k in range(1, harmonics + 1) for p in ("a", "b")]
    undetermined = [names[j] for j in range(len(names))
                    if null.size and np.max(np.abs(null[:, j])) > 1e-6]
    n = np.arange(harmonics + 1)
    acoef = np.concatenate([[sol[0]], sol[1::2]])
    bcoef = np.concatenate([[0.0], sol[2::2]])
    return FourierModel(n, acoef, bcoef, undetermined)
