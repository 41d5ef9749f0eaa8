"""Out of memory is one line and exit 2 (issue 31): a MemoryError, an ENOMEM and a native
module that cannot be mapped under an address-space limit (matplotlib's, at 800 MB) were
tracebacks with exit 1; anything else still raises."""

from __future__ import annotations

import errno

import pytest
from typer.testing import CliRunner

from pipeline.cli.commands import app, out_of_memory
from tests.corpus import step_csv

ARGS = ["--input", "u", "--output", "y", "--time", "time", "--method", "first_order", "-q"]


@pytest.mark.parametrize("exc", [
    MemoryError(),
    OSError(errno.ENOMEM, "Cannot allocate memory"),
    ImportError("/x/_backend_agg.so: failed to map segment from shared object"),
])
def test_out_of_memory_is_one_line(tmp_path, monkeypatch, exc):
    import pipeline.run as run

    (tmp_path / "log.csv").write_text(step_csv())
    assert CliRunner().invoke(app, ["identify", str(tmp_path / "log.csv"), *ARGS]
                              ).exit_code == 0  # the twin
    def fails(*a, **k):
        raise exc
    monkeypatch.setattr(run, "analysed", fails)
    res = CliRunner().invoke(app, ["identify", str(tmp_path / "log.csv"), *ARGS])
    lines = [x for x in res.stderr.splitlines() if x.strip()]
    assert res.exit_code == 2 and len(lines) == 1, res.stderr
    assert lines[0].startswith("error: out of memory (") and "more memory" in lines[0]
    assert "Traceback" not in res.stderr


def test_what_is_out_of_memory():
    assert out_of_memory(MemoryError())
    assert out_of_memory(OSError(errno.ENOMEM, "x"))
    assert not out_of_memory(OSError(errno.EACCES, "Permission denied"))
    assert not out_of_memory(ImportError("No module named 'dask'"))
