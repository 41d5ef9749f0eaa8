"""One record, analysed: segment, identify on the chosen events, validate on the others,
grade every fit.

:func:`analyse` is pure (a :class:`~pipeline.record.Record` and :class:`AnalysisOptions`
in, a :class:`~pipeline.results.RecordResult` out) and is the only analysis path: the
``identify`` and ``run`` commands, the batch workers and the Python API all call it, so
they give the same fits for the same record and options.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from .events import EventData
from .fit import Fit
from .grade import grade
from .methods import identify, select_methods
from .record import Record
from .results import RecordResult
from .segment import SegmentOptions, segment
from .validate import score

#: An event window with fewer samples after t0 gives no model (never a silent bad one).
MIN_WINDOW_SAMPLES = 10


@dataclass(frozen=True)
class AnalysisOptions:
    """What to do with a record (the config's segmentation, identification and methods).

    ``events``: the identification events (indices, or "all"); the others validate.
    ``methods``: "all" (every method for each event's kind) or a list of ids.
    """

    segmentation: SegmentOptions = field(default_factory=SegmentOptions)
    events: tuple[int, ...] | str = (0,)
    methods: tuple[str, ...] | str = "all"


def analyse(record: Record, options: AnalysisOptions | None = None, *,
            name: str | None = None) -> RecordResult:
    """Segment, identify on the chosen events, validate on the others (pure).

    A record that cannot be analysed (no event, a missing identification event) comes
    back with ``error`` set; a method that does not apply gives a ``not_applicable`` fit.
    """
    opt = options or AnalysisOptions()
    base = RecordResult(name=name or record.name, source=record.source, record=record)
    events = segment(record, opt.segmentation)
    if not events:
        return replace(base, error=f"{record.source}: no step or impulse event found in the "
                                   f"input {record.input_name!r}")
    base = replace(base, events=events)
    ident = (list(range(len(events))) if opt.events == "all" else sorted(set(opt.events)))
    if not ident:
        return replace(base, error=f"{record.source}: no identification event was chosen")
    missing = [i for i in ident if not 0 <= i < len(events)]
    if missing:
        return replace(base, error=(
            f"{record.source}: identification event {missing[0]} does not exist; the record "
            f"has {len(events)} event(s) (0..{len(events) - 1})"))
    validation = [e.index for e in events if e.index not in ident]
    roles = {e.index: ("identification" if e.index in ident else "validation") for e in events}
    fits: list[Fit] = []
    for i in ident:
        ev = events[i]
        data = EventData.from_event(record, ev)
        short = ev.i_end - ev.i_start < MIN_WINDOW_SAMPLES
        for mid in select_methods(opt.methods, ev.kind):
            if short:
                fits.append(Fit(mid, i, "not_applicable", f"window too short: "
                                f"{ev.i_end - ev.i_start} samples after t0, at least "
                                f"{MIN_WINDOW_SAMPLES} are needed"))
                continue
            fit = identify(data, mid)
            if fit.ok:
                fit = replace(fit, metrics=score(fit.model, record, events, ev, validation))
            fits.append(fit)
    return grade(replace(base, roles=roles, fits=fits))
