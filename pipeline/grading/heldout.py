"""The held-out misfit: a model that does not carry from its own event to the others.

:func:`validation_misfit` raises ``validation_misfit`` (a warning) when the held-out RMS
error is beyond :data:`MISFIT_RATIO` times what the data and the model allow: the
held-out events' noise, the fit's own error on its identification data
(:func:`own_rms`), the best refinement's on the same data (:func:`fit_floor`), and what
the model's own parameter uncertainty moves its held-out simulation by
(:func:`pipeline.grading.determinacy.heldout_spread`), the two added as variances of
independent errors (the prediction error's variance is the noise's plus the estimate's,
``sigma^2 + diag(J C J^T)``: Ljung, System Identification, 2nd ed., sec. 9.3, the
parameter error independent of the new data's noise). :mod:`.verdicts` runs it with the
other checks.
"""

from __future__ import annotations

import math

import numpy as np

from ..fit import Fit, Flag
from ..record import Record
from ..refine import MISFIT_RATIO, held_out_events, noise_bar, own_rms
from ..results import RecordResult
from .determinacy import heldout_spread


def output_unit(rec: Record) -> str:
    """The output's unit as a message writes it after a number (``" degC"``), or ``""``."""
    u = rec.units.get("output")
    return f" {u}" if u else ""


def fit_floor(fit: Fit, result: RecordResult) -> float:
    """The smallest RMS error any refinement reaches on the same identification data as
    ``fit`` (the same events): what the noise, coloured as it is, leaves when some
    structure of the table describes the response. A misfit is judged against it and the
    noise estimate together: the noise estimate alone reads slow (AR(1), 1/f) noise as
    misfit."""
    same = [own_rms(f) for f in result.fits if f.ok and f.is_refined and f.event == fit.event
            and tuple(f.events) == tuple(fit.events)]
    same = [r for r in same if math.isfinite(r)]
    return min(same) if same else math.nan


def validation_misfit(fit: Fit, result: RecordResult, floor: float) -> Flag | None:
    """The held-out RMS error (on the validation events; without them, on the events held
    out from the fit: the cross-validated error, so a model gets the same verdict whichever
    events identify) beyond :data:`MISFIT_RATIO` times what the data allow: the held-out
    events' noise, or the fit's own error on its identification data (its colour
    included), whichever is larger. A model right for its own event that does not carry
    to the others (an operating-point-dependent gain or dynamics, a drift). Beside the
    noise, the misfit is judged against what the model's own parameter uncertainty moves
    its held-out simulation by (:func:`pipeline.grading.determinacy.heldout_spread`): a
    model right within its intervals is not flagged for the long validation run an
    integrator's gain error grows over."""
    rec = result.record
    if result.validation_events:
        mse = fit.metrics.get("mse_validation", math.nan)
        held_out = scored = list(result.validation_events)
    else:
        mse = fit.metrics.get("mse_cross_validation", math.nan)
        own = set(fit.events or (fit.event,))
        held_out = [i for i in result.identification_events if i not in own]
        # the events its cross-validated error was scored on: a one-event model's, at
        # most MAX_FOLDS of the others (held_out_events); a joint model's folds each
        # hold out one of its own events
        scored = list(fit.events) if fit.events else held_out_events(
            result.identification_events, fit.event)
    held = [result.events[i] for i in held_out]
    noise = float(np.mean([e.noise for e in held])) if held else 0.0
    ref = max(noise_bar(fit, held) / MISFIT_RATIO, floor if math.isfinite(floor) else 0.0)
    if not math.isfinite(mse) or ref <= 0:
        return None
    ratio = math.sqrt(mse) / ref
    if ratio <= MISFIT_RATIO:
        return None
    # what the parameters' own uncertainty moves the held-out simulation by: a model
    # right within its intervals may miss a long validation run (an integrator's gain).
    # Cross-validated, the model of all its events stands for its folds' (theirs, from
    # fewer events, are no more certain: the allowance is not larger than it should be)
    spread = heldout_spread(fit, rec, result.events, scored)
    if spread is not None and not math.isfinite(spread):
        spread = None  # no finite covariance: no allowance (and no inf in results.json)
    if spread:
        ref = math.sqrt(ref * ref + spread * spread)
        ratio = math.sqrt(mse) / ref
        if ratio <= MISFIT_RATIO:
            return None
    unit = output_unit(rec)
    allow = "its own event and its parameters' uncertainty allow" if spread else \
        "its own event leaves"
    return Flag("validation_misfit", f"On the events it did not see the model misses the "
                f"data by {ratio:.1f} times what {allow} (RMS {math.sqrt(mse):.3g}{unit} against "
                f"{ref:.3g}): the plant does not behave the same way over the whole log (a "
                "gain or dynamics that change with the operating point, or a drift); trust it "
                "near the conditions it was identified at.",
                {"misfit_ratio": ratio, "rms": math.sqrt(mse), "noise": noise, "reference": ref,
                 **({"spread": spread} if spread is not None else {})})
