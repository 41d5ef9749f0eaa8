"""Loaders: one module per input format, all returning :class:`~pipeline.record.Record`.

The formats (:mod:`.registry`): ``csv`` (:mod:`.delimited`: delimited text, ``.csv``,
``.tsv``, ``.txt``), ``dat`` (:mod:`.dat`: DaISy's whitespace numbers, no header), ``mat``
(:mod:`.mat`), ``xlsx`` (:mod:`.excel`), ``parquet`` (:mod:`.columnar`: Parquet and Arrow
IPC) and ``mcap`` (:mod:`.mcap`). Each module says which ``data:`` keys it takes in its
options model; the tabular formats share :class:`~.table.TableOptions` (the time base of
:mod:`.timebase` and the quirk policies of :mod:`.quirks`) and the step from a table to a
record (:mod:`.table`). :mod:`.options` builds the config's ``data:`` section from them and
rejects a key of another format. :mod:`.align` puts two separately sampled signals onto
one grid.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..record import Record, with_setpoint
from .base import DataSection, Format, SignalConfig
from .datasets import dataset, fetch, load_registry, shown_source
from .mcap import format_inspect, inspect_mcap
from .native import panic_text_held
from .options import DataConfig, check_file, check_section, does_not_apply, options_for
from .paths import files_named
from .registry import FORMATS, SUFFIXES, find_format, format_of


def load_record(path: Path, data: DataSection, name: str | None = None) -> Record:
    """Load one file as a Record following a ``data:`` section (:data:`DataConfig`).

    The format is ``data.format``, else the file's suffix; a key of another format is a
    :class:`UserError`, as is every problem with the file.
    """
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{path}: is a folder; expected a log file (a folder of logs goes in "
                        "a config's data.path)")
    if not path.is_file():
        raise UserError(f"{path}: file not found")
    fmt = format_of(path, data.format)
    try:
        with panic_text_held():
            record = fmt.load(path, data, options_for(data, fmt, str(path)),
                              name or path.stem)
            return record if data.setpoint is None else _with_setpoint(path, data, fmt,
                                                                       record)
    except BaseException as exc:
        # a native reader's panic (polars, pyo3: a BaseException, which no `except
        # Exception` stops) on a damaged file it does not check is the file's fault
        if type(exc).__name__ != "PanicException":
            raise
        raise UserError(f"{path}: the {fmt.name} reader failed on this file (a damaged "
                        f"file? {' '.join(str(exc).split())[:200]})") from None


def _with_setpoint(path: Path, data: DataSection, fmt: Format, record: Record) -> Record:
    """``record`` with the setpoint ``data.setpoint`` read from the same file: the file
    loaded again with the setpoint as its input, by the same loader and policies (so every
    format that reads an input reads a setpoint, and a row the policies drop or merge is
    dropped or merged for both); the time stamps must come out the same, but for a
    topic of its own (MCAP), which is held onto the record's grid as the input is."""
    again = data.model_copy(update={"input": data.setpoint, "setpoint": None,
                                    "initial_input": None})
    try:
        other = fmt.load(path, again, options_for(again, fmt, str(path)), record.name)
    except UserError as exc:  # the loader names the column as the input's: say which key
        raise UserError(f"{exc} (reading data.setpoint)") from None
    for role, signal in (("input", record.input_name), ("output", record.output_name)):
        if other.input_name == signal:
            raise UserError(f"{path}: data.setpoint {shown_signal(data.setpoint)} is the "
                            f"{role} itself; expected the closed loop's setpoint beside "
                            "the controller output (the input) and the measurement")
    if np.array_equal(other.t, record.t):
        return with_setpoint(record, other.u, other.input_name)
    if not isinstance(data.setpoint, SignalConfig):  # a table's rows are the same rows
        raise UserError(f"{path}: data.setpoint {shown_signal(data.setpoint)} is read on "
                        f"other time stamps ({other.t.size} rows) than the input "
                        f"({record.t.size}); expected the setpoint logged beside the "
                        "input and output")
    # a topic of its own (MCAP): held from its previous value onto the record's grid, as
    # the input is (a setpoint holds until it is changed); before its first value, that
    # value, with a note
    k = np.searchsorted(other.t, record.t, side="right") - 1
    held = other.u[np.maximum(k, 0)]
    out = with_setpoint(record, held, other.input_name)
    if k[0] < 0:
        out = replace(out, notes=(*out.notes, f"setpoint {other.input_name}: its first value "
                                  f"(at t = {float(other.t[0]):.6g} s) is taken as held "
                                  "before it"))
    return out


def shown_signal(signal) -> str:
    """A signal as a config names it: a column in quotes, or ``topic field``."""
    if isinstance(signal, SignalConfig):
        return f"{signal.topic} {signal.field}"
    return repr(signal)


__all__ = ["FORMATS", "SUFFIXES", "DataConfig", "Format", "Record", "SignalConfig", "check_file",
           "check_section", "does_not_apply", "fetch", "files_named", "find_format",
           "dataset", "format_inspect", "format_of", "inspect_mcap", "load_record", "shown_source",
           "load_registry", "options_for"]
