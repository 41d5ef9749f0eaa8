"""Batch runs: many records in a process pool (or on Dask), their progress, and the
interrupts that stop a run without losing its work.

- :mod:`.pool` - the records of a run in worker processes, in order; :mod:`.cluster` - on
  a Dask cluster;
- :mod:`.progress` - the stage lines and the progress bar;
- :mod:`.interrupt` - Ctrl-C and SIGTERM: a run stops between records, a report is
  never half written (:func:`deferred`);
- :mod:`.forkserver_guard` - the workers' start method.
"""

from .interrupt import SIGNALS, deferred, handle_signals, interruption
from .pool import LazyPool, check_executor, lazy_pool, local_pool, parallel_map, run_records
from .progress import Stages, show_progress

__all__ = ["SIGNALS", "LazyPool", "Stages", "check_executor", "deferred", "handle_signals",
           "interruption", "lazy_pool", "local_pool", "parallel_map", "run_records",
           "show_progress"]
