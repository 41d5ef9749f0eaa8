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


def test_few_malloc_arenas_for_the_command_and_its_children():
    """glibc's arenas reserve 64 MB of address space each: the command asks for two
    (``MALLOC_ARENA_MAX`` for the processes it starts), and keeps a user's own choice."""
    import os
    import subprocess
    import sys

    code = ("import os; from pipeline.memory import few_malloc_arenas; few_malloc_arenas(); "
            "print(os.environ.get('MALLOC_ARENA_MAX'))")
    env = {k: v for k, v in os.environ.items() if k not in ("MALLOC_ARENA_MAX",
                                                           "GLIBC_TUNABLES")}
    got = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True).stdout.strip()
    if not sys.platform.startswith("linux"):
        return
    assert got == "2"
    mine = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**env, "MALLOC_ARENA_MAX": "5"}, check=True).stdout.strip()
    assert mine == "5"


def test_a_run_under_an_address_space_limit(tmp_path):
    """Under a 1.1 GB address-space limit (``ulimit -v``) a small log is identified: the
    command held 1,327 MB of address space when its analysis began with glibc's default
    arenas (the run failed in its imports or in OpenBLAS's buffer, exit 1 or a C
    retry loop deaf to SIGTERM), about 600 MB with two."""
    import resource
    import subprocess
    import sys

    if not sys.platform.startswith("linux"):
        pytest.skip("RLIMIT_AS as Linux counts it")
    (tmp_path / "log.csv").write_text(step_csv())
    limit = 1_100 << 20

    def limited():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    res = subprocess.run([sys.executable, "-m", "pipeline", "identify",
                          str(tmp_path / "log.csv"), *ARGS], capture_output=True, text=True,
                         timeout=300, preexec_fn=limited)
    assert res.returncode == 0, res.stderr[-2000:]


def test_no_blas_buffer_without_room_for_it(monkeypatch):
    """Where the imports left less than BLAS_HEADROOM of address space, a MemoryError
    before OpenBLAS is touched (it would fail in C: exit(1), or retry without end)."""
    from pipeline import memory

    monkeypatch.setattr(memory, "address_space_left", lambda: 5 << 20)
    with pytest.raises(MemoryError, match="5 MB of address space is left"):
        memory.reserve_blas_buffers.__wrapped__()
    monkeypatch.setattr(memory, "address_space_left", lambda: None)
    memory.reserve_blas_buffers.__wrapped__()  # the twin: no limit, the buffers taken


def test_out_of_memory_is_said_without_rich(tmp_path, monkeypatch):
    """The out-of-memory line is written plainly: rich's first use imports its emoji
    table, which under the limit was the MemoryError's own traceback, exit 1."""
    import pipeline.cli.output as output
    import pipeline.run as run

    (tmp_path / "log.csv").write_text(step_csv())
    def fails(*a, **k):
        raise MemoryError()
    def no_rich(*a, **k):
        raise MemoryError("rich rendering")
    monkeypatch.setattr(run, "analysed", fails)
    monkeypatch.setattr(output.err, "print", no_rich)
    res = CliRunner().invoke(app, ["identify", str(tmp_path / "log.csv"), *ARGS])
    assert res.exit_code == 2, res.output
    assert res.stderr.startswith("error: out of memory (") and "Traceback" not in res.stderr
