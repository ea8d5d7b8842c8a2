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

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.data.columns import uncertainty_name
from enctools.data.schemas import check_new_columns
from enctools.errors import DataError, SettingsError
from enctools.methods.budget import Coverage, repeats_dof, type_a_coverage
from enctools.methods.harmonics import analyse, check_grid, grid, synthesize
from enctools.methods.revolutions import (
    ChannelSpec,
    RunningMean,
    Spectra,
    require_continuous,
    revolution_spectra,
)
from enctools.units import ARCSEC

if TYPE_CHECKING:
    import pyarrow as pa

    from enctools.data.streams import Header, InputStream


@dataclass(frozen=True)
class Settings:
    """What a comparison does: the options of enc compare, checked together.

    ``device``: the device channel (a head, an average made by enc average-heads, or
    several heads, whose mean is the device); ``ref``: the reference channel, likewise,
    whose reading is the angle; ``band``: keep harmonics 1..K (0: no band limit, the
    samples averaged in angle bins instead); ``points``: points of the output grid
    over one revolution (more than 2 K); ``name``: the deviation column (default
    DEVICE-REF, see :attr:`label`); ``ref_curve``: the name (path) of a deviations stream
    holding the reference's calibrated error, as recorded (:func:`run` takes the stream's
    table), ``ref_column`` its column (default the first); ``spectrum``: a spectrum
    output is asked for (needs a band limit; not recorded in the outputs).
    SettingsError naming the fields when they do not go together.
    """

    device: tuple[str, ...]
    ref: tuple[str, ...]
    band: int = 100
    points: int = 1024
    name: str | None = None
    ref_curve: str | None = None
    ref_column: str | None = None
    spectrum: bool = False

    def __post_init__(self) -> None:
        if self.band < 0:
            msg = f"`band` must be >= 0, not {self.band}"
            raise SettingsError(msg)
        if self.spectrum and self.band == 0:
            msg = "`spectrum` needs a band limit (`band` K > 0)"
            raise SettingsError(msg)
        both = set(self.device) & set(self.ref)
        if both:
            msg = f"`device` and `ref` share {', '.join(sorted(both))}"
            raise SettingsError(msg)
        if self.band > 0:
            check_grid(self.points, self.band)
        check_new_columns("deviations", [self.label, uncertainty_name(self.label)],
                          "`name`" if self.name is not None else "the column name")

    @property
    def label(self) -> str:
        """The deviation column's name: ``name``, else DEVICE-REF (heads joined by +)."""
        return self.name or f"{'+'.join(self.device)}-{'+'.join(self.ref)}"

    def to_dict(self) -> dict[str, Any]:
        """The settings as the outputs' metadata records them (lists, the label as name)."""
        return {"device": list(self.device), "ref": list(self.ref), "band": self.band,
                "points": self.points, "name": self.label, "ref_curve": self.ref_curve,
                "ref_column": self.ref_column}


@dataclass
class Comparison:
    """Averaged deviation: coefficients c_0..c_K and per-harmonic u [arcsec] (band > 0),
    the curve on the grid and its pointwise standard uncertainty [arcsec], over
    ``revolutions``."""

    coefficients: np.ndarray | None
    uncertainty: np.ndarray | None
    curve: np.ndarray
    curve_uncertainty: np.ndarray
    revolutions: int

    def coverage(self) -> tuple[Coverage | None, Coverage | None]:
        """The coverage (dof, k) of U = k u of the curve and of the harmonics: the spread
        of the revolutions' mean, R - 1 degrees of freedom per point, 2 (R - 1) per
        harmonic (re and im pooled); None where one revolution gives no spread."""
        curve = type_a_coverage(self.curve_uncertainty, repeats_dof(self.revolutions))
        if self.uncertainty is None:
            return curve, None
        return curve, type_a_coverage(self.uncertainty[1:], repeats_dof(self.revolutions, 2))


def compare(revolutions: Iterator[Spectra], band: int, points: int,
            reference_error: np.ndarray | None = None) -> Comparison:
    """Average per-revolution deviations (device channels minus the reference coordinate).

    ``revolutions``: (index, spectra (C, K+1) [rad], binned (C, points) [rad] or None)
    with the device's heads as channels (their mean is the device); ``band`` 0 means no
    band limit (binned curves are averaged); ``reference_error``: coefficients
    c_0..c_K [arcsec] of the reference's own error, added to the result.
    """
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


def reference_error(curve_table: pa.Table, column: str | None,
                    ref_fields: list[pa.Field], band: int, source: str) -> np.ndarray:
    """Coefficients c_0..c_K [arcsec] of the reference channel's error from a calibrated curve.

    A curve of a scale (field metadata ``argument = scale angle``, as enc selfcal
    writes) becomes the error of the reference channel: A(n) F(n) over the heads
    behind it, plus their radial motion if the curve has x, y [nm]. Any other curve is
    taken as the reference channel's error as it stands.
    """
    from enctools.data.schemas import columns_with_role, field_meta
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


def run(source: InputStream, settings: Settings, progress: Callable[[int], Any] | None = None,
        curve: pa.Table | None = None
        ) -> tuple[tuple[Header, pa.Table], tuple[Header, pa.Table] | None]:
    """A readings stream in; the deviations (and, band-limited, spectrum) of device - reference.

    ``curve``: the table of the deviations stream ``settings.ref_curve`` names (the
    reference's calibrated error, added back), as the caller read it. ``progress`` is
    called with the number of revolutions analysed.
    """
    from enctools.data.readings import head_info

    require_continuous(source, "enc compare needs a continuous run")
    dev = tuple(head_info(source.schema, h, source.source) for h in settings.device)
    refs = tuple(head_info(source.schema, h, source.source) for h in settings.ref)
    band, points = settings.band, settings.points
    correction = None
    if curve is not None and settings.ref_curve is not None:
        correction = reference_error(curve, settings.ref_column,
                                     [source.schema.field(h) for h in settings.ref],
                                     band if band > 0 else (points - 1) // 2, settings.ref_curve)
    spec = ChannelSpec(dev, refs, mean=True)  # the device is their mean
    revs = revolution_spectra(source, spec, band, progress,
                              grid_points=0 if band > 0 else points)
    return _outputs(source.header, settings, compare(revs, band, points, correction),
                    ",".join(sorted({r.encoder for r in refs})))


def _outputs(header: Header, settings: Settings, res: Comparison, ref_encoder: str
             ) -> tuple[tuple[Header, pa.Table], tuple[Header, pa.Table] | None]:
    """The deviations (curve on the grid) and, band-limited, spectrum of a comparison;
    ``ref_encoder``: the encoder(s) of the reference's heads, recorded with the settings
    (the budget takes the row the rig declares for that encoder, enc-rig(5))."""
    from enctools.data.curves import Column, deviations_table, spectrum_table, uncertainty

    label = settings.label
    curve_cov, spectrum_cov = res.coverage()
    cols = [Column(label, res.curve, "deviation", "arcsec",
                   {"device": ",".join(settings.device), "reference": ",".join(settings.ref),
                    "argument": "reference angle", "band": settings.band}),
            uncertainty(label, res.curve_uncertainty, "arcsec",
                        None if curve_cov is None else curve_cov.field_meta())]
    table = deviations_table(grid(settings.points), cols)
    recorded = settings.to_dict() | {"revolutions": res.revolutions, "ref_encoder": ref_encoder}
    deviations = header.derive("deviations", table.schema, settings=recorded,
                               domain="revolution")
    if res.coefficients is None:
        return (deviations, table), None
    st = spectrum_table([(label, res.coefficients, None, res.uncertainty)],
                        coverage=None if spectrum_cov is None else spectrum_cov.field_meta())
    return (deviations, table), (header.derive("spectrum", st.schema, settings=recorded), st)
