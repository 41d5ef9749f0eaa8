"""The data options of the one-file commands (``identify``, ``segment``): one table of
them, the decorator that gives a command all of them, and their ``data:`` section.

Each option sets the ``data:`` key of its name (``--time-unit`` -> ``data.time_unit``), so
the command line and a config say the same thing and are checked by the same models: a
key the file's format does not take, or two that exclude each other, is one line naming
the option. Nothing here imports the loaders until a command runs.
"""

from __future__ import annotations

import functools
import inspect
from pathlib import Path
from typing import Annotated

import typer

from ..errors import UserError

_PANEL = "Data (see README: Input formats)"


def _option(decl: str, help: str) -> typer.models.OptionInfo:
    return typer.Option(decl, help=help, rich_help_panel=_PANEL)


#: (parameter, type, option): the data options, in the order ``--help`` shows them.
DATA_OPTIONS: tuple[tuple[str, object, typer.models.OptionInfo], ...] = (
    ("input", str, _option("--input", "input column, by name or 0-based position "
                           "(MCAP: /topic:field)")),
    ("output", str, _option("--output", "output column, by name or 0-based position "
                            "(MCAP: /topic:field)")),
    ("format", str | None, _option("--format", "csv (also tsv, txt, text), dat, mat, xlsx, parquet "
                                   "(feather, arrow) or mcap; default: from the suffix")),
    ("time", str | None, _option("--time", "time column, by name or 0-based position: "
                                 "numbers (in --time-unit) or date-times")),
    ("sample_time", float | None, _option("--sample-time", "time between rows when there is "
                                          "no time column (in --time-unit)")),
    ("time_unit", str | None, _option("--time-unit", "unit of the time column: s, ms, min, h "
                                      "(default: the header's, else s)")),
    ("time_zone", str | None, _option("--time-zone", "zone of date-times without offset, "
                                      "e.g. Europe/Berlin (default: UTC)")),
    ("time_format", str | None, _option("--time-format", "layout of date-times that are not "
                                        "ISO-8601, e.g. '%d.%m.%Y %H:%M:%S'")),
    ("delimiter", str | None, _option("--delimiter", "comma, semicolon, tab or whitespace "
                                      "(default: detected)")),
    ("decimal", str | None, _option("--decimal", "decimal mark, . or , (default: detected)")),
    ("header", bool | None, _option("--header/--no-header", "whether the first row names the "
                                    "columns (default: detected)")),
    ("sheet", str | None, _option("--sheet", "xlsx sheet, by name or 0-based position "
                                  "(default: the first)")),
    ("duplicates", str | None, _option("--duplicates", "rows that repeat a time stamp: error "
                                       "(default), mean or first")),
    ("fill_gaps", int | None, _option("--fill-gaps", "fill drop-outs of up to N empty rows "
                                      "(input held, output interpolated); default 0")),
    ("long_gaps", str | None, _option("--long-gaps", "longer drop-outs: error (default) or "
                                      "keep_longest")),
    ("skip_rows", int | None, _option("--skip-rows", "the first N lines are not data (a "
                                      "banner); default: such lines found and skipped")),
    ("trailing_lines", str | None, _option("--trailing-lines", "lines after the data that "
                                           "are not data: error (default) or skip")),
    ("unwrap", float | None, _option("--unwrap", "period of an output that wraps (a counter, "
                                     "an angle: 360), unwrapped")),
    ("initial_input", float | None, _option("--initial-input", "input level before the "
                                            "first row")),
    ("setpoint", str | None, _option("--setpoint", "a closed loop's setpoint column: the "
                                     "input is then the controller output, and the "
                                     "running controller is read off the log")),
    ("units", str | None, _option("--units", "units of the signals, e.g. input=V,output=degC "
                                  "(default: from the header, if it gives them)")),
)

#: the options that are not ``data:`` format keys
_COMMON = ("input", "output", "format", "initial_input", "setpoint", "units")


def _units(text: str | None) -> dict[str, str] | None:
    """``input=V,output=degC`` -> ``{"input": "V", "output": "degC"}``."""
    if text is None:
        return None
    out = {}
    for item in (x.strip() for x in text.split(",") if x.strip()):
        key, sep, value = item.partition("=")
        if not sep or key.strip() not in ("input", "output", "time") or not value.strip():
            raise UserError(f"--units {text!r}: expected input=UNIT,output=UNIT (and "
                            "time=UNIT), e.g. input=V,output=degC")
        out[key.strip()] = value.strip()
    return out


def flag(key: str) -> str:
    """The command-line option of a data key: ``time_unit`` -> ``--time-unit``."""
    return "--" + key.replace("_", "-")


def with_data_options(command):
    """Give ``command`` every option of :data:`DATA_OPTIONS` in place of its ``data``
    parameter, which it receives as the ``data:`` section of its ``file`` argument."""
    sig = inspect.signature(command, eval_str=True)
    extra = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, annotation=Annotated[
        kind, option], default=inspect.Parameter.empty if name in ("input", "output") else None)
        for name, kind, option in DATA_OPTIONS]
    own = [p for p in sig.parameters.values() if p.name != "data"]

    @functools.wraps(command)
    def wrapper(**kwargs):
        given = {name: kwargs.pop(name) for name, _, _ in DATA_OPTIONS}
        return command(**kwargs, data=data_config(kwargs["file"], given))

    wrapper.__signature__ = sig.replace(parameters=[*own, *extra])
    return wrapper


def data_config(file: Path, given: dict):
    """The ``data:`` section of a one-file command; the file's format (``--format``, else
    its suffix) says how ``--input``/``--output`` name a signal and which options apply."""
    from pydantic import ValidationError

    from ..io import DataConfig, does_not_apply, format_of, options_for

    if Path(file).is_dir():
        raise UserError(f"{file}: is a folder; expected a log file (a folder of logs goes "
                        "in a config's data.path)")
    fmt = format_of(file, given["format"])
    keys = {k: v for k, v in given.items() if v is not None and k not in _COMMON}
    for key in keys:
        if key not in fmt.keys:
            raise UserError(f"{file}: {flag(key)} {does_not_apply(key, fmt)}")
    if "time" in fmt.keys and not {"time", "sample_time"} & set(keys):
        raise UserError(f"{file}: give --time COLUMN or --sample-time SECONDS")
    try:
        data = DataConfig(path=str(file), format=given["format"],
                          input=fmt.parse_signal(given["input"]),
                          output=fmt.parse_signal(given["output"]),
                          initial_input=given["initial_input"], units=_units(given["units"]),
                          setpoint=None if given["setpoint"] is None else
                          fmt.parse_signal(given["setpoint"]),
                          **keys)
    except ValidationError as exc:
        err0 = exc.errors()[0]
        raise UserError(f"{flag(str(err0['loc'][0]))}: {err0['msg']} "
                        f"(got {err0.get('input')!r})") from None
    options_for(data, fmt, str(file), label=flag)
    return data
