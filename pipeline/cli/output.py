"""The terminal side of the ``pipeline`` command: the consoles, tables that stay whole in
pipes and CI logs (:func:`show`), ``--json`` (:func:`print_json`), the one error line,
and the ranking ``identify`` prints (:func:`print_ranking`)."""

from __future__ import annotations

import errno
import sys
from typing import Annotated

import typer
from rich import box as rich_box
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from ..quoting import printable


class _Console(Console):
    """rich's console, but a closed stdout is a :class:`BrokenPipeError` for
    :func:`handled` (rich's own handler exits 1, the regression code)."""

    def on_broken_pipe(self) -> None:
        self.quiet = True
        raise BrokenPipeError


out = _Console(highlight=False, soft_wrap=True)
err = _Console(stderr=True, highlight=False, soft_wrap=True)


class StdoutError(OSError):
    """Standard output could not take what was written (a full device, ``> /dev/full``; a
    quota; an I/O error), told apart from a failing file of the run by the stream that
    raised it (:func:`guard_stdout`)."""


class _GuardedStdout:
    """``sys.stdout`` whose write errors are :class:`StdoutError` (a closed pipe stays a
    :class:`BrokenPipeError`); everything else is the stream's own."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text):
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise StdoutError(exc.errno, exc.strerror) from None

    def flush(self):
        try:
            return self._stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise StdoutError(exc.errno, exc.strerror) from None

    def __getattr__(self, name):
        return getattr(self._stream, name)


class _ClosedStdout:
    """``sys.stdout`` when the command was started with it closed (``>&-``): every write
    is a :class:`StdoutError` (the output has nowhere to go: one line and exit 2, not
    an AttributeError on None or a silent exit 0); flushing nothing is no error."""

    encoding = "utf-8"

    def write(self, text):
        if text:
            raise StdoutError(errno.EBADF, "it is closed (started with >&-); redirect it to "
                              "a file or /dev/null instead")
        return 0

    def flush(self):
        return None

    def isatty(self):
        return False

    def fileno(self):
        return 1


def guard_stdout() -> None:
    """Wrap ``sys.stdout`` (the ``pipeline`` command does, first thing) so a failed write
    to it is a :class:`StdoutError`; a stdout the command was started without (closed:
    ``None``) fails each write (:class:`_ClosedStdout`), a missing stderr writes to
    /dev/null. (The command's entry point holds the closed descriptors on /dev/null
    before anything opens a file: ``pipeline.__main__``.)"""
    import os

    if sys.stderr is None:
        sys.stderr = open(os.devnull, "w", encoding="utf-8")  # noqa: SIM115 - for life
    if sys.stdout is None:
        sys.stdout = _ClosedStdout()
    elif not isinstance(sys.stdout, _GuardedStdout | _ClosedStdout):
        sys.stdout = _GuardedStdout(sys.stdout)


def report_stdout_failure(exc: OSError) -> None:
    """The one line for a :class:`StdoutError`; stdout then points at /dev/null so that
    the exit's flush of what is left does not fail again."""
    stdout_to_devnull()
    error_line(f"cannot write standard output: {exc.strerror}")

#: Off a terminal a table is as wide as its content, up to this many columns: complete
#: lines that a pipe, grep or a CI log keeps whole (a CI log's 80 columns cut flag codes,
#: field paths and URLs in the middle).
PLAIN_WIDTH = 10_000


def show(tab: Table) -> None:
    """Print a table: on a terminal at its width, identifier columns kept whole
    (:func:`keep_whole`); off a terminal (a pipe, a file, a CI log) with ASCII rules at
    its natural width, so no cell wraps and every line is complete."""
    if out.is_terminal:
        out.print(tab)
        return
    tab.box = rich_box.ASCII
    natural = out.measure(tab, options=out.options.update_width(PLAIN_WIDTH)).maximum
    width = out.width  # print(width=...) is capped at the console's own width
    out.width = max(width, min(natural, PLAIN_WIDTH))
    try:
        out.print(tab)
    finally:
        out.width = width


def keep_whole(tab: Table, column: int, cells: list[str]) -> None:
    """Identifiers never wrap: column ``column`` is at least as wide as the longest word
    of ``cells`` (a method id, a flag code, a field path, a URL), the other columns
    give way."""
    words = [w for c in cells for w in str(c).split()]
    if words:
        tab.columns[column].min_width = max(tab.columns[column].min_width or 0,
                                            max(len(w) for w in words))


def stdout_to_devnull() -> None:
    """Point stdout at /dev/null so that the interpreter's last flush of the unread output
    does not raise again at exit (the Python documentation's recipe, ``signal`` module
    notes on SIGPIPE)."""
    import os

    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout is not a file descriptor (a test runner)
        pass
    finally:
        os.close(devnull)


def error_line(message: str) -> None:
    """One ``error: ...`` line on stderr, control characters from file and topic names
    shown as escapes (a terminal escape sequence in a name reaches the terminal inert)."""
    err.print(f"error: {printable(message)}", markup=False)


def plain_error_line(message: str) -> None:
    """:func:`error_line` without rich: out of memory, where rendering the line through
    rich could fail on its own (it imports its emoji table on first use: under
    ``ulimit -v 1200000`` that import was the MemoryError's traceback, exit 1)."""
    try:
        sys.stderr.write(f"error: {printable(message)}\n")
        sys.stderr.flush()
    except (OSError, ValueError, MemoryError):  # nowhere left to say it
        pass


JsonOption = Annotated[bool, typer.Option("--json", help="print JSON to stdout")]


def print_json(doc: object) -> None:
    """``--json``: the command's rows as one JSON document on stdout."""
    import json

    sys.stdout.write(json.dumps(doc, indent=1, default=str) + "\n")


VERDICT_STYLE = {"ok": "bold green", "info": "dim", "warning": "bold yellow",
                 "unreliable": "bold red",
                 "failed": "bold red"}


def rich_table(t, columns: list[str] | None = None, title: str = "") -> Table:
    """A report table (:class:`pipeline.report.tables.Table`) for the terminal, with only
    ``columns`` (by name) when given; verdicts in colour, the recommended row bold."""
    keep = [k for k, c in enumerate(t.columns) if columns is None or c in columns]
    verdicts = [k for k in keep if t.rows and t.rows[0][k].kind == "verdict"]
    tab = Table(title=title or None,
                caption="* the recommended model" if t.highlight is not None else None)
    for k in keep:
        tab.add_column(t.columns[k], no_wrap=t.columns[k] in ("method", "verdict"))
    if verdicts:
        tab.add_column("flags", overflow="fold")
    for j, k in enumerate(keep):  # no word of a cell split, no number cut
        keep_whole(tab, j, [row[k].text for row in t.rows])
    if verdicts:
        keep_whole(tab, len(keep), [row[verdicts[0]].note.replace(",", " ") for row in t.rows])
    for r, row in enumerate(t.rows):
        cells = []
        for k in keep:
            c = row[k]
            style = VERDICT_STYLE.get(c.text) if c.kind == "verdict" else None
            text = escape(printable(c.text))
            if r == t.highlight and k == keep[0]:
                text += " *"
            cells.append(f"[{style}]{text}[/]" if style else text)
        if verdicts:
            cells.append(escape(printable(row[verdicts[0]].note)).replace(", ", " "))
        tab.add_row(*cells, style="bold" if r == t.highlight else None)
    return tab


def print_ranking(res) -> None:
    """The recommended model first (units, intervals, verdict, flags), then each event's
    ranking with verdicts: the same tables as the report."""
    from ..grading import CRITERION_COLUMNS, criterion
    from ..report import PARAMETERS_COLUMN, ranking_table, recommended_box

    box = recommended_box(res)
    if box is not None:
        style = VERDICT_STYLE.get(box["verdict"], "bold")
        out.print(f"Recommended model for {escape(printable(res.name))}: "
                  f"[{style}]{box['verdict']}[/]")
        out.print(f"  G(s) = {box['tf']}   ({box['method']}, event {box['event']}; "
                  f"{box['scores']})", markup=False)
        show(rich_table(box["params"]))
        for f in box["flags"]:
            out.print(f"  [{VERDICT_STYLE[f['severity']]}]{f['code']}[/] "
                      f"{escape(printable(f['message']))}")
        out.print(f"  why: {box['reason']}", markup=False)
        if res.tuning is not None:
            from ..report import controller_lines

            for line in controller_lines(res.tuning):
                out.print(printable(line), markup=False)
    else:
        out.print(f"No model recommended for {escape(printable(res.name))}: "
                  f"[{VERDICT_STYLE['unreliable']}]unreliable[/]")
        for f in res.flags:
            out.print(f"  [{VERDICT_STYLE[f.severity]}]{f.code}[/] {escape(printable(f.message))}")
    if res.loop is not None:
        from ..report import running_loop_lines

        for line in running_loop_lines(res.loop, res.record.units, res.recommended):
            out.print(printable(line), markup=False)
    has_val = bool(res.validation_events)
    for i in res.identification_events:
        table = ranking_table(res, i)
        crit = CRITERION_COLUMNS[criterion(res)]  # the one the recommendation decided by
        columns = ["rank", "method", "verdict", PARAMETERS_COLUMN, crit] + (
            ["fit % (valid.)"] if has_val else [])
        show(rich_table(table, columns,
                        title=escape(printable(f"{res.name}: event {i}, ranked by {crit}"))))
        for f in res.fits:
            if f.event == i and not f.ok:
                out.print(printable(f"  {f.method}: {f.status}: {f.reason}"), markup=False)
