"""One synthetic log (a known FOPDT plant, two steps) written in every form a user may
have it in, each with the ``data:`` keys that read it back (for tests/test_forms.py).

Every writer takes the log's arrays and a folder and returns the file and its keys. The
values are written in full (``repr``) so a text form holds the same numbers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from zoneinfo import ZoneInfo

import numpy as np
import polars as pl

from pipeline.models import ProcessModel
from pipeline.synth import step_record

#: the plant: K = 2.5, T = 7 s, delay 1.5 s; steps 1.5 -> 3.5 at 13.7 s, -> 2.0 at 113.7 s
MODEL = ProcessModel("first_order", {"K": 2.5, "T": 7.0, "delay": 1.5})
DT = 0.1


@dataclass(frozen=True)
class Log:
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray


def synthetic_log() -> Log:
    rec = step_record(MODEL, u0=1.5, changes=[(13.7, 3.5), (113.7, 2.0)], t_end=213.7,
                      dt=DT, y0=-4.0, noise=0.02)
    n = rec.t.size
    return Log(np.arange(n) / 10, np.asarray(rec.u), np.asarray(rec.y))  # t = i/10 exactly


Writer = Callable[[Log, Path], tuple[Path, dict]]
COLS = {"input": "u", "output": "y", "time": "time"}


def _table(time, log: Log):
    return zip(time, log.u, log.y, strict=True)


def _text(path: Path, header: str | None, rows, sep: str = ",", comma: bool = False) -> Path:
    def cell(v) -> str:
        text = v if isinstance(v, str) else repr(float(v))
        return text.replace(".", ",") if comma else text

    lines = [header] if header else []
    lines += [sep.join(cell(v) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def csv_header(log: Log, d: Path):
    return _text(d / "log.csv", "time,u,y", _table(log.t, log)), COLS


def csv_no_header(log: Log, d: Path):
    return (_text(d / "nohead.csv", None, _table(log.t, log)),
            {"input": 1, "output": 2, "time": 0})


def tsv_units(log: Log, d: Path):
    return (_text(d / "log.tsv", "time (s)\tHeater (%)\tT [°C]", _table(log.t, log),
                  sep="\t"), {"input": "Heater", "output": "T", "time": "time"})


def semicolon_decimal_comma(log: Log, d: Path):
    return (_text(d / "export.csv", "Zeit;Heizung;Temperatur", _table(log.t, log),
                  sep=";", comma=True),
            {"input": "Heizung", "output": "Temperatur", "time": "Zeit"})


def whitespace_txt(log: Log, d: Path):
    return (_text(d / "log.txt", None, _table(log.t, log), sep="   "),
            {"input": "1", "output": "2", "time": "0"})


def mat_v5(log: Log, d: Path):
    import scipy.io

    path = d / "log.mat"
    scipy.io.savemat(path, {"Zeit": log.t, "Ts": DT, "u": log.u[:, None], "y": log.y},
                     format="5")
    return path, {"input": "u", "output": "y", "time": "Zeit"}


def mat_v73(log: Log, d: Path):
    """MATLAB's v7.3 layout: HDF5 after a 512-byte header, arrays transposed, a struct as
    a group with MATLAB_class attributes."""
    import h5py

    path = d / "log73.mat"
    with h5py.File(path, "w", userblock_size=512) as f:
        group = f.create_group("log")
        group.attrs["MATLAB_class"] = np.bytes_("struct")
        for name, v in (("t", log.t), ("u", log.u), ("y", log.y)):
            ds = group.create_dataset(name, data=v[None, :])
            ds.attrs["MATLAB_class"] = np.bytes_("double")
    with open(path, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Sun Oct 27 2024 HDF5 "
                 b"schema 1.00 .".ljust(116) + b"\x00" * 8 + b"\x00\x02IM")
    return path, {"input": "log.u", "output": "log.y", "time": "log.t"}


def xlsx(log: Log, d: Path):
    path = d / "log.xlsx"
    frame = pl.DataFrame({"time": log.t, "u": log.u, "y": log.y})
    import xlsxwriter

    with xlsxwriter.Workbook(path) as book:
        pl.DataFrame({"Note": ["plant A"]}).write_excel(book, worksheet="Info")
        frame.write_excel(book, worksheet="Log")
    return path, {**COLS, "sheet": "Log"}


def parquet(log: Log, d: Path):
    path = d / "log.parquet"
    pl.DataFrame({"time": log.t, "u": log.u, "y": log.y}).write_parquet(path)
    return path, COLS


def feather(log: Log, d: Path):
    path = d / "log.feather"
    pl.DataFrame({"time": log.t, "u": log.u, "y": log.y}).write_ipc(path)
    return path, COLS


def _stamps(log: Log, start: datetime) -> list[datetime]:
    return [start + timedelta(milliseconds=100 * i) for i in range(log.t.size)]


def datetime_utc(log: Log, d: Path):
    start = datetime(2024, 10, 27, 0, 58, tzinfo=UTC)
    text = [s.strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z" for s in _stamps(log, start)]
    return _text(d / "utc.csv", "time,u,y", _table(text, log)), COLS


def datetime_offsets(log: Log, d: Path):
    """Local time with its offset, across the autumn change (+02:00, then +01:00)."""
    berlin = ZoneInfo("Europe/Berlin")
    start = datetime(2024, 10, 27, 0, 58, tzinfo=UTC)
    text = [s.astimezone(berlin).isoformat(timespec="milliseconds")
            for s in _stamps(log, start)]
    return _text(d / "offsets.csv", "time,u,y", _table(text, log)), COLS


def datetime_local_dst(log: Log, d: Path):
    """Wall-clock time without offset in Berlin across the autumn change: 02:58 CEST to
    02:59:59.9, then 02:00:00 CET again."""
    berlin = ZoneInfo("Europe/Berlin")
    start = datetime(2024, 10, 27, 0, 58, tzinfo=UTC)
    text = [s.astimezone(berlin).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]
            for s in _stamps(log, start)]
    return (_text(d / "local.csv", "time,u,y", _table(text, log)),
            {**COLS, "time_zone": "Europe/Berlin"})


def milliseconds(log: Log, d: Path):
    ms = [str(100 * i) for i in range(log.t.size)]
    return (_text(d / "ms.csv", "t [ms],u,y", _table(ms, log)),
            {"input": "u", "output": "y", "time": "t"})


def repeated_stamps(log: Log, d: Path):
    """Three rows per stamp whose mean is the sample (the logger's sub-samples)."""
    rows = []
    for t, u, y in zip(log.t, log.u, log.y, strict=True):
        rows += [(t, u, y - 0.0078125), (t, u, y), (t, u, y + 0.0078125)]
    return _text(d / "repeated.csv", "time,u,y", rows), {**COLS, "duplicates": "mean"}


def dropouts(log: Log, d: Path):
    """0.5 % of the input and output cells empty (single-row logger drop-outs)."""
    rng = np.random.default_rng(7)
    n = log.t.size
    rows = [[t, u, y] for t, u, y in zip(log.t, log.u, log.y, strict=True)]
    for i in rng.choice(np.arange(1, n - 1), size=int(0.005 * n), replace=False):
        rows[i][1 + int(rng.integers(2))] = ""
    return _text(d / "dropouts.csv", "time,u,y", rows), {**COLS, "fill_gaps": 1}


#: name -> (writer, relative tolerance against the plain CSV)
FORMS: dict[str, tuple[Writer, float]] = {
    "csv_header": (csv_header, 1e-9),
    "csv_no_header": (csv_no_header, 1e-9),
    "tsv_units": (tsv_units, 1e-9),
    "semicolon_decimal_comma": (semicolon_decimal_comma, 1e-9),
    "whitespace_txt": (whitespace_txt, 1e-9),
    "mat_v5": (mat_v5, 1e-9),
    "mat_v73": (mat_v73, 1e-9),
    "xlsx": (xlsx, 1e-6),
    "parquet": (parquet, 1e-9),
    "feather": (feather, 1e-9),
    "datetime_utc": (datetime_utc, 1e-9),
    "datetime_offsets": (datetime_offsets, 1e-9),
    "datetime_local_dst": (datetime_local_dst, 1e-9),
    "milliseconds": (milliseconds, 1e-9),
    "repeated_stamps": (repeated_stamps, 1e-9),
    "dropouts": (dropouts, 1e-3),
}
