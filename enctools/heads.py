"""Head arrangements: averaging heads, and the transfer functions of averages and differences.

Heads of one encoder at nominal angles alpha_k [rad] see the graduation error
eps(theta + alpha_k) and the spindle's radial error motion through
``[x sin alpha_k - y cos alpha_k] / R`` (seed 000 eq. (1)).

- Averaging N heads passes the harmonic n of eps with
  ``A(n) = (1/N) sum_k exp(i n alpha_k)`` (seed 000 eqs. (3)-(6)): equally spaced heads
  keep the multiples of N (A = 1) and cancel the rest (A = 0), and radial motion
  cancels whenever ``sum_k exp(i alpha_k) = 0``.
- The difference of head k and head j has ``W_kj(n) = exp(i n alpha_k) - exp(i n alpha_j)``
  (seed 000 eq. (11)); the basic Fourier self-calibration divides by it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: |A(n)| below this counts as cancelled, above 1 - this as passed
TOLERANCE = 1e-9


def average_transfer(alphas: np.ndarray, n: np.ndarray) -> np.ndarray:
    """A(n) = mean_k exp(i n alpha_k) of the heads at ``alphas`` [rad] (seed 000 eq. (5))."""
    a = np.asarray(alphas, dtype=np.float64)
    return np.exp(1j * np.outer(np.asarray(n, dtype=np.float64), a)).mean(axis=1)


def radial_gain(alphas: np.ndarray) -> float:
    """How much of the radial motion an average keeps: |mean_k exp(i alpha_k)|.

    The average's reading moves by ``[x <sin alpha> - y <cos alpha>] / R``; 0 means
    radial motion cancels (equal spacing, N >= 2), 1 a single head.
    """
    return float(abs(np.exp(1j * np.asarray(alphas, dtype=np.float64)).mean()))


def difference_transfer(alpha_k: float, alpha_j: float, n: np.ndarray) -> np.ndarray:
    """W_kj(n) = exp(i n alpha_k) - exp(i n alpha_j) of the difference H_k - H_j."""
    n = np.asarray(n, dtype=np.float64)
    return np.exp(1j * n * alpha_k) - np.exp(1j * n * alpha_j)


@dataclass(frozen=True)
class AverageSummary:
    """Which harmonics an average of heads passes and cancels, up to ``band``."""

    alphas_deg: tuple[float, ...]
    band: int
    passed: tuple[int, ...]       # |A(n)| = 1
    cancelled: tuple[int, ...]    # A(n) = 0
    partial: tuple[int, ...]      # 0 < |A(n)| < 1
    radial_gain: float

    @property
    def equally_spaced_n(self) -> int | None:
        """N when the heads are N equally spaced ones (passes exactly the multiples of N)."""
        n = len(self.alphas_deg)
        want = tuple(k for k in range(1, self.band + 1) if k % n == 0)
        return n if n > 1 and self.passed == want and not self.partial else None

    def describe(self, name: str, heads: list[str]) -> str:
        """One line for a log or a report."""
        eq = self.equally_spaced_n
        if eq:
            keeps = f"keeps the multiples of {eq} of the graduation error and cancels the rest"
        else:
            keeps = (f"keeps {_ranges(self.passed) or 'no harmonic'} fully, cancels "
                     f"{_ranges(self.cancelled) or 'none'}, attenuates {_ranges(self.partial) or 'none'}")
        radial = ("cancels radial motion" if self.radial_gain < 1e-9 else
                  f"keeps {self.radial_gain:.3g} of the radial motion")
        return (f"{name} = mean({', '.join(heads)}) at "
                f"{'/'.join(f'{a:g}' for a in self.alphas_deg)} deg: {keeps} "
                f"(n <= {self.band}); {radial}")


def summarize_average(alphas: np.ndarray, band: int) -> AverageSummary:
    """Passed, cancelled and attenuated harmonics 1..band of the average of heads at ``alphas`` [rad]."""
    n = np.arange(1, band + 1)
    mag = np.abs(average_transfer(alphas, n))
    passed = tuple(int(k) for k in n[mag > 1 - 1e-9])
    cancelled = tuple(int(k) for k in n[mag < 1e-9])
    partial = tuple(int(k) for k in n[(mag >= 1e-9) & (mag <= 1 - 1e-9)])
    return AverageSummary(tuple(float(np.degrees(a)) for a in alphas), band, passed, cancelled,
                          partial, radial_gain(alphas))


def _ranges(ns: tuple[int, ...] | list[int], limit: int = 12) -> str:
    """'2, 4, 6, ..., 100 (every 2nd)' or '3-7, 12' - a short list of harmonic orders."""
    ns = list(ns)
    if not ns:
        return ""
    if len(ns) > 3:
        steps = set(np.diff(ns))
        if len(steps) == 1 and ns[1] - ns[0] > 1:
            return f"{ns[0]}, {ns[1]}, ..., {ns[-1]}"
    runs: list[str] = []
    start = prev = ns[0]
    for k in ns[1:] + [None]:  # type: ignore[list-item]
        if k is not None and k == prev + 1:
            prev = k
            continue
        if prev - start < 3:
            runs += [str(k) for k in range(start, prev + 1)]
        else:
            runs.append(f"{start}-{prev}")
        if k is not None:
            start = prev = k
    if len(runs) > limit:
        return ", ".join(runs[:limit]) + f", ... ({len(ns)} in all)"
    return ", ".join(runs)


def format_orders(ns: list[int] | tuple[int, ...]) -> str:
    """A short human list of harmonic orders (ranges and arithmetic runs folded)."""
    return _ranges(ns)
