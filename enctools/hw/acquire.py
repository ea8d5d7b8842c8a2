"""Acquisition: drive a rig's devices in one of four modes and yield readings batches.

- ``continuous``: turn at a speed for N revolutions, sample every head every
  ``interval_s`` (hardware-timed blocks); seed 000's procedure.
- ``steps``: move to each target, settle, take k readings of every head and sensor;
  uni- or bidirectional runs (polygon work, ISO 230-2); seed 001's procedure.
- ``sweep``: steps over a small range at a fine pitch (interpolation checks with
  probes; seed 000 table 1).
- ``closure``: the polygon's closure (cross-calibration, enc-closure(1)): one run of the
  polygon's faces positions every 360/faces per setting of the polygon on the table,
  the polygon turned by one face between runs (run s: setting s), so that every face
  meets every table position.

Counter values arrive raw and wrapped; they leave as unwrapped int64 counts. Batches
are yielded as they are read, so a caller can flush them at once and lose nothing if
the run is stopped.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.arrays import arrow_array
from enctools.data.readings import head_field
from enctools.data.rig import Rig
from enctools.data.riglimits import ARRAYS, RANGES, fmt
from enctools.data.schemas import make_field
from enctools.data.streams import BATCH_ROWS, Header
from enctools.errors import DeviceError, SettingsError
from enctools.hw.base import Session, partial_block
from enctools.units import ARCSEC, DEG, TWO_PI

MODES = ("continuous", "steps", "sweep", "closure")

DEFAULTS: dict[str, Any] = {
    "mode": "continuous", "revolutions": 1.0, "speed_rpm": 1.0, "interval_s": 0.003,
    "count": 24, "positions_deg": None, "settle_s": 1.0, "readings": 1, "runs": 1,
    "bidirectional": False, "overshoot_deg": 0.5,
    "start_deg": 0.0, "range_arcsec": 25.0, "step_arcsec": 0.5,
}


@dataclass
class Settings:
    """Effective acquisition settings (units in the names: deg, arcsec, s, r/min)."""

    mode: str = "continuous"
    revolutions: float = 1.0
    speed_rpm: float = 1.0
    interval_s: float = 0.003
    count: int = 24
    positions_deg: list[float] | None = None
    settle_s: float = 1.0
    readings: int = 1
    runs: int = 1
    bidirectional: bool = False
    overshoot_deg: float = 0.5
    start_deg: float = 0.0
    range_arcsec: float = 25.0
    step_arcsec: float = 0.5
    seed: int | None = None
    signals: bool = False
    heads: list[str] | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {k: v for k, v in asdict(self).items() if k != "extra"} | self.extra


def rig_defaults(rig: Rig, mode: str | None) -> dict[str, Any]:
    """Acquisition defaults from the rig's ``[acquire]`` tables for a mode."""
    a = rig.acquire
    out: dict[str, Any] = {k: a[k] for k in ("mode", "revolutions", "speed_rpm", "interval_s")
                           if k in a}
    mode = mode or out.get("mode", "continuous")
    if mode in ("steps", "sweep", "closure"):
        out.update(a.get(mode, {}))
    out["mode"] = mode
    return out


def resolve(rig: Rig, given: dict[str, Any]) -> Settings:
    """Settings from the ones given (None = not given) over the rig's and built-in defaults;
    each one checked, a SettingsError naming its field."""
    mode = given.get("mode")
    merged = dict(DEFAULTS)
    merged.update(rig_defaults(rig, mode))
    merged.update({k: v for k, v in given.items() if v is not None})
    if merged["mode"] == "closure":
        merged.update(_closure_plan(rig, given))
    s = Settings(**{k: merged[k] for k in Settings.__dataclass_fields__ if k in merged})
    check(s)
    if s.heads:
        unknown = [h for h in s.heads if h not in rig.head_names]
        if unknown:
            msg = (f"`heads`: rig {rig.name} has no head {unknown[0]!r} "
                   f"(heads: {', '.join(rig.head_names)})")
            raise SettingsError(msg)
    return s


def _closure_plan(rig: Rig, given: dict[str, Any]) -> dict[str, Any]:
    """A closure run's positions and runs: the polygon's faces each (the settings for
    them given are refused: the design is fixed by the polygon)."""
    faces = rig.polygon.get("faces") if rig.polygon else None
    if faces is None:
        msg = f"`mode` closure: rig {rig.name} has no [polygon]"
        raise SettingsError(msg)
    for name in ("count", "positions_deg", "runs", "bidirectional"):
        if given.get(name) not in (None, False):
            msg = (f"`{name}`: not for `mode` closure (one run of the {faces} faces' positions "
                   "per setting of the polygon)")
            raise SettingsError(msg)
    return {"count": int(faces), "runs": int(faces), "positions_deg": None,
            "bidirectional": False}


#: setting -> the rig key whose range it shares (enc-rig(5) LIMITS)
BOUNDS: dict[str, str] = {
    "revolutions": "acquire.revolutions",
    "interval_s": "acquire.interval_s",
    "count": "acquire.steps.count",
    "settle_s": "acquire.steps.settle_s",
    "readings": "acquire.steps.readings",
    "runs": "acquire.steps.runs",
    "overshoot_deg": "acquire.steps.overshoot_deg",
    "start_deg": "acquire.sweep.start_deg",
    "range_arcsec": "acquire.sweep.range_arcsec",
    "step_arcsec": "acquire.sweep.step_arcsec",
}
#: the most positions a steps or sweep run visits (positions x runs x directions)
MAX_TARGETS = 1_000_000
#: the most samples of a continuous run
MAX_SAMPLES = 2_000_000_000


def _bounded(name: str, v: Any, lo: float, hi: float) -> None:
    if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            and lo <= v <= hi):
        msg = f"`{name}` must be {fmt(lo)}..{fmt(hi)}, not {v!r}"
        raise SettingsError(msg)


def check(s: Settings) -> None:
    """Reject settings no rig could carry out, or that would loop or allocate without
    end: a SettingsError naming the field and its range (the rig key's, enc-rig(5)
    LIMITS)."""
    if s.mode not in MODES:
        msg = f"`mode` must be one of {', '.join(MODES)}, not {s.mode!r}"
        raise SettingsError(msg)
    for name, key in BOUNDS.items():
        _bounded(name, getattr(s, name), *RANGES[key])
    lo, hi = RANGES["acquire.speed_rpm"]
    if s.mode == "continuous" and not (isinstance(s.speed_rpm, int | float)
                                       and 0 < abs(s.speed_rpm) <= hi):
        msg = f"`speed_rpm` must be non-zero and {fmt(lo)}..{fmt(hi)} r/min, not {s.speed_rpm!r}"
        raise SettingsError(msg)
    if s.positions_deg is not None:
        most = ARRAYS["acquire.steps.positions_deg"][1]
        if not 1 <= len(s.positions_deg) <= most:
            msg = f"`positions_deg` must give 1..{most} positions, not {len(s.positions_deg)}"
            raise SettingsError(msg)
        for p in s.positions_deg:
            _bounded("positions_deg", p, *RANGES["acquire.steps.positions_deg"])
    if s.mode == "continuous":
        n = samples_total(s)
        if not 1 <= n <= MAX_SAMPLES:
            msg = (f"{n} samples requested (`revolutions`/`speed_rpm`/`interval_s`); "
                   f"must be 1..{MAX_SAMPLES}")
            raise SettingsError(msg)
    else:
        n = positions_total(s) * s.runs * (2 if s.bidirectional else 1)
        if n > MAX_TARGETS:
            msg = (f"{n} positions requested (positions x `runs` x directions); "
                   f"must be at most {MAX_TARGETS}")
            raise SettingsError(msg)


def positions_total(s: Settings) -> int:
    """Positions of one run of a steps or sweep run."""
    if s.mode == "sweep":
        return math.floor(s.range_arcsec / s.step_arcsec + 1e-9) + 1
    return len(s.positions_deg) if s.positions_deg is not None else s.count


def samples_total(s: Settings) -> int:
    """Samples (count) of a continuous run: revolutions x (60 / speed [r/min]) / interval [s]."""
    return round(s.revolutions * 60.0 / abs(s.speed_rpm) / s.interval_s)


def targets(s: Settings) -> list[tuple[int, int, int, float]]:
    """(step, run, direction, target [rad]) in the order a steps or sweep run visits them."""
    if s.mode == "sweep":
        pos = [s.start_deg * DEG + k * s.step_arcsec * ARCSEC for k in range(positions_total(s))]
    elif s.positions_deg is not None:
        pos = [p * DEG for p in s.positions_deg]
    else:
        pos = [s.start_deg * DEG + k * TWO_PI / s.count for k in range(s.count)]
    out = []
    for run in range(s.runs):
        out += [(k, run, 1, p) for k, p in enumerate(pos)]
        if s.bidirectional:
            out += [(k, run, -1, p) for k, p in reversed(list(enumerate(pos)))]
    return out


class Unwrapper:
    """Turns raw counter values (mod 2**bits) into continuous int64 counts."""

    def __init__(self, bits: int) -> None:
        self.modulus = np.int64(1) << bits
        self.half = np.int64(1) << (bits - 1)
        self.last: np.int64 | None = None

    def __call__(self, raw: np.ndarray, expected: float | None = None) -> np.ndarray:
        """Unwrap a block; ``expected`` [count] picks the turn when moves are large."""
        raw = np.asarray(raw, dtype=np.int64)
        if raw.size == 0:
            return raw
        if expected is not None:
            turns = round((expected - raw[0]) / float(self.modulus))
            first = raw[0] + np.int64(turns) * self.modulus
        elif self.last is None:
            first = raw[0] - self.modulus if raw[0] >= self.half else raw[0]
        else:
            d0 = (raw[0] - self.last + self.half) % self.modulus - self.half
            first = self.last + d0
        d = (np.diff(raw) + self.half) % self.modulus - self.half
        out = np.empty_like(raw)
        out[0] = first
        np.cumsum(d, out=out[1:])
        out[1:] += first
        self.last = out[-1]
        return out


def readings_schema(rig: Rig, session: Session, s: Settings) -> pa.Schema:
    """The columns of the readings stream this acquisition writes."""
    from enctools.hw.sim import zero_count

    fields = [make_field("t", pa.float64(), "s")]
    for enc, h in rig.heads:
        if s.heads and h.name not in s.heads:
            continue
        fields.append(head_field(h.name, enc.name, round(h.angle / DEG, 12), enc.counts_per_rev,
                                 enc.periods_per_rev, enc.interpolation, enc.radius_m,
                                 zero_count(enc, h.angle)))
    for ch in session.channels():
        if s.heads and ch.meta and ch.meta.get("head") not in s.heads:
            continue
        fields.append(make_field(ch.name, pa.float64(), ch.unit, ch.role, **(ch.meta or {})))
    if s.mode != "continuous":
        for sensor in session.sensors.values():
            ch = sensor.channel
            fields.append(make_field(ch.name, pa.float64(), ch.unit, ch.role, **(ch.meta or {})))
        fields += [make_field("target", pa.float64(), "rad"), make_field("step", pa.int32(), ""),
                   make_field("run", pa.int32(), ""), make_field("direction", pa.int8(), "")]
    return pa.schema(fields)


Progress = Callable[[int, int], None]


def acquire(rig: Rig, session: Session, s: Settings,
            progress: Progress | None = None) -> tuple[Header, Iterator[pa.RecordBatch]]:
    """Header and batches of a readings stream; the batches are read lazily."""
    schema = readings_schema(rig, session, s)
    if s.mode == "continuous":
        # Start turning and sampling first: the header then carries the motion's truth.
        direction = 1.0 if s.speed_rpm > 0 else -1.0
        session.axis.rotate(direction * abs(s.speed_rpm) * TWO_PI / 60.0)
        session.counter.start(s.interval_s)
    meta: dict[str, Any] = {"rig": rig.to_dict(), "mode": s.mode,
                            "settings": s.to_dict() | {"backend": session.describe()}}
    truth = session.truth()
    if truth is not None:
        meta["truth"] = truth
    if s.mode == "closure":
        session.turn_polygon(0)  # refused before any output by a rig that cannot
    header = Header("readings", schema, meta)
    run = _continuous if s.mode == "continuous" else _stepped
    return header, run(rig, session, s, schema, progress)


def _unwrappers(rig: Rig) -> dict[str, tuple[Unwrapper, int]]:
    return {h.name: (Unwrapper(e.counter_bits), e.counts_per_rev) for e, h in rig.heads}


def _continuous(rig: Rig, session: Session, s: Settings, schema: pa.Schema,
                progress: Progress | None) -> Iterator[pa.RecordBatch]:
    """The blocks of a continuous run as batches; a run stopped inside a block (a device
    fault, SIGINT, SIGTERM) first yields the samples of it already read, then raises."""
    total = samples_total(s)
    unwrap = _unwrappers(rig)
    heads = tuple(f.name for f in schema if f.name in unwrap)
    done = 0
    block: dict[str, np.ndarray] | None = None  # read and checked, not yet yielded
    try:
        while done < total:
            n = min(BATCH_ROWS, total - done)
            try:
                got = session.counter.read_block(n)
            except BaseException as exc:
                block = _checked(partial_block(exc), heads)
                raise
            check_block(got, heads)
            block = got
            if len(block["t"]) == 0:
                continue
            batch = _batch(block, schema, unwrap)
            done += batch.num_rows
            block = None
            yield batch
            if progress:
                progress(done, total)
    except GeneratorExit:
        raise
    except BaseException:
        if block is not None and len(block["t"]) > 0:
            yield _batch(block, schema, unwrap)  # the caller writes it, then gets the error
        raise
    finally:
        session.counter.stop()
        session.axis.stop()


def _checked(block: dict[str, np.ndarray] | None,
             heads: tuple[str, ...]) -> dict[str, np.ndarray] | None:
    """A partial block if it is whole (every head, equal lengths), else None."""
    if block is None:
        return None
    try:
        check_block(block, heads)
    except DeviceError:
        return None
    return block


def _batch(block: dict[str, np.ndarray], schema: pa.Schema,
           unwrap: dict[str, tuple[Unwrapper, int]]) -> pa.RecordBatch:
    """A counter block as a record batch: counters unwrapped to int64 counts."""
    cols = []
    for f in schema:
        if f.name in unwrap:
            cols.append(arrow_array(unwrap[f.name][0](block[f.name]), pa.int64()))
        else:
            cols.append(arrow_array(np.asarray(block[f.name], dtype=np.float64)))
    return pa.RecordBatch.from_arrays(cols, schema=schema)


def _stepped(rig: Rig, session: Session, s: Settings, schema: pa.Schema,
             progress: Progress | None) -> Iterator[pa.RecordBatch]:
    """One batch per position, yielded once all its readings are taken; a position read
    whole before a fault or signal is yielded before the run ends, never a part of one."""
    plan = targets(s)
    unwrap = _unwrappers(rig)
    overshoot = s.overshoot_deg * DEG
    rows: dict[str, list[Any]] | None = None  # a position read, not yet yielded
    try:
        for i, (step, run, direction, target) in enumerate(plan):
            if s.mode == "closure" and step == 0:
                session.turn_polygon(run)
            if s.mode in ("steps", "closure") and overshoot > 0:
                session.axis.move_to(target - direction * overshoot)
            session.axis.move_to(target)
            session.clock.sleep(s.settle_s)
            rows = _position(session, s, schema, unwrap, (step, run, direction, target))
            batch = _rows_batch(rows, schema)
            rows = None
            yield batch
            if progress:
                progress(i + 1, len(plan))
    except GeneratorExit:
        raise
    except BaseException:
        if rows is not None:
            yield _rows_batch(rows, schema)  # the caller writes it, then gets the error
        raise


def _position(session: Session, s: Settings, schema: pa.Schema,
              unwrap: dict[str, tuple[Unwrapper, int]],
              where: tuple[int, int, int, float]) -> dict[str, list[Any]]:
    """The readings at one position: ``s.readings`` rows of every column."""
    step, run, direction, target = where
    rows: dict[str, list[Any]] = {f.name: [] for f in schema}
    for _ in range(s.readings):
        sample = session.counter.read_now()
        for name, (uw, cpr) in unwrap.items():
            if name in rows:
                rows[name].append(int(uw(sample[name], expected=target * cpr / TWO_PI)[0]))
        rows["t"].append(float(sample["t"][0]))
        for key, val in sample.items():
            if key != "t" and key not in unwrap and key in rows:
                rows[key].append(float(val[0]))
        for name, sensor in session.sensors.items():
            rows[name].append(float(sensor.read()))
        rows["target"].append(target)
        rows["step"].append(step)
        rows["run"].append(run)
        rows["direction"].append(direction)
    return rows


def _rows_batch(rows: dict[str, list[Any]], schema: pa.Schema) -> pa.RecordBatch:
    return pa.RecordBatch.from_arrays([pa.array(rows[f.name], f.type) for f in schema],
                                      schema=schema)


def check_block(block: dict[str, np.ndarray], heads: tuple[str, ...]) -> None:
    """A device block must give every head and equal lengths (else a device fault)."""
    n = len(block.get("t", ()))
    for h in heads:
        if h not in block or len(block[h]) != n:
            msg = f"device returned a block without head {h!r} or of the wrong length"
            raise DeviceError(msg)
