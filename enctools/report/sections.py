"""One report section per stream kind: the figures and the plot data of one input.

:func:`build_section` reads an open :class:`~enctools.streams.InputStream` and returns
a :class:`Section` holding, for its kind:

- deviations: every curve (role deviation [arcsec], radial [nm]) with its figures,
  largest harmonics and, where a role-uncertainty column names it (field metadata
  ``of``), its standard uncertainty and expanded uncertainty U = k u (k as the
  column states it in its field metadata ``k``: Student's at its degrees of freedom;
  else 2);
- spectrum: the largest harmonics of each curve with U = k u and |W(n)|, and the
  harmonics the method is blind to (metadata ``blind``);
- points: the deviation per position (means when positions repeat), figures, the
  harmonics by least squares and, for runs with repeats, ISO 230-2 or VDI/DGQ 3441
  (:attr:`Options.standard`);
- model and rom: their metadata and the figures of weights / corrections;
- readings: what was recorded (mode, heads, rows, duration, turns), for step runs the
  positioning deviation of the axis (encoder - target, on an encoder the axis does not
  position on: :mod:`enctools.report.positioning`, :mod:`enctools.report.steprun`) with
  ISO 230-2, and the raw sin/cos signals for a Lissajous plot when recorded.

Readings are read batch by batch (memory does not grow with the run's length).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data import readings
from enctools.data.columns import column, declared_unit, uncertainty_columns
from enctools.data.schemas import columns_with_role, field_meta
from enctools.data.statistics import Figures, curve_figures
from enctools.data.streams import InputStream
from enctools.errors import DataError, EncError
from enctools.methods.budget import Budget, type_a_coverage
from enctools.methods.interp.screen import screen_notes
from enctools.methods.points import count_deg, is_linear
from enctools.methods.targets import tolerance
from enctools.models.correction_u import CorrectionU
from enctools.report import longcurves
from enctools.report.figures import K_COVERAGE, Harmonics, expanded_uncertainty, harmonics
from enctools.report.iso230 import Iso230, approaches, iso230_2, target_positions
from enctools.report.longcurves import Digest, period_domain, stated_k
from enctools.report.positioning import positioning_heads
from enctools.report.readingsscan import ReadingsScan, scan_batch, signal_columns
from enctools.report.steprun import positioning
from enctools.report.vdi3441 import Vdi3441, from_iso
from enctools.units import DEG

#: Lissajous plots keep at most this many samples per head
LISSAJOUS_POINTS = 4000


@dataclass
class Curve:
    """One error curve of a section: values at angles [rad] over one revolution, or at the
    phase [rad, 0..2 pi] within one signal period (``domain == "period"``)."""

    name: str
    unit: str                       # "arcsec", "nm" or "count"
    role: str                       # deviation, radial, points, correction, positioning
    angle: np.ndarray               # rad
    values: np.ndarray
    figures: Figures
    harmonics: Harmonics | None = None   # every order 0..nmax (largest(): the top ones)
    u: np.ndarray | None = None     # standard uncertainty per angle, same unit
    domain: str = "revolution"      # or "period": angle is the phase in a signal period
    head: str | None = None
    extra: dict[str, float] = field(default_factory=dict)
    k: float = K_COVERAGE           # coverage factor of U = k u (a budget's Student k)
    dof: float | None = None        # degrees of freedom of a Type A u (targets' approaches)
    #: the mean of each direction (+1 up, -1 down) per target, where both were approached
    directions: dict[int, np.ndarray] = field(default_factory=dict)
    #: a long curve's (longcurves.py): then angle, values and u are its plot's envelope
    digest: Digest | None = None
    #: a model's: each point it was fitted to [deg] and its prediction there refitted
    #: without that point [arcsec] (enc fit-rbf's ``residuals.held_out``)
    held_out: tuple[np.ndarray, np.ndarray] | None = None
    #: a model's uncertainty at any angle (enc fit-rbf's ``residuals.correction_u``)
    correction_u: CorrectionU | None = None

    @property
    def U_max(self) -> float | None:
        """Largest expanded uncertainty U = k u along the curve, in its unit (arcsec, nm)."""
        return None if self.u is None else float(np.max(expanded_uncertainty(self.u, self.k)))


@dataclass
class SpectrumRows:
    """The harmonics of one curve of a spectrum stream."""

    curve: str
    n: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    u: np.ndarray | None = None
    transfer: np.ndarray | None = None
    unit: str = "arcsec"            # of amplitude and u
    k: float = K_COVERAGE           # coverage factor of U = k u (as the u column states it)

    def largest(self, count: int) -> np.ndarray:
        """Row indices of the ``count`` largest amplitudes (n > 0), largest first."""
        idx = np.flatnonzero(self.n > 0)
        return idx[np.argsort(-self.amplitude[idx], kind="stable")][:count]


@dataclass
class Section:
    """What the report says about one input."""

    source: str
    kind: str
    meta: dict[str, Any]
    domain: str = "revolution"      # or "period" (interpolation errors)
    unit: str = "arcsec"            # of its angle errors (enc report --unit)
    curves: list[Curve] = field(default_factory=list)
    spectra: list[SpectrumRows] = field(default_factory=list)
    iso: Iso230 | None = None
    vdi: Vdi3441 | None = None
    info: dict[str, Any] = field(default_factory=dict)
    signals: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    budget: Budget | None = None    # the GUM budget of its results [arcsec], when declared
    covariance: Any = None          # a polygon run's report.covariance.Statement, with it

    @property
    def rig_name(self) -> str | None:
        rig = self.meta.get("rig")
        return rig.get("name") if isinstance(rig, dict) else None

    @property
    def history(self) -> list[str]:
        return list(self.meta.get("history", []))


@dataclass(frozen=True)
class Options:
    """Report settings: harmonics listed, the highest order considered, the
    positioning standard of step runs (``iso230-2`` or ``vdi3441``) and whether a step
    run read on the axis' feedback encoder gets the servo loop's figures
    (``servo_loop``; else none, :mod:`enctools.report.positioning`)."""

    top_harmonics: int = 5
    nmax: int = 100
    standard: str = "iso230-2"
    servo_loop: bool = False
    #: a setting's field -> the words that name it in a note (a command: its option)
    words: Callable[[str], str] | None = field(default=None, compare=False)

    def say(self, text: str) -> str:
        """``text`` with each setting it names (```field```) in :attr:`words`."""
        return EncError(text).render(self.words or (lambda name: name))

    @property
    def standard_name(self) -> str:
        """The standard as the report names it."""
        return STANDARDS[self.standard]


#: the positioning standards of enc report --standard, and their names
STANDARDS = {"iso230-2": "ISO 230-2", "vdi3441": "VDI/DGQ 3441"}


#: the report's default settings
DEFAULT_OPTIONS = Options()


def build_section(stream: InputStream, opts: Options = DEFAULT_OPTIONS) -> Section:
    """The section of one input stream (dispatch on its kind)."""
    build = {"deviations": _deviations, "spectrum": _spectrum, "points": _points,
             "model": _model, "rom": _rom, "readings": _readings}[stream.kind]
    section = Section(stream.source, stream.kind, dict(stream.meta))
    build(stream, section, opts)
    return section


def _col(table: pa.Table, name: str) -> np.ndarray:
    return table.column(name).to_numpy(zero_copy_only=False).astype(np.float64)


def _curve(name: str, unit: str, role: str, angle: np.ndarray, values: np.ndarray,
           opts: Options, source: str, **kw: Any) -> Curve:
    try:
        figs = curve_figures(values)
    except DataError as exc:
        msg = f"{source}: column {name!r}: {exc}"
        raise DataError(msg) from None
    try:
        harm = harmonics(angle, values, opts.nmax)
    except DataError:
        harm = None
    return Curve(name, unit, role, angle, np.asarray(values, np.float64), figs, harm,
                 **kw)


# ------------------------------------------------------------------ deviations


def _deviations(stream: InputStream, s: Section, opts: Options) -> None:
    """Each curve with its figures, harmonics and U: a stream of at most
    ``longcurves.HOLD_ROWS`` rows held whole, a longer one summed block by block."""
    from enctools.report.budget import curve_budget_into, interpolation_into, stated_dof

    schema = stream.schema
    if period_domain(s.meta, schema):
        s.domain = "period"
    unc = uncertainty_columns(schema)
    named = [(name, role, "nm" if field_meta(schema.field(name)).get("unit") == "nm" else unit)
             for role, unit in (("deviation", "arcsec"), ("radial", "nm"))  # a scale's: nm
             for name in columns_with_role(schema, role)]
    got = longcurves.gather(stream, [(n, unit, unc.get(n)) for n, _, unit in named], opts.nmax,
                            longcurves.radial_pair([n for n, r, _ in named if r == "radial"]))
    held = got if isinstance(got, pa.Table) else None
    if held is not None and held.num_rows == 0:
        msg = f"{s.source}: deviations stream has no rows"
        raise DataError(msg)
    longs = {} if isinstance(got, pa.Table) else got.results(s.source)
    theta = None if held is None else column(held, "theta", "rad", s.source)
    for name, role, unit in named:
        fm = field_meta(schema.field(name))
        in_period = s.domain == "period" and role == "deviation"
        kw: dict[str, Any] = {"head": fm.get("head", name if in_period else None),
                              "domain": "period" if in_period else "revolution"}
        if held is not None and theta is not None:
            u = column(held, unc[name], unit, s.source) if name in unc else None
            s.curves.append(_curve(name, unit, role, theta, column(held, name, unit, s.source),
                                   opts, s.source, u=u, **kw))
        else:
            r = longs[name]
            s.curves.append(Curve(name, unit, role, r.angle, r.values, r.figures, r.harmonics,
                                  u=r.u, digest=r.digest, **kw))
        if name in unc:
            s.curves[-1].k = stated_k(schema, unc[name])
            if role == "deviation" and s.budget is None:
                dof = stated_dof(field_meta(schema.field(unc[name])))
                longcurves.budget(s, lambda: curve_budget_into(s, s.curves[-1], dof),  # noqa: B023
                                  longs)  # called at once, in this iteration
        s.curves[-1].extra |= {k: float(fm[k]) for k in ("period_arcsec", "signal_period_nm")
                               if in_period and k in fm}  # an encoder's, a scale's
        if in_period and fm.get("reference") == "probes":
            s.curves[-1].extra["probes"] = 1.0      # its reference: the probes
    if s.budget is None:
        longcurves.budget(s, lambda: interpolation_into(s), longs)
    s.info["grid points"] = held.num_rows if held is not None else got.rows
    s.notes += screen_notes(s.meta.get("signals"))  # interp-check --signals: faults found
    if s.domain == "period":
        periods = {k: sorted({f"{c.extra[k]:.{d}g}" for c in s.curves if k in c.extra})
                   for k, d in (("period_arcsec", 4), ("signal_period_nm", 6))}
        said = [", ".join(v) + f" {k.rsplit('_', 1)[1]}" for k, v in periods.items() if v]
        s.info["signal period"] = said[0] if said else "-"


# -------------------------------------------------------------------- spectrum


def _spectrum(stream: InputStream, s: Section, opts: Options) -> None:
    table = stream.read_all()
    names = table.schema.names
    curves = (table.column("curve").to_pylist() if "curve" in names
              else [s.meta.get("curve", "spectrum")] * table.num_rows)
    n_all = table.column("n").to_numpy(zero_copy_only=False).astype(np.int64)
    # the amplitude's uncertainty: by its field metadata 'of' (v2), else the v1 column u
    u_col = uncertainty_columns(table.schema).get("amplitude", "u" if "u" in names else None)
    for curve in dict.fromkeys(curves):
        mask = np.array([c == curve for c in curves])
        s.spectra.append(SpectrumRows(
            curve=str(curve), n=n_all[mask],
            amplitude=column(table, "amplitude", "arcsec", s.source)[mask],
            phase=column(table, "phase", "rad", s.source)[mask],
            u=column(table, u_col, "arcsec", s.source)[mask] if u_col else None,
            transfer=_col(table, "transfer")[mask] if "transfer" in names else None,
            k=stated_k(table.schema, u_col) if u_col else K_COVERAGE))
    blind = s.meta.get("blind")
    if blind:
        s.info["blind harmonics"] = ", ".join(str(b) for b in blind) if isinstance(
            blind, list) else str(blind)
    if period_domain(s.meta, table.schema):
        s.domain = "period"
    for key, label in (("ill_conditioned", "ill-conditioned harmonics"),
                       ("blind_radial", "radial motion x, y blind at")):
        if s.meta.get(key):
            s.info[label] = ", ".join(map(str, s.meta[key]))


# ---------------------------------------------------------------------- points


def _points(stream: InputStream, s: Section, opts: Options) -> None:
    table = stream.read_all()
    if table.num_rows == 0:
        msg = f"{s.source}: points stream has no rows"
        raise DataError(msg)
    if is_linear(table.schema):
        from enctools.report.linear import linear_points

        linear_points(table, s, opts)
        return
    pos = column(table, "position", "deg", s.source, declared_unit("points", s.meta, "position"))
    dev = column(table, "deviation", "arcsec", s.source)
    direction, run = (table.column(c).to_numpy(zero_copy_only=False)
                      if c in table.schema.names else None for c in ("direction", "run"))
    _points_into(s, pos, dev, direction, opts, "deviation", "points",
                 tolerance(pos, count_deg(s.meta)), run=run)
    _budget_into(s, pos, dev, one_approach=all(x is None or len(set(x.tolist())) == 1
                                               for x in (direction, run)))


def _budget_into(s: Section, pos_deg: np.ndarray, dev: np.ndarray, one_approach: bool) -> None:
    """The uncertainty budget of a polygon run's points (report/budget.py); ``pos_deg``
    the indicated position [deg] and ``dev`` the deviation [arcsec] of each point."""
    from enctools.report.budget import points_budget_into

    points_budget_into(s, one_approach, pos_deg, dev)


def _points_into(s: Section, pos_deg: np.ndarray, dev: np.ndarray,
                 direction: np.ndarray | None, opts: Options, name: str, role: str,
                 tol_deg: float = 0.01, run: np.ndarray | None = None,
                 no_iso: str | None = None) -> None:
    """Points -> one curve (means per target when positions repeat) and ISO 230-2.

    ``tol_deg``: measured positions closer than this are one target (a points stream:
    the tolerance every command derives, :func:`enctools.methods.targets.tolerance`;
    commanded targets of a readings stream are exact: a tiny tolerance). ``run``: the run of
    each reading; the readings of one run at one target in one direction are one
    approach, averaged first (None: each reading is one). ``no_iso``: why the run
    gets no ISO 230-2 figures (a sweep), as a note."""
    if not np.all(np.isfinite(pos_deg)):
        msg = f"{s.source}: a position is NaN or infinite"
        raise DataError(msg)
    # positions modulo 360 deg are one target: a closing 360 deg row is the 0 deg target
    # again (seed 001 tables 1 and 2), averaged with it as enc points and fit-rbf do
    unique, index, counts = target_positions(pos_deg, tol_deg, circular=True)
    order = np.argsort(unique)          # targets in increasing angle
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    unique, index, counts = unique[order], rank[index], counts[order]
    if np.all(counts == 1):
        curve = _curve(name, "arcsec", role, pos_deg * DEG, dev, opts, s.source)
    else:
        curve = _repeated(s, pos_deg, dev, direction, run, (unique, index), opts,
                          (name, role, tol_deg), no_iso)
    s.curves.append(curve)
    s.info["positions"] = int(unique.size)
    # a points stream's rows are points (each may be the mean of several readings,
    # which its budget counts); a step run's rows are readings
    s.info["points" if s.kind == "points" else "readings"] = int(pos_deg.size)


def _repeated(s: Section, pos_deg: np.ndarray, dev: np.ndarray, direction: np.ndarray | None,
              run: np.ndarray | None, targets: tuple[np.ndarray, np.ndarray], opts: Options,
              what: tuple[str, str, float], no_iso: str | None) -> Curve:
    """The curve of points whose positions repeat: per target the mean over the
    directions of the mean over approaches (one run's readings at one target in one
    direction averaged first) [arcsec], its standard uncertainty from the approaches'
    scatter (Type A; a budget adds its Type B terms, report/budget.py), and ISO 230-2
    when every target has 2 approaches or more."""
    name, role, tol_deg = what
    unique, index = targets
    d = np.ones(dev.size, np.int64) if direction is None else np.asarray(direction, np.int64)
    a_index, a_dir, a_x, _ = approaches(index, dev, d, run)
    means, u, n_min, dof = _means_and_u(a_index, a_dir, a_x, unique.size)
    curve = _curve(name, "arcsec", role, unique * DEG, means, opts, s.source)
    if u is not None and set(a_dir.tolist()) == {-1, 1}:    # each direction's mean x_i
        for sign in (1, -1):
            sel = a_dir == sign
            curve.directions[sign] = (np.bincount(a_index[sel], weights=a_x[sel],
                                                  minlength=unique.size)
                                      / np.bincount(a_index[sel], minlength=unique.size))
    s.notes.append(f"{dev.size} readings at {unique.size} positions ({a_x.size} approaches): "
                   "the curve and its figures use the mean deviation per position")
    none = f"no {opts.standard_name} figures"
    if n_min < 2:
        s.notes.append(f"{none}: one run per target and direction (the run "
                       "column numbers them; its readings are one approach); s needs 2 or more")
        return curve
    curve.u = u
    coverage = type_a_coverage(u, dof) if u is not None else None
    if coverage is not None:    # Student's k on the few approaches u rests on
        curve.k, curve.dof = coverage.k, dof
    if no_iso is not None:
        s.notes.append(f"{none}: {no_iso}")
        return curve
    # the standard's x = actual - target: a points stream's deviation is indicated - true
    x_sign = -1 if role == "points" else 1
    try:
        iso = iso230_2(pos_deg, x_sign * dev, direction, tol_deg, circular=True, run=run)
        iso.x_sign = x_sign
        if opts.standard == "vdi3441":
            s.vdi = from_iso(iso)
        else:
            s.iso = iso
            s.notes += iso.warnings
    except DataError as exc:
        s.notes.append(f"{none}: {str(exc).removeprefix('ISO 230-2: ')}")
    else:
        if iso.is_bidirectional:
            s.notes.append("with both directions the curve is the mean "
                           "bidirectional positioning deviation x_i")
    return curve


def _means_and_u(a_index: np.ndarray, a_dir: np.ndarray, a_x: np.ndarray, m: int
                 ) -> tuple[np.ndarray, np.ndarray | None, int, float]:
    """Per target: the mean over the directions of each direction's mean x_ij [arcsec]
    (x_i of ISO 230-2 with both), its standard uncertainty (type A: s / sqrt(n) of each
    direction, combined) [arcsec], the fewest approaches of a target and direction, and
    the degrees of freedom u rests on (Welch-Satterthwaite over the directions, on their
    mean variances along the curve: n - 1 for one direction)."""
    means, var, n_min, dirs = np.zeros(m), np.zeros(m), np.inf, sorted(set(a_dir.tolist()))
    parts: list[tuple[float, int]] = []     # (mean variance of a direction's mean, n - 1)
    for sign in dirs:
        sel = a_dir == sign
        n = np.bincount(a_index[sel], minlength=m)
        n_min = min(n_min, int(n.min()))
        if n.min() == 0:        # a direction misses a target: pooled, ISO 230-2 says so
            total = np.bincount(a_index, minlength=m)
            return (np.bincount(a_index, weights=a_x, minlength=m) / total, None,
                    int(total.min()), 0.0)
        mean = np.bincount(a_index[sel], weights=a_x[sel], minlength=m) / n
        resid = a_x[sel] - mean[a_index[sel]]
        with np.errstate(invalid="ignore", divide="ignore"):
            var_d = np.bincount(a_index[sel], weights=resid ** 2, minlength=m) / (n - 1) / n
        var += var_d
        parts.append((float(np.mean(var_d)), int(n.min()) - 1))
        means += mean
    total_var = sum(v for v, _ in parts)
    denominator = sum(v * v / f for v, f in parts if f > 0)
    dof = total_var ** 2 / denominator if denominator > 0 else 0.0
    return means / len(dirs), np.sqrt(var) / len(dirs), int(n_min), dof


# --------------------------------------------------------------- model and rom


def _model(stream: InputStream, s: Section, opts: Options) -> None:
    table = stream.read_all()
    model = s.meta.get("model", {})
    if isinstance(model, dict):
        for k, v in model.items():
            if isinstance(v, (str, int, float, bool)):
                s.info[str(k)] = v
    s.info["rows"] = table.num_rows
    residuals = s.meta.get("residuals")
    if isinstance(residuals, dict):
        for k, v in residuals.items():
            if isinstance(v, (int, float)):
                s.info[f"residual {k}"] = v
    from enctools.models.curve_model import (
        from_stream,  # the model's own evaluator (rbf or fourier)
    )

    evaluate = from_stream(stream.header, table, s.source)
    grid = np.arange(720) * 0.5
    cu = CorrectionU.from_meta(residuals.get("correction_u")) \
        if isinstance(residuals, dict) else None
    s.curves.append(_curve("model", "arcsec", "model", grid * DEG,
                           np.asarray(evaluate(grid), np.float64), opts, s.source,
                           held_out=_held_out(residuals, s.source), correction_u=cu,
                           u=None if cu is None else np.full(grid.size, cu.u_c),
                           k=K_COVERAGE if cu is None else cu.k))
    s.notes.append("the model curve is evaluated every 0.5 deg; thresholds do not apply to it")


def _held_out(residuals: Any, source: str) -> tuple[np.ndarray, np.ndarray] | None:
    """A model's points [deg] and its predictions there refitted without each [arcsec]
    (None: the model states none); a DataError line when they are malformed."""
    held = residuals.get("held_out") if isinstance(residuals, dict) else None
    if held is None:
        return None
    try:
        x = np.asarray(held["position_deg"], np.float64)
        y = np.asarray(held["prediction_arcsec"], np.float64)
    except (TypeError, KeyError, ValueError):
        x = y = np.zeros(0)
    if x.ndim != 1 or x.shape != y.shape or x.size == 0 \
            or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        msg = (f"{source}: residuals.held_out must hold position_deg and prediction_arcsec, "
               "lists of as many finite numbers")
        raise DataError(msg)
    return x, y


def _rom(stream: InputStream, s: Section, opts: Options) -> None:
    """A correction table's corrections [count] against its addresses over a turn: a
    table of at most ``longcurves.HOLD_ROWS`` addresses held whole, a longer one (a
    23-bit ROM: 2^23 words) summed block by block (:func:`longcurves.address_angle`)."""
    meta = s.meta.get("rom")
    rom: dict[str, Any] = meta if isinstance(meta, dict) else {}
    s.info |= {str(k): v for k, v in rom.items() if isinstance(v, (str, int, float, bool))}
    got = longcurves.gather(stream, [("correction", "count", None)], opts.nmax, None,
                            longcurves.address_angle(rom.get("entries"), s.source))
    if isinstance(got, pa.Table):
        if got.num_rows == 0:
            msg = f"{s.source}: rom stream has no rows"
            raise DataError(msg)
        turn = rom.get("entries") or int(_col(got, "address").max()) + 1
        s.curves.append(_curve("correction", "count", "correction",
                               longcurves.address_angle(turn, s.source)(got),
                               _col(got, "correction"), opts, s.source))
    else:
        r = got.results(s.source)["correction"]
        s.curves.append(Curve("correction", "count", "correction", r.angle, r.values,
                              r.figures, r.harmonics, digest=r.digest))
    s.info["addresses"] = got.num_rows if isinstance(got, pa.Table) else got.rows


# -------------------------------------------------------------------- readings


def _readings(stream: InputStream, s: Section, opts: Options) -> None:
    schema = stream.schema
    infos = readings.heads(schema)
    signal_cols = signal_columns(schema)
    stepped = "target" in schema.names
    # the positioning deviation is read on an encoder the axis does not position on
    encoder, where = positioning_heads(infos, s.meta)
    scan = ReadingsScan(autocollimator=bool(columns_with_role(schema, "autocollimator")))
    for batch in stream.batches():
        if batch.num_rows:
            scan_batch(scan, batch, infos, signal_cols, encoder if stepped else [])
    s.info["mode"] = s.meta.get("mode", "steps" if stepped else "continuous")
    s.info["rows"] = scan.rows
    s.info["heads"] = ", ".join(f"{i.name} ({i.encoder} at {i.alpha / DEG:g} deg)"
                                for i in infos)
    if scan.t_first is not None and scan.t_last is not None:
        s.info["duration"] = f"{scan.t_last - scan.t_first:.4g} s"
    if scan.rows and infos and not stepped:
        h = infos[0]
        turns = (scan.last[h.name] - scan.first[h.name]) / float(h.counts_per_rev)
        s.info["turns"] = f"{turns:.4g} (head {h.name})"
    for head in signal_cols:
        if head + ".cos" in scan.signals:
            c = np.concatenate(scan.signals[head + ".cos"])
            sn = np.concatenate(scan.signals[head + ".sin"])
            step = max(1, c.size // LISSAJOUS_POINTS)
            s.signals[head] = (c[::step], sn[::step])
    if stepped and where is not None and scan.rows:
        s.info["positioning read on"] = where.describe()
        positioning(s, scan, encoder, opts, where, _points_into)
    elif scan.rows and not stepped:
        s.notes.append(f"no {opts.standard_name} figures: a continuous run has no target "
                       "positions to approach (a step run of enc acquire has them)")
