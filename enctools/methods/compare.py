"""Direct comparison: the deviation of a device against a reference (seed 000 eqs. (7), (8), (10)).

The device and the reference are head channels (single heads, averages made by
``enc average-heads``, or the mean of several heads given here). Per revolution of
the reference the deviation ``d(theta) = device - reference`` [arcsec] is taken
against the reference's reading as the angle, then averaged over revolutions
(multi-turn averaging) and band-limited to the first K harmonics (the paper keeps
100), which removes the heads' interpolation errors (eq. (10)). Without a band limit
the samples are averaged in angle bins instead.

When the reference's own error has been calibrated (a deviations curve, e.g. from
``enc selfcal``), it is added back: ``device error = d + reference error`` (the
correction eq. (9) leaves out). A scale's graduation curve is turned into the error
of the reference channel by the transfer function A(n) of the reference's heads
(seed 000 eq. (5)) and, when the curve carries x, y, their radial motion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.errors import DataError, UsageError
from enctools.units import ARCSEC

if TYPE_CHECKING:
    import pyarrow as pa

    from enctools.data.readings import HeadInfo
    from enctools.data.streams import Header, InputStream


@dataclass
class Comparison:
    """Averaged deviation: coefficients c_0..c_K and per-harmonic u [arcsec] (band > 0),
    the curve on the grid and its pointwise standard uncertainty [arcsec]."""

    coefficients: np.ndarray | None
    uncertainty: np.ndarray | None
    curve: np.ndarray
    curve_uncertainty: np.ndarray
    revolutions: int


def compare(revolutions: Any, band: int, points: int,
            reference_error: np.ndarray | None = None) -> Comparison:
    """Average per-revolution deviations (device channels minus the reference coordinate).

    ``revolutions``: (index, spectra (C, K+1) [rad], binned (C, points) [rad] or None)
    with the device's heads as channels (their mean is the device); ``band`` 0 means no
    band limit (binned curves are averaged); ``reference_error``: coefficients
    c_0..c_K [arcsec] of the reference's own error, added to the result.
    """
    from enctools.methods.harmonics import synthesize
    from enctools.methods.revolutions import RunningMean

    coef = RunningMean()
    curve = RunningMean()
    for _, g, binned in revolutions:
        if band > 0:
            c = g.mean(axis=0) / ARCSEC
            c[0] = 0
            coef.add(c)
            curve.add(synthesize(c, points))
        else:
            b = binned.mean(axis=0) / ARCSEC  # type: ignore[union-attr]
            b = b - np.nanmean(b)
            curve.add(b)
    if curve.count < 1:
        msg = "input: no complete revolution of the reference; record at least one"
        raise DataError(msg)
    assert curve.mean is not None
    if band > 0:
        assert coef.mean is not None
        c = coef.mean.copy()
        if reference_error is not None:
            c = c + reference_error[: c.size]
            c[0] = 0
        return Comparison(c, coef.sem(), synthesize(c, points), curve.sem(), curve.count)
    y = curve.mean.copy()
    if reference_error is not None:
        y = y + synthesize(reference_error, points)
    return Comparison(None, None, y, curve.sem(), curve.count)


def reference_error(curve_header: Header, curve_table: pa.Table, column: str | None,
                    ref_fields: list[pa.Field], band: int, source: str) -> np.ndarray:
    """Coefficients c_0..c_K [arcsec] of the reference channel's error from a calibrated curve.

    A curve of a scale (field metadata ``argument = scale angle``, as enc selfcal
    writes) becomes the error of the reference channel: A(n) F(n) over the heads
    behind it, plus their radial motion if the curve has x, y [nm]. Any other curve is
    taken as the reference channel's error as it stands.
    """
    from enctools.data.schemas import columns_with_role, field_meta
    from enctools.methods.harmonics import analyse
    from enctools.methods.heads import head_alphas

    names = columns_with_role(curve_table.schema, "deviation")
    if column is None:
        if not names:
            raise DataError(f"{source}: no deviation column")
        column = names[0]
    if column not in names:
        msg = f"{source}: no deviation column {column!r} (deviations: {', '.join(names)})"
        raise DataError(msg)
    theta = curve_table.column("theta").to_numpy()
    m = theta.size
    if m < 2 * band + 1 or not np.allclose(theta, np.arange(m) * (2 * np.pi / m), atol=1e-9):
        msg = (f"{source}: the curve needs a uniform grid over one revolution starting at 0 "
               f"with more than {2 * band} points (it has {m})")
        raise DataError(msg)
    y = curve_table.column(column).to_numpy(zero_copy_only=False).astype(float)
    if not np.all(np.isfinite(y)):
        raise DataError(f"{source}: column {column!r} has NaN values")
    f = analyse(y, band)
    fm = field_meta(curve_table.schema.field(column))
    if fm.get("argument") != "scale angle":
        f[0] = 0
        return f
    n = np.arange(band + 1)
    total = np.zeros(band + 1, dtype=np.complex128)
    for rf in ref_fields:
        alphas = head_alphas(rf)
        total += np.exp(1j * np.outer(n, alphas)).mean(axis=1) * f
        radial = columns_with_role(curve_table.schema, "radial")
        if "x" in radial and "y" in radial:
            r = float(field_meta(rf)["radius_m"])
            x = analyse(curve_table.column("x").to_numpy(), band)
            yy = analyse(curve_table.column("y").to_numpy(), band)
            radial_nm = x * np.mean(np.sin(alphas)) - yy * np.mean(np.cos(alphas))
            total += radial_nm * 1e-9 / r / ARCSEC
    total /= len(ref_fields)
    total[0] = 0
    return total


def run(source: InputStream, device: list[str], ref: list[str], band: int, points: int,
        name: str | None, ref_curve: tuple[Header, pa.Table, str] | None,
        ref_column: str | None, progress: Any = None
        ) -> tuple[tuple[Header, pa.Table], tuple[Header, pa.Table] | None]:
    """A readings stream in; the deviations (and, band-limited, spectrum) of device - reference."""
    from enctools.data.curves import Column, deviations_table, spectrum_table
    from enctools.data.readings import head_info
    from enctools.methods.harmonics import grid
    from enctools.methods.revolutions import ChannelSpec, revolution_spectra

    if source.meta.get("mode") not in (None, "continuous"):
        msg = (f"{source.source}: a {source.meta.get('mode')} run; enc compare needs a "
               "continuous run")
        raise DataError(msg)
    dev: list[HeadInfo] = [head_info(source.schema, h, source.source) for h in device]
    refs: list[HeadInfo] = [head_info(source.schema, h, source.source) for h in ref]
    both = set(device) & set(ref)
    if both:
        raise UsageError(f"--device and --ref share {', '.join(sorted(both))}")
    if band > 0 and points <= 2 * band:
        raise UsageError(f"--points {points} cannot carry --band {band}: give more than {2 * band}")
    correction = None
    if ref_curve is not None:
        kmax = band if band > 0 else (points - 1) // 2
        correction = reference_error(ref_curve[0], ref_curve[1], ref_column,
                                     [source.schema.field(h) for h in ref], kmax, ref_curve[2])
    spec = ChannelSpec(tuple(dev), tuple(refs), mean=True)  # the device is their mean
    revs = revolution_spectra(source, spec, max(band, 0), progress,
                              grid_points=0 if band > 0 else points)
    res = compare(revs, band, points, correction)
    label = name or f"{'+'.join(device)}-{'+'.join(ref)}"
    cols = [Column(label, res.curve, "deviation", "arcsec",
                   {"device": ",".join(device), "reference": ",".join(ref),
                    "argument": "reference angle", "band": band}),
            Column(f"u_{label}", res.curve_uncertainty, "uncertainty", "arcsec", {"of": label})]
    table = deviations_table(grid(points), cols)
    settings = {"device": device, "ref": ref, "band": band, "points": points, "name": label,
                "ref_curve": ref_curve[2] if ref_curve else None, "ref_column": ref_column,
                "revolutions": res.revolutions}
    header = source.header.derive("deviations", table.schema, settings=settings,
                                  domain="revolution")
    spectrum = None
    if res.coefficients is not None:
        st = spectrum_table([(label, res.coefficients, None, res.uncertainty)])
        spectrum = (source.header.derive("spectrum", st.schema, settings=settings), st)
    return (header, table), spectrum
