"""The ``pipeline`` command (Typer): one module per command group, one error handler.
"""

from .commands import app

__all__ = ["app"]
