"""What a memory table's file says of itself: its layout and, by its content, its format.

enc make-rom heads every table with what enc correct needs to read it back
(:class:`Layout`: the code's bits n, the word width, the LSB in counts, the sample point,
the byte order of a binary image), where the format allows:

- a comment's first line (mif, coe, mem, acs, siemens): :func:`comment_line`,
  read back by :func:`from_comment`;
- a sidecar ``NAME-metadata.json`` beside the file (csv: W3C CSV on the Web metadata,
  whose ``url`` names the table; ihex, whose records have no place for text): the same
  layout under ``enctools.table`` (:func:`sidecar`, :func:`from_sidecar`);
- nowhere in a raw image (bin): the reader gives the layout (enc correct: options, and
  the code's bits from the rig of the stream corrected).

:func:`identify` names the format of a table file whose name does not, from content
that only that format has.
"""

from __future__ import annotations

import json
import os
import re
from dataclasses import asdict, dataclass
from typing import Any

from enctools.data.csvio import CSVW_CONTEXT, sidecar_path
from enctools.data.header import load_metadata
from enctools.data.limits import MAX_METADATA_BYTES
from enctools.errors import DataError
from enctools.units import TWO_PI, factor

#: the first comment line (older files end after ``arcsec``)
COMMENT = re.compile(r"enctools make-rom: (\d+) entries, (\d+)-bit signed corrections to add "
                     r"to a (\d+)-bit code, LSB ([-+0-9.eE]+) arcsec"
                     r"(?: = ([-+0-9.eE]+) counts)?(?:, sampled at the (centre|start))?")


@dataclass(frozen=True)
class Layout:
    """A memory table's layout, as its file states it.

    entries : 2**m words. code_bits : n, bits of the code. width : word width [bit].
    lsb : counts of the code per LSB of a word. sample : ``centre`` or ``start`` of each
    address's codes (None: not stated). endian : byte order of a binary image (None: a
    format of words, or not stated).
    """

    entries: int
    code_bits: int
    width: int
    lsb: float
    sample: str | None = None
    endian: str | None = None

    @property
    def lsb_arcsec(self) -> float:
        """One LSB [arcsec]: ``lsb`` counts of 360 deg / 2**n."""
        return self.lsb * TWO_PI * factor("rad", "arcsec") / 2.0 ** self.code_bits

    @property
    def address_bits(self) -> int:
        return self.entries.bit_length() - 1


def comment_line(layout: Layout) -> str:
    """The first comment line of a table file (:data:`COMMENT` reads it back)."""
    return (f"enctools make-rom: {layout.entries} entries, {layout.width}-bit signed "
            f"corrections to add to a {layout.code_bits}-bit code, LSB "
            f"{layout.lsb_arcsec!r} arcsec = {layout.lsb!r} counts"
            + (f", sampled at the {layout.sample}" if layout.sample else ""))


def from_comment(text: str) -> Layout | None:
    """The layout a table's comment states (its first 4 KiB), or None. Files of older
    versions state the LSB in arcsec only: the counts follow from it."""
    m = COMMENT.search(text[:4096])
    if m is None:
        return None
    entries, width, bits = int(m.group(1)), int(m.group(2)), int(m.group(3))
    if m.group(5) is not None:
        lsb = float(m.group(5))
    else:
        lsb = float(m.group(4)) / (TWO_PI / 2.0 ** bits * factor("rad", "arcsec"))
    return Layout(entries, bits, width, lsb, m.group(6))


def sidecar(layout: Layout, fmt: str, url: str, comment: list[str]) -> bytes:
    """The sidecar of a table file named ``url`` (relative): for csv, CSVW metadata of its
    two columns; for both, the layout and the comment lines under ``enctools.table``."""
    doc: dict[str, Any] = {}
    if fmt == "csv":
        doc = {"@context": CSVW_CONTEXT, "url": url,
               "dialect": {"delimiter": ",", "header": True, "lineTerminators": ["\n"]},
               "tableSchema": {"columns": [
                   {"name": "address", "titles": "address", "datatype": "long"},
                   {"name": "correction", "titles": "correction", "datatype": "long",
                    "dc:description": "signed correction to add to the code [LSB]"}]}}
    else:
        doc = {"url": url}
    table = {"format": fmt, **asdict(layout), "lsb_arcsec": layout.lsb_arcsec,
             "comment": comment}
    doc["enctools"] = {"table": table}
    return (json.dumps(doc, indent=1) + "\n").encode()


def sidecar_doc(path: str) -> dict[str, Any] | None:
    """The JSON document beside ``path`` (``path-metadata.json``), or None when there is
    none; DataError when it is there but not a JSON object within the metadata limits
    (its size and nesting checked before it is parsed, as a stream's header is)."""
    side = sidecar_path(path)
    if not os.path.isfile(side):
        return None
    try:
        with open(side, "rb") as f:
            raw = f.read(MAX_METADATA_BYTES + 1)
    except OSError as exc:
        msg = f"{side}: not a readable sidecar ({type(exc).__name__})"
        raise DataError(msg) from None
    return load_metadata(raw, side)


def is_table_sidecar(doc: dict[str, Any] | None) -> bool:
    """Whether a sidecar describes a table of enc make-rom (not a stream)."""
    own = doc.get("enctools") if doc else None
    return isinstance(own, dict) and isinstance(own.get("table"), dict)


def from_sidecar(path: str) -> Layout | None:
    """The layout the sidecar beside ``path`` states, or None without a table's sidecar
    (DataError when its layout is malformed)."""
    doc = sidecar_doc(path)
    if not is_table_sidecar(doc):
        return None
    assert doc is not None
    t = doc["enctools"]["table"]
    try:
        layout = Layout(int(t["entries"]), int(t["code_bits"]), int(t["width"]),
                        float(t["lsb"]), t.get("sample"), t.get("endian"))
    except (KeyError, TypeError, ValueError) as exc:
        msg = f"{sidecar_path(path)}: the table's layout is malformed ({exc!r})"
        raise DataError(msg) from None
    if layout.sample not in (None, "centre", "start") or \
            layout.endian not in (None, "little", "big"):
        msg = f"{sidecar_path(path)}: the table's sample or endian is not one enctools writes"
        raise DataError(msg)
    return layout


def has_sidecar(fmt: str) -> bool:
    """Whether a table of format ``fmt`` states its layout in a sidecar beside it."""
    from enctools.models.romformats import registry

    found = registry.find(fmt)
    return found is not None and found.layout_in == "sidecar"


def identify(head: bytes) -> str | None:
    """The table format whose content a file's first bytes (``head``, up to 4 KiB) have
    (its record's ``signature``: SINUMERIK's ``$AA_ENC_COMP[``, ACS's ``ERRORMAP1D``, COE's
    ``memory_initialization_radix``, MIF's ``DEPTH=``, the CSV header
    ``address,correction``, ``$readmemh`` text headed by ``//`` comments and ``@0``, Intel
    HEX records), or None. A raw image has no content of its own."""
    from enctools.models.romformats import registry

    for fmt in registry.records():
        if fmt.signature is not None and fmt.signature.search(head):
            return fmt.name
    return None
