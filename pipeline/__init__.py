"""pipeline: batch system identification from step and impulse tests.

Data conventions (written down once, used everywhere):

- time in seconds; ``t``, ``u``, ``y`` are float64 1-D numpy arrays, ``t`` strictly increasing;
- models work in deviation variables from the operating point ``(u0, y0)``;
- parameter names are ``K`` (gain), ``T`` (time constant), ``T1``, ``T2`` (two distinct
  time constants), ``n`` (order of an equal-lag model), ``zeta`` (damping), ``wn``
  (natural frequency, rad/s) and ``delay`` (dead time, s). There is no second spelling.
"""

import os
from importlib.metadata import PackageNotFoundError, version

# Many small problems: BLAS threads cost more than they save (2.7x slower in-process on a
# 2-core machine, BENCHMARKS.md) and oversubscribe the batch pool. A user's setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

try:
    __version__ = version("pipeline")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+local"
