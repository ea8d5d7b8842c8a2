"""Head arrangements for self-calibration: analyse one, or search for the best.

For heads at angles alpha_k (the first is the reference) and a band of harmonics
K this module gives |W(n)| of the method (each method of
:mod:`enctools.methods.selfcal_methods` says its own: esa: seed 000 eq. (15) with the
weights of eq. (14), C = 1; fourier: the least-squares |W|; average: |A(n)|), the blind and
ill-conditioned harmonics, the orders where radial motion x, y is blind (esa: those
where W(n) = 0), min |W| and where, the noise amplification, and the
sensitivity of the result to errors in the heads' mounting angles. The search
finds the arrangement of m heads that maximises min |W(n)| over n = 2..K (esa) or
1..K (fourier), as in Jiao et al. 2017 (seed 000 ref. [16]), on a grid refined
around the best candidates.

For 0/60/135/228 deg and esa, min |W| over 2..100 is 1.18 at n = 42; all four
angles are multiples of 3 deg, so W(n) = 0 at n = 120 (and at 119, 121, aliases of
n = 1 where W is always 0).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from itertools import chain, combinations
from math import comb

import numpy as np

from enctools.errors import SettingsError
from enctools.methods import selfcal_methods
from enctools.methods.heads import format_orders
from enctools.methods.selfcal import MIN_TRANSFER
from enctools.methods.selfcal_methods.base import SelfcalMethod
from enctools.units import DEG

_BLIND = 1e-9
#: the highest band a search scores (its candidates are scored in chunks of arrays of
#: the band: 2^20 orders would take gigabytes)
MAX_SEARCH_BAND = 4096
#: what a search scores by (see :func:`search`)
CRITERIA = ("w", "gain")
#: the most arrangements a search scores (grid and refinement together, its plan's
#: upper bound) unless ``max_candidates`` says otherwise
MAX_CANDIDATES = 2_000_000
#: the grid is coarsened (its step times 1.5) until it has at most this many slots
#: combinations: its candidates are held in memory (8 bytes an angle)
GRID_MOST = 1_500_000
#: refinement: the steps tried from each kept arrangement at one grid level, at most
REFINE_STEPS = 6
#: candidates scored in one call: at most this many angle-orders (heads x orders), so that
#: a call takes well under a second and a few tens of MB, and a signal lands between calls
SLICE_ELEMENTS = 1_000_000
#: enc design's name in the registry of methods
COMMAND = "design"


@dataclass(frozen=True)
class Settings:
    """What enc design does: its options, checked together (angles in deg).

    ``angles_deg``: the head angles to analyse, the reference first; ``search_heads``:
    search the best arrangement of this many heads instead (its result is analysed);
    ``method``: a method of :mod:`enctools.methods.selfcal_methods` that enc design
    offers (default: the registry's for the number of heads, esa for 4, else fourier);
    ``band``: the highest harmonic K; ``min_transfer``: the normalised |W(n)|
    (dimensionless) below which a harmonic is ill-conditioned; ``mounting_error_deg``:
    the RMS error of each head's mounting angle for the sensitivity; ``step_deg``,
    ``min_gap_deg``, ``criterion``: the search's grid step, least angle between
    neighbouring heads and score (see :func:`search`); ``strict``: refuse blind and
    ill-conditioned harmonics instead of warning. SettingsError naming the fields when
    they do not go together.
    """

    angles_deg: tuple[float, ...] | None = None
    method: str | None = None
    band: int = 100
    min_transfer: float = MIN_TRANSFER
    mounting_error_deg: float = 0.01
    search_heads: int | None = None
    step_deg: float = 1.0
    min_gap_deg: float = 10.0
    criterion: str = "w"
    strict: bool = False
    max_candidates: int = MAX_CANDIDATES

    def __post_init__(self) -> None:
        if self.angles_deg is None and self.search_heads is None:
            msg = "give `angles_deg` DEG,... to analyse, or `search_heads` M to search"
            raise SettingsError(msg)
        if self.criterion not in CRITERIA:
            msg = f"`criterion` must be {' or '.join(CRITERIA)}, not {self.criterion!r}"
            raise SettingsError(msg)
        if self.search_heads is not None:
            check_search(self.search_heads, self.search_method, self.min_gap_deg)
            if self.band > MAX_SEARCH_BAND:
                msg = (f"`band` must be at most {MAX_SEARCH_BAND} with `search_heads` (each "
                       f"arrangement scored is an array of the band), not {self.band}")
                raise SettingsError(msg)
            plan_search(self.search_heads, self.band, self.search_method, self.step_deg,
                        self.min_gap_deg).check(self.max_candidates)
        elif self.angles_deg is not None:
            arrangement_method(list(self.angles_deg), self.method)

    @property
    def search_method(self) -> str:
        """The method a search scores: ``method``, else the default for ``search_heads``
        heads (esa for 4, else fourier)."""
        return self.method or selfcal_methods.default(self.search_heads or 0, COMMAND).name


@dataclass
class Analysis:
    """Per harmonic n = 0..K of an arrangement (angles in deg)."""

    method: str
    angles_deg: tuple[float, ...]
    band: int
    transfer: np.ndarray          # |W(n)| as the method defines it
    normalised: np.ndarray        # |W(n)| / noise norm: 1 / noise gain
    gain: np.ndarray              # noise amplification (one head's noise -> F(n))
    sensitivity: np.ndarray       # RMS relative error of F(n) per rad of mounting error
    first: int                    # first harmonic the criterion looks at
    blind: list[int]
    ill: list[int]
    min_transfer: float
    #: orders 2..K where radial motion x, y is not determined (esa: W(n) = 0); None
    #: when the method does not separate radial motion at all (fourier, average)
    blind_radial: list[int] | None = None

    @property
    def worst(self) -> tuple[float, int]:
        """(min |W(n)| [dimensionless], its order n) over first..K, blind harmonics excluded."""
        n = np.arange(self.first, self.band + 1)
        w = self.transfer[n]
        ok = self.normalised[n] > _BLIND
        if not ok.any():
            return 0.0, int(n[0])
        i = int(np.argmin(np.where(ok, w, np.inf)))
        return float(w[i]), int(n[i])

    @property
    def max_gain(self) -> tuple[float, int]:
        """(largest finite noise gain [dimensionless], its order n) over first..K."""
        n = np.arange(self.first, self.band + 1)
        g = np.where(np.isfinite(self.gain[n]), self.gain[n], -np.inf)
        i = int(np.argmax(g))
        return float(g[i]), int(n[i])


def strategy(method: str) -> SelfcalMethod:
    """The method ``method`` as enc design offers it; SettingsError naming `method` and
    the methods offered when there is none."""
    found = selfcal_methods.find(method, COMMAND)
    if found is None:
        offered = selfcal_methods.names(COMMAND)
        msg = (f"`method` must be {', '.join(offered[:-1])} or {offered[-1]}, "
               f"not {method!r}")
        raise SettingsError(msg)
    return found


def arrangement_method(angles_deg: list[float], method: str | None) -> str:
    """The method analysing heads at ``angles_deg`` [deg]: ``method``, else the registry's
    default for their number (esa for 4 heads, else fourier); SettingsError naming the
    fields when the heads do not fit it."""
    al = np.asarray(angles_deg, dtype=np.float64) * DEG
    given = selfcal_methods.find(method, COMMAND)
    if al.size < (given.min_heads if given is not None else 2):
        raise SettingsError("give at least 2 head angles (`angles_deg` 0,60,135,228)")
    if len(set(np.round(np.mod(angles_deg, 360.0), 9))) != al.size:
        raise SettingsError(f"`angles_deg`: two heads at the same angle ({angles_deg})")
    chosen = (selfcal_methods.default(al.size, COMMAND) if method is None
              else strategy(method))
    chosen.check_angles(al, angles_deg)
    return chosen.name


def analyse(angles_deg: list[float], band: int, method: str | None = None,
            min_transfer: float = MIN_TRANSFER) -> Analysis:
    """|W(n)|, blind/ill harmonics, noise gain and mounting sensitivity of an arrangement.

    ``angles_deg``: head angles [deg], the reference first. ``method``: a method enc
    design offers (esa: 4 heads; fourier: any >= 2; average: the mean of the heads,
    |A(n)|); default the registry's for the number of heads (:func:`arrangement_method`).
    Sensitivity: first-order RMS relative error of F(n) when every head, the reference
    included, is off its nominal angle by an independent 1 rad, through the method's own
    solve (:func:`~enctools.methods.selfcal_uncertainty.relative_mounting_sensitivity`,
    the figure enc selfcal's budget takes; the curve's argument is the scale angle under
    the reference head, so the reference's own error moves every other head against it).
    """
    chosen = strategy(arrangement_method(angles_deg, method))
    al = np.asarray(angles_deg, dtype=np.float64) * DEG
    n = np.arange(band + 1)
    transfer, normalised = chosen.transfer(al[0], al[1:], n)
    sens = _sensitivity(chosen.name, al, band)
    transfer[0] = normalised[0] = 0.0
    with np.errstate(divide="ignore"):
        gain = np.where(normalised > _BLIND, 1.0 / np.maximum(normalised, 1e-300), np.inf)
    sens = np.where(normalised > _BLIND, sens, np.inf)
    blind = [int(k) for k in n[1:] if normalised[k] <= _BLIND]
    ill = [int(k) for k in n[1:] if _BLIND < normalised[k] < min_transfer] \
        if chosen.conditions else []
    radial = [k for k in blind if k >= 2] if chosen.separates_radial else None
    return Analysis(chosen.name, tuple(float(x) for x in angles_deg), band, transfer,
                    normalised, gain, sens, chosen.first, blind, ill, min_transfer, radial)


def _sensitivity(method: str, al: np.ndarray, band: int) -> np.ndarray:
    """:func:`analyse`'s sensitivity [1/rad] at orders 0..band, heads at ``al`` [rad];
    0 for a method enc selfcal does not solve by (average: the heads' mean, no figure)."""
    from enctools.methods.selfcal import Method, solution_parts
    from enctools.methods.selfcal_uncertainty import relative_mounting_sensitivity

    if selfcal_methods.find(method, "selfcal") is None:
        return np.zeros(band + 1)
    bound = Method(method, float(al[0]), al[1:], band, radius_m=1.0)
    return relative_mounting_sensitivity(lambda g: solution_parts(bound.solve(g)),
                                         bound.all_alphas, band)


@dataclass
class SearchResult:
    """The best arrangement found and its min |W| (or min normalised |W|) over the band."""

    angles_deg: tuple[float, ...]
    score: float
    criterion: str
    evaluated: int


@dataclass(frozen=True)
class SearchPlan:
    """What a search will score: ``grid`` arrangements on a grid of ``step_deg`` [deg]
    (after coarsening), then at most ``refine`` in the refinement; ``orders``: the
    orders each is scored over, ``heads`` with the reference."""

    heads: int
    orders: int
    step_deg: float
    grid: int
    refine: int

    @property
    def total(self) -> int:
        """The most arrangements the search scores."""
        return self.grid + self.refine

    def check(self, max_candidates: int) -> None:
        """SettingsError (one line) when the search may score more than
        ``max_candidates`` arrangements."""
        if not 1 <= max_candidates <= 10**12:
            msg = f"`max_candidates` must be 1..1000000000000, not {max_candidates}"
            raise SettingsError(msg)
        if self.total > max_candidates:
            msg = (f"the search would score up to {self.total} arrangements of {self.heads} "
                   f"heads ({self.grid} on a {self.step_deg:g} deg grid, at most "
                   f"{self.refine} refining), more than `max_candidates` {max_candidates}: "
                   "give a larger `max_candidates` (or, for a smaller grid, a coarser "
                   "`step_deg` or a larger `min_gap_deg`)")
            raise SettingsError(msg)


def plan_search(heads: int, band: int, method: str = "esa", step_deg: float = 1.0,
                min_gap_deg: float = 10.0, keep: int = 100) -> SearchPlan:
    """How many arrangements :func:`search` scores at most, counted before any is built."""
    check_search(heads, method, min_gap_deg)
    m = heads - 1
    step = _coarsened(m, float(step_deg))
    grid = _grid_count(m, step, min_gap_deg)
    refine, kept, h = 0, min(keep, grid), step
    while h > 0.01:
        h = max(h / 3.0, 0.01)
        refine += kept * REFINE_STEPS * 3**m
        kept = min(kept, max(4, keep // 4))
    first = strategy(method).first
    return SearchPlan(heads, max(band - first + 1, 1), step, grid, refine)


def estimate_seconds(plan: SearchPlan, method: str, criterion: str = "w") -> float:
    """About how long [s] the search of ``plan`` takes at most on this machine: a few
    arrangements are scored and timed."""
    chosen = strategy(method)
    n = np.arange(chosen.first, chosen.first + plan.orders, dtype=np.float64)
    rows = max(1, min(256, SLICE_ELEMENTS // (plan.heads * plan.orders)))
    trial = np.tile(np.linspace(30.0, 300.0, plan.heads - 1), (rows, 1)) * DEG
    t0 = time.perf_counter()
    chosen.scores(trial, n, criterion)
    return (time.perf_counter() - t0) / rows * plan.total


def search(heads: int, band: int, method: str = "esa", step_deg: float = 1.0,
           min_gap_deg: float = 10.0, criterion: str = "w", keep: int = 100,
           max_candidates: int = MAX_CANDIDATES,
           progress: Callable[[int, int], None] | None = None) -> SearchResult:
    """The arrangement of ``heads`` heads (reference at 0 deg) maximising min |W(n)|.

    Over the method's orders ``first``..band, by its own scores
    (:meth:`~enctools.methods.selfcal_methods.SelfcalMethod.scores`): esa over n =
    2..band (Jiao 2017), ``criterion`` "w" (|W| with C = 1, as the seed) or "gain"
    (|W| / noise norm); fourier: normalised |W| over 1..band. Every
    arrangement on a ``step_deg`` grid with neighbours at least ``min_gap_deg`` apart
    (head bodies need room) is scored (a coarser grid first when that is too many),
    then the ``keep`` best are refined locally down to 0.01 deg. SettingsError before
    anything is scored when that may be more than ``max_candidates`` arrangements
    (:func:`plan_search`); ``progress(done, most)`` is told the arrangements scored.
    """
    plan = plan_search(heads, band, method, step_deg, min_gap_deg, keep)
    plan.check(max_candidates)
    chosen = strategy(method)
    n = np.arange(chosen.first, band + 1, dtype=np.float64)
    m, step = heads - 1, plan.step_deg
    tick = progress or (lambda done, most: None)
    per = max(1, SLICE_ELEMENTS // (heads * n.size))
    cand = _grid(m, step, min_gap_deg)
    sc = np.empty(cand.shape[0])
    for i0 in range(0, cand.shape[0], per):
        sc[i0:i0 + per] = chosen.grid_scores(cand[i0:i0 + per], step, n, criterion)
        tick(min(i0 + per, cand.shape[0]), plan.total)
    evaluated = cand.shape[0]
    order = np.argsort(-sc)[:keep]
    best = [(float(sc[i]), cand[i]) for i in order]
    del cand, sc
    h = step
    while h > 0.01:
        h = max(h / 3.0, 0.01)
        offsets = np.array(np.meshgrid(*[[-h, 0.0, h]] * m)).reshape(m, -1).T
        refined = []
        for s0, a0 in best:
            pts = a0[None, :] + offsets
            for _ in range(REFINE_STEPS):
                pts_ok = pts[_feasible(pts, min_gap_deg)]
                if pts_ok.size == 0:
                    break
                s = np.concatenate([chosen.scores(pts_ok[i:i + per] * DEG, n, criterion)
                                    for i in range(0, pts_ok.shape[0], per)])
                evaluated += s.size
                tick(evaluated, plan.total)
                j = int(np.argmax(s))
                if s[j] <= s0 + 1e-12:
                    break
                s0, a0 = float(s[j]), pts_ok[j]
                pts = a0[None, :] + offsets
            refined.append((s0, a0))
        best = sorted(refined, key=lambda p: -p[0])[: max(4, keep // 4)]
    tick(evaluated, evaluated)
    s0, a0 = best[0]
    angles = (0.0, *(float(np.round(x, 2)) for x in a0))
    return SearchResult(angles, s0, criterion, evaluated)


def check_search(heads: int, method: str, min_gap_deg: float) -> None:
    """SettingsError naming the fields unless ``heads`` heads at least ``min_gap_deg``
    [deg] apart can be searched for ``method``."""
    strategy(method).check_search(heads)
    if heads < 2 or heads > 8:
        raise SettingsError(f"`search_heads`: 2 to 8 heads, not {heads}")
    if min_gap_deg * heads >= 360:
        raise SettingsError(f"`min_gap_deg` {min_gap_deg} deg leaves no room for {heads} heads")


def _coarsened(m: int, step: float) -> float:
    """The grid step [deg]: ``step`` times 1.5 until the slots give at most
    :data:`GRID_MOST` combinations of ``m``."""
    while comb(max(int(360.0 / step), m), m) > GRID_MOST:
        step *= 1.5
    return step


def _spacing(m: int, step: float, gap: float) -> tuple[int, int]:
    """(g, last): neighbours at least g slots apart, the last head at slot <= last, on
    the ``step`` grid (slot k at k step deg, 0 < k < round(360 / step)), as
    :func:`_feasible` has it with its tolerance."""
    g = max(1, int(np.ceil((gap - 1e-9) / step)))
    while g > 1 and (g - 1) * step >= gap - 1e-9:
        g -= 1
    while g * step < gap - 1e-9:
        g += 1
    last = round(360.0 / step) - 1
    while last > 0 and 360.0 - last * step < gap - 1e-9:
        last -= 1
    return g, last


def _grid_count(m: int, step: float, gap: float) -> int:
    """How many rows :func:`_grid` has, counted without building them."""
    g, last = _spacing(m, step, gap)
    free = last - (m - 1) * (g - 1) - g + 1
    return comb(free, m) if free >= m else 0


def _grid(m: int, step: float, gap: float) -> np.ndarray:
    """All increasing m-tuples of angles on the step grid in (0, 360) at least ``gap`` apart
    (and from 0 and 360), in lexicographic order: tuples j of slots g..last - (m-1)(g-1),
    spread to k_i = j_i + i (g - 1)."""
    g, last = _spacing(m, step, gap)
    count = _grid_count(m, step, gap)
    if count == 0:
        return np.zeros((0, m))
    top = last - (m - 1) * (g - 1)
    j = np.fromiter(chain.from_iterable(combinations(range(g, top + 1), m)), dtype=np.int64,
                    count=count * m).reshape(count, m)
    return (j + np.arange(m) * (g - 1)).astype(np.float64) * step


def _feasible(rows: np.ndarray, gap: float) -> np.ndarray:
    full = np.concatenate([np.zeros((rows.shape[0], 1)), rows, np.full((rows.shape[0], 1), 360.0)],
                          axis=1)
    d = np.diff(full, axis=1)
    return np.all(d >= gap - 1e-9, axis=1)


def report(a: Analysis, mounting_error_deg: float) -> str:
    """A short text report of an analysis; ``mounting_error_deg`` is the RMS error [deg]
    of each head's mounting angle, scaled by the sensitivity [1/rad] to an error of F(n)."""
    w, nw = a.worst
    g, ng = a.max_gain
    lines = [f"arrangement: {'/'.join(f'{x:g}' for x in a.angles_deg)} deg, method {a.method}, "
             f"harmonics {a.first}..{a.band}"]
    chosen = strategy(a.method)
    label = chosen.figure
    lines.append(f"min {label} over {a.first}..{a.band}: {w:.4g} at n = {nw}"
                 + (" (blind harmonics excluded)" if a.blind else ""))
    lines.append(f"blind harmonics: {format_orders(a.blind) or 'none'}")
    if a.blind_radial is None:
        lines.append(f"radial motion x, y: not separated ({a.method})")
    else:
        lines.append(f"radial motion x, y blind at: {format_orders(a.blind_radial) or 'none'}")
    if chosen.conditions:
        lines.append(f"ill-conditioned (noise gain > {1 / a.min_transfer:g}): "
                     f"{format_orders(a.ill) or 'none'}")
        gains = a.gain[a.first:]
        gains = gains[np.isfinite(gains)]
        lines.append(f"noise gain: max {g:.3g} at n = {ng}; "
                     f"RMS over the band {np.sqrt(np.mean(np.square(gains))):.3g}")
        sens = a.sensitivity[a.first:] * (mounting_error_deg * DEG)
        fin = np.isfinite(sens)
        k = int(np.argmax(np.where(fin, sens, -1))) + a.first
        lines.append(f"mounting error {mounting_error_deg:g} deg (RMS per head): relative error "
                     f"of F(n) up to {np.nanmax(np.where(fin, sens, np.nan)):.3g} (n = {k}), "
                     f"{sens[fin].mean():.3g} on average")
    return "\n".join(lines)


@dataclass
class Design:
    """What enc design found: the search's best arrangement (if searched) and its analysis."""

    search: SearchResult | None
    analysis: Analysis


def run(settings: Settings, progress: Callable[[int, int], None] | None = None) -> Design:
    """Search (with ``settings.search_heads``; ``progress(done, most)`` told the
    arrangements scored) and analyse an arrangement of heads."""
    found = None
    angles = list(settings.angles_deg or ())
    if settings.search_heads is not None:
        found = search(settings.search_heads, settings.band, settings.search_method,
                       settings.step_deg, settings.min_gap_deg, settings.criterion,
                       max_candidates=settings.max_candidates, progress=progress)
        angles = list(found.angles_deg)
    return Design(found, analyse(angles, settings.band, settings.method, settings.min_transfer))


def refuse_or_warn(a: Analysis, strict: bool) -> None:
    """Name the blind and ill-conditioned harmonics: SettingsError when ``strict``, else a
    warning."""
    problems = []
    if a.blind:
        problems.append(f"blind harmonics {format_orders(a.blind)}")
    if a.blind_radial:
        problems.append(f"radial motion x, y blind at {format_orders(a.blind_radial)}")
    if a.ill:
        problems.append(f"ill-conditioned harmonics {format_orders(a.ill)}")
    if not problems:
        return
    where = "/".join(f"{x:g}" for x in a.angles_deg)
    msg = f"{where} deg up to n = {a.band}: {'; '.join(problems)}"
    if strict:
        raise SettingsError(msg + " (`strict`)")
    logging.getLogger("enctools").warning("%s", msg)
