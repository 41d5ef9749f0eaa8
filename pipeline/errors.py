"""Exceptions the library raises and the exit codes the CLI maps them to (DESIGN.md).

The library never calls ``sys.exit``; user errors carry one line that names the
file, the line or the config key, and what was expected.
"""

from enum import IntEnum

from .quoting import printable, shorten


class ExitCode(IntEnum):
    """The exit-code contract of the ``pipeline`` command (one place for it)."""

    OK = 0  #: done
    REGRESSION = 1  #: a model or its validation error drifted past a baseline's tolerance
    USER_ERROR = 2  #: bad input or config (one line on stderr), or every record failed
    SOME_FAILED = 3  #: a batch in which some records failed (the report lists them)
    #: the reader of stdout went away (``pipeline ... | head -1``): 128 + SIGPIPE, what a
    #: shell reports for a command SIGPIPE ended; never 1, which a gate reads as a regression
    BROKEN_PIPE = 141


class UserError(Exception):
    """Bad input or configuration: exit code 2, one line on stderr, no traceback."""

    exit_code = ExitCode.USER_ERROR

    #: A message is cut (its start and end kept) past this many characters: one line,
    #: whatever a file or a config quotes into it (:func:`pipeline.quoting.quoted` keeps
    #: the quoted values short in the first place).
    MAX_LENGTH = 2000

    def __init__(self, message: str) -> None:
        super().__init__(message)
        # line breaks and tabs folded (one line), every other control character written
        # as an escape (a \x0b or \r in a file name is named as such, not as a space)
        text = " ".join(printable(" ".join(message.split("\n")).replace("\t", " ")).split())
        self.message = shorten(text, self.MAX_LENGTH)


class NotApplicable(Exception):
    """Raised inside a method when the event does not have the shape it needs.

    The method registry turns it into a ``Fit`` with status ``not_applicable``;
    it never escapes :func:`pipeline.methods.identify`.
    """

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason
