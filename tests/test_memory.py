"""The C heap's freed pages given back between stages (:mod:`pipeline.memory`)."""

import os
import sys

import numpy as np
import pytest

from pipeline import memory


def _rss() -> int:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * 4096


@pytest.mark.skipif(memory._libc("malloc_trim") is None, reason="no glibc malloc_trim here")
def test_freed_window_sized_arrays_are_given_back():
    """Window-sized arrays (below glibc's mapping threshold, so on the heap) freed in a
    checkerboard, as an analysis frees its windows: the holes stay resident until
    release(), which returns most of them (at least half of the 50 MB)."""
    keep, drop = [], []
    for k in range(1000):
        (keep if k % 2 else drop).append(np.ones(12_000))  # 96 kB each
    drop.clear()
    before = _rss()
    memory.release()
    assert before - _rss() >= 25e6
    assert len(keep) == 500


def test_release_is_harmless_without_glibc(monkeypatch):
    monkeypatch.setattr(sys, "platform", "darwin")
    memory._libc.cache_clear()
    try:
        assert memory._libc("malloc_trim") is None
        memory.release()  # a no-op, not an error
        monkeypatch.delenv("MALLOC_MMAP_THRESHOLD_", raising=False)
        memory.large_arrays_mapped()  # a no-op too: the environment left alone
        assert "MALLOC_MMAP_THRESHOLD_" not in os.environ
    finally:
        memory._libc.cache_clear()


_LOAD = """
import json, os, sys
def rss():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
from pipeline.memory import polars_returns_freed_pages
polars_returns_freed_pages()  # as the command line does when it starts
import pipeline
rec = pipeline.load(sys.argv[1], input="u", output="y", time="time")  # imports, warm-up
before = rss()
rec = pipeline.load(sys.argv[2], input="u", output="y", time="time")
print(json.dumps({"held": rss() - before, "arrays": 3 * rec.t.nbytes,
                  "conf": os.environ.get("_RJEM_MALLOC_CONF")}))
"""


def _load_in_a_child(tmp_path, env: dict) -> dict:
    import json
    import subprocess

    import polars as pl
    n = 300_000
    t = np.arange(n) * 0.1
    u = 5.0 + (np.arange(n) // 20_000 % 2)
    y = 10.0 + 2.0 * u + np.random.default_rng(0).normal(0.0, 0.02, n)
    pl.DataFrame({"time": t, "u": u, "y": y}).write_csv(tmp_path / "big.csv")
    pl.DataFrame({"time": t[:2000], "u": u[:2000], "y": y[:2000]}).write_csv(
        tmp_path / "small.csv")
    env = {k: v for k, v in {**os.environ, **env}.items() if v is not None}
    out = subprocess.run([sys.executable, "-c", _LOAD, str(tmp_path / "small.csv"),
                          str(tmp_path / "big.csv")], capture_output=True, text=True,
                         check=True, env=env)
    return json.loads(out.stdout)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="polars' jemalloc: Linux")
def test_the_load_holds_the_records_arrays_not_polars_freed_pages(tmp_path):
    """The command line asks polars' allocator to return freed pages at once: after
    loading 300 k rows the process holds about the record's three arrays (7.2 MB), not
    also the pages the CSV parse freed (measured: 1.3x the arrays, against 4.1x with the
    decay a user's setting of the variable keeps)."""
    ours = _load_in_a_child(tmp_path, {"_RJEM_MALLOC_CONF": None})
    assert ours["conf"].endswith(memory.POLARS_MALLOC_CONF)
    assert ours["held"] < 1.6 * ours["arrays"]
    theirs = _load_in_a_child(tmp_path, {"_RJEM_MALLOC_CONF": "dirty_decay_ms:10000"})
    assert theirs["conf"].endswith("dirty_decay_ms:10000")  # the user's is kept
    assert ours["held"] < theirs["held"] / 2


def test_the_command_sets_polars_allocator_up_and_import_pipeline_does_not():
    """The command's entry point sets polars' allocator up (a user's setting kept); a
    program that imports the library (and loads a log with it: polars imported) keeps
    polars' own configuration, and its child processes theirs."""
    import subprocess
    env = {k: v for k, v in os.environ.items()
           if k not in ("_RJEM_MALLOC_CONF", "MALLOC_MMAP_THRESHOLD_")}
    def shows(var):
        return f"import os; print(os.environ.get({var!r}))"
    show = shows("_RJEM_MALLOC_CONF")
    command = ("import sys, contextlib; sys.argv = ['pipeline', '--version']\n"
               "from pipeline.__main__ import main\n"
               "with contextlib.suppress(SystemExit): main()\n" + show)

    def child(code, **extra):
        return subprocess.run([sys.executable, "-c", code], capture_output=True,
                              text=True, check=True, env={**env, **extra}
                              ).stdout.strip().splitlines()[-1].split(",")

    assert child(command) == [memory.POLARS_MALLOC_CONF]
    if memory._libc("mallopt") is not None:  # and glibc's threshold (import pipeline: not)
        threshold = shows("MALLOC_MMAP_THRESHOLD_")
        assert child(command.replace(show, threshold)) == [str(memory.MMAP_THRESHOLD)]
        assert child("import pipeline, pipeline.api\n" + threshold) == ["None"]
    assert child(command, _RJEM_MALLOC_CONF="dirty_decay_ms:10000") == ["dirty_decay_ms:10000"]
    # polars writes its own defaults there when it is imported; ours is not among them
    assert memory.POLARS_MALLOC_CONF not in child("import pipeline, pipeline.api\n" + show)


_CHUNKS = """
import os, sys
import numpy as np
from pipeline import memory
def rss():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
mode, size = sys.argv[1], int(sys.argv[2])
if mode == "fixed":
    memory.large_arrays_mapped()
if size > memory.MMAP_THRESHOLD:
    x = np.ones(size // 8)  # a chunk, mapped and freed: glibc raises its threshold to it
    del x
arrays, windows = [], []
for k in range(20):  # chunked passes' arrays, with windows allocated between them
    arrays.append(np.ones(size // 8))
    windows.append(np.ones(5000))
before = rss()
arrays.clear()
print(before - rss(), os.environ.get("MALLOC_MMAP_THRESHOLD_"))
"""


def _glibc() -> bool:
    try:
        return os.confstr("CS_GNU_LIBC_VERSION") is not None
    except (ValueError, OSError, AttributeError):
        return False


@pytest.mark.skipif(not _glibc() or memory._libc("mallopt") is None, reason="glibc's malloc")
def test_the_threshold_is_fixed_so_freed_chunks_are_given_back():
    """After one freed 8 MB chunk glibc serves the next ones from the heap, where freed
    they stay resident (under the next stage's arrays); with the threshold fixed
    (:func:`pipeline.memory.large_arrays_mapped`, as the command line does) they are
    mapped, and freeing twenty of them (160 MB) gives the memory back. Arrays below the
    threshold (1 MB) stay on the heap, which glibc's default maps. The variable is set
    for the processes it starts; a user's own choice is kept."""
    import subprocess
    env = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")
           and k not in ("GLIBC_TUNABLES", "LD_PRELOAD")}

    def child(mode, size, **extra):
        out = subprocess.run([sys.executable, "-c", _CHUNKS, mode, str(size)],
                             capture_output=True, text=True, check=True,
                             env={**env, **extra}).stdout.split()
        return int(out[0]), out[1]

    chunk, small = 8 << 20, 1 << 20
    freed, var = child("fixed", chunk)
    assert freed > 0.9 * 20 * chunk and var == str(memory.MMAP_THRESHOLD)
    assert child("default", chunk)[0] < 0.2 * 20 * chunk
    assert child("fixed", small)[0] < 0.2 * 20 * small  # the threshold is above 1 MB
    assert child("default", small)[0] > 0.9 * 20 * small
    freed, var = child("fixed", chunk, MALLOC_MMAP_THRESHOLD_="131072")  # the user's
    assert var == "131072" and freed > 0.9 * 20 * chunk
    tunable = "glibc.malloc.mmap_threshold=131072"
    freed, var = child("fixed", small, GLIBC_TUNABLES=tunable)  # the user's, this way
    assert var == "None" and freed > 0.9 * 20 * small
