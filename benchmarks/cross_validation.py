"""Cross-validation folds by Gauss-Newton steps against exact refits (issue 14).

    python benchmarks/cross_validation.py [--samples 1000000] [--events 200]
                                          [--structures first_order,two_lags,...]

On the scale benchmark's staircase log (:func:`scale.write_log`, kept in the temporary
folder or ``--keep``), for each refinement structure: the joint fit over every event
(:func:`pipeline.refine.joint.refine_span`), then :func:`pipeline.refine.joint.cross_validate` (the
folds stepped from the joint optimum where they converge, :mod:`pipeline.refine.left_out`)
timed against exact refits of the same folds (``refine_span(..., exclude=fold)``,
polishing the joint model, the fallback's options), with the pooled held-out MSE of
each, the folds stepped, and the worst ratio of a stepped fold's criterion to the exact
refit's. CPU seconds of this process.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import scale  # noqa: E402

import pipeline  # noqa: E402
from pipeline.analysis import AnalysisOptions, _event_fits  # noqa: E402
from pipeline.methods import REGISTRY  # noqa: E402
from pipeline.refine import joint  # noqa: E402
from pipeline.refine.event import event_states, structure_state  # noqa: E402
from pipeline.refine.lstsq import solve  # noqa: E402
from pipeline.refine.problem import Problem  # noqa: E402
from pipeline.segmentation.detect import segment  # noqa: E402
from pipeline.validate import heldout_residuals  # noqa: E402

STRUCTURES = ("first_order", "second_order", "two_lags", "n_lags", "zero_two_lags",
              "lead_lag", "integrator", "integrator_lag")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--events", type=int, default=200)
    ap.add_argument("--structures", default=",".join(STRUCTURES))
    ap.add_argument("--keep", type=Path, default=None, help="folder for the log")
    a = ap.parse_args()
    folder = a.keep or Path(tempfile.mkdtemp())
    path = folder / f"scale_{a.samples}_{a.events}.csv"
    if not path.exists():
        scale.write_log(path, a.samples, a.events)
    rec = pipeline.load(path, input="u", output="y", time="time")
    opt = AnalysisOptions(events="all")
    events = segment(rec, opt.segmentation)
    states = event_states(rec, events)
    ident = list(range(len(events)))
    models = [f.model for f in _event_fits(rec, events, 0, [], states, opt) if f.ok]
    fold_opt = replace(opt.refine, n_starts=1, bootstrap=0, coarse=False)
    print(f"{a.samples:,} samples, {len(events)} events")
    print("| structure | folds stepped | steps (s) | exact refits (s) | held-out MSE, "
          "relative difference | worst stepped fold criterion / exact |")
    print("|---|---:|---:|---:|---:|---:|")
    for st in a.structures.split(","):
        mid = f"lsq_{st}"
        if mid not in REGISTRY:
            sys.exit(f"unknown structure {st!r}")
        ref, s = joint.refine_span(rec, events, ident, st, models=models, states=states,
                                   options=opt.refine)
        t0 = time.process_time()
        mse, folds = joint.cross_validate(rec, events, ident, ref.model, states=states,
                                          options=fold_opt)
        t1 = time.process_time()
        errors, ratios = [], []
        cost = _criterion(rec, events, ident, states, st, s,
                          joint.span_options(fold_opt, ident).max_rows)
        for f in folds:
            exact, _ = joint.refine_span(rec, events, ident, st, models=[ref.model],
                                         states=states, exclude=f["events"], options=fold_opt)
            u0 = exact.u0 if exact.model.integrating else None
            errors.append(heldout_residuals(exact.model, rec, list(events), f["events"],
                                            u0)[1])
            if f["refit"] == "gauss-newton":
                ratios.append(cost(f["params"], f["events"]) /
                              cost(exact.model.params, f["events"]))
        t2 = time.process_time()
        exact_mse = float(np.mean(np.concatenate(errors) ** 2))
        stepped = sum(f["refit"] == "gauss-newton" for f in folds)
        worst = f"{max(ratios):.6f}" if ratios else "-"
        print(f"| {st} | {stepped} of {len(folds)} | {t1 - t0:.2f} | {t2 - t1:.2f} | "
              f"{mse / exact_mse - 1:.1e} | {worst} |")


def _criterion(rec, events, ident, states, structure, s, rows):
    """The fold's criterion (sum of squared rows, gain and offset solved) at given
    parameters: the same rows as the refit's (``rows`` at most)."""
    sl = slice(s.start, s.stop)
    base = Problem.of(rec.t[sl], rec.u[sl], rec.y[sl], structure, u_ref=s.u_ref,
                      mask=s.mask, initial_state=structure_state(structure, s.state,
                                                                 events[ident[0]]),
                      free_lags=3, max_rows=rows)

    def cost(params, held):
        f = base.with_mask(joint.span(events, ident, states, exclude=held).mask,
                           rec.y[sl], rows)
        a = f.design_rows(params)
        r = f.y - a @ solve(a, f.y)[0]
        return float(r @ r)
    return cost


if __name__ == "__main__":
    main()
