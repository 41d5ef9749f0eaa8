"""The ``pipeline`` logger: what a run tells the user on stderr besides errors.

Levels (``pipeline run``): ``--quiet`` ERROR (errors only, no progress bar); default
WARNING; ``--verbose`` INFO (each record's stages and time, each report step's time).
Stdout carries only the summary lines. Messages go through one rich console on stderr so
that they print above a live progress bar instead of through it.
"""

from __future__ import annotations

import logging
from functools import cache

from .quoting import printable

#: --quiet, default, --verbose
LEVELS = {"quiet": logging.ERROR, "normal": logging.WARNING, "verbose": logging.INFO}


@cache
def console():
    """The one rich console on stderr (progress bars and log lines share it)."""
    from rich.console import Console

    return Console(stderr=True, highlight=False, soft_wrap=True)


def logger(name: str) -> logging.Logger:
    """A child of the ``pipeline`` logger (pass ``__name__``)."""
    return logging.getLogger(name if name.startswith("pipeline") else f"pipeline.{name}")


def configure(verbosity: str = "normal") -> None:
    """Send the ``pipeline`` logger's messages at ``verbosity`` (:data:`LEVELS`) to stderr,
    one plain line each (``pipeline: <message>``); configured once, later calls set the
    level."""
    root = logging.getLogger("pipeline")
    root.setLevel(LEVELS[verbosity])
    handler = next((h for h in root.handlers if isinstance(h, _ConsoleHandler)), None)
    if handler is None:
        handler = _ConsoleHandler()
        root.addHandler(handler)
        root.propagate = False
    handler.setLevel(LEVELS[verbosity])
    # numpy's and scipy's RuntimeWarnings (an overflow inside a fit of extreme data, a
    # badly conditioned filter) are not the user's error lines: --verbose shows them
    logging.captureWarnings(True)
    warned = logging.getLogger("py.warnings")
    warned.propagate = False
    if handler not in warned.handlers:
        warned.addHandler(handler)
    warned.setLevel(logging.WARNING if verbosity == "verbose" else logging.ERROR)


class _ConsoleHandler(logging.Handler):
    def emit(self, record: logging.LogRecord) -> None:
        try:
            console().print(f"pipeline: {printable(record.getMessage())}", markup=False)
        except Exception:  # logging must never break a run
            self.handleError(record)
