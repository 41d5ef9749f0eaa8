"""MATLAB ``.mat`` files: ``scipy.io`` for versions 4 to 7, ``h5py`` for 7.3 (HDF5).

The columns are the file's numeric vectors: each vector variable (``Zeit``), each field
of a struct, dotted (``log.u``, ``log.sensors.T``), and each column of a matrix
(``data[0]``, ``data[1]``; samples along its longer side). The signals are the vectors of
the most common length; variables of another length (a scalar ``Ts``, a short vector)
are left out, and naming one says so. ``input``, ``output`` and ``time`` name a column,
or give its 0-based position in that order (the file's order).

Keys (``data:``, beside the common ones): the time and quirk keys of every table
(:class:`~pipeline.io.table.TableOptions`).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import polars as pl

from ..errors import UserError
from ..record import Record
from .base import DataSection, Format, Places
from .table import Table, TableOptions, one_line, table_to_record

#: HDF5 attribute values of MATLAB's numeric classes (v7.3 files).
_NUMERIC_CLASSES = {"double", "single", "logical", "int8", "uint8", "int16", "uint16",
                    "int32", "uint32", "int64", "uint64"}


class MatOptions(TableOptions):
    """The keys of a ``.mat`` file: the time base and the quirk policies."""


def load_mat(path: Path, data: DataSection, options: MatOptions, name: str) -> Record:
    """One ``.mat`` file as a :class:`Record` (see the module docstring)."""
    return table_to_record(read_mat_table(path), data, options, name)


def read_mat_table(path: Path) -> Table:
    """The vectors of a .mat file of the signals' length as a :class:`Table`."""
    vectors = dict(_columns(_read(path)))
    if not vectors:
        raise UserError(f"{path}: no numeric variables; expected vectors of samples")
    n = Counter(v.size for v in vectors.values()).most_common(1)[0][0]
    names = tuple(k for k, v in vectors.items() if v.size == n)
    left_out = {k: f"has {v.size} value(s), where the signals have {n} samples"
                for k, v in vectors.items() if v.size != n}
    frame = pl.DataFrame([pl.Series(str(i), vectors[k], dtype=pl.Float64)
                          for i, k in enumerate(names)])
    return Table(frame, names, Places(path, range(1, n + 1), word="sample"),
                 noun="variable", left_out=left_out)


def _read(path: Path) -> dict:
    """The file's variables: nested dicts of arrays (structs as dicts)."""
    import scipy.io

    try:
        return scipy.io.loadmat(path, squeeze_me=True, simplify_cells=True)
    except NotImplementedError:  # MATLAB 7.3: HDF5
        return _read_hdf5(path)
    except (ValueError, TypeError, OSError, scipy.io.matlab.MatReadError) as exc:
        raise UserError(f"{path}: not a readable MAT-file ({one_line(exc)}); expected a "
                        "MATLAB .mat file (v4 to v7.3)") from None


def _read_hdf5(path: Path) -> dict:
    """A v7.3 file's numeric datasets and struct groups (MATLAB stores them transposed)."""
    import h5py

    def walk(group) -> dict:
        out = {}
        for key, item in group.items():
            if key.startswith("#"):  # '#refs#', '#subsystem#': MATLAB's internals
                continue
            cls = item.attrs.get("MATLAB_class", b"")
            cls = cls.decode() if isinstance(cls, bytes) else str(cls)
            if isinstance(item, h5py.Group):
                out[key] = walk(item)
            elif cls in _NUMERIC_CLASSES and "MATLAB_empty" not in item.attrs:
                out[key] = np.asarray(item[()]).T
        return out

    try:
        with h5py.File(path, "r") as f:
            return walk(f)
    except OSError as exc:
        raise UserError(f"{path}: not a readable MAT-file ({one_line(exc)}); expected a "
                        "MATLAB .mat file (v4 to v7.3)") from None


def _columns(variables: dict, prefix: str = ""):
    """``(name, 1-D float64 array)`` for every numeric vector, struct field and matrix
    column, in the file's order (names starting ``__`` are scipy's header entries)."""
    for key, value in variables.items():
        if key.startswith("__"):
            continue
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            yield from _columns(value, f"{name}.")
            continue
        arr = np.asarray(value)
        if arr.dtype.kind not in "biuf":
            continue
        arr = np.squeeze(arr)
        if arr.ndim <= 1:
            yield name, np.atleast_1d(arr).astype(np.float64)
        elif arr.ndim == 2:
            cols = arr if arr.shape[0] >= arr.shape[1] else arr.T
            for j in range(cols.shape[1]):
                yield f"{name}[{j}]", cols[:, j].astype(np.float64)


FORMAT = Format("mat", (".mat",), MatOptions, load_mat)
