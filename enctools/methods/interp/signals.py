"""The interpolation error from the heads' raw signals by the Heydemann fit (signals mode).

Signals are the role=signal columns of a head: components cos/sin, or the four
phases 0/90/180/270 (reduced to cos/sin by :func:`~enctools.methods.heydemann.from_four_phase`).
The ellipse fit (:mod:`enctools.methods.heydemann`) gives the faults, the error
they cause at the phase the head reads, and the counts re-interpolated from the
corrected phase.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.arrays import arrow_array
from enctools.data.limits import FIELD_RANGES
from enctools.data.readings import HeadInfo, head_info, signal_phase
from enctools.data.schemas import columns_with_role, field_meta, parse_field_value
from enctools.errors import DataError
from enctools.methods import heydemann as hd
from enctools.methods.interp.curve import Curve, error_figures
from enctools.methods.interp.model import PeriodHarmonics
from enctools.methods.interp.screen import screened_fit
from enctools.methods.interp.settings import Settings
from enctools.methods.interp.tables import column
from enctools.units import ARCSEC, TWO_PI

#: harmonics of the error (per signal period) given with a curve
HARMONICS = 8


def signal_columns(schema: pa.Schema) -> dict[str, dict[str, str]]:
    """{head: {component: column}} of the role=signal columns."""
    by_head: dict[str, dict[str, str]] = {}
    for c in columns_with_role(schema, "signal"):
        fm = field_meta(schema.field(c))
        by_head.setdefault(fm.get("head", ""), {})[fm.get("component", "")] = c
    return by_head


def quadrature(table: pa.Table, name: str,
               components: dict[str, str]) -> tuple[np.ndarray, np.ndarray]:
    """(I, Q) [V] of head ``name`` from its signal ``components``; DataError without a pair."""
    return quadrature_of(name, raw_channels(table, name, components))


def raw_channels(table: pa.Table, name: str, components: dict[str, str]) -> dict[str, np.ndarray]:
    """The signal channels [V] of head ``name`` that make its quadrature pair, by component:
    cos and sin, or the four phases; DataError without a pair."""
    for pair in (("cos", "sin"), ("0", "90", "180", "270")):
        if set(pair) <= components.keys():
            return {k: column(table, components[k]) for k in pair}
    msg = (f"input: head {name} has signal components {', '.join(sorted(components))}; "
           f"need cos and sin, or 0, 90, 180 and 270")
    raise DataError(msg)


def quadrature_of(name: str, channels: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(I, Q) [V] from the :func:`raw_channels` of head ``name``."""
    if "cos" in channels:
        return channels["cos"], channels["sin"]
    return hd.from_four_phase(*(channels[k] for k in ("0", "90", "180", "270")))


def declared_rails(schema: pa.Schema, components: dict[str, str], settings: Settings
                   ) -> dict[str, tuple[tuple[float, float], str]]:
    """Per component, the rails (low, high) [V] of its channel and where they come from:
    ``settings.rails_v`` for every channel, else the column's field metadata
    ``rail_low_v`` and ``rail_high_v``; channels with neither are left out."""
    out = {}
    for comp, col in components.items():
        if settings.rails_v is not None:
            out[comp] = ((settings.rails_v[0], settings.rails_v[1]), "option")
            continue
        fm = field_meta(schema.field(col))
        if "rail_low_v" in fm and "rail_high_v" in fm:
            lo, hi = float(fm["rail_low_v"]), float(fm["rail_high_v"])
            if not lo < hi:
                msg = (f"input: column {col}: rail_low_v {lo:g} V is not below rail_high_v "
                       f"{hi:g} V; give the ADC's rails with `rails_v` LOW,HIGH")
                raise DataError(msg)
            out[comp] = ((lo, hi), "declared")
    return out


def check_signals(table: pa.Table, settings: Settings
                  ) -> tuple[list[Curve], dict[str, dict[str, Any]], dict[str, np.ndarray]]:
    """Heydemann fit of every head's raw signals; the interpolation error they predict.

    ``settings``: the heads (default every head with signals), the shortest arc
    (``min_arc_deg``), the largest share of samples excluded (``allow_excluded_pct``),
    the rails (``rails_v``) and the curve's points. Clipped samples and radius outliers
    are left out of each fit (:func:`~enctools.methods.interp.screen.screened_fit`).
    Returns the curves (error [arcsec] at the read phase, mean removed) of the heads
    with an encoder geometry and, per head, the fit
    (:meth:`~enctools.methods.heydemann.EllipseFit.to_dict`), the screening
    (:meth:`~enctools.methods.interp.screen.Screen.to_dict`) and the Lissajous radius
    variation; and per head the flags of the rows whose samples the fit used.
    """
    by_head = signal_columns(table.schema)
    if not by_head:
        msg = "input: no raw signal columns (role=signal); record them with enc acquire"
        raise DataError(msg)
    names = list(settings.heads) if settings.heads else list(by_head)
    curves, fits, fitted = [], {}, {}
    grid = np.linspace(0.0, TWO_PI, settings.points, endpoint=False)
    for name in names:
        comp = by_head.get(name)
        if comp is None:
            msg = f"input: no signals of head {name!r} (signals of: {', '.join(by_head)})"
            raise DataError(msg)
        raw = raw_channels(table, name, comp)
        i, q = quadrature_of(name, raw)
        try:
            fit, screen = screened_fit(raw, i, q, declared_rails(table.schema, comp, settings),
                                       settings.min_arc_deg, settings.allow_excluded_pct)
        except DataError as exc:
            raise DataError(f"head {name}: {exc.template}") from None
        meta = {"signals": fit.to_dict(), "lissajous": hd.radius_variation(i, q),
                "screen": screen.to_dict(), "reference": "signals"}
        fits[name] = meta
        fitted[name] = np.zeros(i.shape, dtype=bool)
        fitted[name][np.isfinite(i) & np.isfinite(q)] = screen.kept
        info = head_info(table.schema, name) if name in table.schema.names else \
            _signal_geometry(table.schema, name, comp)
        if info is not None and info.periods_per_rev:
            curves.append(_signal_curve(name, info, fit, grid, meta))
    return curves, fits, fitted


def _signal_geometry(schema: pa.Schema, name: str, components: dict[str, str]
                     ) -> HeadInfo | None:
    """A head without a counts column (signals from a user's table): its signal periods
    a revolution from its signal columns' field metadata ``periods_per_rev`` (None:
    none stated, no curve)."""
    rng = FIELD_RANGES["signal"]["periods_per_rev"]
    stated = {parse_field_value(field_meta(schema.field(c)).get("periods_per_rev", ""), rng)
              for c in components.values()}
    if len(stated) != 1 or None in stated:
        return None
    ppr = int(str(stated.pop()))
    return HeadInfo(name=name, encoder=name, alpha=0.0, counts_per_rev=ppr,
                    periods_per_rev=ppr, interpolation=1, radius_m=0.0, zero_count=0)


def _signal_curve(name: str, info: HeadInfo, fit: hd.EllipseFit, grid: np.ndarray,
                  meta: dict[str, Any]) -> Curve:
    """The error [arcsec] the fitted faults cause on the read-phase ``grid`` [rad], mean removed.

    ``meta`` (the head's fit) gains the period, the mean removed, the figures and
    the first :data:`HARMONICS` harmonics.
    """
    ppr = info.periods_per_rev
    unit_err = hd.read_phase_error(fit, grid) * (1.0 / ppr / ARCSEC)
    mean = float(unit_err.mean())
    err = unit_err - mean
    u = hd.interpolation_error_u(fit, grid, ppr)
    meta |= {"encoder": info.encoder, "periods_per_rev": ppr,
             "period_arcsec": TWO_PI / ppr / ARCSEC, "mean_arcsec": mean,
             "figures": error_figures(err)}
    c = np.fft.rfft(err)[1:HARMONICS + 1] * 2 / grid.size
    meta["harmonics"] = [{"n": k + 1, "amplitude": float(abs(v)),
                          "phase": float(np.angle(v))} for k, v in enumerate(c)]
    return Curve(name, info.encoder, ppr, grid, err, u,
                 PeriodHarmonics(np.arange(1, HARMONICS + 1), c,
                                 np.zeros((2 * HARMONICS, 2 * HARMONICS))),
                 meta, [f"{name}: {w}" for w in fit.warnings])


def corrected_counts(table: pa.Table, fits: dict[str, dict[str, Any]], names: Sequence[str],
                     fitted: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """Counts [count] of each head with the interpolation redone from the corrected phase.

    The period index comes from the head's counts; the fraction from the
    Heydemann-corrected phase (the sample's phase nearest the counted one is
    taken, so a correction across a period boundary moves to the next period).
    Rows whose signals the fit left out (``fitted[name]`` False: clipped, radius
    outliers, not finite) cannot be trusted for a phase: their counts are corrected
    by the fitted error at the phase they read instead.
    """
    comps = signal_columns(table.schema)
    out = {}
    for name in names:
        info = head_info(table.schema, name)
        f = fits[name]["signals"]
        i, q = quadrature(table, name, comps[name])
        fit = hd.EllipseFit(f["offset_cos_v"], f["offset_sin_v"], f["amplitude_v"], f["ratio"],
                            f["phase_rad"], u={}, cov=np.zeros((5, 5)), noise=0.0, arc=0.0,
                            samples=0)
        phi = hd.corrected_phase(i, q, *fit.params)
        counts = column(table, name).astype(np.int64)
        n = info.interpolation
        absolute = counts + info.zero_count
        frac = np.mod(phi, TWO_PI) * (n / TWO_PI)
        base = np.floor_divide(absolute, n) * n
        trusted = fitted[name] if fitted is not None else np.isfinite(phi)
        new = absolute.copy()
        new[trusted] = base[trusted] + np.rint(frac[trusted]).astype(np.int64)
        # choose the period so the corrected count is nearest the counted one
        new += n * np.rint((absolute - new) / n).astype(np.int64)
        if not trusted.all():
            read = signal_phase(counts[~trusted], info)
            error = hd.read_phase_error(fit, read) * (n / TWO_PI)
            new[~trusted] = absolute[~trusted] - np.rint(error).astype(np.int64)
        out[name] = new - info.zero_count
    return out


def corrected_readings(table: pa.Table, fits: dict[str, dict[str, Any]], names: Sequence[str],
                       fitted: dict[str, np.ndarray] | None = None) -> pa.Table:
    """The readings ``table`` with the counts of heads ``names`` from :func:`corrected_counts`."""
    for name, counts in corrected_counts(table, fits, names, fitted).items():
        idx = table.schema.get_field_index(name)
        table = table.set_column(idx, table.schema.field(name), arrow_array(counts, pa.int64()))
    return table
