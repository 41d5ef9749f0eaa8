"""One native (BLAS/OpenMP) thread in the ``pipeline`` command's processes (issue 30).

The fits solve many tiny least-squares problems; a BLAS thread pool costs more than it
saves on them. ``pipeline identify --events all`` on the TCLab log (1,001 rows) took
6.45 s of CPU with OpenBLAS's default threads and 4.87 s with one, in the same wall time
and with the same fits (BENCHMARKS.md, "One BLAS thread in every command"). Pool workers
limited themselves already (:func:`pipeline.batch.pool.limit_native_threads`); the
command's own process did not. Set through the environment before numpy loads (the
libraries read it at load); a user's own setting is kept. The Python API leaves a
caller's threads alone."""

from __future__ import annotations

import os
import sys

#: The variables OpenBLAS, MKL, BLIS and OpenMP read their thread count from at load.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                    "OMP_NUM_THREADS")


def one_native_thread() -> None:
    """Ask for one native thread in this process and the ones it starts, unless numpy is
    loaded already (too late for this process) or the user set the variable."""
    if "numpy" in sys.modules:
        return
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, "1")
