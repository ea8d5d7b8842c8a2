"""Transfer functions of the self-calibration methods, and the basic least squares.

For heads at angles alpha_k [rad] (the reference first), harmonic by harmonic n:
the four-head error separation's weights a1..a3 and W(n) (seed 000 eqs. (13)-(15)),
the basic method's least-squares |W(n)| and its solution (Geckeler 2006; seed 000
refs [13, 14]), and the check that heads divide the circle equally (equal-division
averaging). The methods of :mod:`enctools.methods.selfcal_methods` are made of them.
"""

from __future__ import annotations

import numpy as np

from enctools.errors import SettingsError
from enctools.units import DEG

#: a normalised |W(n)| at or below this is zero: the harmonic is blind
BLIND = 1e-9


def esa_weights(alpha_ref: float, alphas: np.ndarray) -> np.ndarray:
    """Weights a1..a3 cancelling radial motion in sum_j a_j (H_j - H_ref) (seed 000 eq. (14)).

    C = 1, as the seed.

    They solve eq. (13) with the angles relative to the reference head: ``a = s x c`` with
    ``s_j = sin(alpha_j) - sin(alpha_ref)``, ``c_j = cos(alpha_j) - cos(alpha_ref)``, which
    is eq. (14) for alpha_ref = 0. Angles in rad.
    """
    al = np.asarray(alphas, dtype=np.float64)
    if al.size != 3:
        msg = f"esa needs exactly 3 heads besides the reference, not {al.size}"
        raise SettingsError(msg)
    s = np.sin(al) - np.sin(alpha_ref)
    c = np.cos(al) - np.cos(alpha_ref)
    return np.cross(s, c)


def esa_transfer(alpha_ref: float, alphas: np.ndarray, n: np.ndarray) -> np.ndarray:
    """W(n) = sum_j a_j (exp(i n alpha_j) - exp(i n alpha_ref)) (seed 000 eq. (15)); rad."""
    a = esa_weights(alpha_ref, alphas)
    n = np.asarray(n, dtype=np.float64)
    diff = np.exp(1j * np.outer(n, alphas)) - np.exp(1j * n * alpha_ref)[:, None]
    return (a[None, :] * diff).sum(axis=1)


def esa_noise_norm(alpha_ref: float, alphas: np.ndarray) -> float:
    """sqrt(sum a_j^2 + (sum a_j)^2): the noise of E(n) per unit noise of one head."""
    a = esa_weights(alpha_ref, alphas)
    return float(np.sqrt(np.sum(a**2) + np.sum(a) ** 2))


def fourier_transfer(alphas: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Effective |W(n)| of the least-squares basic method over heads at ``alphas`` [rad].

    ``sqrt(sum_k |exp(i n alpha_k) - mean_j exp(i n alpha_j)|^2)``: for two heads it is
    |W_21(n)| / sqrt(2); the noise gain is its inverse.
    """
    w = np.exp(1j * np.outer(np.asarray(n, dtype=np.float64), alphas))
    return np.sqrt(np.sum(np.abs(w - w.mean(axis=1, keepdims=True)) ** 2, axis=1))


def fourier_solve(spectra: np.ndarray, alphas: np.ndarray) -> np.ndarray:
    """Graduation coefficients F(n) [rad] by least squares across heads, radial motion ignored.

    ``spectra``: (heads, K + 1) coefficients G_k(n) of each head's error relative to
    any common coordinate. Blind harmonics come out 0.
    """
    n = np.arange(spectra.shape[1])
    w = np.exp(1j * np.outer(alphas, n))  # (heads, K+1)
    wc = w - w.mean(axis=0)
    gc = spectra - spectra.mean(axis=0)
    den = np.sum(np.abs(wc) ** 2, axis=0)
    num = np.sum(np.conj(wc) * gc, axis=0)
    out = np.zeros(spectra.shape[1], dtype=np.complex128)
    ok = den > BLIND * len(alphas)
    out[ok] = num[ok] / den[ok]
    out[0] = 0
    return out


def check_equal_spacing(alphas: np.ndarray, names: list[str], tol_deg: float = 0.05) -> None:
    """SettingsError unless the heads divide the circle equally (eda)."""
    n = len(alphas)
    a = np.sort(np.mod(alphas, 2 * np.pi))
    gaps = np.diff(np.append(a, a[0] + 2 * np.pi))
    if n < 2 or np.max(np.abs(gaps - 2 * np.pi / n)) > tol_deg * DEG:
        msg = (f"eda needs equally spaced heads; {', '.join(names)} are at "
               f"{'/'.join(f'{x / DEG:g}' for x in alphas)} deg "
               "(use `method` fourier or esa)")
        raise SettingsError(msg)
