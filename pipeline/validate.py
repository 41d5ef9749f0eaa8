"""Validation: simulate a model where it was not identified and score it (DESIGN.md).

The model starts at rest at the operating point ``(u0, y0)`` of the data it is simulated
on, the measured input drives it (seed 001: "x(0) = y0"), and:

* ``ise`` - integral of the squared error over the identification event window (seed 002
  eq. 25), with ``mse_identification`` over the same samples;
* ``mse_validation`` - mean squared error (seed 001's J) over all validation samples; each
  contiguous run of validation events is simulated from the operating point before its
  first event;
* ``fit_percent`` - MATLAB ``compare``'s NRMSE fit over the validation samples.
"""

from __future__ import annotations

import numpy as np

from .events import Event
from .metrics import fit_percent, ise, mse
from .models import ProcessModel
from .record import Record
from .simulate import simulate


def event_simulation(model: ProcessModel, record: Record, ev: Event) -> np.ndarray:
    """Model output over the event window, started at rest at the event's (u0, y0)."""
    sl = slice(ev.i_start, ev.i_end)
    return simulate(model, record.t[sl], record.u[sl], ev.u0, ev.y0)


def validation_runs(events: list[Event], validation: list[int]) -> list[tuple[int, int, Event]]:
    """Contiguous runs of validation events as ``(i_start, i_end, first_event)``."""
    runs: list[tuple[int, int, Event]] = []
    for i in sorted(validation):
        ev = events[i]
        if runs and runs[-1][1] == ev.i_start:
            runs[-1] = (runs[-1][0], ev.i_end, runs[-1][2])
        else:
            runs.append((ev.i_start, ev.i_end, ev))
    return runs


def validation_simulation(model: ProcessModel, record: Record, events: list[Event],
                          validation: list[int]) -> list[tuple[slice, np.ndarray]]:
    """``(samples, simulated output)`` for each contiguous validation run."""
    out = []
    for a, b, first in validation_runs(events, validation):
        sl = slice(a, b)
        out.append((sl, simulate(model, record.t[sl], record.u[sl], first.u0, first.y0)))
    return out


def score(model: ProcessModel, record: Record, events: list[Event], ident: Event,
          validation: list[int]) -> dict[str, float]:
    """The metrics of one model (see the module docstring); NaN where there is no data."""
    sl = slice(ident.i_start, ident.i_end)
    y_id = record.y[sl]
    sim_id = event_simulation(model, record, ident)
    metrics = {
        "ise": ise(record.t[sl], y_id, sim_id),
        "mse_identification": mse(y_id, sim_id),
        "mse_validation": float("nan"),
        "fit_percent": float("nan"),
    }
    sims = validation_simulation(model, record, events, validation)
    if sims:
        y_val = np.concatenate([record.y[s] for s, _ in sims])
        y_hat = np.concatenate([v for _, v in sims])
        metrics["mse_validation"] = mse(y_val, y_hat)
        metrics["fit_percent"] = fit_percent(y_val, y_hat)
    return metrics
