"""Synthetic plants and logs with known truth, for tests, examples and benchmarks.

- :mod:`.plants`: exact responses of a :class:`~pipeline.models.ProcessModel` to staircase
  and pulse inputs, as arrays or a :class:`~pipeline.record.Record` (no files);
- :mod:`.logs`: folders of synthetic CSV logs (some corrupt on purpose) and their truth;
- :mod:`.mcap_example`: the example MCAP log ``datasets/examples/lamp_plate.mcap``
  (``python -m pipeline.synth.mcap_example`` rewrites it).
"""

from .logs import write_synthetic_logs
from .plants import (
    JAKOUBEK_LAGS,
    jakoubek_record,
    lag_chain_step,
    pulse,
    response,
    staircase,
    step_record,
)

__all__ = ["JAKOUBEK_LAGS", "jakoubek_record", "lag_chain_step", "pulse", "response",
           "staircase", "step_record", "write_synthetic_logs"]
