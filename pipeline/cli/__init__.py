"""The ``pipeline`` command (Typer): one module per command group, one error handler;
the guard that tells a failed write to stdout from other errors (for ``__main__``).
"""

from .commands import app
from .output import StdoutError, guard_stdout, report_stdout_failure

__all__ = ["StdoutError", "app", "guard_stdout", "report_stdout_failure"]
