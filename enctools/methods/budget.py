"""An uncertainty budget per the GUM (JCGM 100:2008): contributions combined and expanded.

Each input quantity X_i of the measurement model contributes a standard uncertainty
u_i = |c_i| * value_i / divisor_i to the measured deviation [arcsec]: ``value`` is
what was declared or measured, in its own unit (a half-width, an expanded
uncertainty, a standard deviation), the divisor turns it into a standard uncertainty
(sqrt 3 for a rectangular half-width, k for an expanded one, 1 for a standard
deviation) and c_i is the sensitivity coefficient [arcsec per unit of value].

The combined standard uncertainty is u_c = sqrt(sum u_i^2) (uncorrelated inputs,
GUM 5.1.2), its effective degrees of freedom by Welch-Satterthwaite (GUM G.4.1)

    nu_eff = u_c^4 / sum(u_i^4 / nu_i)

and the expanded uncertainty U = k u_c with k the two-sided Student t quantile at
the coverage probability and nu_eff (GUM G.3.2; 1.96 at 95 % when nu_eff is
infinite, as for Type B inputs declared exactly).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

from enctools.data.uncertainty import DIVISORS as DIVISORS  # the GUM's divisors, here too
from enctools.data.uncertainty import UNITS, Declaration
from enctools.errors import DataError
from enctools.methods.polygon_terms import POLYGON_TERMS, SENSITIVITY
from enctools.methods.student import t_quantile


@dataclass(frozen=True)
class Contribution:
    """One input quantity of the budget (one row of the table).

    ``value`` is in ``unit``; ``sensitivity`` in arcsec per ``unit``; ``dof`` the
    degrees of freedom of u_i (``math.inf`` for a Type B value taken as exact).
    """

    name: str
    source: str
    kind: str
    distribution: str
    value: float
    unit: str
    divisor: float
    sensitivity: float
    dof: float = math.inf
    quantity: str = ""      # the declared quantity it is of (enc-rig(5)); "" for none

    @property
    def u_arcsec(self) -> float:
        """Standard uncertainty contributed to the deviation [arcsec]."""
        return abs(self.sensitivity) * self.value / self.divisor


@dataclass(frozen=True)
class Budget:
    """A combined budget: its rows, u_c and U [arcsec], nu_eff, k and the coverage."""

    contributions: tuple[Contribution, ...]
    u_c: float
    nu_eff: float
    k: float
    U: float
    coverage: float = 0.95


def coverage_factor(nu_eff: float, coverage: float = 0.95) -> float:
    """Two-sided Student t quantile k at ``coverage`` for ``nu_eff`` degrees of freedom."""
    if not 0.0 < coverage < 1.0:
        msg = f"coverage probability {coverage} is not between 0 and 1"
        raise DataError(msg)
    # scipy.stats's and scipy.special's quantiles, without importing either (0.5 s and
    # 0.14-0.35 s of every command's start): enctools.methods.student
    return t_quantile(nu_eff, 0.5 + coverage / 2.0)


def effective_dof(u: Iterable[float], dof: Iterable[float]) -> float:
    """Welch-Satterthwaite degrees of freedom of the sum of ``u`` [any one unit]."""
    pairs = list(zip(u, dof, strict=True))
    total = math.fsum(ui * ui for ui, _ in pairs)
    denominator = math.fsum(ui ** 4 / nu for ui, nu in pairs if not math.isinf(nu) and ui > 0)
    if denominator == 0.0:
        return math.inf
    return total * total / denominator


@dataclass(frozen=True)
class Coverage:
    """The coverage of an expanded uncertainty U = k u: ``dof`` the degrees of freedom
    of u (``math.inf`` when it rests on no estimate), ``k`` the two-sided Student t
    quantile at ``probability`` and ``dof``."""

    dof: float
    k: float
    probability: float = 0.95

    def field_meta(self) -> dict[str, str]:
        """The field metadata of an uncertainty column that states it (enc-streams(5))."""
        return {"dof": "inf" if math.isinf(self.dof) else f"{self.dof:.6g}",
                "k": f"{self.k:.6g}", "coverage": f"{self.probability:g}"}


def repeats_dof(repeats: int, parts: int = 1) -> float:
    """Degrees of freedom of a standard deviation of the mean of ``repeats`` repeats
    (revolutions, runs), its variance pooled over ``parts`` independent components of
    the same variance (2: the real and imaginary part of a harmonic); 0 for one."""
    return float(parts * max(repeats - 1, 0))


def type_a_coverage(u_a: np.ndarray | float, dof: float, u_b: np.ndarray | float = 0.0,
                    probability: float = 0.95) -> Coverage | None:
    """k and the effective degrees of freedom of u = sqrt(u_a^2 + u_b^2) along a column
    (a curve's points, a spectrum's harmonics; any one unit).

    ``u_a``: Type A standard uncertainties on ``dof`` degrees of freedom each; ``u_b``:
    the Type B part, taken as exact. Welch-Satterthwaite (GUM G.4.1) on the column's
    mean variances, not point by point: a point's own u_a is itself the estimate whose
    scatter Student's t allows for, and a point where it came out small must not get a
    small k as well (that understates U on a few repeats). None when there is no
    estimate (``dof`` 0: a single repeat; u_a not finite).
    """
    var_a = float(np.mean(np.square(u_a)))
    var_b = float(np.mean(np.square(u_b)))
    if not (dof > 0.0 and math.isfinite(var_a) and math.isfinite(var_b)):
        return None
    if var_a == 0.0 or math.isinf(dof):
        nu = math.inf
    else:
        nu = (var_a + var_b) ** 2 / (var_a ** 2 / dof)
    return Coverage(nu, coverage_factor(nu, probability), probability)


def combine(contributions: Iterable[Contribution], coverage: float = 0.95) -> Budget:
    """The budget of uncorrelated ``contributions``: u_c, nu_eff, k and U [arcsec]."""
    rows = tuple(contributions)
    for row in rows:
        if not (math.isfinite(row.value) and row.value >= 0.0 and row.divisor > 0.0
                and math.isfinite(row.sensitivity) and row.dof > 0.0):
            msg = (f"uncertainty contribution {row.name!r}: value {row.value:g} {row.unit}, "
                   f"divisor {row.divisor:g}, sensitivity {row.sensitivity:g} and degrees of "
                   f"freedom {row.dof:g} must be finite, value >= 0, divisor and dof > 0")
            raise DataError(msg)
    u = [row.u_arcsec for row in rows]
    u_c = math.sqrt(math.fsum(ui * ui for ui in u))
    nu_eff = effective_dof(u, (row.dof for row in rows))
    k = coverage_factor(nu_eff, coverage)
    return Budget(rows, u_c, nu_eff, k, k * u_c, coverage)


# ------------------------------------------------- the model of a polygon step run
#
# Seed 001 sec. 5.3: the polygon turns with the encoder; at position j the table stops
# where the encoder reads about j * 360/faces, the N measuring heads are read n times
# and the autocollimator looks at face j. The deviation of point j is relative to the
# run's first position (the datum, j = 0):
#
#     D_j = (E_j - E_0) - j p - (a_j - a_0)(1 + kappa) - (delta_j - delta_0)
#
# E the mean of the N heads' quantised readings, a the autocollimator's indication,
# kappa its scale error, delta the face angle deviations of the polygon, p its pitch.


@dataclass(frozen=True)
class PolygonRun:
    """What a polygon step run tells its budget (from the points' metadata).

    s_arcsec : pooled standard deviation of one reading's deviation (head mean minus
        autocollimator) about its position's mean [arcsec], on ``dof`` degrees of freedom.
    readings : readings per position (the fewest of the run).
    span_arcsec : the largest |a_j - a_0| of the run's autocollimator indications [arcsec].
    lsb_arcsec : one count of the encoder [arcsec]; heads : the N heads averaged.
    head_s_arcsec : pooled standard deviation of one head's reading about its position's
        mean [arcsec] (the noise that dithers the quantisation).
    interval_s : time between a stop's readings [s]; runs, directions : of the run
        (None: not stated); closing_arcsec : the closing reading's deviation on the first
        face again, less the first's [arcsec] (None: no closing reading).
    """

    s_arcsec: float
    dof: float
    readings: int
    span_arcsec: float
    lsb_arcsec: float
    heads: int
    head_s_arcsec: float
    interval_s: float | None = None
    runs: int | None = None
    directions: int | None = None
    closing_arcsec: float | None = None

    def readings_span(self) -> str:
        """What the readings' Type A spans: "5 readings 1 ms apart at each stop of one run"."""
        apart = "" if self.interval_s is None else f" {_duration(self.interval_s)} apart"
        return f"{self.readings} readings{apart} at each stop of one run"

    def approaches_span(self) -> str:
        """What a Type A over approaches spans: "3 runs x 2 directions" (or "the approaches")."""
        if self.runs is None:
            return "the approaches"
        runs = f"{self.runs} run{'s' if self.runs != 1 else ''}"
        both = " x 2 directions" if self.directions == 2 else ""
        return f"{runs}{both}"


def _duration(seconds: float) -> str:
    """A time in the unit that reads best: "1 ms", "2 s", "250 us"."""
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6)):
        if seconds >= scale * (1.0 - 1e-9):
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds:.3g} s"


def repeatability(run: PolygonRun) -> Contribution:
    """Type A: the scatter of the n readings at a position. u(D_j) = s sqrt(1/n + 1/n):
    the point is the difference of two means of n readings (position j and the datum),
    as one row (one estimate s on its dof): value s, divisor sqrt(n), c = sqrt(2)."""
    return Contribution(f"repeatability: {run.readings_span()}",
                        "this run", "A", "normal", run.s_arcsec, "arcsec",
                        math.sqrt(run.readings), math.sqrt(2.0), run.dof)


def closing_drift(run: PolygonRun) -> Contribution | None:
    """The drift over the run from its closing reading, back on the first face at 360 deg:
    its deviation less the first's, d [arcsec], bounds the zero's drift between the datum
    and any point (a drift that does not turn back): rectangular of half-width |d|, c = 1
    (GUM 4.3.7). It holds the two readings' noise too: a bound. None without one."""
    d = run.closing_arcsec
    if d is None:
        return None
    return Contribution(f"drift over the run: closing reading at 360 deg, {d:+.3g} arcsec "
                        "from the first", "this run", "B", "rectangular", abs(d), "arcsec",
                        math.sqrt(3.0), 1.0)


def polygon_faces(face: Declaration) -> list[Contribution]:
    """The polygon's face angle deviations delta_j and delta_0: dD/d(delta_j) = -1,
    dD/d(delta_0) = +1, each face's u as ``face`` declares it (a polygon certificate's
    uncertainty of a certified face, or the face errors themselves when not applied).
    On finite dof (a Type A, as enc closure's faces: every face's u from one s) the two
    are one row, c = sqrt 2, so that Welch-Satterthwaite counts the one estimate once."""
    if math.isfinite(face.dof):
        row = _declared(face, "polygon face angles at the point and the datum", 1.0)
        return [replace(row, sensitivity=row.sensitivity * math.sqrt(2.0))]
    return [_declared(face, "polygon face angle at the point", -1.0),
            _declared(face, "polygon face angle at the datum", 1.0)]


def autocollimator_scale(scale: Declaration, span_arcsec: float) -> Contribution:
    """The autocollimator's scale error kappa: dD/d(kappa) = -(a_j - a_0) [arcsec], its
    largest magnitude over the run (``span_arcsec``), so that the row holds every point."""
    return _declared(scale, "autocollimator scale error", -span_arcsec)


def dithered_quantisation(lsb_arcsec: float, noise_arcsec: float, terms: int = 4000) -> float:
    """Standard uncertainty [arcsec] of the mean of many readings of one head quantised
    to ``lsb_arcsec`` (q) with Gaussian noise of ``noise_arcsec`` (sigma) before the
    quantiser: the mean's bias is b(x) = sum_m (-1)^(m+1) (q / (pi m))
    exp(-2 pi^2 m^2 sigma^2 / q^2) sin(2 pi m x / q) for a true value x; over an unknown
    x (uniform within a count) its rms is

        u = (q / pi) sqrt( sum_m exp(-4 pi^2 m^2 sigma^2 / q^2) / (2 m^2) )

    q / sqrt(12) without noise (the rectangular half-width q/2: sum 1/m^2 = pi^2/6),
    vanishing when sigma is a fair part of q (the readings' scatter then holds it)."""
    q = lsb_arcsec
    if q <= 0.0:
        return 0.0
    if noise_arcsec == 0.0:
        return q / math.sqrt(12.0)
    m = np.arange(1, terms + 1, dtype=float)
    total = float(np.sum(np.exp(-4.0 * math.pi ** 2 * m ** 2 * noise_arcsec ** 2 / q ** 2)
                         / (2.0 * m ** 2)))
    return q / math.pi * math.sqrt(total)


def quantisation(run: PolygonRun) -> Contribution:
    """The quantisation of the N heads at the point and the datum: dD/dQ_k = +-1/N for
    each of 2N head readings, so u = u_q sqrt(2N) / N with u_q
    (:func:`dithered_quantisation`) at the heads' noise, sigma^2 = s_head^2 - q^2/12
    (the scatter of a head's readings holds the quantiser's own q^2/12, Sheppard)."""
    q = run.lsb_arcsec
    sigma = math.sqrt(max(run.head_s_arcsec ** 2 - q * q / 12.0, 0.0))
    u_q = dithered_quantisation(q, sigma)
    return Contribution(f"quantisation of {run.heads} head(s), 1 count = {q:.4g} arcsec",
                        "encoder resolution", "B", "normal", u_q, "arcsec", 1.0,
                        math.sqrt(2.0 * run.heads) / run.heads)


def polygon_run_budget(declared: dict[str, Declaration], run: PolygonRun,
                       face: Declaration | None = None, coverage: float = 0.95) -> Budget:
    """The budget of a point of a polygon step run (any but the datum, whose D is 0).

    ``declared``: the rig's declarations (polygon, autocollimator enter this model);
    ``face``: the polygon's face uncertainty when it comes from elsewhere (a polygon
    certificate), else ``declared["polygon"]``.
    """
    rows = [repeatability(run), quantisation(run)]
    drift = closing_drift(run)
    if drift is not None:
        rows.append(drift)
    face = face if face is not None else declared.get("polygon")
    if face is not None:
        rows += polygon_faces(face)
    if "autocollimator" in declared:
        rows.append(autocollimator_scale(declared["autocollimator"], run.span_arcsec))
    return combine(rows + polygon_terms(declared), coverage)


def polygon_terms(declared: dict[str, Declaration]) -> list[Contribution]:
    """The rows of the method's terms the rig declares (:mod:`enctools.methods.
    polygon_terms`: resolution, noise, flatness, pyramidal, alignment, drift)."""
    return [_declared(declared[q], name, SENSITIVITY[kind])
            for q, (name, kind) in POLYGON_TERMS.items() if q in declared]


#: the declared quantities the polygon step run's model uses
POLYGON_RUN_QUANTITIES = ("polygon", "autocollimator", *POLYGON_TERMS)


# ------------------------------------------ the model of a comparison (seed 000 eq. 10)
#
# A device against a reference encoder on one spindle, averaged over R revolutions:
# D(theta) = E_dev(theta) - E_ref(theta), read E_dev = D + E_ref, dD/dE_ref = -1. What is
# known of E_ref depends on what was done with the reference: with its calibrated curve
# applied (enc compare --reference-curve) only the curve's own error remains, which the
# calibration's certificate states (``reference_encoder``); used as it reads, its whole
# error remains, which only a bound states (``reference_encoder_uncorrected``: its
# accuracy, a half-width as a maker gives a grade). The one never stands in for the
# other: the calibration's U of an uncorrected reference claims too little.

#: the row of each declared quantity of a reference encoder
REFERENCE_ROWS = {
    "reference_encoder": "calibrated deviation of the reference encoder",
    "reference_encoder_uncorrected": "accuracy of the reference encoder, used without its "
                                     "calibrated curve",
}


def reference_quantity(corrected: bool) -> str:
    """The declared quantity of a reference encoder's row: the calibration's U when its
    calibrated curve was applied (``corrected``), else its uncorrected accuracy."""
    return "reference_encoder" if corrected else "reference_encoder_uncorrected"


def reference_row(reference: Declaration) -> Contribution:
    """The reference encoder's row (c = -1) of its declaration, named by what it is."""
    return _declared(reference, REFERENCE_ROWS[reference.quantity], -1.0)


def comparison_budget(u_a_arcsec: float, dof: float, reference: Declaration,
                      coverage: float = 0.95) -> Budget:
    """The budget of a point of a comparison against a reference encoder: the Type A
    u of the mean over the revolutions [arcsec] on ``dof`` degrees of freedom, and the
    reference encoder's row (``reference``: quantity ``reference_encoder`` with its
    calibrated curve applied, ``reference_encoder_uncorrected`` without;
    :func:`reference_quantity`)."""
    rows = [Contribution("repeatability of the mean over the revolutions", "this run", "A",
                         "normal", u_a_arcsec, "arcsec", 1.0, 1.0, dof),
            reference_row(reference)]
    return combine(rows, coverage)


#: the declared quantities the comparison's model uses (one of them, as the curve was used)
COMPARISON_QUANTITIES = ("reference_encoder", "reference_encoder_uncorrected")


# ------------------------------------------- the model of a step run (ISO 230-2)
#
# A step run approaches each target T_i several times (runs, directions); at each stop the
# N heads of the reference instrument, an encoder the axis does not position on, are read:
#
#     x_ij = E_ij - T_i = P_ij + e_ref(T_i) + a(T_i) + (1/N) sum_k r_k(T_i)
#
# P the axis' true positioning deviation (the measurand), e_ref the reference encoder's
# error at the target (its whole graduation and interpolation error when read as it reads,
# as enc report reads a step run; what its calibrated curve leaves when applied), a its
# alignment to the axis, r_k the rounding of head k to whole counts (the same at every
# approach of a target when the noise is below a count: Type B).
# A uniform temperature leaves the angles of a circular scale and of the axis unchanged:
# no temperature term enters an angle read on an angle scale (the angular rule).


def resolution(lsb_arcsec: float, heads: int, what: str) -> Contribution:
    """The rounding of ``heads`` heads to whole counts of ``lsb_arcsec``, averaged: each a
    rectangular half-width q/2 (divisor sqrt 3), c = 1/sqrt(N) for their mean, so
    u = q / sqrt(12 N)."""
    return Contribution(f"resolution of {what}: {heads} head(s), 1 count = "
                        f"{lsb_arcsec:.4g} arcsec", "encoder resolution", "B", "rectangular",
                        lsb_arcsec / 2.0, "arcsec", math.sqrt(3.0), 1.0 / math.sqrt(heads))


def type_a_row(u_a_arcsec: float, dof: float, what: str) -> Contribution:
    """The Type A row of a result that is a mean over repeats: u [arcsec] on ``dof``."""
    return Contribution(what, "this run", "A", "normal", u_a_arcsec, "arcsec", 1.0, 1.0, dof)


def step_run_budget(u_a_arcsec: float, dof: float, resolution_row: Contribution,
                    declared: dict[str, Declaration], reference: bool = True,
                    coverage: float = 0.95, corrected: bool = False) -> Budget:
    """The budget of a target of a step run read on an encoder (``x_ij`` above): the
    Type A u of the target's mean over its approaches [arcsec] on ``dof``, the rounding
    of the heads (``resolution_row``, :func:`resolution`) and, when the encoder read is a
    reference instrument (``reference``: not the axis' feedback, whose reading measures
    the servo loop), its error (e_ref: ``reference_encoder_uncorrected`` as read,
    ``reference_encoder`` with its calibrated curve applied, ``corrected``;
    :func:`reference_quantity`) and alignment (``alignment``) as ``declared``, c = -1
    each."""
    rows = [type_a_row(u_a_arcsec, dof, "repeatability of the approaches"), resolution_row]
    quantity = reference_quantity(corrected)
    if reference and quantity in declared:
        rows.append(reference_row(declared[quantity]))
    if reference and "alignment" in declared:
        rows.append(_declared(declared["alignment"],
                              "alignment of the reference instrument to the axis", -1.0))
    return combine(rows, coverage)


def polygon_runs_budget(declared: dict[str, Declaration], run: PolygonRun, u_a_arcsec: float,
                        dof: float, face: Declaration | None = None,
                        coverage: float = 0.95) -> Budget:
    """The budget of a target of a polygon step run of several runs or directions
    (ISO 230-2 on the polygon): the model D_j of :func:`polygon_run_budget` with the Type A
    u of the target's mean over its approaches [arcsec] on ``dof`` in place of the
    readings' repeatability, then the heads' quantisation, the polygon's faces, the
    autocollimator's scale and the alignment (c = -1) as ``declared``."""
    rows = [type_a_row(u_a_arcsec, dof, f"repeatability over {run.approaches_span()}"),
            quantisation(run)]
    face = face if face is not None else declared.get("polygon")
    if face is not None:
        rows += polygon_faces(face)
    if "autocollimator" in declared:
        rows.append(autocollimator_scale(declared["autocollimator"], run.span_arcsec))
    return combine(rows + polygon_terms(declared), coverage)


#: the declared quantities a step run's models use (read on an encoder; on a polygon)
STEP_RUN_QUANTITIES = ("reference_encoder", "reference_encoder_uncorrected", "alignment")
POLYGON_RUNS_QUANTITIES = ("polygon", "autocollimator", *POLYGON_TERMS)


# ------------------------------------------- the model of a self-calibration (seed 000)
#
# The graduation error at a point is the mean over R revolutions of the method's solution
# (enc-selfcal(1)): G = mean_r G_r + b + e_blind, with the revolutions' scatter (Type A,
# R - 1 degrees of freedom), b the method's own bound (its last iteration's change, the
# second-order term of the coordinate, the rounding when every revolution repeats it) and
# e_blind the content of the harmonics the head arrangement cannot see (W(n) = 0 in the
# band: set to 0 by the method). A uniform temperature leaves the scale's angles unchanged.


def selfcal_budget(u_a_arcsec: float, revolutions: int, bound_arcsec: float,
                   blind: tuple[tuple[int, ...], float] | None = None,
                   declared: dict[str, Declaration] | None = None,
                   mounting_arcsec_per_rad: float | None = None,
                   coverage: float = 0.95) -> Budget:
    """The budget of a point of a self-calibrated graduation error: the Type A u of the
    mean over ``revolutions`` [arcsec] on R - 1 degrees of freedom, the method's bound
    [arcsec] (normal, taken as exact), for ``blind`` = (orders, amplitude [arcsec]) a
    sinusoid of that root-sum-square amplitude and unknown phase (u-shaped, divisor
    sqrt 2) for the harmonics the arrangement cannot see, and of the ``declared``
    quantities the heads' mounting (:func:`head_mounting`, with the run's sensitivity
    ``mounting_arcsec_per_rad``) and the temperature (c = 0)."""
    rows = [type_a_row(u_a_arcsec, float(revolutions - 1),
                       f"repeatability over the {revolutions} revolutions"),
            Contribution("the method's own bound (last iteration, second order, rounding)",
                         "the self-calibration", "B", "normal", bound_arcsec, "arcsec", 1.0,
                         1.0)]
    if blind is not None:
        orders, amplitude = blind
        rows.append(Contribution(
            f"harmonics the heads cannot see (n = {', '.join(map(str, orders))})",
            "transfer function W(n) = 0; amplitude from the neighbouring orders", "B",
            "u-shaped", amplitude, "arcsec", math.sqrt(2.0), 1.0))
    declared = declared or {}
    if "head_mounting" in declared and mounting_arcsec_per_rad is not None:
        rows.append(head_mounting(declared["head_mounting"], mounting_arcsec_per_rad))
    if "temperature" in declared:
        rows.append(_declared(declared["temperature"], "temperature (uniform): a circular "
                              "scale's angles do not change", 0.0))
    return combine(rows, coverage)


def head_mounting(d: Declaration, arcsec_per_rad: float) -> Contribution:
    """The heads' mounting angles, each off its nominal angle by an independent error
    as ``d`` declares (quantity ``head_mounting``): c = the rms change of the curve
    [arcsec] per rad of each head's error, root-sum-square over the heads
    (:func:`enctools.methods.selfcal_uncertainty.mounting_sensitivity`, worked out by
    enc selfcal through the method's own transfer function)."""
    return _declared(d, "mounting angles of the heads (each, independent)",
                     arcsec_per_rad / UNITS["angle"]["rad"])


#: the declared quantities the self-calibration's model uses
SELFCAL_QUANTITIES = ("head_mounting", "temperature")


def _declared(d: Declaration, name: str, c_base: float) -> Contribution:
    """A Contribution of a declaration: its value and unit as declared, c [arcsec per
    declared unit] from ``c_base`` [arcsec per base unit of the dimension]."""
    c = c_base * UNITS[d.dimension][d.unit]
    return Contribution(name, d.source, d.kind, d.distribution, d.value, d.unit, d.divisor, c,
                        d.dof, d.quantity)


# ------------------------------------------- the model of a probe-based angle (seed 000)
#
# An angle from a displacement probe on an arm (seed 000 sec. 4): psi = h / L, with the
# arm at temperature 20 degC + dT: L = L20 (1 + alpha dT), the probe's reading h (1 + k_p).


def probe_arm_sensitivity(psi_arcsec: float, arm_m: float) -> float:
    """dpsi/dL = -h / L^2 = -psi / L [arcsec per m]."""
    return -psi_arcsec / arm_m


def probe_scale_sensitivity(psi_arcsec: float) -> float:
    """dpsi/dk_p of psi = h (1 + k_p) / L at k_p = 0: psi [arcsec per unit scale error]."""
    return psi_arcsec


def temperature_sensitivity(psi_arcsec: float, expansion_per_k: float) -> float:
    """dpsi/d(dT) of psi = h / (L20 (1 + alpha dT)) at dT = 0: -psi alpha [arcsec per K]."""
    return -psi_arcsec * expansion_per_k


def probe_interpolation_budget(u_a_arcsec: float, dof: float, psi_arcsec: float,
                               arm_m: float, declared: dict[str, Declaration],
                               coverage: float = 0.95) -> Budget:
    """The budget of an interpolation error measured against capacitive probes (seed 000
    sec. 4: psi = h / L): the Type A u of the curve [arcsec] on ``dof`` degrees of
    freedom, and the probe's calibration, the arm's length and its temperature as
    ``declared`` (quantities probe, probe_arm, temperature). The reference's trend over
    the sweep is fitted out with the device's, so a scale error of psi reaches the
    result through the part of psi that remains: the interpolation error itself, at
    most ``psi_arcsec`` (its largest magnitude)."""
    rows = [Contribution("repeatability of the interpolation error", "this run", "A",
                         "normal", u_a_arcsec, "arcsec", 1.0, 1.0, dof)]
    if "probe" in declared:
        rows.append(_declared(declared["probe"], "probe calibration (scale) error",
                              probe_scale_sensitivity(psi_arcsec)))
    if "probe_arm" in declared:
        rows.append(_declared(declared["probe_arm"], "probe arm length L",
                              probe_arm_sensitivity(psi_arcsec, arm_m)))
    temperature = declared.get("temperature")
    if temperature is not None:
        rows.append(_declared(temperature, "temperature of the arm (from 20 degC)",
                              temperature_sensitivity(psi_arcsec,
                                                      temperature.expansion_per_k)))
    return combine(rows, coverage)


#: the declared quantities the probe-based interpolation error's model uses
PROBE_QUANTITIES = ("probe", "probe_arm", "temperature")
