"""The laboratory's fields of a calibration certificate: a certificate file (TOML).

A certificate file (enc report's, FILE.toml) says who the certificate is for and what
was calibrated, where and when, under which conditions, against which reference
standards and who approves it (ISO/IEC 17025:2017 clause 7.8); a number given apart
(``certificate_number``) overrides the file's per run. Every key is documented in
enc-certificate(5). An unknown table or key, a value of the wrong type or out of its
range is one DataError line naming the file and the key, raised before the report is
built (no partial output).

Temperatures are in degC, humidity in % (relative).
"""

from __future__ import annotations

import datetime as _dt
import itertools
import math
from dataclasses import dataclass, field
from typing import Any

from enctools.data.files import read_small_text
from enctools.data.text import character_name, check_identifier
from enctools.errors import DataError

#: the largest certificate file read [bytes]
MAX_BYTES = 65536
#: the longest text value [characters]
MAX_TEXT = 2000
#: the most reference standards listed
MAX_REFERENCES = 50
#: the longest certificate number [characters] (it heads every page)
MAX_NUMBER = 64

DATE = "date"
TEXT = "text"
#: the range of each number key [its unit]
RANGES = {"air_temperature_c": (-50.0, 100.0), "material_temperature_c": (-50.0, 100.0),
          "humidity_percent": (0.0, 100.0)}

#: table -> key -> the type of its value (text, date or number)
SCHEMA: dict[str, dict[str, str]] = {
    "certificate": {"number": TEXT, "title": TEXT, "issued": DATE, "statement": TEXT},
    "laboratory": {"name": TEXT, "address": TEXT, "accreditation": TEXT},
    "customer": {"name": TEXT, "address": TEXT, "order": TEXT},
    "item": {"description": TEXT, "manufacturer": TEXT, "model": TEXT, "serial": TEXT,
             "received": DATE, "condition": TEXT},
    "calibration": {"date": DATE, "location": TEXT, "operator": TEXT, "remarks": TEXT,
                    "procedure": TEXT},
    "specification": {"name": TEXT, "limits": TEXT},
    "environment": {"air_temperature_c": "number", "material_temperature_c": "number",
                    "humidity_percent": "number", "remarks": TEXT},
    "reference": {"name": TEXT, "serial": TEXT, "certificate": TEXT, "due": DATE,
                  "traceability": TEXT, "quantity": TEXT},
    "approval": {"name": TEXT, "function": TEXT},
}
#: the keys that name or number a thing (a serial number, a customer, a standard's
#: certificate): one line, refused when they hold a character that reads other than it
#: is (enctools.data.text.check_identifier); every other text key is free text, shown
#: with such characters escaped (enc-certificate(5), TEXT)
IDENTIFIERS = frozenset({
    "[certificate] number", "[laboratory] name", "[laboratory] accreditation",
    "[customer] name", "[customer] order", "[item] manufacturer", "[item] model",
    "[item] serial", "[calibration] operator", "[reference] name", "[reference] serial",
    "[reference] certificate", "[reference] quantity", "[calibration] procedure",
    "[approval] name",
    "[approval] function", "number"})


@dataclass
class Certificate:
    """The lab's fields: each table of the file as a dict of its keys' values (text,
    ``datetime.date`` or float), the reference standards as a list of such dicts."""

    number: str = ""
    fields: dict[str, dict[str, Any]] = field(default_factory=dict)
    references: list[dict[str, Any]] = field(default_factory=list)
    source: str = ""

    def get(self, table: str, key: str) -> Any:
        """The value of ``key`` in ``table``, or None when the file does not give it."""
        return self.fields.get(table, {}).get(key)

    def table(self, table: str) -> dict[str, Any]:
        """Every key given in ``table``."""
        return dict(self.fields.get(table, {}))


def load_certificate(path: str | None, number: str | None = None) -> Certificate | None:
    """The certificate of ``path`` (None: none), its number replaced by ``number`` when
    given; None when neither is given (the document is then a calibration report).

    Raises DataError (one line naming the file and the key) for a file that cannot be
    read, is not TOML, or has an unknown key or a value of the wrong type or range;
    the number given apart (``certificate_number``) is checked as the file's key is.
    """
    if path is None and number is None:
        return None
    cert = Certificate(source=f"certificate file {path}" if path else "`certificate_number`")
    if path is not None:
        import tomllib  # here: a report without a certificate file never parses TOML

        text = read_small_text(path, f"certificate file {path}", MAX_BYTES,
                               "a certificate file")
        try:
            raw = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            msg = f"certificate file {path}: not valid TOML: {exc}"
            raise DataError(msg) from None
        except RecursionError:
            msg = f"certificate file {path}: tables nested too deep"
            raise DataError(msg) from None
        _parse(raw, cert, f"certificate file {path}")
        check_dates(cert, f"certificate file {path}")
    if number is not None:
        cert.number = _value(number, TEXT, "`certificate_number`", "number")
    if not cert.number or len(cert.number) > MAX_NUMBER or "\n" in cert.number:
        msg = (f"{cert.source}: no certificate number ([certificate] number of the file, "
               f"or `certificate_number`: one line of at most {MAX_NUMBER} characters)")
        raise DataError(msg)
    return cert


#: the certificate's dates in the order they must come: (table, key, what it is)
DATES = (("item", "received", "the item was received"),
         ("calibration", "date", "it was calibrated"),
         ("certificate", "issued", "the certificate is issued"))


def check_dates(cert: Certificate, where: str) -> None:
    """One date model: the item received, then calibrated, then the certificate issued
    (each on or after the one before). DataError naming both keys otherwise."""
    given = [(f"[{t}] {k}", cert.get(t, k), what) for t, k, what in DATES
             if cert.get(t, k) is not None]
    for (key_a, a, what_a), (key_b, b, what_b) in itertools.pairwise(given):
        if b < a:
            msg = (f"{where}: {key_b} {b.isoformat()} is before {key_a} {a.isoformat()}: "
                   f"{what_b} on or after {what_a}")
            raise DataError(msg)


def _parse(raw: dict[str, Any], cert: Certificate, where: str) -> None:
    for table, body in raw.items():
        if table not in SCHEMA:
            msg = f"{where}: unknown table [{table}] (tables: {', '.join(SCHEMA)})"
            raise DataError(msg)
        if table == "reference":
            if not isinstance(body, list) or not all(isinstance(b, dict) for b in body):
                msg = f"{where}: reference standards are [[reference]] tables"
                raise DataError(msg)
            if len(body) > MAX_REFERENCES:
                msg = f"{where}: {len(body)} [[reference]] tables, more than {MAX_REFERENCES}"
                raise DataError(msg)
            cert.references = [_keys(b, table, where) for b in body]
            continue
        if not isinstance(body, dict):
            msg = f"{where}: [{table}] must be a table of keys, not a {_type(body)}"
            raise DataError(msg)
        cert.fields[table] = _keys(body, table, where)
    cert.number = cert.fields.get("certificate", {}).get("number", "")


def _keys(body: dict[str, Any], table: str, where: str) -> dict[str, Any]:
    out = {}
    for key, value in body.items():
        kind = SCHEMA[table].get(key)
        if kind is None:
            msg = (f"{where}: unknown key {key!r} in [{table}] "
                   f"(keys: {', '.join(SCHEMA[table])})")
            raise DataError(msg)
        out[key] = _value(value, kind, where, f"[{table}] {key}")
    return out


def _value(value: Any, kind: str, where: str, key: str) -> Any:
    """A value checked against its kind (and range): text, date or number."""
    if kind == TEXT:
        if not isinstance(value, str):
            msg = f"{where}: {key} must be text, not a {_type(value)}"
            raise DataError(msg)
        if key in IDENTIFIERS:
            check_identifier(value, f"{where}: {key}")
        control = next((ch for ch in value if ord(ch) < 32 and ch != "\n"), None)
        if len(value) > MAX_TEXT or control is not None:
            found = f" ({character_name(control)})" if control else ""
            msg = (f"{where}: {key}: at most {MAX_TEXT} characters, no control characters "
                   f"but line breaks{found}")
            raise DataError(msg)
        return value.strip()
    if kind == DATE:
        if isinstance(value, _dt.date) and not isinstance(value, _dt.datetime):
            return value
        if isinstance(value, str):
            try:
                return _dt.date.fromisoformat(value)
            except ValueError:
                pass
        msg = f"{where}: {key} must be a date (2026-11-30), not {_shown(value)}"
        raise DataError(msg)
    name = key.rsplit(" ", 1)[-1]
    lo, hi = RANGES[name]
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) or not lo <= value <= hi:
        msg = f"{where}: {key} must be a number from {lo:g} to {hi:g}, not {_shown(value)}"
        raise DataError(msg)
    return float(value)


def _type(value: Any) -> str:
    return {str: "text", bool: "boolean", int: "integer", float: "number", list: "array",
            dict: "table"}.get(type(value), type(value).__name__)


def _shown(value: Any) -> str:
    text = repr(value) if isinstance(value, (str, int, float)) else f"a {_type(value)}"
    return text if len(text) <= 40 else text[:37] + "..."
