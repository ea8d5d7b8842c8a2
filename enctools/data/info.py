"""A plain-text description of a stream: kind, columns with units, rows, history."""

from __future__ import annotations

from typing import Any

from enctools.data.schemas import field_meta
from enctools.data.streams import InputStream
from enctools.data.text import printable_lines


def describe(stream: InputStream) -> str:
    """Read through a stream and describe it in a few lines (like ``ncdump -h``).

    Every value from the file is shown with its control characters escaped
    (:func:`enctools.data.text.printable`): a line of the description is one line.
    """
    rows = 0
    batches = 0
    for b in stream.batches():
        rows += b.num_rows
        batches += 1
    h = stream.header
    lines = [f"{stream.source}: {h.kind} stream (schema v{h.meta.get('schema_version', '?')}, "
             f"{stream.format}), {rows} rows in {batches} batches"]
    rig = h.meta.get("rig")
    if isinstance(rig, dict):
        lines.append(f"  rig: {rig.get('name')} — {rig.get('description', '')}".rstrip(" —"))
    if "mode" in h.meta:
        lines.append(f"  mode: {h.meta['mode']}")
    lines.append("  columns:")
    written = written_units(stream)
    for f in h.schema:
        fm = field_meta(f)
        unit = fm.pop("unit", "")
        role = fm.pop("role", "")
        extra = ", ".join(f"{k}={v}" for k, v in fm.items())
        if f.name in written:  # the file holds it in another unit than the stream reads
            title, held = written[f.name]
            unit = f"{held} in the file as {title}, read in {unit}"
        desc = f"    {f.name:<12} {f.type!s:<8} [{unit}]"
        if role:
            desc += f" {role}"
        if extra:
            desc += f" ({extra})"
        lines.append(desc)
    keys = [k for k in h.meta if k not in ("history", "kind", "schema_version")]
    lines.append(f"  metadata: {', '.join(keys) or '-'}")
    lines.append("  history:")
    lines += [f"    {line}" for line in h.history] or ["    -"]
    return printable_lines(lines)


def written_units(stream: InputStream) -> dict[str, tuple[str, str]]:
    """Column -> (its title, the unit the file holds it in) of a CSV or TSV stream's
    columns written in another unit than the stream reads them in
    (:func:`enctools.data.csvio.written_units`); {} for the other formats."""
    from enctools.data.csvio import written_units as in_file

    if stream.format not in ("CSV", "TSV") or stream.source == "stdin":
        return {}
    return in_file(stream.source)


def info_dict(stream: InputStream) -> dict[str, Any]:
    """A stream described as a dict for enc info's JSON (enc-streams(5), SUMMARIES):
    source, kind, schema version, format, rows and batches read, the rig's name, the
    mode, each column with its type, unit, role and other field metadata, the keys of
    the stream metadata and the history lines."""
    rows = batches = 0
    for b in stream.batches():
        rows += b.num_rows
        batches += 1
    h = stream.header
    columns = []
    written = written_units(stream)
    for f in h.schema:
        fm = field_meta(f)
        columns.append({"name": f.name, "type": str(f.type), "unit": fm.pop("unit", ""),
                        "role": fm.pop("role", ""), "metadata": fm})
        if f.name in written:
            columns[-1] |= {"title": written[f.name][0], "written_unit": written[f.name][1]}
    rig = h.meta.get("rig")
    return {"source": stream.source, "kind": h.kind,
            "schema_version": h.meta.get("schema_version"), "format": stream.format,
            "n_rows": rows, "n_batches": batches,
            "rig": rig.get("name") if isinstance(rig, dict) else None,
            "mode": h.meta.get("mode"), "columns": columns,
            "metadata_keys": [k for k in h.meta if k not in ("history", "kind",
                                                             "schema_version")],
            "history": list(h.history)}
