"""Text from files shown as it is, never obeyed: the one rule for every reader.

Some characters make text read other than it is: the C0 and C1 controls and DEL (a
terminal obeys them: cursor moves, colours, titles), the line and paragraph separators
(U+2028, U+2029 and NEL, U+0085: a new line where none is seen in the file), the
bidirectional controls (U+202A-U+202E, U+2066-U+2069, U+200E, U+200F, U+061C: "AE23-1009"
shown as "9001-32EA") and the zero-width characters (U+200B-U+200D, U+2060, U+FEFF: two
names that look the same and are not). These are :data:`DECEPTIVE`.

- An identifier (a rig's, an encoder's or a head's name, a serial or certificate number,
  a customer's name; enc-rig(5), enc-certificate(5)) that holds one is refused:
  :func:`check_identifier`, one DataError line naming the field and the character.
- Free text (descriptions, addresses, remarks, history lines) is shown with each one
  escaped, ``\\u202e``, ``\\x1b``: :func:`printable` on a terminal (a line breaks no
  line), :func:`escaped` in the HTML and the PDF (line breaks and tabs kept).
"""

from __future__ import annotations

from typing import Any

from enctools.errors import DataError

_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
_BIDI = (0x061C, 0x200E, 0x200F, *range(0x202A, 0x202F), *range(0x2066, 0x206A))
_ZERO_WIDTH = (*range(0x200B, 0x200E), 0x2060, 0xFEFF)
#: the code points that make text read other than it is: C0 controls, DEL, C1 controls
#: (NEL among them), the line and paragraph separators, bidi controls, zero-width ones
DECEPTIVE = frozenset((*range(0x20), 0x7F, *range(0x80, 0xA0), 0x2028, 0x2029, *_BIDI,
                       *_ZERO_WIDTH))


def _escape(code: int) -> str:
    ch = chr(code)
    return _NAMED.get(ch, f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}")


#: the surrogates: no characters; U+DC80-U+DCFF are the bytes of a name that is not
#: UTF-8 (a Latin-1 file name), as Python decodes it (PEP 383), shown as those bytes
SURROGATES = range(0xD800, 0xE000)
# every deceptive character -> its escape (the terminal's); the documents keep \n, \t
_TABLE = {c: _escape(c) for c in DECEPTIVE} | {
    c: f"\\x{c - 0xDC00:02x}" if 0xDC80 <= c <= 0xDCFF else f"\\u{c:04x}" for c in SURROGATES}
_DOCUMENT = {c: e for c, e in _TABLE.items() if chr(c) not in "\n\t"}


def printable(s: str) -> str:
    """``s`` with every deceptive character (newline too) replaced by its escape
    (``\\x1b``, ``\\u202e``), and a byte of a name that is not UTF-8 as that byte
    (``\\xe9``).

    For one line of text made of values read from a file (rig descriptions, history
    lines, column names, units) on a terminal: nothing in it can move the cursor, clear
    the screen, set a window title, start a line of its own or reverse what follows.
    """
    return s.translate(_TABLE)


def printable_lines(lines: list[str]) -> str:
    """``lines`` made printable one by one, joined by newlines."""
    return "\n".join(printable(line) for line in lines)


def escaped(s: str) -> str:
    """``s`` as a document shows free text: every deceptive character escaped as
    :func:`printable` does, but line breaks and tabs kept (an address's lines)."""
    return s.translate(_DOCUMENT)


def escaped_all(value: Any) -> Any:
    """``value`` with :func:`escaped` applied to every string in it, through dicts,
    lists and tuples (a document's data, as its template reads it); other values as
    they are."""
    if isinstance(value, str):
        return escaped(value)
    if isinstance(value, dict):
        return {k: escaped_all(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(escaped_all(v) for v in value)
    return value


def first_deceptive(s: str) -> str | None:
    """The first deceptive character (or surrogate) of ``s``, or None."""
    return next((ch for ch in s if ord(ch) in DECEPTIVE or ord(ch) in SURROGATES), None)


def character_name(ch: str) -> str:
    """``U+202E (RIGHT-TO-LEFT OVERRIDE)``; a control character without a Unicode name
    as ``U+001B (a control character)``."""
    import unicodedata

    code = ord(ch)
    what = ("a byte that is not UTF-8" if 0xDC80 <= code <= 0xDCFF else "a surrogate"
            if code in SURROGATES else unicodedata.name(ch, "a control character"))
    return f"U+{code:04X} ({what})"


def check_identifier(value: str, where: str) -> str:
    """``value``, once it holds no deceptive character; else a DataError naming
    ``where`` (the file and the field) and the character.

    An identifier is one line of text that names or numbers a thing (a serial number, a
    rig's or a head's name): no line break, no control, bidi or zero-width character.
    """
    ch = first_deceptive(value)
    if ch is not None:
        msg = (f"{where} holds the character {character_name(ch)}, which is refused in "
               "names and numbers (controls, line separators, bidi and zero-width "
               "characters)")
        raise DataError(msg)
    return value


def first_line(exc: BaseException, limit: int = 200) -> str:
    """The first line of an exception's message, at most ``limit`` characters, for an
    error line of our own (its type's name when the message is empty). Not escaped:
    :func:`printable` it when it may carry a file's bytes."""
    text = str(exc).strip()
    return text.splitlines()[0][:limit] if text else type(exc).__name__
