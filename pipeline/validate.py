"""Validation: simulate a model where it was not identified and score it (DESIGN.md).

* ``ise`` - integral of the squared error over the identification event window (seed 002
  eq. 25), with ``mse_identification`` over the same samples; the model starts at rest at
  the event's operating point ``(u0, y0)`` (seed 001: "x(0) = y0"), as the graphical
  methods assume (:func:`event_simulation`; an integrating model on the baseline's line,
  its drift going on, as the integrating methods read it);
* ``mse_validation`` - mean squared error (seed 001's J) over all validation samples, and
  ``fit_percent``, MATLAB ``compare``'s NRMSE fit over them.

Validation is simulated *continuously*: the model starts at rest at the operating point of
the record's first event, at the first sample of the record, and the measured input drives
it through everything before the validation events, so the state it has at a validation
event is the one the measured input gave it, not an assumed rest. For each contiguous run of
validation events the offset is then estimated on a short warm-up before the run's first
step (:func:`warmup`; for an integrating structure the drift too, which is what an unknown
input balance point does to it), and only the validation samples after it are scored
(MATLAB ``compare`` with ``InitialCondition`` estimated plays the same role; Ljung, System
Identification, 2nd ed., sec. 16.6). A plant that is still moving when a validation step
comes is no longer scored on a false start from rest.

An integrating model stands still only at its input balance point, which the first event's
input level need not be (a motor that already turns): it starts on the steady ramp its
balance point gives (:func:`ramp_before`: ``K (u0 - u_balance)`` with a refinement's
fitted balance point, :attr:`pipeline.fit.Fit.balance_point`; else the drift segmentation
measured), its lag at equilibrium, so a ramp running before the first step is the model's,
not a drift the warm-up has to extrapolate (and a lag started at rest off its balance would add a
start-up transient that the warm-up's drift fit would extrapolate over the whole run).
"""

from __future__ import annotations

import numpy as np

from .events import Event
from .metrics import fit_percent_of_errors, ise, mse
from .models import ProcessModel
from .record import Record
from .simulation import forced_response, memory
from .uncertainty import variance_factor


def simulate(model: ProcessModel, record: Record, sl: slice, u0: float, y0: float
             ) -> np.ndarray:
    """The model from rest at ``(u0, y0)`` over the samples ``sl`` of the record
    (:func:`pipeline.simulation.simulate`, through the forced response with the record's
    sample time: no check of the grid on every call, no filter cache)."""
    t, u = record.t[sl], record.u[sl]
    if t.size < 2:
        return np.full(t.size, float(y0))
    x = forced_response(model.structure, dict(model.params), t, u, record.sample_time,
                        u0=float(u0))
    x *= model.K  # in place: forced_response returns a fresh array
    x += float(y0)
    return x


def event_simulation(model: ProcessModel, record: Record, ev: Event) -> np.ndarray:
    """Model output over the event window, started at rest at the event's (u0, y0); an
    integrating model's on the baseline's line (``y0 + drift (t - t0)``: the ramp before
    the step goes on, as the integrating methods read the response against it)."""
    sl = slice(ev.i_start, ev.i_end)
    sim = simulate(model, record, sl, ev.u0, ev.y0)
    return sim + ev.drift * (record.t[sl] - ev.t0) if model.integrating else sim


def ramp_before(model: ProcessModel, first: Event, balance: float | None = None) -> float:
    """The output's slope before the first event under the model: for an integrating
    model ``K (u0 - balance)`` with its balance point given, else the first event's
    measured drift; 0 for a self-regulating model (at rest)."""
    if not model.integrating:
        return 0.0
    return model.K * (first.u0 - balance) if balance is not None else first.drift


def validation_runs(events: list[Event], validation: list[int]) -> list[tuple[int, int, Event]]:
    """Contiguous runs of validation events as ``(i_start, i_end, first_event)``."""
    runs: list[tuple[int, int, Event]] = []
    for i in sorted(set(validation)):  # once each: runs are corrected in place later
        ev = events[i]
        if runs and runs[-1][1] == ev.i_start:
            runs[-1] = (runs[-1][0], ev.i_end, runs[-1][2])
        else:
            runs.append((ev.i_start, ev.i_end, ev))
    return runs


def continuous_simulation(model: ProcessModel, record: Record, events: list[Event],
                          stop: int | None = None, balance: float | None = None,
                          needed: int = 0) -> np.ndarray:
    """The model driven by the measured input from the first sample of the record (to
    ``stop``), at rest at the operating point of the first event (an integrating model on
    the steady ramp of its balance point, :func:`ramp_before`).

    ``needed``: the first sample the caller reads. A self-regulating model forgets its
    input after :func:`pipeline.simulation.memory` samples (its pulse response is below
    1e-17 of its gain), so it is simulated from that many samples before ``needed``
    only, from rest at the same operating point: the samples from ``needed`` on are the
    same to rounding, and a validation run late in a long record costs its own length,
    not the record's (the entries before ``needed`` are then not computed: NaN)."""
    start, sim = _simulated(model, record, events, stop, balance, needed)
    return np.concatenate([np.full(start, np.nan), sim]) if start else sim


def _late_start(model: ProcessModel, record: Record, events: list[Event],
                balance: float | None) -> int | None:
    """The samples a simulation may start before the first one it needs
    (:func:`continuous_simulation`), or None when it must start at the record's start
    (an integrating model on a ramp, an irregular grid, a model without finite memory)."""
    if ramp_before(model, events[0], balance) or record.sample_time is None:
        return None
    return memory(model, record.sample_time)


def _simulated(model: ProcessModel, record: Record, events: list[Event],
               stop: int | None, balance: float | None, needed: int) -> tuple[int, np.ndarray]:
    """``(start, simulated output on [start, stop))`` of :func:`continuous_simulation`."""
    stop = record.n_samples if stop is None else stop
    first = events[0]
    slope = ramp_before(model, first, balance)
    start = 0
    mem = _late_start(model, record, events, balance) if needed > 0 else None
    if mem is not None:
        start = max(0, min(needed, stop) - mem)
    sim = simulate(model, record, slice(start, stop), first.u0, first.y0)
    return start, (sim + slope * (record.t[start:stop] - first.t0) if slope else sim)


def warmup_correction(model: ProcessModel, t: np.ndarray, error: np.ndarray,
                      t_after: np.ndarray) -> np.ndarray | float:
    """The correction to add to a simulation after a warm-up with simulation error
    ``error`` (measured - simulated) at times ``t``: its mean, and for an integrating
    structure its linear drift extrapolated to ``t_after`` where the drift is beyond three
    standard errors (an input balance point off by that much; extrapolating a drift that
    is only noise would add noise to every later sample). Zero without a warm-up. A
    constant correction is a number, not a run-long array of it."""
    if error.size == 0:
        return 0.0
    if model.spec.integrating and error.size >= 4:
        tw = t - t[0]
        (slope, icpt), res, *_ = np.polyfit(tw, error, 1, full=True)
        s2 = float(res[0]) / (error.size - 2) if res.size else 0.0
        se = np.sqrt(s2 / max(float(np.sum((tw - tw.mean()) ** 2)), 1e-300))
        if abs(slope) > 3 * se:
            return icpt + slope * (t_after - t[0])
    return float(np.mean(error))


#: The warm-up before a validation step: this share of the previous event's window (at
#: least the settled baseline segmentation found before the step).
WARMUP_FRACTION = 0.25


def warmup(events: list[Event], first: Event) -> slice:
    """Samples on which the offset before a validation run is estimated: the last
    :data:`WARMUP_FRACTION` of the previous event's window, at least the event's baseline
    ``[i_base, i_start)`` (all of it before the first event of a record)."""
    a = first.i_base
    if first.index > 0:
        prev = events[first.index - 1]
        a = min(a, first.i_start - int(WARMUP_FRACTION * (first.i_start - prev.i_start)))
    return slice(max(a, 0), first.i_start)


def validation_simulation(model: ProcessModel, record: Record, events: list[Event],
                          validation: list[int], balance: float | None = None
                          ) -> list[tuple[slice, np.ndarray]]:
    """``(samples, simulated output)`` for each contiguous validation run (see the module
    docstring: continuous simulation, offset estimated on the warm-up before each run).

    Runs further apart than the model's memory are simulated separately, each from its
    memory before its warm-up (:func:`continuous_simulation`: the same samples to
    rounding), so validating on a few events spread over a long record costs their
    length, not the record's."""
    runs = validation_runs(events, validation)
    if not runs:
        return []
    warmups = [warmup(events, first) for _, _, first in runs]
    needed = [min(w.start, a) for w, (a, _, _) in zip(warmups, runs, strict=True)]
    mem = _late_start(model, record, events, balance)
    groups: list[list[int]] = []
    for k in range(len(runs)):
        if groups and (mem is None or needed[k] - mem <= runs[groups[-1][-1]][1]):
            groups[-1].append(k)
        else:
            groups.append([k])
    out = []
    for group in groups:
        start, sim = _simulated(model, record, events, runs[group[-1]][1], balance,
                                needed=min(needed[k] for k in group))
        corrections = []
        for k in group:  # every warm-up read before any run is corrected in place
            (a, b, _), w = runs[k], warmups[k]
            ws = slice(w.start - start, w.stop - start)
            corrections.append(warmup_correction(model, record.t[w], record.y[w] - sim[ws],
                                                 record.t[a:b]))
        for k, corr in zip(group, corrections, strict=True):
            a, b, _ = runs[k]
            v = sim[a - start: b - start]
            v += corr  # in place: a record-long copy less (views of one simulation)
            out.append((slice(a, b), v))
    return out


def heldout_residuals(model: ProcessModel, record: Record, events: list[Event],
                      heldout: list[int], balance: float | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """``(sample indices, measured - simulated)`` over the held-out events, simulated as
    validation (:func:`validation_simulation`)."""
    return run_errors(validation_simulation(model, record, events, heldout, balance), record)


def run_errors(sims: list[tuple[slice, np.ndarray] | None], record: Record
               ) -> tuple[np.ndarray, np.ndarray]:
    """``(sample indices, measured - simulated)`` of the simulated runs ``sims``, in their
    order, filled run by run: no concatenated copies of record-long arrays. Empties
    ``sims`` as it goes (each entry set to None once copied), so a simulation is freed
    once its last run is copied (the runs of one simulated stretch are views of it), not
    kept beside all the errors."""
    if not sims:
        return np.empty(0, int), np.empty(0)
    n = sum(s.stop - s.start for s, _ in sims)
    idx = np.empty(n, np.int32 if record.n_samples < 2**31 else np.int64)
    e = np.empty(n)
    k = 0
    for j in range(len(sims)):
        (s, v), sims[j] = sims[j], None
        m = s.stop - s.start
        idx[k: k + m] = np.arange(s.start, s.stop, dtype=idx.dtype)
        np.subtract(record.y[s], v, out=e[k: k + m])
        k += m
    return idx, e


def score(model: ProcessModel, record: Record, events: list[Event], ident: Event,
          validation: list[int], balance: float | None = None,
          heldout: tuple[np.ndarray, np.ndarray] | None = None) -> dict[str, float]:
    """The metrics of one model (see the module docstring; ``balance``: an integrating
    refinement's balance point, :attr:`pipeline.fit.Fit.balance_point`); NaN where there is
    no data. ``heldout``: :func:`heldout_residuals` on ``validation``, when the caller
    has them already."""
    sl = slice(ident.i_start, ident.i_end)
    y_id = record.y[sl]
    sim_id = event_simulation(model, record, ident)
    metrics = {
        "ise": ise(record.t[sl], y_id, sim_id),
        "mse_identification": mse(y_id, sim_id),
        "mse_validation": float("nan"),
        "fit_percent": float("nan"),
    }
    idx, e = heldout if heldout is not None else heldout_residuals(
        model, record, events, validation, balance)
    if idx.size:
        metrics["mse_validation"] = float(np.mean(e * e))  # mse(e, 0 * e): the same number
        metrics["fit_percent"] = fit_percent_of_errors(record.y[idx], e)
    return metrics


def identification_residuals(fit, record: Record, ev: Event) -> tuple[float, int, float]:
    """``(sum of squared errors, samples, variance factor)`` of a one-event fit over its
    event's baseline (:func:`fit_start`) and window: a refinement's own fit (its offset
    and initial state estimated), a graphical model simulated from rest at the event's
    (u0, y0) as the method assumes. The variance factor is the residuals' ``n / n_eff``
    (:func:`pipeline.uncertainty.variance_factor`)."""
    r = fit.refinement
    if r is not None:
        return r.sse, r.n_fit, r.variance_factor
    sl = slice(fit_start(ev.i_base, ev.i_start, ev.i_end), ev.i_end)
    e = record.y[sl] - simulate(fit.model, record, sl, ev.u0, ev.y0)
    return float(e @ e), int(e.size), variance_factor(e)


def fit_start(i_base: int, i_start: int, i_end: int) -> int:
    """First sample of an event's identification data: the baseline before the step, at
    most as long as the window after it (enough to pin the offset and show a drift)."""
    return max(i_base, i_start - (i_end - i_start))
