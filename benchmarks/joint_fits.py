"""The fits over all events of a long log (issue 14): each refinement's joint fit with its
cross-validation, CPU, folds refitted exactly, and the parameters it found.

    python benchmarks/joint_fits.py LOG.csv [--rows N] [--structures first_order,...]
                                    [--rows-per-event K]

``LOG.csv`` is a ``time,u,y`` log (``benchmarks/scale.py --keep DIR`` writes them; their
plant is first order, K 2, T an eighth of a window, dead time 3 samples); ``--rows`` reads
its first N rows only. The events are segmented, the graphical methods run on event 0
(their models are the joint fits' starts, as in :func:`pipeline.analyse` with every event
identifying), then :func:`pipeline.refine.span_fit` with cross-validation runs for each
structure. ``--rows-per-event`` sets :data:`pipeline.refine.joint.ROWS_PER_EVENT` (0: the 600
rows of a one-event fit, the behaviour before it existed) to compare in one run.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

STRUCTURES = ("first_order", "two_lags", "second_order", "zero_two_lags", "lead_lag",
              "n_lags")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("log", type=Path)
    ap.add_argument("--rows", type=int, default=None)
    ap.add_argument("--structures", default=",".join(STRUCTURES))
    ap.add_argument("--rows-per-event", type=int, default=None)
    a = ap.parse_args()

    import polars as pl

    import pipeline.refine.joint as joint
    from pipeline.analysis import AnalysisOptions, _event_fits
    from pipeline.methods import REGISTRY
    from pipeline.record import make_record
    from pipeline.refine.event import event_states
    from pipeline.segmentation.detect import segment

    if a.rows_per_event is not None:
        joint.ROWS_PER_EVENT = a.rows_per_event
    df = pl.read_csv(a.log, n_rows=a.rows)
    rec = make_record(*(df[k].to_numpy() for k in ("time", "u", "y")), name=a.log.stem,
                      source=str(a.log))
    events = segment(rec)
    states = event_states(rec, events)
    ident = list(range(len(events)))
    graphical = tuple(m for m in REGISTRY if REGISTRY[m].kind != "refinement")
    models = [f.model for f in _event_fits(rec, events, 0, [], states,
                                           AnalysisOptions(events="all", methods=graphical))
              if f.ok]
    print(f"{rec.n_samples:,} samples, {len(events)} events; rows per event "
          f"{joint.ROWS_PER_EVENT}")
    total = 0.0
    for structure in a.structures.split(","):
        cpu = time.process_time()
        fit = joint.span_fit(rec, events, ident, f"lsq_{structure}", structure,
                             models=models, states=states, cross_validation=True)
        cpu = time.process_time() - cpu
        total += cpu
        folds = fit.diagnostics.get("folds", [])
        exact = sum(f["refit"] == "exact" for f in folds)
        params = ({k: round(v, 4) for k, v in fit.model.params.items()} if fit.model
                  else fit.reason)
        print(f"  {structure:14s} {fit.status:7s} {cpu:7.1f} s CPU, {exact}/{len(folds)} "
              f"folds refitted exactly, {params}", flush=True)
    print(f"  all: {total:.1f} s CPU")


if __name__ == "__main__":
    main()
