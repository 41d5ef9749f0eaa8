"""Loaders: one module per source format, all returning :class:`~pipeline.record.Record`."""

from __future__ import annotations

from pathlib import Path

from ..errors import UserError
from ..record import Record
from .table import first_data_line, frame_to_record, read_csv_frame, read_dat_frame

FORMATS = {".csv": "csv", ".dat": "dat", ".txt": "dat", ".mcap": "mcap"}


def detect_format(path: Path, declared: str | None = None) -> str:
    if declared:
        return declared
    fmt = FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise UserError(
            f"{path}: unknown file type {path.suffix!r}; expected .csv, .dat, .txt or .mcap "
            "(or set data.format)"
        )
    return fmt


def load_record(path: Path, data, name: str | None = None) -> Record:
    """Load one file as a Record following a :class:`~pipeline.config.DataConfig`."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: file not found")
    fmt = detect_format(path, data.format)
    name = name or path.stem
    units = data.unit_map()
    if fmt == "mcap":
        from .mcap import Signal, load_mcap

        if isinstance(data.input, str) or isinstance(data.output, str):
            raise UserError(
                f"{path}: an MCAP input/output is a topic and field, e.g. "
                "input: {topic: /lamp/cmd, field: data}"
            )
        return load_mcap(
            path, Signal(data.input.topic, data.input.field),
            Signal(data.output.topic, data.output.field), stamp=data.stamp,
            sample_time=data.sample_time, max_gap=data.max_gap,
            initial_input=data.initial_input, name=name, units=units,
        )
    if not isinstance(data.input, str) or not isinstance(data.output, str):
        raise UserError(f"{path}: a {fmt} file's input and output are column names")
    if fmt == "csv":
        df = read_csv_frame(path)
        offset = first_data_line(path)
    else:
        df = read_dat_frame(path, data.columns or ["time", "u", "y"])
        offset = 1
    return frame_to_record(
        df, path, input=data.input, output=data.output, time=data.time,
        sample_time=data.sample_time, initial_input=data.initial_input, units=units,
        name=name, data_offset=offset,
    )


__all__ = ["FORMATS", "Record", "detect_format", "load_record"]
