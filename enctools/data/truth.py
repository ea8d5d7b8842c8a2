"""Ground truth of the virtual rig, in a form any test can evaluate at any angle.

The simulator writes a :class:`Truth` into the metadata of every stream it makes
(key ``truth``); the methods' tests rebuild it with :meth:`Truth.from_dict` and
score their results against it.

Conventions (all angles in rad, errors in arcsec, radial motion in nm):

- ``graduation[encoder]``: graduation error eps(phi) of the scale, phi the scale
  angle under a head (``theta + alpha_k``). Its 1st harmonic is the mounting
  eccentricity e/R. The 1st harmonic of radial motion is indistinguishable from
  eccentricity and is counted here, never in ``radial``.
- ``radial[encoder]``: ``{"x": Series, "y": Series}``, spindle radial error motion in
  the plane of that encoder, in nm, as a function of the *unwrapped* spindle angle
  theta (integer frequencies: synchronous part; the others: asynchronous).
- ``signals[head]``: the head's signal faults (Heydemann model). The interpolation
  error they cause, psi [arcsec], is :func:`interpolation_error` of the true scale
  angle under the head, s = theta + alpha + eps(theta + alpha) + (x sin alpha -
  y cos alpha) / R: the head's reading before psi and noise, plus alpha. The head
  then reads r = s + psi (its signal phase is r times the periods per revolution),
  so a method, which sees only r, finds psi as a function of the angle read:
  psi(s) at the s with s + psi(s) = r, not interpolation_error at r itself (that
  is off by about psi times its slope: up to 0.0115" on sjtu-dual's H heads);
  :func:`interpolation_error_read` evaluates it at a signal phase read.
- ``motion``: theta(t) = theta0 + omega t + sum of speed-jitter sinusoids, t the
  stream's ``t`` [s] (continuous mode).
- ``polygon``: face angle errors of the polygon, arcsec, as its certificate gives them
  (enc-points(1)); the autocollimator reads (theta - theta0 - j 2 pi / faces) [arcsec]
  - face error + noise at face j (with the polygon turned on the table by s faces, enc
  closure: face (j + s) mod faces, plus the setting's offset).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from enctools.units import ARCSEC, TWO_PI

#: samples x terms up to which a Series is summed as one matrix product (8 bytes each)
_OUTER_TERMS = 1 << 16


@dataclass(frozen=True)
class Series:
    """A sum of sinusoids ``sum a_j cos(f_j x) + b_j sin(f_j x)``.

    ``freq`` is in cycles per revolution (per 2 pi rad of x); integer frequencies
    make the series periodic in 2 pi. Units of ``a``/``b`` are the caller's.
    """

    freq: np.ndarray
    a: np.ndarray
    b: np.ndarray
    #: which terms are integer harmonics, and whether some are and some not: a steps run
    #: evaluates a series at one angle thousands of times, so these are worked out once
    _integer: np.ndarray = field(init=False, repr=False, compare=False)
    _any: bool = field(init=False, repr=False, compare=False)
    _mixed: bool = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("freq", "a", "b"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=np.float64))
        integer = self.freq == np.round(self.freq)
        object.__setattr__(self, "_integer", integer)
        object.__setattr__(self, "_any", bool(np.any(integer)))
        object.__setattr__(self, "_mixed", self._any and not bool(np.all(integer)))

    @property
    def periodic(self) -> bool:
        """True when every frequency is an integer (the series repeats every turn)."""
        return bool(np.all(self._integer))

    def __call__(self, x: np.ndarray | float) -> np.ndarray:
        """Evaluate at angles ``x`` [rad] (any shape).

        A few angles (a steps or sweep reading) are summed as one matrix product over
        the terms; many, term by term, in memory of the size of ``x``.
        """
        x = np.asarray(x, dtype=np.float64)
        integer = self._integer
        xr = np.mod(x, TWO_PI) if self._any else x
        if x.size * self.freq.size <= _OUTER_TERMS:
            arg = xr.reshape(-1, 1) * self.freq
            if self._mixed:
                arg = np.where(integer, arg, x.reshape(-1, 1) * self.freq)
            return (np.cos(arg) @ self.a + np.sin(arg) @ self.b).reshape(x.shape)
        out = np.zeros_like(x)
        for f, a, b, is_int in zip(self.freq, self.a, self.b, integer, strict=True):
            arg = f * (xr if is_int else x)
            out += a * np.cos(arg) + b * np.sin(arg)
        return out

    def harmonics(self, n_max: int) -> np.ndarray:
        """Complex coefficients c_n = a_n - i b_n for n = 0..n_max of the integer part.

        With this convention ``a cos(n x) + b sin(n x) = Re(c_n exp(i n x))``, x [rad];
        c_n is in the unit of ``a``/``b`` (arcsec for graduation, nm for radial motion).
        """
        c = np.zeros(n_max + 1, dtype=np.complex128)
        for f, a, b in zip(self.freq, self.a, self.b, strict=True):
            if f == round(f) and 0 <= f <= n_max:
                c[int(f)] += a - 1j * b
        return c

    def band(self, keep: np.ndarray | list[int] | None = None, n_max: int | None = None,
             multiple_of: int | None = None, synchronous: bool | None = None) -> Series:
        """A new series with only the selected terms.

        ``keep``: explicit integer frequencies; ``n_max``: frequencies up to n_max;
        ``multiple_of``: integer frequencies that are multiples of it;
        ``synchronous``: True keeps integer frequencies, False the others.
        """
        mask = np.ones(self.freq.shape, dtype=bool)
        integer = self._integer
        if keep is not None:
            mask &= np.isin(self.freq, np.asarray(keep, dtype=np.float64))
        if n_max is not None:
            mask &= self.freq <= n_max
        if multiple_of is not None:
            mask &= integer & (np.mod(self.freq, multiple_of) == 0)
        if synchronous is not None:
            mask &= integer if synchronous else ~integer
        return Series(self.freq[mask], self.a[mask], self.b[mask])

    def shifted(self, alpha: float) -> Series:
        """The series of ``x -> self(x + alpha)`` (alpha in rad)."""
        c = (self.a - 1j * self.b) * np.exp(1j * self.freq * alpha)
        return Series(self.freq, c.real, -c.imag)

    def to_dict(self) -> dict[str, list[float]]:
        return {"freq": self.freq.tolist(), "a": self.a.tolist(), "b": self.b.tolist()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Series:
        return cls(np.asarray(d["freq"]), np.asarray(d["a"]), np.asarray(d["b"]))

    @classmethod
    def empty(cls) -> Series:
        return cls(np.zeros(0), np.zeros(0), np.zeros(0))


@dataclass(frozen=True)
class SignalFaults:
    """Faults of a head's quadrature signals (Heydemann model), relative to amplitude 1.

    The head delivers ``I = offset_cos + cos(phi)`` and
    ``Q = offset_sin + ratio * sin(phi + phase)`` with phi the true signal phase.
    """

    offset_cos: float = 0.0
    offset_sin: float = 0.0
    ratio: float = 1.0
    phase: float = 0.0  # rad

    def to_dict(self) -> dict[str, float]:
        return {"offset_cos": self.offset_cos, "offset_sin": self.offset_sin,
                "ratio": self.ratio, "phase": self.phase}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SignalFaults:
        return cls(float(d["offset_cos"]), float(d["offset_sin"]), float(d["ratio"]),
                   float(d["phase"]))


def signal_phase_error(faults: SignalFaults, phi: np.ndarray) -> np.ndarray:
    """Phase error [rad of signal phase] of an arctangent interpolator fed faulty signals.

    ``atan2(Q, I) - phi`` wrapped to (-pi, pi], phi the true signal phase [rad].
    """
    phi = np.asarray(phi, dtype=np.float64)
    i = faults.offset_cos + np.cos(phi)
    q = faults.offset_sin + faults.ratio * np.sin(phi + faults.phase)
    return np.angle(np.exp(1j * (np.arctan2(q, i) - phi)))


def interpolation_error(faults: SignalFaults, scale_angle: np.ndarray,
                        periods_per_rev: int) -> np.ndarray:
    """Interpolation error psi [arcsec] of a head at the scale angle under it [rad].

    The error within one signal period caused by the signal faults: the phase
    error divided by the number of signal periods per revolution.
    """
    phi = np.mod(np.asarray(scale_angle, dtype=np.float64), TWO_PI) * periods_per_rev
    return signal_phase_error(faults, phi) / periods_per_rev / ARCSEC


def interpolation_error_read(faults: SignalFaults, phase_read: np.ndarray,
                             periods_per_rev: int) -> np.ndarray:
    """Interpolation error psi [arcsec] at the signal phase a head reads [rad].

    The head reads phase r = phi + e(phi), phi the true phase and e
    :func:`signal_phase_error`; psi is e(phi) / periods_per_rev at the phi solving it,
    found by fixed-point iteration phi <- r - e(phi) (e changes by far less than the
    phase: it converges to rounding in a few dozen steps). What a method that sees only
    the readings (enc interp-check) recovers, as the module's conventions say.
    """
    r = np.asarray(phase_read, dtype=np.float64)
    phi = r.copy()
    for _ in range(50):
        phi = r - signal_phase_error(faults, phi)
    return signal_phase_error(faults, phi) / periods_per_rev / ARCSEC


@dataclass(frozen=True)
class Motion:
    """theta(t) = theta0 + omega (t - t0) + sum_j A_j sin(2 pi f_j (t - t0) + p_j) [rad, s]."""

    theta0: float = 0.0
    omega: float = 0.0
    jitter_amp: np.ndarray = field(default_factory=lambda: np.zeros(0))
    jitter_freq: np.ndarray = field(default_factory=lambda: np.zeros(0))
    jitter_phase: np.ndarray = field(default_factory=lambda: np.zeros(0))
    t0: float = 0.0

    def __call__(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=np.float64) - self.t0
        out = self.theta0 + self.omega * t
        for a, f, p in zip(self.jitter_amp, self.jitter_freq, self.jitter_phase,
                           strict=True):
            out = out + a * np.sin(TWO_PI * f * t + p)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"theta0": self.theta0, "omega": self.omega,
                "jitter_amp": list(map(float, self.jitter_amp)),
                "jitter_freq": list(map(float, self.jitter_freq)),
                "jitter_phase": list(map(float, self.jitter_phase)), "t0": self.t0}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Motion:
        return cls(float(d["theta0"]), float(d["omega"]), np.asarray(d["jitter_amp"]),
                   np.asarray(d["jitter_freq"]), np.asarray(d["jitter_phase"]),
                   float(d.get("t0", 0.0)))


@dataclass
class Truth:
    """Everything the simulator knows and a method should recover."""

    graduation: dict[str, Series] = field(default_factory=dict)
    radial: dict[str, dict[str, Series]] = field(default_factory=dict)
    signals: dict[str, SignalFaults] = field(default_factory=dict)
    polygon: np.ndarray | None = None
    motion: Motion | None = None

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "graduation": {k: s.to_dict() for k, s in self.graduation.items()},
            "radial": {k: {ax: s.to_dict() for ax, s in v.items()}
                       for k, v in self.radial.items()},
            "signals": {k: f.to_dict() for k, f in self.signals.items()},
        }
        if self.polygon is not None:
            d["polygon"] = list(map(float, self.polygon))
        if self.motion is not None:
            d["motion"] = self.motion.to_dict()
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Truth:
        return cls(
            graduation={k: Series.from_dict(s) for k, s in d.get("graduation", {}).items()},
            radial={k: {ax: Series.from_dict(s) for ax, s in v.items()}
                    for k, v in d.get("radial", {}).items()},
            signals={k: SignalFaults.from_dict(f) for k, f in d.get("signals", {}).items()},
            polygon=np.asarray(d["polygon"]) if "polygon" in d else None,
            motion=Motion.from_dict(d["motion"]) if "motion" in d else None,
        )
