"""User text inside our messages and outputs: quoted short, shown literally.

Two helpers, used wherever a message or an output shows what a user wrote (a config value,
a file, column or topic name):

* :func:`quoted` is a bounded ``repr``: a value of any size (a YAML alias bomb expands to
  billions of items behind a few hundred bytes) is quoted in at most ``limit`` characters,
  and building the quote costs no more than that (:mod:`reprlib` stops at its limits
  instead of building the whole ``repr`` and cutting it).
* :func:`printable` makes control characters visible (``\\x1b``): a terminal escape
  sequence in a file name must not recolour or rewrite the terminal, and XML 1.0 forbids
  most C0 characters (https://www.w3.org/TR/xml/#charsets), so the same text is safe on
  stderr, in report.md and in the JUnit file.
"""

from __future__ import annotations

import re
import reprlib

#: How many characters a quoted value takes at most in a message.
QUOTE_LIMIT = 80

_REPR = reprlib.Repr()
_REPR.maxlevel = 2
_REPR.maxlist = _REPR.maxtuple = _REPR.maxset = _REPR.maxfrozenset = _REPR.maxdeque = 4
_REPR.maxdict = 4
_REPR.maxstring = QUOTE_LIMIT
_REPR.maxother = QUOTE_LIMIT
_REPR.maxlong = 40

# C0 and C1 controls, DEL, lone surrogates (an undecodable file name byte), the two
# non-characters XML forbids, and the bidirectional overrides that reorder a terminal line.
_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\ud800-\udfff\ufffe\uffff"
                          "\u202a-\u202e\u2066-\u2069]")
_UNPRINTABLE_KEEP_LINES = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\ud800-\udfff"
                                     "\ufffe\uffff\u202a-\u202e\u2066-\u2069]")


def shorten(text: str, limit: int = QUOTE_LIMIT) -> str:
    """``text`` cut to at most ``limit`` characters, keeping its start and its end."""
    if len(text) <= limit:
        return text
    head = max(limit - 3, 2) * 2 // 3
    tail = max(limit - 3 - head, 0)
    return text[:head] + "..." + (text[-tail:] if tail else "")


def quoted(value: object, limit: int = QUOTE_LIMIT) -> str:
    """A short ``repr`` of a user's value for a message: at most ``limit`` characters,
    in time and memory bounded by the limit, whatever the value holds."""
    return printable(shorten(_REPR.repr(value), limit))


def _escape(match: re.Match) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def printable(text: str, *, lines: bool = False) -> str:
    """``text`` with control characters written as escapes (``\\x1b``, ``\\x07``,
    ``\\udcff``); with ``lines`` newlines, carriage returns and tabs are kept."""
    pattern = _UNPRINTABLE_KEEP_LINES if lines else _UNPRINTABLE
    return pattern.sub(_escape, str(text))
