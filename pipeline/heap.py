"""Memory on long records: freed memory handed back to the system between the stages of a
long record's analysis, and the chunk size of the passes that avoid record-long
temporaries (:data:`CHUNK`).

glibc's allocator keeps freed heap memory for reuse and returns it only from the top of
the heap; a long record's analysis frees thousands of window-sized arrays (the per-step
refinements, the per-step gains' columns) scattered through the heap, and what follows
cannot reuse the holes for its record-long arrays (those are mapped on their own). At
10 M samples / 2000 events the process held 585 MB more than the loaded record after the
analysis, with 2 MB of it live; ``malloc_trim(0)`` gave back all but 35 MB, and the next
stage's arrays then stack on the record, not on the holes (issue 14: peak memory). No
library does this for us: numpy and polars allocate through the C library.
"""

from __future__ import annotations

import ctypes
import functools
import sys

#: Samples per chunk of a pass that works a chunk at a time instead of on record-long
#: temporaries (8 MB of float64): the chunked filter of a long simulation
#: (:mod:`pipeline.basis`), rankings (:mod:`pipeline.ranks`), paired sums and order checks
#: (:mod:`pipeline.recommend`), decimation (:mod:`pipeline.report.drawing`). Each gives
#: the numbers of one whole-array pass.
CHUNK = 1 << 20


@functools.cache
def _malloc_trim():
    """glibc's ``malloc_trim``, or None (another C library, another system)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(None).malloc_trim  # the process's own C library
    except (OSError, AttributeError):
        return None


def release() -> None:
    """Return the C heap's free pages to the system (``malloc_trim(0)``; nothing where
    the C library has no such call). Costs about a millisecond."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)
