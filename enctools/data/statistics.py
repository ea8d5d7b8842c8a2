"""Summary statistics of deviations: peak-to-peak, +/-, mean, Bessel s, RMS.

One convention for every command and the report: ``pp = max - min``, ``+/- = pp / 2``,
``std`` the Bessel (n - 1) standard deviation of seed 001 eq. (8) and ``rms`` the root
mean square of the values themselves (not about the mean). Unit-blind: the figures are
in the unit of the values given (arcsec, nm, ...).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from enctools.errors import DataError


@dataclass(frozen=True)
class Figures:
    """Figures of n values (unit of the input).

    ``std`` is the Bessel (n - 1) standard deviation of seed 001 eq. (8), over the
    values exactly as given (a closing 360 deg row that repeats 0 deg counts).
    """

    n: int
    mean: float
    minimum: float
    maximum: float
    pp: float
    plus_minus: float
    std: float
    rms: float

    def to_dict(self) -> dict[str, float | int]:
        return asdict(self)

    @property
    def max_abs(self) -> float:
        """The largest magnitude, max(|minimum|, |maximum|)."""
        return max(abs(self.minimum), abs(self.maximum))


def curve_figures(values: np.ndarray) -> Figures:
    """Figures of a curve or point set (seed 001 sec. 5.3: p-p and eq. (8)).

    Parameters
    ----------
    values : deviations [arcsec] (or nm); NaN values are an error, not skipped.
    """
    x = np.asarray(values, dtype=np.float64).ravel()
    if x.size == 0:
        msg = "no values to summarise"
        raise DataError(msg)
    if not np.all(np.isfinite(x)):
        bad = int(np.count_nonzero(~np.isfinite(x)))
        msg = f"{bad} of {x.size} values are NaN or infinite"
        raise DataError(msg)
    lo, hi = float(x.min()), float(x.max())
    std = float(np.std(x, ddof=1)) if x.size > 1 else float("nan")
    return Figures(n=int(x.size), mean=float(x.mean()), minimum=lo, maximum=hi, pp=hi - lo,
                   plus_minus=(hi - lo) / 2.0, std=std, rms=float(np.sqrt(np.mean(x * x))))


def figures_or_nan(values: np.ndarray) -> Figures:
    """:func:`curve_figures`, or NaN figures (n = the values given) when there is no value
    or a NaN among them: the residuals of a fit the points do not determine.

    Parameters
    ----------
    values : deviations or residuals [arcsec] (or nm).
    """
    x = np.asarray(values, dtype=np.float64).ravel()
    if x.size == 0 or not np.all(np.isfinite(x)):
        nan = float("nan")
        return Figures(int(x.size), nan, nan, nan, nan, nan, nan, nan)
    return curve_figures(x)


def median(values: np.ndarray) -> float:
    """The median of the values, in their unit (NaN when there is none or a NaN among
    them): ``np.median``'s value without its import of ``numpy.ma``, a tenth of importing
    numpy and pyarrow, which a command on a small input pays at start."""
    x = np.asarray(values, dtype=np.float64).ravel()
    if x.size == 0 or np.isnan(x).any():
        return float("nan")
    k = x.size // 2
    if x.size % 2:
        return float(np.partition(x, k)[k])
    part = np.partition(x, (k - 1, k))
    return float((part[k - 1] + part[k]) / 2.0)
