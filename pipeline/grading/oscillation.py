"""A step response that rings and a model that does not (the ``oscillation_unmodelled``
flag, :data:`pipeline.grading.verdicts.FLAGS`): issue 27 item 6 (a response no structure
of the table represents says so) and issue 28 (a controller tuned from a model that
misses a lightly damped mode is never called robust)."""

from __future__ import annotations

import math
import weakref

import numpy as np

from ..fit import Fit, Flag
from ..methods import light_ring
from ..models import delayed_step
from ..record import in_time_unit
from ..results import RecordResult

#: A model overshooting less than this share of the oscillation the data show misses it.
MISSED_OVERSHOOT = 0.5


def oscillation_unmodelled(fit: Fit, result: RecordResult) -> Flag | None:
    """The record's step responses oscillate about their final value and the model's own
    step response does not (or overshoots less than :data:`MISSED_OVERSHOOT` of the
    largest oscillation read) and the ring is lightly damped (its valley/peak decay gives
    a damping ratio below :data:`pipeline.methods.second_order.LIGHT_DAMPING`): a lightly
    damped mode behind a lag, say, that no overdamped structure represents, whatever its
    fit error (a warning; a tuning from it is never "robust",
    :data:`pipeline.tuning.UNTRUSTED_FLAGS`). The oscillation is the
    one ``second_order_overshoot`` reads on any step event, with its significance tests (an
    overshoot of 3 and a valley of 2 noise sigmas, a rise that agrees with the period:
    :func:`pipeline.methods.second_order.check_oscillation`)."""
    if fit.model.integrating:
        return None
    reading = _ringing(result)
    if reading is None:
        return None
    seen = float(reading.diagnostics.get("overshoot", math.nan))
    ev = result.events[fit.event]
    t = np.linspace(0.0, max(ev.t_end - ev.t0, 1e-9), 2001)
    own = float(np.max(delayed_step(fit.model.spec, fit.model.params, t))) - 1.0
    if not (math.isfinite(seen) and seen > 0 and own < MISSED_OVERSHOOT * seen):
        return None
    if not light_ring(reading):
        return None
    rec = result.record
    period = float(reading.diagnostics.get("period", math.nan))
    unit = rec.units.get("time")
    shown = f"{in_time_unit(period, unit):.3g} {unit or 's'}"
    return Flag("oscillation_unmodelled", f"The step's response overshoots its final value "
                f"by {seen:.0%} of its change and comes back (a period of {shown}"
                f"), and this {fit.model.structure.replace('_', ' ')} model "
                + ("does not overshoot" if own <= 1e-6 else f"overshoots by {own:.0%}")
                + ": it misses a lightly damped mode, and a controller tuned from it knows "
                "nothing of the loop near that frequency.",
                {"overshoot": seen, "model_overshoot": max(own, 0.0), "period": period})


#: The last record :func:`_ringing` read (every fit of a record asks the same question).
_LAST_RINGING: list[tuple[weakref.ref, int, Fit | None]] = []


def _ringing(result: RecordResult) -> Fit | None:
    """``second_order_overshoot``'s reading with the largest overshoot over the record's
    step events (its own fits where the methods ran, else read here), or None when no
    step response oscillates above the noise."""
    rec = result.record
    if _LAST_RINGING and _LAST_RINGING[0][0]() is rec and \
            _LAST_RINGING[0][1] == len(result.events):
        return _LAST_RINGING[0][2]
    from ..events import EventData
    from ..methods import identify

    best = None
    for ev in result.events:
        if ev.kind != "step":
            continue
        reading = next((f for f in result.fits if f.method == "second_order_overshoot"
                        and f.event == ev.index and not f.events), None)
        if reading is None:
            reading = identify(EventData.from_event(rec, ev), "second_order_overshoot")
        if reading.ok and (best is None or reading.diagnostics.get("overshoot", 0.0)
                           > best.diagnostics.get("overshoot", 0.0)):
            best = reading
    _LAST_RINGING[:] = [(weakref.ref(rec), len(result.events), best)]
    return best
