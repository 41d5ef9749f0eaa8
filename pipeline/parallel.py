"""One record's independent fits, spread over worker processes (issue 30 item 3).

A long log with many events spends nearly all its time in fits that do not depend on
each other: the methods on each identification event, each refinement over all of them,
the held-out errors of the one-event models, each step refined on its own for the
consistency check. :func:`spread` runs such a list of pure tasks on a :class:`Workers`
(a process pool the batch layer owns, :class:`pipeline.batch.LazyPool`) and gives the
results in the order of the tasks, exactly as the loop in this process would: every task
is a pure function of its inputs, so one worker and many give the same fits (only the
``seconds`` they took differ).

The core does not know what a pool is: a :class:`Workers` is anything with a ``size``
and an ordered ``map``. Without one (the Python API's default) everything runs here.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol

#: Below this many samples in the windows to fit, a record's fits stay in this process:
#: starting workers (a fork server importing numpy, scipy and polars: about 1.5 s of CPU)
#: costs more than the fits of a short log (a 5,000-sample event's eight refinements take
#: about 0.4 s).
MIN_SAMPLES = 20_000
#: Chunks per worker: enough for the chunks' different costs to even out, few enough
#: that the record (sent once per chunk) is not copied for every task.
CHUNKS_PER_WORKER = 4


class Workers(Protocol):
    """Processes to run a record's tasks on: ``size`` of them, and a ``map`` that gives
    ``[fn(x) for x in items]`` in order (``fn`` and the items picklable)."""

    size: int

    def map(self, fn: Callable[[Any], Any], items: Sequence) -> list: ...


#: Above this many samples in the record its fits stay in this process: every chunk
#: carries a pickled copy of the record (24 bytes a sample), made in this process, and at
#: 10 M samples that copy (240 MB) would stack on the peak memory the scale target holds
#: to 3x the raw arrays. Not measured there yet; 1 M samples (24 MB a copy) spread.
MAX_RECORD_SAMPLES = 2_000_000


def worth_spreading(workers: Workers | None, samples: int, tasks: int, *,
                    record_samples: int) -> Workers | None:
    """``workers`` when there is enough to fit (``samples`` in the windows to fit, at
    least :data:`MIN_SAMPLES`) in at least two tasks, and the record is not so long that
    its copies cost memory (:data:`MAX_RECORD_SAMPLES`); else None (run here)."""
    if workers is None or workers.size < 2 or tasks < 2 or samples < MIN_SAMPLES \
            or record_samples > MAX_RECORD_SAMPLES:
        return None
    return workers


def spread(workers: Workers | None, fn: Callable[[Any, Any], Any], shared: Any,
           items: Sequence) -> list:
    """``[fn(shared, x) for x in items]``, on ``workers`` when given.

    The items go out in interleaved chunks (``items[k::n]``: a staircase's neighbouring
    events cost alike, so every chunk gets a fair share of the long and the short ones),
    each with one copy of ``shared`` (the record and what every task reads of it).
    ``fn`` must be a module-level function (it is pickled by name)."""
    items = list(items)
    if workers is None or len(items) < 2:
        return [fn(shared, x) for x in items]
    n = min(len(items), CHUNKS_PER_WORKER * workers.size)
    done = workers.map(run_chunk, [(fn, shared, items[k::n]) for k in range(n)])
    out: list = [None] * len(items)
    for k, results in enumerate(done):
        out[k::n] = results
    return out


def run_chunk(task: tuple[Callable[[Any, Any], Any], Any, Sequence]) -> list:
    """One chunk of :func:`spread`: ``[fn(shared, x) for x in items]``."""
    fn, shared, items = task
    return [fn(shared, x) for x in items]
