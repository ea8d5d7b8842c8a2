"""Self-calibration of a scale's graduation error from several heads of one encoder.

Every method works harmonic by harmonic on the per-revolution spectra G_k(n) of
the head errors relative to the angle coordinate (:mod:`enctools.methods.revolutions`),
all in rad. The head model is seed 000 eq. (1): ``G_k(n) = exp(i n alpha_k) F(n) + C(n)
+ [X(n) sin alpha_k - Y(n) cos alpha_k] / R`` with F the graduation error, C what
all heads share (the coordinate's own error) and X, Y the spindle's radial error
motion.

- ``fourier``: the basic transfer-function method (Geckeler 2006; seed 000 refs
  [13, 14]): least squares for F(n) and C(n) across all heads, radial motion
  ignored. ``|W(n)| = sqrt(sum_k |exp(i n alpha_k) - mean_j exp(i n alpha_j)|^2)``;
  blind where every head sees the same phase. Gives the 1st harmonic.
- ``eda``: the equal-division averaged method: N equally spaced heads,
  ``F(n) = mean_k exp(-i n alpha_k) G_k(n)``; the multiples of N are blind, and
  radial motion leaks into the harmonics n = +/-1 (mod N).
- ``esa``: the four-head error separation (seed 000 eqs. (11)-(18)): the weights
  a1..a3 of eq. (14) cancel radial motion in the weighted sum of the differences to
  the reference head, ``F(n) = E(n) / W(n)`` for n >= 2 (eqs. (15), (16)), the 1st
  harmonic from the basic model, and x(theta), y(theta) from eqs. (17), (18). Where
  W(n) = 0 the graduation term at order n is itself a radial-motion pattern: F(n),
  X(n) and Y(n) are all undetermined, and all three are set to 0 and named.

The 1st harmonic of radial motion cannot be told from the scale's eccentricity:
it is reported as part of the graduation error (the simulator's truth does the same).
"""

from __future__ import annotations

import itertools
import logging
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.errors import DataError, SettingsError
from enctools.methods import selfcal_methods
from enctools.methods.coordinate import Settled, refine, settle, spectra_against
from enctools.methods.harmonics import check_grid, grid, synthesize
from enctools.methods.heads import format_orders
from enctools.methods.overlap import ahead
from enctools.methods.revolutions import (
    ChannelSpec,
    Revolution,
    RunningMean,
    require_continuous,
    revolutions,
)
from enctools.methods.selfcal_methods.base import Solution, basic_table
from enctools.methods.selfcal_uncertainty import (
    SampleRepeats,
    Uncertainties,
    mounting_changes,
    mounting_rms,
    systematic,
    uncertainties,
)
from enctools.methods.transfer import (
    BLIND,
    check_equal_spacing,
    esa_noise_norm,
    esa_transfer,
    esa_weights,
    fourier_solve,
    fourier_transfer,
)
from enctools.units import ARCSEC, TWO_PI

if TYPE_CHECKING:
    import pyarrow as pa

    from enctools.data.readings import HeadInfo
    from enctools.data.streams import Header, InputStream
    from enctools.methods.budget import Coverage

#: the transfer functions are importable from here too, as before they had a module
__all__ = ["MIN_TRANSFER", "Conditioning", "Method", "Result", "Settings", "Solution",
           "calibrate", "check_equal_spacing", "check_method", "esa_noise_norm", "esa_transfer",
           "esa_weights", "fourier_solve", "fourier_transfer", "plan", "run"]

#: default: a harmonic whose normalised transfer |W(n)| / |a| is below this is ill-conditioned
MIN_TRANSFER = 0.1

log = logging.getLogger("enctools")
#: how the other heads are chosen when no method is given (that of the basic method)
_DEFAULT_OTHERS = selfcal_methods.SelfcalMethod("", "")


def check_method(name: str) -> None:
    """SettingsError naming `method` unless ``name`` is a method enc selfcal solves with
    (:func:`enctools.methods.selfcal_methods.names`)."""
    selfcal_methods.get(name, "selfcal")


@dataclass(frozen=True)
class Settings:
    """What a self-calibration does: the options of enc selfcal, checked together.

    ``method``: a method of :mod:`enctools.methods.selfcal_methods`; ``ref``: the
    reference head; ``heads``: the other heads; ``angle_from``: the heads whose mean is
    the angle coordinate (None: chosen from the readings, see :func:`plan`); ``band``:
    the highest harmonic K solved for; ``points``: points of the output grid over one
    revolution (more than 2 K); ``min_transfer``: the normalised |W(n)| (dimensionless)
    below which a harmonic is ill-conditioned; ``strict``: refuse blind and
    ill-conditioned harmonics instead of
    warning. SettingsError naming the fields when they do not go together.
    """

    method: str | None = None
    ref: str | None = None
    heads: tuple[str, ...] | None = None
    angle_from: tuple[str, ...] | None = None
    band: int = 100
    points: int = 1024
    min_transfer: float = MIN_TRANSFER
    strict: bool = False

    def __post_init__(self) -> None:
        if self.method is not None:
            check_method(self.method)
        if self.band < 1:
            msg = f"`band` must be > 0, not {self.band}"
            raise SettingsError(msg)
        check_grid(self.points, self.band)
        if not self.min_transfer > 0:
            msg = f"`min_transfer` must be > 0, not {self.min_transfer}"
            raise SettingsError(msg)

    def to_dict(self) -> dict[str, Any]:
        """The settings as the outputs' metadata records them (lists, not tuples)."""
        return {"method": self.method, "ref": self.ref, "heads": _listed(self.heads),
                "angle_from": _listed(self.angle_from), "band": self.band,
                "points": self.points, "min_transfer": self.min_transfer,
                "strict": self.strict}


def _listed(names: tuple[str, ...] | None) -> list[str] | None:
    return None if names is None else list(names)


@dataclass
class Conditioning:
    """How well each harmonic 0..K is determined.

    ``transfer``: |W(n)| as the method defines it (seed 000 eq. (15) with C = 1 for
    esa); ``gain``: noise amplification, the factor from one head's noise to F(n)
    (1 / normalised transfer); ``blind``/``ill``: harmonic orders 1..K that are not
    determined / whose gain exceeds 1 / ``min_transfer``; ``blind_radial``: orders
    2..K where radial motion x, y is not determined (esa: where W(n) = 0 the
    graduation term is a radial-motion pattern, eqs. (11), (15)), set to 0 in x, y.
    """

    transfer: np.ndarray
    gain: np.ndarray
    blind: list[int] = field(default_factory=list)
    ill: list[int] = field(default_factory=list)
    limit: float = MIN_TRANSFER
    blind_radial: list[int] = field(default_factory=list)

    def message(self) -> str | None:
        """One line naming the blind (graduation, then x, y) and ill-conditioned orders."""
        parts = []
        if self.blind:
            parts.append(f"blind harmonics (|W(n)| = 0): {format_orders(self.blind)}")
        if self.blind_radial:
            parts.append(f"radial motion x, y blind at {format_orders(self.blind_radial)}")
        if self.ill:
            parts.append(f"ill-conditioned harmonics (noise gain > "
                         f"{1 / self.limit:g}): {format_orders(self.ill)}")
        return "; ".join(parts) or None


class Method:
    """A self-calibration method bound to a head arrangement and a band.

    ``name``: the method's name in the registry (:mod:`enctools.methods.selfcal_methods`);
    ``ref`` and ``heads``: the reference head's angle and the others' [rad];
    ``radius_m``: scale radius [m].
    """

    def __init__(self, name: str, alpha_ref: float, alphas: np.ndarray, band: int,
                 radius_m: float, names: list[str] | None = None,
                 min_transfer: float = MIN_TRANSFER) -> None:
        self.strategy = selfcal_methods.get(name, "selfcal")
        self.name = name
        self.alpha_ref = float(alpha_ref)
        self.alphas = np.asarray(alphas, dtype=np.float64)
        self.all_alphas = np.concatenate([[self.alpha_ref], self.alphas])
        self.band = int(band)
        self.radius_m = float(radius_m)
        self.names = names or [f"head{k}" for k in range(len(self.all_alphas))]
        self.min_transfer = float(min_transfer)
        self.params = self.strategy.prepare(self.alpha_ref, self.alphas, self.names)
        self.conditioning = self._conditioning()
        self._tables: dict[int, dict[str, np.ndarray]] = {}

    @property
    def blind(self) -> list[int]:
        """The orders 1..K not determined."""
        return self.conditioning.blind

    @property
    def blind_radial(self) -> list[int]:
        """The orders 2..K where radial motion is not determined."""
        return self.conditioning.blind_radial

    def _conditioning(self) -> Conditioning:
        n = np.arange(self.band + 1)
        transfer, normalised = self.strategy.transfer(self.alpha_ref, self.alphas, n)
        with np.errstate(divide="ignore"):
            gain = np.where(normalised > BLIND, 1.0 / np.maximum(normalised, 1e-300), np.inf)
        blind = [int(k) for k in n[1:] if normalised[k] <= BLIND]
        ill = [int(k) for k in n[1:] if BLIND < normalised[k] < self.min_transfer]
        radial = [k for k in blind if k >= 2] if self.strategy.separates_radial else []
        return Conditioning(transfer, gain, blind, ill, self.min_transfer, radial)

    def _table(self, size: int) -> dict[str, np.ndarray]:
        """What :meth:`solve` multiplies by at harmonics 0..size-1: made once, not per call.

        ``basic``: conj(exp(i n alpha_k) - mean_j exp(i n alpha_j)) / |W(n)|^2 of the
        least squares (0 where blind; eq. (15) of the basic model); and the method's own
        (:meth:`~enctools.methods.selfcal_methods.SelfcalMethod.tables`).
        """
        table = self._tables.get(size)
        if table is not None:
            return table
        n = np.arange(size)
        w, basic = basic_table(self.all_alphas, n, BLIND)
        table = {"basic": basic} | self.strategy.tables(self, n, w)
        self._tables[size] = table
        return table

    def solve(self, spectra: np.ndarray) -> Solution:
        """Solve one set of head spectra (heads: ref first, then ``alphas``; rad) for F, X, Y."""
        return self.strategy.solve(self, spectra, self._table(spectra.shape[1]))

    def coordinate_error(self, sol: Solution, alphas: np.ndarray) -> np.ndarray:
        """Coefficients [rad] of the error of a coordinate: the mean of heads at ``alphas``."""
        n = np.arange(sol.graduation.size)
        c = np.exp(1j * np.outer(n, alphas)).mean(axis=1) * sol.graduation
        if sol.x is not None and sol.y is not None:
            radial = sol.x * np.mean(np.sin(alphas)) - sol.y * np.mean(np.cos(alphas))
            c = c + radial / self.radius_m
        c[0] = 0
        return c


@dataclass
class Result:
    """What a self-calibration found, averaged over revolutions.

    Coefficients c_0..c_K of the graduation error [arcsec] (function of the scale
    angle) and of radial motion x, y [nm] (function of the spindle angle; esa only),
    each with its standard uncertainty per harmonic [same unit]: the spread between
    revolutions and the bound on the method's own error, and the coverage of U
    (``u``: :class:`~enctools.methods.selfcal_uncertainty.Uncertainties`); curves
    on a ``points`` grid with pointwise uncertainties in ``u``. ``iterations``: of the
    coordinate on the first revolution and on the mean; ``last_change``: the RMS
    change of the graduation error in the last [arcsec]; ``offsets``: each head's
    constant offset against the reference [rad]; ``mounting``: the rms change of the
    graduation curve [arcsec] per rad of each head's mounting angle, and
    ``mounting_coefficients`` its coefficients c_0..c_K per head [same]
    (:func:`~enctools.methods.selfcal_uncertainty.mounting_changes`).
    """

    method: str
    heads: list[str]
    coordinate: list[str]
    band: int
    revolutions: int
    conditioning: Conditioning
    coefficients: dict[str, np.ndarray]
    u: Uncertainties
    curves: dict[str, np.ndarray]
    iterations: tuple[int, int] = (0, 0)
    last_change: float = 0.0
    offsets: np.ndarray = field(default_factory=lambda: np.zeros(0))
    mounting: np.ndarray = field(default_factory=lambda: np.zeros(0))
    mounting_coefficients: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))


#: the factor from each solution array's unit to the output's: rad -> arcsec, m -> nm
SCALE = {"graduation": 1.0 / ARCSEC, "x": 1e9, "y": 1e9}


def solution_parts(sol: Solution) -> dict[str, np.ndarray]:
    """The solution's coefficient arrays by name [rad, m]: graduation, then x, y if solved."""
    out = {"graduation": sol.graduation}
    if sol.x is not None and sol.y is not None:
        out |= {"x": sol.x, "y": sol.y}
    return out


def calibrate(revolutions: Iterator[Revolution], method: Method,
              coordinate_alphas: np.ndarray, points: int, coordinate: list[str],
              resolution: float = 0.0) -> Result:
    """Analyse revolutions against the spindle angle, average them and solve with ``method``.

    ``revolutions``: the channels minus the angle coordinate [rad] per revolution, heads
    in the method's order (reference first); ``coordinate_alphas`` [rad]: the heads whose
    mean is the coordinate. The coordinate's own error and the heads' constant offsets
    are found on the first revolution and taken out of every one
    (:mod:`enctools.methods.coordinate`); what is left of it is corrected on the mean.
    ``resolution``: one count of the heads [rad] (2 pi / counts_per_rev; the coarsest).
    Memory does not grow with the revolutions (but for the first one's sample angles).
    """

    def model(g: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        sol = method.solve(g)
        return method.coordinate_error(sol, coordinate_alphas), solution_parts(sol)

    spectra, samples = RunningMean(), 0
    # the solution's arrays stacked (graduation, then x, y): one mean and one synthesis of
    # them all a revolution, each row as its own would be
    coef, curves, names = RunningMean(), RunningMean(), list(SCALE)
    repeats = SampleRepeats(resolution / max(len(coordinate_alphas), 1))
    first = next(revolutions, None)
    settled = None if first is None else settle(first, method.band, model)
    for rev, g in _against_theta(first, revolutions, settled, method.band):
        repeats.add(rev)
        spectra.add(g)
        samples += rev.u.size - 1
        parts = solution_parts(method.solve(g))
        names = list(parts)
        scaled = np.array([c * SCALE[name] for name, c in parts.items()])
        coef.add(scaled)
        curves.add(synthesize(scaled, points))
    if spectra.mean is None or settled is None or spectra.count < 2:
        msg = (f"input: {spectra.count} complete revolution(s) of the angle coordinate; "
               "self-calibration needs at least 2 (record more revolutions with enc acquire)")
        raise DataError(msg)
    refined = refine(spectra.mean, settled.angle.error_coefficients(method.band), model)
    noise = resolution / np.sqrt(12.0) * np.sqrt(2.0 / (samples / spectra.count))
    bound = systematic(lambda g: solution_parts(method.solve(g)), len(method.all_alphas), refined,
                       noise if repeats.repeated else 0.0, SCALE)
    solved = {name: part * SCALE[name] for name, part in refined.parts.items()}
    change = refined.change["graduation"] * SCALE["graduation"]
    moved = mounting_changes(lambda g: solution_parts(method.solve(g)), method.all_alphas,
                             refined.parts, method.radius_m)
    return Result(method.name, list(method.names), coordinate, method.band, spectra.count,
                  method.conditioning, solved,
                  uncertainties(dict(zip(names, coef.rows(), strict=True)),
                                dict(zip(names, curves.rows(), strict=True)), bound,
                                repeats.repeated),
                  {name: synthesize(part, points) for name, part in solved.items()},
                  (settled.iterations, refined.iterations),
                  float(np.sqrt(np.sum(np.abs(change[1:]) ** 2) / 2)),
                  spectra.mean[:, 0].real - spectra.mean[0, 0].real,
                  mounting_rms(moved) * SCALE["graduation"], moved * SCALE["graduation"])


def _against_theta(first: Revolution | None, rest: Iterator[Revolution],
                   settled: Settled | None, band: int) -> Iterator[tuple[Revolution, np.ndarray]]:
    """Each revolution (``first``, then ``rest``) with its heads' coefficients c_0..c_band
    against theta [rad], as ``settled`` on the first (:func:`settle`): its offsets taken
    off the revolution's values [rad] as they are summed (read from its pieces, not
    joined) and its coefficients made on a worker thread ahead of the caller
    (:func:`enctools.methods.overlap.ahead`), which folds them meanwhile.
    """
    if first is None or settled is None:
        return

    def against(rev: Revolution) -> np.ndarray:
        g = spectra_against(rev, rev.parts, settled.angle, band, minus=settled.offsets)
        g[:, 0] += settled.offsets
        return g

    yield from ahead(itertools.chain([first], rest), against)


@dataclass
class Plan:
    """Which heads a self-calibration reads, and how: resolved from a readings header.

    ``settings``: the settings with method, ref, heads and angle_from filled in.
    """

    method: Method
    heads: list[HeadInfo]          # reference first
    coordinate: list[HeadInfo]
    encoder: str
    settings: Settings


def plan(schema: pa.Schema, meta: dict, settings: Settings, source: str = "input") -> Plan:
    """Resolve the method, reference head, other heads and angle coordinate.

    Defaults: the encoder with the most heads; the reference is its head nearest
    0 deg; the other heads are those not among the rig's measuring heads
    (``measure_heads``), else all others; ``esa`` when that makes three heads,
    ``fourier`` otherwise. The angle coordinate is the mean of the encoder's measuring
    heads when all are recorded (their average cancels radial motion), else the
    reference head.
    """
    from enctools.data.readings import head_info, rig_measure_heads
    from enctools.data.readings import heads as all_heads

    infos = all_heads(schema)
    if not infos:
        msg = f"{source}: readings stream has no head column"
        raise DataError(msg)
    by_name = {h.name: h for h in infos}
    given = (settings.ref,) if settings.ref is not None else ()
    for name in given + (settings.heads or ()) + (settings.angle_from or ()):
        head_info(schema, name, source)  # DataError naming the heads present
    encoder = _encoder(infos, by_name, settings)
    enc_heads = [h for h in infos if h.encoder == encoder]
    listed = rig_measure_heads(meta, encoder)
    measure = [n for n in listed if n in by_name]
    ref = settings.ref if settings.ref is not None else _nearest_zero(enc_heads).name
    heads = [h for h in _other_heads(settings, enc_heads, ref, measure) if h != ref]
    chosen = [by_name[ref]] + [by_name[h] for h in heads]
    method = _method_for(settings.method, chosen, encoder, ref)
    if settings.angle_from is not None:
        angle_from = list(settings.angle_from)
    else:  # the mean of all measuring heads, when they are all recorded
        angle_from = measure if len(measure) == len(listed) and len(measure) > 1 else [ref]
    coordinate = [by_name[n] for n in angle_from]
    foreign = [h.name for h in coordinate if h.encoder != encoder]
    if foreign:
        msg = (f"`angle_from`: {', '.join(foreign)} belong to another encoder than {encoder}; "
               "the angle coordinate must come from the calibrated scale's heads")
        raise SettingsError(msg)
    m = Method(method, chosen[0].alpha, np.array([h.alpha for h in chosen[1:]]),
               settings.band, chosen[0].radius_m, [h.name for h in chosen],
               settings.min_transfer)
    resolved = replace(settings, method=method, ref=ref, heads=tuple(heads),
                       angle_from=tuple(angle_from))
    return Plan(m, chosen, coordinate, encoder, resolved)


def _encoder(infos: list[HeadInfo], by_name: dict[str, HeadInfo], settings: Settings) -> str:
    """The calibrated encoder: the reference's, the first head's, else the one with most heads."""
    if settings.ref is not None:
        return by_name[settings.ref].encoder
    if settings.heads:
        return by_name[settings.heads[0]].encoder
    counts: dict[str, int] = {}
    for h in infos:
        counts[h.encoder] = counts.get(h.encoder, 0) + 1
    return max(counts, key=lambda e: counts[e])


def _nearest_zero(heads: list[HeadInfo]) -> HeadInfo:
    """The head whose nominal angle is nearest 0 deg (the first of equals)."""
    return min(heads, key=lambda h: min(h.alpha % (2 * np.pi), 2 * np.pi - h.alpha % (2 * np.pi)))


def _other_heads(settings: Settings, enc_heads: list[HeadInfo], ref: str,
                 measure: list[str]) -> list[str]:
    """The heads besides the reference: as given, else the encoder's non-measuring heads.

    A method may choose otherwise (eda: the measuring heads, equally spaced, when the rig
    names them); without non-measuring heads, all the encoder's heads but the reference.
    """
    if settings.heads is not None:
        return list(settings.heads)
    all_but_ref = [h.name for h in enc_heads if h.name != ref]
    others = [n for n in all_but_ref if n not in measure]
    strategy = selfcal_methods.find(settings.method, "selfcal") or _DEFAULT_OTHERS
    return strategy.other_heads(all_but_ref, others, [n for n in measure if n != ref])


def _method_for(method: str | None, chosen: list[HeadInfo], encoder: str, ref: str) -> str:
    """The method for the chosen heads (the registry's default for their number: esa with
    4, else fourier), checked against them."""
    mixed = [h.name for h in chosen if h.encoder != encoder]
    if mixed:
        msg = (f"`heads`: {', '.join(mixed)} belong to another encoder than {ref} ({encoder}); "
               "self-calibration uses heads of one scale")
        raise SettingsError(msg)
    if len(chosen) < 2:
        msg = f"self-calibration needs at least 2 heads of encoder {encoder}; give `heads`"
        raise SettingsError(msg)
    strategy = (selfcal_methods.default(len(chosen), "selfcal") if method is None
                else selfcal_methods.get(method, "selfcal"))
    strategy.check_count(len(chosen), [h.name for h in chosen])
    return strategy.name


def run(source: InputStream, settings: Settings,
        progress: Callable[[int, int], Any] | None = None
        ) -> tuple[tuple[Header, pa.Table], tuple[Header, pa.Table]]:
    """A readings stream in, (deviations, spectrum) headers and tables out.

    Warns about (or, ``settings.strict``, refuses) blind and ill-conditioned
    harmonics before reading any data. ``progress(done, total)`` is called with the
    revolutions analysed and expected.
    """
    require_continuous(source, "self-calibration needs a continuous run "
                               "(enc acquire in continuous mode)")
    p = plan(source.schema, source.meta, settings, source.source)
    check_width(len(p.heads), p.method.band, source.source)
    _refuse_or_warn(p.method, settings.strict)
    total = int(float((source.meta.get("settings") or {}).get("revolutions") or 0))

    def tick(done: int) -> None:
        if progress is not None:
            progress(done, max(total, done))

    spec = ChannelSpec(tuple(p.heads), tuple(p.coordinate))
    res = calibrate(revolutions(source, spec, tick, p.method.band), p.method,
                    np.array([h.alpha for h in p.coordinate]), p.settings.points,
                    [h.name for h in p.coordinate],
                    max(TWO_PI / h.counts_per_rev for h in p.heads))
    log.info("%s: %d revolutions of %s, harmonics 1..%d", p.method.name, res.revolutions,
             "/".join(res.heads), res.band)
    return _outputs(source.header, p, res)


#: most terms of the series the harmonic core sums a revolution's bins with (16 bins a
#: harmonic: its first neglected term is then below the unit roundoff)
_SERIES_TERMS = 12


def check_width(heads: int, band: int, source: str) -> None:
    """DataError, before anything is read, when the spectra of ``heads`` channels up to
    harmonic ``band`` would need more than
    :data:`~enctools.methods.revolutions.MAX_REVOLUTION_VALUES` values at once: the
    harmonic core forms (terms x heads x bins) moments of each revolution, bins = 16 a
    harmonic (:mod:`enctools.methods.harmonics`), some 200 KB a head at K = 100."""
    from enctools.methods.harmonics import BINS_PER_HARMONIC
    from enctools.methods.revolutions import MAX_REVOLUTION_VALUES

    bins = 1 << max(3, (band * BINS_PER_HARMONIC - 1).bit_length())
    need = heads * bins * _SERIES_TERMS
    if need > MAX_REVOLUTION_VALUES:
        most = max(MAX_REVOLUTION_VALUES // (bins * _SERIES_TERMS), 0)
        msg = (f"{source}: {heads} heads up to harmonic {band} need {need} values a "
               f"revolution ({heads} heads x {bins} bins x {_SERIES_TERMS} terms); at most "
               f"{MAX_REVOLUTION_VALUES} are held: give at most {most} `heads`, or a "
               "smaller `band`")
        raise DataError(msg)


def _refuse_or_warn(method: Method, strict: bool) -> None:
    """Name the blind and ill-conditioned harmonics: SettingsError when ``strict``, else a
    warning."""
    problem = method.conditioning.message()
    if not problem:
        return
    where = f"{method.name} with {'/'.join(method.names)} up to n = {method.band}"
    if strict:
        msg = f"{where}: {problem} (`strict`; narrow `band` or move heads)"
        raise SettingsError(msg)
    what = []
    if method.conditioning.blind:
        what.append("blind orders are set to 0")
    if method.conditioning.ill:
        what.append("ill-conditioned ones are divided through, their noise amplified (in u)")
    log.warning("%s: %s; %s", where, problem, ", ".join(what) or "see enc-selfcal(1)")


def _outputs(header: Header, p: Plan, res: Result
             ) -> tuple[tuple[Header, pa.Table], tuple[Header, pa.Table]]:
    """The deviations (curves on the grid) and spectrum (coefficients) of a result."""
    from enctools.data.curves import Column, deviations_table, spectrum_table, uncertainty

    def stated(cov: Coverage | None) -> dict[str, str]:
        return {} if cov is None else cov.field_meta()

    cols = [Column("graduation", res.curves["graduation"], "deviation", "arcsec",
                   {"encoder": p.encoder, "argument": "scale angle",
                    "method": p.method.name}),
            uncertainty("graduation", res.u.curves["graduation"], "arcsec",
                        stated(res.u.curve["graduation"]))]
    for ax in ("x", "y"):
        if ax in res.curves:
            u_rms = float(np.sqrt(np.mean(res.u.curves[ax] ** 2)))
            cols.append(Column(ax, res.curves[ax], "radial", "nm",
                               {"encoder": p.encoder, "argument": "spindle angle",
                                "u_rms_nm": f"{u_rms:.4g}"}))
            cols.append(uncertainty(ax, res.u.curves[ax], "nm", stated(res.u.curve[ax])))
    table = deviations_table(grid(p.settings.points), cols)
    cond = p.method.conditioning
    meta = {"settings": p.settings.to_dict() | {"encoder": p.encoder,
                                                "revolutions": res.revolutions},
            "blind": cond.blind, "ill_conditioned": cond.ill, "domain": "revolution",
            "iterations": {"first_revolution": res.iterations[0], "mean": res.iterations[1],
                           "last_change_arcsec": res.last_change},
            "offsets_arcsec": {h: float(o / ARCSEC) for h, o in zip(res.heads, res.offsets)},
            "rounding_repeats": res.u.repeated,
            "mounting_arcsec_per_rad": {h: float(m) for h, m in zip(res.heads, res.mounting)},
            "mounting_coefficients_arcsec_per_rad": {
                h: {"re": c.real.tolist(), "im": c.imag.tolist()}
                for h, c in zip(res.heads, res.mounting_coefficients)}}
    if "x" in res.curves:
        meta["blind_radial"] = cond.blind_radial
    dev_header = header.derive("deviations", table.schema, **meta)
    st = spectrum_table([("graduation", res.coefficients["graduation"], cond.transfer,
                          res.u.harmonics["graduation"])],
                        coverage=stated(res.u.spectrum["graduation"]))
    spec_header = header.derive("spectrum", st.schema, **meta)
    return (dev_header, table), (spec_header, st)
