"""The ranges of a rig file's values: what a rig may make a command allocate or loop over.

Every number of a rig file has a stated range (enc-rig(5) lists them); every array a
type for its items and a most number of them. A rig from elsewhere is data: a value
out of range ends the command with one line naming the key, the value, the range and
the file, before anything is allocated (a polygon of 10^9 faces, 10^9 harmonics) or a
device is opened. The ranges hold every real rig with a wide margin.
"""

from __future__ import annotations

import math
from typing import Any

from enctools.errors import DataError

#: a rig file is read only when it is a regular file of at most this many bytes
MAX_BYTES = 1 << 20
#: seeds of the simulator's random generators (numpy's default_rng takes 0..2^63-1 here)
MAX_SEED = (1 << 63) - 1
#: the deepest nesting of arrays and tables a rig may have (the deepest real one is 4)
MAX_DEPTH = 8
#: the greatest width or precision a command template's format spec may declare
#: (``{deg:>12.6f}``): a command line is short, and ``{deg:>1500000000}`` would build
#: a string of 1.5 GB
MAX_TEMPLATE_WIDTH = 64

_SEED = (0, MAX_SEED)
_ARCSEC = (0.0, 3600.0)  # an error, a noise or a step of at most one degree [arcsec]
_TURN = (-360.0, 360.0)  # an angle [deg]
_NM = (0.0, 1e6)  # radial motion or probe noise, at most 1 mm [nm]
_MM = (-10000.0, 10000.0)  # a length on a rig [mm]

#: "table.key" -> (least, greatest): inclusive bounds of every number of a rig file
RANGES: dict[str, tuple[float, float]] = {
    "format": (1, 1000),
    "encoder.periods_per_rev": (1, 1 << 27),
    "encoder.interpolation": (1, 1 << 24),
    "encoder.diameter_mm": (0.001, 10000.0),
    "encoder.counter_bits": (8, 62),
    "encoder.latency_s": (0.0, 1.0),
    "encoder.plane_mm": _MM,
    "encoder.head.angle_deg": _TURN,
    "encoder.head.noise_arcsec": _ARCSEC,
    "encoder.head.signal.offset_cos": (-1.0, 1.0),
    "encoder.head.signal.offset_sin": (-1.0, 1.0),
    "encoder.head.signal.ratio": (0.1, 10.0),
    "encoder.head.signal.phase_deg": (-45.0, 45.0),
    "encoder.head.signal.amplitude_v": (0.0, 100.0),
    "encoder.head.signal.noise_v": (0.0, 100.0),
    "encoder.graduation.seed": _SEED,
    "encoder.graduation.first_harmonic_arcsec": (-3600.0, 3600.0),
    "encoder.graduation.first_harmonic_phase_deg": _TURN,
    "encoder.graduation.max_harmonic": (2, 2048),
    "encoder.graduation.slope": (0.0, 10.0),
    "encoder.graduation.pp_arcsec": _ARCSEC,
    "encoder.graduation.average_pp_arcsec": _ARCSEC,
    "encoder.radial.seed": _SEED,
    "encoder.radial.synchronous_pp_nm": _NM,
    "encoder.radial.max_harmonic": (2, 2048),
    "encoder.radial.asynchronous_rms_nm": _NM,
    "encoder.radial.asynchronous_terms": (0, 64),
    "probe.arm_mm": (0.001, 10000.0),
    "probe.side": (-1, 1),
    "probe.noise_nm": _NM,
    "polygon.faces": (3, 720),
    "polygon.face_error_arcsec": _ARCSEC,
    "polygon.seed": _SEED,
    "autocollimator.noise_arcsec": _ARCSEC,
    "autocollimator.scale_error_ppm": (-1e5, 1e5),
    "motion.speed_rpm": (-6000.0, 6000.0),
    "motion.jitter_arcsec": _ARCSEC,
    "motion.jitter_hz": (0.0, 10000.0),
    "motion.start_deg": _TURN,
    "motion.speed_error_ppm": (-1e5, 1e5),
    "motion.position_noise_arcsec": _ARCSEC,
    "acquire.revolutions": (1e-6, 1e5),
    "acquire.speed_rpm": (-6000.0, 6000.0),
    "acquire.interval_s": (1e-7, 3600.0),
    "acquire.steps.positions_deg": _TURN,
    "acquire.steps.count": (1, 100_000),
    "acquire.steps.settle_s": (0.0, 3600.0),
    "acquire.steps.readings": (1, 10_000),
    "acquire.steps.runs": (1, 1000),
    "acquire.steps.overshoot_deg": (0.0, 360.0),
    "acquire.sweep.start_deg": _TURN,
    "acquire.sweep.range_arcsec": (0.0, 1_296_000.0),
    "acquire.sweep.step_arcsec": (1e-6, 1_296_000.0),
    "acquire.sweep.settle_s": (0.0, 3600.0),
    "acquire.sweep.readings": (1, 10_000),
    "acquire.closure.settle_s": (0.0, 3600.0),
    "acquire.closure.readings": (1, 10_000),
    "acquire.closure.overshoot_deg": (0.0, 360.0),
    "backend.seed": _SEED,
}

#: "table.key" of an array -> (item types, most items); arrays of tables included
ARRAYS: dict[str, tuple[tuple[type, ...], int]] = {
    "encoder": ((dict,), 16),
    "encoder.head": ((dict,), 64),
    "encoder.measure_heads": ((str,), 64),
    "probe": ((dict,), 16),
    "motion.jitter_arcsec": ((int, float), 64),
    "motion.jitter_hz": ((int, float), 64),
    "acquire.steps.positions_deg": ((int, float), 100_000),
}

#: "table.key" of a string -> the values it may take
CHOICES: dict[str, tuple[str, ...]] = {
    "acquire.mode": ("continuous", "steps", "sweep", "closure"),
}

#: "table.key" of an array of tables or of a string array -> least number of items
LEAST: dict[str, int] = {"encoder": 1, "encoder.head": 1, "encoder.measure_heads": 1}


def fmt(v: float) -> str:
    """A limit or a value as an error line and enc-rig(5) write it (1296000, 1e-06, inf)."""
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e16:
        return str(int(v))
    return f"{v:g}" if isinstance(v, float) else str(v)


def check_value(spec_key: str, value: Any, source: str, loc: str) -> None:
    """DataError (one line) when a number, string or array is outside its stated range.

    ``spec_key``: the key's place in the format ("encoder.head.noise_arcsec");
    ``loc``: where it is in this file ("encoder[0].head[1].noise_arcsec").
    """
    if isinstance(value, list):
        _check_array(spec_key, value, source, loc)
    elif isinstance(value, str) and spec_key in CHOICES and value not in CHOICES[spec_key]:
        msg = (f"rig file {source}: {loc} must be one of {', '.join(CHOICES[spec_key])}, "
               f"not {value!r}")
        raise DataError(msg)
    elif isinstance(value, int | float) and not isinstance(value, bool):
        _check_number(spec_key, value, source, loc)


def _check_number(spec_key: str, value: float, source: str, loc: str) -> None:
    if spec_key not in RANGES:
        return
    lo, hi = RANGES[spec_key]
    if not (math.isfinite(value) and lo <= value <= hi):
        msg = f"rig file {source}: {loc} must be {fmt(lo)}..{fmt(hi)}, not {fmt(value)}"
        raise DataError(msg)
    if spec_key == "probe.side" and value == 0:
        msg = f"rig file {source}: {loc} must be 1 or -1, not 0"
        raise DataError(msg)


def _check_array(spec_key: str, value: list[Any], source: str, loc: str) -> None:
    if spec_key not in ARRAYS:
        return
    types, most = ARRAYS[spec_key]
    least = LEAST.get(spec_key, 0)
    if not least <= len(value) <= most:
        msg = (f"rig file {source}: {loc} must have {least}..{most} items, "
               f"not {len(value)}")
        raise DataError(msg)
    if dict in types:
        return  # arrays of tables: each table is checked key by key
    for i, item in enumerate(value):
        if not isinstance(item, types) or isinstance(item, bool):
            want = "a string" if str in types else "a number"
            msg = f"rig file {source}: {loc}[{i}] must be {want}, not {item!r}"
            raise DataError(msg)
        if isinstance(item, int | float):
            _check_number(spec_key, item, source, f"{loc}[{i}]")


def depth(value: Any, limit: int = MAX_DEPTH) -> int:
    """The nesting depth of parsed TOML (tables and arrays), counted up to ``limit + 1``."""
    stack = [(value, 0)]
    deepest = 0
    while stack:
        v, d = stack.pop()
        deepest = max(deepest, d)
        if deepest > limit:
            return deepest
        if isinstance(v, dict):
            stack.extend((x, d + 1) for x in v.values())
        elif isinstance(v, list):
            stack.extend((x, d + 1) for x in v)
    return deepest
