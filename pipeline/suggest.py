"""The nearest name to a typo, for user-error lines (issue 29): ``did you mean 'Q1'?``.

A name that differs only in case wins (``q1`` for ``Q1``); else the closest by
:func:`difflib.get_close_matches` (the standard library's Ratcliff-Obershelp ratio, cutoff
0.6), compared in lower case.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def nearest(word: str, choices: Iterable[str]) -> str | None:
    """The choice ``word`` most likely meant, or None when none is close."""
    names = [str(c) for c in choices]
    folded = [n for n in names if n.casefold() == word.casefold() and n != word]
    if folded:
        return folded[0]
    lower = {n.lower(): n for n in reversed(names)}
    close = difflib.get_close_matches(word.lower(), list(lower), n=1, cutoff=0.6)
    return lower[close[0]] if close and lower[close[0]] != word else None


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """``" (did you mean 'x'?)"`` for the nearest choice, else an empty string."""
    hit = nearest(word, choices)
    return f" (did you mean {hit!r}?)" if hit is not None else ""
