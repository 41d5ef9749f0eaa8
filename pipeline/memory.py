"""Memory on long records: freed memory handed back to the system after each analysis (the
run layer calls :func:`release`, :func:`pipeline.run.analysed`), and the chunk size of the
passes that avoid record-long temporaries (:data:`CHUNK`).

glibc's allocator keeps freed heap memory for reuse and returns it only from the top of
the heap; a long record's analysis frees thousands of window-sized arrays (the per-step
refinements, the per-step gains' columns) scattered through the heap, and what follows
cannot reuse the holes for its record-long arrays (those are mapped on their own). At
10 M samples / 2000 events the process held 585 MB more than the loaded record after the
analysis, with 2 MB of it live; ``malloc_trim(0)`` gave back all but 35 MB, and the next
stage's arrays then stack on the record, not on the holes (issue 14: peak memory). No
library does this for us: numpy allocates through the C library.

polars allocates through its own jemalloc (Linux), which keeps the pages a CSV parse
freed as "dirty" for reuse: at 1 M rows the load held 101 MB after reading 24 MB of
arrays, under every later stage's peak. :func:`polars_returns_freed_pages` asks it to
give them back at once (:data:`POLARS_MALLOC_CONF`). The command line does it when it
starts (``pipeline.__main__``), before polars is imported (its pool workers inherit it);
a program that uses the library calls it first thing, or sets the variable itself.
``import pipeline`` does not: it would change the environment of the importing program
and of every process it starts.

glibc maps an allocation on its own (and unmaps it when freed) only from a threshold up
that it raises to the size of each mapped block freed, up to 32 MB: after the first
freed 8 MB chunk of a chunked pass (:data:`CHUNK`), every later one comes from the heap
and stays resident when freed, under the next stage's record-long arrays.
:func:`large_arrays_mapped` fixes the threshold at :data:`MMAP_THRESHOLD` for the
command's process and its pool workers (the same way: the command line calls it first).
"""

from __future__ import annotations

import functools
import os
import sys

#: Samples per chunk of a pass that works a chunk at a time instead of on record-long
#: temporaries (8 MB of float64): the chunked filter of a long simulation
#: (:mod:`pipeline.simulation.regressors`), rankings (:mod:`pipeline.grading.ranks`), paired
#: sums and order checks (:mod:`pipeline.grading.recommendation`), decimation
#: (:mod:`pipeline.report.drawing`). Each gives the numbers of one whole-array pass.
CHUNK = 1 << 20


#: polars' jemalloc configuration (the environment variable ``_RJEM_MALLOC_CONF``, read
#: once when polars is imported): freed pages returned to the system at once, not after
#: a decay. Measured on the scale logs (``benchmarks/scale.py``): at 1 M rows the load's
#: high-water mark over the imports 111 -> 64 MB, its resident set after it 101 -> 24 MB
#: (the record's arrays), its CPU 0.21 -> 0.23 s (medians of 5); at 10 M rows 540 ->
#: 396 MB, 340 -> 231 MB, 2.32 -> 2.46 s (the bare polars read 2.27 s: 1.08x).
POLARS_MALLOC_CONF = "dirty_decay_ms:0"


def polars_returns_freed_pages() -> None:
    """Set :data:`POLARS_MALLOC_CONF` for polars, unless the user configured its
    allocator already or polars is imported (its allocator read its configuration then:
    setting it now would only change child processes')."""
    if "polars" not in sys.modules:
        os.environ.setdefault("_RJEM_MALLOC_CONF", POLARS_MALLOC_CONF)


#: Allocations from this size up are mapped on their own and given back when freed
#: (glibc's ``M_MMAP_THRESHOLD``, fixed: not raised by the freed blocks). Above the
#: per-event windows' arrays (5,000 samples: 40 kB) and the search's, below a chunked
#: pass's 8 MB. Measured with ``pipeline identify LOG --method all --events all`` on the
#: scale logs (``benchmarks/scale.py``): see BENCHMARKS.md, "the allocator's threshold".
MMAP_THRESHOLD = 4 << 20
_M_MMAP_THRESHOLD = -3  # glibc's malloc.h


def large_arrays_mapped() -> None:
    """Fix glibc's mmap threshold at :data:`MMAP_THRESHOLD`: in this process by
    ``mallopt``, in the processes it starts by glibc's ``MALLOC_MMAP_THRESHOLD_`` (read
    when a process starts). Nothing where the user chose a threshold (that variable, or
    ``GLIBC_TUNABLES``' ``glibc.malloc.mmap_threshold``: glibc applied it to this process
    already), where the C library is not glibc, or where glibc refuses the value (a
    32-bit build's maximum is 512 kB)."""
    _malloc_option(_M_MMAP_THRESHOLD, MMAP_THRESHOLD, "MALLOC_MMAP_THRESHOLD_",
                   "malloc.mmap_threshold")


#: glibc malloc arenas at most (``M_ARENA_MAX``; its default is 8 per core). Each arena a
#: thread opens reserves 64 MB of address space, and polars' and OpenBLAS's threads open
#: them: ``pipeline run configs/thermal.yaml`` held 1,327 MB of address space (185 MB
#: resident) when its analysis began, 606 MB with two arenas. An address-space limit
#: (``ulimit -v``, a batch system's) of 1.2 GB then failed in the imports; with two it
#: runs. The command's own threads are one (Python's) and polars allocates with jemalloc,
#: so two arenas cost no contention that matters.
ARENA_MAX = 2
_M_ARENA_MAX = -8  # glibc's malloc.h


def few_malloc_arenas() -> None:
    """At most :data:`ARENA_MAX` glibc arenas: in this process by ``mallopt`` (before its
    threads start), in the processes it starts by ``MALLOC_ARENA_MAX``. Nothing where the
    user chose (that variable, or ``GLIBC_TUNABLES``' ``glibc.malloc.arena_max``) or the C
    library is not glibc."""
    _malloc_option(_M_ARENA_MAX, ARENA_MAX, "MALLOC_ARENA_MAX", "malloc.arena_max")


def _malloc_option(option: int, value: int, variable: str, tunable: str) -> None:
    """Set glibc's malloc ``option`` to ``value`` in this process (``mallopt``) and, where
    glibc took it, the environment ``variable`` its child processes read at their start.
    Nothing where the user chose already (``variable``, or ``tunable`` in
    ``GLIBC_TUNABLES``) or the C library is not glibc."""
    if variable in os.environ or tunable in os.environ.get("GLIBC_TUNABLES", ""):
        return
    mallopt = _libc("mallopt")
    if mallopt is not None and mallopt(option, value) == 1:
        os.environ[variable] = str(value)


@functools.cache
def _libc(name: str):
    """glibc's function ``name``, or None (another C library, another system)."""
    if not sys.platform.startswith("linux"):
        return None
    import ctypes  # here: `import pipeline` (and the command line's start) without it

    try:
        return getattr(ctypes.CDLL(None), name)  # the process's own C library
    except (OSError, AttributeError):
        return None


def release() -> None:
    """Return the C heap's free pages to the system (``malloc_trim(0)``; nothing where
    the C library has no such call). Costs about a millisecond."""
    trim = _libc("malloc_trim")
    if trim is not None:
        trim(0)


def available() -> int | None:
    """Bytes this process may still allocate, as far as the system says: the least of
    the memory available (``MemAvailable``, /proc/meminfo), the cgroup's limit less its
    use (cgroup v2 ``memory.max``/``memory.current``) and the address-space limit less
    the address space in use (``RLIMIT_AS``, ``VmSize``). None where none of them can be
    read (another system). A reader that would abort past it (a native library's failed
    allocation is not an exception) checks first."""
    found = []
    meminfo = _proc_fields("/proc/meminfo")
    if "MemAvailable" in meminfo:
        found.append(meminfo["MemAvailable"])
    try:
        limit = open("/sys/fs/cgroup/memory.max").read().strip()
        if limit != "max":
            used = int(open("/sys/fs/cgroup/memory.current").read())
            found.append(max(0, int(limit) - used))
    except (OSError, ValueError):
        pass
    left = address_space_left()
    if left is not None:
        found.append(left)
    return min(found) if found else None


def address_space_left() -> int | None:
    """The address-space limit less the address space in use (``RLIMIT_AS``, ``VmSize``),
    in bytes; None without a limit or where it cannot be read."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        status = _proc_fields("/proc/self/status")
        if soft != resource.RLIM_INFINITY and "VmSize" in status:
            return max(0, soft - status["VmSize"])
    except (ImportError, OSError, ValueError):
        pass
    return None


def _proc_fields(path: str) -> dict[str, int]:
    """The ``Name: N kB`` lines of a /proc file, in bytes ({} when it cannot be read)."""
    out = {}
    try:
        with open(path) as f:
            for line in f:
                name, _, rest = line.partition(":")
                parts = rest.split()
                if len(parts) == 2 and parts[1] == "kB" and parts[0].isdigit():
                    out[name] = int(parts[0]) * 1024
    except OSError:
        pass
    return out


#: Address space that must be left when the BLAS buffers are taken (two of about 32 MB
#: and room to fit): less is refused as out of memory before any native library can fail
#: on it (at ``ulimit -v 1000000`` the command's imports left 0-6 MB).
BLAS_HEADROOM = 96 << 20
#: Square matrices of this size multiplied once by each BLAS library: large enough that
#: OpenBLAS takes its buffered path (its small-matrix kernels skip the buffer).
_BLAS_WARM_SIZE = 256


@functools.cache
def reserve_blas_buffers() -> None:
    """Have numpy's and scipy's OpenBLAS allocate their work buffers now, while memory is
    free: each allocates about 32 MB on its first buffered call and keeps it for the
    process's life. Allocated first in a fit under a nearly exhausted address-space limit,
    the allocation fails inside OpenBLAS, which retries in C and then calls ``exit(1)``
    or, in scipy's build, retries without end, deaf to SIGTERM (issue 31: ``ulimit -v
    800000``, ``pipeline run configs/thermal.yaml --workers 1`` spun for 11 minutes of CPU
    in ``blas_memory_alloc`` under ``scipy_dgelsd_``). With the buffers held, the same
    shortage is a MemoryError in numpy: one line and exit 2. Cost: one 256 x 256 product
    per library, about a millisecond, once per process. With less than
    :data:`BLAS_HEADROOM` of address space left, a MemoryError before either library is
    touched (where the imports alone used up the limit, OpenBLAS's buffer was the first
    allocation to fail, 2 runs in 6)."""
    import numpy as np
    from scipy.linalg import blas

    left = address_space_left()
    if left is not None and left < BLAS_HEADROOM:
        raise MemoryError(f"{left >> 20} MB of address space is left after start-up, "
                          f"at least {BLAS_HEADROOM >> 20} MB are needed")
    a = np.ones((_BLAS_WARM_SIZE, _BLAS_WARM_SIZE))
    a @ a  # numpy's own OpenBLAS
    blas.dgemm(1.0, a, a)  # scipy's (LAPACK's least squares calls its dgemm)
