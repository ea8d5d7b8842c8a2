"""The virtual rig: the measurement model of seed 000 eq. (1) as a device backend.

Head k of an encoder at nominal angle alpha_k reads::

    H_k(theta) = theta + eps(theta + alpha_k)
                 + [x(theta) sin alpha_k - y(theta) cos alpha_k] / R
                 + psi_k + noise

with eps the graduation error, x, y the spindle radial error motion in the encoder's
plane, psi_k the interpolation error caused by the head's signal faults (an
arctangent interpolator fed Heydemann-faulty signals) and white noise. The reading is
taken ``latency_s`` late (seed 001 eq. 2), quantised to counts and wrapped by a
counter of ``counter_bits``. The head's counter is zeroed at the grating line
nearest its nominal position, so ``counts mod interpolation`` is the phase within
the signal period.

Time is virtual: settling and moves advance the session's clock without sleeping,
so a 20-minute run takes about a second. Deterministic by seed: the truth by the
rig file's seeds, the noise by the session seed.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

from enctools.data.rig import Encoder, Head, Rig
from enctools.data.truth import Motion, Series, interpolation_error
from enctools.errors import SettingsError
from enctools.hw.base import Axis, Channel, Clock, Counter, Sensor, Session, carry_partial
from enctools.hw.sim_truth import jitter_motion, make_truth
from enctools.units import ARCSEC, DEG, TWO_PI

_GRID = 1 << 18  # points per turn of the tabulated periodic errors
_READ_TIME = 0.001  # s taken by one software-timed reading
_MOVE_RPM = 10.0  # r/min of positioning moves
_REALTIME_BLOCK_S = 0.2  # real-time mode: a counter block at least this often
_SETTING_ARCSEC = 3.0  # how far off a polygon set again on the table is turned (1 s.d.)


class VirtualClock(Clock):
    """Virtual time [s] that only moves when told to."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += max(0.0, seconds)
        self.pace()

    def pace(self) -> None:
        """Hold until the wall clock reaches the virtual time (a no-op unless real-time)."""


class RealtimeClock(VirtualClock):
    """Virtual time paced by the wall clock: a run takes as long as it would on a rig."""

    def __init__(self) -> None:
        super().__init__()
        self.start = time.monotonic()

    def pace(self) -> None:
        wait = self.start + self.t - time.monotonic()
        if wait > 0:
            time.sleep(wait)


class _Tabulated:
    """A periodic Series tabulated on a fine grid, evaluated by linear interpolation.

    The table (an inverse FFT of 2^18 points) is built at the first call large enough
    to pay for it; smaller calls (a few readings of a steps run, a tiny run) evaluate
    the series exactly, so a session opens without building it.
    """

    _DIRECT_TERMS = 200_000  # samples x terms below which the series is summed directly

    def __init__(self, series: Series) -> None:
        self.sync = series.band(synchronous=True)
        self.rest = series.band(synchronous=False)
        self.table: np.ndarray | None = None
        self.slope: np.ndarray | None = None
        # the rest as amplitude * cos(f x - phase): one cosine per component
        self._amp = np.hypot(self.rest.a, self.rest.b)
        self._phase = np.arctan2(self.rest.b, self.rest.a)

    def _build(self) -> None:
        sync = self.sync
        spec = np.zeros(_GRID // 2 + 1, dtype=np.complex128)
        c = sync.harmonics(int(sync.freq.max()) if sync.freq.size else 0)
        spec[: c.size] = c
        spec[0] = c[0] * 2 if c.size else 0
        table = np.fft.irfft(spec, _GRID) * _GRID / 2
        self.table = np.append(table, table[0])
        self.slope = np.diff(self.table)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if self.table is None and x.size * self.sync.freq.size < self._DIRECT_TERMS:
            out = self.sync(x)
        else:
            if self.table is None:
                self._build()
            assert self.table is not None and self.slope is not None
            u = np.mod(x, TWO_PI)
            u *= _GRID / TWO_PI
            i = u.astype(np.int64)
            np.minimum(i, _GRID - 1, out=i)
            u -= i
            out = self.slope[i]
            out *= u
            out += self.table[i]
        if not self._amp.size:  # no other components: the sum above is the curve
            return out
        if x.size * self._amp.size <= self._DIRECT_TERMS // 8:  # a few angles: no loop
            terms = np.multiply.outer(x, self.rest.freq)
            terms -= self._phase
            np.cos(terms, out=terms)
            terms *= self._amp
            # added one term after another, as the loop below: the same sums to the bit
            return np.cumsum(np.concatenate([out[..., None], terms], axis=-1), axis=-1)[..., -1]
        for f, a, p in zip(self.rest.freq, self._amp, self._phase, strict=True):
            arg = f * x
            arg -= p
            np.cos(arg, out=arg)
            arg *= a
            out += arg
        return out


def _phase_error(faults: Any, phi: np.ndarray) -> np.ndarray:
    """:func:`enctools.truth.signal_phase_error` with three transcendentals, not six.

    ``atan2(Q, I) - phi`` wrapped to (-pi, pi] is the angle of ``(I + iQ) exp(-i phi)``:
    one arctangent of the signals rotated back by phi, sharing cos phi and sin phi
    with the signals themselves.
    """
    c = np.cos(phi)
    s = np.sin(phi)
    i = faults.offset_cos + c
    q = s * math.cos(faults.phase)
    q += c * math.sin(faults.phase)
    q *= faults.ratio
    q += faults.offset_sin
    return np.arctan2(q * c - i * s, i * c + q * s)


class VirtualRig(Session):
    """A simulated rig: counter, probes, autocollimator, axis, all on one virtual clock."""

    clock: VirtualClock
    axis: SimAxis

    def __init__(self, rig: Rig, seed: int | None = None, signals: bool = False,
                 realtime: bool = False) -> None:
        self.rig = rig
        self.seed = int(seed if seed is not None else rig.backend.get("seed", 0))
        self.rng = np.random.default_rng(self.seed)
        self.signals = signals
        self.realtime = realtime
        self.clock = RealtimeClock() if realtime else VirtualClock()
        self._truth = make_truth(rig)
        start = float(rig.motion.get("start_deg", 0.0)) * DEG
        self.motion = Motion(theta0=start, omega=0.0)
        self._eps = {e.name: _Tabulated(self._truth.graduation[e.name]) for e in rig.encoders}
        self._radial = {e.name: {ax: _Tabulated(s) for ax, s in self._truth.radial[e.name].items()}
                        for e in rig.encoders}
        self._held = start
        #: the truth at the held angle, by (encoder, angle, shape): see _held_truth
        self._held_cache: dict[tuple[str, float, tuple[int, ...]], list] = {}
        self._settled: dict[float, float] = {}  # see settled
        self.feedback = self._feedback_encoder()
        self._measuring = [k for k, h in enumerate(self.feedback.heads)
                           if h.name in self.feedback.measure_heads]
        self.counter = SimCounter(self)
        self.axis = SimAxis(self)
        self.sensors: dict[str, Sensor] = {}
        arm_plane = rig.encoders[0].name
        for p in rig.probes:
            self.sensors[p.name] = SimProbe(self, p.name, p.arm_mm / 1000.0, p.side,
                                            p.noise_nm, arm_plane)
        if rig.polygon:
            name = rig.autocollimator.get("name", "AC")
            self.sensors[name] = SimAutocollimator(
                self, name, int(rig.polygon.get("faces", 24)),
                float(rig.autocollimator.get("noise_arcsec", 0.0)), start,
                float(rig.autocollimator.get("scale_error_ppm", 0.0)) * 1e-6)

    def turn_polygon(self, setting: int) -> None:
        """The polygon set on the table turned by ``setting`` faces: the autocollimator then
        sees face (j + setting) mod faces at table position j, with the setting's offset
        (the polygon set again by hand: a few arcsec, the same for every face)."""
        ac = next((s for s in self.sensors.values() if isinstance(s, SimAutocollimator)), None)
        if ac is None:
            msg = f"`mode` closure: rig {self.rig.name} has no polygon and autocollimator"
            raise SettingsError(msg)
        ac.setting = setting
        ac.offset = float(self.rng.normal(0.0, _SETTING_ARCSEC)) if setting else 0.0

    def _feedback_encoder(self) -> Encoder:
        name = self.rig.motion.get("feedback")
        for e in self.rig.encoders:
            if e.name == name:
                return e
        return self.rig.encoders[0]

    # -- the model -------------------------------------------------------------
    def angle(self, t: np.ndarray) -> np.ndarray:
        """True table angle [rad] at times ``t`` [s]."""
        return self.motion(t)

    def radial_motion(self, enc: Encoder, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Spindle radial error motion x, y [nm] in the encoder's plane at angles theta."""
        rad = self._radial[enc.name]
        return rad["x"](theta), rad["y"](theta)

    def head_reading(self, enc: Encoder, head_index: int, theta: np.ndarray,
                     noise: bool = True, xy: tuple[np.ndarray, np.ndarray] | None = None,
                     ) -> tuple[np.ndarray, np.ndarray]:
        """(reading [rad] relative to the head's zero, signal phase [rad]) at true angles."""
        h = enc.heads[head_index]
        reading, phase = self._head_truth(enc, h, theta, xy)
        return (self._noisy(h, reading) if noise else reading), phase

    def _noisy(self, h: Head, reading: np.ndarray) -> np.ndarray:
        """``reading`` [rad] with head ``h``'s noise added (a new array when it has any)."""
        if h.noise_arcsec > 0:
            return reading + self.rng.normal(0.0, h.noise_arcsec * ARCSEC, reading.shape)
        return reading

    def _head_truth(self, enc: Encoder, h: Head, theta: np.ndarray,
                    xy: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
        """(reading [rad] without noise, signal phase [rad]) of head ``h`` at true angles."""
        x, y = xy if xy is not None else self.radial_motion(enc, theta)
        radial = (x * np.sin(h.angle) - y * np.cos(h.angle)) * 1e-9 / enc.radius_m
        ideal = theta + self._eps[enc.name](theta + h.angle) * ARCSEC + radial
        phase = np.mod(ideal + h.angle, TWO_PI) * enc.periods_per_rev
        psi = _phase_error(self._truth.signals[h.name], phase) / enc.periods_per_rev
        return ideal + psi, phase

    def _held_truth(self, enc: Encoder, shape: tuple[int, ...]
                    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """:meth:`_head_truth` of every head of ``enc`` at the held angle: worked out once
        per angle held (a step run's readings at one position differ by their noise
        alone); the same arrays every time, never changed by their users."""
        key = (enc.name, self._held, shape)
        got = self._held_cache.get(key)
        if got is None:
            theta = np.full(shape, self._held)
            xy = self.radial_motion(enc, theta)
            got = [self._head_truth(enc, h, theta, xy) for h in enc.heads]
            self._held_cache = {k: v for k, v in self._held_cache.items()
                                if k[1] == self._held} | {key: got}
        return got

    def counts(self, enc: Encoder, head_index: int, reading: np.ndarray) -> np.ndarray:
        """Raw counter values [count] of a reading [rad]: quantised, zeroed near the head, wrapped
        to counter_bits."""
        h = enc.heads[head_index]
        c = np.rint((reading + h.angle) * (enc.counts_per_rev / TWO_PI)).astype(np.int64)
        c -= zero_count(enc, h.angle)
        return np.mod(c, np.int64(1) << enc.counter_bits)

    def sample(self, t: np.ndarray, with_signals: bool = False,
               held: bool = False) -> dict[str, np.ndarray]:
        """Raw counter values of every head (and signals) at times ``t``."""
        out: dict[str, np.ndarray] = {"t": t}
        if not held:  # a block may tabulate the truth: what was held is worked out anew
            self._held_cache, self._settled = {}, {}
        for enc in self.rig.encoders:
            if held:
                truth = self._held_truth(enc, t.shape)
            else:
                theta = self.angle(t - enc.latency_s)
                xy = self.radial_motion(enc, theta)
                truth = [self._head_truth(enc, h, theta, xy) for h in enc.heads]
            for k, (h, (reading, phase)) in enumerate(zip(enc.heads, truth, strict=True)):
                out[h.name] = self.counts(enc, k, self._noisy(h, reading))
                if with_signals:
                    f = self._truth.signals[h.name]
                    amp = float(h.signal.get("amplitude_v", 0.5))
                    sn = float(h.signal.get("noise_v", 0.0))
                    i = amp * (f.offset_cos + np.cos(phase))
                    q = amp * (f.offset_sin + f.ratio * np.sin(phase + f.phase))
                    if sn > 0:
                        i = i + self.rng.normal(0, sn, t.shape)
                        q = q + self.rng.normal(0, sn, t.shape)
                    out[f"{h.name}.cos"] = i
                    out[f"{h.name}.sin"] = q
        return out

    def settled(self, angle: float) -> float:
        """The true angle [rad] at which the feedback encoder reads ``angle`` [rad], as the
        controller closes its loop on it (a fixed-point iteration: the error is tiny);
        worked out once per angle (a run returns to its positions run after run)."""
        theta = self._settled.get(angle)
        if theta is None:
            theta = angle
            for _ in range(4):
                theta = angle - self.feedback_error(theta)
            self._settled[angle] = theta
        return theta

    def feedback_error(self, theta: float) -> float:
        """Error [rad] of the feedback encoder's head average at true angle ``theta``."""
        enc = self.feedback
        th = np.array([theta])
        xy = self.radial_motion(enc, th)  # the same for every head
        return float(np.mean([self.head_reading(enc, k, th, noise=False, xy=xy)[0][0] - theta
                               for k in self._measuring]))

    # -- session ---------------------------------------------------------------
    def channels(self) -> list[Channel]:
        if not self.signals:
            return []
        out = []
        for _, h in self.rig.heads:
            out.append(Channel(f"{h.name}.cos", "V", "signal", {"head": h.name,
                                                                "component": "cos"}))
            out.append(Channel(f"{h.name}.sin", "V", "signal", {"head": h.name,
                                                                "component": "sin"}))
        return out

    def truth(self) -> dict[str, Any]:
        d = self._truth.to_dict()
        d["motion"] = self.motion.to_dict()
        return d

    def describe(self) -> dict[str, Any]:
        d: dict[str, Any] = {"backend": "sim", "seed": self.seed}
        if self.realtime:
            d["realtime"] = True
        return d


def zero_count(enc: Encoder, alpha: float) -> int:
    """The count a head's counter is zeroed at: the grating line nearest ``alpha`` [rad]."""
    return round(alpha * enc.periods_per_rev / TWO_PI) * enc.interpolation


class SimCounter(Counter):
    def __init__(self, rig: VirtualRig) -> None:
        self.sim = rig
        self.heads = tuple(h.name for _, h in rig.rig.heads)
        self.counter_bits = {h.name: e.counter_bits for e, h in rig.rig.heads}
        self._interval = 0.0
        self._next = 0.0

    def start(self, interval_s: float) -> None:
        self._interval = interval_s
        self._next = self.sim.clock.now()
        self._k = 0
        self._t0 = self._next

    def read_block(self, max_samples: int) -> dict[str, np.ndarray]:
        if self.sim.realtime:
            max_samples = min(max_samples, max(1, math.ceil(_REALTIME_BLOCK_S / self._interval)))
        k = np.arange(self._k, self._k + max_samples)
        t = self._t0 + k * self._interval
        self._k += max_samples
        block = self.sim.sample(t, with_signals=self.sim.signals)
        self.sim.clock.t = float(t[-1])
        try:
            self.sim.clock.pace()
        except BaseException as exc:  # a signal while waiting: the samples whose time came
            clock = self.sim.clock
            elapsed = time.monotonic() - clock.start if isinstance(clock, RealtimeClock) else 0.0
            n = int(np.searchsorted(t, elapsed, side="right"))
            carry_partial(exc, {name: v[:n] for name, v in block.items()})
            raise
        return block

    def stop(self) -> None:
        self._interval = 0.0

    def read_now(self) -> dict[str, np.ndarray]:
        self.sim.clock.sleep(_READ_TIME)
        t = np.array([self.sim.clock.now()])
        return self.sim.sample(t, with_signals=self.sim.signals, held=self.sim.axis.holding)


class SimAxis(Axis):
    """Closed-loop axis: positions so that the feedback encoder reads the target."""

    def __init__(self, rig: VirtualRig) -> None:
        self.sim = rig
        self.holding = True
        self.position_noise = float(rig.rig.motion.get("position_noise_arcsec", 0.0)) * ARCSEC

    def rotate(self, speed: float) -> None:
        sim = self.sim
        now = sim.clock.now()
        theta = float(sim.angle(np.array([now]))[0]) if not self.holding else sim._held
        sim.motion = dataclasses.replace(jitter_motion(sim.rig, theta, speed), t0=now)
        self.holding = False

    def stop(self) -> None:
        sim = self.sim
        sim._held = float(sim.angle(np.array([sim.clock.now()]))[0])
        sim.motion = Motion(theta0=sim._held, omega=0.0, t0=sim.clock.now())
        self.holding = True

    def move_to(self, angle: float) -> None:
        sim = self.sim
        if not self.holding:
            self.stop()
        theta = sim.settled(angle)
        if self.position_noise > 0:
            theta += float(sim.rng.normal(0.0, self.position_noise))
        travel = abs(theta - sim._held)
        sim.clock.sleep(travel / (_MOVE_RPM * TWO_PI / 60.0))
        sim._held = theta
        sim.motion = Motion(theta0=theta, omega=0.0, t0=sim.clock.now())


class SimProbe(Sensor):
    """A displacement probe on an arm [m]: side * arm * rotation + translation + noise.

    Zeroed at its first reading. The translation is the radial motion (y) in the
    plane of the rig's first encoder; two probes on opposite sides cancel it. Beyond
    :data:`RANGE_M` from its zero the probe is out of range and reads NaN, as a real
    one does (a steps run round the circle turns the arm metres past it).
    """

    RANGE_M = 1e-3

    def __init__(self, rig: VirtualRig, name: str, arm_m: float, side: int, noise_nm: float,
                 plane: str) -> None:
        self.sim = rig
        self.arm = arm_m
        self.side = side
        self.noise = noise_nm * 1e-9
        self.plane = plane
        self.zero: float | None = None
        self.channel = Channel(name, "m", "probe", {"arm_m": arm_m, "side": side})

    def read(self) -> float:
        sim = self.sim
        theta = sim._held if sim.axis.holding else float(sim.angle(np.array([sim.clock.now()]))[0])
        if self.zero is None:
            self.zero = theta
        translation = float(sim._radial[self.plane]["y"](np.array([theta]))[0]) * 1e-9
        noise = float(sim.rng.normal(0.0, self.noise)) if self.noise > 0 else 0.0
        value = self.side * self.arm * (theta - self.zero) + translation + noise
        return value if abs(value) <= self.RANGE_M else float("nan")


class SimAutocollimator(Sensor):
    """An autocollimator looking at a polygon on the table [arcsec]; NaN off any face.

    It indicates the face's angle (table angle off the nominal face plus the face's
    error) times 1 + ``scale_error`` (its calibration error, relative), plus noise.
    """

    RANGE_ARCSEC = 1000.0

    def __init__(self, rig: VirtualRig, name: str, faces: int, noise_arcsec: float,
                 theta0: float, scale_error: float = 0.0) -> None:
        self.sim = rig
        self.faces = faces
        self.noise = noise_arcsec
        self.theta0 = theta0
        self.scale = 1.0 + scale_error
        self.setting = 0  # faces the polygon is turned by on the table (closure runs)
        self.offset = 0.0  # arcsec: that setting's offset
        self.channel = Channel(name, "arcsec", "autocollimator")

    def read(self) -> float:
        sim = self.sim
        theta = sim._held if sim.axis.holding else float(sim.angle(np.array([sim.clock.now()]))[0])
        step = TWO_PI / self.faces
        j = int(np.round((theta - self.theta0) / step))
        dev = (theta - self.theta0 - j * step) / ARCSEC
        if abs(dev) > self.RANGE_ARCSEC:
            return float("nan")
        face = sim._truth.polygon[(j + self.setting) % self.faces] \
            if sim._truth.polygon is not None else 0.0
        noise = float(sim.rng.normal(0.0, self.noise)) if self.noise > 0 else 0.0
        return (dev - face + self.offset) * self.scale + noise


__all__ = ["VirtualRig", "interpolation_error", "zero_count"]
