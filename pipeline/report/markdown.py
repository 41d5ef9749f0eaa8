"""Escaping for report.md, as Jinja's autoescape does for report.html.

The Markdown template's environment applies :func:`md_text` to every ``{{ ... }}`` it
outputs (its ``finalize``), so a record, column, unit or file name, a title or an error
reaches report.md as text: it cannot open HTML (``<script>``, ``<img onerror>``) in a
previewer that renders HTML, break a table row (``|``, a newline), close a code span
(a backtick) or become a link. What the template marks as already escaped
(:class:`markupsafe.Markup`: a macro's output piped through ``safe``, :func:`md_code`)
passes through unchanged.

Rules from CommonMark 0.31 (https://spec.commonmark.org/0.31.2/): backslash escapes of
ASCII punctuation (section 2.4), entity references (2.5), code spans (6.1: a fence
longer than any backtick run inside); and GitHub Flavored Markdown tables
(https://github.github.com/gfm/#tables-extension-: a ``|`` in a cell, even inside a
code span, is written ``\\|``).
"""

from __future__ import annotations

import re

from markupsafe import Markup

from ..quoting import printable

_TEXT = str.maketrans({"\\": "\\\\", "`": "\\`", "|": "\\|", "<": "&lt;", ">": "&gt;",
                       "&": "&amp;", "\n": " ", "\r": " ", "\t": " "})
_TICKS = re.compile("`+")


def md_text(value) -> Markup:
    """``value`` as inline Markdown text that shows literally (see the module docstring);
    ``Markup`` (already escaped) is returned as is. ``](`` is broken up so that text in
    brackets cannot become a link or an image."""
    if isinstance(value, Markup):
        return value
    text = printable(str(value)).translate(_TEXT).replace("](", "]\\(")
    return Markup(text)


def md_code(value, *, table: bool = True) -> Markup:
    """``value`` as a Markdown code span: a fence longer than its longest backtick run,
    padded when it starts or ends with a backtick; ``|`` escaped in a ``table`` cell (GFM
    reads it as a cell border even inside a code span; outside a table the backslash
    would show)."""
    text = printable(str(value))  # one line: a newline is written \x0a
    longest = max((len(m) for m in _TICKS.findall(text)), default=0)
    fence = "`" * (longest + 1)
    if text.startswith("`") or text.endswith("`") or (text.startswith(" ") and
                                                      text.endswith(" ") and text.strip()):
        text = f" {text} "
    if table:
        text = text.replace("|", "\\|")
    return Markup(f"{fence}{text}{fence}")


def finalize(value) -> Markup:
    """The Markdown environment's ``finalize``: every output escaped unless marked safe."""
    return md_text(value)


def finalize_html(value):
    """The HTML environment's ``finalize`` (autoescape does the rest): control characters
    shown as escapes; already escaped output (a macro's) passes."""
    return value if isinstance(value, Markup) else printable(str(value))
