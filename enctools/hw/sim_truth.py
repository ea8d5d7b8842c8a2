"""Make the virtual rig's ground truth from a rig description.

The truth is fixed by the rig file (its ``seed`` keys), not by the acquisition's
noise seed, so every run of a rig sees the same scale, spindle and heads.

- Graduation error: harmonics 2..max_harmonic with amplitudes ~ n^-slope and random
  phases, scaled so their peak-to-peak is ``pp_arcsec``; where ``average_pp_arcsec``
  is given, the harmonics the encoder's measuring heads keep in their average are
  scaled first so that the average's error has that peak-to-peak (the figure a
  paper reports). The 1st harmonic (eccentricity) is set by ``first_harmonic_*``.
- Radial error motion in each encoder's plane: synchronous harmonics 2..max_harmonic
  (~1/n, scaled to ``synchronous_pp_nm`` on the larger of x, y) plus a few
  asynchronous sinusoids at non-integer frequencies (``asynchronous_rms_nm``).
"""

from __future__ import annotations

import numpy as np

from enctools.data.rig import Encoder, Rig
from enctools.data.truth import Motion, Series, SignalFaults, Truth
from enctools.units import ARCSEC, DEG, TWO_PI

_GRID = 4096


def _pp(series_c: np.ndarray, n: np.ndarray) -> float:
    """Peak-to-peak of sum Re(c_n exp(i n x)) on a fine grid."""
    x = np.arange(_GRID) * TWO_PI / _GRID
    spec = np.zeros(_GRID // 2 + 1, dtype=np.complex128)
    spec[n.astype(int)] = series_c
    y = np.fft.irfft(spec, _GRID) * _GRID / 2  # Re(sum c_n e^{inx}) for n >= 1
    return float(np.ptp(y)) if len(x) else 0.0


def average_transfer(alphas: np.ndarray, n: np.ndarray) -> np.ndarray:
    """A(n) = mean_k exp(i n alpha_k) of heads at ``alphas`` [rad] (seed 000 eq. 5)."""
    return np.exp(1j * np.outer(n, alphas)).mean(axis=1)


def _root(f, lo: float, hi: float, xtol: float = 2e-12) -> float:
    """A root of f in [lo, hi] (f(lo) < 0 <= f(hi)) by bisection, to scipy brentq's default
    tolerance. Not brentq itself: importing scipy.optimize costs every `enc acquire` 0.3 s."""
    if f(hi) < 0:
        raise ValueError("f(lo) and f(hi) must have different signs")
    while hi - lo > xtol + 4 * np.finfo(float).eps * abs(hi):
        mid = 0.5 * (lo + hi)
        if f(mid) < 0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def graduation_truth(enc: Encoder) -> Series:
    """The graduation error [arcsec] of an encoder's scale, from its rig table."""
    g = enc.graduation
    rng = np.random.default_rng(g.get("seed", 0))
    nmax = int(g.get("max_harmonic", 120))
    n = np.arange(2, nmax + 1)
    amp = n ** -float(g.get("slope", 1.0)) * np.abs(rng.normal(size=n.size)
                                                   + 1j * rng.normal(size=n.size))
    c = amp * np.exp(1j * rng.uniform(0, TWO_PI, n.size))
    alphas = np.array([h.angle for h in enc.heads if h.name in enc.measure_heads])
    keep = np.abs(average_transfer(alphas, n)) > 0.5 if alphas.size > 1 else np.zeros(n.size, bool)
    if "average_pp_arcsec" in g and keep.any():
        a = average_transfer(alphas, n)
        c[keep] *= float(g["average_pp_arcsec"]) / _pp(c[keep] * a[keep], n[keep])
    target = float(g.get("pp_arcsec", 1.0))
    if keep.any() and (~keep).any():
        def excess(scale: float) -> float:
            cc = c.copy()
            cc[~keep] *= scale
            return _pp(cc, n) - target

        scale = _root(excess, 0.0, 1e3 / max(np.abs(c).max(), 1e-12)) if excess(0.0) < 0 \
            else 0.0
        c[~keep] *= scale
    else:
        c *= target / _pp(c, n)
    e1 = float(g.get("first_harmonic_arcsec", 0.0))
    p1 = float(g.get("first_harmonic_phase_deg", 0.0)) * DEG
    freq = np.concatenate([[1.0], n])
    coef = np.concatenate([[e1 * np.exp(1j * p1)], c])
    return Series(freq, coef.real, -coef.imag)


def radial_truth(enc: Encoder) -> dict[str, Series]:
    """Spindle radial error motion x, y [nm] in the plane of an encoder."""
    r = enc.radial
    rng = np.random.default_rng(r.get("seed", 0))
    nmax = int(r.get("max_harmonic", 12))
    n = np.arange(2, nmax + 1).astype(float)
    out: dict[str, Series] = {}
    sync: dict[str, np.ndarray] = {}
    for ax in ("x", "y"):
        amp = (1 / n) * np.abs(rng.normal(size=n.size) + 1j * rng.normal(size=n.size))
        sync[ax] = amp * np.exp(1j * rng.uniform(0, TWO_PI, n.size))
    pp = max(_pp(sync["x"], n), _pp(sync["y"], n))
    scale = float(r.get("synchronous_pp_nm", 50.0)) / pp if pp > 0 else 0.0
    nterms = int(r.get("asynchronous_terms", 4))
    rms = float(r.get("asynchronous_rms_nm", 0.0))
    for ax in ("x", "y"):
        f_async = rng.uniform(1.5, 25.0, nterms)
        f_async = np.where(np.abs(f_async - np.round(f_async)) < 0.05, f_async + 0.25, f_async)
        a_async = rng.normal(size=nterms) + 1j * rng.normal(size=nterms)
        a_async *= rms / np.sqrt(np.sum(np.abs(a_async) ** 2) / 2) if nterms else 0
        c = np.concatenate([sync[ax] * scale, a_async])
        freq = np.concatenate([n, f_async])
        out[ax] = Series(freq, c.real, -c.imag)
    return out


def polygon_truth(rig: Rig) -> np.ndarray | None:
    """Face angle errors [arcsec] of the rig's polygon, as a certificate gives them (they
    sum to zero; enc-points(1), POLYGON CERTIFICATE): the table turns j * 360/faces + error
    from face 0 square to the autocollimator to face j square."""
    p = rig.polygon
    if not p:
        return None
    rng = np.random.default_rng(p.get("seed", 0))
    e = rng.normal(size=int(p.get("faces", 24))) * float(p.get("face_error_arcsec", 0.0))
    return e.mean() - e  # drawn with the other sign before certificates were read


def make_truth(rig: Rig) -> Truth:
    """The whole ground truth of a rig (motion excluded: it depends on the run)."""
    signals = {}
    for _, h in rig.heads:
        s = h.signal
        signals[h.name] = SignalFaults(float(s.get("offset_cos", 0.0)),
                                       float(s.get("offset_sin", 0.0)),
                                       float(s.get("ratio", 1.0)), float(s.get("phase", 0.0)))
    return Truth(graduation={e.name: graduation_truth(e) for e in rig.encoders},
                 radial={e.name: radial_truth(e) for e in rig.encoders},
                 signals=signals, polygon=polygon_truth(rig))


def jitter_motion(rig: Rig, theta0: float, omega: float) -> Motion:
    """A motion theta(t) [rad] at speed ``omega`` [rad/s] with the rig's speed jitter."""
    m = rig.motion
    amp = np.asarray(m.get("jitter_arcsec", []), dtype=float) * ARCSEC
    hz = np.asarray(m.get("jitter_hz", []), dtype=float)
    if amp.size != hz.size:
        from enctools.errors import DataError
        msg = f"rig {rig.name}: motion.jitter_arcsec and motion.jitter_hz differ in length"
        raise DataError(msg)
    phase = np.linspace(0.3, 2.1, amp.size) if amp.size else np.zeros(0)
    if omega == 0:
        amp = np.zeros_like(amp)
    # A drive never turns at exactly its nominal speed: without this, sampling at a
    # whole number of signal periods would read every head at one phase forever.
    omega = omega * (1.0 + float(m.get("speed_error_ppm", 0.0)) * 1e-6)
    return Motion(theta0, omega, amp, hz, phase)
