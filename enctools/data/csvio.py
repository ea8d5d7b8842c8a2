"""CSV and TSV streams: a text table, header first, and its JSON sidecar (CSV on the Web).

A stream written as CSV (``x.csv``) or TSV (``x.tsv``) is two files:

- the table: one header line, then one line per row; no comment lines. A column's
  title is its name followed by ``_`` and its unit (``deviation`` in arcsec is
  ``deviation_arcsec``, ``theta`` in rad ``theta_rad``); a column without a unit keeps
  its name (``n``, ``run``). Floats in the shortest form that reads back to the same
  number (``nan``, ``inf`` spelt so), integers as integers, a string (or title) in
  quotes when it holds the delimiter, a quote or a line end (RFC 4180: ``"`` doubled
  inside); fields separated by ``,`` (CSV) or a tab (TSV); lines
  end with ``\\n``.
- the sidecar ``x.csv-metadata.json``: W3C CSV on the Web (CSVW) metadata describing the
  table (``@context``, ``url``, ``dialect``, ``tableSchema.columns`` with ``name``,
  ``titles``, ``datatype`` and the unit as ``schema:unitText``), and under the key
  ``enctools`` what the table cannot say: the kind, schema version, rows, each column's
  name, Arrow type and field metadata, and the stream's metadata (rig, settings, truth,
  history). Reading the table with its sidecar gives back the same stream.

The angle errors (columns whose field unit is arcsec) are written in the unit the writer is
given (the unit the command reports in) and read back into arcsec; other
columns keep their stream's unit. On stdout a table goes without its sidecar: the
metadata is then nowhere.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import pyarrow as pa

from enctools.data import files, limits
from enctools.data.header import META_KEY, Header, load_metadata
from enctools.data.text import first_line, printable
from enctools.errors import DataError, OutputError, SettingsError
from enctools.units import ANGLE_UNITS, DISPLAY_UNITS, factor

FORMATS = ("csv", "tsv")
DELIMITERS = {"csv": ",", "tsv": "\t"}
EXTENSIONS = {".csv": "csv", ".tsv": "tsv"}
#: appended to the table's name to name its sidecar (CSVW's ``{+url}-metadata.json``)
SIDECAR_SUFFIX = "-metadata.json"
CSVW_CONTEXT = "http://www.w3.org/ns/csvw"
#: the unit of the angle errors in the stream, and in a table unless told another
ERROR_UNIT = "arcsec"

#: Arrow type -> CSVW (XML Schema) datatype, for the types a stream's columns may have
_DATATYPES = {"double": "double", "float": "float", "int8": "byte", "int16": "short",
              "int32": "int", "int64": "long", "uint8": "unsignedByte",
              "uint16": "unsignedShort", "uint32": "unsignedInt", "uint64": "unsignedLong",
              "string": "string"}

def checked_sidecar_path(path: str) -> str:
    """The sidecar's path of the table ``path``; OutputError when its name would be
    longer than a file name may be (``files.NAME_MAX`` bytes)."""
    sidecar = sidecar_path(path)
    size = len(os.fsencode(Path(sidecar).name))
    if size > files.NAME_MAX:
        msg = (f"output {path}: its CSVW sidecar's name would be {size} bytes, over the "
               f"{files.NAME_MAX} a file name may have; give a name of at most "
               f"{files.NAME_MAX - len(SIDECAR_SUFFIX)} bytes")
        raise OutputError(msg, path)
    return sidecar


def sidecar_path(path: str | os.PathLike[str]) -> str:
    """The sidecar of a table file: ``x.csv`` -> ``x.csv-metadata.json``."""
    return os.fspath(path) + SIDECAR_SUFFIX


def title(name: str, unit: str) -> str:
    """A column's title in the header line: ``name_unit``, or ``name`` without a unit."""
    return f"{name}_{unit}" if unit else name


def _unit_of(field: pa.Field) -> str:
    return (field.metadata or {}).get(b"unit", b"").decode()


def written_unit(field: pa.Field, errors: str) -> str:
    """The unit a column is written in: ``errors`` for an angle error (float, arcsec),
    else the column's own unit."""
    unit = _unit_of(field)
    return errors if unit == ERROR_UNIT and pa.types.is_floating(field.type) else unit


def _csvw_name(text: str) -> str:
    """A title as a CSVW column name: characters other than A-Z a-z 0-9 _ percent-encoded
    (the name is a URI template variable)."""
    return "".join(c if re.fullmatch(r"[A-Za-z0-9_]", c) else
                   "".join(f"%{b:02X}" for b in c.encode()) for c in text)


# --------------------------------------------------------------------------- output


class TableWriter:
    """Writes a stream as a CSV or TSV table into ``target`` (a path, or a binary file
    such as stdout), header line first; the writer protocol of ``streams.OutputStream``.

    ``errors``: the unit the angle errors (field unit arcsec) are written in, one of
    ``DISPLAY_UNITS`` (the unit the command reports in). ``sidecar(url)`` gives the sidecar's
    bytes once every row is written.
    """

    def __init__(self, target: str | IO[bytes], header: Header, fmt: str,
                 errors: str = ERROR_UNIT) -> None:
        if errors not in DISPLAY_UNITS:
            msg = (f"`unit` {errors!r} is not a unit of angle errors "
                   f"(one of {', '.join(DISPLAY_UNITS)})")
            raise SettingsError(msg)
        self.fmt = fmt
        self.header = header
        self.rows = 0
        self._delimiter = DELIMITERS[fmt]
        self._units = [written_unit(f, errors) for f in header.schema]
        self._scale = [factor(_unit_of(f), u) if u != _unit_of(f) else 1.0
                       for f, u in zip(header.schema, self._units)]
        self.titles = [title(f.name, u) for f, u in zip(header.schema, self._units)]
        _check_titles(header.schema.names, self.titles)
        self._own = isinstance(target, str)
        self._f: IO[bytes] = open(target, "wb") if isinstance(target, str) else target  # noqa: SIM115
        line = self._delimiter.join(_quoted(t, self._delimiter) for t in self.titles)
        self._f.write(f"{line}\n".encode())

    def write_batch(self, batch: pa.RecordBatch) -> None:
        """Append the batch's rows: each value as text (Arrow's shortest round-trip form
        for floats), joined by the delimiter, one line a row."""
        import numpy as np
        import pyarrow.compute as pc

        if batch.num_rows == 0:
            return
        for name, c in zip(batch.schema.names, batch.columns):
            if c.null_count:
                msg = f"CSV output cannot hold missing values (column {name!r})"
                raise DataError(msg)
        texts = [_text(pc.multiply(c, pa.scalar(s, c.type)) if s != 1.0 else c, self._delimiter)
                 for c, s in zip(batch.columns, self._scale)]
        lines = pc.binary_join_element_wise(*texts, _large(self._delimiter))
        lines = pc.binary_join_element_wise(lines, _large(""), _large("\n"))  # line + "\n"
        offsets = np.frombuffer(lines.buffers()[1], dtype=np.int64)
        data = lines.buffers()[2]
        self._f.write(memoryview(data)[offsets[lines.offset]:offsets[lines.offset + len(lines)]])
        if not self._own:  # stdout: each batch as it comes (a terminal, a pipe to Miller)
            self._f.flush()
        self.rows += batch.num_rows

    def close(self) -> None:
        self._f.flush()
        if self._own:
            self._f.close()

    def sidecar(self, url: str) -> bytes:
        """The sidecar of the table written, whose file is named ``url`` (relative)."""
        meta = json.loads(self.header.arrow_schema().metadata[META_KEY])
        columns, described = [], []
        for f, unit, text in zip(self.header.schema, self._units, self.titles):
            typ = _type_name(f.type)
            col = {"name": _csvw_name(text), "titles": text, "datatype": _DATATYPES[typ]}
            if unit:
                col["schema:unitText"] = unit
            columns.append(col)
            described.append({"name": f.name, "type": typ,
                              "metadata": {k.decode(): v.decode()
                                           for k, v in (f.metadata or {}).items()}})
        doc = {"@context": CSVW_CONTEXT, "url": url,
               "dialect": {"delimiter": self._delimiter, "header": True, "doubleQuote": True,
                           "lineTerminators": ["\n"]},
               "tableSchema": {"columns": columns},
               "enctools": {"kind": meta.pop("kind"),
                            "schema_version": meta.pop("schema_version"),
                            "rows": self.rows, "columns": described, "metadata": meta}}
        # NaN as the stream's own metadata writes it (figures of too few points)
        return (json.dumps(doc, indent=1) + "\n").encode()


def stage(tmp: str, path: str, sidecar: bytes, force: bool,
          group: files.OutputGroup | None) -> None:
    """The complete table ``tmp`` renamed to ``path`` and its ``sidecar`` written beside
    it, both or neither: with ``group``'s other outputs, or now (OutputError naming
    ``path`` when either cannot be)."""
    together = files.OutputGroup() if group is None else group
    together.stage(tmp, path, force)
    try:
        together.write(sidecar_path(path), sidecar, force=force)
        if group is None:
            together.commit()
    except OutputError as exc:
        if group is None:
            together.discard()
        raise OutputError(exc.template, path) from None


def _text(column: pa.Array, delimiter: str) -> pa.Array:
    """A column as large strings the way the table holds them: numbers in Arrow's
    shortest round-trip form, strings quoted when they need it (:func:`_quoted`)."""
    import pyarrow.compute as pc

    if not (pa.types.is_string(column.type) or pa.types.is_large_string(column.type)):
        return pc.cast(column, pa.large_string())
    column = pc.cast(column, pa.large_string())
    special = "[" + re.escape(delimiter) + '"\n\r]'
    quoted = pc.binary_join_element_wise(_large('"'), pc.replace_substring(column, '"', '""'),
                                         _large('"'), _large(""))
    return pc.if_else(pc.match_substring_regex(column, special), quoted, column)


def _large(text: str) -> pa.Scalar:
    return pa.scalar(text, pa.large_string())


def _quoted(text: str, delimiter: str) -> str:
    """A field as RFC 4180 writes it: in quotes, ``"`` doubled, when it holds the
    delimiter, a quote or a line end (CR too)."""
    if any(c in text for c in (delimiter, '"', "\n", "\r")):
        return '"' + text.replace('"', '""') + '"'
    return text


def _type_name(t: pa.DataType) -> str:
    if pa.types.is_large_string(t) or pa.types.is_string(t):
        return "string"
    name = str(t)
    if name not in _DATATYPES:
        msg = f"CSV output cannot hold a column of type {t}"
        raise DataError(msg)
    return name


def _check_titles(names: list[str], titles: list[str]) -> None:
    """Two columns whose titles would be the same are refused (DataError)."""
    seen: dict[str, str] = {}
    for name, text in zip(names, titles):
        if text in seen:
            msg = (f"CSV output: columns {seen[text]!r} and {name!r} would both be titled "
                   f"{text!r}")
            raise DataError(msg)
        seen[text] = name


# ---------------------------------------------------------------------------- input


def text_format(path: str) -> str | None:
    """``csv`` or ``tsv`` when ``path`` is read as a text table: it has a sidecar (whose
    dialect says which), or its extension says so; None otherwise."""
    ext = EXTENSIONS.get(Path(path).suffix.lower())
    if os.path.isfile(sidecar_path(path)):
        return ext or "csv"
    return ext


def read_sidecar(path: str) -> dict[str, Any]:
    """The sidecar of the table at ``path``, within the metadata limits (DataError: none,
    not JSON, too large or deep)."""
    import stat

    side = sidecar_path(path)
    try:
        st = os.stat(side)
    except OSError:
        msg = (f"{path}: a CSV or TSV table is read as a stream with its sidecar "
               f"{side}, which is missing (without one, a table of points or of sin/cos "
               "signals is read by the commands that take one: enc-points(1), TABLES)")
        raise DataError(msg) from None
    if not stat.S_ISREG(st.st_mode):  # a FIFO would wait for a writer
        msg = f"{side}: not a regular file"
        raise DataError(msg)
    size = st.st_size
    if size > limits.MAX_METADATA_BYTES:
        msg = f"{side}: a sidecar of {size} bytes; at most {limits.MAX_METADATA_BYTES} are read"
        raise DataError(msg)
    try:
        with open(side, "rb") as f:
            return load_metadata(f.read(limits.MAX_METADATA_BYTES + 1), side)
    except OSError as exc:
        msg = f"{side}: cannot read: {exc.strerror}"
        raise DataError(msg) from None


class _Layout:
    """What a sidecar says of its table: fields, titles, written units, rows, metadata."""

    def __init__(self, doc: dict[str, Any], source: str) -> None:
        own = doc.get("enctools") if isinstance(doc, dict) else None
        if isinstance(own, dict) and "table" in own and "kind" not in own:
            msg = (f"{source}: the sidecar of a correction table of enc make-rom, not of a "
                   "stream (enc correct reads it as its correction table)")
            raise DataError(msg)
        try:
            self._parse(doc)
        except (KeyError, IndexError, TypeError, ValueError, AttributeError) as exc:
            msg = f"{source}: not an enctools CSV sidecar ({printable(first_line(exc))})"
            raise DataError(msg) from None
        if self.rows > limits.MAX_STREAM_ROWS:
            msg = f"{source}: claims {self.rows} rows; at most {limits.MAX_STREAM_ROWS} are read"
            raise DataError(msg)

    def _parse(self, doc: dict[str, Any]) -> None:
        own = doc["enctools"]
        csvw = doc["tableSchema"]["columns"]
        described = own["columns"]
        if not isinstance(csvw, list) or not isinstance(described, list):
            raise TypeError("columns are not lists")
        if len(csvw) != len(described):
            msg = f"{len(csvw)} CSVW columns but {len(described)} enctools columns"
            raise ValueError(msg)
        if len(csvw) > limits.MAX_COLUMNS:
            msg = f"{len(csvw)} columns; at most {limits.MAX_COLUMNS} are read"
            raise ValueError(msg)
        self.delimiter = str(doc.get("dialect", {}).get("delimiter", ","))
        if self.delimiter not in DELIMITERS.values():
            msg = f"delimiter {self.delimiter!r} is neither ',' nor a tab"
            raise ValueError(msg)
        self.fields, self.titles, self.units = [], [], []
        for c, d in zip(csvw, described):
            fm = {str(k): str(v) for k, v in d.get("metadata", {}).items()}
            t = _arrow_type(str(d["type"]))
            self.fields.append(pa.field(str(d["name"]), t, metadata=fm or None))
            text = c["titles"]
            self.titles.append(text if isinstance(text, str) else str(text[0]))
            self.units.append(str(c.get("schema:unitText", "")))
        if len(set(self.titles)) < len(self.titles):
            raise ValueError("two columns have the same title")
        self.rows = int(own["rows"])
        if self.rows < 0:
            raise ValueError("rows < 0")
        meta = dict(own.get("metadata", {}))
        meta["kind"] = str(own["kind"])
        meta["schema_version"] = int(own["schema_version"])
        self.meta = meta

    def check(self, source: str) -> None:
        """Each title is its column's name and written unit; each written unit the field's
        own, or an angle unit for an angle error (DataError otherwise)."""
        for f, text, unit in zip(self.fields, self.titles, self.units):
            own = _unit_of(f)
            convertible = own == ERROR_UNIT and unit in ANGLE_UNITS and pa.types.is_floating(f.type)
            if unit != own and not convertible:
                msg = (f"{source}: column {printable(text)!r} is in {printable(unit)!r}, "
                       f"its field in {printable(own)!r}")
                raise DataError(msg)
            if text != title(f.name, unit):
                msg = (f"{source}: the sidecar titles column {printable(f.name)!r} "
                       f"{printable(text)!r}, not {printable(title(f.name, unit))!r}")
                raise DataError(msg)


def written_units(path: str) -> dict[str, tuple[str, str]]:
    """Column -> (its title, the unit the file holds it in) of the CSV or TSV stream at
    ``path`` whose columns its writer wrote in another unit than the stream's (errors in
    urad: a deviation in arcsec written as ``deviation_urad``), from its sidecar."""
    layout = _Layout(read_sidecar(path), sidecar_path(path))
    out = {}
    for f, title, unit in zip(layout.fields, layout.titles, layout.units, strict=True):
        if unit and unit != _unit_of(f):
            out[f.name] = (title, unit)
    return out


def _arrow_type(name: str) -> pa.DataType:
    if name not in _DATATYPES:
        msg = f"column type {name!r} is not one of {', '.join(_DATATYPES)}"
        raise ValueError(msg)
    return pa.string() if name == "string" else pa.type_for_alias(name)


def open_table(f: IO[bytes], source: str) -> tuple[Header, Iterator[pa.RecordBatch], int,
                                                    Callable[[], None]]:
    """Open a CSV or TSV table with its sidecar: (Header, batches, rows it claims, closer).

    The header line must be the titles the sidecar gives, the file must end with a
    newline, and the rows must be as many as the sidecar says (DataError otherwise, when
    the batches are read).
    """
    layout = _Layout(read_sidecar(source), sidecar_path(source))
    layout.check(sidecar_path(source))
    header = Header(layout.meta["kind"], pa.schema(layout.fields), layout.meta)
    f.seek(0, os.SEEK_END)
    size = f.tell()
    if size:
        f.seek(size - 1)
        if f.read(1) != b"\n":
            msg = f"{source}: truncated (its last line does not end with a newline)"
            raise DataError(msg)
    # pyarrow's own file, not the Python one: reading a Python file object, pyarrow may
    # leave a read pending on one of its threads when a read fails (SIGABRT at exit)
    native = pa.OSFile(os.fsencode(f.name))

    def close() -> None:
        native.close()
        f.close()

    return header, _batches(native, layout, header.schema, source), layout.rows, close


def _reader(f: Any, layout: _Layout, schema: pa.Schema) -> Any:
    import pyarrow.csv as pcsv

    # newlines_in_values: a quoted field may hold a line end; it also holds a line to the
    # block's size (without it, a line of any length is read whole)
    return pcsv.open_csv(
        f, read_options=pcsv.ReadOptions(block_size=limits.MAX_CSV_LINE_BYTES,
                                         use_threads=False),
        parse_options=pcsv.ParseOptions(delimiter=layout.delimiter, newlines_in_values=True),
        convert_options=pcsv.ConvertOptions(
            column_types={t: x.type for t, x in zip(layout.titles, schema)}, null_values=[],
            strings_can_be_null=False, quoted_strings_can_be_null=False))


def _batches(f: Any, layout: _Layout, schema: pa.Schema,
             source: str) -> Iterator[pa.RecordBatch]:
    """The table's rows as batches of the stream's schema, angle errors back in arcsec."""
    import pyarrow.compute as pc

    scale = [factor(u, _unit_of(x)) if u != _unit_of(x) else 1.0
             for x, u in zip(schema, layout.units)]
    rows = 0
    try:
        reader = _reader(f, layout, schema)
        if reader.schema.names != layout.titles:
            got = ",".join(reader.schema.names)
            msg = (f"{source}: its header line {printable(got[:200])!r} is not the one its "
                   f"sidecar describes ({len(layout.titles)} columns "
                   f"{printable(','.join(layout.titles)[:200])!r})")
            raise DataError(msg)
        for b in reader:
            rows += b.num_rows
            if rows > layout.rows:
                break
            _check_text(b, source)
            arrays = [pc.multiply(c, pa.scalar(s, c.type)) if s != 1.0 else c
                      for c, s in zip(b.columns, scale)]
            yield pa.RecordBatch.from_arrays(arrays, schema=schema)
    except pa.ArrowException as exc:
        msg = f"{source}: not the CSV table its sidecar describes ({_arrow_message(exc)})"
        raise DataError(msg) from None
    if rows != layout.rows:
        msg = (f"{source}: {'over ' if rows > layout.rows else ''}{rows} rows, its sidecar "
               f"says {layout.rows} (truncated, or the sidecar of another table)")
        raise DataError(msg)


def _arrow_message(exc: BaseException) -> str:
    text = printable(first_line(exc))
    if "straddling" in text or ("block" in text and "size" in text):
        return f"a line over {limits.MAX_CSV_LINE_BYTES} bytes"
    return text


def _check_text(batch: pa.RecordBatch, source: str) -> None:
    """No string field over :data:`~enctools.data.limits.MAX_CSV_FIELD_BYTES`."""
    import pyarrow.compute as pc

    for name, col in zip(batch.schema.names, batch.columns):
        if pa.types.is_string(col.type) and len(col):
            longest = pc.max(pc.binary_length(col)).as_py() or 0
            if longest > limits.MAX_CSV_FIELD_BYTES:
                msg = (f"{source}: column {printable(name)!r} holds a field of {longest} "
                       f"bytes; at most {limits.MAX_CSV_FIELD_BYTES}")
                raise DataError(msg)
