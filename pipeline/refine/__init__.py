"""Least-squares refinement: a model structure fitted to the data as a whole, with its
operating point and initial state, and calibrated 95 % intervals.

- :mod:`.refinement` - :func:`refine`, one structure over one span (variable projection,
  a bounded trust-region search from many starts, intervals from the profiled Jacobian);
  its pieces: the design (:mod:`.problem`), the linear solves (:mod:`.lstsq`), the
  search space and starts (:mod:`.search`);
- :mod:`.event` - one event alone: its window, how its initial state is treated, why a
  structure does not apply;
- :mod:`.joint` - one model over several events, the state carried through the record,
  and the cross-validation folds (:mod:`.left_out`: Gauss-Newton folds beyond ten);
- :mod:`.heldout_noise` - a one-event refinement's intervals widened by the noise its
  held-out events show;
- :mod:`.closed_loop` - the plant fitted through its closed loop, the controller known
  (the indirect approach).
"""

from .closed_loop import ClosedLoopFit, fit_through_loop, loop_response
from .event import (
    baseline_drift,
    carry_source,
    event_states,
    mismatch,
    refine_event,
    summary,
    unchanged,
)
from .heldout_noise import MISFIT_RATIO, noise_bar, own_rms, widened
from .joint import fold_models, held_out_events, span_fit
from .refinement import MIN_DOF, Refinement, RefineOptions, refine

__all__ = ["MIN_DOF", "MISFIT_RATIO", "ClosedLoopFit", "RefineOptions", "Refinement",
           "baseline_drift", "carry_source", "event_states", "fit_through_loop",
           "fold_models", "held_out_events", "loop_response", "mismatch", "noise_bar",
           "own_rms", "refine", "refine_event", "span_fit", "summary", "unchanged",
           "widened"]
