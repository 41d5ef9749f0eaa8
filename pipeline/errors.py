"""Exceptions the library raises; the CLI maps them to exit codes (DESIGN.md).

The library never calls ``sys.exit``; user errors carry one line that names the
file, the line or the config key, and what was expected.
"""


class UserError(Exception):
    """Bad input or configuration: exit code 2, one line on stderr, no traceback."""

    exit_code = 2

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = " ".join(message.split())  # always one line


class NotApplicable(Exception):
    """Raised inside a method when the event does not have the shape it needs.

    The method registry turns it into a ``Fit`` with status ``not_applicable``;
    it never escapes :func:`pipeline.methods.identify`.
    """

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason
