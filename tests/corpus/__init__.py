"""The hostile-input corpus: tests as data (issue 13).

Each module ``tests/corpus/<area>.py`` holds ``CASES: list[Hostile]``; one parametrised test
(``tests/test_corpus.py``) runs every row through the real CLI, in process, in a fresh
folder, and checks what a platform team relies on: the exit code, at most
``Hostile.max_lines`` stderr lines, no traceback, no temporary folder left behind, the
user's own files kept (``keep``) and, where a row says so, its own check.

A row's ``files`` are written into the case folder first (``str`` as UTF-8, ``bytes`` as
is; a name may hold a folder), then its ``links``: symbolic links, name -> target as
``os.symlink`` takes it (relative to the link's folder; ``{d}`` is the case folder), so a
dangling link, a loop of links and a link to ``.`` can be rows too. ``absent`` are
substrings that neither stdout nor stderr may hold (a secret the row planted). ``args``
are the CLI arguments after ``pipeline``; ``{d}`` in an argument is replaced by the case
folder. The CLI runs with the case folder as the working directory.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Hostile:
    kind: str                                  # unique id, the test's name
    args: tuple[str, ...]                      # after `pipeline`; {d} is the case folder
    code: int                                  # the expected exit code
    files: dict[str, str | bytes] = field(default_factory=dict)
    stderr: tuple[str, ...] = ()               # substrings the stderr must hold
    keep: tuple[str, ...] = ()                 # files (from `files`) that must be unchanged
    max_lines: int = 3                         # stderr lines at most
    check: Callable[[Path], None] | None = None  # more assertions on the case folder
    links: dict[str, str] = field(default_factory=dict)  # symbolic links: name -> target
    absent: tuple[str, ...] = ()               # substrings stdout and stderr must not hold


def step_csv(*, K: float = 2.0, T: float = 5.0, dt: float = 0.5, n: int = 400,
             header: str = "time,u,y", sep: str = ",", seed: int = 0,
             steps: tuple[tuple[float, float], ...] = ((20.0, 1.0), (110.0, 0.0))) -> str:
    """A first-order plant (gain K, lag T) driven by input steps ``(time, new level)``,
    white noise of 0.01 * K, from u = 0, y = 0; rendered as CSV text with ``header``."""
    t = np.arange(n) * dt
    u = np.zeros(n)
    for at, level in steps:
        u[t >= at] = level
    a = np.exp(-dt / T)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = a * y[k - 1] + K * (1 - a) * u[k - 1]
    y += np.random.default_rng(seed).normal(0, 0.01 * K, n)
    lines = [header] + [sep.join(f"{v:.6g}" for v in row) for row in zip(t, u, y, strict=True)]
    return "\n".join(lines) + "\n"


def config(data: str, *, name: str = "hostile", extra: str = "") -> str:
    """A run config whose ``data:`` section is the given YAML text (indented for you)."""
    body = "\n".join("  " + line for line in data.strip().splitlines())
    return f"name: {name}\ndata:\n{body}\nmethods: [first_order]\n{extra}"
