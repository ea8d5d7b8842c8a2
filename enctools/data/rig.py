"""Rig descriptions: TOML files naming encoders, heads, sensors, the axis and backends.

A rig is loaded by bundled name (``sjtu-dual``, ``ciomp-23bit``) or by path. The
format is documented in enc-rig(5); every key is checked, and an unknown key is an
error that names it, its table and the closest known key.

Units in rig files: angles in degrees, lengths in mm, errors in arcsec, radial
motion in nm, times in s, speeds in r/min.

The TOML parser and the package's resources are imported by the functions that read a
rig file: a command that reads the rig a stream records needs the classes alone.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from enctools.data.files import read_small_text
from enctools.data.riglimits import MAX_BYTES, MAX_DEPTH, check_value, depth
from enctools.data.text import check_identifier
from enctools.data.uncertainty import Declaration, declarations
from enctools.errors import DataError
from enctools.units import DEG

FORMAT_VERSION = 1

# Allowed keys per table: key -> expected type(s). Nested tables are checked by path.
_SPEC: dict[str, dict[str, tuple[type, ...]]] = {
    "": {"format": (int,), "name": (str,), "description": (str,), "encoder": (list,),
         "probe": (list,), "polygon": (dict,), "motion": (dict,), "acquire": (dict,),
         "backend": (dict,), "autocollimator": (dict,), "uncertainty": (dict,)},
    "encoder": {"name": (str,), "model": (str,), "periods_per_rev": (int,),
                "interpolation": (int,), "diameter_mm": (int, float), "counter_bits": (int,),
                "latency_s": (int, float), "plane_mm": (int, float), "measure_heads": (list,),
                "head": (list,), "graduation": (dict,), "radial": (dict,)},
    "encoder.head": {"name": (str,), "angle_deg": (int, float), "noise_arcsec": (int, float),
                     "signal": (dict,), "backend": (dict,)},
    "encoder.head.signal": {"offset_cos": (int, float), "offset_sin": (int, float),
                            "ratio": (int, float), "phase_deg": (int, float),
                            "amplitude_v": (int, float), "noise_v": (int, float)},
    "encoder.graduation": {"seed": (int,), "first_harmonic_arcsec": (int, float),
                           "first_harmonic_phase_deg": (int, float), "max_harmonic": (int,),
                           "slope": (int, float), "pp_arcsec": (int, float),
                           "average_pp_arcsec": (int, float)},
    "encoder.radial": {"seed": (int,), "synchronous_pp_nm": (int, float), "max_harmonic": (int,),
                       "asynchronous_rms_nm": (int, float), "asynchronous_terms": (int,)},
    "probe": {"name": (str,), "arm_mm": (int, float), "side": (int,), "noise_nm": (int, float),
              "backend": (dict,)},
    "polygon": {"faces": (int,), "face_error_arcsec": (int, float), "seed": (int,)},
    "autocollimator": {"name": (str,), "noise_arcsec": (int, float),
                       "scale_error_ppm": (int, float), "backend": (dict,)},
    "motion": {"speed_rpm": (int, float), "jitter_arcsec": (list,), "jitter_hz": (list,),
               "start_deg": (int, float), "feedback": (str,), "speed_error_ppm": (int, float),
               "position_noise_arcsec": (int, float), "backend": (dict,)},
    "acquire": {"mode": (str,), "revolutions": (int, float), "speed_rpm": (int, float),
                "interval_s": (int, float), "steps": (dict,), "sweep": (dict,),
                "closure": (dict,)},
    "acquire.steps": {"positions_deg": (list,), "count": (int,), "settle_s": (int, float),
                      "readings": (int,), "runs": (int,), "bidirectional": (bool,),
                      "overshoot_deg": (int, float)},
    "acquire.sweep": {"start_deg": (int, float), "range_arcsec": (int, float),
                      "step_arcsec": (int, float), "settle_s": (int, float),
                      "readings": (int,)},
    "acquire.closure": {"settle_s": (int, float), "readings": (int,),
                        "overshoot_deg": (int, float)},
    "backend": {"kind": (str,), "seed": (int,)},
}
#: the keys whose text is free (shown escaped, enctools.data.text); every other string
#: of the tables above names a thing and holds no control, bidi or zero-width character
FREE_TEXT = frozenset({"description"})
# Tables whose contents belong to a backend and are checked by it, not here.
_OPEN_TABLES = {"backend", "encoder.head.backend", "probe.backend", "autocollimator.backend",
                "motion.backend"}


@dataclass(frozen=True)
class Head:
    """One scanning head: name, nominal angle [rad] from the encoder's first head."""

    name: str
    angle: float
    noise_arcsec: float = 0.0
    signal: dict[str, float] = field(default_factory=dict)
    backend: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Encoder:
    """An angle encoder: its scale, its heads and its counter."""

    name: str
    periods_per_rev: int
    interpolation: int
    diameter_mm: float
    heads: tuple[Head, ...]
    model: str = ""
    counter_bits: int = 32
    latency_s: float = 0.0
    plane_mm: float = 0.0
    measure_heads: tuple[str, ...] = ()
    graduation: dict[str, Any] = field(default_factory=dict)
    radial: dict[str, Any] = field(default_factory=dict)

    @property
    def counts_per_rev(self) -> int:
        """Counts per revolution: signal periods x interpolation factor."""
        return self.periods_per_rev * self.interpolation

    @property
    def radius_m(self) -> float:
        """Scale radius [m]."""
        return self.diameter_mm / 2000.0


@dataclass(frozen=True)
class Probe:
    """A displacement probe on an arm (capacitive probe for interpolation checks)."""

    name: str
    arm_mm: float
    side: int = 1
    noise_nm: float = 0.0
    backend: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Rig:
    """A whole rig: encoders, probes, polygon, autocollimator, motion, defaults, backend."""

    name: str
    encoders: tuple[Encoder, ...]
    description: str = ""
    probes: tuple[Probe, ...] = ()
    polygon: dict[str, Any] = field(default_factory=dict)
    autocollimator: dict[str, Any] = field(default_factory=dict)
    motion: dict[str, Any] = field(default_factory=dict)
    acquire: dict[str, Any] = field(default_factory=dict)
    backend: dict[str, Any] = field(default_factory=lambda: {"kind": "sim"})
    source: str = ""
    uncertainty: dict[str, Any] = field(default_factory=dict)  # [uncertainty.NAME] tables

    @property
    def heads(self) -> list[tuple[Encoder, Head]]:
        """All heads of all encoders, in rig order."""
        return [(e, h) for e in self.encoders for h in e.heads]

    @property
    def head_names(self) -> list[str]:
        return [h.name for _, h in self.heads]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-able description (goes into every stream's metadata)."""
        return asdict(self)


def bundled_rigs() -> list[str]:
    """Names of the rigs shipped with enctools."""
    from importlib import resources

    root = resources.files("enctools") / "rigs"
    return sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".toml"))


def load_rig(name_or_path: str) -> Rig:
    """Load a rig by bundled name or TOML path; raises DataError with one line."""
    import tomllib

    text, source = rig_text(name_or_path)
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = f"rig file {source}: not valid TOML: {exc}"
        raise DataError(msg) from None
    except RecursionError:
        msg = f"rig file {source}: arrays or tables nested deeper than {MAX_DEPTH} levels"
        raise DataError(msg) from None
    if depth(raw) > MAX_DEPTH:
        msg = f"rig file {source}: arrays or tables nested deeper than {MAX_DEPTH} levels"
        raise DataError(msg)
    return parse_rig(raw, source)


def _read_rig_file(p: Path, name: str) -> str:
    """The text of a rig file: a regular file of at most MAX_BYTES, checked before reading."""
    return read_small_text(p, f"rig file {name}", MAX_BYTES, "a rig file")


def rig_text(name_or_path: str) -> tuple[str, str]:
    """The TOML text of a bundled rig (by name) or of a rig file, and its source's name."""
    p = Path(name_or_path)
    looks_like_path = name_or_path.endswith(".toml") or "/" in name_or_path or p.exists()
    if looks_like_path:
        return _read_rig_file(p, name_or_path), str(p)
    from importlib import resources

    names = bundled_rigs()
    if name_or_path not in names:
        hint = difflib.get_close_matches(name_or_path, names, n=1)
        did = f" (did you mean {hint[0]!r}?)" if hint else ""
        msg = (f"unknown rig {name_or_path!r}{did}; bundled rigs: {', '.join(names)}; "
               "or give the path of a rig file")
        raise DataError(msg)
    res = resources.files("enctools") / "rigs" / f"{name_or_path}.toml"
    return res.read_text(encoding="utf-8"), f"{name_or_path} (bundled)"


def _check(table: dict[str, Any], path: str, source: str, where: str) -> None:
    spec = _SPEC[path]
    for key, value in table.items():
        if key not in spec:
            hint = difflib.get_close_matches(key, spec, n=1)
            did = f"; did you mean {hint[0]!r}?" if hint else ""
            loc = f"[{where}]" if where else "the top level"
            msg = f"rig file {source}: unknown key {key!r} in {loc}{did}"
            raise DataError(msg)
        types = spec[key]
        # a TOML boolean is an int to Python: it fits only where a boolean is allowed
        if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
            want = " or ".join(t.__name__.replace("dict", "table").replace("list", "array")
                               .replace("str", "string").replace("int", "integer")
                               for t in types)
            loc = f"{where}.{key}" if where else key
            msg = f"rig file {source}: {loc} must be {want}, not {value!r}"
            raise DataError(msg)
        sub = f"{path}.{key}" if path else key
        loc = f"{where}.{key}" if where else key
        check_value(sub, value, source, loc)
        _check_names(key, value, source, loc)
        if sub in _OPEN_TABLES:
            continue
        if isinstance(value, dict) and sub in _SPEC:
            _check(value, sub, source, f"{where}.{key}" if where else key)
        elif isinstance(value, list) and sub in _SPEC:
            for i, item in enumerate(value):
                if not isinstance(item, dict):
                    msg = f"rig file {source}: {sub} must be an array of tables ([[{sub}]])"
                    raise DataError(msg)
                _check(item, sub, source, f"{where + '.' if where else ''}{key}[{i}]")


def _check_names(key: str, value: Any, source: str, where: str) -> None:
    """A name (a string, or the strings of an array of names) that reads as it is: one
    line without control, bidi or zero-width characters (enc-rig(5), NAMES)."""
    if key in FREE_TEXT:
        return
    names = value if isinstance(value, list) else [value]
    for i, name in enumerate(names):
        if isinstance(name, str):
            at = f"{where}[{i}]" if isinstance(value, list) else where
            check_identifier(name, f"rig file {source}: {at}")


def _require(table: dict[str, Any], key: str, source: str, where: str) -> Any:
    if key not in table:
        msg = f"rig file {source}: [{where}] needs the key {key!r}"
        raise DataError(msg)
    return table[key]


def parse_rig(raw: dict[str, Any], source: str = "<rig>") -> Rig:
    """Check a parsed TOML document and build a :class:`Rig`."""
    _check(raw, "", source, "")
    fmt = raw.get("format", FORMAT_VERSION)
    if fmt > FORMAT_VERSION:
        msg = (f"rig file {source}: format {fmt} is newer than this enctools reads "
               f"({FORMAT_VERSION}); upgrade enctools")
        raise DataError(msg)
    name = _require(raw, "name", source, "top level")
    seen: set[str] = set()
    encoders = tuple(_parse_encoder(e, f"encoder[{i}]", source, seen)
                     for i, e in enumerate(_require(raw, "encoder", source, "top level")))
    backend = dict(raw.get("backend", {"kind": "sim"}))
    backend.setdefault("kind", "sim")
    _check_open_keys(raw, backend, source)
    _check_declared_encoders(declarations(raw.get("uncertainty"),
                                          f"rig file {source}: uncertainty"), encoders, source)
    return Rig(name=name, encoders=encoders, description=raw.get("description", ""),
               probes=_parse_probes(raw, source), polygon=dict(raw.get("polygon", {})),
               autocollimator=dict(raw.get("autocollimator", {})),
               motion=dict(raw.get("motion", {})), acquire=dict(raw.get("acquire", {})),
               backend=backend, source=source,
               uncertainty={k: dict(v) for k, v in raw.get("uncertainty", {}).items()})


def _check_declared_encoders(declared: dict[str, Declaration], encoders: tuple[Encoder, ...],
                             source: str) -> None:
    """A declaration's ``encoder`` names one of the rig's encoders."""
    names = [e.name for e in encoders]
    for quantity, d in declared.items():
        if d.encoder and d.encoder not in names:
            msg = (f"rig file {source}: uncertainty.{quantity}.encoder {d.encoder!r} is not "
                   f"an encoder of the rig ({', '.join(names)})")
            raise DataError(msg)


def _check_open_keys(raw: dict[str, Any], backend: dict[str, Any], source: str) -> None:
    """The keys of the open [backend] table that the rig itself reads, and the jitter's
    two arrays, which go in pairs."""
    if "seed" in backend:
        seed = backend["seed"]
        if not isinstance(seed, int) or isinstance(seed, bool):
            msg = f"rig file {source}: backend.seed must be integer, not {seed!r}"
            raise DataError(msg)
        check_value("backend.seed", seed, source, "backend.seed")
    if not isinstance(backend["kind"], str):
        msg = f"rig file {source}: backend.kind must be string, not {backend['kind']!r}"
        raise DataError(msg)
    motion = raw.get("motion", {})
    names = [e.get("name") for e in raw.get("encoder", [])]
    if "feedback" in motion and motion["feedback"] not in names:
        msg = (f"rig file {source}: motion.feedback names no encoder: {motion['feedback']!r} "
               f"(encoders: {', '.join(map(str, names))})")
        raise DataError(msg)
    if len(motion.get("jitter_arcsec", [])) != len(motion.get("jitter_hz", [])):
        msg = (f"rig file {source}: motion.jitter_arcsec and motion.jitter_hz must have "
               "as many items")
        raise DataError(msg)


def _parse_encoder(e: dict[str, Any], where: str, source: str, seen: set[str]) -> Encoder:
    """One ``[[encoder]]`` table; ``seen``: the head names so far (each must be new)."""
    heads = []
    for j, h in enumerate(_require(e, "head", source, where)):
        hname = _require(h, "name", source, f"{where}.head[{j}]")
        if hname in seen:
            msg = f"rig file {source}: head name {hname!r} is used twice"
            raise DataError(msg)
        seen.add(hname)
        signal = dict(h.get("signal", {}))
        if "phase_deg" in signal:
            signal["phase"] = signal.pop("phase_deg") * DEG
        heads.append(Head(hname, float(_require(h, "angle_deg", source, f"{where}.head[{j}]"))
                          * DEG, float(h.get("noise_arcsec", 0.0)), signal,
                          dict(h.get("backend", {}))))
    for key in ("periods_per_rev", "interpolation"):
        if _require(e, key, source, where) <= 0:
            msg = f"rig file {source}: {where}.{key} must be positive"
            raise DataError(msg)
    bits = int(e.get("counter_bits", 32))
    if not 8 <= bits <= 62:
        msg = f"rig file {source}: {where}.counter_bits must be 8..62, not {bits}"
        raise DataError(msg)
    measure = tuple(e.get("measure_heads", [h.name for h in heads]))
    unknown = [m for m in measure if m not in {h.name for h in heads}]
    if unknown:
        msg = f"rig file {source}: {where}.measure_heads names unknown head {unknown[0]!r}"
        raise DataError(msg)
    return Encoder(
        name=_require(e, "name", source, where),
        periods_per_rev=int(e["periods_per_rev"]), interpolation=int(e["interpolation"]),
        diameter_mm=float(_require(e, "diameter_mm", source, where)), heads=tuple(heads),
        model=e.get("model", ""), counter_bits=bits,
        latency_s=float(e.get("latency_s", 0.0)), plane_mm=float(e.get("plane_mm", 0.0)),
        measure_heads=measure, graduation=dict(e.get("graduation", {})),
        radial=dict(e.get("radial", {})))


def _parse_probes(raw: dict[str, Any], source: str) -> tuple[Probe, ...]:
    """The ``[[probe]]`` tables (arms must be positive)."""
    probes = tuple(Probe(_require(p, "name", source, f"probe[{i}]"),
                         float(_require(p, "arm_mm", source, f"probe[{i}]")),
                         int(p.get("side", 1)), float(p.get("noise_nm", 0.0)),
                         dict(p.get("backend", {})))
                   for i, p in enumerate(raw.get("probe", [])))
    for p in probes:
        if not p.arm_mm > 0 or not math.isfinite(p.arm_mm):
            msg = f"rig file {source}: probe {p.name!r}: arm_mm must be > 0, not {p.arm_mm}"
            raise DataError(msg)
    return probes
