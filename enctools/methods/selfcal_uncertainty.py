"""The uncertainty of a self-calibration: Type A from its revolutions, the method's bound.

A self-calibration averages R revolutions (:mod:`enctools.methods.selfcal`). Per
harmonic and per point of each curve its standard uncertainty is

    u = sqrt(s_mean^2 + b^2)

with s_mean the standard deviation of the mean over the revolutions (Type A; per
harmonic pooled over the real and imaginary part: 2 (R - 1) degrees of freedom; per
point of a curve R - 1) and b a bound on what the revolutions do not show
(:func:`systematic`): the method's own last change and second-order term and, when the
run samples the same angles every revolution (:class:`SampleRepeats`), the heads'
rounding to whole counts, which is then the same in every revolution. When the angles
move from revolution to revolution (a drive's speed varies by far more than a count)
the rounding differs between them and is in s_mean already: counting it again would
state a U that covers more than it says.

U = k u with k from Student's t at the effective degrees of freedom
(:func:`enctools.methods.budget.type_a_coverage`): on 2 revolutions a curve point's
k is 12.7, a harmonic's 4.30; on 20, 2.09 and 2.02.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from enctools import kernel
from enctools.methods.budget import Coverage, repeats_dof, type_a_coverage

if TYPE_CHECKING:
    from enctools.methods.coordinate import Refined
    from enctools.methods.revolutions import Revolution, RunningMean

#: a run repeats its sampling when more than this share of a revolution's coordinate
#: positions (whole quanta of the coordinate) were sampled in the first revolution too
REPEATED_SHARE = 0.5


class SampleRepeats:
    """Whether a run samples the same angles every revolution.

    ``quantum``: the angle coordinate's step [rad] (one count of its heads over their
    number). Each revolution's coordinate samples, in whole quanta from the revolution's
    start, are looked up among the first revolution's; :attr:`repeated` is True when
    on average more than :data:`REPEATED_SHARE` of them are found. A drive whose speed
    varies by more than a count between revolutions shares almost none; sampling
    triggered by the encoder's position shares nearly all.
    """

    def __init__(self, quantum: float) -> None:
        self.quantum = float(quantum)
        self._first: np.ndarray | None = None
        self._shares: list[float] = []

    def _positions(self, rev: Revolution) -> np.ndarray:
        return np.rint((rev.u[:-1] - rev.start) / self.quantum).astype(np.int64)

    def add(self, rev: Revolution) -> None:
        """Take in one revolution (its coordinate ``u`` [rad] from ``start``)."""
        if self.quantum <= 0.0:
            return
        if self._first is None:
            # np.unique's values, without its import of numpy.ma (numpy 2.4: 10-20 ms of a
            # command's start)
            first = np.sort(self._positions(rev))
            keep = np.ones(first.size, dtype=bool)
            keep[1:] = first[1:] != first[:-1]
            self._first = first[keep]
            return
        self._shares.append(self._share(rev, self._first))

    def _share(self, rev: Revolution, first: np.ndarray) -> float:
        """The share of the revolution's positions among the first one's: by one merge in
        the compiled kernel (:mod:`enctools.kernel`) when it can, else a binary search."""
        lib = kernel.library()
        u = rev.u[:-1]
        if lib is not None and u.size and u.strides[0] == u.itemsize and u.dtype == np.float64:
            found = lib.enc_repeat_count(u.size, u.ctypes.data, rev.start, self.quantum,
                                         first.size, first.ctypes.data)
            if found >= 0:
                return found / u.size
        return float(np.mean(_among(self._positions(rev), first)))

    @property
    def repeated(self) -> bool:
        """True when the revolutions after the first sample the first one's angles."""
        return bool(self._shares) and float(np.mean(self._shares)) > REPEATED_SHARE


def _among(values: np.ndarray, ordered: np.ndarray) -> np.ndarray:
    """Which of ``values`` are in ``ordered`` (sorted, unique): np.isin's answer by a
    binary search of each (isin sorts or hashes both arrays anew at every call)."""
    if ordered.size == 0:
        return np.zeros(values.shape, dtype=bool)
    at = np.minimum(np.searchsorted(ordered, values), ordered.size - 1)
    return ordered[at] == values


def systematic(parts: Callable[[np.ndarray], dict[str, np.ndarray]], heads: int,
               refined: Refined, noise: float, scale: dict[str, float]
               ) -> dict[str, np.ndarray]:
    """A bound per harmonic on what the method itself leaves in each solution array
    [arcsec, nm]: the last iteration's change, the second-order term of the coordinate
    correction, and the heads' rounding to whole counts, ``noise`` [rad] per harmonic
    of one head (LSB / sqrt(12) * sqrt(2 / samples per revolution); 0 when the run does
    not repeat its sampling: the rounding is then in the spread between revolutions)
    times the noise gain of each harmonic, in full: a run that samples the same angles
    every revolution repeats its rounding, which no averaging then reduces.

    ``parts``: the method's solution of head spectra (``heads`` rows, the reference
    first; rad) as arrays by name [rad, m]; ``scale``: each array's factor to the
    output's unit (rad -> arcsec, m -> nm).
    """
    band = next(iter(refined.parts.values())).size - 1
    gain = {name: np.zeros(band + 1) for name in refined.parts}
    for k in range(heads):
        unit = np.zeros((heads, band + 1), dtype=np.complex128)
        unit[k] = 1.0
        for name, c in parts(unit).items():
            gain[name] += np.abs(c) ** 2
    return {name: (np.abs(refined.change[name]) + np.abs(refined.second[name])
                   + noise * np.sqrt(gain[name])) * scale[name] for name in refined.parts}


@dataclass
class Uncertainties:
    """Standard uncertainties of a self-calibration and the coverage of their U.

    ``harmonics``: u per harmonic 0..K of each solution array [arcsec, nm]; ``curves``:
    u per point of each curve [same]; ``spectrum`` and ``curve``: the coverage (dof, k)
    of each, by name; ``repeated``: whether the run sampled the same angles every
    revolution (its rounding then in ``harmonics`` and ``curves`` as a bound).
    """

    harmonics: dict[str, np.ndarray] = field(default_factory=dict)
    curves: dict[str, np.ndarray] = field(default_factory=dict)
    spectrum: dict[str, Coverage | None] = field(default_factory=dict)
    curve: dict[str, Coverage | None] = field(default_factory=dict)
    repeated: bool = False


def uncertainties(coef: dict[str, RunningMean], curves: dict[str, RunningMean],
                  bound: dict[str, np.ndarray], repeated: bool) -> Uncertainties:
    """u per harmonic and per curve point, and their coverage, from the revolutions'
    running means of the coefficients and curves [arcsec, nm] and the method's ``bound``
    per harmonic [same] (:func:`systematic`)."""
    out = Uncertainties(repeated=repeated)
    for name, b in bound.items():
        count = coef[name].count
        sem = coef[name].sem()
        out.harmonics[name] = np.hypot(sem, b)
        out.spectrum[name] = type_a_coverage(sem[1:], repeats_dof(count, 2), b[1:])
        b_curve = float(np.sqrt(np.sum(b ** 2)))
        sem_curve = curves[name].sem()
        out.curves[name] = np.hypot(sem_curve, b_curve)
        out.curve[name] = type_a_coverage(sem_curve, repeats_dof(count), b_curve)
    return out


def mounting_changes(parts: Callable[[np.ndarray], dict[str, np.ndarray]],
                     alphas: np.ndarray, solved: dict[str, np.ndarray],
                     radius_m: float) -> np.ndarray:
    """The change of the graduation error's coefficients c_0..c_K [rad] per rad of each
    head's mounting angle: (heads, K + 1), heads in the method's order (the reference
    first); the curve's change is Re(sum_n c_n exp(i n theta)).

    A head mounted at alpha_k + d_k reads eps(theta + alpha_k + d_k) and the radial
    motion at that angle, where the method assumes alpha_k: to first order its spectrum
    gains d_k (i n exp(i n alpha_k) F(n) + (X(n) cos alpha_k + Y(n) sin alpha_k) / R)
    (seed 000 eq. (11) differentiated in alpha_k), which the method solves as it solves
    any spectrum: ``parts`` (the method's solution of head spectra, rad -> arrays by
    name) gives the change of F, through each harmonic's own gain (1 / W(n) of esa,
    the least squares of fourier and eda; 0 at a blind order). The curve's argument is
    the scale angle under the reference head: every head moved together moves that
    datum with them and changes nothing, so the reference's own change is minus the
    sum of the others' (the simulator agrees; enc-selfcal(1), Head mounting).
    ``solved``: the method's solution [rad, m] (F, and X, Y where it separates them);
    ``alphas`` [rad].
    """
    f = solved["graduation"]
    n = np.arange(f.size)
    x, y = solved.get("x"), solved.get("y")
    out = np.zeros((alphas.size, f.size), dtype=np.complex128)
    for k, alpha in enumerate(alphas[1:], start=1):
        row = 1j * n * np.exp(1j * n * alpha) * f
        if x is not None and y is not None:
            row = row + (x * np.cos(alpha) + y * np.sin(alpha)) / radius_m
        moved = np.zeros((alphas.size, f.size), dtype=np.complex128)
        moved[k] = row
        out[k] = parts(moved)["graduation"]
    out[:, 0] = 0.0
    out[0] = -np.sum(out[1:], axis=0)
    return out


def relative_mounting_sensitivity(parts: Callable[[np.ndarray], dict[str, np.ndarray]],
                                  alphas: np.ndarray, band: int) -> np.ndarray:
    """The rms relative error of F(n), n = 0..band, per rad of an independent error of
    every head's mounting angle, the reference's included [1/rad]: sqrt(sum_k |c_kn|^2)
    of :func:`mounting_changes` for a flat scale error F(n) = 1 (each order is solved
    on its own, so the change is proportional to F(n)); 0 at a blind order.
    ``parts`` and ``alphas`` [rad] as :func:`mounting_changes` takes them."""
    flat = np.ones(band + 1, dtype=np.complex128)
    flat[0] = 0.0
    changes = mounting_changes(parts, alphas, {"graduation": flat}, 1.0)
    return np.sqrt(np.sum(np.abs(changes) ** 2, axis=0))


def mounting_rms(changes: np.ndarray) -> np.ndarray:
    """Each head's rms change of the curve along it [rad per rad] from its coefficients
    (:func:`mounting_changes`, c_0 = 0; Parseval: sqrt(sum_n |c_n|^2 / 2))."""
    return np.sqrt(np.sum(np.abs(changes) ** 2, axis=1) / 2.0)


def mounting_sensitivity(changes: np.ndarray) -> float:
    """The rms change of the curve [rad] when each head's mounting angle is off by an
    independent error of 1 rad standard deviation: sqrt(sum_k rms_k^2) of
    :func:`mounting_rms`."""
    return float(np.sqrt(np.sum(mounting_rms(changes) ** 2)))
