"""Grading: every fit's verdict and the flags behind it, the per-step consistency of the
log, the closed-loop check, and the recommended model.

- :mod:`.verdicts` - the flag table and the checks that raise them, a verdict per fit
  (:mod:`.determinacy`: how well the data determine a model's response; :mod:`.heldout`:
  the misfit on the events a model did not see);
- :mod:`.consistency` - every step on its own, and what the steps say together (with
  :mod:`.superposition`: one gain per step at shared dynamics);
- :mod:`.closed_loop` - whether the log looks like a closed loop (with :mod:`.ranks`);
- :mod:`.recommendation` - the model to use, and why.
"""

from .consistency import per_step, static_map_note
from .recommendation import (
    CRITERION_COLUMNS,
    CRITERION_NAMES,
    criterion,
    information_criteria,
    ranked,
    recommend,
)
from .verdicts import FLAGS, grade, no_usable_model, record_verdict

__all__ = ["CRITERION_COLUMNS", "CRITERION_NAMES", "FLAGS", "criterion", "grade",
           "information_criteria", "no_usable_model", "per_step", "ranked",
           "recommend", "record_verdict", "static_map_note"]
