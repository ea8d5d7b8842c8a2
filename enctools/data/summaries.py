"""The figures a command summarises, as plain dicts in one vocabulary.

Every command that prints a summary builds it here as a dict (printed as JSON, or
rendered as the text on stderr), and enc report's JSON uses the same keys
for the same figures. The keys are listed in enc-streams(5), SUMMARIES. The rules:

- snake_case; a number's key ends in its unit: ``pp_arcsec``, ``pp_nm`` (radial
  motion), ``delay_s``, ``spread_deg``, ``phase_rad``; counts start with ``n_`` or
  name what they count (``entries``, ``rows``); dimensionless numbers carry no suffix
  (``transfer``, ``coverage_k``, ``period_ratio``).
- the figures of a set of values (:func:`figure_dict`) are always ``n_points``,
  ``mean_U``, ``min_U``, ``max_U``, ``pp_U``, ``pm_U`` (half the p-p), ``s_bessel_U``
  (seed 001 eq. 8), ``rms_U``, ``max_abs_U`` for the unit ``U``.
- a value that is not a finite number is ``null`` (:func:`clean`), never NaN.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from enctools.data.statistics import Figures

#: the stems of a value set's figures, in the order they are given
FIGURE_STEMS = ("mean", "min", "max", "pp", "pm", "s_bessel", "rms", "max_abs")


def figure_dict(fig: Figures, unit: str, stems: tuple[str, ...] = FIGURE_STEMS
                ) -> dict[str, Any]:
    """The figures of n values as ``{"n_points": n, "pp_<unit>": ..., ...}``.

    ``unit`` is the unit of the values (arcsec, nm, count): it becomes each key's
    suffix. ``stems`` picks which figures are given (``n_points`` always is).
    """
    values = {"mean": fig.mean, "min": fig.minimum, "max": fig.maximum, "pp": fig.pp,
              "pm": fig.plus_minus, "s_bessel": fig.std, "rms": fig.rms,
              "max_abs": fig.max_abs}
    out: dict[str, Any] = {"n_points": int(fig.n)}
    for stem in stems:
        out[f"{stem}_{unit}"] = float(values[stem])
    return out


def clean(x: Any) -> Any:
    """``x`` with numpy scalars and arrays as plain numbers and lists, tuples as lists,
    and every NaN or infinity as None (JSON ``null``)."""
    if isinstance(x, dict):
        return {str(k): clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean(v) for v in x]
    if isinstance(x, np.ndarray):
        return clean(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (np.floating, float)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def to_json(summary: dict[str, Any], indent: int | None = 1) -> str:
    """The summary as JSON text (no NaN token: :func:`clean` first)."""
    return json.dumps(clean(summary), indent=indent, allow_nan=False)


#: the names stream metadata gives some figures, and their summary keys
META_NAMES = {"n": "n_points", "bessel_std_arcsec": "s_bessel_arcsec",
              "peak_to_peak_arcsec": "pp_arcsec", "plus_minus": "pm_arcsec",
              "plus_minus_arcsec": "pm_arcsec",
              "pp": "pp_arcsec", "mean": "mean_arcsec", "rms": "rms_arcsec",
              "std": "s_bessel_arcsec", "max_abs": "max_abs_arcsec",
              "before_bessel_std_arcsec": "before_s_bessel_arcsec",
              "before_peak_to_peak_arcsec": "before_pp_arcsec"}


def from_meta(meta: dict[str, Any]) -> dict[str, Any]:
    """Figures [arcsec] as stream metadata names them (``bessel_std_arcsec``,
    ``peak_to_peak_arcsec``, ``plus_minus``) under their summary keys."""
    return {META_NAMES.get(k, k): v for k, v in meta.items()}


def before_after(before: Figures, after: Figures) -> dict[str, Any]:
    """The figures [arcsec] of an error before and after a correction, and by what factor
    the correction divides its Bessel s and its p-p (``s_ratio``, ``pp_ratio``: before /
    after; null when the after figure is 0)."""
    def ratio(b: float, a: float) -> float:
        return b / a if a > 0 else math.nan

    return {"before": figure_dict(before, "arcsec"), "after": figure_dict(after, "arcsec"),
            "s_ratio": ratio(before.std, after.std), "pp_ratio": ratio(before.pp, after.pp)}
