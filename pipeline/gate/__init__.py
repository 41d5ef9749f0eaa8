"""The regression gate: a run compared with its baseline, what changed, and the history.

- :mod:`.baseline` - the comparison with a baseline's results.json, within tolerances per
  parameter and validation error, and accepting a run as the new baseline;
- :mod:`.baseline_file` - reading a baseline (any readable schema version);
- :mod:`.findings` - what changed, record by record, in words and numbers;
- :mod:`.history` - one row per fit and night in a Parquet history;
- :mod:`.tuning_findings` - what changed in the tuned controller settings.
"""

from .baseline import (
    Comparison,
    Finding,
    Tolerances,
    accept,
    compare,
    param_scale,
    tolerance_problem,
)
from .baseline_file import load_baseline, load_results
from .findings import RecordRegression, display_text, pct_text
from .history import append_history, history_lock, history_rows, load_history
from .tuning_findings import SETTINGS

__all__ = ["Comparison", "Finding", "RecordRegression", "SETTINGS", "Tolerances", "accept",
           "append_history", "compare", "display_text", "history_lock", "history_rows",
           "load_baseline", "load_history", "load_results", "param_scale", "pct_text",
           "tolerance_problem"]
