"""Text from files made safe for a terminal: control characters shown, never obeyed."""

from __future__ import annotations

_NAMED = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
# C0 controls, DEL and C1 controls (U+0080-U+009F) -> a visible repr-style escape.
_TABLE = {c: _NAMED.get(chr(c), f"\\x{c:02x}")
          for c in (*range(0x20), 0x7F, *range(0x80, 0xA0))}


def printable(s: str) -> str:
    """``s`` with every control character (newline too) replaced by its escape (``\\x1b``).

    For one line of text made of values read from a file (rig descriptions, history
    lines, column names, units): nothing in it can move the cursor, clear the screen,
    set a window title or start a line of its own.
    """
    return s.translate(_TABLE)


def printable_lines(lines: list[str]) -> str:
    """``lines`` made printable one by one, joined by newlines."""
    return "\n".join(printable(line) for line in lines)


def first_line(exc: BaseException, limit: int = 200) -> str:
    """The first line of an exception's message, at most ``limit`` characters, for an
    error line of our own (its type's name when the message is empty). Not escaped:
    :func:`printable` it when it may carry a file's bytes."""
    text = str(exc).strip()
    return text.splitlines()[0][:limit] if text else type(exc).__name__
