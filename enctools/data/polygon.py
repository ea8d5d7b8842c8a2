"""A polygon's certificate: its face angle errors and their uncertainty (enc-points(1),
POLYGON CERTIFICATE).

The face angle error of face j [arcsec] is the angle the table turns from face 0
square to the autocollimator to face j square, minus j * 360/faces (faces numbered
in the order the table brings them to the autocollimator). A certificate gives them
relative to the mean of all faces (``reference: mean``, the default: they sum to
zero) or to its first face (``reference: first``: that face's error is 0); in
memory they are always relative to the mean.

The file is a text table as :mod:`enctools.data.tables` reads one (CSV, TSV or blanks,
``#`` comments), with a header line naming the columns ``face``, ``error`` and
either ``U`` (expanded uncertainty, with ``k``) or ``u`` (standard uncertainty); a
title may name its unit (``error [urad]``). Comment lines ``# key: value`` give
``certificate`` (its number), ``traceability``, ``unit``, ``k``, ``reference`` and, for
a certificate whose uncertainties are a Type A evaluation (enc closure's), ``type: A``
and the degrees of freedom they rest on, ``dof`` (default: Type B, taken as exact).
:func:`certificate_text` writes the same format (what enc closure writes of the faces).
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from enctools.data import limits
from enctools.data.files import read_bytes
from enctools.data.riglimits import RANGES
from enctools.data.tables import ALIASES, RawTable, cell_unit, parse_text, title_unit
from enctools.data.text import check_identifier, printable
from enctools.errors import DataError
from enctools.units import ANGLE_UNITS, factor

#: the keys a comment line ``# key: value`` may give
KEYS = ("certificate", "traceability", "unit", "k", "reference", "type", "dof")
#: the most degrees of freedom a certificate may state (beyond: as good as exact)
MAX_DOF = 1e9
REFERENCES = ("mean", "first")
#: the largest coverage factor a certificate may state
MAX_K = 10.0
#: the largest face angle error a certificate may state [arcsec] (an autocollimator's range)
MAX_FACE_ERROR_ARCSEC = 1000.0
_FACE = {"face", "face number", "face no", "face no.", "no", "no.", "number", "#"}
_ERROR = {"error", "face error", "face angle error", "angle error", "deviation"}
_EXPANDED = {"expanded", "expanded uncertainty"}
_STANDARD = {"standard", "standard uncertainty"}
_KEY_LINE = re.compile(r"#\s*([A-Za-z]+)\s*[:=]\s*(.*?)\s*$")


@dataclass(frozen=True)
class Certificate:
    """A polygon's face angle errors and their standard uncertainties [arcsec].

    error_arcsec, u_arcsec : one per face, the certificate's first face first; the
        errors relative to their mean (they sum to zero).
    number, traceability : as the certificate states them (None: not stated).
    source, sha256 : the file read and the SHA-256 of its bytes.
    first : the number of the certificate's first face (0 or 1).
    kind, dof : the evaluation of u_arcsec ("A" or "B") and its degrees of freedom
        (``math.inf``: taken as exact).
    """

    error_arcsec: np.ndarray
    u_arcsec: np.ndarray
    number: str | None
    traceability: str | None
    source: str
    sha256: str
    first: int = 0
    kind: str = "B"
    dof: float = math.inf

    @property
    def faces(self) -> int:
        return int(self.error_arcsec.size)

    def meta(self) -> dict[str, Any]:
        """The ``polygon_certificate`` metadata of the points it corrects."""
        return {"file": os.path.basename(self.source), "sha256": self.sha256,
                "certificate": self.number, "traceability": self.traceability,
                "faces": self.faces, "first_face_number": self.first,
                "error_arcsec": [float(x) for x in self.error_arcsec],
                "u_arcsec": [float(x) for x in self.u_arcsec],
                "u_max_arcsec": float(self.u_arcsec.max()), "type": self.kind,
                "dof": None if math.isinf(self.dof) else self.dof}


def face_standard_uncertainty(cert: Certificate) -> np.ndarray:
    """The standard uncertainty of each face's angle error [arcsec], face 0 first: the
    "polygon face errors" contribution of an uncertainty budget."""
    return cert.u_arcsec.copy()


def points_face_uncertainty(meta: dict[str, Any]) -> np.ndarray | None:
    """The standard uncertainty of each face's angle error [arcsec] that a points stream's
    metadata carries from the certificate it was corrected with (``polygon_certificate``,
    first face first); None when its points were not corrected by one."""
    cert = meta.get("polygon_certificate")
    if not isinstance(cert, dict) or not isinstance(cert.get("u_arcsec"), list):
        return None
    u = np.asarray(cert["u_arcsec"], dtype=np.float64)
    if u.ndim != 1 or u.size == 0 or not np.all(np.isfinite(u) & (u > 0)):
        msg = "metadata polygon_certificate.u_arcsec must be positive numbers, one per face"
        raise DataError(msg)
    return u


def certificate_evaluation(cert: dict[str, Any]) -> tuple[str, float]:
    """The evaluation ("A" or "B") and dof of a ``polygon_certificate``'s u (metadata of
    points written before they were recorded: B, taken as exact)."""
    kind, dof = cert.get("type", "B"), cert.get("dof")
    if kind not in ("A", "B") or not (dof is None or (
            isinstance(dof, int | float) and not isinstance(dof, bool) and 0 < dof <= MAX_DOF)):
        msg = "metadata polygon_certificate: type must be A or B and dof a number > 0 or null"
        raise DataError(msg)
    return kind, math.inf if dof is None else float(dof)


def read_certificate(path: str, faces: int | None = None, unit: str | None = None
                     ) -> Certificate:
    """A polygon's certificate from a text table (the module's format).

    faces : the faces the polygon must have (None: as many as the certificate lists).
    unit : the unit of the values when the file states none (None: arcsec); a file
        that states another is refused.
    DataError, one line naming the file and line, when it cannot be used: wrong or
    missing or repeated faces, a value that is not a finite number, an uncertainty not
    > 0, errors that do not sum to about zero where the reference is the mean.
    """
    import hashlib  # here: most commands that import this module read no certificate

    size = _size(path)
    if size > limits.MAX_CSV_BYTES:
        msg = f"{path}: a certificate of {size} bytes; at most {limits.MAX_CSV_BYTES} are read"
        raise DataError(msg)
    data = read_bytes(path)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        msg = f"{path}: not a text table (a polygon certificate is CSV, TSV or blank-separated)"
        raise DataError(msg) from None
    keys = _keys(text, path)
    if not any(ln.strip() and not ln.lstrip().startswith("#") for ln in text.splitlines()):
        msg = f"{path}: no faces (the certificate is empty or only comments)"
        raise DataError(msg)
    raw = parse_text(text, path)
    cols = _columns(raw)
    units = _units(raw, cols, keys, unit)
    face = _values(raw, cols["face"], None)
    error = _values(raw, cols["error"], units["error"])
    spread = _values(raw, cols["u"], units["u"])
    if cols["u"] in cols.get("expanded", ()):
        spread = spread / _k(keys, path)
    order, first = _face_order(raw, face, faces)
    error, spread = error[order], spread[order]
    _check_values(raw, error, spread, order)
    error = _relative_to_mean(raw, error, spread, keys.get("reference", "mean"))
    kind, dof = _evaluation(keys, path)
    return Certificate(error, spread, keys.get("certificate"), keys.get("traceability"),
                       path, hashlib.sha256(data).hexdigest(), first, kind, dof)


def _evaluation(keys: dict[str, str], path: str) -> tuple[str, float]:
    """The ``type`` (A or B) and ``dof`` lines: a Type A needs its dof; B's default inf."""
    kind = keys.get("type", "B").upper()
    if kind not in ("A", "B"):
        msg = f"{path}: type must be A or B, not {keys['type']!r}"
        raise DataError(msg)
    if "dof" not in keys:
        if kind == "A":
            msg = f"{path}: a Type A certificate needs the degrees of freedom: a line '# dof: N'"
            raise DataError(msg)
        return kind, math.inf
    parsed = cell_unit(keys["dof"])
    dof = parsed[0] if parsed is not None and parsed[1] is None else math.nan
    if not 0 < dof <= MAX_DOF:
        msg = f"{path}: dof must be a number > 0 and at most {MAX_DOF:g}, not {keys['dof']!r}"
        raise DataError(msg)
    return kind, dof


def _size(path: str) -> int:
    try:
        return os.stat(path).st_size
    except OSError:
        return 0  # read_bytes says what is wrong


def _keys(text: str, path: str) -> dict[str, str]:
    """The ``# key: value`` comment lines of the known keys (others are comments)."""
    out: dict[str, str] = {}
    for n, line in enumerate(text.splitlines(), 1):
        m = _KEY_LINE.match(line.strip()[:limits.MAX_CSV_FIELD_BYTES])
        if m is None or m.group(1).lower() not in KEYS:
            continue
        key, value = m.group(1).lower(), printable(m.group(2))
        if key == "certificate":   # a number: refused, not escaped (enctools.data.text)
            check_identifier(m.group(2), f"{path}: line {n}: certificate")
        if key in out and out[key] != value:
            msg = f"{path}: line {n}: {key} is stated twice ({out[key]!r}, {value!r})"
            raise DataError(msg)
        out[key] = value
    ref = out.get("reference", "mean").lower()
    if ref not in REFERENCES:
        msg = f"{path}: reference must be {' or '.join(REFERENCES)}, not {ref!r}"
        raise DataError(msg)
    out["reference"] = ref
    if "unit" in out:
        out["unit"] = _unit(out["unit"], path, "the unit line")
    return out


def _unit(text: str, path: str, where: str) -> str:
    unit = ALIASES.get(text.strip().lower())
    if unit not in ANGLE_UNITS:
        msg = f"{path}: {where} says {text!r}: not an angle unit ({', '.join(ANGLE_UNITS)})"
        raise DataError(msg)
    return unit


def _role(title: str) -> str | None:
    name, _ = title_unit(title)
    if name in _FACE:
        return "face"
    if name in _ERROR:
        return "error"
    if name in _EXPANDED or (name == "u" and title.strip().startswith("U")):
        return "expanded"
    if name in _STANDARD or name == "u":
        return "standard"
    return None


def _columns(raw: RawTable) -> dict[str, Any]:
    """Column index of face, error and u (standard or expanded: ``expanded`` holds it)."""
    found: dict[str, int] = {}
    for i, title in enumerate(raw.titles):
        role = _role(title)
        if role is not None and role in found:
            msg = (f"{raw.source}: columns {printable(raw.titles[found[role]])!r} and "
                   f"{printable(title)!r} both give the {role} column")
            raise DataError(msg)
        if role is not None:
            found[role] = i
    if "expanded" in found and "standard" in found:
        msg = f"{raw.source}: both U and u columns; give the expanded (U, with k) or the standard"
        raise DataError(msg)
    missing = [r for r in ("face", "error") if r not in found]
    if missing or not ({"expanded", "standard"} & set(found)):
        titles = ", ".join(repr(printable(t)) for t in raw.titles)
        msg = (f"{raw.source}: a polygon certificate needs the columns face, error and U "
               f"(expanded, with k) or u (standard); columns found: {titles}")
        raise DataError(msg)
    u = found.get("expanded", found.get("standard"))
    return {"face": found["face"], "error": found["error"], "u": u,
            "expanded": (u,) if "expanded" in found else ()}


def _units(raw: RawTable, cols: dict[str, Any], keys: dict[str, str], given: str | None
           ) -> dict[str, str]:
    """The unit of the error and u columns: the title's, else the file's, else ``given``."""
    if given is not None and "unit" in keys and keys["unit"] != given:
        msg = (f"{raw.source}: the certificate says unit {keys['unit']}, "
               f"`certificate_unit` {given} (mixed units)")
        raise DataError(msg)
    out = {}
    for role in ("error", "u"):
        title = raw.titles[cols[role]]
        _, in_title = title_unit(title)
        if in_title is not None:
            in_title = _unit(in_title, raw.source, f"column {printable(title)!r}")
        file_unit = keys.get("unit", given)
        if in_title is not None and file_unit is not None and in_title != file_unit:
            msg = (f"{raw.source}: column {printable(title)!r} is in {in_title}, the "
                   f"certificate's unit {file_unit} (mixed units)")
            raise DataError(msg)
        out[role] = in_title or file_unit or "arcsec"
    return out


def _values(raw: RawTable, col: int, unit: str | None) -> np.ndarray:
    """A column as numbers (in arcsec when ``unit`` is given); a cell that is not a
    finite number, or in another unit, is refused naming its line."""
    title = printable(raw.titles[col])
    out = np.empty(len(raw))
    for i, cell in enumerate(raw.columns[col]):
        if isinstance(cell, str):
            parsed = cell_unit(cell)
            if parsed is None:
                msg = f"{raw.source}: {raw.where(i)}, column {title!r}: {printable(cell)!r} " \
                      "is not a number"
                raise DataError(msg)
            value, cell_u = parsed
            if unit is not None and cell_u is not None and cell_u != unit:
                msg = (f"{raw.source}: {raw.where(i)}, column {title!r}: {printable(cell)!r} "
                       f"is in {cell_u}, the column in {unit} (mixed units)")
                raise DataError(msg)
        else:
            value = float(cell)
        if not math.isfinite(value):
            msg = f"{raw.source}: {raw.where(i)}, column {title!r}: NaN or infinite"
            raise DataError(msg)
        out[i] = value
    return out * factor(unit, "arcsec") if unit is not None else out


def _k(keys: dict[str, str], path: str) -> float:
    if "k" not in keys:
        msg = f"{path}: a U column needs the coverage factor: a line '# k: 2'"
        raise DataError(msg)
    parsed = cell_unit(keys["k"])
    k = parsed[0] if parsed is not None and parsed[1] is None else float("nan")
    if not 0 < k <= MAX_K:
        msg = f"{path}: k must be a number > 0 and at most {MAX_K:g}, not {keys['k']!r}"
        raise DataError(msg)
    return k


def _face_order(raw: RawTable, face: np.ndarray, faces: int | None) -> tuple[np.ndarray, int]:
    """Rows in face order and the first face's number (0 or 1): every face once."""
    lo, hi = RANGES["polygon.faces"]
    for i, f in enumerate(face):
        if not float(f).is_integer():
            msg = f"{raw.source}: {raw.where(i)}: face {f:g} is not a whole number"
            raise DataError(msg)
    n = faces if faces is not None else face.size
    if faces is not None and face.size != faces:
        msg = f"{raw.source}: {face.size} faces; the polygon has {faces}"
        raise DataError(msg)
    if not lo <= n <= hi:
        msg = f"{raw.source}: {n} faces; a polygon has {int(lo)}..{int(hi)}"
        raise DataError(msg)
    values, counts = np.unique(face, return_counts=True)
    if (counts > 1).any():
        twice = int(values[counts > 1][0])
        rows = [raw.where(int(i)) for i in np.flatnonzero(face == twice)[:2]]
        msg = f"{raw.source}: face {twice} is listed twice ({rows[0]}, {rows[1]})"
        raise DataError(msg)
    got = {int(v) for v in values}
    first = 0 if 0 in got else 1
    missing, extra = sorted(set(range(first, first + n)) - got), sorted(got - set(
        range(first, first + n)))
    if missing or extra:
        what = f"face {missing[0]} is missing" if missing else f"face {extra[0]} is not one"
        msg = f"{raw.source}: {what}: faces are numbered 0..{n - 1} or 1..{n}"
        raise DataError(msg)
    return np.argsort(face, kind="stable"), first


def _check_values(raw: RawTable, error: np.ndarray, spread: np.ndarray,
                  order: np.ndarray) -> None:
    for j, (e, u) in enumerate(zip(error, spread, strict=True)):
        if abs(e) > MAX_FACE_ERROR_ARCSEC:
            msg = (f"{raw.source}: {raw.where(int(order[j]))}: face error {e:g} arcsec is "
                   f"beyond +-{MAX_FACE_ERROR_ARCSEC:g} arcsec")
            raise DataError(msg)
        if not 0 < u <= MAX_FACE_ERROR_ARCSEC:
            msg = (f"{raw.source}: {raw.where(int(order[j]))}: the uncertainty must be > 0 "
                   f"and at most {MAX_FACE_ERROR_ARCSEC:g} arcsec, not {u:g}")
            raise DataError(msg)


def _relative_to_mean(raw: RawTable, error: np.ndarray, spread: np.ndarray,
                      reference: str) -> np.ndarray:
    """The errors relative to their mean; a certificate relative to the mean must sum to
    about zero (its mean within the largest standard uncertainty), one relative to its
    first face must give that face 0 (within the same)."""
    tol = float(spread.max())
    if reference == "mean" and abs(error.mean()) > tol:
        msg = (f"{raw.source}: the face errors' mean is {error.mean():.4g} arcsec, not about 0 "
               f"(within u {tol:.3g} arcsec) as a certificate relative to the mean has it; "
               "one relative to its first face says '# reference: first'")
        raise DataError(msg)
    if reference == "first" and abs(error[0]) > tol:
        msg = (f"{raw.source}: reference first, but the first face's error is "
               f"{error[0]:.4g} arcsec, not 0")
        raise DataError(msg)
    return error - error.mean()


def certificate_text(error_arcsec: np.ndarray, u_arcsec: np.ndarray, number: str,
                     traceability: str, comments: tuple[str, ...] = (),
                     type_a_dof: float | None = None) -> str:
    """A certificate in the format :func:`read_certificate` reads: faces from 0, errors
    relative to their mean and standard uncertainties [arcsec]; ``type_a_dof``: the
    uncertainties are a Type A evaluation on that many degrees of freedom."""
    lines = [f"# {c}" for c in comments]
    lines += [f"# certificate: {number}", f"# traceability: {traceability}",
              "# reference: mean", "# unit: arcsec"]
    if type_a_dof is not None:
        lines += ["# type: A", f"# dof: {type_a_dof:g}"]
    lines += ["face,error,u"]
    lines += [f"{j},{e:.6f},{u:.6f}" for j, (e, u) in enumerate(zip(error_arcsec, u_arcsec,
                                                                     strict=True))]
    return "\n".join(lines) + "\n"
